"""Re-measure the camera profiles (blender_sesgen/scene/camera_profiles.py) from the real frames in
../shared/data and print each measured number beside the profile's value.

    python bench/camera_profiles.py [--camera kitti,euroc,robotcar] [--still]

Measured per camera (docs/sensors.md, "Camera profiles", says how each number enters a profile):
- **noise by level**: Immerkær's estimator (CVIU 1996: sigma = sqrt(pi/2) / 6 * mean |I * N|,
  N the 3x3 Laplacian difference) on flat pixels (Sobel magnitude below 2 DN, away from
  clipping) per 16-DN brightness bin, minus the 8-bit quantisation noise (1/12 DN^2);
- **response exponent and full well**: the noise-level function of a gamma-g camera is
  sigma_Y^2 = (255 / g)^2 x^(2/g - 1) (x / FW + (r / FW)^2) with x = Y_n^g the linear signal;
  g, the full well FW (electrons at full scale, at the gain the camera ran at) and the read
  noise r are the least-squares fit over the bins (g on a 0.05 grid in 1..2.8); bins above
  1.15x the lower monotone envelope (texture that passed the flatness test: only adds
  variance) are left out;
- **sharpness**: straight edges (Canny + probabilistic Hough, 24 px or longer (14 on the RobotCar green plane), at least 40 DN
  of contrast, not clipped): pixels within 6 px are projected on the edge normal and an edge
  a + b * Phi(d / s) fitted; the median s over edges with R^2 > 0.98 is the camera's Gaussian-
  equivalent edge spread (MTF50 = sqrt(ln 2 / 2) / (pi s) cycles/px);
- **clipping and black level**: the share of pixels at 255 and at the darkest level, the
  0.01th percentile (the black level);
- **vignetting**: the column means of all frames (rows 20-80 %), fitted with
  a * cos(theta)^(4 v) over the horizontal ray angle (f from the calibration);
- **metering**: the median over the frames of the mean of the pixels linearised with the fitted
  exponent (the mean linear signal, the target a scene-following auto-exposure holds);
- **frame rate**: the median step of the excerpt's time stamps (EuRoC data.csv, RobotCar
  stereo.timestamps; KITTI's excerpt has none);
- **temporal noise** (``--still``: EuRoC, whose MAV stands for all 95 frames of the excerpt; KITTI's
  car and RobotCar's drive): photon transfer from still frame pairs, per camera. Each pixel's
  temporal variance is the mean over the consecutive pairs of (difference - the pair's median
  difference)^2 / 2 (the median takes out the lights' flicker and the auto-exposure's creep; a
  difference of consecutive frames, not of each frame from the mean, leaves slow drifts out);
  pixels where the mean frame is flat (gradient below 1 DN/px: a 0.1 px shake moves them by
  under 0.1 DN) and never at 0 or 255, binned by their mean level (8 DN); the median variance of
  a bin (texture that moves and flickering lamps only add: the median keeps them out) against
  the level is fitted with a line, var = K (level - black) + (K r)^2 + 1/12, K the conversion
  gain (DN per electron, so the full well at full scale is 255 / K) and r the read noise in
  electrons at the black level above. The same on the frames binned 2 x 2 (their float mean)
  checks the binning of docs/sensors.md: independent pixels have a quarter of the variance.
  Immerkær's estimator on flat pixels (above) counts fine texture and fixed pattern as noise:
  it gave the euroc profile twice the temporal variance.
RobotCar frames are raw Bayer GBRG: noise and edges are measured on the first green plane
(half size, so its noise is per sensor pixel) and the edge spread is doubled back to sensor
pixels.
"""
from __future__ import annotations

import argparse
import os
import warnings
import sys
from math import log, pi, sqrt
from pathlib import Path

import cv2
import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit
from scipy.special import erf

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("SESGEN_SHARED_DATA", REPO.parent / "shared" / "data"))

_N = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], dtype=np.float64)


