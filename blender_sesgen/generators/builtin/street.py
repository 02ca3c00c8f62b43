"""Writes scenes/street.ses: a 300-step drive down a textured street with gentle turns.

The path comes first (EGO lines: forward 0.2-0.4 m/frame, turns of at most 0.35 deg/frame,
small pitch/roll/vertical bumps that average out); the street is then laid along the
integrated path: ground and facade quads every 10 frames, poles, lamps and parked boxes
beside the road. Run: python -m blender_sesgen.generators.builtin.street > scenes/street.ses

As a scene generator (``python -m blender_sesgen generate street --count N --seed S``):
``generate(seed, kitti=False, steps=300)`` returns the script; seed 0 is street.ses itself,
any other seed varies the drive (speed, the number, places, sizes and directions of the
bends), the facades (heights, tints, texture order), the parked cars, the time of day (sun
and sky) and sometimes adds fog. ``steps`` shortens or lengthens the drive.

``--kitti`` writes scenes/street_kitti.ses instead: the same street and drive seen by a rig with
KITTI odometry's geometry (1226x370 px, f = 707 px, baseline 0.54 m) at KITTI's speed
(every 4th frame of the drive: 50 steps of ~1.2 m, 62 m) - the real KITTI excerpt's setting
with exact ground truth (docs/stereo-vo.md).
"""
from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np

from ...contract.frames import start_pose
from ...contract.motion import ego_from_poses, integrate_ego

STEPS = 300
HALF_WIDTH = 7.0          # facades this far left/right of the path (m)
EYE_HEIGHT = 1.5
FACADE_TEXTURES = (3, 8, 11, 7, 1, 5, 12, 2, 6, 9)


@dataclass(frozen=True)
class Variation:
    """What a seed changes; the defaults are street.ses's (seed 0)."""
    steps: int = STEPS
    speed: tuple = (0.3, 0.1)            # mean and amplitude of W (m/frame)
    bends: tuple = ((0.3, 0.08, 0.35), (0.72, 0.1, -0.35))   # (where 0..1, width, yaw deg/frame; + = left)
    layout_seed: int = 7                 # facade heights and tints, parked cars
    facades: tuple = FACADE_TEXTURES
    sun: tuple | None = None             # (elevation, azimuth) in degrees; None: street.ses's sun and sky
    fog: tuple | None = None             # (start, end) in metres

    @classmethod
    def of(cls, seed: int, steps: int = STEPS) -> "Variation":
        if seed == 0:
            return cls(steps=steps)
        rng = np.random.default_rng(seed)
        mean = float(rng.uniform(0.2, 0.45))
        bends = []
        for where in np.sort(rng.uniform(0.15, 0.85, int(rng.integers(1, 4)))):
            bends.append((round(float(where), 3), round(float(rng.uniform(0.05, 0.12)), 3),
                          round(float(rng.uniform(0.15, 0.45) * rng.choice([-1, 1])), 3)))
        fog = None
        if rng.uniform() < 0.3:
            start = float(rng.uniform(15, 50))
            fog = (round(start, 1), round(start + float(rng.uniform(60, 200)), 1))
        return cls(steps=steps, speed=(round(mean, 3), round(float(rng.uniform(0.02, min(0.12, mean - 0.1))), 3)),
                   bends=tuple(bends), layout_seed=int(rng.integers(2**31)),
                   facades=tuple(int(t) for t in rng.permutation(FACADE_TEXTURES)),
                   sun=(round(float(rng.uniform(10, 65)), 1), round(float(rng.uniform(0, 360)), 1)), fog=fog)


def _wobble(amplitude_deg: float, cycles: float, phase: float = 0.0, steps: int = STEPS) -> np.ndarray:
    """Per-step increments of the angle A*sin(2 pi cycles k/steps + phase) - A*sin(phase):
    the accumulated angle oscillates about zero (no net tilt, so no drift in height)."""
    k = np.arange(steps + 1) / steps
    angle = amplitude_deg * np.sin(2 * np.pi * cycles * k + phase)
    return np.diff(angle)


