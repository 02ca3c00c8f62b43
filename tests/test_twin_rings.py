"""bench/twin.py's ring-power line (where a spectrum slope's gap lies), on synthetic frames."""
from __future__ import annotations

import importlib.util
from pathlib import Path

import cv2
import numpy as np

_spec = importlib.util.spec_from_file_location("twin_bench", Path(__file__).resolve().parents[1] / "bench" / "twin.py")
twin = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(twin)


def _frames(imgs):
    K = np.array([[350.0, 0, 306], [0, 350.0, 92], [0, 0, 1]])
    return twin.Frames(imgs, imgs, K, 0.54)


def test_ring_power_ratio_finds_the_missing_fine_contrast():
    """A frame against itself: 1 in every band; against a copy blurred by a Gaussian of 1 px
    (the fine contrast gone, the large-scale kept): ~1 in the lowest band, far above 1 in the
    top band, rising with frequency as the Gaussian's squared MTF falls; a copy with twice the
    contrast about the same mean: 0.25 in every band; a copy 0.7 x as bright (the same contrast
    over its mean): 1 in every band (power over the mean squared)."""
    rng = np.random.default_rng(1)
    noise = np.fft.irfft2(np.fft.rfft2(rng.normal(size=(185, 613))) / np.maximum(
        np.hypot(*np.meshgrid(np.fft.rfftfreq(613), np.fft.fftfreq(185))), 1e-3))
    img = np.clip(128 + 20 * noise / noise.std(), 0, 255).astype(np.uint8)
    real = _frames([img] * 2)
    parse = lambda s: [float(x.split(": ")[1]) for x in s.split(", ")]  # noqa: E731
    assert parse(twin.ring_power_ratio(real, _frames([img] * 2), 2)) == [1.0] * 7
    blurred = parse(twin.ring_power_ratio(real, _frames([cv2.GaussianBlur(img, (0, 0), 1.0)] * 2), 2))
    assert abs(blurred[0] - 1) < 0.1 and blurred[-1] > 5 and np.all(np.diff(blurred[1:]) > 0), blurred
    strong = np.clip(128 + 2 * (img.astype(float) - img.mean()) + (img.mean() - 128), 0, 255).astype(np.uint8)
    doubled = parse(twin.ring_power_ratio(real, _frames([strong] * 2), 2))
    assert np.allclose(doubled, 0.25, atol=0.03), doubled
    dimmer = parse(twin.ring_power_ratio(real, _frames([np.round(0.7 * img).astype(np.uint8)] * 2), 2))
    assert np.allclose(dimmer, 1.0, atol=0.05), dimmer


def test_street_kinds_and_kitti_street_marks(shared_data):
    """The render's street surfaces by asset kind (the flush sidewalk strip is the parking bay),
    and KITTI sequence_1's hand-marked street regions lying on what they name: in each marked
    frame the sunlit asphalt is darker than the light kerb top, gutter and sidewalk and brighter
    than the lawn, the dark block-paved bay in between (frame 12: 1.45 x the road, the kerb tops
    and the gutter 2.3-2.4 x)."""
    kind = lambda k, h=0.13: twin._street_kind({"kind": k, "size": [2.5, h, 320]})  # noqa: E731
    assert [kind("road"), kind("kerb"), kind("sidewalk"), kind("sidewalk", 0.01), kind("verge"), kind("car")] == \
        ["road", "kerb", "sidewalk", "bay", "lawn", None]
    for k, regions in twin.KITTI_STREET.items():
        L = twin._linear(twin.kitti_marked_frame(k), "kitti")
        med = {name: float(np.median(L[y0:y1, x0:x1])) for name, (x0, y0, x1, y1) in regions.items()}
        road = med.pop("road")
        assert med.pop("lawn") < road, (k, road)
        bay = med.pop("bay", None)
        assert bay is None or 1.2 * road < bay < 0.8 * min(med.values()), (k, road, bay, med)
        assert all(v > 1.8 * road for v in med.values()), (k, road, med)
