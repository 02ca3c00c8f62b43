"""The rounded box's tessellation (pure): on the ideal surface, closed, outward, and its
volume approaches the closed-form volume of a box with rounded edges."""
from __future__ import annotations

import math

import numpy as np
import pytest

from blender_sesgen.scene.geometry.rounded_box import rounded_box


def _volume(V, faces) -> float:
    vol = 0.0
    for f in faces:
        for k in range(1, len(f) - 1):
            vol += np.dot(V[f[0]], np.cross(V[f[k]], V[f[k + 1]])) / 6.0
    return vol


@pytest.mark.parametrize("size, r, n", [((1.0, 0.6, 0.4), 0.05, 8), ((2.0, 2.0, 2.0), 1.0, 16), ((0.5, 1.5, 0.3), 0.15, 4)])
def test_rounded_box_is_the_minkowski_sum(size, r, n):
    V, faces, N = rounded_box(size, r, n)
    inner = np.asarray(size) / 2 - r
    # every vertex on the ideal surface, its normal the surface normal there
    dist = np.linalg.norm(V - np.clip(V, -inner, inner), axis=1)
    np.testing.assert_allclose(dist, r, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(N, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(V, np.clip(V, -inner, inner) + r * N, atol=1e-12)
    # closed two-manifold: every edge in exactly two faces, in opposite directions
    edges = {}
    for f in faces:
        for a, b in zip(f, f[1:] + f[:1]):
            edges[(a, b)] = edges.get((a, b), 0) + 1
    assert all(c == 1 for c in edges.values()) and all((b, a) in edges for a, b in edges)
    # outward: each face's normal agrees with its vertices' surface normals
    for f in faces:
        fn = np.cross(V[f[1]] - V[f[0]], V[f[2]] - V[f[0]])
        assert fn @ N[list(f)].mean(axis=0) > 0
    A, B, C = 2 * inner
    exact = A * B * C + 2 * r * (A * B + B * C + C * A) + math.pi * r * r * (A + B + C) + 4 / 3 * math.pi * r**3
    vol = _volume(V, faces)
    assert vol <= exact + 1e-12
    # chord error of a cell: along an edge one step, across a corner cell its diagonal (sqrt 2 steps)
    sag = r * (1 - math.cos(math.sqrt(2) * math.pi / 2 / n / 2))
    surface = 2 * (A * B + B * C + C * A) + 2 * math.pi * r * (A + B + C) + 4 * math.pi * r * r
    assert exact - vol <= sag * surface


def test_bevel_radius_bounds():
    with pytest.raises(ValueError):
        rounded_box((1, 1, 0.2), 0.11, 4)
