"""Split a still camera's frame-to-frame difference in a render: the sensor model against the
path tracer (docs/sensors.md, "Camera profiles": a still render's frame difference, split).

    python bench/still_split.py RENDER [--frames 30,31] [--again RENDER2]

RENDER is a render folder with EXRs (``render`` or ``bench/twin.py``'s ``--out``/SCENE). For
each pair of consecutive frames it prints the mean absolute difference (DN, left view, the
sensor's 8-bit grey) of: the frames developed through today's camera chain as rendered;
one frame's EXR developed with two sensor-noise seeds (the sensor model alone); the frames
developed without noise (the path tracer's per-frame noise and the camera's motion), on flat
pixels (gradient < 1 DN/px) and on edges (> 5 DN/px) apart; and the median KLT
forward-backward error (px) of each; where the camera only turns between the frames (the
standing MAV), also the first frame's EXR moved by the poses' turns (:func:`rotation_warp`)
instead of each frame rendered anew. ``--again`` names a folder holding the same frames
rendered with another Cycles seed (``render --seed``): the same pose developed alike, so the
path tracer alone. Every frame is developed at the first frame's exposure and gain (recorded
state): only the image changes.

    python bench/still_split.py --motion [SCRIPT]

prints the standing camera's frame-to-frame motion of the EuRoC V1_01 excerpt (both cameras,
frames 0-5 still and 5-94 shaken by the rotors; :func:`image_turn`) beside that of SCRIPT's
poses (default scenes/hall.ses, its first ``STAND_FRAMES``), as turns about the camera's own
axes: right (the image's vertical shift), down (horizontal shift) and its optical axis (roll).
"""
from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import sys
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))

from blender_sesgen.contract.se3 import so3_log  # noqa: E402


def turns_of_images(frames: list[np.ndarray], K: np.ndarray) -> np.ndarray:
    """(n-1, 3) turns (deg) of a camera of intrinsics K between consecutive images about its own
    right, down and optical axes (x right, y down, z ahead): :func:`image_turn` of each pair."""
    return np.array([image_turn(a, b, K) for a, b in zip(frames, frames[1:])])


def image_turn(a: np.ndarray, b: np.ndarray, K: np.ndarray, iterations: int = 12) -> np.ndarray:
    """The turn (deg, about the camera's own x right, y down, z ahead) that takes image ``a`` to
    ``b`` when the camera only rotates: Gauss-Newton on the rotation's homography K R^T K^-1
    (three unknowns) with a gain and offset between the two images, on all pixels after a
    Gaussian of 1 px (EuRoC's standing frames are rotation-only: the near floor and the far
    window shift alike). Not a shift over the focal: at EuRoC's +-40 deg across, a turn about
    the down axis moves the image's edges 1.74 x its centre, and a rigid fit read it 1.36 x;
    nor ECC's 8-parameter homography, whose nearest rotation let cam0 and cam1 differ by 0.0075
    deg (median) in the turn about the right axis."""
    K = np.asarray(K, float)
    A = cv2.GaussianBlur(a.astype(np.float32), (0, 0), 1.0)
    B = cv2.GaussianBlur(b.astype(np.float32), (0, 0), 1.0)
    H_, W_ = A.shape
    u, v = np.meshgrid(np.arange(W_, dtype=float), np.arange(H_, dtype=float))
    x = np.stack([u.ravel(), v.ravel(), np.ones(u.size)])
    Ki = np.linalg.inv(K)

    def where(w):      # pixels of b where a's pixels land when the camera turns by w (rad)
        p = K @ cv2.Rodrigues(np.asarray(w, float))[0].T @ Ki @ x
        return p[0] / p[2], p[1] / p[2]

    eps = 1e-6
    base = where(np.zeros(3))
    moved = [where(np.eye(3)[i] * eps) for i in range(3)]
    # d(where)/dw as six 1-D columns (u and v by each of w's three); the normal equations are built
    # on the usable pixels only, by 1-D takes: the same sums as the full (N, 5) matrix, ~1.4 x faster
    # (the suite reads 300 pairs)
    J = [[(moved[i][k] - base[k]) / eps for i in range(3)] for k in range(2)]
    Af = A.ravel()
    a_lit = Af < 250
    w = np.zeros(3)
    for _ in range(iterations):
        pu, pv = where(w)
        Bw = cv2.remap(B, pu.reshape(H_, W_).astype(np.float32), pv.reshape(H_, W_).astype(np.float32), cv2.INTER_LINEAR)
        gy, gx = np.gradient(Bw)
        Bf = Bw.ravel()
        ok = np.flatnonzero((pu > 2) & (pu < W_ - 3) & (pv > 2) & (pv < H_ - 3) & a_lit & (Bf < 250))
        gu, gv = gx.ravel().take(ok).astype(float), gy.ravel().take(ok).astype(float)
        M = np.empty((5, ok.size))                   # rows: d(b at the warp)/dw (3), gain, offset
        for i in range(3):
            np.add(gu * J[0][i].take(ok), gv * J[1][i].take(ok), out=M[i])
        M[3] = -Af.take(ok)
        M[4] = -1.0
        r = Bf.take(ok) - Af.take(ok)
        sol = np.linalg.solve(M @ M.T, -M @ r)
        w = w + sol[:3]
        if np.abs(sol[:3]).max() < 2e-7:       # 0.0001 px at 436 px
            break
    return np.degrees(w)


