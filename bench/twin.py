"""A camera twin beside the real camera: renders N frames of a library twin through its
camera profile and prints, in one run and at the same image size, the image and tracking
figures and three stereo VOs' errors on the render and on the real excerpt, with ratios.

    python bench/twin.py [--scene city] [--frames 45] [--scale 0.5] [--quality final] [--out out/twin]
                         [--no-render] [--start K] [--resensor] [--draws N]

Scenes: ``city`` = scenes/city_kitti.ses (``SENSOR profile kitti``) beside KITTI sequence_1
(../shared/data/kitti); ``hall`` = scenes/hall.ses (``SENSOR profile euroc``) beside the EuRoC
V1_01 excerpt (rectified with its sensor.yaml; it has no ground truth: image and tracking
figures only); both with their ``AUTOEXPOSURE`` (the script is written to OUT/<scene>_twin.ses). The real frames are
brought to the render's size with area averaging (cv2.INTER_AREA; K scaled like ``--resolution-scale``).
``--start K`` compares frames K..K+N-1 of both (renders those of the sequence; the
auto-exposure starts converged on frame 0 since session 20, as a camera long running, and
follows the scene from there); the city's later frames hold its
street's far part (KITTI sequence_1's frames 24-44: the side street, the block under works);
the metering pass still meters frames 0..K+N-1; the city's region and brightness lines (frames
from 0, KITTI's hand-marked frames) are left out.
``--draws N`` (default 9) develops the rendered EXRs N times through today's camera chain, draw
d with the sensor's noise seed + d (its fixed pattern and temporal noise), computes every
figure on each, and prints the render's median, the comparison's range over the draws and
each target judged on the median: one draw's VO ratios move with the noise (the OpenCV VO's
Sim(3) ratio 0.77-1.9 over ten draws of one render), and real KITTI is one draw of its own.

Figures (issue 28): power-spectrum slope, KLT forward-backward error (median), pixels at 0
or 255, SGBM valid share (vo_reference.evaluate.realism); per VO - the OpenCV KLT+SGBM+PnP VO
(``opencv-baseline``), an ORB-matching VO (below) and our ``accurate`` VO - translation RPE
(median over the steps, % of the true step), rotation RPE (median, deg/step; compare VO
against VO: KITTI's ground truth rotation noise is ~0.05 deg/frame), end-point drift and the
Sim(3)-aligned position RMSE (% of the path), each with its render/real ratio. Targets for
city vs KITTI sequence 1: translation RPE and Sim(3) error ratios 0.67-1.5, KLT error and
SGBM valid share within 25 %, clipped share within 2 points, slope within 0.2.

Causes (printed under the table): the **brightness spread** of both (median / mean of the
linear signal, the 8-bit images linearised with the profile's black level and response: a
mean-metering auto-exposure puts the sky at saturation only when the scene's median is
high enough relative to its mean), for city the brightness of each kind of surface, the real
frames' **ring power** over the render's per band of frequency (where the slope's gap lies) and the
**sunlit road's pixel-scale contrast** (``road_grain``), and, on the render (it has depth), the **SGBM error at
the OpenCV VO's corners** (Shi-Tomasi 1000/0.01/8, its detector): the share of corners on a
depth edge (the ground-truth disparity spans > 15 % in the 7 x 7 window) and the median
SGBM disparity error there and on smooth surfaces, in % of the true disparity. For city, the
VOs' causes (``vo_cause_lines``): each VO's steps off by more than 10 %, the ORB VO's inliers
(count, median depth) and the rig's rotation change between steps; the ORB VO's inliers nearer
than 20 m right and left by third of the steps and its broken steps' error along the drive
(``orb_near_lines``); the ORB VO taken apart on
both (``orb_kind_lines``: keypoints, matches, matches with depth, inliers, the share of matches
the true step confirms, the inliers' translation bound) and, on the render, its inliers by
object kind and its error with ORB kept off each kind (docs/sensors.md, "The VOs' errors, step
by step"); and each kind's pixel-scale contrast (``kinds_grain``: where the finest rings lack),
the contrast power by region and band (``band_power_by_region``: KITTI's hand-marked boxes, cars
included, against the render's regions by object id, and where the render's power sits) and the
top band's by ninth of the frame (``band_power_by_cell``: no region's choice). For hall, the
standing camera's KLT error at the render's own shake (``klt_at_shake``: EuRoC's error against
its shake, whose frames 30-49 are calm; docs/sensors.md, "The still camera's KLT, taken apart").
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from blender_sesgen.contract.camera import backproject, project, scaled_K
from blender_sesgen.contract.depth import depth_from_disparity
from blender_sesgen.contract.se3 import invert, rotation_angle_rad, se3
from vo_reference.io.base import Sequence
from vo_reference.io.sequence import open_sequence
from vo_reference.io.trajectory import Trajectory
from vo_reference.evaluate.realism import ring_power, sequence_stats, spectrum_slope
from vo_reference.evaluate.sgbm import sgbm_disparity
from vo_reference.stereo.pipeline import run_stereo_vo
from vo_reference.stereo.report import shape_errors

REPO = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("SESGEN_SHARED_DATA", REPO.parent / "shared" / "data"))
SCENES = {"city": ("scenes/city_kitti.ses", "kitti"), "hall": ("scenes/hall.ses", "euroc")}
VOS = ("opencv-baseline", "orb", "accurate")


class Frames(Sequence):
    """A stereo sequence held in memory (grey frames, K, baseline, poses or None);
    ``black_in_image``: the 8-bit frames hold the camera's black level (a real camera's files)."""

    def __init__(self, left, right, K, baseline_m, T_world_cam=None, timestamps_s=None, black_in_image=True):
        self.black_in_image = bool(black_in_image)
        self._img = {"left": list(left), "right": list(right)}
        self.K, self.baseline_m = np.asarray(K, float), float(baseline_m)
        self.num_frames = len(self._img["left"])
        H, W = self._img["left"][0].shape[:2]
        self.resolution, self.views = (W, H), ("left", "right")
        self._T = None if T_world_cam is None else np.asarray(T_world_cam)[: self.num_frames]
        self.timestamps_s = (np.arange(self.num_frames, dtype=float) if timestamps_s is None
                             else np.asarray(timestamps_s, float)[: self.num_frames])

    def image_gray(self, k, view="left"):
        return self._img[view][k]

    def image_rgb(self, k, view="left"):
        return cv2.cvtColor(self._img[view][k], cv2.COLOR_GRAY2RGB)

    def linear(self, k, profile: str) -> np.ndarray:
        """Frame k's left image as linear signal (``_linear``), its black level where it holds one."""
        return _linear(self.image_gray(k), profile, self.black_in_image)

    def T_world_cam(self, view="left"):
        return self._T


def resized(seq, n: int, size: tuple[int, int], start: int = 0) -> Frames:
    """Frames start..start+n-1 of ``seq`` at ``size`` (W, H), area-averaged, K scaled."""
    W0, H0 = seq.resolution
    imgs = {v: [cv2.resize(seq.image_gray(k, v), size, interpolation=cv2.INTER_AREA) if size != (W0, H0)
                else seq.image_gray(k, v) for k in range(start, start + n)] for v in ("left", "right")}
    T = seq.T_world_cam("left")
    return Frames(imgs["left"], imgs["right"], scaled_K(np.asarray(seq.K, float), W0, H0, *size), seq.baseline_m,
                  None if T is None else T[start:], np.asarray(seq.timestamps_s)[start:])


def euroc_rectified(n: int, size, start: int = 0) -> Frames:
    """Frames start..start+n-1 of the EuRoC excerpt rectified with its two sensor.yaml files (no poses)."""
    from realism import euroc_frames        # bench/realism.py, beside this script
    _, L, R = euroc_frames(start + n)
    L, R = L[start:], R[start:]
    if size != (L[0].shape[1], L[0].shape[0]):
        L = [cv2.resize(x, size, interpolation=cv2.INTER_AREA) for x in L]
        R = [cv2.resize(x, size, interpolation=cv2.INTER_AREA) for x in R]
    return Frames(L, R, np.eye(3), 0.11)     # K and baseline unused: no VO without ground truth


# --- an ORB-matching stereo VO --------------------------------------------------------------

class OrbStep:
    """One step of the ORB VO taken apart (``orb_steps``' ``funnel``): its keypoint and match
    counts, the matches with an SGBM depth (P: their points in camera k, m; q: their pixels in
    k+1) and the indices of PnP-RANSAC's inliers among them (empty when the step failed). A
    plain class: tests load this script by path, where a dataclass finds no module."""

    def __init__(self, keypoints: int, matches: int, P: np.ndarray, q: np.ndarray, inliers: np.ndarray):
        self.keypoints, self.matches, self.P, self.q, self.inliers = keypoints, matches, P, q, inliers


def orb_steps(seq: Frames, n: int, inliers: list | None = None, mask=None, funnel: list | None = None) -> list[np.ndarray]:
    """T_k_k1 per step: ORB (2000) matched k -> k+1 (Hamming, cross-check), SGBM depth at k,
    solvePnPRansac + LM refinement; a failed step keeps the previous motion. ``inliers``: a list
    that gets each step's (inlier count, their median depth in m; 0 and nan when it failed).
    ``mask``: frame k -> uint8 image where ORB may detect (None: everywhere; the causes'
    masking); ``funnel``: a list that gets each step's ``OrbStep``."""
    orb = cv2.ORB_create(2000)
    bf = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True)
    K, steps = seq.K, []
    where = (lambda k: None) if mask is None else mask
    for k in range(n - 1):
        a, b = seq.image_gray(k), seq.image_gray(k + 1)
        ka, da = orb.detectAndCompute(a, where(k))
        kb, db = orb.detectAndCompute(b, where(k + 1))
        T, used = (steps[-1] if steps else np.eye(4)), (0, float("nan"))
        rec = OrbStep(len(ka), 0, np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0, int))
        if da is not None and db is not None:
            m = bf.match(da, db)
            p0 = np.array([ka[x.queryIdx].pt for x in m]).reshape(-1, 2)
            p1 = np.array([kb[x.trainIdx].pt for x in m]).reshape(-1, 2)
            disp = sgbm_disparity(a, seq.image_gray(k, "right"))
            d = disp[np.rint(p0[:, 1]).astype(int), np.rint(p0[:, 0]).astype(int)]
            ok = d > 1.0
            P = backproject(K, p0[ok], depth_from_disparity(d[ok], K[0, 0], seq.baseline_m))
            rec = OrbStep(len(ka), len(m), P, p1[ok], np.zeros(0, int))
            if ok.sum() >= 6:
                okr, rvec, tvec, inl = cv2.solvePnPRansac(P, p1[ok], K, None, iterationsCount=200,
                                                          reprojectionError=1.0, confidence=0.999)
                if okr and inl is not None and len(inl) >= 6:
                    inl = inl.ravel()
                    rvec, tvec = cv2.solvePnPRefineLM(P[inl], p1[ok][inl], K, None, rvec, tvec)
                    T = invert(se3(cv2.Rodrigues(rvec)[0], tvec.ravel()))
                    used = (len(inl), float(np.median(P[inl, 2])))
                    rec.inliers = inl
        steps.append(T)
        if inliers is not None:
            inliers.append(used)
        if funnel is not None:
            funnel.append(rec)
    return steps


def vo_steps(seq: Frames, method: str, n: int, inliers: list | None = None) -> list[np.ndarray]:
    if method == "orb":
        return orb_steps(seq, n, inliers)
    res = run_stereo_vo(seq, method, frames=range(0, n))
    return [np.asarray(T) for T in _steps_of(res.trajectory.T_world_cam)]


def _steps_of(poses) -> list[np.ndarray]:
    return [invert(poses[k]) @ poses[k + 1] for k in range(len(poses) - 1)]


BAD_STEP_PCT = 10.0     # a step whose translation error exceeds this share of the true step: a broken step