def ego_rows(v: Variation = Variation()) -> np.ndarray:
    n = v.steps
    s = (np.arange(n) + 0.5) / n
    if v == Variation(steps=n):   # street.ses's bends, computed as they always were
        turn = 0.35 * (np.exp(-((s - 0.3) / 0.08) ** 2) - np.exp(-((s - 0.72) / 0.1) ** 2))  # left, then right
    else:
        turn = sum(a * np.exp(-((s - c) / w) ** 2) for c, w, a in v.bends)
    mean, amp = v.speed
    return np.column_stack([
        0.004 * np.sin(2 * np.pi * 7 * s + 0.4),            # U: slight lateral sway
        0.003 * np.sin(2 * np.pi * 11 * s + 1.1),           # V: road bumps (y down)
        mean + amp * np.sin(2 * np.pi * 2 * s - 0.5),       # W: speed (street.ses: 0.2-0.4 m/frame)
        _wobble(0.4, 9, steps=n),                            # alpha: pitch, about +-0.4 deg
        -turn + _wobble(0.3, 5, steps=n),                    # beta: yaw (+ = turn right): the bends
        _wobble(0.3, 6, 0.7, steps=n),                       # gamma: roll
    ]).round(4)


def fmt(*values) -> str:
    return " ".join(f"{v:.3f}".rstrip("0").rstrip(".").replace("-0", "0") if abs(v) < 5e-4 else
                    f"{v:.3f}".rstrip("0").rstrip(".") for v in values)


KITTI_STRIDE, KITTI_STEPS = 4, 50


def street_axis(T: np.ndarray) -> tuple[list, list]:
    """Street axis samples (points on the ground, unit headings): every 10 frames of the
    drive ``T``, plus 60 m beyond both ends along the end headings."""
    pts, heads = [], []
    for k in range(0, len(T), 10):
        fwd = T[k][:3, 2] * [1, 0, 1]
        pts.append(T[k][:3, 3] * [1, 0, 1])
        heads.append(fwd / np.linalg.norm(fwd))
    for i in range(1, 7):
        pts.insert(0, pts[0] - 10.0 * heads[0]); heads.insert(0, heads[0])
        pts.append(pts[-1] + 10.0 * heads[-1]); heads.append(heads[-1])
    return pts, heads


def drive(kitti: bool = False, v: Variation = Variation()) -> tuple[np.ndarray, np.ndarray]:
    """(EGO rows, T_world_left of the drive: street.ses's 300 steps, or the variation's);
    with ``kitti`` the rows are those of every KITTI_STRIDE-th frame (the poses T stay those
    of the full drive)."""
    rows = ego_rows(v)
    T = integrate_ego(start_pose((0.0, EYE_HEIGHT, 0.0)), rows)
    if kitti:  # one step per KITTI_STRIDE frames of the same drive (exactly the same poses)
        rows = np.array([ego_from_poses(T[k], T[k + KITTI_STRIDE])
                         for k in range(0, KITTI_STRIDE * KITTI_STEPS, KITTI_STRIDE)])
    return rows, T


def generate(seed: int = 0, kitti: bool = False, steps: int = STEPS) -> str:
    """The script of the street for ``seed`` (see the module docstring): seed 0 gives
    scenes/street.ses (scenes/street_kitti.ses with ``kitti``)."""
    if int(seed) < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    if kitti and steps < KITTI_STRIDE * KITTI_STEPS:
        raise ValueError(f"kitti needs a drive of at least {KITTI_STRIDE * KITTI_STEPS} steps, got {steps}")
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    return "\n".join(street_lines(kitti, v=Variation.of(int(seed), int(steps)), seed=int(seed))) + "\n"


