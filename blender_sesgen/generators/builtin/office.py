"""Writes scenes/office.ses: an office walked through with a hand-held camera, TUM RGB-D style.

A 7 x 2.9 x 9 m room: wooden or tiled floor, plastered walls with skirting, a row of
windows (open frames: daylight and the view out come in), a door, ceiling light panels
(with area lights), desks with monitors and office chairs, bookcases full of books,
cabinets, a sofa on a rug, pot plants, pictures; outside, a lawn, trees and a building
across. The camera is TUM's (640 x 480, f = 525 px) made stereo (baseline 0.1 m) and
moves like a hand-held one at 30 Hz: slowly along the aisle (~0.4 m/s, 12 s),
panning and tilting to look at the shelves, desks and windows, with hand shake.

    python -m blender_sesgen.generators.builtin.office [--seed N] [--frames N] > scenes/office.ses

``generate(seed, frames=360)`` returns the script (the checked-in file is seed 0). Every seed
furnishes the room its own way (windows, door, desks, chairs, wall colour, floor); a seed
other than 0 also varies (:class:`Variation`) the daylight (sun elevation 10-60 deg, any
azimuth, or one time in three a bundled HDRI outside: city, courtyard, forest, sunrise,
sunset), the ceiling lights' power and colour temperature, the finishes (floor tone and
wear, wall wear) and the walk: the route's waypoints, its direction, the eye height, the
points looked at and the hand shake.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .sesgen_layout import (Ids, Lighting, asset, command_line, derived_material, draw_lighting, num, nums,
                           script_with_poses, sky_and_sun, SeededVariation, smooth_noise, variation_rng)

RATE_HZ = 30.0
WALKS = ("aisle", "loop")        # up the aisle (office.ses), or around the desks and back to the start
FLOORS = {"wood_planks": ((0.33, 0.19, 0.09), (0.45, 0.30, 0.16), (0.20, 0.11, 0.05), (0.52, 0.40, 0.25)),
          "ceramic_tiles": ((0.62, 0.62, 0.6), (0.45, 0.44, 0.42), (0.7, 0.66, 0.58), (0.3, 0.3, 0.31))}
LAMP_COLOURS = ((1.0, 0.86, 0.7), (1.0, 0.95, 0.88), (0.92, 0.96, 1.0))   # warm, neutral, cool white
WAY = ((2.75, 1.3), (2.75, -0.9), (1.8, -2.6), (0.8, -2.9))              # the route along the aisle
LOOKS = ((0.0, 0.8, 0.2), (0.3, 0.8, -1.2), (1.0, 1.5, -4.5), (-2.5, 0.9, -2.0), (-0.5, 0.8, 0.8))


@dataclass(frozen=True)
class Variation(SeededVariation, salt=0x0FF):
    """What a seed changes besides the layout; the defaults are office.ses's (seed 0)."""
    lighting: Optional[Lighting] = None  # None: the sun the layout stream draws (office.ses's)
    lamps: tuple = (60.0, None)          # ceiling area lights: (strength W, colour or None = white)
    floor: Optional[tuple] = None        # (colour, wear) of the floor's library material; None: the library's
    wall_wear: float = 0.1
    way: tuple = WAY                     # waypoints (x, z) of the walk, walked in this order
    looks: tuple = LOOKS                 # points looked at, in turn
    eye: float = 1.45                    # mean eye height (m)
    shake: float = 1.0                   # hand shake, relative to office.ses's

    @classmethod
    def draw(cls, rng: np.random.Generator) -> "Variation":
        lighting = draw_lighting(rng, elevation=(10.0, 60.0), p_hdri=1 / 3)
        lamps = (round(float(rng.uniform(25.0, 90.0)), 1), LAMP_COLOURS[int(rng.integers(len(LAMP_COLOURS)))])
        floor = (int(rng.integers(4)), round(float(rng.uniform(0.0, 0.5)), 2))
        # the aisle (x 2.6-2.9) stays between the desks and the bookcases; the corner by the windows moves more
        jitter = [(rng.uniform(-0.12, 0.12), rng.uniform(-0.3, 0.3)), (rng.uniform(-0.12, 0.12), rng.uniform(-0.3, 0.3)),
                  (rng.uniform(-0.3, 0.3), rng.uniform(-0.25, 0.25)), (rng.uniform(-0.4, 0.4), rng.uniform(-0.2, 0.3))]
        way = tuple((round(x + dx, 3), round(z + dz, 3)) for (x, z), (dx, dz) in zip(WAY, jitter))
        looks = tuple(tuple(round(c + float(rng.uniform(-0.5, 0.5)), 3) for c in p) for p in LOOKS)
        if rng.uniform() < 0.4:                  # walked the other way: from the windows back down the aisle
            way, looks = way[::-1], looks[::-1]
        return cls(lighting=lighting, lamps=lamps, floor=floor, wall_wear=round(float(rng.uniform(0.0, 0.4)), 2),
                   way=way, looks=looks, eye=round(float(rng.uniform(1.3, 1.65)), 2),
                   shake=round(float(rng.uniform(0.6, 1.5)), 2))