def vo_errors(seq: Frames, method: str, n: int) -> dict:
    """Translation RPE (% of the true step), rotation RPE (deg/step), end-point drift and
    Sim(3) RMSE (% of the path) of one VO against the sequence's ground truth; and the
    causes' figures: the steps whose translation error exceeds ``BAD_STEP_PCT``, each step's
    translation (``steps_m``, camera k's frame) and rotation vector (``steps_rad``; both for
    ``gt_error_lines``) and, for the ORB VO, its
    inliers' count and median depth (median over the steps)."""
    T_gt = seq.T_world_cam("left")[:n]
    used = []
    est_steps = vo_steps(seq, method, n, used)
    poses = [T_gt[0]]
    for T in est_steps:
        poses.append(poses[-1] @ T)
    t_rpe, r_rpe = step_errors(T_gt, est_steps)
    ts = np.asarray(seq.timestamps_s, float)[:n]
    shape = shape_errors(Trajectory(np.asarray(T_gt), ts), Trajectory(np.asarray(poses), ts))
    out = {"t_rpe_pct": float(np.median(t_rpe)), "r_rpe_deg": float(np.median(r_rpe)),
           "drift_pct": shape["end_point_drift_pct"], "sim3_pct": shape.get("sim3_position_rmse_pct", np.nan),
           "bad_steps": int(np.sum(np.asarray(t_rpe) > BAD_STEP_PCT)),
           "steps_m": np.array([np.asarray(T, float)[:3, 3] for T in est_steps]),
           "steps_rad": np.array([cv2.Rodrigues(np.asarray(T, float)[:3, :3])[0].ravel() for T in est_steps])}
    if used:
        count, depth = np.array(used, float).T
        out.update(inliers=float(np.median(count)), inlier_depth_m=float(np.nanmedian(depth)))
    return out


def step_errors(T_gt, est_steps) -> tuple[np.ndarray, np.ndarray]:
    """Per step: translation error (% of the true step) and rotation error (deg) of the
    estimated steps T_k_k1 against the ground-truth poses T_world_cam."""
    t, r = [], []
    for Tg, Te in zip(_steps_of(np.asarray(T_gt)), est_steps):
        E = invert(Tg) @ Te
        t.append(100 * np.linalg.norm(E[:3, 3]) / max(np.linalg.norm(Tg[:3, 3]), 1e-9))
        # the angle through the quaternion: the arccos of the trace reads KITTI's 7-digit poses.txt
        # (|R R^T - I| up to 1.5e-7) as up to ~0.03 deg of rotation
        r.append(float(np.degrees(rotation_angle_rad(E[:3, :3]))))
    return np.array(t), np.array(r)


def rotation_change_deg(T_world_cam: np.ndarray, n: int) -> np.ndarray:
    """The rig's rotation change between consecutive steps (deg; n - 2 values): the angle of
    R(k, k+1) R(k-1, k)^T, what a constant-velocity prediction of step k misses."""
    T = np.asarray(T_world_cam)[:n]
    R = [(invert(T[k]) @ T[k + 1])[:3, :3] for k in range(len(T) - 1)]
    return np.degrees([rotation_angle_rad(R[k] @ R[k - 1].T) for k in range(1, len(R))])


# --- causes -------------------------------------------------------------------------------------

def _linear(img, profile: str, black_in_image: bool = True) -> np.ndarray:
    """An 8-bit grey frame through the inverse of the profile's response and, where the image
    holds it, its black level: the real camera's files (KITTI's darkest pixels are 6-8, EuRoC's
    ~13) and the render's sensor/rgb (the chain's 8-bit output keeps the black level)."""
    from blender_sesgen.scene.camera_profiles import PROFILES, black_8bit
    sensor = PROFILES[profile].sensor
    black = black_8bit(sensor) if black_in_image else 0.0
    gamma = float(sensor.get("gamma", 1.0))
    if sensor.get("response") == "linear":
        gamma = 1.0
    return np.clip((img.astype(float) - black) / (255.0 - black), 0, 1) ** gamma


def brightness_spread(frames: Frames, profile: str, n: int) -> float:
    """Median over mean of the linear signal (``_linear``), the median over the frames."""
    out = []
    for k in range(n):
        lin = frames.linear(k, profile)
        out.append(np.median(lin) / max(lin.mean(), 1e-9))
    return float(np.median(out))


def headroom(frames: Frames, profile: str, n: int) -> float:
    """Full scale over the frame mean of the linear signal (``_linear``), the median over the
    frames: how far above the mean a surface may be before it clips (a sunlit white wall)."""
    return float(np.median([1.0 / max(frames.linear(k, profile).mean(), 1e-9) for k in range(n)]))


# KITTI sequence_1's frames marked by hand (x0, y0, x1, y1 at 1226 x 370): sunlit regions of each
# kind (docs/sensors.md, Near infrared); the render's kinds come from its object ids. The facades:
# frame 0 the white house's wall and windows (burnt out, as the render's white walls), frame 40
# the blockwork floors above the scaffold (the earlier boxes held a young tree and site clutter,
# which gave the facades 0.42 and 0.38 of pixel-scale contrast; these 0.00 and 0.24)
KITTI_REGIONS = {
    0: {"road": (480, 300, 780, 365), "lawn": (20, 290, 330, 360), "tree": (390, 60, 470, 130),
        "hedge": (860, 185, 960, 225), "facade": (880, 15, 960, 75), "sky": (560, 0, 640, 50)},
    20: {"road": (500, 280, 700, 365), "lawn": (20, 260, 300, 360), "tree": (1060, 20, 1200, 120),
         "facade": (668, 30, 698, 170), "sky": (560, 30, 640, 100)},
    40: {"road": (470, 335, 750, 368), "lawn": (0, 240, 260, 300), "tree": (200, 20, 400, 80),
         "facade": (700, 5, 810, 95), "sky": (600, 20, 690, 100)}}
RENDER_KINDS = {"road": ("road",), "lawn": ("terrain",), "tree": ("vegetation",), "facade": ("building",), "sky": ()}


def kitti_marked_frame(k: int) -> np.ndarray:
    """KITTI sequence_1's left frame ``k`` (one of ``KITTI_REGIONS``'), grey, at its own size."""
    return cv2.imread(str(DATA / "kitti" / "sequence_1" / "image_l" / f"{k:06d}.png"), 0)


def kitti_regions_at(table: dict, size: tuple):
    """(frame, name, L, box) for each hand-marked region of ``table`` ({frame: {name: (x0, y0, x1,
    y1)}} in KITTI's pixels): the frame area-resampled to the render's ``size`` (W, H) and made
    linear, the box scaled to it (floats)."""
    W, H = size
    for k, regions in table.items():
        img = kitti_marked_frame(k)
        sx, sy = W / img.shape[1], H / img.shape[0]
        L = _linear(cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA), "kitti")
        for name, (x0, y0, x1, y1) in regions.items():
            yield k, name, L, (x0 * sx, y0 * sy, x1 * sx, y1 * sy)


def render_classes(out: Path):
    """The render's sequence and its object classes by id (the manifest's objects)."""
    man = json.loads((out / "manifest.json").read_text())
    return open_sequence(out), {o["id"]: o["class"] for o in man["objects"]}


def kinds_brightness(out: Path, frames: Frames, real_frames: Frames, n: int) -> tuple[str, str]:
    """Median linear signal of each kind over the frame's mean (KITTI: the hand-marked sunlit
    regions; the render: all pixels of the kind's classes, by object id, sun and shade), the
    median over frames, and the share of pixels darker than 0.3 x the frame mean."""
    real = {}
    for k, regions in KITTI_REGIONS.items():
        L = _linear(kitti_marked_frame(k), "kitti")
        med = {name: np.median(L[y0:y1, x0:x1]) for name, (x0, y0, x1, y1) in regions.items()}
        for name, v in med.items():
            real.setdefault(name, []).append(v / L.mean())
    seq, cls = render_classes(out)
    ours, dark = {}, []
    for k in range(n):
        L = frames.linear(k, "kitti")
        ids = np.asarray(seq.ids(k, "left")).astype(int)
        names = np.vectorize(lambda i: cls.get(i, "sky"))(ids)
        dark.append(np.mean(L < 0.3 * L.mean()))
        med = {kind: np.median(L[np.isin(names, c or ("sky",))]) if np.isin(names, c or ("sky",)).any() else np.nan
               for kind, c in RENDER_KINDS.items()}
        for name, v in med.items():
            ours.setdefault(name, []).append(v / L.mean())
    real_dark = [np.mean(L < 0.3 * L.mean()) for L in (real_frames.linear(k, "kitti") for k in range(n))]
    fmt = lambda d: ", ".join(f"{k} {np.nanmedian(v):.2f}" for k, v in d.items())  # noqa: E731
    return (fmt(real) + f"; pixels < 0.3 x mean {100 * np.median(real_dark):.0f} %",
            fmt(ours) + f"; pixels < 0.3 x mean {100 * np.median(dark):.0f} %")


def facade_brightness(out: Path, frames: Frames, n: int) -> str:
    """Why the render's facade brightness (``kinds_brightness``: all its building pixels, sun and
    shade, windows included) sits below KITTI's hand-marked sunlit boxes: the render's building
    pixels' linear signal over the frame mean at the median, 75th and 90th percentile, and their
    share brighter than the frame mean, each the median over frames."""
    seq, cls = render_classes(out)
    building = [i for i, c in cls.items() if c == "building"]
    q = []
    for k in range(n):
        L = frames.linear(k, "kitti")
        m = np.isin(np.asarray(seq.ids(k, "left")).astype(int), building)
        if m.sum() >= 100:
            r = L[m] / max(float(L.mean()), 1e-9)
            q.append((*np.percentile(r, (50, 75, 90)), np.mean(r > 1.0)))
    if not q:
        return "no building pixels"
    p50, p75, p90, bright = np.median(np.array(q), axis=0)
    return f"median {p50:.2f}, p75 {p75:.2f}, p90 {p90:.2f}; {100 * bright:.0f} % brighter than the frame mean"


def slope_by_reduction(real_seq, n: int, size: tuple[int, int]) -> str:
    """The real excerpt's spectrum slope (left frames, their mean as in the table) when
    brought to ``size`` in three ways: area averaging (the table's: the camera binned to that size, a box pixel aperture,
    which keeps the power that folds back from above the new Nyquist), a Gaussian pyramid
    (cv2.pyrDown's 5-tap binomial low-pass per halving: little aliasing) and Lanczos
    (cv2.INTER_LANCZOS4: sharp, aliasing). The render's slope has no reduction: how far the
    real figure moves with the reduction alone says how much of a slope gap is the
    comparison's."""
    W0 = real_seq.resolution[0]
    if size[0] == W0:
        return "no reduction (the real frames at their own size)"

    def pyramid(img):
        while img.shape[1] >= 2 * size[0]:
            img = cv2.pyrDown(img)
        return cv2.resize(img, size, interpolation=cv2.INTER_AREA)

    ways = {"area": lambda im: cv2.resize(im, size, interpolation=cv2.INTER_AREA), "Gaussian pyramid": pyramid,
            "Lanczos": lambda im: cv2.resize(im, size, interpolation=cv2.INTER_LANCZOS4)}
    return ", ".join(f"{name} {np.mean([spectrum_slope(f(real_seq.image_gray(k))) for k in range(n)]):.2f}"
                     for name, f in ways.items())


RING_BANDS = ((2, 8), (8, 16), (16, 32), (32, 48), (48, 64), (64, 80), (80, 92))


def _ring_power(img) -> np.ndarray:
    """``spectrum_slope``'s rings (``realism.ring_power``) of an 8-bit grey frame, over its
    mean squared (contrast power)."""
    return ring_power(img) / float(np.mean(img, dtype=np.float64)) ** 2


