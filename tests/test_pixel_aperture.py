"""The pixel's aperture, measured on rendered slanted edges against closed forms.

A glowing wall behind a black sheet whose edge leans 5 degrees: every pixel's value is the
light its aperture gathers. The edge's Gaussian-equivalent spread (an a + b Phi(d / sigma)
fit across the edge) is compared with the same fit of the exact edge of the aperture at the
same pixel distances (each pixel: the share of its aperture's weight on the bright side):
- the sensor path (a TIMING shutter) renders the beauty through a box of one pixel, the
  photosite (at --resolution-scale 0.5 a binned pixel: still a box of one render pixel);
- the ideal camera keeps Blackman-Harris 1.5, which Cycles spans over +-1.5 px;
- the sensor images add the lens's defocus disc, whose diameter in render pixels halves at
  half size (the profile's binning);
- the ground truth stays point-sampled at the pixel centres whatever the beauty's filter.
Mutants that fail: the beauty without the box (0.42 px where the box's fit is 0.32), the
defocus not binned at half size (1.15 px where 0.61 is due).
"""
from __future__ import annotations

import json
from math import sqrt
from pathlib import Path

import numpy as np
import pytest

from markers import needs
from render_support import read_exr, render_here

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")
scipy_optimize = pytest.importorskip("scipy.optimize")
from scipy.special import erf  # noqa: E402

WALL_Z, LEAN = -3.0, np.radians(5.0)
CAM = (0.0, 1.0, 0.5)


def _script(shutter: bool, sensor: str = "") -> str:
    # the sheet's left edge passes through (0.05, 1) and leans by LEAN; 1 mm in front of the wall
    x_lo, x_hi = 0.05 - 2 * np.tan(LEAN), 0.05 + 2 * np.tan(LEAN)
    z = WALL_Z + 0.001
    lines = ["CAMERA resolution 96 64 focal 90 baseline 0", f"START position {CAM[0]} {CAM[1]} {CAM[2]}",
             "WORLD colour 0 0 0", "RENDER samples 256 denoise off",
             "MATERIAL name glow colour 0 0 0 emission 1 1 1 emission_strength 1 roughness 1 specular 0",
             "MATERIAL name ink colour 0 0 0 roughness 1 specular 0",
             f"QUAD id 1 material glow vertices -3 -1 {WALL_Z}  3 -1 {WALL_Z}  3 3 {WALL_Z}  -3 3 {WALL_Z}",
             f"QUAD id 2 material ink vertices {x_lo} -1 {z}  3 -1 {z}  3 3 {z}  {x_hi} 3 {z}",
             "EGO 0 0 0 0 0 0"]
    if shutter:
        lines.append("TIMING rate 10 exposure 0.001")
    if sensor:
        lines.append(sensor)
    return "\n".join(lines) + "\n"


def _render(tmp: Path, name: str, text: str, scale: float) -> tuple[Path, dict]:
    (tmp / f"{name}.ses").write_text(text)
    out = render_here(tmp / f"{name}.ses", tmp / name, "--quiet", "--frames", "0:1", "--resolution-scale", str(scale))
    return out, json.loads((out / "manifest.json").read_text())


def _edge_px(m: dict) -> tuple[np.ndarray, np.ndarray]:
    """A point on the edge and its unit normal in pixels (the camera looks down -z, unrotated)."""
    K = np.asarray(m["K"] if "K" in m else m["intrinsics"]["K"], float)

    def project(x, y):
        xc, yc, zc = x - CAM[0], -(y - CAM[1]), CAM[2] - (WALL_Z + 0.001)
        return np.array([K[0, 0] * xc / zc + K[0, 2], K[1, 1] * yc / zc + K[1, 2]])
    a, b = project(0.05, 1.0), project(0.05 + np.tan(LEAN), 2.0)
    t = (b - a) / np.linalg.norm(b - a)
    return a, np.array([-t[1], t[0]])