def rotation_warp(img: np.ndarray, T_world_a: np.ndarray, T_world_b: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Image ``img`` (H x W or H x W x C) taken from pose a as the camera sees it from pose b
    when it only turned (same position; OpenCV camera frames): the homography K R^T K^-1, R = a's
    rotation to b's, sampled by cubic splines (scipy; OpenCV's cubic kernel moved EuRoC's frame
    1.18 x the turn as image_turn reads it, its bilinear one blurs by the sub-pixel phase),
    borders reflected. Exact for a pinhole camera up to the pixel filter and view-dependent
    shading over the turn (hundredths of a degree on the stand)."""
    from scipy import ndimage
    R = np.asarray(T_world_a)[:3, :3].T @ np.asarray(T_world_b)[:3, :3]
    Hi = np.asarray(K, float) @ R @ np.linalg.inv(K)        # pixel in b -> where it was in a
    src = np.asarray(img, float)
    h, w = src.shape[:2]
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    p = Hi @ np.stack([u.ravel(), v.ravel(), np.ones(u.size)])
    at = [(p[1] / p[2]).reshape(h, w), (p[0] / p[2]).reshape(h, w)]
    planes = src[..., None] if src.ndim == 2 else src
    out = np.stack([ndimage.map_coordinates(planes[..., c], at, order=3, mode="reflect")
                    for c in range(planes.shape[-1])], axis=-1)
    return out[..., 0].astype(np.float32) if src.ndim == 2 else out.astype(np.float32)


def turns_of_poses(T_world_cam: np.ndarray) -> np.ndarray:
    """(n-1, 3) turns (deg) between consecutive camera poses (T_world_cam, OpenCV camera frame
    x right, y down, z ahead) about the camera's own right, down and optical axes; the sense
    that makes :func:`turns_of_images` of the images they take read the same."""
    R = np.asarray(T_world_cam, float)[:, :3, :3]
    return np.degrees(so3_log(np.swapaxes(R[:-1], -1, -2) @ R[1:]))


def motion_figures(turns: np.ndarray) -> dict:
    """Per axis (right, down, optical) of (n, 3) turns (deg): s.d., median and p90 of |turn|."""
    a = np.abs(turns)
    return {"sd": turns.std(axis=0), "median": np.median(a, axis=0), "p90": np.percentile(a, 90, axis=0)}


EUROC_ROTORS_FRAME = 6    # V1_01's frames 0-5 differ by the sensor's noise only; the rotors shake it from 6 on


@functools.lru_cache(maxsize=2)
def euroc_standing_turns(view: str = "left") -> tuple[np.ndarray, float]:
    """EuRoC V1_01's 95 standing frames (rectified, full size): the turns between consecutive
    frames (:func:`turns_of_images`, 94 rows: row k is frames k -> k+1) and the focal (px)."""
    from realism import euroc_frames      # bench/realism.py, beside this script
    _, L, R = euroc_frames(95)
    P = euroc_rectified_P()
    return turns_of_images(L if view == "left" else R, P[:, :3]), float(P[0, 0])


def euroc_rectified_P() -> np.ndarray:
    """The rectified left camera's 3 x 4 projection (bench/realism.py's EuRoC rectification, P1)."""
    from realism import euroc_rectification
    return euroc_rectification()[1][2]


def _motion_lines(script: Path) -> list[str]:
    from blender_sesgen.ses.parser import parse_text
    from blender_sesgen.generators.builtin.hall import STAND_FRAMES
    lines = []
    for view in ("left", "right"):
        t, f = euroc_standing_turns(view)
        for name, rows in (("still 0-5", t[:EUROC_ROTORS_FRAME - 1]), ("shaken 5-94", t[EUROC_ROTORS_FRAME - 1:])):
            lines.append(_figure_line(f"EuRoC V1_01 cam{'01'[view == 'right']} {name}", rows, f))
    scene = parse_text(script.read_text(), str(script), str(script.parent))
    T = scene.timeline.left()[:STAND_FRAMES]
    lines.append(_figure_line(f"{script.name} poses 5-{STAND_FRAMES - 1}", turns_of_poses(T)[EUROC_ROTORS_FRAME - 1:], f))
    return lines


def _figure_line(name: str, turns: np.ndarray, f: float) -> str:
    m = motion_figures(turns)
    ac = [np.corrcoef(turns[:-1, i], turns[1:, i])[0, 1] for i in range(3)]
    return (f"{name}: " + "; ".join(f"{ax} sd {m['sd'][i]:.4f} median {m['median'][i]:.4f} p90 {m['p90'][i]:.4f} "
                                    f"(median {np.radians(m['median'][i]) * f:.3f} px) lag-1 {ac[i]:+.2f}"
                                    for i, ax in enumerate(("right", "down", "optical"))) + " (deg)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("render", type=Path, nargs="?")
    ap.add_argument("--motion", nargs="?", const=REPO / "scenes" / "hall.ses", type=Path, metavar="SCRIPT",
                    help="EuRoC's standing frame-to-frame turns beside SCRIPT's (default scenes/hall.ses)")
    ap.add_argument("--frames", default="30,31", help="frames, comma-separated (default 30,31)")
    ap.add_argument("--again", type=Path, help="the same frames rendered with another Cycles seed")
    a = ap.parse_args(argv)
    if a.motion is not None:
        if not a.motion.is_file():
            print(f"--motion: no script at {a.motion}", file=sys.stderr)
            return 2
        print("\n".join(_motion_lines(a.motion)))
        return 0
    if a.render is None:
        print("name a render folder (or --motion)", file=sys.stderr)
        return 2
    try:
        frames = [int(x) for x in a.frames.split(",")]
    except ValueError:
        print(f"--frames: integers separated by commas, got {a.frames!r}", file=sys.stderr)
        return 2
    for folder in [a.render] + ([a.again] if a.again else []):
        missing = [k for k in frames if not (folder / "exr" / "left" / f"{k:06d}.exr").is_file()]
        if not (folder / "scene.ses").is_file() or missing:
            print(f"{folder}: not a render folder holding the EXRs of frames {frames}", file=sys.stderr)
            return 2
    from blender_sesgen.render.plan import EffectiveSettings, RenderOptions
    from blender_sesgen.render.sensor import pipeline, raw
    from blender_sesgen.render.sensor.autoexposure import LUMA
    from blender_sesgen.render.sensor.outputs import state_relpath
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    from blender_sesgen.ses.parser import parse_text
    from vo_reference.evaluate.realism import klt_fb_error
    from vo_reference.io.color import rgb8_to_gray8
    from vo_reference.io.sequence import open_sequence

    out = a.render
    scene = parse_text((out / "scene.ses").read_text(), str(out / "scene.ses"), str(out))
    if scene.sensor is None:
        print(f"{out}: the scene has no SENSOR: nothing to split", file=sys.stderr)
        return 2
    scale = json.loads((out / "manifest.json").read_text())["render"]["resolution_scale"]
    plan = SensorPlan.create(scene, EffectiveSettings.of(scene, RenderOptions(resolution_scale=scale)))
    S = plan.sensor
    cam = pipeline.Camera(S, plan.lens_spec, plan.pixel_rays(), plan.K[0, 2], plan.K[1, 2], plan.nominal_exposure_s())
    state_file = out / state_relpath(frames[0])
    state = json.loads(state_file.read_text()) if state_file.is_file() else {}
    exposure_s = float(state.get("exposure_s", plan.nominal_exposure_s()))
    gain = float(state.get("gain", 1.0))

    def developed(linear, k, seed):
        c = dataclasses.replace(cam, sensor=dataclasses.replace(S, seed=seed))
        return rgb8_to_gray8(pipeline.process(linear, c, pipeline.Shot(exposure_s, gain, k, 0)).rgb8)

    def noiseless(linear):
        """The chain's 8-bit grey without noise or quantisation (a colour sensor: the luma of the
        signal, before its mosaic)."""
        img = pipeline.optical_image(linear, cam.lens, S, cam.rays, cam.cx, cam.cy)
        ratio = exposure_s / cam.nominal_exposure_s if cam.nominal_exposure_s > 0 else 1.0
        e = (np.clip(img, 0.0, None) * (S.full_well_e / S.saturation * ratio)) @ LUMA
        full = 2 ** S.bits - 1
        raw_dn = np.clip(S.black_level_dn + e * raw.conversion_gain(S.full_well_e, S.bits, gain), 0.0, full)
        pedestal = S.black_level_dn / full
        x = (raw_dn - S.black_level_dn) / (full - S.black_level_dn)
        return 255.0 * (pedestal + (1.0 - pedestal) * raw.response(x, S.response, S.gamma))

    def parts(x, y):
        grad = np.hypot(*np.gradient(x))
        ok = (x < 254) & (y < 254)
        d = np.abs(x - y)
        return f"{d.mean():.2f} (flat {d[ok & (grad < 1)].mean():.2f}, edges {d[ok & (grad > 5)].mean():.2f})"

    seq = open_sequence(out)
    lin = {k: seq.rgb_linear(k, "left") for k in frames}
    dev = {k: developed(lin[k], k, S.seed) for k in frames}
    clean = {k: noiseless(lin[k]) for k in frames}
    print(f"{out}: {getattr(S, 'profile', None) or 'SENSOR'} at {seq.resolution[0]} px wide, "
          f"exposure {exposure_s * 1e3:.2f} ms, gain {gain:g}")
    T = seq.T_world_cam("left")
    K = np.asarray(seq.K, float)
    for k0, k1 in zip(frames, frames[1:]):
        print(f"frames {k0}-{k1}: developed {np.abs(dev[k0].astype(float) - dev[k1]).mean():.2f} DN "
              f"(KLT {klt_fb_error(dev[k0], dev[k1]):.4f} px); without noise {parts(clean[k0], clean[k1])}")
        if np.abs(T[k0][:3, 3] - T[frames[0]][:3, 3]).max() < 1e-9 and np.abs(T[k1][:3, 3] - T[frames[0]][:3, 3]).max() < 1e-9:
            # the camera only turned: frame k's image is frame frames[0]'s moved by the turn's homography
            w0, w1 = (developed(rotation_warp(lin[frames[0]], T[frames[0]], T[k], K), k, S.seed) for k in (k0, k1))
            print(f"  frame {frames[0]}'s EXR moved by the poses' turns instead (the camera only turns): "
                  f"developed {np.abs(w0.astype(float) - w1).mean():.2f} DN (KLT {klt_fb_error(w0, w1):.4f} px)")
    for k in frames:
        other = developed(lin[k], k, S.seed + 1)
        line = (f"frame {k}: sensor model alone (two noise seeds) {np.abs(dev[k].astype(float) - other).mean():.2f} DN "
                f"(KLT {klt_fb_error(dev[k], other):.4f} px)")
        if a.again:
            lin2 = open_sequence(a.again).rgb_linear(k, "left")
            dev2 = developed(lin2, k, S.seed + 1)
            line += (f"; path tracer alone (two Cycles seeds) without noise {parts(clean[k], noiseless(lin2))}, "
                     f"developed {np.abs(dev[k].astype(float) - dev2).mean():.2f} "
                     f"(KLT {klt_fb_error(dev[k], dev2):.4f} px)")
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