def ring_power_ratio(real: Frames, ours: Frames, n: int) -> str:
    """Where the slope's gap lies: the real frames' ring power over the render's, both over
    their frame mean squared, per band of cycles per image height (median over the frames):
    above 1 at the top, the render lacks fine contrast; below 1 at the bottom, it has too much
    large-scale contrast."""
    r = [[_ring_power(real.image_gray(k))[a:b].mean() / _ring_power(ours.image_gray(k))[a:b].mean()
          for a, b in RING_BANDS] for k in range(n)]
    return ", ".join(f"{a}-{b}: {v:.2f}" for (a, b), v in zip(RING_BANDS, np.median(r, axis=0)))


# KITTI sequence_1's cars marked by hand (x0, y0, x1, y1 at 1226 x 370; frame 0 the dark car parked
# right, 20 the grey one, 40 the far left's parked ones): KITTI_REGIONS' boxes plus these are the
# real side of ``band_power_by_region``
KITTI_CARS = {0: {"car": (720, 175, 836, 242)}, 20: {"car": (726, 182, 854, 256)}, 40: {"car": (86, 182, 170, 224)}}
REGION_BANDS = ((2, 16), (16, 48), (48, 72), (72, 92))


def band_images(img, bands=REGION_BANDS) -> list[np.ndarray]:
    """An 8-bit grey frame's band-passed images, one per band of ``bands`` (cycles per image
    height, ``ring_power``'s rings: a <= rho < b): the frame over its mean, minus one (contrast),
    mirror-padded by 16 px against the FFT's wrap, each band kept by its ring mask. The mean of a
    band image's square over the whole frame is the band's share of the frame's contrast power
    (Parseval); over a region, the region's own (``band_power_by_region``)."""
    a = np.asarray(img, np.float64)
    H, W = a.shape
    a = a / max(float(a.mean()), 1e-9) - 1.0
    p = 16
    F = np.fft.fft2(np.pad(a, p, mode="reflect"))
    m = min(H, W)
    Hp, Wp = H + 2 * p, W + 2 * p
    rho = np.hypot(np.fft.fftfreq(Wp)[None, :] * m, np.fft.fftfreq(Hp)[:, None] * m)
    return [np.real(np.fft.ifft2(F * ((rho >= lo) & (rho < hi))))[p:p + H, p:p + W] for lo, hi in bands]


def _region_masks(ids: np.ndarray, cls: dict) -> dict[str, np.ndarray]:
    """The render's regions by object id (``kinds_grain``'s: each kind 3 px in from its edges, the
    crown with the sky seen through it), plus ``car`` and the open ``sky`` (no object, outside
    the crowns)."""
    of = lambda names: np.isin(ids, [i for i, x in cls.items() if x in names])  # noqa: E731
    ero = lambda m: cv2.erode(m.astype(np.uint8), np.ones((7, 7))) > 0  # noqa: E731
    veg, sky = of(("vegetation",)), ~np.isin(ids, list(cls))
    hull = cv2.morphologyEx(veg.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((9, 9), np.uint8)) > 0
    regions = {kind: ero(of(c)) for kind, c in RENDER_KINDS.items() if c}
    regions["crown"] = ero(hull & (veg | sky))
    regions["car"] = ero(of(("car", "truck", "bus")))
    regions["sky"] = ero(sky & ~hull)
    return regions


def band_power_by_region(out: Path, real: Frames, ours: Frames, n: int) -> tuple[str, str]:
    """Where the ring power's gap lies in the frame: the contrast power (``band_images``: the
    frame over its mean) of each band of ``REGION_BANDS`` inside each region, its mean square
    over the region's pixels, the median over frames. KITTI sequence_1 in its hand-marked boxes
    (``KITTI_REGIONS`` and ``KITTI_CARS``, frames 0, 20, 40, at the render's size, 2 px in); the
    render in its regions by object id (``_region_masks``), frames 0..n-1; ``frame`` is the
    whole frame of both, frames 0..n-1. Returns (the KITTI /
    render ratio per region and band, the render's share of each band's frame power per region
    -- where its power sits; the shares need not sum to 1: edges between regions are left out)."""
    W, H = ours.resolution
    real_p: dict[str, list] = {}
    boxes = {k: {**KITTI_REGIONS[k], **KITTI_CARS.get(k, {})} for k in KITTI_REGIONS}
    for k, regions in boxes.items():
        full = kitti_marked_frame(k)       # the 8-bit grey frame, as ring_power reads it
        sx, sy = W / full.shape[1], H / full.shape[0]
        bands = band_images(cv2.resize(full, (W, H), interpolation=cv2.INTER_AREA))
        for name, (x0, y0, x1, y1) in regions.items():
            m = (slice(int(y0 * sy) + 2, int(y1 * sy) - 2), slice(int(x0 * sx) + 2, int(x1 * sx) - 2))
            if bands[0][m].size >= 20:
                real_p.setdefault(name, []).append([float(np.mean(b[m] ** 2)) for b in bands])
    for k in range(n):
        real_p.setdefault("frame", []).append([float(np.mean(b ** 2)) for b in band_images(real.image_gray(k))])
    seq, cls = render_classes(out)
    ours_p: dict[str, list] = {}
    share: dict[str, list] = {}
    for k in range(n):
        bands = band_images(ours.image_gray(k))
        total = [float(np.mean(b ** 2)) for b in bands]
        ours_p.setdefault("frame", []).append(total)
        for name, m in _region_masks(np.asarray(seq.ids(k, "left")).astype(int), cls).items():
            if m.sum() >= 50:
                ours_p.setdefault(name, []).append([float(np.mean(b[m] ** 2)) for b in bands])
                share.setdefault(name, []).append([float(np.sum(b[m] ** 2)) / (t * m.size) for b, t in zip(bands, total)])
    band_names = "/".join(f"{a}-{b}" for a, b in REGION_BANDS)
    med = lambda v: np.median(np.array(v), axis=0)  # noqa: E731
    ratio = []
    for name in ("frame", "facade", "road", "lawn", "crown", "car", "sky"):   # KITTI's tree boxes are crowns
        r = real_p.get("tree" if name == "crown" else name)
        if r is None or name not in ours_p:
            continue
        top = f" ({1e4 * med(r)[-1]:.1f} / {1e4 * med(ours_p[name])[-1]:.1f})"
        ratio.append(f"{name} " + "/".join(f"{x:.2f}" for x in med(r) / med(ours_p[name])) + top)
    shares = [f"{name} " + "/".join(f"{100 * x:.0f}" for x in med(v)) for name, v in share.items()]
    return (f"KITTI / render ({band_names} cycles; in brackets KITTI's and the render's top band x 1e4) "
            + ", ".join(ratio),
            f"render's share of each band's frame power, % ({band_names}) " + ", ".join(shares))