def generate(seed: int = 0, frames: Optional[int] = None, walk: str = "aisle") -> str:
    """The SES script of the office walk for ``seed`` (see the module docstring); ``walk``:
    ``aisle`` (office.ses: up the aisle to the windows, 360 frames by default; fewer frames are
    the first ones of that walk, more walk it slower) or ``loop``
    (once around the desks and back to the start at 0.6 m/s; frames by default as long as
    that takes)."""
    if walk not in WALKS:
        raise ValueError(f"walk must be one of {', '.join(WALKS)}, got {walk!r}")
    if frames is None:
        frames = AISLE_FRAMES if walk == "aisle" else int(round(_loop_length() / WALK_SPEED * RATE_HZ)) + 1
    if int(seed) < 0 or int(frames) < 2:
        raise ValueError(f"seed must be >= 0 and frames >= 2, got seed {seed}, frames {frames}")
    var = Variation.of(int(seed))
    rng = np.random.default_rng(seed)
    W, H, D, t = 7.0, 2.9, 9.0, 0.2
    ids = Ids({"shell": 1, "opening": 100, "light": 200, "furniture": 300, "decor": 700, "outside": 900})
    floor_mat = str(rng.choice(["wood_planks", "ceramic_tiles"]))
    wall_colour = rng.choice(["0.7 0.69 0.66", "0.66 0.64 0.58", "0.6 0.63 0.64", "0.72 0.7 0.62"])
    sun = sky_and_sun(float(rng.uniform(25, 40)), float(rng.uniform(150, 210)))   # drawn all the same: the layout stays
    out = ["// office.ses - an office walked through with a hand-held camera, TUM RGB-D style:",
           "// 640x480, f 525 px (TUM's), stereo baseline 0.1 m, 30 Hz.",
           f"// Generated by blender_sesgen/generators/builtin/office.py --seed {seed} --frames {frames}"
           + (" --walk loop" if walk == "loop" else "") + " (edit that, not this file). Y up, metres.",
           "CAMERA resolution 640 480 focal 525 baseline 0.1 near 0.05 far 200",
           *(sun if var.lighting is None else var.lighting.lines()),
           # no RENDER line: the preset (final) holds 39.5 dB here against a 4096-sample reference
           # (frame 0's centre window; bench/RESULTS.md, session 11 quality11)
           "LOOK exposure auto",
           "SENSOR profile tum          // the Kinect v1 RGB camera of TUM RGB-D (docs/sensors.md)",
           "AUTOEXPOSURE                // its exposure follows the scene (metered before the frames render)", "",
           "// materials derived from the library (colour replaces the library's)",
           f"MATERIAL name wall_paint library plaster colour {wall_colour} wear {num(var.wall_wear, 2)}",
           "MATERIAL name ceiling_paint library plaster colour 0.78 0.78 0.76 wear 0.05",
           "MATERIAL name skirting library plastic colour 0.7 0.7 0.68"]
    if var.floor is not None:
        out.append(derived_material("floor_finish", floor_mat, FLOORS[floor_mat][var.floor[0]], var.floor[1], seed=seed))
        floor_mat = "floor_finish"
    out += ["",
            "// the room: floor, ceiling, walls around a window row (north) and a door (west)"]
    out.append(f"CUBOID id {ids('shell')} name floor material {floor_mat} position 0 -0.1 0 "
               f"dim {nums((W + 2 * t, 0.2, D + 2 * t))}")
    out.append(f"CUBOID id {ids('shell')} name ceiling material ceiling_paint class ceiling position 0 {num(H + 0.1)} 0 "
               f"dim {nums((W + 2 * t, 0.2, D + 2 * t))}")

    def wall(u0, u1, y0, y1, side):
        """A wall piece on side north (z = -D/2), south, west (x = -W/2) or east, u along it."""
        cu, cy = 0.5 * (u0 + u1), 0.5 * (y0 + y1)
        if side in ("north", "south"):
            z = -D / 2 - t / 2 if side == "north" else D / 2 + t / 2
            pos, dim = (cu, cy, z), (u1 - u0, y1 - y0, t)
        else:
            x = -W / 2 - t / 2 if side == "west" else W / 2 + t / 2
            pos, dim = (x, cy, cu), (t, y1 - y0, u1 - u0)
        return f"CUBOID id {ids('shell')} material wall_paint class wall position {nums(pos)} dim {nums(dim)}"

    # north wall: windows
    sill, top = 0.9, 2.4
    n_win = int(rng.integers(2, 4))
    win_w = float(rng.uniform(1.3, 1.7))
    xs = np.linspace(-W / 2, W / 2, n_win + 2)[1:-1]
    edges = [-W / 2 - t]
    for x in xs:
        edges += [x - win_w / 2, x + win_w / 2]
    edges.append(W / 2 + t)
    out.append(wall(-W / 2 - t, W / 2 + t, 0, sill, "north"))
    out.append(wall(-W / 2 - t, W / 2 + t, top, H + 0.2, "north"))
    for a, b_ in zip(edges[::2], edges[1::2]):
        out.append(wall(a, b_, sill, top, "north"))
    for x in xs:
        out.append(asset("window_frame", ids("opening"), (x, sill, -D / 2 - t / 2), 0.0,
                         (round(win_w, 3), top - sill, t), seed=int(rng.integers(1e6))))
        out.append(asset("radiator", ids("decor"), (x, 0, -D / 2), 0.0, (round(win_w * 0.8, 2), 0.75, 0.1),
                         seed=int(rng.integers(1e6))))
    out.append(wall(-W / 2 - t, W / 2 + t, 0, H + 0.2, "south"))
    out.append(wall(-D / 2, D / 2, 0, H + 0.2, "east"))
    door_z, door_w, door_h = float(rng.uniform(1.5, 3.0)), 0.9, 2.05
    out.append(wall(-D / 2, door_z - door_w / 2, 0, H + 0.2, "west"))
    out.append(wall(door_z + door_w / 2, D / 2, 0, H + 0.2, "west"))
    out.append(wall(door_z - door_w / 2, door_z + door_w / 2, door_h, H + 0.2, "west"))
    out.append(asset("door", ids("opening"), (-W / 2 - t / 2, 0, door_z), 90.0, (door_w, door_h, t), seed=3))
    for lo, hi in (((-W / 2, 0, -D / 2), (W / 2, 0.08, -D / 2 + 0.015)), ((-W / 2, 0, D / 2 - 0.015), (W / 2, 0.08, D / 2)),
                   ((W / 2 - 0.015, 0, -D / 2), (W / 2, 0.08, D / 2))):
        c, dm = (np.add(lo, hi) / 2), np.subtract(hi, lo)
        out.append(f"CUBOID id {ids('shell')} material skirting class wall position {nums(c)} dim {nums(dm)}")

    out += ["", "// ceiling light panels and their light"]
    for x in (-1.6, 1.6):
        for z in (-2.6, 0.0, 2.6):
            out.append(asset("ceiling_light", ids("light"), (x, H, z), 0.0, (1.2, 0.05, 0.3), seed=11))
            out.append(f"LIGHT area position {nums((x, H - 0.12, z))} direction 0 -1 0 size 1.1 0.25 "
                       f"strength {num(var.lamps[0])}" + (f" colour {nums(var.lamps[1])}" if var.lamps[1] else ""))

    out += ["", "// desks with monitors and chairs (two rows facing each other), shelves, cabinets, sofa corner"]
    desk_z = [-1.2, 0.75]
    for row, z in enumerate(desk_z):
        for x in (-1.6, 0.0, 1.6):
            if rng.random() < 0.15:
                continue
            yaw = 0.0 if row == 1 else 180.0
            face = 1 if row == 1 else -1
            out.append(asset("desk", ids("furniture"), (x, 0, z), yaw, (1.5, 0.74, 0.75), seed=int(rng.integers(1e6))))
            out.append(asset("monitor", ids("furniture"), (x + rng.uniform(-0.3, 0.3), 0.74, z - face * 0.2), yaw,
                             seed=int(rng.integers(1e6))))
            if rng.random() < 0.5:
                out.append(asset("monitor", ids("furniture"), (x + 0.45, 0.74, z - face * 0.15), yaw + face * 15,
                                 seed=int(rng.integers(1e6))))
            out.append(asset("chair", ids("furniture"), (x + rng.uniform(-0.2, 0.2), 0, z + face * 0.75),
                             yaw + 180 + rng.uniform(-25, 25), seed=int(rng.integers(1e6))))
    for z in np.arange(-D / 2 + 0.8, D / 2 - 2.5, 1.05):          # bookcases along the east wall
        out.append(asset("shelf", ids("furniture"), (W / 2 - 0.2, 0, z + 0.5), -90.0, (1.0, 2.0, 0.34),
                         seed=int(rng.integers(1e6))))
    for x in (-2.5, -1.4):                                          # cabinets along the south wall
        out.append(asset("cabinet", ids("furniture"), (x, 0, D / 2 - 0.25), 180.0, (1.0, 1.1, 0.45),
                         seed=int(rng.integers(1e6))))
    out.append(asset("sofa", ids("furniture"), (-W / 2 + 0.5, 0, D / 2 - 2.0), 90.0, (2.0, 0.85, 0.9), seed=int(rng.integers(1e6))))
    out.append(asset("rug", ids("decor"), (-W / 2 + 1.6, 0, D / 2 - 2.0), 90.0, (2.2, 0.008, 1.6), seed=int(rng.integers(1e6))))
    out.append(asset("table", ids("furniture"), (-W / 2 + 1.7, 0, D / 2 - 2.0), 90.0, (1.0, 0.45, 0.6), seed=int(rng.integers(1e6))))
    for p in ((-W / 2 + 0.4, 0, -D / 2 + 0.5), (W / 2 - 0.45, 0, D / 2 - 0.6), (0.9, 0, D / 2 - 0.4)):
        out.append(asset("plant", ids("decor"), p, rng.uniform(0, 360), seed=int(rng.integers(1e6))))
    for (x, z, yaw) in ((-1.0, D / 2, 180.0), (-W / 2, -2.0, 90.0), (-W / 2, 0.8, 90.0)):
        out.append(asset("picture", ids("decor"), (x, 0, z), yaw,
                         (round(float(rng.uniform(0.5, 1.0)), 2), round(float(rng.uniform(1.5, 1.7)), 2), 0.03),
                         seed=int(rng.integers(1e6))))

    out.append(asset("whiteboard", ids("decor"), (1.8, 0, D / 2), 180.0, (1.8, 1.45, 0.03), seed=int(rng.integers(1e6))))

    out += ["", "// outside the windows: lawn, trees, a building across"]
    out.append(f"QUAD id {ids('outside')} material grass vertices -60 -0.3 -5  60 -0.3 -5  60 -0.3 -80  -60 -0.3 -80")
    for _ in range(5):
        out.append(asset("tree", ids("outside"), (rng.uniform(-14, 14), -0.3, rng.uniform(-22, -9)), rng.uniform(0, 360),
                         seed=int(rng.integers(1e6))))
    out.append(asset("building", ids("outside"), (rng.uniform(-6, 6), -0.3, -40), 0.0, (30, 16, 12), seed=int(rng.integers(1e6))))

    # --- hand-held walk --------------------------------------------------------------------
    if walk == "loop":
        P, yaw, pitch, roll = _loop_walk(frames, var, variation_rng(seed, 0x100))
        return script_with_poses(out, f"the walk: once around the desks and back to where it began, {frames} poses "
                                 f"of the left camera at {num(RATE_HZ, 0)} Hz", P, yaw, pitch, roll)
    # a shorter walk is the first frames of the 12 s one (~0.4 m/s, the same hand shake), not the
    # whole aisle squeezed into them (60 frames walked it at 2 m/s); a longer one walks it slower
    n = max(int(frames), AISLE_FRAMES)
    tt = np.arange(n) / RATE_HZ
    s = np.linspace(0, 1, n)
    # through the aisle between the desks and the shelves, then turning towards the windows
    way = np.array(var.way)
    u = np.linspace(0, 1, len(way))
    px = np.interp(s, u, way[:, 0])
    pz = np.interp(s, u, way[:, 1])
    k = max(int(0.5 * RATE_HZ), 1)          # smooth the corners (0.5 s moving average, twice)
    for _ in range(2):
        px = np.convolve(np.pad(px, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), "valid")
        pz = np.convolve(np.pad(pz, k, mode="edge"), np.ones(2 * k + 1) / (2 * k + 1), "valid")
    py = var.eye + 0.04 * smooth_noise(rng, n, 1.0, (0.6, 1.4)) + 0.008 * np.sin(2 * np.pi * 1.8 * tt)
    P = np.stack([px, py, pz], axis=1)
    # where the camera looks: points of interest handed over smoothly (desks, shelves,
    # windows, the sofa corner), as a person filming the room would
    target = _smooth_targets(np.array(var.looks), s, k)
    yaw, pitch, roll = _handheld_view(P, target, rng, var.shake, n)
    n = int(frames)
    return script_with_poses(out, f"the walk: {n} poses of the left camera at {num(RATE_HZ, 0)} Hz",
                             P[:n], yaw[:n], pitch[:n], roll[:n])


