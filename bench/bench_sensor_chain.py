"""What the sensor images cost per stereo frame (``render/sensor/outputs.py:
write_sensor_images``: the camera chain on the flat RGB, the raw and RGB PNGs, the JPEG, their
hashes), stage by stage, at the library scenes' own sizes, and what the lens blur's FFT at
fast lengths (``optics.apply_mtf``: the mirrored image padded to a length without a prime
factor above 7) saves against the FFT at the padded image's own size, with the change it
makes to the images.

    PYTHONPATH=. .venv/bin/python bench/bench_sensor_chain.py [--scenes city_kitti hall office sensors]
        [--rounds 5]

No Blender: the linear images are synthetic (a smooth gradient, edges and fine texture, mean
luminance near the auto-exposure's target), written as the frame's EXRs (``files.exr.write_exr``)
and run through ``write_sensor_images`` as a render does (frame 0, both views). CPU seconds
(``time.process_time``), the cheapest of ``--rounds`` rounds, the stage rows in turns.
``old FFT``: ``apply_mtf`` at the padded image's own size (the code before); ``changed``: of
the two views' raw images, the pixels whose DN differ between the two (``noisy``: the images
written; ``mean``: without noise, ``mean_dn``), and the largest difference of the optical
image relative to its peak.
"""
from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from blender_sesgen.files.exr import write_exr  # noqa: E402
from blender_sesgen.files.png import write_png  # noqa: E402
from blender_sesgen.render.plan import RenderOptions, RenderPlan  # noqa: E402
from blender_sesgen.render.sensor import optics, outputs, pipeline, raw  # noqa: E402

RGB = ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Combined.B", "ViewLayer.Combined.A"]


def apply_mtf_unpadded(rgb, margin: int = 16, **params):
    """``optics.apply_mtf`` before fast lengths: the FFT at the mirrored image's own size."""
    rgb = np.asarray(rgb, dtype=np.float64)
    H, W = rgb.shape[:2]
    m = int(min(margin, H - 1, W - 1))
    out = np.empty_like(rgb)
    for c in range(rgb.shape[2]):
        p = np.pad(rgb[..., c], m, mode="reflect")
        lam = params.get("wavelength_nm") or optics.WAVELENGTH_NM[c % 3]
        T = optics._stored_otf(p.shape, tuple(sorted({**params, "wavelength_nm": lam}.items())))
        out[..., c] = np.fft.irfft2(np.fft.rfft2(p) * T, s=p.shape)[m:m + H, m:m + W]
    return out


def mean_dn(img: np.ndarray, sensor, exposure_s: float, nominal_s: float, gain: float) -> np.ndarray:
    """The raw DN of an optical image without noise (``pipeline.process`` and ``raw.capture``
    with every noise left out: the mean signal, quantised): where a change of the optical
    image moves a pixel's DN by itself. (The noisy images cannot tell: the shot noise's
    Poisson draws take a varying count of random numbers, so a change in one pixel's signal
    shifts the noise of every pixel after it.)"""
    e = np.minimum(pipeline.photosite_signal(img, sensor, exposure_s, nominal_s), float(sensor.full_well_e))
    dn = np.rint(float(sensor.black_level_dn) + e * raw.conversion_gain(sensor.full_well_e, sensor.bits, gain))
    return np.clip(dn, 0, 2 ** int(sensor.bits) - 1)


