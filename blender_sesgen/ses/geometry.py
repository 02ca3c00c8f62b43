"""Geometric validity of QUAD vertices (the renderer triangulates a quad as 0-1-2 + 0-2-3).

Tolerances are relative to the quad's size (its longest edge ``L``):
- repeated vertex: two vertices closer than 1e-9·L (or all at one point);
- zero area: every corner's cross product below 1e-9·L² (all vertices collinear);
- non-coplanar: a vertex farther than 1e-4·L from the plane through the centroid
  normal to the best-conditioned corner;
- self-intersecting ("bow tie"): the vertices are not in order around the boundary.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

COPLANAR_REL_TOL = 1e-4
DEGENERATE_REL_TOL = 1e-9


def quad_problem(vertices) -> Optional[tuple[str, str]]:
    """None if the quad is fine, else (kind, message) with kind 'degenerate' or 'non-coplanar'."""
    P = np.asarray(vertices, dtype=float).reshape(4, 3)
    edges = np.roll(P, -1, axis=0) - P
    L = float(np.max(np.linalg.norm(P[:, None] - P[None], axis=-1)))
    if L == 0.0:
        return "degenerate", "QUAD vertices are all the same point"
    for a in range(4):
        for b in range(a + 1, 4):
            if np.linalg.norm(P[a] - P[b]) <= DEGENERATE_REL_TOL * L:
                return "degenerate", f"QUAD vertices {a + 1} and {b + 1} are the same point"
    # The plane's normal from the best-conditioned corner (robust even for a bow tie, whose
    # signed areas cancel): the largest of the four corner cross products.
    corners = [np.cross(P[(k + 1) % 4] - P[k], P[(k - 1) % 4] - P[k]) for k in range(4)]
    normal = max(corners, key=lambda c: float(np.linalg.norm(c)))
    if np.linalg.norm(normal) <= DEGENERATE_REL_TOL * L * L:
        return "degenerate", "QUAD has zero area (its vertices are collinear)"
    n = normal / np.linalg.norm(normal)
    centroid = P.mean(axis=0)
    dist = np.abs((P - centroid) @ n)
    worst = int(np.argmax(dist))
    if dist[worst] > COPLANAR_REL_TOL * L:
        return "non-coplanar", (f"QUAD vertices are not coplanar: vertex {worst + 1} is {dist[worst]:.4g} "
                                f"off their plane (tolerance {COPLANAR_REL_TOL * L:.2g})")
    turns = np.array([np.dot(np.cross(edges[k - 1], edges[k]), n) for k in range(4)])
    if np.sum(turns > 0) == 2 and np.sum(turns < 0) == 2:
        return "degenerate", "QUAD is self-intersecting: list its vertices in order around its boundary"
    return None