def _smooth_targets(looks: np.ndarray, s: np.ndarray, k: int) -> np.ndarray:
    """Points looked at, handed over smoothly: ``looks`` evenly spread over the walk,
    interpolated at the fractions ``s`` and smoothed (2 s moving average, twice)."""
    lu = np.linspace(0, 1, len(looks))
    target = np.stack([np.interp(s, lu, looks[:, i]) for i in range(3)], axis=1)
    for _ in range(2):
        target = np.stack([np.convolve(np.pad(target[:, i], 2 * k, mode="edge"), np.ones(4 * k + 1) / (4 * k + 1),
                                       "valid") for i in range(3)], axis=1)
    return target


def _handheld_view(P: np.ndarray, target: np.ndarray, rng, shake: float, n: int, slow=1.0):
    """Yaw, pitch, roll (deg) of a hand-held camera at P looking at ``target``, with hand
    shake of strength ``shake`` (``slow``: how many times longer than office.ses's 12 s walk
    this one is, so that the shake keeps its frequency)."""
    view = target - P
    yaw = np.degrees(np.arctan2(-view[:, 0], -view[:, 2]))
    yaw = np.degrees(np.unwrap(np.radians(yaw)))
    pitch = np.degrees(np.arctan2(view[:, 1], np.hypot(view[:, 0], view[:, 2])))
    q = shake
    c = lambda *f: tuple(slow * x for x in f)      # noqa: E731
    yaw = yaw + q * 4 * smooth_noise(rng, n, 1.0, c(0.5, 1.1)) + q * 0.3 * smooth_noise(rng, n, 1.0, c(6.0, 9.0, 14.0))
    pitch = pitch + q * 3 * smooth_noise(rng, n, 1.0, c(0.4, 0.9)) + q * 0.3 * smooth_noise(rng, n, 1.0, c(6.0, 11.0))
    roll = q * 2.0 * smooth_noise(rng, n, 1.0, c(0.5, 1.2)) + q * 0.4 * smooth_noise(rng, n, 1.0, c(7.0, 13.0))
    return yaw, pitch, roll