def street_lines(kitti: bool = False, crossing: tuple[int, int] | None = None, v: Variation = Variation(),
                 seed: int = 0) -> list[str]:
    """The script's lines. ``crossing`` (i0, i1): no facades along axis segments i0..i1-1 on
    either side, where a cross street (gravel, 40 m each way) meets this one. ``v``: what
    the seed ``seed`` varies (the default: street.ses)."""
    rows, T = drive(kitti, v)
    pts, heads = street_axis(T)
    up = np.array([0.0, 1.0, 0.0])
    if kitti:
        head = ["// street_kitti.ses - street.ses's street and drive with KITTI odometry's rig and speed:",
                "// 1226x370 px, f 707 px, baseline 0.54 m, 50 steps of ~1.2 m (every 4th frame of street.ses).",
                "// Generated by blender_sesgen/generators/builtin/street.py --kitti (edit that, not this file). Y up, metres.",
                "CAMERA resolution 1226 370 focal 707 baseline 0.54 near 0.1 far 500"]
    else:
        head = ["// street.ses - a 300-step (301-frame) drive down a textured street with gentle turns, for VO.",
                "// Generated by blender_sesgen/generators/builtin/street.py (edit that, not this file). Y up, metres.",
                "// Forward 0.2-0.4 m/frame, a left then a right bend (<= 0.4 deg/frame), small bumps and sway.",
                "CAMERA resolution 640 480 focal 389 baseline 0.5 near 0.1 far 500"]
    if seed:
        head[0] = (f"// street, seed {seed}: a {v.steps}-step drive down a textured street (generated: the seed "
                   "varies the drive, facades, cars, sun and fog).")
        head[1] = f"// Generated by blender_sesgen/generators/builtin/street.py: generate(seed={seed}, kitti={kitti}, steps={v.steps})."
    out = head + [f"START position 0 {EYE_HEIGHT} 0"] + sun_and_sky(v) + [""]
    next_id = 1
    rng = np.random.default_rng(v.layout_seed)
    out.append("// road (gravel) and facades (textures 1-12), one segment per 10 m-ish")
    for i in range(len(pts) - 1):
        a, b = pts[i], pts[i + 1]
        ra, rb = np.cross(heads[i], up), np.cross(heads[i + 1], up)  # right-hand side of the street
        La, Ra, Lb, Rb = a - HALF_WIDTH * ra, a + HALF_WIDTH * ra, b - HALF_WIDTH * rb, b + HALF_WIDTH * rb
        out.append(f"QUAD id {next_id} texture 10 colour 0.8 0.8 0.8 vertices {fmt(*La, *Ra, *Rb, *Lb)}")
        next_id += 1
        for side, (p, q) in (("left", (La, Lb)), ("right", (Ra, Rb))):
            h = float(rng.uniform(7, 14))
            tex = v.facades[(i * 3 + (side == "right") * 5) % len(v.facades)]
            col = rng.uniform(0.7, 1.0, 3)
            if crossing is not None and crossing[0] <= i < crossing[1]:
                continue  # the cross street's mouth (the random draws above keep the rest unchanged)
            top_p, top_q = p + h * up, q + h * up
            out.append(f"QUAD id {next_id} texture {tex} colour {fmt(*col)} vertices {fmt(*p, *q, *top_q, *top_p)}")
            next_id += 1
    end = pts[-1]
    r_end = np.cross(heads[-1], up)
    out.append(f"QUAD id {next_id} texture 3 vertices "
               f"{fmt(*(end + HALF_WIDTH * r_end), *(end - HALF_WIDTH * r_end), *(end - HALF_WIDTH * r_end + 12 * up), *(end + HALF_WIDTH * r_end + 12 * up))}")
    next_id = 1000
    out += ["", "// street furniture: poles with lamps, parked boxes, a few bollards"]
    for i in range(1, len(pts) - 1):
        if crossing is not None and crossing[0] - 1 <= i <= crossing[1]:
            continue  # keep the cross street's mouth clear
        r = np.cross(heads[i], up)
        yaw = float(np.degrees(np.arctan2(-heads[i][0], -heads[i][2])))  # local z along the street
        for sgn in (-1, 1):
            if i % 2 == (sgn > 0):
                base = pts[i] + sgn * 5.0 * r
                out.append(f"CYLINDER id {next_id} texture 6 colour 0.6 0.6 0.6 position {fmt(*(base + 2.0 * up))} dim 0.12 4")
                out.append(f"SPHERE id {next_id + 1} texture 2 colour 1 1 0.8 position {fmt(*(base + 4.2 * up))} dim 0.3")
                next_id += 2
            if (i + (sgn > 0)) % 3 == 0:
                car = pts[i] + 0.5 * (pts[i + 1] - pts[i]) + sgn * 3.6 * r
                size = rng.uniform([1.7, 1.3, 3.8], [1.9, 1.6, 4.6])
                out.append(f"CUBOID id {next_id} texture {int(rng.choice([4, 9, 12]))} colour {fmt(*rng.uniform(0.5, 1, 3))} "
                           f"position {fmt(*(car + size[1] / 2 * up))} 0 {yaw:.1f} 0 dim {fmt(*size)}")
                next_id += 1
    if crossing is not None:
        out += ["", "// the cross street: a gravel road and facades along it, 40 m each way"]
        out += cross_street_lines(pts, heads, crossing, 900)
    out += ["", "// the drive: EGO U V W alpha beta gamma (camera frame: x right, y down, z forward; degrees)"]
    out += [f"EGO {' '.join(f'{x:.6f}' for x in row)}" if kitti else f"EGO {fmt(*row)}" for row in rows]
    return out