def band_power_by_cell(real: Frames, ours: Frames, n: int) -> tuple[str, str]:
    """Where the top band's gap lies in the image, free of any region's choice: the top band's
    (``REGION_BANDS[-1]``) contrast power (``band_images``) in each ninth of the frame (thirds
    of its height and width), the median over frames 0..n-1 of both (the same views of a
    twin street). Returns (the KITTI / render ratio by cell, top row first, left to right;
    both's power x 1e4 by cell)."""
    def cells(img):
        B = band_images(img, REGION_BANDS[-1:])[0] ** 2
        H, W = B.shape
        return [[float(B[i * H // 3:(i + 1) * H // 3, j * W // 3:(j + 1) * W // 3].mean()) for j in range(3)]
                for i in range(3)]
    r = np.median([cells(real.image_gray(k)) for k in range(n)], axis=0)
    o = np.median([cells(ours.image_gray(k)) for k in range(n)], axis=0)
    rows = lambda a, f: " | ".join(" ".join(f.format(x) for x in row) for row in a)  # noqa: E731
    return rows(r / o, "{:.2f}"), f"KITTI {rows(1e4 * r, '{:.0f}')}; render {rows(1e4 * o, '{:.0f}')}"


def _grain(L: np.ndarray, mask: np.ndarray) -> float:
    """Pixel-scale contrast: the robust deviation (1.4826 MAD) of the linear signal over its
    5 x 5 box mean, minus one, on ``mask``."""
    x = (L / np.maximum(cv2.blur(L, (5, 5)), 1e-3) - 1.0)[mask]
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else float("nan")


def road_grain(out: Path, frames: Frames, n: int) -> tuple[float, float]:
    """The sunlit road's pixel-scale contrast (``_grain``), the median over frames: KITTI
    sequence_1 in its hand-marked road regions (frames 0, 20, 40, at the render's size); the
    render on its road pixels (object ids; 7 x 7 in from the class's edges) brighter than half
    their median (the sunlit road)."""
    W, H = frames.resolution
    real = []
    for k, regions in KITTI_REGIONS.items():
        img = kitti_marked_frame(k)
        sx, sy = W / img.shape[1], H / img.shape[0]
        L = _linear(cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA), "kitti")
        x0, y0, x1, y1 = regions["road"]
        m = np.zeros(L.shape, bool)
        m[int(y0 * sy) + 2:int(y1 * sy) - 2, int(x0 * sx) + 2:int(x1 * sx) - 2] = True
        real.append(_grain(L, m))
    seq, cls = render_classes(out)
    road = [i for i, c in cls.items() if c == "road"]
    ours = []
    for k in range(n):
        L = frames.linear(k, "kitti")
        m = cv2.erode(np.isin(np.asarray(seq.ids(k, "left")).astype(int), road).astype(np.uint8), np.ones((7, 7))) > 0
        if m.sum() >= 200:
            ours.append(_grain(L, m & (L > 0.5 * np.median(L[m]))))
    return float(np.median(real)), float(np.nanmedian(ours)) if ours else float("nan")


def kinds_grain(out: Path, frames: Frames, n: int) -> tuple[str, str]:
    """Where the finest rings' deficit lies: the pixel-scale contrast (``_grain``) of each kind
    of ``kinds_brightness``, the median over frames: KITTI sequence_1 in ``KITTI_REGIONS``'
    hand-marked regions (sunlit; at the render's size, 2 px in from their edges), the render on
    each kind's pixels 3 px in from the kind's edges (by object id, sun and shade; a depth edge
    inside a kind, a crown against a wall, is not the kind's own detail). KITTI's tree boxes are
    crowns with the sky seen through them; the render's ``crown`` is the same: its vegetation
    closed over 9 x 9 px, leaves and the sky inside, 3 px in (``tree`` has its leaves alone)."""
    W, H = frames.resolution
    real: dict[str, list] = {}
    for _, name, L, (x0, y0, x1, y1) in kitti_regions_at(KITTI_REGIONS, (W, H)):
        m = np.zeros(L.shape, bool)
        m[int(y0) + 2:int(y1) - 2, int(x0) + 2:int(x1) - 2] = True
        if m.sum() >= 20 and name != "sky":
            real.setdefault(name, []).append(_grain(L, m))
    seq, cls = render_classes(out)
    ours: dict[str, list] = {}
    for k in range(n):
        L = frames.linear(k, "kitti")
        ids = np.asarray(seq.ids(k, "left")).astype(int)
        for kind, c in RENDER_KINDS.items():
            if not c:
                continue
            m = np.isin(ids, [i for i, x in cls.items() if x in c])
            m = cv2.erode(m.astype(np.uint8), np.ones((7, 7))) > 0
            if m.sum() >= 100:
                ours.setdefault(kind, []).append(_grain(L, m))
        veg = np.isin(ids, [i for i, x in cls.items() if x == "vegetation"])
        hull = cv2.morphologyEx(veg.astype(np.uint8), cv2.MORPH_CLOSE, np.ones((9, 9), np.uint8)) > 0
        crown = cv2.erode((hull & (veg | ~np.isin(ids, list(cls)))).astype(np.uint8), np.ones((7, 7))) > 0
        if crown.sum() >= 100:
            ours.setdefault("crown", []).append(_grain(L, crown))
    fmt = lambda d: ", ".join(f"{k} {np.nanmedian(v):.3f}" for k, v in d.items())  # noqa: E731
    return fmt(real), fmt(ours)


# KITTI sequence_1's street surfaces marked by hand (x0, y0, x1, y1 at 1226 x 370), sunlit parts:
# frame 0 the kerb's top around the right tree lawn and the light concrete gutter before it, frame
# 12 the dark parking bay (concrete setts, light sand joints); the render's from its asset kinds
KITTI_STREET = {
    0: {"road": (480, 300, 780, 365), "kerb": (800, 286, 815, 292), "gutter": (845, 335, 880, 350),
        "sidewalk": (1000, 250, 1080, 275), "lawn": (20, 290, 330, 360)},
    12: {"road": (520, 300, 700, 365), "gutter": (787, 302, 803, 310), "bay": (830, 290, 920, 310),
         "sidewalk": (950, 225, 1100, 260), "lawn": (20, 260, 300, 360)}}


def _street_kind(o: dict) -> str | None:
    """A render object's street surface: its asset kind, the flush sidewalk strip being the bay."""
    kind = o.get("kind")
    if kind == "sidewalk" and o.get("size", [0, 1])[1] < 0.05:
        return "bay"
    return {"road": "road", "kerb": "kerb", "sidewalk": "sidewalk", "verge": "lawn"}.get(kind)


KERB_TOP_M = 0.02      # a kerb's pixels within this of its top height: its top (its face is in view too)


def _world_height(seq, k: int, K: np.ndarray) -> np.ndarray:
    """World y (m, up) of every pixel of the render's left frame k (its depth, K and pose)."""
    z = np.asarray(seq.depth(k, "left"), float)
    H, W = z.shape
    x, y = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    P = backproject(K, np.stack([x.ravel(), y.ravel()], 1), np.where(np.isfinite(z), z, 1e6).ravel())
    T = np.asarray(seq.T_world_cam("left"))[k]
    return (P @ T[:3, :3].T + T[:3, 3])[:, 1].reshape(H, W)


def street_surfaces(out: Path, frames: Frames, n: int) -> tuple[str, str]:
    """Each street surface's brightness over the sunlit road's (median linear signal) and its
    pixel-scale contrast (``_grain``, where a region spans 10 x 10 px at the render's size), the
    median over frames: KITTI sequence_1 in ``KITTI_STREET``'s hand-marked regions (at the
    render's size), the render by asset kind on its sunlit pixels (brighter than half the
    sunlit road's median; the grain 3 x 3 in from the kind's edges; the kerb on its top, within
    ``KERB_TOP_M`` of its height by the true depth: its road-facing face is in view as well). The
    sunlit road: 3 x 3 in from its edges, brighter than half its median."""
    W, H = frames.resolution
    real: dict[str, list] = {}
    road: dict[int, float] = {}      # each frame's sunlit road (its table lists the road first)
    for k, name, L, (x0, y0, x1, y1) in kitti_regions_at(KITTI_STREET, (W, H)):
        m = np.zeros(L.shape, bool)
        m[int(y0):int(np.ceil(y1)), int(x0):int(np.ceil(x1))] = True
        v = float(np.median(L[m]))
        if name == "road":
            road[k] = v
        ys, xs = np.nonzero(m)
        grain = _grain(L, m) if np.ptp(ys) >= 10 and np.ptp(xs) >= 10 else float("nan")
        real.setdefault(name, []).append((v / road[k], grain))
    man = json.loads((out / "manifest.json").read_text())
    kind_of = {o["id"]: _street_kind(o) for o in man["objects"]}
    # a kerb's top (world y, m): its rest pose's height plus its own; KITTI's marks are kerb tops
    kerb_top = [o["T_world_obj_rest"][1][3] + o["size"][1] for o in man["objects"]
                if kind_of[o["id"]] == "kerb" and "T_world_obj_rest" in o and "size" in o]
    seq = open_sequence(out)
    ours: dict[str, list] = {}
    for k in range(n):
        L = frames.linear(k, "kitti")
        ids = np.asarray(seq.ids(k, "left")).astype(int)
        m = cv2.erode(np.isin(ids, [i for i, c in kind_of.items() if c == "road"]).astype(np.uint8), np.ones((3, 3))) > 0
        if m.sum() < 20:
            continue
        road = float(np.median(L[m & (L > 0.5 * np.median(L[m]))]))
        for name in ("kerb", "gutter", "bay", "sidewalk", "lawn"):
            # sunlit: brighter than half the sunlit road (KITTI's regions are sunlit ones); the
            # brightness on all such pixels of the kind (a kerb's top is 1-2 px high at 8 m and
            # half size: an erosion leaves its face, in shade), the grain 3 x 3 in from its edges
            kind = np.isin(ids, [i for i, c in kind_of.items() if c == name])
            lit = kind & (L > 0.5 * road)
            if name == "kerb" and kerb_top:
                lit &= _world_height(seq, k, frames.K) > min(kerb_top) - KERB_TOP_M
            if lit.sum() >= 20:
                inner = lit & (cv2.erode(kind.astype(np.uint8), np.ones((3, 3))) > 0)
                ours.setdefault(name, []).append((float(np.median(L[lit])) / road,
                                                  _grain(L, inner) if inner.sum() >= 100 else np.nan))
    fmt = lambda d: ", ".join(f"{name} {np.nanmedian([v for v, _ in vs]):.2f}" + (  # noqa: E731
        f" ({np.nanmedian([g for _, g in vs]):.3f})" if np.isfinite([g for _, g in vs]).any() else "")
        for name, vs in d.items() if name != "road")
    return fmt(real), fmt(ours)


def corners_on_depth_edges(out: Path, frames: Frames, n: int, start: int = 0) -> dict:
    """The OpenCV VO's corners on the render: the share on a depth edge and the median SGBM
    disparity error (% of the true disparity) at edge and surface corners."""
    seq = open_sequence(out)
    fB = frames.K[0, 0] * frames.baseline_m
    err = {True: [], False: []}
    share = []
    for k in range(n - 1):
        z = seq.depth(start + k, "left")
        d_gt = np.where(np.isfinite(z), fB / z, 0.0).astype(np.float32)
        box = np.ones((7, 7), np.uint8)
        hi, lo = cv2.dilate(d_gt, box), cv2.erode(d_gt, box)
        edge = (hi - lo) > 0.15 * np.maximum(hi, 1e-3)
        left = frames.image_gray(k)
        d = sgbm_disparity(left, frames.image_gray(k, "right"))
        pts = cv2.goodFeaturesToTrack(left, 1000, 0.01, 8)
        if pts is None:
            continue
        x, y = np.rint(pts.reshape(-1, 2)).astype(int).T
        ok = (d[y, x] > 1) & (d_gt[y, x] > 0)
        share.append(np.mean(edge[y, x][ok]))
        for on_edge in (True, False):
            m = ok & (edge[y, x] == on_edge)
            err[on_edge] += list(100 * (d[y, x][m] / d_gt[y, x][m] - 1))
    return {"edge_share": float(np.mean(share)), "edge_err_pct": float(np.median(err[True])),
            "surface_err_pct": float(np.median(err[False]))}


def corners_on_sgbm_edges(frames: Frames, n: int) -> dict:
    """The same corners on either sequence, judged by SGBM's own disparity (no ground truth:
    real and render alike): the share of the corners with a valid disparity that lie on a
    disparity discontinuity (valid disparities span > 15 % in the 7 x 7 window, the rule of
    ``corners_on_depth_edges``), and of those nearer than 15 m (fB / d: the near field that
    decides a step's scale) the share on one."""
    fB = frames.K[0, 0] * frames.baseline_m
    share, near = [], []
    box = np.ones((7, 7), np.uint8)
    for k in range(n - 1):
        left = frames.image_gray(k)
        d = sgbm_disparity(left, frames.image_gray(k, "right"))
        valid = d > 1
        hi = cv2.dilate(np.where(valid, d, 0.0).astype(np.float32), box)
        lo = cv2.erode(np.where(valid, d, 1e6).astype(np.float32), box)
        edge = (hi - lo) > 0.15 * np.maximum(hi, 1e-3)
        pts = cv2.goodFeaturesToTrack(left, 1000, 0.01, 8)
        if pts is None:
            continue
        x, y = np.rint(pts.reshape(-1, 2)).astype(int).T
        ok = valid[y, x]
        share.append(np.mean(edge[y, x][ok]))
        close = ok & (fB / np.maximum(d[y, x], 1e-3) < 15.0)
        if close.any():
            near.append(np.mean(edge[y, x][close]))
    return {"edge_share": float(np.mean(share)), "near_edge_share": float(np.mean(near)) if near else float("nan")}


REGIONS = ("upper left", "upper middle", "upper right", "lower left", "lower middle", "lower right")


def _sixth(x: np.ndarray, y: np.ndarray, W: int, H: int) -> np.ndarray:
    """The ``REGIONS`` index (0..5) of pixels (x, y) in a W x H image (points outside it counted
    in the nearest sixth)."""
    return np.clip(y * 2 // H, 0, 1).astype(int) * 3 + np.clip(x * 3 // W, 0, 2).astype(int)


def corners_by_region(frames: Frames, n: int) -> np.ndarray:
    """The OpenCV VO's corners (Shi-Tomasi 1000/0.01/8, its detector) in each sixth of the image
    (``REGIONS``: upper and lower half, left, middle and right third), mean per frame over frames
    0..n-1: where a render's corners lack (session 14: KITTI sequence_1's lower right 60-63 a
    frame, the render's 36-38 - KITTI's front gardens)."""
    counts = np.zeros(6)
    for k in range(n):
        img = frames.image_gray(k)
        H, W = img.shape[:2]
        pts = cv2.goodFeaturesToTrack(img, 1000, 0.01, 8)
        if pts is None:
            continue
        x, y = pts.reshape(-1, 2).T
        counts += np.bincount(_sixth(x, y, W, H), minlength=6)
    return counts / max(n, 1)


MATCH_TOL_PX = 1.5      # a match the true step carries to within this of its partner: consistent


def pnp_translation_bound(P: np.ndarray, K: np.ndarray) -> float:
    """The Cramér-Rao bound of a PnP's translation (m, root of the trace of its covariance) from
    points P (N, 3, camera k, m) whose pixels in k+1 carry 1 px of independent noise per
    coordinate, rotation estimated along: how precisely the inliers' count and placement (depth,
    spread over the image) can fix the step at all, whatever the matcher. At the identity
    motion (a step's rotation and translation move the bound little)."""
    X, Y, Z = np.asarray(P, float).T
    fx, fy = K[0, 0], K[1, 1]
    J = np.zeros((2 * len(Z), 6))
    # d pixel / d translation, then d pixel / d rotation = (d pixel / d point) (-[P]x)
    J[0::2, 3:] = np.stack([fx / Z, 0 * Z, -fx * X / Z**2], 1)
    J[1::2, 3:] = np.stack([0 * Z, fy / Z, -fy * Y / Z**2], 1)
    J[0::2, :3] = np.stack([-fx * X * Y / Z**2, fx * (1 + X**2 / Z**2), -fx * Y / Z], 1)
    J[1::2, :3] = np.stack([-fy * (1 + Y**2 / Z**2), fy * X * Y / Z**2, fy * X / Z], 1)
    C = np.linalg.inv(J.T @ J)
    return float(np.sqrt(np.trace(C[3:, 3:])))


def orb_funnel(seq: Frames, n: int, mask=None) -> dict:
    """The ORB VO taken apart, medians over the steps: keypoints, cross-checked matches, those
    with an SGBM depth, PnP-RANSAC's inliers; the share of the matches with depth that the true
    step carries to within ``MATCH_TOL_PX`` of their partner (the same rule for real and render:
    SGBM depth, ground-truth step), the inliers' translation bound (``pnp_translation_bound``,
    % of the true step at 1 px) and the median translation error (% of the step, as
    ``vo_errors``) with the steps over ``BAD_STEP_PCT``."""
    T_gt = np.asarray(seq.T_world_cam("left"))[:n]
    recs: list[OrbStep] = []
    steps = orb_steps(seq, n, mask=mask, funnel=recs)
    t_err, _ = step_errors(T_gt, steps)
    cons, bound = [], []
    for k, r in enumerate(recs):
        T_k1_k = invert(invert(T_gt[k]) @ T_gt[k + 1])
        step_m = float(np.linalg.norm(T_k1_k[:3, 3]))
        if len(r.P):
            Q = r.P @ T_k1_k[:3, :3].T + T_k1_k[:3, 3]
            cons.append(float(np.mean(np.linalg.norm(project(seq.K, Q) - r.q, axis=1) < MATCH_TOL_PX)))
        if len(r.inliers) >= 6:
            bound.append(100 * pnp_translation_bound(r.P[r.inliers], seq.K) / step_m)
    med = lambda v: float(np.median(v)) if len(v) else float("nan")  # noqa: E731
    return {"keypoints": med([r.keypoints for r in recs]), "matches": med([r.matches for r in recs]),
            "with_depth": med([len(r.P) for r in recs]), "inliers": med([len(r.inliers) for r in recs]),
            "consistent": med(cons), "bound_pct": med(bound), "t_rpe_pct": med(t_err),
            "bad_steps": int(np.sum(t_err > BAD_STEP_PCT)), "funnel": recs}


def orb_inliers_by_region(recs: list, K: np.ndarray, size: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The ORB VO's inliers (``orb_funnel``'s ``funnel``) in each sixth of the image (``REGIONS``,
    their pixels in frame k of size (W, H)): the mean count a step and their median SGBM depth (m,
    nan where none): where a render's steps are fixed, near or far (session 15: KITTI
    sequence_1's upper right holds ~96 a step at ~21 m, the render's ~43)."""
    W, H = size
    counts, depth = np.zeros(6), [[] for _ in range(6)]
    for r in recs:
        if len(r.inliers):
            P = r.P[r.inliers]
            px = project(K, P)
            cell = _sixth(px[:, 0], px[:, 1], W, H)
            counts += np.bincount(cell, minlength=6)
            for c, z in zip(cell, P[:, 2]):
                depth[c].append(z)
    return counts / max(len(recs), 1), np.array([np.median(d) if d else np.nan for d in depth])


def _kind_of_ids(out: Path) -> dict[int, str]:
    """The render's object ids and their kind (the asset kind, else the class)."""
    man = json.loads((out / "manifest.json").read_text())
    return {o["id"]: o.get("kind") or o["class"] for o in man["objects"]}


ORB_MASK_PX = 3         # keypoints this close to an object's pixels count as its (occlusion junctions)


def orb_kind_lines(out: Path, real: Frames, ours: Frames, name: str, n: int, start: int = 0, top: int = 4) -> list[str]:
    """The ORB VO taken apart on both (``orb_funnel``) and, on the render (object ids), where its
    inliers lie by object kind and its error when ORB may not detect within ``ORB_MASK_PX`` of
    one kind (the kinds holding the most inliers): a kind whose keypoints break steps (thin
    tubes crossing a facade make corners that slide with parallax) lowers the error when
    masked, one that carries the steps raises it. Draw 0 of the render."""
    fr, fo = orb_funnel(real, n), orb_funnel(ours, n)
    seq = open_sequence(out)
    kind_of = _kind_of_ids(out)
    kinds_at = lambda k: np.vectorize(lambda i: kind_of.get(int(i), "sky"))(seq.ids(start + k, "left"))  # noqa: E731
    counts: dict[str, int] = {}
    for k, r in enumerate(fo["funnel"]):
        if len(r.inliers):
            px = project(ours.K, r.P[r.inliers])
            ids = np.asarray(seq.ids(start + k, "left"))
            H, W = ids.shape
            x = np.clip(np.rint(px[:, 0]).astype(int), 0, W - 1)
            y = np.clip(np.rint(px[:, 1]).astype(int), 0, H - 1)
            for i in ids[y, x]:
                kd = kind_of.get(int(i), "sky")
                counts[kd] = counts.get(kd, 0) + 1
    total = max(sum(counts.values()), 1)
    ranked = sorted(counts, key=counts.get, reverse=True)[:top]
    box = np.ones((2 * ORB_MASK_PX + 1,) * 2, np.uint8)

    def without(kind):
        def mask(k):
            m = (kinds_at(k) == kind).astype(np.uint8)
            return (cv2.dilate(m, box) == 0).astype(np.uint8) * 255
        return mask
    masked = {kd: orb_funnel(ours, n, without(kd)) for kd in ranked if kd != "sky"}
    f = lambda d: (f"keypoints {d['keypoints']:.0f}, cross-checked matches {d['matches']:.0f}, with SGBM depth "  # noqa: E731
                   f"{d['with_depth']:.0f}, inliers {d['inliers']:.0f}; the true step carries "
                   f"{100 * d['consistent']:.0f} % of the matches to within {MATCH_TOL_PX} px; the inliers' "
                   f"translation bound {d['bound_pct']:.2f} % of the step at 1 px")
    return [f"ORB VO taken apart (median over the steps): {name} {f(fr)}; render {f(fo)}; bound render / real "
            f"{_ratio(fo['bound_pct'], fr['bound_pct']):.2f}, translation RPE render / real "
            f"{_ratio(fo['t_rpe_pct'], fr['t_rpe_pct']):.2f}",
            "render's ORB inliers by object kind: " + ", ".join(f"{kd} {100 * counts[kd] / total:.0f} %" for kd in ranked)
            + f"; ORB VO's translation RPE (bad steps) as is {fo['t_rpe_pct']:.2f} % ({fo['bad_steps']}), without "
            f"keypoints within {ORB_MASK_PX} px of " + ", ".join(f"{kd} {d['t_rpe_pct']:.2f} % ({d['bad_steps']})"
                                                                 for kd, d in masked.items()),
            "ORB VO's inliers by region (mean a step at their median depth; " + ", ".join(REGIONS) + "): "
            + "; ".join(f"{who} " + " / ".join(f"{c:.0f} at {z:.0f} m" for c, z in zip(*orb_inliers_by_region(
                d["funnel"], seq_.K, seq_.resolution))) for who, d, seq_ in ((name, fr, real), ("render", fo, ours)))]


NEAR_M = 20.0           # an ORB inlier nearer than this fixes a step's length (its image motion grows as 1/Z^2)


def orb_near_inliers(recs: list, parts: int = 3) -> list[dict]:
    """The ORB VO's inliers nearer than ``NEAR_M`` (``orb_funnel``'s ``funnel``) in ``parts`` runs
    of consecutive steps: the mean count a step right and left of the camera (|X| > 2 m) and the
    right ones' median lateral distance (m): a PnP fixes the step's length from the image motion
    of near points off the axis; few, or far to the side, and the length wanders (session 20:
    KITTI sequence_1's frames 34-44 hold 85 a step 6.7 m right, on its works block's scaffold and
    fence; the render held 51 at 8.5 m)."""
    out = []
    for part in np.array_split(np.arange(len(recs)), parts):
        right, left, xs = 0, 0, []
        for k in part:
            r = recs[k]
            if len(r.inliers):
                P = r.P[r.inliers]
                near = P[:, 2] < NEAR_M
                right += int(np.sum(near & (P[:, 0] > 2.0)))
                left += int(np.sum(near & (P[:, 0] < -2.0)))
                xs += list(P[near & (P[:, 0] > 2.0), 0])
        m = max(len(part), 1)
        out.append({"steps": (int(part[0]), int(part[-1])) if len(part) else (0, 0), "right": right / m,
                    "left": left / m, "right_x_m": float(np.median(xs)) if xs else float("nan")})
    return out


def orb_near_lines(real: Frames, ours: Frames, name: str, n: int, start: int = 0) -> list[str]:
    """``orb_near_inliers`` on both, by third of the steps (draw 0 of the render), and each side's
    steps off by more than ``BAD_STEP_PCT`` with their error along the drive (mm; + too long)."""
    lines = []
    for who, fr in ((name, real), ("render", ours)):
        recs: list[OrbStep] = []
        steps = orb_steps(fr, n, funnel=recs)
        T_gt = np.asarray(fr.T_world_cam("left"))[:n]
        t_err, _ = step_errors(T_gt, steps)
        bad = []
        for k in np.flatnonzero(t_err > BAD_STEP_PCT):
            E = invert(invert(T_gt[k]) @ T_gt[k + 1]) @ steps[k]
            bad.append(f"{start + k}-{start + k + 1} {t_err[k]:.0f} % ({1000 * E[2, 3]:+.0f} mm along)")
        parts = "; ".join(f"steps {start + d['steps'][0]}-{start + d['steps'][1] + 1}: right {d['right']:.0f} at "
                          f"{d['right_x_m']:.1f} m, left {d['left']:.0f}" for d in orb_near_inliers(recs))
        lines.append(f"{who}: ORB inliers nearer than {NEAR_M:.0f} m a step (right at their median lateral "
                     f"distance; frames) {parts}; steps off by > {BAD_STEP_PCT:.0f} %: " + (", ".join(bad) or "none"))
    return lines


def vo_cause_lines(name: str, real: Frames, ours: Frames, real_figs: dict, draw_figs: list[dict], n: int) -> list[str]:
    """What the VOs' errors come from (docs/sensors.md, "Camera twins"): broken steps per VO, the
    ORB VO's inliers (a PnP's translation error on points at depth Z, measured to a fixed pixel
    precision, grows as Z / sqrt(points)) and the rig's rotation change between steps (what the
    accurate VO's constant-velocity prediction, which picks the camera's motion from two rigid
    motions, misses)."""
    med = lambda key: float(np.median([d[key] for d in draw_figs]))  # noqa: E731
    bad = ", ".join(f"{vo} {real_figs[f'{vo}/bad_steps']} / {med(f'{vo}/bad_steps'):.0f} "
                    f"(max {max(d[f'{vo}/bad_steps'] for d in draw_figs)})" for vo in VOS)
    zr, nr = real_figs["orb/inlier_depth_m"], real_figs["orb/inliers"]
    zo, no = med("orb/inlier_depth_m"), med("orb/inliers")
    cr, co = rotation_change_deg(real.T_world_cam(), n), rotation_change_deg(ours.T_world_cam(), n)
    return [f"steps with translation error > {BAD_STEP_PCT:.0f} % of the step, {name} / render (median over the "
            "draws): " + bad,
            f"ORB VO's inliers (median over the steps; SGBM depth): {name} {nr:.0f} at {zr:.1f} m, render {no:.0f} at "
            f"{zo:.1f} m; depth / sqrt(inliers) render / real {_ratio(zo / np.sqrt(no), zr / np.sqrt(nr)):.2f}",
            "rig rotation change between consecutive steps (ground truth; what a constant-velocity prediction misses): "
            f"{name} median {np.median(cr):.3f} deg (p90 {np.percentile(cr, 90):.3f}), render median "
            f"{np.median(co):.3f} deg (p90 {np.percentile(co, 90):.3f})"]


def gt_error_lines(name: str, real: Frames, ours: Frames, real_figs: dict, draw_figs: list[dict], n: int,
                   boot: int = 2000) -> list[str]:
    """How much of the real translation RPE is the real ground truth's own error (bench/gt_noise.py,
    docs/sensors.md "The ground truth's own error"); printed beside the table, the table's verdicts
    unchanged. (1) The poses' heading against the images': the mean lateral offset of the poses'
    step from the three VOs' median step (``heading_offset_rad``; the render's exact poses: ~0, the
    check) and each VO's RPE with each side's offset turned out of its poses (render: median over
    the draws). (2) The poses' random step error by the three-cornered hat of the OpenCV and
    accurate VOs (3D rms a step, 90 % block-bootstrap interval): plain on both (the render's is the
    VOs' error correlation, its poses being exact), the real one corrected with the correlation the
    render shows, and the smoothness bound on a white pose noise."""
    import gt_noise as gn     # bench/gt_noise.py, beside this script
    g_real = gn.step_vectors(real.T_world_cam("left")[:n])
    g_ours = gn.step_vectors(ours.T_world_cam("left")[:n])
    vo_of = lambda figs: [figs[f"{vo}/steps_m"] for vo in VOS]  # noqa: E731
    psi_r = gn.heading_offset_rad(g_real, vo_of(real_figs))
    psi_o = [gn.heading_offset_rad(g_ours, vo_of(d)) for d in draw_figs]
    deg = lambda r: f"{np.degrees(r):+.2f}"  # noqa: E731
    rpe, added = [], []
    for vo in VOS:
        r0 = float(np.median(gn.rpe_pct(g_real, real_figs[f"{vo}/steps_m"])))
        r1 = float(np.median(gn.rpe_pct(gn.turned(g_real, psi_r), real_figs[f"{vo}/steps_m"])))
        o0 = [float(np.median(gn.rpe_pct(g_ours, d[f"{vo}/steps_m"]))) for d in draw_figs]
        o1 = [float(np.median(gn.rpe_pct(gn.turned(g_ours, p), d[f"{vo}/steps_m"]))) for d, p in zip(draw_figs, psi_o)]
        rpe.append(f"{vo} real {r0:.3f} -> {r1:.3f} %, render {np.median(o0):.3f} -> {np.median(o1):.3f} %, render / real "
                   f"{np.median([x / r0 for x in o0]):.2f} -> {np.median([x / r1 for x in o1]):.2f}")
        # the other way round: the render's exact poses given the real poses' turn (their step right by psi)
        o2 = [float(np.median(gn.rpe_pct(gn.turned(g_ours, -psi_r), d[f"{vo}/steps_m"]))) for d in draw_figs]
        added.append(f"{vo} {np.median(o2):.3f} % ({np.median([x / r0 for x in o2]):.2f})")
    lateral = 1e3 * np.mean(g_real[:, 0] - np.median(np.stack(vo_of(real_figs)), axis=0)[:, 0])
    lines = [f"the poses' heading against the images' (the poses' step's lateral offset from the three VOs' median "
             f"step, mean over the steps, deg): {name} {deg(psi_r)} ({lateral:+.1f} mm a step), "
             f"render {deg(float(np.median(psi_o)))} (draws {deg(min(psi_o))} to {deg(max(psi_o))}; exact poses: the "
             f"check); translation RPE with it turned out of each one's poses (median, % of the step): " + "; ".join(rpe)
             + f"; the render against its poses turned by {name}'s heading instead (render / real as judged): "
             + ", ".join(added)]
    a, b = (real_figs[f"{vo}/steps_m"] for vo in ("opencv-baseline", "accurate"))
    plain = gn.hat_with_interval(g_real, a, b, 0.0, boot)
    rho = gn.vo_correlation([g_ours] * len(draw_figs), [d["opencv-baseline/steps_m"] for d in draw_figs],
                            [d["accurate/steps_m"] for d in draw_figs])
    corr = gn.hat_with_interval(g_real, a, b, rho, boot)
    ours_plain = [gn.cornered_hat(g_ours, d["opencv-baseline/steps_m"], d["accurate/steps_m"]).sum() for d in draw_figs]
    iv = lambda h: f"{gn.mm(h['total'])} [{gn.mm(h['lo'])}, {gn.mm(h['hi'])}]"  # noqa: E731
    lines.append(f"the poses' random step error (three-cornered hat of the poses and the OpenCV and accurate VOs' steps; "
                 f"3D rms, mm a step, 90 % block bootstrap): {name} plain {iv(plain)}, render plain "
                 f"{gn.mm(float(np.median(ours_plain)))} (exact poses: the VOs' error correlation, rho x/y/z "
                 + "/".join(f"{r:.2f}" for r in rho) + f"), {name} corrected with the render's rho {iv(corr)}; "
                 f"a white pose noise's bound from {name}'s third differences x/y/z "
                 + "/".join(f"{1e3 * v:.1f}" for v in gn.smoothness_bound(real.T_world_cam("left")[:n])) + " mm a step")
    # rotation: the poses' own error by the same hat, and the two VOs' disagreement (no poses in it)
    rr, ro = gn.step_rotations(real.T_world_cam("left")[:n]), gn.step_rotations(ours.T_world_cam("left")[:n])
    rdeg = lambda v2: f"{np.degrees(np.sign(v2) * np.sqrt(abs(v2))):.4f}"  # noqa: E731
    hat_r = gn.cornered_hat(rr, real_figs["opencv-baseline/steps_rad"], real_figs["accurate/steps_rad"]).sum()
    hat_o = np.median([gn.cornered_hat(ro, d["opencv-baseline/steps_rad"], d["accurate/steps_rad"]).sum() for d in draw_figs])
    dis = lambda f: float(np.mean(np.sum((f["opencv-baseline/steps_rad"] - f["accurate/steps_rad"]) ** 2, axis=1)))  # noqa: E731
    dr, do = dis(real_figs), [dis(d) for d in draw_figs]
    tdis = lambda f, g: 100 * float(np.sqrt(np.mean(np.sum((f["opencv-baseline/steps_m"] - f["accurate/steps_m"]) ** 2,  # noqa: E731
                                                           axis=1)))) / float(np.mean(np.linalg.norm(g, axis=1)))
    lines.append(f"rotation (3D rms, deg a step): the poses' own error by the same hat {name} {rdeg(hat_r)}, render "
                 f"{rdeg(float(hat_o))} (exact poses: the check); the OpenCV and accurate VOs' disagreement (no poses in "
                 f"it) {name} {rdeg(dr)}, render {rdeg(float(np.median(do)))}, render / real "
                 f"{np.median([np.sqrt(x / dr) for x in do]):.2f}; in translation (rms, % of the step) {name} "
                 + f"{tdis(real_figs, g_real):.2f}, render {np.median([tdis(d, g_ours) for d in draw_figs]):.2f}, render / real "
                 + f"{np.median([tdis(d, g_ours) / tdis(real_figs, g_real) for d in draw_figs]):.2f}")
    # each VO's own rotation error by the hat with the poses as the third estimate (independent of
    # the VOs: its noise cancels), less the two VOs' covariance (the render's check above reads it)
    own = lambda f, g, vo, other: gn.cornered_hat(f[f"{vo}/steps_rad"], f[f"{other}/steps_rad"], g).sum()  # noqa: E731
    parts = []
    for vo, other in (("opencv-baseline", "accurate"), ("accurate", "opencv-baseline")):
        r_ = own(real_figs, rr, vo, other)
        o_ = [own(d, ro, vo, other) for d in draw_figs]
        parts.append(f"{vo} {name} {rdeg(r_)}, render {rdeg(float(np.median(o_)))}, render / real "
                     f"{np.median([np.sign(x) * np.sqrt(abs(x) / r_) for x in o_]) if r_ > 0 else float('nan'):.2f}")
    lines.append("each VO's own rotation error by the hat (the poses the third estimate, their noise cancelling; less "
                 "the two VOs' covariance; 3D rms, deg a step): " + "; ".join(parts))
    return lines


def klt_at_speed(real: Frames, ours: Frames, n: int, real_klt: float) -> str:
    """The KLT forward-backward error grows with how far the corners move, so a twin that drives
    slower than the real rig tracks more easily (bench/klt_causes.py): the rigs' mean step, the
    exponent of the render's KLT in the step (its KLT over pairs k, k+2 against k, k+1:
    fb ~ step^alpha), and the render's KLT carried to the real rig's step, with its ratio."""
    from vo_reference.evaluate.realism import klt_fb_error
    step = lambda fr: float(np.mean(np.linalg.norm(np.diff(np.asarray(fr.T_world_cam("left"))[:n, :3, 3], axis=0),  # noqa: E731
                                                   axis=1)))
    sr, so = step(real), step(ours)
    ours_klt = float(np.nanmedian([klt_fb_error(ours.image_gray(k), ours.image_gray(k + 1)) for k in range(n - 1)]))
    two = float(np.nanmedian([klt_fb_error(ours.image_gray(k), ours.image_gray(k + 2)) for k in range(n - 2)]))
    alpha = float(np.log2(two / ours_klt))
    at = ours_klt * (sr / so) ** alpha
    return (f"KLT and the rig's speed: mean step real {sr:.3f} m, render {so:.3f} m; the render's KLT over two steps "
            f"{two:.3f} px (fb ~ step^{alpha:.2f}); at the real rig's step {at:.3f} px, render / real "
            f"{_ratio(ours_klt, real_klt):.2f} -> {_ratio(at, real_klt):.2f} (draw 0)")


def pair_klt(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(forward-backward error, shift) of one frame pair, px: the medians over a's corners tracked
    both ways (realism.klt_fb_error's corners, LK and rule) of the error and of the forward track's
    length (how far the pair moved the corners)."""
    from vo_reference.evaluate.realism import CORNER_CAP, CORNER_MIN_DISTANCE, CORNER_QUALITY, LK_PARAMS
    pts = cv2.goodFeaturesToTrack(a, CORNER_CAP, CORNER_QUALITY, CORNER_MIN_DISTANCE)
    if pts is None:
        return float("nan"), float("nan")
    p1, s1, _ = cv2.calcOpticalFlowPyrLK(a, b, pts, None, **LK_PARAMS)
    p0, s2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **LK_PARAMS)
    ok = (s1.ravel() == 1) & (s2.ravel() == 1)
    if not ok.any():
        return float("nan"), float("nan")
    return (float(np.median(np.linalg.norm((p0 - pts).reshape(-1, 2)[ok], axis=1))),
            float(np.median(np.linalg.norm((p1 - pts).reshape(-1, 2)[ok], axis=1))))


def shake_fit(real_all: Frames, shaken_from: int = 5) -> tuple[np.ndarray, float, float]:
    """EuRoC's KLT error against the shake: its shaken pairs' (error, shift) from pair
    ``shaken_from`` on (``pair_klt``) and the line log error = icpt + slope log shift fitted
    over them: (pairs, slope, icpt)."""
    rr = np.array([pair_klt(real_all.image_gray(k), real_all.image_gray(k + 1))
                   for k in range(shaken_from, real_all.num_frames - 1)])
    ok = np.isfinite(rr).all(axis=1) & (rr > 0).all(axis=1)
    slope, icpt = np.polyfit(np.log(rr[ok, 1]), np.log(rr[ok, 0]), 1)
    return rr[ok], float(slope), float(icpt)


def _pairs_klt(frames: Frames, first: int, last: int) -> np.ndarray:
    """``pair_klt`` of the pairs k, k+1 for k in first..last-1: rows (error, shift)."""
    return np.array([pair_klt(frames.image_gray(k), frames.image_gray(k + 1)) for k in range(first, last)])


def _over_line(pairs: np.ndarray, fit: tuple) -> float:
    """The median over ``pairs`` (rows error, shift) of each error over EuRoC's at its shift."""
    _, slope, icpt = fit
    return float(np.nanmedian(pairs[:, 0] / np.exp(icpt + slope * np.log(pairs[:, 1]))))


def klt_over_shake(frames: Frames, n: int, fit: tuple) -> float:
    """The median over the pairs of frames 0..n-1 of each pair's KLT error over EuRoC's at that
    pair's own shift (``shake_fit``'s line): the table's KLT at equal shake. The same rule on both
    sides (EuRoC's compared pairs read ~1 where they lie on its own line)."""
    return _over_line(_pairs_klt(frames, 0, n - 1), fit)


def klt_at_shake(real_all: Frames, ours: Frames, n: int, start: int, shaken_from: int = 5,
                 fit: tuple | None = None) -> str:
    """A standing camera's KLT error grows with the shake between the two frames: EuRoC V1_01's
    pairs (the rotors from pair 5 on) move its corners 0.02 px a frame in its calm frames 30-49 and
    0.09-0.16 px elsewhere, and its error follows (log-log correlation ~0.8). The shake's bursts are
    not EuRoC's frame for frame (a twin draws its own), so the table judges the KLT at equal shake
    (``klt_over_shake``); this line: each side's median shift over the compared pairs, EuRoC's
    error at a shift (a line fitted in log-log over all its shaken pairs ``real_all``; ``fit``:
    ``shake_fit``'s, when the caller has it), and the render's error over EuRoC's at the render's
    own shift, pair by pair (median; draw 0)."""
    rr, slope, icpt = fit = fit or shake_fit(real_all, shaken_from)
    at = lambda shift: np.exp(icpt + slope * np.log(shift))  # noqa: E731
    cmp_real = _pairs_klt(real_all, start, min(start + n - 1, real_all.num_frames - 1))
    ro = _pairs_klt(ours, 0, n - 1)
    return (f"KLT and the stand's shake (median over pairs, px): compared pairs' shift real {np.median(cmp_real[:, 1]):.3f}, "
            f"render {np.nanmedian(ro[:, 1]):.3f} (EuRoC's shaken pairs {shaken_from}-{real_all.num_frames - 2}: "
            f"{np.median(rr[:, 1]):.3f}); EuRoC's error ~ shift^{slope:.2f} ({at(0.02):.5f} at 0.02 px, "
            f"{at(0.1):.5f} at 0.1); the render's error over EuRoC's at the render's shift {_over_line(ro, fit):.2f} "
            "(draw 0)")


# --- the render -----------------------------------------------------------------------------

def twin_script(script: str, profile: str, out: Path, frames: int | None = None) -> Path:
    """The library script with its camera profile and AUTOEXPOSURE (both the library's
    default today; added if a script lacks them). A script of POSE lines without moving
    objects keeps only its first ``frames`` poses: the metering pass then meters only the
    frames the bench renders, and their exposures and images are those of the whole
    sequence (the auto-exposure looks back, never ahead). MOVE keyframes tie a script to
    its length: such a script (city_kitti) stays whole."""
    lines = (REPO / script).read_text().splitlines()
    if frames is not None and not any(ln.startswith("MOVE") for ln in lines):
        poses = [i for i, ln in enumerate(lines) if ln.startswith("POSE")]
        drop = set(poses[frames:]) if len(poses) > frames else set()
        lines = [ln for i, ln in enumerate(lines) if i not in drop]
    if not any(ln.startswith("SENSOR") for ln in lines):
        lines.append(f"SENSOR profile {profile}")
    if not any(ln.startswith("AUTOEXPOSURE") for ln in lines):
        lines.append("AUTOEXPOSURE")
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{Path(script).stem}_twin.ses"
    path.write_text("\n".join(lines) + "\n")
    return path


def render(script: Path, out: Path, n: int, scale: float, quality: str, start: int = 0) -> float:
    """Render frames start..start+n-1 (resuming); mean seconds per stereo frame rendered in this run."""
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(script), "--out", str(out), "--frames",
           f"{start}:{start + n}",
           "--resume", "--resolution-scale", str(scale), "--quality", quality, "--progress", "json"]
    proc = subprocess.Popen(cmd, cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO)), stderr=subprocess.PIPE,
                            text=True)
    secs = []
    for line in proc.stderr:
        try:
            ev = json.loads(line)
        except ValueError:
            print("  " + line.rstrip(), file=sys.stderr)
            continue
        if isinstance(ev, dict) and ev.get("event") == "progress" and ev.get("wall_s") is not None:
            secs.append(float(ev["wall_s"]))
            print(f"  rendered frame {ev.get('frame')} in {secs[-1]:.0f} s", file=sys.stderr)
    if proc.wait() != 0:
        sys.exit(f"render of {script} failed (exit {proc.returncode})")
    return float(np.mean(secs)) if secs else float("nan")


def resensor(out: Path, n: int, start: int = 0, draw: int = 0) -> Frames:
    """Frames start..start+n-1 of the render in ``out`` through today's camera chain again (its
    EXRs, the scene.ses of the folder parsed with today's profiles, each frame's exposure and
    gain from today's auto-exposure on the recorded metering): the chain runs after Cycles, so a
    changed profile needs no new render. ``draw`` d develops them with the sensor's noise seed
    + d (``--draws``): another draw of the same camera's fixed-pattern and temporal noise; draw 0
    is the rendered sensor images while the chain is unchanged."""
    from blender_sesgen.render.plan import RenderOptions, EffectiveSettings
    from blender_sesgen.render.sensor import pipeline
    from blender_sesgen.render.sensor.outputs import state_relpath
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    from blender_sesgen.ses.parser import parse_text
    from vo_reference.io.color import rgb8_to_gray8
    seq = open_sequence(out)
    scene = parse_text((out / "scene.ses").read_text(), str(out / "scene.ses"), str(out))
    scale = json.loads((out / "manifest.json").read_text())["render"]["resolution_scale"]
    plan = SensorPlan.create(scene, EffectiveSettings.of(scene, RenderOptions(resolution_scale=scale)))
    sensor = dataclasses.replace(plan.sensor, seed=plan.sensor.seed + draw)
    camera = pipeline.Camera(sensor, plan.lens_spec, plan.pixel_rays(), plan.K[0, 2], plan.K[1, 2],
                             plan.nominal_exposure_s())
    # each frame's exposure from today's schedule on the brightness the render metered (a changed
    # auto-exposure target needs no new render; the EXRs' motion blur keeps the rendered length)
    state = lambda k: json.loads((out / state_relpath(k)).read_text())  # noqa: E731
    if plan.autoexposure is not None:
        # the metering pass's brightness of every frame (the manifest; a render of frames K.. holds
        # no state before K), else the frames' own states
        metered = (json.loads((out / "manifest.json").read_text()).get("sensor") or {}).get("metered") or []
        if len(metered) < start + n or any(v is None for v in metered[:start + n - 1]):
            metered = [state(k)["metered"] for k in range(start + n)]
        schedule = plan.exposures(list(metered[:start + n - 1]))
    else:
        schedule = [None] * start + [(st["exposure_s"], st["gain"]) for st in map(state, range(start, start + n))]
    imgs, fpn = {"left": [], "right": []}, {}
    for k in range(start, start + n):
        for vi, view in enumerate(("left", "right")):
            f = pipeline.process(seq.rgb_linear(k, view), camera, pipeline.Shot(*schedule[k], k, vi), fpn_cache=fpn)
            imgs[view].append(rgb8_to_gray8(f.rgb8))
    T = seq.T_world_cam("left")
    return Frames(imgs["left"], imgs["right"], seq.K, seq.baseline_m, None if T is None else T[start:],
                  np.asarray(seq.timestamps_s)[start:])


# --- the table ------------------------------------------------------------------------------

# --draws' default: a draw of 45 city frames costs ~10 CPU s (develop 3.3, image figures 1.7, VOs 5.4;
# docs/sensors.md), 9 of them ~8 % of a 45-frame render's ~1100 CPU s; an odd count has one median draw
DEFAULT_DRAWS = 9


def _cpu_s() -> float:
    """This process's user + system CPU seconds (the draws run in it; the render is a child)."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _sensor_seed(out: Path) -> int:
    """The noise seed of the render's sensor (draw 0's; draw d adds d)."""
    from blender_sesgen.ses.parser import parse_text
    scene = parse_text((out / "scene.ses").read_text(), str(out / "scene.ses"), str(out))
    return int(scene.sensor.seed) if scene.sensor is not None else 0


def _ratio(a, b):
    return a / b if np.isfinite(a) and np.isfinite(b) and b != 0 else float("nan")


VO_FIGURES = (("t_rpe_pct", "translation RPE (median, % of step)", "judged turned, next row"),
              ("t_rpe_turned_pct", "translation RPE, each one's poses' heading turned out (median, % of step)",
               "0.67-1.5"),
              ("r_rpe_deg", "rotation RPE (median, deg/step)", "compare VO against VO"),
              ("drift_pct", "end-point drift (% of path)", ""),
              ("sim3_pct", "Sim(3) position RMSE (% of path)", "0.67-1.5"))


def with_heading_out(figs: dict, T_world_cam: np.ndarray, n: int) -> dict:
    """``figs`` with each VO's translation RPE against its poses turned by the heading the three
    VOs read against them (``gt_noise.heading_offset_rad``: the poses' step's mean lateral offset
    from the VOs' median step). KITTI sequence_1's poses are turned +0.35 deg against its images
    (7.3 mm a step to the right of all three VOs', which agree within 1.2 mm; the render's exact
    poses read 0.00): an error of the poses, not of a VO. The same rule on both sides, so the
    render's figure is its plain one (docs/sensors.md, "The ground truth's own error")."""
    import gt_noise as gn     # bench/gt_noise.py, beside this script
    g = gn.step_vectors(np.asarray(T_world_cam)[:n])
    psi = gn.heading_offset_rad(g, [figs[f"{vo}/steps_m"] for vo in VOS])
    out = dict(figs, heading_rad=psi)
    for vo in VOS:
        out[f"{vo}/t_rpe_turned_pct"] = float(np.median(gn.rpe_pct(gn.turned(g, psi), figs[f"{vo}/steps_m"])))
    return out


def figures(frames: Frames, n: int, with_vo: bool) -> dict[str, float]:
    """The table's figures of one sequence (one draw of the render, or the real excerpt)."""
    st = sequence_stats(frames._img["left"], frames._img["right"])
    out = {"slope": st.slope, "klt": st.klt_fb_median, "clipped": st.clipped, "sgbm": st.sgbm_valid,
           "corners": st.corners}
    if with_vo:
        for vo in VOS:
            out.update({f"{vo}/{k}": v for k, v in vo_errors(frames, vo, n).items()})
    return out


def _rows_spec(with_vo: bool, shake: bool = False) -> list[tuple]:
    """(key, label, value format, comparison 'diff'|'pt'|'ratio', its format, target or '' ,
    the target's test on the comparison). ``shake`` (a standing camera: the hall): the KLT is
    judged at equal shake (``klt_over_shake``), the plain one a row of its own."""
    within = lambda c: abs(c - 1) <= 0.25  # noqa: E731
    klt = [("klt", "KLT forward-backward error (px)", "{:.3f}", "ratio", "{:.2f}", "within 25 %", within)]
    if shake:
        klt = [("klt", "KLT forward-backward error (px)", "{:.4f}", "ratio", "{:.2f}", "judged at equal shake, next row",
                None),
               ("klt_shake", "KLT forward-backward error over EuRoC's at the pair's own shake (median over pairs)",
                "{:.2f}", "ratio", "{:.2f}", "within 25 %", within)]
    spec = [("slope", "power-spectrum slope", "{:.2f}", "diff", "{:+.2f}", "within 0.2", lambda c: abs(c) <= 0.2),
            *klt,
            ("clipped", "pixels at 0 or 255", "pct", "pt", "{:+.1f} pt", "within 2 pt", lambda c: abs(c) <= 2.0),
            ("sgbm", "SGBM valid share", "{:.2f}", "ratio", "{:.2f}", "within 25 %", lambda c: abs(c - 1) <= 0.25),
            ("corners", "Shi-Tomasi corners", "{:.0f}", "ratio", "{:.2f}", "", None)]
    if with_vo:
        for vo in VOS:
            for key, label, target in VO_FIGURES:
                spec.append((f"{vo}/{key}", f"{vo}: {label}", "{:.3f}", "ratio", "{:.2f}", target,
                             (lambda c: 0.67 <= c <= 1.5) if target == "0.67-1.5" else None))
    return spec


def _compare(kind: str, ours: float, real: float) -> float:
    if kind == "diff":
        return ours - real
    if kind == "pt":
        return 100 * (ours - real)
    return _ratio(ours, real)


def table(real_name: str, real: dict, draws: list[dict], size: tuple[int, int], n: int) -> list[str]:
    """The markdown table: per figure the real value, the render's median over the draws
    (``figures`` of each), the comparison of the median draw and, for several draws, the
    comparison's range over them; each target judged on the median comparison (real is one
    draw of its own camera's noise, the render's spread is the draws')."""
    many = len(draws) > 1
    rows = [f"| figure ({n} frames, {size[0]}x{size[1]}) | {real_name} | render"
            + (f" (median of {len(draws)} draws)" if many else "") + " | render / real | "
            + ("range over the draws | " if many else "") + "target |",
            "|---|---|---|---|---|" + ("---|" if many else "")]
    ok = lambda c: "met" if c else "missed"  # noqa: E731
    for key, label, fmt, kind, cfmt, target, test in _rows_spec("orb/t_rpe_pct" in real, "klt_shake" in real):
        vals = np.array([d[key] for d in draws], float)
        comps = np.array([_compare(kind, v, real[key]) for v in vals], float)
        comp = float(np.median(comps)) if np.isfinite(comps).all() else float("nan")
        show = (lambda v: f"{100 * v:.1f} %") if fmt == "pct" else fmt.format
        cell = f"{target}: {ok(test(comp))}" if test is not None else target
        rng = f" {cfmt.format(np.nanmin(comps))} to {cfmt.format(np.nanmax(comps))} |" if many else ""
        rows.append(f"| {label} | {show(real[key])} | {show(float(np.median(vals)))} | {cfmt.format(comp)} |{rng}"
                    f" {cell} |".replace("|  |", "| |"))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="city", choices=sorted(SCENES))
    ap.add_argument("--frames", type=int, default=45)
    ap.add_argument("--scale", type=float, default=0.5, help="--resolution-scale of the render (default 0.5)")
    ap.add_argument("--quality", default="final",
                    help="render preset (default final: draft's denoiser keeps ~0.28 of the crowns' finest band, "
                         "final ~0.55; bench/crown_detail.py --cross)")
    ap.add_argument("--out", default="out/twin")
    ap.add_argument("--no-render", action="store_true", help="use the frames already rendered in --out")
    ap.add_argument("--start", type=int, default=0,
                    help="compare frames K..K+N-1 of both (default 0; city: renders frames K.. of the sequence)")
    ap.add_argument("--resensor", action="store_true",
                    help="run today's camera chain again on the rendered EXRs (after a profile changed)")
    ap.add_argument("--draws", type=int, default=DEFAULT_DRAWS,
                    help=f"develop the EXRs with N sensor-noise seeds (today's chain, as --resensor) and judge "
                         f"the median over them (default {DEFAULT_DRAWS}; 1: the rendered images alone)")
    a = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"real data not found at {DATA} (set SESGEN_SHARED_DATA)", file=sys.stderr)
        return 2
    script, profile = SCENES[a.scene]
    if a.start < 0:
        print(f"--start: 0 or more, got {a.start}", file=sys.stderr)
        return 2
    if a.draws < 1:
        print(f"--draws: 1 or more, got {a.draws}", file=sys.stderr)
        return 2
    if profile == "euroc":
        have = len(list((DATA / "euroc" / "mav0" / "cam0" / "data").glob("*.png")))
        if a.start + 3 > have:
            print(f"--start {a.start}: the EuRoC excerpt has {have} frames; compare from frame {max(have - 3, 0)} "
                  f"at the latest (3 frames at least)", file=sys.stderr)
            return 2
    if profile == "kitti":
        have = open_sequence(DATA / "kitti" / "sequence_1").num_frames
        if a.start + 3 > have:
            print(f"--start {a.start}: KITTI sequence_1 has {have} frames; compare from frame {max(have - 3, 0)} "
                  f"at the latest (3 frames at least)", file=sys.stderr)
            return 2
    out = REPO / a.out / a.scene
    t0 = time.perf_counter()
    secs = float("nan") if a.no_render else render(twin_script(script, profile, REPO / a.out, a.start + a.frames),
                                                   out, a.frames, a.scale, a.quality, a.start)
    seq = open_sequence(out)
    n = 0
    while n < min(a.frames, seq.num_frames - a.start) and seq.frame_complete(a.start + n):
        n += 1
    if n < 3:
        print(f"{out}: only {n} frame(s) rendered completely; render more (without --no-render)", file=sys.stderr)
        return 2
    if profile == "kitti":
        real_seq = open_sequence(DATA / "kitti" / "sequence_1")
        n = min(n, real_seq.num_frames - a.start)
        real, name = resized(real_seq, n, tuple(seq.resolution), a.start), "real KITTI sequence_1"
        reductions = None if a.start else slope_by_reduction(real_seq, n, tuple(seq.resolution))
    else:
        real, name = euroc_rectified(n, tuple(seq.resolution), a.start), "real EuRoC V1_01"
        n = min(n, real.num_frames)
    with_vo = profile == "kitti"
    # the hall's standing camera: its KLT judged at equal shake, on EuRoC's own line of error
    # against shift (its compared frames 30-49 are its calm spell; the twin's shake is drawn)
    real_all = euroc_rectified(have, tuple(seq.resolution)) if profile == "euroc" else None
    fit = shake_fit(real_all) if real_all is not None else None
    draw_figs, cpu_s = [], []
    for d in range(a.draws):
        c0 = _cpu_s()
        frames = (resensor(out, n, a.start, d) if a.resensor or a.draws > 1
                  else resized(seq, n, tuple(seq.resolution), a.start))
        draw_figs.append(figures(frames, n, with_vo))
        if fit is not None:
            draw_figs[-1]["klt_shake"] = klt_over_shake(frames, n, fit)
        if with_vo:
            draw_figs[-1] = with_heading_out(draw_figs[-1], frames.T_world_cam("left"), n)
        cpu_s.append(_cpu_s() - c0)
        if d == 0:
            ours = frames     # the cause lines below: draw 0
    seed0 = _sensor_seed(out)
    print(f"\n### {script} + SENSOR profile {profile} (--resolution-scale {a.scale:g}, --quality {a.quality}) "
          f"vs {name}" + (f", frames {a.start}-{a.start + n - 1} of both" if a.start else "") + "\n")
    real_figs = figures(real, n, with_vo)
    if fit is not None:
        real_figs["klt_shake"] = klt_over_shake(real, n, fit)
    if with_vo:
        real_figs = with_heading_out(real_figs, real.T_world_cam("left"), n)
    print("\n".join(table(name, real_figs, draw_figs, tuple(seq.resolution), n)))
    if a.draws > 1:
        print(f"\nrender: the same EXRs developed {a.draws} times through the camera chain, sensor noise seeds "
              f"{seed0}..{seed0 + a.draws - 1} (fixed pattern and temporal noise); each target is judged on the "
              f"median draw's figure. {name} is one draw of its own camera's noise: its figures would move as much, "
              f"which one excerpt cannot show. Lines below: draw 0.")
    print(f"sensor-noise draws: {a.draws}, {np.mean(cpu_s):.1f} CPU s each (develop + figures"
          + (" + three VOs" if with_vo else "") + f", {n} frames)")
    if with_vo and n >= 4:
        print(klt_at_speed(real, ours, n, real_figs["klt"]))
    if profile == "euroc":
        print(klt_at_shake(real_all, ours, n, a.start, fit=fit))
    if with_vo:
        for line in (vo_cause_lines(name, real, ours, real_figs, draw_figs, n) + gt_error_lines(name, real, ours, real_figs,
                                                                                                draw_figs, n)
                     + orb_kind_lines(out, real, ours, name, n, a.start) + orb_near_lines(real, ours, name, n, a.start)):
            print(line)
    print(f"\nbrightness spread (median / mean of the linear signal): {name} {brightness_spread(real, profile, n):.2f}, "
          f"render {brightness_spread(ours, profile, n):.2f}")
    print(f"headroom (full scale over the frame mean of the linear signal, median): {name} "
          f"{headroom(real, profile, n):.2f}, render {headroom(ours, profile, n):.2f}")
    if profile == "kitti" and a.start:
        print(f"(--start {a.start}: the region and brightness lines below read frames from 0 and KITTI's hand-marked "
              f"frames 0, 20, 40: left out)")
    if profile == "kitti" and not a.start:
        kr, ko = kinds_brightness(out, ours, real, n)
        print(f"brightness over the frame mean (median): real KITTI sequence_1 (hand-marked sunlit regions, frames "
              f"0, 20, 40) {kr}; render (by object id, sun and shade) {ko}")
        print(f"render's building pixels over the frame mean (its sunlit walls are its upper quantiles): "
              f"{facade_brightness(out, ours, n)}")
        print(f"spectrum slope of {name} by how it is brought to {seq.resolution[0]} px wide (mean): {reductions}")
        print(f"ring power over the frame mean squared, {name} over the render (cycles per image height): "
              f"{ring_power_ratio(real, ours, n)}")
        br, bo = band_power_by_region(out, real, ours, n)
        print(f"contrast power by region and band (the frame over its mean, band-passed; mean square in the "
              f"region, median over frames): {br}; {bo}")
        cr, co = band_power_by_cell(real, ours, n)
        print(f"top band's contrast power by ninth of the frame ({REGION_BANDS[-1][0]}-{REGION_BANDS[-1][1]} "
              f"cycles; rows top to bottom, left to right): KITTI / render {cr}; x 1e4 {co}")
        gr, go = road_grain(out, ours, n)
        print(f"sunlit road's pixel-scale contrast (robust deviation over the 5 x 5 mean): real KITTI sequence_1 "
              f"{gr:.3f}, render {go:.3f}")
        qr, qo = kinds_grain(out, ours, n)
        print(f"pixel-scale contrast by kind (robust deviation over the 5 x 5 mean): real KITTI sequence_1 "
              f"(hand-marked sunlit regions, frames 0, 20, 40) {qr}; render (by object id, sun and shade) {qo}")
        sr, so = street_surfaces(out, ours, n)
        print(f"street surfaces over the sunlit road (median linear signal; in brackets the pixel-scale contrast): "
              f"real KITTI sequence_1 (hand-marked, frames 0, 12) {sr}; render (by asset kind, sunlit) {so}")
    c = corners_on_depth_edges(out, ours, n, a.start)
    print(f"render: {100 * c['edge_share']:.0f} % of the OpenCV VO's corners on depth edges; SGBM disparity error "
          f"there {c['edge_err_pct']:+.2f} %, on surfaces {c['surface_err_pct']:+.2f} % (median, of the true disparity)")
    er, eo = corners_on_sgbm_edges(real, n), corners_on_sgbm_edges(ours, n)
    print(f"corners on SGBM disparity discontinuities (both, the same rule): {name} {100 * er['edge_share']:.0f} % "
          f"({100 * er['near_edge_share']:.0f} % of those nearer than 15 m), render {100 * eo['edge_share']:.0f} % "
          f"({100 * eo['near_edge_share']:.0f} %)")
    cr, co = corners_by_region(real, n), corners_by_region(ours, n)
    print("corners by region (the OpenCV VO's detector, mean a frame; " + ", ".join(REGIONS) + f"): {name} "
          + " / ".join(f"{c:.0f}" for c in cr) + ", render " + " / ".join(f"{c:.0f}" for c in co))
    print(f"\nseconds per stereo frame rendered: {secs:.0f}; bench wall time {time.perf_counter() - t0:.0f} s; "
          f"load {open('/proc/loadavg').read().split()[0]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