# the walk around the desks (x, z): up the aisle, west along the windows, down the west side,
# east between the desks and the sofa corner, back to the start; and what it looks at
LOOP_WAY = ((2.75, 1.3), (2.75, -1.0), (2.3, -3.0), (-2.85, -3.1), (-2.9, 0.9), (-2.2, 1.95), (2.3, 1.95),
            (2.75, 1.3))
LOOP_LOOKS = ((1.0, 1.5, -4.5), (3.5, 1.2, -1.5), (-2.0, 1.2, -4.0), (0.0, 0.9, -1.2), (-3.5, 1.3, 0.8),
              (1.8, 1.4, 4.5), (3.5, 1.2, 0.0), (1.0, 1.5, -4.5))
WALK_SPEED = 0.6                 # m/s along the loop
AISLE_FRAMES = 360               # the aisle walk's 12 s at 30 Hz


def _loop_length() -> float:
    w = np.array(LOOP_WAY)
    return float(np.linalg.norm(np.diff(w, axis=0), axis=1).sum())


def _loop_walk(n: int, var: "Variation", rng):
    """Positions (n, 3), yaw, pitch, roll of the walk around the desks that ends where it
    began, looking where it looked at the start (a loop closure at the end)."""
    way = np.array(LOOP_WAY)
    seg = np.linalg.norm(np.diff(way, axis=0), axis=1)
    u = np.concatenate([[0.0], np.cumsum(seg)]) / seg.sum()          # waypoints by distance walked
    s = np.linspace(0, 1, n)
    k = max(int(0.5 * RATE_HZ), 1)

    def closed_smooth(x, half):     # a moving average around the closed loop: it ends where it begins
        x = x[:-1]
        for _ in range(2):
            x = np.convolve(np.pad(x, half, mode="wrap"), np.ones(2 * half + 1) / (2 * half + 1), "valid")
        return np.append(x, x[0])
    px, pz = closed_smooth(np.interp(s, u, way[:, 0]), k), closed_smooth(np.interp(s, u, way[:, 1]), k)
    tt = np.arange(n) / RATE_HZ
    slow = n / 360.0
    py = var.eye + 0.04 * smooth_noise(rng, n, 1.0, (0.6 * slow, 1.4 * slow)) + 0.008 * np.sin(2 * np.pi * 1.8 * tt)
    P = np.stack([px, py, pz], axis=1)
    looks = np.array(LOOP_LOOKS)
    target = np.stack([closed_smooth(np.interp(s, u, looks[:, i]), 2 * k) for i in range(3)], axis=1)
    return (P, *_handheld_view(P, target, rng, var.shake, n, slow))


if __name__ == "__main__":
    command_line(generate, __doc__, None)