def synthetic(h: int, w: int, seed: int) -> np.ndarray:
    """A linear RGB image with large areas, sharp edges and fine texture (mean luminance ~0.2)."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:h, 0:w] / max(h, w)
    base = 0.15 + 0.2 * u + 0.1 * np.sin(9 * v) ** 2
    blocks = (np.floor(u * 23) + np.floor(v * 17)) % 3 * 0.08
    tex = 0.05 * rng.random((h, w))
    img = (base + blocks + tex)[..., None] * np.array([1.0, 0.95, 0.85])
    return img.astype(np.float32)


def cpu(f, rounds: int) -> float:
    best = float("inf")
    for _ in range(rounds):
        c = time.process_time()
        f()
        best = min(best, time.process_time() - c)
    return best


def measure(scene: str, rounds: int) -> dict:
    plan = RenderPlan.from_file(str(REPO / "scenes" / f"{scene}.ses"), RenderOptions(resolution_scale=1.0))
    sp = plan.sensor
    if not sp.writes_sensor_images:
        raise SystemExit(f"{scene}: no SENSOR statement")
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-sensor-chain-"))
    try:
        lin = {v: synthetic(sp.height, sp.width, i) for i, v in enumerate(sp.views)}
        exrs = {}
        for v, img in lin.items():
            exrs[v] = tmp / f"{v}.exr"
            write_exr(exrs[v], {n: (img[..., i] if i < 3 else np.ones(img.shape[:2], np.float32))
                                for i, n in enumerate(RGB)})
        n = plan.scene.frames
        m = SimpleNamespace(channels={"rgb": RGB},
                            extra={"sensor": {k: [None] * n for k in outputs.STATE_KEYS}})
        outputs.make_folders(sp, tmp)
        exposure_s, gain = sp.exposures([])[0]
        rays = sp.pixel_rays()
        camera = pipeline.Camera(sp.sensor, sp.lens_spec, rays, sp.K[0, 2], sp.K[1, 2], sp.nominal_exposure_s())
        shots = [pipeline.Shot(exposure_s, gain, 0, i) for i in range(len(sp.views))]
        imgs = [lin[v].astype(np.float64) for v in sp.views]
        fpn: dict = {}

        def chain():
            return [pipeline.process(img, camera, shot, fpn_cache=fpn) for img, shot in zip(imgs, shots)]

        def optical():
            return [pipeline.optical_image(img, sp.lens_spec, sp.sensor, rays, sp.K[0, 2], sp.K[1, 2]) for img in imgs]
        frames = chain()

        def pngs():
            for i, f in enumerate(frames):
                write_png(tmp / f"raw{i}.png", f.raw_dn, outputs.PNG_LEVEL)
                write_png(tmp / f"rgb{i}.png", f.rgb8, outputs.PNG_LEVEL)

        def whole():
            outputs.write_sensor_images(sp, m, tmp, 0, exposure_s, gain, exrs)
        new = optics.apply_mtf
        rows = {"whole": [], "chain": [], "optics": [], "pngs": [], "whole old FFT": [], "optics old FFT": []}
        for _ in range(rounds):   # the rows in turns: the load hits each alike
            optics.apply_mtf = new
            rows["whole"].append(cpu(whole, 1))
            rows["chain"].append(cpu(chain, 1))
            rows["optics"].append(cpu(optical, 1))
            rows["pngs"].append(cpu(pngs, 1))
            optics.apply_mtf = apply_mtf_unpadded
            rows["whole old FFT"].append(cpu(whole, 1))
            rows["optics old FFT"].append(cpu(optical, 1))
        optics.apply_mtf = apply_mtf_unpadded
        old_frames, old_opt = chain(), optical()
        optics.apply_mtf = new
        new_opt = optical()
        rel = max(float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-30)) for a, b in zip(new_opt, old_opt))
        raw_changed = sum(int((a.raw_dn != b.raw_dn).sum()) for a, b in zip(frames, old_frames))
        dn = [mean_dn(x, sp.sensor, exposure_s, sp.nominal_exposure_s(), gain) for x in (*new_opt, *old_opt)]
        k = len(new_opt)
        mean_changed = sum(int((dn[i] != dn[k + i]).sum()) for i in range(k))
        H, W = sp.height, sp.width
        mm = min(16, H - 1, W - 1)
        return {"scene": scene, "size": f"{W}x{H}", "profile": getattr(sp.sensor, "profile", None) or "custom",
                "fft": f"{H + 2 * mm}x{W + 2 * mm}->{optics.fast_length(H + 2 * mm)}x{optics.fast_length(W + 2 * mm)}",
                **{k: min(v) for k, v in rows.items()}, "rel": rel, "raw_changed": raw_changed,
                "mean_changed": mean_changed, "pixels": H * W * len(sp.views)}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=["city_kitti", "hall", "office", "sensors"])
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args(argv)
    import os
    print(f"# sensor images per stereo frame (CPU s, cheapest of {a.rounds}); load {os.getloadavg()[0]:.1f}")
    print(f"{'scene':12s} {'size':>9s} {'profile':>8s} {'FFT grid':>22s} {'whole':>6s} {'chain':>6s} {'optics':>6s} "
          f"{'PNGs':>6s} | {'whole':>6s} {'optics':>6s} (old FFT) | changed DN: noisy mean of pixels; optics rel")
    for scene in a.scenes:
        r = measure(scene, a.rounds)
        print(f"{r['scene']:12s} {r['size']:>9s} {r['profile']:>8s} {r['fft']:>22s} {r['whole']:6.3f} {r['chain']:6.3f} "
              f"{r['optics']:6.3f} {r['pngs']:6.3f} | {r['whole old FFT']:6.3f} {r['optics old FFT']:6.3f}           | "
              f"{r['raw_changed']:6d} {r['mean_changed']:4d} of {r['pixels']}, {r['rel']:.1e}", flush=True)
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