def frames(camera: str) -> tuple[list[np.ndarray], float]:
    """The real 8-bit frames of ``camera`` and the focal length in their pixels."""
    if camera == "kitti":
        root = DATA / "kitti" / "sequence_1"
        files = sorted((root / "image_l").glob("*.png")) + sorted((root / "image_r").glob("*.png"))
        focal_px = float((root / "calib.txt").read_text().split()[0])
        return [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files], focal_px
    if camera == "euroc":
        root = DATA / "euroc" / "mav0"
        files = sorted((root / "cam0" / "data").glob("*.png")) + sorted((root / "cam1" / "data").glob("*.png"))
        return [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in files], 458.654
    if camera == "robotcar":
        root = DATA / "robotcar"
        focal_px = float((root / "models" / "stereo_wide_left.txt").read_text().split()[0])
        files = sorted((root / "stereo_centre_bayer").glob("*.png"))
        # GBRG: the first green plane is (even row, even column)
        return [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE)[0::2, 0::2] for f in files], focal_px / 2
    raise SystemExit(f"unknown camera {camera!r} (kitti, euroc, robotcar)")


def noise_by_level(imgs, bin_dn: int = 16, flat_dn: float = 2.0):
    """[(level DN, sigma DN, pixels)] of flat pixels per brightness bin (Immerkær)."""
    sums, counts = {}, {}
    for img in imgs:
        f = img.astype(np.float64)
        lap = np.abs(cv2.filter2D(f, -1, _N, borderType=cv2.BORDER_REFLECT))[1:-1, 1:-1]
        gx, gy = cv2.Sobel(f, -1, 1, 0, ksize=3) / 8, cv2.Sobel(f, -1, 0, 1, ksize=3) / 8
        grad = np.hypot(gx, gy)[1:-1, 1:-1]
        level = cv2.blur(f, (3, 3))[1:-1, 1:-1]
        mx = cv2.dilate(f, np.ones((3, 3)))[1:-1, 1:-1]
        mn = cv2.erode(f, np.ones((3, 3)))[1:-1, 1:-1]
        ok = (grad < flat_dn) & (mx < 255) & (mn > 0)
        b = (level[ok] // bin_dn).astype(int)
        for k in np.unique(b):
            sel = b == k
            sums[k] = sums.get(k, 0.0) + lap[ok][sel].sum()
            counts[k] = counts.get(k, 0) + int(sel.sum())
    out = []
    for k in sorted(counts):
        if counts[k] >= 2000:
            sigma = sqrt(pi / 2) / 6 * sums[k] / counts[k]
            out.append(((k + 0.5) * bin_dn, sqrt(max(sigma ** 2 - 1 / 12, 0.0)), counts[k]))
    return out


def fit_response(nlf, black_dn: float):
    """(gamma, full well e-, read noise e-, rms residual DN) of the noise-level function."""
    Y = np.array([lv for lv, _, _ in nlf])
    s = np.array([sg for _, sg, _ in nlf])
    # texture only adds variance: keep the bins near the lower monotone envelope
    keep = s <= 1.15 * np.minimum.accumulate(s[::-1])[::-1]
    Y, s = Y[keep], s[keep]
    span = 255.0 - black_dn
    yn = np.clip((Y - black_dn) / span, 1e-3, 1.0)
    best = None
    for g in np.arange(1.0, 2.81, 0.05):
        x = yn ** g
        # sigma_x^2 = x / FW + (r / FW)^2, sigma_x = sigma_Y * g * x^(1 - 1/g) / span
        sx2 = (s * g * x ** (1 - 1 / g) / span) ** 2
        A = np.stack([x, np.ones_like(x)], axis=1)
        (a, c), *_ = np.linalg.lstsq(A, sx2, rcond=None)
        if a <= 0:
            continue
        c = max(c, 0.0)
        pred = np.sqrt((a * x + c)) * span / (g * x ** (1 - 1 / g))
        rms = float(np.sqrt(np.mean((pred - s) ** 2)))
        if best is None or rms < best[3]:
            fw = 1.0 / a
            best = (float(g), fw, sqrt(c) * fw, rms)
    return best


def _phi(z):
    return 0.5 * (1 + erf(z / sqrt(2)))


def edge_spread(imgs, max_edges: int = 400, min_len: int = 24):
    """(median Gaussian-equivalent edge spread in px, edges used)."""
    spreads = []
    for img in imgs:
        f = img.astype(np.float64)
        lines = cv2.HoughLinesP(cv2.Canny(img, 60, 150), 1, np.pi / 360, min_len, minLineLength=min_len, maxLineGap=1)
        if lines is None:
            continue
        H, W = img.shape
        for x0, y0, x1, y1 in lines[:, 0, :]:
            t = np.array([x1 - x0, y1 - y0], float)
            L = np.linalg.norm(t)
            t /= L
            n = np.array([-t[1], t[0]])
            xs, ys = np.meshgrid(np.arange(max(min(x0, x1) - 7, 0), min(max(x0, x1) + 8, W)),
                                 np.arange(max(min(y0, y1) - 7, 0), min(max(y0, y1) + 8, H)))
            rel = np.stack([xs - x0, ys - y0], -1).astype(float)
            d, along = rel @ n, rel @ t
            sel = (np.abs(d) <= 6) & (along >= 2) & (along <= L - 2)
            v, d = f[ys[sel], xs[sel]], d[sel]
            if v.size < 60 or v.max() >= 255 or v.min() <= 0:
                continue
            lo, hi = np.median(v[d < -3]) if (d < -3).any() else 0, np.median(v[d > 3]) if (d > 3).any() else 0
            if abs(hi - lo) < 40:
                continue
            try:
                (a, b, off, sg), _ = curve_fit(lambda x, a, b, o, s: a + b * _phi((x - o) / s), d, v,
                                               p0=(lo, hi - lo, 0.0, 1.0), maxfev=2000)
            except RuntimeError:
                continue
            res = np.sum((a + b * _phi((d - off) / sg) - v) ** 2)
            if 1 - res / np.sum((v - v.mean()) ** 2) > 0.98 and 0.2 < abs(sg) < 4 and abs(off) < 1.5:
                spreads.append(abs(sg))
            if len(spreads) >= max_edges:
                return float(np.median(spreads)), len(spreads)
    return (float(np.median(spreads)) if spreads else float("nan")), len(spreads)


def vignetting(imgs, focal_px: float) -> float:
    """The exponent v of cos(theta)^(4 v) fitted to the mean column profile."""
    H, W = imgs[0].shape
    prof = np.mean([im[int(0.2 * H):int(0.8 * H)].astype(np.float64).mean(0) for im in imgs], 0)
    theta = np.arctan((np.arange(W) + 0.5 - W / 2) / focal_px)
    lc = np.log(np.cos(theta))
    ok = prof > 5
    A = np.stack([np.ones(ok.sum()), 4 * lc[ok]], 1)
    (_, v), *_ = np.linalg.lstsq(A, np.log(prof[ok]), rcond=None)
    return float(v)


def frame_rate_hz(camera: str) -> float:
    """The median frame rate of the excerpt's time stamps (nan where it has none: KITTI's)."""
    if camera == "euroc":
        rows = (DATA / "euroc" / "mav0" / "cam0" / "data.csv").read_text().splitlines()
        t = np.array([float(r.split(",")[0]) * 1e-9 for r in rows if r and not r.startswith("#")])
    elif camera == "robotcar":
        rows = (DATA / "robotcar" / "stereo_centre_bayer" / "stereo.timestamps").read_text().split("\n")
        t = np.array([float(r.split()[0]) * 1e-6 for r in rows if r.strip()])
    else:
        return float("nan")
    return float(1.0 / np.median(np.diff(t)))


def still_frames(camera: str) -> dict[str, np.ndarray]:
    """{view: (N, H, W) uint8} of an excerpt whose camera stands still (EuRoC's); {} for the others."""
    if camera != "euroc":
        return {}
    root = DATA / "euroc" / "mav0"
    return {c: np.stack([cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in sorted((root / c / "data").glob("*.png"))])
            for c in ("cam0", "cam1")}


def temporal_noise(stack: np.ndarray, bin_dn: float = 8.0, flat_dn: float = 1.0, min_px: int = 200):
    """Photon transfer of still frames ``stack`` (N, H, W): [(level DN, temporal variance DN^2,
    pixels)] per bin of the mean level (the module docstring, "temporal noise")."""
    mean = np.mean(stack, axis=0, dtype=np.float64)
    gy, gx = np.gradient(mean)
    var = np.zeros_like(mean)
    for f0, f1 in zip(stack[:-1], stack[1:]):       # a pair at a time: the stack's memory only
        d = f1.astype(np.float64) - f0
        d -= np.median(d)
        var += d * d
    var /= 2 * (len(stack) - 1)
    ok = (np.hypot(gx, gy) < flat_dn) & (np.max(stack, axis=0) < 255) & (np.min(stack, axis=0) > 0)
    out = []
    for lo in np.arange(0.0, 255.0, bin_dn):
        sel = ok & (mean >= lo) & (mean < lo + bin_dn)
        if sel.sum() >= min_px:
            out.append((float(lo + bin_dn / 2), float(np.median(var[sel])), int(sel.sum())))
    return out


def fit_photon_transfer(ptc, black_dn: float, quantisation_dn2: float = 1 / 12):
    """(K DN/e-, full well e- at 255 DN, read noise e- at ``black_dn``) of the line
    var = K (level - black) + (K r)^2 + quantisation, fitted with weights sqrt(pixels)."""
    lv, v, n = (np.array(c, dtype=np.float64) for c in zip(*ptc))
    w = np.sqrt(n)
    (k, c), *_ = np.linalg.lstsq(np.stack([lv, np.ones_like(lv)], 1) * w[:, None], v * w, rcond=None)
    read_var_dn2 = c + k * black_dn - quantisation_dn2
    return float(k), 255.0 / float(k), float(np.sqrt(max(read_var_dn2, 0.0)) / k)


def measure(camera: str, spread_scale: float = 1.0) -> dict:
    imgs, focal_px = frames(camera)
    allpx = np.concatenate([im.ravel() for im in imgs])
    black = float(np.percentile(allpx, 0.01))
    nlf = noise_by_level(imgs)
    g, fw, rn, rms = fit_response(nlf, black)
    spread, n_edges = edge_spread(imgs, min_len=24 if spread_scale == 1 else 14)
    # what the auto-exposure holds: the mean of the linear signal (the mean of the linearised
    # pixels; linearising the mean DN instead gave KITTI 0.255 for 0.276)
    target = float(np.median([np.mean(np.clip((im.astype(np.float64) - black) / (255 - black), 0, 1) ** g)
                              for im in imgs]))
    return {"frames": len(imgs), "size": f"{imgs[0].shape[1]}x{imgs[0].shape[0]}", "black_dn": black,
            "clipped_255": float((allpx == 255).mean()), "at_black": float((allpx <= black).mean()),
            "nlf": nlf, "gamma": g, "full_well_e": fw, "read_noise_e": rn, "nlf_rms_dn": rms,
            "edge_spread_px": spread * spread_scale, "edges": n_edges,
            "mtf50": sqrt(log(2) / 2) / (pi * spread * spread_scale), "vignetting": vignetting(imgs, focal_px),
            "metered_target": target, "rate_hz": frame_rate_hz(camera)}


def main(argv=None) -> int:
    warnings.simplefilter("ignore", OptimizeWarning)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--camera", default="kitti,euroc,robotcar")
    ap.add_argument("--still", action="store_true",
                    help="only the temporal noise of the still excerpts (photon transfer; EuRoC)")
    args = ap.parse_args(argv)
    from blender_sesgen.scene.camera_profiles import PROFILES, black_8bit
    if not DATA.is_dir():
        print(f"no real data at {DATA} (set SESGEN_SHARED_DATA)", file=sys.stderr)
        return 2
    for cam in args.camera.split(","):
        if cam not in PROFILES or cam in ("tum", "phone"):
            print(f"unknown camera {cam!r} (kitti, euroc, robotcar)", file=sys.stderr)
            return 2
        if args.still:
            print_still(cam, PROFILES[cam])
            continue
        m = measure(cam, 2.0 if cam == "robotcar" else 1.0)
        p = PROFILES[cam]
        print(f"\n== {cam}: {m['frames']} frames {m['size']}")
        print("  noise by level (level DN: sigma DN [pixels]): " + ", ".join(
            f"{lv:.0f}: {sg:.2f} [{n}]" for lv, sg, n in m["nlf"]))
        rows = (("black level (DN of the 8-bit files)", m["black_dn"], black_8bit(p.sensor)),
                ("response exponent (gamma)", m["gamma"], p.sensor.get("gamma", 1.0)),
                ("full well (e-, Immerkaer; at its gain)", m["full_well_e"], p.sensor["fullwell"]),
                ("read noise (e-, Immerkaer)", m["read_noise_e"], p.sensor["readnoise"]),
                ("noise fit rms (DN)", m["nlf_rms_dn"], None),
                ("edge spread (px, Gaussian sigma)", m["edge_spread_px"], p.edge_spread_px),
                ("MTF50 (cycles/px)", m["mtf50"], None), ("edges used", m["edges"], None),
                ("vignetting exponent v", m["vignetting"], p.lens.get("vignetting", 0.0)),
                ("pixels at 255", m["clipped_255"], None), ("pixels at the black level", m["at_black"], None),
                ("metered mean (linear)", m["metered_target"], p.autoexposure.get("target")),
                ("frame rate (Hz, time stamps)", m["rate_hz"], p.timing.get("rate")))
        for name, meas, prof in rows:
            print(f"  {name:38s} measured {meas:10.4g}   profile {'' if prof is None else format(prof, '.4g')}")
        print_still(cam, p)
    return 0


def profile_variance_dn2(sensor: dict, level_dn, binning: int = 1) -> np.ndarray:
    """The temporal variance (DN^2) a profile's SENSOR tags give a pixel at ``level_dn`` of its
    8-bit output, binned ``binning`` x ``binning`` (camera_profiles.at_width; raw.py's model:
    shot + read noise, then the 8-bit quantisation of the output)."""
    if int(sensor.get("bits", 8)) != 8 or sensor.get("response", "linear") != "linear":
        raise ValueError("the photon-transfer line holds for a linear 8-bit output only")
    s = float(binning)
    k = 255.0 / (float(sensor["fullwell"]) * s * s)
    lv = np.asarray(level_dn, dtype=np.float64)
    return k * (lv - float(sensor.get("black", 0.0))) + (k * float(sensor.get("readnoise", 0.0)) * s) ** 2 + 1 / 12


def print_still(cam: str, p) -> None:
    """The temporal noise of ``cam``'s still excerpt beside the profile's (nothing if it has none)."""
    still = still_frames(cam)
    if not still:
        print(f"  temporal noise: no still frames in the {cam} excerpt (the camera moves)")
        return
    black = float(p.sensor.get("black", 0.0))
    for view, stack in still.items():
        n, h, w = stack.shape
        # no dark rows in the files: the photon-transfer line fixes K r^2 - black only, and the
        # darkest pixel's mean over the still frames bounds the black level from above
        print(f"  black level {view}: at most {np.mean(stack, axis=0, dtype=np.float64).min():.1f} DN "
              f"(the darkest pixel's mean over the {n} still frames; profile {black:g})")
        blocks = stack[:, :h // 2 * 2, :w // 2 * 2].reshape(n, h // 2, 2, w // 2, 2)
        half = blocks.sum(axis=(2, 4), dtype=np.uint16) / 4.0
        for label, ptc, b in (("full size", temporal_noise(stack), 1),
                              ("binned 2x2", temporal_noise(half, flat_dn=0.7), 2)):
            k, fw, rn = fit_photon_transfer(ptc, black, 1 / 12 / b ** 2)
            model = profile_variance_dn2(p.sensor, [lv for lv, _, _ in ptc], b) - 1 / 12 + 1 / 12 / b ** 2
            print(f"  temporal noise {view} {label} ({n} still frames; level DN: variance DN^2 measured / profile): "
                  + ", ".join(f"{lv:.0f}: {v:.2f} / {m:.2f}" for (lv, v, _), m in zip(ptc, model)))
            # per native pixel: a binned pixel holds b^2 pixels' electrons and b times the read noise
            print(f"    photon transfer: {k:.5f} DN/e-; per native pixel full well {fw / b ** 2:.0f} e-, read noise "
                  f"{rn / b:.1f} e- at black {black:g} DN (profile {p.sensor['fullwell']:g} e-, "
                  f"{p.sensor.get('readnoise', 0):g} e-)")


if __name__ == "__main__":
    raise SystemExit(main())