def sun_and_sky(v: Variation) -> list[str]:
    """street.ses's sun and sky, or the seed's time of day (the sun lamp where the sky's sun
    is: elevation above the ground, azimuth from -Z towards +X), and its fog."""
    if v.sun is None:
        out = ["LIGHT sun direction -0.4 -1 -0.3 strength 2", "WORLD sky strength 0.6 elevation 40 azimuth 30"]
    else:
        el, az = np.radians(v.sun)
        towards = np.array([np.cos(el) * np.sin(az), np.sin(el), -np.cos(el) * np.cos(az)])
        warm = min(1.0, v.sun[0] / 40.0)   # a low sun is weaker and redder
        out = [f"LIGHT sun direction {fmt(*-towards)} strength {fmt(0.8 + 1.6 * np.sin(el))} "
               f"colour 1 {fmt(0.8 + 0.2 * warm)} {fmt(0.65 + 0.35 * warm)}",
               f"WORLD sky strength 0.6 elevation {fmt(v.sun[0])} azimuth {fmt(v.sun[1])}"]
    if v.fog is not None:
        out.append(f"FOG start {fmt(v.fog[0])} end {fmt(v.fog[1])} colour 0.75 0.77 0.8")
    return out



def cross_street_lines(pts, heads, crossing: tuple[int, int], first_id: int, length: float = 40.0) -> list[str]:
    """A straight cross street through axis segments crossing[0]..crossing[1] (its width is
    theirs), perpendicular to the street there: road quads each side and its facades."""
    up = np.array([0.0, 1.0, 0.0])
    a, b = pts[crossing[0]], pts[crossing[1]]
    fwd = (b - a) / np.linalg.norm(b - a)
    r = np.cross(fwd, up)
    out, i = [], first_id
    for sgn in (-1, 1):
        near_a, near_b = a + sgn * HALF_WIDTH * r, b + sgn * HALF_WIDTH * r
        far_a, far_b = near_a + sgn * length * r, near_b + sgn * length * r
        quad = (near_a, near_b, far_b, far_a) if sgn > 0 else (near_b, near_a, far_a, far_b)
        out.append(f"QUAD id {i} texture 10 colour 0.75 0.75 0.75 vertices {fmt(*np.concatenate(quad))}")
        for edge, tex in ((near_a, 7), (near_b, 5)):
            top = 10.0 * up
            far = edge + sgn * length * r
            out.append(f"QUAD id {i + 1} texture {tex} colour 0.9 0.85 0.8 vertices "
                       f"{fmt(*edge, *far, *(far + top), *(edge + top))}")
            i += 1
        i += 1
    return out


def main(kitti: bool = False) -> None:
    print(generate(0, kitti), end="")


if __name__ == "__main__":
    main(kitti="--kitti" in sys.argv[1:])
