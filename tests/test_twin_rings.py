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


def _noise(shape, seed):
    """A 1/f noise field (zero mean, unit deviation)."""
    rng = np.random.default_rng(seed)
    n = np.fft.irfft2(np.fft.rfft2(rng.normal(size=shape)) / np.maximum(
        np.hypot(*np.meshgrid(np.fft.rfftfreq(shape[1]), np.fft.fftfreq(shape[0]))), 1e-3), s=shape)
    return n / n.std()


def test_band_images_split_the_frames_contrast_power_by_ring():
    """The band images of a frame hold its contrast power (the frame over its mean, minus one)
    ring by ring: over the whole frame their mean squares sum to the frame's (Parseval, the
    rings 2-92 of 185 rows and what lies outside them apart), white noise puts its power in
    each band in proportion to the band's share of the frequency plane, and a frame of one
    fine grating (80 cycles per image height) has it in the top band alone."""
    H, W = 185, 613
    rng = np.random.default_rng(3)
    img = np.clip(128 + 12 * rng.normal(size=(H, W)), 0, 255)
    bands = twin.band_images(img, ((0, 2), *twin.REGION_BANDS, (92, 1000)))
    a = img / img.mean() - 1
    assert np.isclose(sum(float(np.mean(b ** 2)) for b in bands), float(np.mean(a ** 2)), rtol=0.05)
    y = np.arange(H)[:, None] * np.ones((1, W))
    grating = 128 + 40 * np.sin(2 * np.pi * 80 * y / H)
    p = [float(np.mean(b ** 2)) for b in twin.band_images(grating)]
    assert p[-1] > 0.97 * sum(p) and np.isclose(p[-1], 0.5 * (40 / 128) ** 2, rtol=0.03), p


def test_band_power_by_region_finds_the_region_that_lacks_fine_contrast(shared_data, tmp_path, monkeypatch):
    """A render whose frames are KITTI's own (area-resampled) with object ids of one kind each
    third of the width: the KITTI / render ratio is ~1 in every band for every region but the
    one whose pixels were blurred (a Gaussian of 1 px: the fine contrast gone), where it is far
    above 1 in the top band and ~1 in the lowest; the render's shares name the regions."""
    import json
    import cv2
    H, W = 185, 613
    full = [twin.kitti_marked_frame(k) for k in twin.KITTI_REGIONS]
    imgs = [cv2.resize(f, (W, H), interpolation=cv2.INTER_AREA) for f in full]
    ids = np.zeros((H, W), np.int32)
    ids[:, : W // 3], ids[:, W // 3: 2 * W // 3], ids[:, 2 * W // 3:] = 1, 2, 3
    (tmp_path / "manifest.json").write_text(json.dumps({"objects": [
        {"id": 1, "class": "terrain"}, {"id": 2, "class": "road"}, {"id": 3, "class": "building"}]}))

    class Ids:
        def ids(self, k, view="left"):
            return ids
    monkeypatch.setattr(twin, "open_sequence", lambda out: Ids())
    soft = [np.where(ids == 3, cv2.GaussianBlur(i, (0, 0), 1.0), i) for i in imgs]
    real = twin.Frames(imgs, imgs, np.eye(3), 0.5)
    same, _ = twin.band_power_by_region(tmp_path, real, twin.Frames(imgs, imgs, np.eye(3), 0.5), 3)
    blur, shares = twin.band_power_by_region(tmp_path, real, twin.Frames(soft, soft, np.eye(3), 0.5), 3)
    parse = lambda s: {w.split()[0]: [float(x) for x in w.split()[1].split("/")]  # noqa: E731
                       for w in s.split(") ", 1)[1].split(", ")}
    # the same frames: the whole frame's ratio 1 in every band
    assert np.allclose(parse(same)["frame"], 1.0), same
    got = parse(blur)
    assert got["facade"][-1] > 3 * got["facade"][0] and got["facade"][-1] > 3, blur
    assert got["frame"][-1] > 1.3 and abs(got["frame"][0] - 1) < 0.1, blur
    assert "facade" in shares and "road" in shares, shares


def test_band_power_by_cell_localises_the_missing_fine_contrast():
    """KITTI's frames against copies blurred in their lower right ninth only: the top band's
    ratio is 1 in eight ninths and far above 1 in that one."""
    import cv2
    H, W = 185, 613
    imgs = [cv2.resize(twin.kitti_marked_frame(k), (W, H), interpolation=cv2.INTER_AREA) for k in twin.KITTI_REGIONS]
    soft = []
    for i in imgs:
        s = i.copy()
        s[2 * H // 3:, 2 * W // 3:] = cv2.GaussianBlur(i, (0, 0), 1.0)[2 * H // 3:, 2 * W // 3:]
        soft.append(s)
    ratio, _ = twin.band_power_by_cell(_frames(imgs), _frames(soft), 3)
    cells = [float(x) for row in ratio.split(" | ") for x in row.split()]
    assert cells[-1] > 3 and all(abs(c - 1) < 0.1 for c in cells[:-1]), ratio
