"""Disparity ground truth: d = fx·B/Z, formats and round trips."""
from __future__ import annotations

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.io.sequence import open_sequence
from synthetic_render import plane_depth, write_render
from vo_reference.groundtruth.disparity import (
    disparity_color, disparity_from_depth, disparity_to_png16, read_disparity, read_disparity_png16,
    sequence_disparity, write_disparity, write_disparity_color, write_disparity_png16)

pytest.importorskip("OpenEXR")


@pytest.fixture
def slanted_plane(tmp_path):
    """A slanted plane (depth varies across the image) with sky in the top rows."""
    W, H, f, B = 40, 30, 35.0, 0.25
    K = np.array([[f, 0, 19.5], [0, f, 14.5], [0, 0, 1]])
    n = np.array([0.3, -0.2, 1.0])
    n /= np.linalg.norm(n)
    frames = []
    for view, x in (("left", 0.0), ("right", B)):
        T = np.eye(4)
        T[0, 3] = x
        z = plane_depth(K, T, n, 3.0, W, H).astype(np.float32)
        z[:3] = np.inf
        frames.append((view, (np.full((H, W, 3), 0.5, np.float32), z, np.ones((H, W), np.int32))))
    root = write_render(tmp_path / "r", K=K, baseline_m=B, T_world_left=np.eye(4)[None], frames=[dict(frames)])
    return open_sequence(root), f, B


def test_disparity_is_fx_b_over_z_exactly(slanted_plane):
    seq, f, B = slanted_plane
    for view in ("left", "right"):
        z = seq.depth(0, view)
        d = sequence_disparity(seq, 0, view)
        assert d.dtype == np.float32
        assert np.all(np.isnan(d[:3])) and np.all(np.isfinite(d[3:]))
        want = (np.float64(f) * B / z[3:].astype(np.float64)).astype(np.float32)
        assert np.array_equal(d[3:], want)


def test_left_disparity_points_to_the_same_surface_in_the_right_view(slanted_plane):
    """x_right = x_left - d: the right depth there equals the left depth (parallel rig)."""
    seq, f, B = slanted_plane
    d, zl, zr = sequence_disparity(seq, 0, "left"), seq.depth(0, "left"), seq.depth(0, "right")
    ys, xs = np.nonzero(np.isfinite(d))
    xr = xs - d[ys, xs]
    inside = (xr >= 0) & (xr <= zl.shape[1] - 1)
    x0 = np.floor(xr[inside]).astype(int)
    a = xr[inside] - x0
    inv = (1 - a) / zr[ys[inside], x0] + a / zr[ys[inside], np.minimum(x0 + 1, zl.shape[1] - 1)]
    assert np.allclose(1 / inv, zl[ys[inside], xs[inside]], rtol=1e-5)


def test_png16_round_trip_within_1_256(tmp_path):
    rng = np.random.default_rng(3)
    d = rng.uniform(0, 250, (20, 30)).astype(np.float32)
    d[0, :5] = np.nan
    p = write_disparity_png16(tmp_path / "d.png", d)
    import cv2
    raw = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    assert raw.dtype == np.uint16 and raw.ndim == 2
    assert np.all(raw[0, :5] == 0) and np.all(raw[1:] > 0)
    assert np.array_equal(raw[1:], np.rint(d[1:].astype(np.float64) * 256).astype(np.uint16))
    back = read_disparity_png16(p)
    assert np.all(np.isnan(back[0, :5]))
    ok = np.isfinite(d)
    assert np.abs(back[ok] - d[ok]).max() <= 1 / 256


def test_png16_tiny_and_huge_values():
    v = disparity_to_png16(np.array([[1e-6, 300.0, 0.0, np.inf, 255.99, 256.0]]))
    # a tiny valid d never becomes 'invalid'; one the 16 bits cannot hold is invalid, never 255.996
    assert v.tolist() == [[1, 0, 1, 0, 65533, 0]]


@pytest.mark.parametrize("ext", [".pfm", ".exr", ".npy"])
def test_float_formats_round_trip_exactly(tmp_path, ext):
    rng = np.random.default_rng(4)
    d = rng.uniform(0, 100, (7, 9)).astype(np.float32)
    d[2, 3] = np.nan
    back = read_disparity(write_disparity(tmp_path / f"d{ext}", d))
    assert back.dtype == np.float32 and back.shape == d.shape
    assert np.array_equal(np.isnan(back), np.isnan(d))
    assert np.array_equal(back[~np.isnan(d)], d[~np.isnan(d)])


def test_pfm_is_middlebury_layout(tmp_path):
    """Header 'Pf', W H, negative scale (little endian), bottom row first, inf = invalid."""
    d = np.array([[1, 2, 3], [4, 5, np.nan]], np.float32)
    raw = (write_disparity(tmp_path / "d.pfm", d)).read_bytes()
    assert raw.startswith(b"Pf\n3 2\n-1.0\n")
    data = np.frombuffer(raw[len(b"Pf\n3 2\n-1.0\n"):], "<f4")
    assert data[:2].tolist() == [4, 5] and np.isposinf(data[2]) and data[3:].tolist() == [1, 2, 3]


def test_colour_visualisation(tmp_path):
    import cv2
    d = np.tile(np.linspace(1, 50, 16, dtype=np.float32), (8, 1))
    d[0, 0] = np.nan
    rgb = disparity_color(d)
    assert rgb.dtype == np.uint8 and rgb.shape == (8, 16, 3) and rgb[0, 0].tolist() == [0, 0, 0]
    assert len({tuple(c) for c in rgb[4]}) > 8
    img = cv2.imread(str(write_disparity_color(tmp_path / "c.png", d)))
    assert np.array_equal(img[..., ::-1], rgb)


def test_errors(tmp_path):
    with pytest.raises(VoError, match="unknown disparity format"):
        write_disparity(tmp_path / "d.txt", np.zeros((2, 2)))
    with pytest.raises(VoError, match="no such"):
        read_disparity(tmp_path / "none.pfm")
    (tmp_path / "bad.pfm").write_bytes(b"P6\n1 1\n255\n...")
    with pytest.raises(VoError, match="not a PFM"):
        read_disparity(tmp_path / "bad.pfm")
    assert np.isnan(disparity_from_depth(np.array([[np.inf, 0.0]]), 100, 0.1)).all()