def _fit_sigma(d: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """(sigma, offset) of a + b Phi((d - o) / sigma) fitted to values at distances d."""
    f = lambda x, a, b, o, s: a + b * 0.5 * (1 + erf((x - o) / (s * sqrt(2))))  # noqa: E731
    lo, hi = float(np.median(values[d < -2])), float(np.median(values[d > 2]))
    (a, b, o, s), _ = scipy_optimize.curve_fit(f, d, values, p0=(lo, hi - lo, 0.0, 0.5), maxfev=4000)
    return abs(float(s)), float(o)


def _distances(shape, m: dict) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (px) of every pixel centre within 4 px of the projected edge, rows 15-85 %."""
    H, W = shape
    p0, n = _edge_px(m)
    v, u = np.mgrid[0:H, 0:W].astype(float)
    d = (u - p0[0]) * n[0] + (v - p0[1]) * n[1]
    return d, (np.abs(d) <= 4) & (v > 0.15 * H) & (v < 0.85 * H)


def edge_sigma(img: np.ndarray, m: dict) -> float:
    """The rendered edge's Gaussian-equivalent spread (px)."""
    d, sel = _distances(img.shape, m)
    s, o = _fit_sigma(d[sel], img[sel])
    assert abs(o) < 0.5, f"the edge is not where it was projected (offset {o:.2f} px)"
    return s


def closed_form_sigma(shape, m: dict, aperture: str, defocus_px: float = 0.0) -> float:
    """The same fit on the exact edge of an aperture at the same pixel distances: each pixel's
    value is the share of its aperture's weight on the bright side. ``box``: the unit square;
    ``blackman_harris``: Cycles' separable window over +-1.5 px; ``defocus_px``: a uniform disc
    of that diameter convolved with it. (The fit of a box's linear ramp is 0.32 px, not its
    standard deviation 1/sqrt(12): the oracle is the fit of the closed form, not a sigma.)"""
    d, sel = _distances(shape, m)
    _, n = _edge_px(m)
    g = (np.arange(48) + 0.5) / 48 - 0.5
    if aperture == "box":
        x, y = np.meshgrid(g, g)
        w = np.ones_like(x)
    else:
        x, y = np.meshgrid(3 * g, 3 * g)
        bh = lambda t: (0.35875 - 0.48829 * np.cos(2 * np.pi * (t / 3 + 0.5)) + 0.14128 * np.cos(4 * np.pi * (t / 3 + 0.5))
                        - 0.01168 * np.cos(6 * np.pi * (t / 3 + 0.5)))  # noqa: E731
        w = bh(x) * bh(y)
    s, w = (x * n[0] + y * n[1]).ravel(), w.ravel()
    if defocus_px:
        r = defocus_px / 2
        dx, dy = np.meshgrid(r * 2 * g, r * 2 * g)
        inside = dx ** 2 + dy ** 2 <= r * r
        s = (s[:, None] + (dx[inside] * n[0] + dy[inside] * n[1])[None, :]).ravel()
        w = np.repeat(w, inside.sum())
    order = np.argsort(s)
    cdf = np.cumsum(w[order]) / w.sum()
    esf = np.interp(d[sel], s[order], cdf)      # the weight on the bright side of a pixel at d
    return _fit_sigma(d[sel], esf)[0]


def _grey(exr: dict) -> np.ndarray:
    return (0.2126 * exr["ViewLayer.Combined.R"] + 0.7152 * exr["ViewLayer.Combined.G"]
            + 0.0722 * exr["ViewLayer.Combined.B"]).astype(np.float64)


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_the_sensor_path_integrates_each_pixel_over_a_box_and_the_ideal_camera_over_blackman_harris(tmp_path, scale):
    box_out, box_m = _render(tmp_path, "box", _script(shutter=True), scale)
    bh_out, bh_m = _render(tmp_path, "bh", _script(shutter=False), scale)
    box = read_exr(box_out / box_m["files"]["left"][0])
    bh = read_exr(bh_out / bh_m["files"]["left"][0])
    shape = _grey(box).shape
    assert edge_sigma(_grey(box), box_m) == pytest.approx(closed_form_sigma(shape, box_m, "box"), abs=0.02)
    assert edge_sigma(_grey(bh), bh_m) == pytest.approx(closed_form_sigma(shape, bh_m, "blackman_harris"), abs=0.02)
    # the ground truth is point-sampled at the pixel centres with either filter: the same bytes
    for name in box:
        if ".Depth." in name or ".Object Index." in name:
            assert np.array_equal(box[name], bh[name]), name


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_the_sensor_images_add_the_lens_defocus_to_the_box_binned_at_half_size(tmp_path, scale):
    """A profile-like sensor 96 px native: the defocus disc of 4 native px is 4 * scale render
    px; no noise to speak of (a huge full well, 16 bits, linear response; the glow far below saturation)."""
    sensor = "SENSOR native 96 fullwell 1e9 saturation 4 bits 16 response linear mono on\nLENS defocus 4"
    out, m = _render(tmp_path, "lens", _script(shutter=True, sensor=sensor), scale)
    import cv2
    img = cv2.imread(str(out / "sensor" / "left" / "rgb" / "000000.png"), cv2.IMREAD_GRAYSCALE).astype(float)
    assert edge_sigma(img, m) == pytest.approx(closed_form_sigma(img.shape, m, "box", 4.0 * scale), abs=0.03)
