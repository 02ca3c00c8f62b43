"""Writes scenes/hall.ses: a large machine hall flown through by a drone, EuRoC-style.

A 30 x 40 m steel-framed hall: concrete floor with painted aisle lines, a brick or
concrete plinth wall with profiled metal cladding above, strip windows of diffusing glazing
(``frosted_glass``) letting in daylight evenly, H columns carrying roof girders, hanging lamps;
machines, pallet racks, tanks, pipe runs, crates, pallets and barrels, painted pallet bays
beside the open middle, a steel stair and railings. The rig is the EuRoC
MAV's VI-sensor (752 x 480 px, focal and principal point of cam0, baseline from the two
cameras' T_BS in ``../shared/data/euroc/mav0/cam0|cam1/sensor.yaml``, read by
:func:`euroc_rig`; undistorted pinhole). As every EuRoC sequence it starts standing, rotors
running (``STAND_FRAMES`` on a take-off stand, cam0 where V1_01's stands: 0.93 m above the
floor, 21.5 deg down, shaken by the rotors, facing a low window behind diffusing glazing as
V1_01's faces its curtained window; a drone test floor before it: marker tape, a white
sheet, a checkerboard, a printed play mat, cables, crash mats standing and stacked round it
2-4 m away), climbs for 2 s, then flies at 20 Hz like EuRoC's Machine Hall runs: ~0.6 m/s
(at most ~1.5) at 1-2.5 m height, its camera 19.5 deg down as V1_01's in flight, looking
around in glances as V1_01's MAV does (headings held, then turned in bursts, whichever way it
flies: :func:`glances`) and never faster than it turns (``YAW_RATE_MAX_DEG_S``), rolling and
pitching a few degrees with its accelerations.

    python -m blender_sesgen.generators.builtin.hall [--seed N] [--frames N] [--stand N] > scenes/hall.ses

``generate(seed, frames=200, width=30, depth=40, height=10)`` returns the script (the
checked-in file is seed 0). Every seed fits out the hall its own way (machines, tanks, racks,
clutter, cladding colour, brick or concrete plinth); a seed other than 0 also varies
(:class:`Variation`) the daylight through the windows (sun elevation 10-65 deg, any azimuth,
or one time in three a bundled HDRI outside: city, courtyard, forest, sunrise, sunset), the
lamps' luminous flux and colour temperature, the finishes (floor concrete tone and wear, the aisle
paint, the door) and the flight: how far it goes (4-10 m) and in which direction, its
sideways swing, height and bobbing, and how much it yaws to look around.

The lamps and the daylight are in the same proportion as in a real hall: a lamp's power is
its luminous flux (20 000 lm, an LED high-bay; 10 000-30 000 lm by seed) at 683 lm/W, divided
by the scale ``WORLD sky`` applies to Blender's physical sky (``SKY_EXPOSURE``: the sky is in
real units, ~100 000 lx of sunlight, before it). So the hall is lit mostly by daylight, a few
per cent of the outdoor level, and a camera exposed for the hall sees its glazing burnt out
and its lamps' diffusers glowing (lamps of 250 W each outshone such a sky some 400-fold). The
glazing scatters the daylight: no sun patches on the floor, which under a mean-metering
auto-exposure left the rest of the hall dark (docs/sensors.md, Camera twins). The panes
``glow`` (``MATERIAL ... glow``: each emits 0.45 x the irradiance the WORLD gives its outer
face / pi, mapped over it, and passes no light itself): traced through the panes, that
daylight reached the room only by bounces and was ~87 % of the hall's noise.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from ...scene.assets.flight_arena import MAT_HANDLE_M
from ...scene.lighting import SKY_EXPOSURE
from ...contract.frames import R_CV_BLENDERCAM
from ...contract.se3 import euler_xyz_deg_to_R, so3_exp
from .sesgen_layout import (REPO, Ids, Lighting, asset, camera_body_R, camera_yaw_pitch_roll, command_line,
                            draw_lighting, num, nums, script_with_poses, SeededVariation, smooth_noise, variation_rng)

# EuRoC MAV cam0/cam1 (../shared/data/euroc/mav0/*/sensor.yaml): used when the data folder is absent
EUROC_DEFAULT = {"resolution": (752, 480), "fu": 458.654, "cu": 367.215, "cv": 248.375, "baseline": 0.110078}
RATE_HZ = 20.0
FLIGHTS = ("sweep", "laps")      # one pass through the middle (hall.ses), or laps that pass the same places
LUMENS_PER_WATT = 683.0         # Blender's lamps and sky: radiant W at 555 nm (glTF's conversion too)
LAMP_COLOURS = ((1.0, 0.86, 0.7), (1.0, 0.95, 0.88), (0.92, 0.96, 1.0))   # warm, neutral, cool white
AISLE_PAINTS = ((0.55, 0.45, 0.03), (0.7, 0.7, 0.68), (0.06, 0.3, 0.12), (0.6, 0.12, 0.04))
DOOR_PAINTS = ((0.35, 0.3, 0.05), (0.05, 0.12, 0.3), (0.3, 0.31, 0.32), (0.35, 0.05, 0.03))
# Before the flight the MAV stands, as at the start of every EuRoC sequence, measured in the
# V1_01 excerpt (../shared/data/euroc/mav0; docs/sensors.md, Camera twins):
STAND_FRAMES = 100       # it lifts off 5.0 s after its first frame (the IMU's |a|: 9.78 +- 0.01 m/s2 until then)
ROTORS_FRAMES = 6        # frames 0-5 differ by the sensor's noise only; the rotors shake it from frame 6 on
STAND_CAMERA_M = 0.93    # cam0 above the floor (the floor plane by stereo, frames 0-94: 0.928-0.932 m)
STAND_PITCH_DEG = -21.5  # cam0's axis below the horizon (stereo 21.3-21.6; the IMU's gravity via T_BS 21.9)
STAND_ROLL_DEG = -1.5    # its roll (camera_pose_line's sense; the floor's normal leans 1.5-1.7 deg to the
                         # image's right)
# The rotors' shake of the standing camera, measured on V1_01's frames 5-94 (cam0 and cam1 agree;
# the rotation between consecutive rectified frames, ``python bench/still_split.py --motion``):
# turns about the camera's own right, down and optical axes of s.d. 0.019, 0.018, 0.017 deg but
# median only 0.0077, 0.0042, 0.0072 deg (0.058, 0.032, 0.055 px at 436 px; frames 0-5, rotors
# off: 0.001): it comes in bursts, quiet for a second at a time (frames 30-50: 0.03 px s.d.),
# loud in others (0.3 px). So each axis turns by a Gaussian of SHAKE_DEG a frame times a loudness
# that swells and fades (exp(SHAKE_BURSTS x a smooth noise of unit RMS): s.d. over median 2.4,
# EuRoC's 2.3-4.2, a Gaussian's 1.5), and keeps SHAKE_HOLD of its last offset: the image's turns
# about right and down are uncorrelated from one frame to the next (lag-1 +0.07 / -0.07; a white
# offset's are -0.5), its roll swings back (-0.66). SHAKE_DEG: EuRoC's medians over the model's
# median per unit (0.665 held, 0.877 white, over 400 draws).
SHAKE_DEG = (0.0116, 0.0063, 0.0082)   # about the camera's right (pitch), down (yaw), optical (roll) axes
SHAKE_HOLD = (0.8, 0.8, 0.0)
SHAKE_BURSTS = 0.7
# EuRoC V1_01's camera faces a window behind a white curtain, 61 % of its clipped pixels
# (frames 30-74: the top quarter 29 % at 255, rows 0-95 of 480, -12..+24 deg across): the
# standing MAV faces a low window in the south wall, 12 m off, behind diffusing glazing
# (``frosted_glass``: a white sheer curtain's 0.40 reflected, 0.45 passed)
LOW_WINDOW = ((-4.0, 4.0), (0.6, 2.6))   # its x span and sill, head heights (m), in the plinth (3 m)
LOW_WINDOW_BAY = 2.0                     # one frame per 2 m
TAKEOFF_FRAMES = 40      # the climb from the stand to the flight's first pose (2 s)
# the heading turns at a bounded rate, as V1_01's MAV does in flight (its gyro about gravity,
# ../shared/data/euroc/mav0/imu0, 5.5-145 s: 0.25-s means at most 44.6 deg/s, p99 38.4; their change
# at most 115 deg/s2, p99 85; per 20-Hz frame median 0.31 deg, max 2.28): the heading that follows
# the velocity flipped by 9-19 deg in one frame where the flight reverses (180-380 deg/s)
YAW_RATE_MAX_DEG_S = 45.0
YAW_ACCEL_MAX_DEG_S2 = 115.0
YAW_FOLLOW_S = 0.4       # how fast it closes on the heading it wants (a time constant, s)
FLIGHT_PITCH_DEG = -19.5  # cam0's axis below the horizon in flight (V1_01's IMU gravity via T_BS, 1-s means
                          # over 5.5-145 s: median 19.47, p10-p90 19.1-19.8; the MAV hovers level, its legs
                          # tilt it on the floor)


@dataclass(frozen=True)
class Variation(SeededVariation, salt=0x4A1):
    """What a seed changes besides the layout; the defaults are hall.ses's (seed 0)."""
    lighting: Lighting = Lighting(sun=(35.0, 120.0))
    lamps: tuple = (20000.0, None)       # hanging lamps: (luminous flux lm, colour or None = white)
    floor: tuple = ((0.3, 0.3, 0.29), 0.6)            # (colour, wear) of the concrete floor
    aisle_paint: tuple = (0.55, 0.45, 0.03)
    door_paint: tuple = (0.35, 0.3, 0.05)
    distance: float = 6.0                # how far the flight goes (m)
    reverse: bool = False                # flown towards +z (south) instead of -z
    swing: float = 1.5                   # sideways swing (m)
    height: tuple = (1.6, 0.5)           # mean height and its swing (m)
    look: float = 35.0                   # a glance's mean turn, looking around (deg)

    @classmethod
    def draw(cls, rng: np.random.Generator) -> "Variation":
        tone = float(rng.uniform(0.75, 1.3))
        return cls(lighting=draw_lighting(rng, elevation=(10.0, 65.0), p_hdri=1 / 3),
                   lamps=(round(float(rng.uniform(10000.0, 30000.0)), -2), LAMP_COLOURS[int(rng.integers(3))]),
                   floor=(tuple(round(0.3 * tone * c, 3) for c in (1, 1, 0.97)), round(float(rng.uniform(0.2, 0.9)), 2)),
                   aisle_paint=AISLE_PAINTS[int(rng.integers(len(AISLE_PAINTS)))],
                   door_paint=DOOR_PAINTS[int(rng.integers(len(DOOR_PAINTS)))],
                   distance=round(float(rng.uniform(4.0, 10.0)), 2), reverse=bool(rng.uniform() < 0.4),
                   swing=round(float(rng.uniform(0.6, 2.6)), 2),
                   height=(round(float(rng.uniform(1.25, 2.1)), 2), round(float(rng.uniform(0.2, 0.6)), 2)),
                   look=round(float(rng.uniform(15.0, 55.0)), 1))


LAMP = (0.6, 1.6, 0.3)           # ceiling_light: width, hanging length, depth (m)
LAMP_LIGHT_M = 0.5               # the area LIGHT just under its diffuser (edge, m)


def lamp_luminance(lumens: float) -> float:
    """The radiance (Blender units, in the scale of ``WORLD sky``) of a lamp of this luminous
    flux whose light leaves through its diffuser and the area LIGHT under it (both
    Lambertian, so flux = pi x radiance x area): the diffuser glows as bright as the lamp."""
    diffuser_m2 = (LAMP[0] - 0.04) * (LAMP[2] - 0.04)       # indoor.ceiling_light's panel
    return lumens / LUMENS_PER_WATT / SKY_EXPOSURE / (np.pi * (diffuser_m2 + LAMP_LIGHT_M ** 2))


def _sensor(path: Path) -> dict:
    text = path.read_text()
    data = re.search(r"T_BS:.*?data:\s*\[([^\]]*)\]", text, re.S).group(1)
    T = np.array([float(x) for x in data.replace("\n", " ").split(",")]).reshape(4, 4)
    intr = [float(x) for x in re.search(r"intrinsics:\s*\[([^\]]*)\]", text).group(1).split(",")]
    res = [int(x) for x in re.search(r"resolution:\s*\[([^\]]*)\]", text).group(1).split(",")]
    return {"T_BS": T, "intrinsics": intr, "resolution": res}


def euroc_rig(root: Path = None) -> dict:
    """cam0's resolution, fu and principal point and the stereo baseline |t_cam1 - t_cam0|
    (both T_BS translations in the body frame) from the EuRoC sensor files (``root``, default
    ``$SESGEN_SHARED_DATA/euroc/mav0`` or ``../shared/data/euroc/mav0``); the stored defaults
    (the same numbers) when they are not on this machine."""
    if root is None:
        root = Path(os.environ.get("SESGEN_SHARED_DATA", REPO.parent / "shared" / "data")) / "euroc" / "mav0"
    try:
        c0, c1 = _sensor(root / "cam0" / "sensor.yaml"), _sensor(root / "cam1" / "sensor.yaml")
    except (OSError, AttributeError):
        return dict(EUROC_DEFAULT)
    fu, _, cu, cv = c0["intrinsics"]
    return {"resolution": tuple(c0["resolution"]), "fu": fu, "cu": cu, "cv": cv,
            "baseline": float(np.linalg.norm(c1["T_BS"][:3, 3] - c0["T_BS"][:3, 3]))}


def generate(seed: int = 0, frames: Optional[int] = None, width: float = 30.0, depth: float = 40.0,
             height: float = 10.0, flight: str = "sweep", laps: int = 3, speed: float = 0.8,
             stand: Optional[int] = None) -> str:
    """The SES script of the hall flight for ``seed`` (see the module docstring). ``stand``:
    frames the MAV stands before it takes off (default ``STAND_FRAMES`` for the sweep, 0 for
    the laps); the sweep then climbs for ``TAKEOFF_FRAMES`` and flies its course over
    max(frames - stand - take-off, 200) frames, cut at ``frames`` (default: all of it), so a
    shorter script is the start of the default one. The laps' ``frames`` default to ``laps``
    laps at ``speed`` m/s."""
    if flight not in FLIGHTS:
        raise ValueError(f"flight must be one of {', '.join(FLIGHTS)}, got {flight!r}")
    if int(laps) < 1 or not speed > 0:
        raise ValueError(f"laps must be >= 1 and speed > 0, got laps {laps}, speed {speed}")
    stand = (STAND_FRAMES if flight == "sweep" else 0) if stand is None else int(stand)
    climb = TAKEOFF_FRAMES if stand else 0
    if frames is None:
        frames = stand + climb + (200 if flight == "sweep" else _laps_frames(int(laps), float(speed)))
    if int(seed) < 0 or int(frames) < 2 or stand < 0:
        raise ValueError(f"seed must be >= 0, frames >= 2 and stand >= 0, got seed {seed}, frames {frames}, "
                         f"stand {stand}")
    laps = int(laps)
    var = Variation.of(int(seed))
    rng = np.random.default_rng(seed)
    rig = euroc_rig()
    W, D, H = width, depth, height
    ids = Ids({"shell": 1, "structure": 100, "window": 300, "light": 400, "machine": 500, "rack": 700,
               "clutter": 800, "glazing": 900, "marking": 1000, "takeoff": 2000})
    t = 0.3
    plinth = 3.0
    out = ["// hall.ses - a machine hall flown through by a drone, EuRoC style: the MAV's stereo rig",
           f"// (cam0 {rig['resolution'][0]}x{rig['resolution'][1]}, focal {num(rig['fu'])} px, baseline "
           f"{num(rig['baseline'], 4)} m from sensor.yaml), {num(RATE_HZ, 0)} Hz.",
           f"// Generated by blender_sesgen/generators/builtin/hall.py --seed {seed} --frames {frames}"
           + (f" --flight laps --laps {laps} --speed {num(speed)}" if flight == "laps" else "")
           + (f" --stand {stand}" if stand != (STAND_FRAMES if flight == "sweep" else 0) else "")
           + " (edit that, not this file). Y up, metres.",
           f"CAMERA resolution {rig['resolution'][0]} {rig['resolution'][1]} focal {num(rig['fu'])} "
           f"principal {num(rig['cu'])} {num(rig['cv'])} baseline {num(rig['baseline'], 4)} near 0.05 far 200",
           *var.lighting.lines(), "LOOK exposure auto",
           "SENSOR profile euroc        // EuRoC's MT9V034, measured (docs/sensors.md)",
           "AUTOEXPOSURE                // its exposure follows the scene (metered before the frames render)", ""]
    clad = rng.choice(["0.3 0.33 0.36", "0.45 0.46 0.45", "0.2 0.27 0.33"])
    out += ["// materials derived from the library (colour replaces the library's)",
            # power-trowelled: a faint sheen that mirrors lamps and windows, blurred (the Physically
            # Based database's concrete: roughness 0.5; docs/sensors.md, Camera twins)
            f"MATERIAL name hall_floor library concrete colour {nums(var.floor[0])} wear {num(var.floor[1], 2)} "
            "roughness 0.55",
            "MATERIAL name floor_joint library concrete colour 0.05 0.05 0.048 wear 0",
            f"MATERIAL name cladding library metal_painted colour {clad}",
            "MATERIAL name roof_steel library metal_painted colour 0.3 0.31 0.32",
            f"MATERIAL name floor_paint library lane_marking colour {nums(var.aisle_paint)}",
            f"MATERIAL name door_paint library metal_painted colour {nums(var.door_paint)}",
            "// the lamps' diffusers glow at the lamps' own luminance (with the LIGHT under each: its flux)",
            f"MATERIAL name light_panel colour 0.85 0.85 0.83 roughness 0.3 emission {nums(var.lamps[1] or (1, 0.97, 0.92))} "
            f"emission_strength {num(lamp_luminance(var.lamps[0]), 4)}",
            "// the diffusing panes glow with the daylight they pass (0.45 x the irradiance on their",
            "// outer face / pi, from the WORLD): light-sampled, not found by bounces",
            "MATERIAL name frosted_glass library frosted_glass glow", "",
            "// the shell: floor, plinth walls, cladding between strip windows, roof"]
    out.append(f"CUBOID id {ids('shell')} name floor material hall_floor class floor "
               f"position 0 -0.1 0 dim {nums((W + 2 * t, 0.2, D + 2 * t))}")
    out.append(f"CUBOID id {ids('shell')} name roof material roof_steel class ceiling "
               f"position 0 {num(H + 0.15)} 0 dim {nums((W + 2 * t, 0.3, D + 2 * t))}")
    wall_mat = "brick" if rng.random() < 0.5 else "concrete"
    win_y0, win_y1 = 5.0, 7.2
    bay = 6.0
    for name, length, centre, along_x, inward in (("north", W, (0, 0, -D / 2 - t / 2), True, (0, 0, 1)),
                                                   ("south", W, (0, 0, D / 2 + t / 2), True, (0, 0, -1)),
                                                   ("west", D, (-W / 2 - t / 2, 0, 0), False, (1, 0, 0)),
                                                   ("east", D, (W / 2 + t / 2, 0, 0), False, (-1, 0, 0))):
        L2 = length / 2

        def box(u0, u1, y0, y1, mat, c=centre, ax=along_x):
            if ax:    # the end walls reach over the side walls' thickness: closed corners
                u0, u1 = u0 - (t if u0 <= -L2 else 0.0), u1 + (t if u1 >= L2 else 0.0)
            cu = 0.5 * (u0 + u1)
            pos = (c[0] + cu, 0.5 * (y0 + y1), c[2]) if ax else (c[0], 0.5 * (y0 + y1), c[2] + cu)
            dim = (u1 - u0, y1 - y0, t) if ax else (t, y1 - y0, u1 - u0)
            return f"CUBOID id {ids('shell')} material {mat} class wall position {nums(pos)} dim {nums(dim)}"
        low = name == "south" and flight == "sweep" and stand > 0
        if low:     # the curtained window the standing MAV faces: the plinth around it
            (a, b_), (y0, y1) = LOW_WINDOW
            out += [box(-L2, a, 0, plinth, wall_mat), box(b_, L2, 0, plinth, wall_mat),
                    box(a, b_, 0, y0, wall_mat), box(a, b_, y1, plinth, wall_mat)]
            for u0 in np.arange(a, b_ - 1e-6, LOW_WINDOW_BAY):
                u1 = min(u0 + LOW_WINDOW_BAY, b_)
                out.append(asset("window_frame", ids("window"), (centre[0] + 0.5 * (u0 + u1), y0, centre[2]), 180.0,
                                 (round(u1 - u0, 3), y1 - y0, t), seed=int(variation_rng(seed, 0xC17).integers(1e6))))
                quad = [(centre[0] + u, y, centre[2] - t / 2 - 0.05) for u, y in ((u0, y0), (u1, y0), (u1, y1), (u0, y1))]
                out.append(f"QUAD id {ids('glazing')} material frosted_glass vertices {nums(np.ravel(quad))}")
        else:
            out.append(box(-L2, L2, 0, plinth, wall_mat))
        out.append(box(-L2, L2, plinth, win_y0, "cladding"))
        out.append(box(-L2, L2, win_y1, H, "cladding"))
        n = int(length // bay)
        edges = np.linspace(-L2, L2, n + 1)
        for i in range(n):
            a, b_ = edges[i] + 0.4, edges[i + 1] - 0.4
            # the pier left of the opening, from the last opening's edge (closed: no daylight
            # slit between the bays)
            out.append(box(edges[i] - (0.4 if i else 0.0), a, win_y0, win_y1, "cladding"))
            if i == n - 1:
                out.append(box(b_, edges[i + 1], win_y0, win_y1, "cladding"))
            # the window in the opening [a, b_] x [win_y0, win_y1]; its room side faces inwards
            cu = 0.5 * (a + b_)
            pos = (centre[0] + cu, win_y0, centre[2]) if along_x else (centre[0], win_y0, centre[2] + cu)
            yaw = {(0, 0, 1): 0.0, (0, 0, -1): 180.0, (1, 0, 0): 90.0, (-1, 0, 0): -90.0}[inward]
            out.append(asset("window_frame", ids("window"), pos, yaw, (round(b_ - a, 3), win_y1 - win_y0, t),
                             seed=int(rng.integers(1e6))))
            # diffusing glazing in the wall's middle plane (inside the frame's bars): daylight
            # comes in evenly, never as sun patches, and the pane burns out in a camera exposed
            # for the room, as EuRoC V1_01's curtained window (docs/sensors.md, Camera twins)
            corners = [(a, win_y0), (b_, win_y0), (b_, win_y1), (a, win_y1)]
            quad = [(centre[0] + u, y, centre[2]) if along_x else (centre[0], y, centre[2] + u) for u, y in corners]
            out.append(f"QUAD id {ids('glazing')} material frosted_glass vertices {nums(np.ravel(quad))}")
        if name == "south":  # a big loading door (closed, steel) in the plinth, beside the low window
            door_x = rng.uniform(-W / 4, W / 4)
            if low:
                door_x = (1.0 if door_x >= 0 else -1.0) * max(abs(door_x), LOW_WINDOW[0][1] + 2.25 + 0.3)
            out.append(f"CUBOID id {ids('shell')} name loading_door material door_paint class door "
                       f"position {nums((door_x, 2.4, D / 2 - 0.02))} dim 4.5 4.8 0.1")

    out += ["", "// structure: columns along the long walls, roof girders across, lamps under them"]
    zs = np.arange(-D / 2 + bay / 2, D / 2, bay)
    col_seed = int(rng.integers(1e6))
    gir_seed = int(rng.integers(1e6))
    for z in zs:
        for x in (-W / 2 + 0.35, W / 2 - 0.35):
            out.append(asset("column", ids("structure"), (x, 0, z), 90.0, (0.4, H - 0.9, 0.4), seed=col_seed))
        out.append(asset("girder", ids("structure"), (0, H - 0.9, z), 0.0, (W, 0.9, 0.3), seed=gir_seed))
        for x in np.linspace(-W / 3, W / 3, 3):
            out.append(asset("ceiling_light", ids("light"), (x, H - 0.9, z), 0.0, LAMP, seed=7))
            out.append(f"LIGHT area position {nums((x, H - 2.55, z))} direction 0 -1 0 size {num(LAMP_LIGHT_M)} "
                       f"strength {num(np.pi * lamp_luminance(var.lamps[0]) * LAMP_LIGHT_M ** 2, 4)}"
                       + (f" colour {nums(var.lamps[1])}" if var.lamps[1] else ""))
    out.append(asset("girder", ids("structure"), (-W / 2 + 0.35, H - 0.9, 0), 90.0, (D, 0.5, 0.3), seed=gir_seed))
    out.append(asset("girder", ids("structure"), (W / 2 - 0.35, H - 0.9, 0), 90.0, (D, 0.5, 0.3), seed=gir_seed))

    out += ["", "// floor markings: aisle lines 12 cm wide"]
    for x in (-W / 2 + 6.5, W / 2 - 6.5):
        out.append(f"CUBOID id {ids('shell')} material floor_paint class floor "
                   f"position {nums((x, 0.002, 0))} dim {nums((0.12, 0.004, D - 4))}")

    # saw-cut contraction joints every 6 m, 6 mm wide and dirt-filled; the cross joints stand
    # 1 mm higher so that no two faces are coplanar (each pixel sees one id)
    out += ["", "// floor joints: saw cuts every 6 m"]
    for x in np.arange(-W / 2 + 3.0, W / 2 - 1.0, 6.0):
        out.append(f"CUBOID id {ids('shell')} material floor_joint class floor "
                   f"position {nums((x, 0.001, 0))} dim {nums((0.006, 0.002, D))}")
    for z in np.arange(-D / 2 + 2.0, D / 2 - 1.0, 6.0):
        out.append(f"CUBOID id {ids('shell')} material floor_joint class floor "
                   f"position {nums((0, 0.0015, z))} dim {nums((W, 0.003, 0.006))}")

    out += ["", "// machines and tanks along the walls, racks at the north end, pipes, clutter"]
    for side in (-1, 1):
        z = -D / 2 + 14.0
        while z < D / 2 - 4:
            size = (round(float(rng.uniform(2.5, 5)), 2), round(float(rng.uniform(1.8, 3.2)), 2),
                    round(float(rng.uniform(1.5, 3)), 2))
            kind = "tank" if rng.random() < 0.25 else "machine"
            if kind == "tank":
                dia = round(float(rng.uniform(1.6, 2.6)), 2)
                size = (dia, round(float(rng.uniform(3.5, 6)), 2), dia)
            x = side * (W / 2 - 1.0 - size[2] / 2 - rng.uniform(0.3, 1.5))
            out.append(asset(kind, ids("machine"), (x, 0, z + size[0] / 2), -90.0 * side, size,
                             seed=int(rng.integers(1e6))))
            z += size[0] + rng.uniform(1.5, 4.0)
        out.append(asset("pipe", ids("machine"), (side * (W / 2 - 0.6), 0, 0), 90.0,
                         (D - 4, round(float(rng.uniform(3, 4)), 2), round(float(rng.uniform(0.2, 0.35)), 2)),
                         seed=int(rng.integers(1e6))))
    for i, x in enumerate(np.linspace(-W / 2 + 6, W / 2 - 6, 3)):
        out.append(asset("rack", ids("rack"), (x, 0, -D / 2 + 5.5 + 0.0 * i), 0.0, (7.5, 5.5, 1.1),
                         seed=int(rng.integers(1e6))))
    out.append(asset("stairs", ids("structure"), (W / 2 - 3.0, 0, -D / 2 + 11), 0.0, (1.2, 3.5, 4.5), seed=5))
    out.append(asset("railing", ids("structure"), (-W / 2 + 6.5, 0, 6), 90.0, (8, 1.05, 0.05), seed=6))
    placed = []                  # (x, z) of the clutter: the pallet bays keep clear of it
    for _ in range(7):           # clutter in groups: stacked crates, pallets with loads, barrels
        gx = float(rng.choice([-1, 1])) * rng.uniform(6.0, W / 2 - 4.5)
        gz = rng.uniform(-D / 2 + 10, D / 2 - 3)
        for _ in range(int(rng.integers(2, 6))):
            kind = str(rng.choice(["crate", "pallet", "barrel"], p=[0.45, 0.3, 0.25]))
            x, z = gx + rng.uniform(-1.5, 1.5), gz + rng.uniform(-1.5, 1.5)
            out.append(asset(kind, ids("clutter"), (x, 0, z), rng.uniform(0, 360), seed=int(rng.integers(1e6))))
            placed.append((x, z))
    # --- the flight ------------------------------------------------------------------------
    n_flight = frames - stand - climb
    if flight == "laps":
        n_flight = max(n_flight, 2)
        P, tt, lap = _laps_path(n_flight, laps, speed, variation_rng(seed, 0x1A9))
        _, yaw, pitch, roll = _attitude(P, tt, rng, var.look, lap)
        comment = (f"the flight: {laps} laps of a {num(LAP_M, 1)} m loop through the middle of the hall, "
                   f"{frames} poses of cam0 at {num(RATE_HZ, 0)} Hz")
    else:
        n = n_flight if not stand else max(n_flight, 200)
        tt = np.arange(n) / RATE_HZ
        s = np.linspace(0, 1, n)
        # a loop through the open middle of the hall: forward along -z, a turn, drifting sideways
        path_x = var.swing * np.sin(2 * np.pi * (0.5 * s + rng.uniform(0, 0.2))) + 0.3 * smooth_noise(rng, n, 1.0, (1.2, 2.5))
        along = 0.5 - 0.5 * np.cos(np.pi * s)
        path_z = D / 2 - 12 - var.distance * (along[::-1] if var.reverse else along)
        path_y = var.height[0] + var.height[1] * np.sin(2 * np.pi * (0.6 * s + rng.uniform(0, 1))) + 0.15 * smooth_noise(rng, n, 1.0, (2.0, 4.1))
        P = np.stack([path_x, path_y, path_z], axis=1)
        # it stands facing the curtained low window in the south wall (EuRoC V1_01's camera faces its
        # curtained window), and turns to its course after lift-off
        S0 = _stand_position(P[0], np.gradient(P, axis=0)[0] * RATE_HZ)
        window = np.array([0.5 * sum(LOW_WINDOW[0]), 0.0, D / 2]) - S0
        look = float(np.degrees(np.arctan2(-window[0], -window[2])))
        climb_yaw, yaw, pitch, roll = _attitude(P, tt, rng, var.look, rest=(look, climb) if stand else None,
                                                    glance_rng=variation_rng(seed, 0x6A1))
        comment = f"the flight: {frames} poses of cam0 at {num(RATE_HZ, 0)} Hz"
    keep_off: list = []           # (x0, x1, z0, z1) boxes no pallet bay's paint reaches into
    if stand:
        S = _stand_position(P[0], np.gradient(P, axis=0)[0] * RATE_HZ)
        out += _takeoff_stand(ids, S, look)
        comment += (f": standing on the take-off stand for {stand} frames (rotors shaking it from frame "
                    f"{min(ROTORS_FRAMES, stand)}), climbing for {climb}, then flying")
        P, yaw, pitch, roll = _stand_and_take_off(P, climb_yaw, yaw, pitch, roll, stand, variation_rng(seed, 0x57A))
        out += _test_floor(ids, S, look, variation_rng(seed, 0x7E5), placed, P, keep_off)
    out += _pallet_bays(ids, D, placed, variation_rng(seed, 0xBA5), keep_off)
    return script_with_poses(out, comment, P[:frames], yaw[:frames], pitch[:frames], roll[:frames])


def _stand_position(P0: np.ndarray, V0: np.ndarray) -> np.ndarray:
    """Where cam0 stands before a take-off that meets the flight at P0 with velocity V0 (m/s):
    STAND_CAMERA_M above the floor, V0 x the climb's time / 3 back along the flight's horizontal
    velocity, so that the climb (:func:`_stand_and_take_off`) never backs up."""
    back = V0 * TAKEOFF_FRAMES / RATE_HZ / 3.0
    return np.array([P0[0] - back[0], STAND_CAMERA_M, P0[2] - back[2]])


def _stand_and_take_off(P, climb_yaw, yaw, pitch, roll, stand: int, rng):
    """The flight (poses P, angles in deg) preceded by ``stand`` frames standing still at
    :func:`_stand_position` heading where ``climb_yaw`` (:func:`_attitude`'s, deg) starts from,
    at the stand's measured pitch and roll, shaken by the rotors from frame ROTORS_FRAMES on
    (:func:`stand_shake`), and TAKEOFF_FRAMES of climb: a cubic from rest
    there to the flight's first pose and velocity, turning as ``climb_yaw``, pitch and roll
    eased into the flight's."""
    V0 = np.gradient(P, axis=0)[0] * RATE_HZ
    S = _stand_position(P[0], V0)
    Tc = TAKEOFF_FRAMES / RATE_HZ
    s = (np.arange(TAKEOFF_FRAMES) / TAKEOFF_FRAMES)[:, None]          # the flight's frame 0 is s = 1
    h01, h11 = 3 * s ** 2 - 2 * s ** 3, s ** 3 - s ** 2                # Hermite: from rest at S to (P0, V0)
    climb = S + h01 * (P[0] - S) + h11 * V0 * Tc
    ease = h01[:, 0]
    look = climb_yaw[0]
    R0 = camera_body_R(look, STAND_PITCH_DEG, STAND_ROLL_DEG)
    turns = stand_shake(rng, stand)
    stood = np.array([camera_yaw_pitch_roll(R0 @ so3_exp(R_CV_BLENDERCAM @ np.radians(w))) for w in turns]).reshape(-1, 3)
    P = np.concatenate([np.tile(S, (stand, 1)), climb, P])
    yaw = np.concatenate([stood[:, 0], climb_yaw, yaw])
    pitch = np.concatenate([stood[:, 1], STAND_PITCH_DEG + ease * (pitch[0] - STAND_PITCH_DEG), pitch])
    roll = np.concatenate([stood[:, 2], STAND_ROLL_DEG + ease * (roll[0] - STAND_ROLL_DEG), roll])
    return P, yaw, pitch, roll


def stand_shake(rng, stand: int) -> np.ndarray:
    """(stand, 3) turns (deg) of the standing camera about its own right, down and optical axes
    (OpenCV's x, y, z) away from its rest: none for the first ROTORS_FRAMES, then the rotors'
    bursty shake (SHAKE_DEG, SHAKE_HOLD, SHAKE_BURSTS)."""
    n = max(stand - ROTORS_FRAMES, 0)
    out = np.zeros((stand, 3))
    for axis in range(3):
        loud = np.exp(SHAKE_BURSTS * smooth_noise(rng, n, 1.0)) if n else np.zeros(0)
        kick = rng.normal(0.0, SHAKE_DEG[axis], n) * loud
        x = 0.0
        for k in range(n):
            x = SHAKE_HOLD[axis] * x + kick[k]
            out[ROTORS_FRAMES + k, axis] = x
    return out


TAKEOFF_STAND = (0.6, 0.5)       # the stand's top (x, z extent, m): a steel table the MAV stands on
MAV_FEET_M = 0.12                # cam0 above the MAV's feet (the Firefly's VI-sensor over its legs)


def _takeoff_stand(ids, S: np.ndarray, yaw_deg: float) -> list[str]:
    """The steel table the MAV stands on (cam0 at ``S``, STAND_CAMERA_M above the floor,
    heading ``yaw_deg``), behind cam0 so that neither camera sees it."""
    top = STAND_CAMERA_M - MAV_FEET_M
    a = np.radians(yaw_deg)
    back = np.array([np.sin(a), 0.0, np.cos(a)])       # behind the camera (it looks along -z at yaw 0)
    c = S + back * (TAKEOFF_STAND[1] / 2 + 0.02)
    return ["", "// the take-off stand: the MAV stands on it before the flight (EuRoC's camera 0.93 m up)",
            f"CUBOID id {ids('takeoff')} name takeoff_stand material door_paint class furniture "
            f"position {nums((c[0], top / 2, c[2]))} 0 {num(yaw_deg, 3)} 0 "
            f"dim {nums((TAKEOFF_STAND[0], top, TAKEOFF_STAND[1]))}"]


# what lies on the floor before the stand, in the camera's (right, ahead) metres on the floor:
# EuRoC V1_01's near field (its corners 1.45-2.4 m away, 71 % in the image's lower half; 38 % of
# its clipped pixels white things on the floor): strips of black marker tape with white markers,
# a sheet of white paper, a checkerboard calibration target standing on the floor
TAPE = (((-1.0, 0.85), (-0.5, 2.8)), ((0.05, 0.85), (0.4, 3.2)), ((1.6, 1.2), (0.8, 2.6)))
TAPE_W, MARKER = 0.1, (0.06, 0.025)          # tape width; a marker's length and width (m)
SHEET = ((-0.25, 1.8), (0.297, 0.42), 12.0)  # centre, (across, along) (an A3 sheet), turn (deg)
BOARD = ((1.5, 3.3), (6, 7), 0.07)           # centre, squares (rows, columns), square (m)
# EuRoC V1_01's camera sees crash mats 2-4 m away round its test floor (quilted, standing on edge
# along the walls, one leaning below the window), a printed play mat under the tape at its right,
# cables: most of its corners (1.45-2.4 m, 71 % in the image's lower half). Here: mats standing on
# their long edge left and right, outside the low window's azimuth (+-18 deg at 12 m), a stack
# lying before the window that hides the floor below it (its top under the sill's line of sight)
MATS_STANDING = (((-2.1, 2.9), 88.0, (2.0, 0.25, 1.4)), ((-2.3, 4.0), -4.0, (2.0, 0.3, 1.2)),
                 ((2.6, 3.7), 6.0, (1.8, 0.25, 1.4)))        # centre (u, w), turn (deg), size
MAT_STACK = ((0.3, 4.3), 5.0, (2.2, 1.4), (0.3, 0.28, 0.3))   # centre, turn, (length, width), thicknesses
PLAY_MAT = ((1.35, 2.1), -10.0, (1.0, 0.004, 1.8))           # centre, turn, size: 4 mm, its prints to 5.5 mm
CABLES = (((-0.6, 1.4), 75.0, (2.6, 0.01, 0.5)), ((0.9, 3.0), -20.0, (1.8, 0.012, 0.4)))
# EuRoC V1_01's test floor is a plain grey carpet (at 376 x 240 its pixel-scale deviation 2.1 DN at
# 156 DN, 2-8 px band 2.0 DN, 0.12 corners per 1000 px) where the hall's power-trowelled concrete
# showed 5.2 DN, 7.0 DN and 2.1 (its stains' weak corners: docs/sensors.md, the hall's still KLT):
# a needle-felt carpet laid over the test area, from behind the stand to under the mat stack,
# 3.75 mm thick (its top apart from the joints' 2 and 3.5 mm as written, the play mat's 4, the
# sheet's 5.5, the tape's 6)
CARPET = ((-3.4, -1.0), (3.6, 5.2))   # its (u, w) corners, the camera's (right, ahead) metres on the floor
CARPET_H = 0.00375
CARPET_MATERIAL = "library fabric colour 0.26 0.26 0.255 roughness 0.95 wear 0"
MAT_CLEARANCE_M = 1.0            # a mat stands at least this far from every pose of the flight (the
                                 # MAV spans ~0.6 m): else it is left out, as it would be in the flight's way


def _clear_of(path: np.ndarray, centre, rotation_deg, lo, hi) -> bool:
    """Whether every point of ``path`` (n, 3) lies at least MAT_CLEARANCE_M from the box
    [lo, hi] (its own frame) placed at ``centre`` turned by ``rotation_deg`` (SES rx ry rz)."""
    R = euler_xyz_deg_to_R(*rotation_deg)
    local = (np.asarray(path) - np.asarray(centre)) @ R
    gap = np.linalg.norm(np.maximum(np.maximum(np.asarray(lo) - local, local - np.asarray(hi)), 0.0), axis=1)
    return bool(gap.min() >= MAT_CLEARANCE_M)


def _test_floor(ids, S: np.ndarray, yaw_deg: float, rng, placed: list, path: np.ndarray,
                keep_off: list) -> list[str]:
    """A drone test area's floor in front of the take-off stand (cam0 at ``S`` heading
    ``yaw_deg``), the things EuRoC V1_01's camera sees near it (TAPE, SHEET, BOARD, the
    crash mats, a play mat, cables); a mat (the stack as one) that the flight (cam0 at
    ``path``) would pass within MAT_CLEARANCE_M of is left out, and the footprints of those
    placed join ``placed`` (the pallet bays keep clear); a carpet (CARPET) covers the test
    area, its (x0, x1, z0, z1) box joins ``keep_off`` (no bay's paint under it). Heights keep
    every top face apart from the floor's paint (joints 2 and 3.5 mm as written, aisle lines
    4 mm, bays 5 mm; none but joints under the test floor): the carpet 3.75 mm, the play mat 4 mm, its prints up to 5.5 mm,
    tape 6 mm, its markers 7 mm, the sheet 5.5 mm (not over the play mat)."""
    a = np.radians(yaw_deg)
    fwd, right = np.array([-np.sin(a), 0.0, -np.cos(a)]), np.array([np.cos(a), 0.0, -np.sin(a)])
    m = -1.0 if S[0] * right[0] > 0 else 1.0         # mirrored: the board's side towards the hall's middle

    def at(u, w, y):
        return S * np.array([1.0, 0.0, 1.0]) + m * u * right + w * fwd + np.array([0.0, y, 0.0])

    def turn(du, dw):           # the yaw (deg) of an object whose local x runs along (du, dw)
        return yaw_deg + np.degrees(np.arctan2(dw, m * du))
    out = ["", "// a drone test area's floor before the stand: marker tape, a white sheet, a checkerboard",
           "MATERIAL name tape_black library rubber colour 0.03 0.03 0.03 wear 0",
           "MATERIAL name paper_white library plastic colour 0.8 0.8 0.78 wear 0 roughness 0.6",
           f"MATERIAL name test_carpet {CARPET_MATERIAL}"]
    for (u0, w0), (u1, w1) in TAPE:
        length = float(np.hypot(u1 - u0, w1 - w0))
        out.append(f"CUBOID id {ids('takeoff')} material tape_black class floor position "
                   f"{nums(at((u0 + u1) / 2, (w0 + w1) / 2, 0.003))} 0 {num(turn(u1 - u0, w1 - w0), 3)} 0 "
                   f"dim {nums((length, 0.006, TAPE_W))}")
        for f in np.sort(rng.uniform(0.03, 0.97, int(length / 0.07))):
            side = rng.uniform(-0.5, 0.5) * (TAPE_W - MARKER[1] - 0.01)
            du, dw = (u1 - u0) / length, (w1 - w0) / length
            u, w = u0 + f * (u1 - u0) - side * dw, w0 + f * (w1 - w0) + side * du
            out.append(f"CUBOID id {ids('takeoff')} material paper_white class floor position {nums(at(u, w, 0.0035))} "
                       f"0 {num(turn(du, dw) + rng.uniform(-60, 60), 3)} 0 dim {nums((MARKER[0], 0.007, MARKER[1]))}")
    (u, w), (across, along), t = SHEET
    out.append(f"CUBOID id {ids('takeoff')} material paper_white class floor position {nums(at(u, w, 0.00275))} "
               f"0 {num(yaw_deg + m * t, 3)} 0 dim {nums((across, 0.0055, along))}")
    for (u, w), t, size in MATS_STANDING:    # on the long edge (its handles under it): the width stands up
        yaw = turn(np.cos(np.radians(t)), np.sin(np.radians(t)))
        a_ = np.radians(yaw)
        c = at(u, w, size[2] / 2 + MAT_HANDLE_M) - size[1] / 2 * np.array([np.sin(a_), 0.0, np.cos(a_)])
        mat_seed = int(rng.integers(1e6))
        L, T_, Wd = size
        if _clear_of(path, c, (90.0, yaw, 0.0), (-L / 2, 0.0, -Wd / 2), (L / 2, T_, Wd / 2)):
            out.append(f"ASSET crash_mat id {ids('takeoff')} seed {mat_seed} position {nums(c)} "
                       f"90 {num(yaw, 3)} 0 size {nums(size)}")
            placed += [tuple(at(u + f * L * np.cos(np.radians(t)), w + f * L * np.sin(np.radians(t)), 0)[[0, 2]])
                       for f in (-0.5, 0.0, 0.5)]
    (u, w), t, (length, width), layers = MAT_STACK
    yaw, y = turn(np.cos(np.radians(t)), np.sin(np.radians(t))), 0.0
    stack = []
    for h in layers:
        stack.append((int(rng.integers(1e6)), at(u, w, y), yaw + rng.normal(0, 2), (length, h, width)))
        y += h
    reach = np.hypot(length, width) / 2          # each layer turned a little: its circle's box
    if _clear_of(path, at(u, w, 0), (0.0, 0.0, 0.0), (-reach, 0.0, -reach), (reach, y, reach)):
        for mat_seed, c, a_, size in stack:
            out.append(f"ASSET crash_mat id {ids('takeoff')} seed {mat_seed} position {nums(c)} "
                       f"0 {num(a_, 3)} 0 size {nums(size)}")
        placed += [tuple(at(u + f * length, w, 0)[[0, 2]]) for f in (-0.5, 0.0, 0.5)]
    (u, w), t, size = PLAY_MAT
    out.append(f"ASSET play_mat id {ids('takeoff')} seed {int(rng.integers(1e6))} position {nums(at(u, w, 0))} "
               f"0 {num(yaw_deg + m * t, 3)} 0 size {nums(size)}")
    placed.append(tuple(at(u, w, 0)[[0, 2]]))
    for (u, w), t, size in CABLES:
        out.append(f"ASSET cable id {ids('takeoff')} seed {int(rng.integers(1e6))} position {nums(at(u, w, 0))} "
                   f"0 {num(turn(np.cos(np.radians(t)), np.sin(np.radians(t))), 3)} 0 size {nums(size)}")
    (u, w), (rows, cols), q = BOARD
    face = yaw_deg - np.degrees(np.arctan2(m * u, w))      # the board faces the camera (left is +yaw)
    out.append(f"CUBOID id {ids('takeoff')} name checkerboard material paper_white class furniture position "
               f"{nums(at(u, w, (rows + 1) * q / 2))} 0 {num(face, 3)} 0 "
               f"dim {nums(((cols + 1) * q, (rows + 1) * q, 0.02))}")
    fa = np.radians(face)
    towards = np.array([-np.sin(fa), 0.0, -np.cos(fa)]) * -1.0     # the board's normal towards the camera
    along_x = np.array([np.cos(fa), 0.0, -np.sin(fa)])
    centre = at(u, w, (rows + 1) * q / 2) + towards * 0.011
    for i in range(rows):
        for j in range(cols):
            if (i + j) % 2:
                continue
            c = centre + along_x * (j - (cols - 1) / 2) * q + np.array([0.0, (i - (rows - 1) / 2) * q, 0.0])
            out.append(f"CUBOID id {ids('takeoff')} material tape_black class furniture position {nums(c)} "
                       f"0 {num(face, 3)} 0 dim {nums((q, q, 0.002))}")
    (u0, w0), (u1, w1) = CARPET
    corners = np.array([at(u, w, 0.0) for u in (u0, u1) for w in (w0, w1)])
    out.append(f"CUBOID id {ids('takeoff')} name test_carpet material test_carpet class floor position "
               f"{nums(at((u0 + u1) / 2, (w0 + w1) / 2, CARPET_H / 2), 5)} 0 {num(turn(1.0, 0.0), 3)} 0 "
               f"dim {nums((u1 - u0, CARPET_H, w1 - w0), 5)}")
    keep_off.append((corners[:, 0].min(), corners[:, 0].max(), corners[:, 2].min(), corners[:, 2].max()))
    return out


BAY = (1.4, 1.2, 0.05)           # a pallet bay's inside (x, z) and its painted line's width (m)
BAY_ROWS_X = (5.2, 6.9)          # |x| of the two rows of bays each side of the open middle (the laps fly |x| <= 3.3)


def _pallet_bays(ids, D: float, placed, rng, keep_off=()) -> list[str]:
    """Floor storage bays marked in paint beside the open middle (halls over 1000 m2 mark their
    traffic routes and storage areas with lines >= 5 cm wide, yellow or white: the German
    workplace rule ASR A1.8), half of them holding a pallet, some loaded with a crate: the
    floor beside the flight has the paint edges, corners and low loads of a working hall. Each bay is four
    strips (long sides whole, short ones between them: no two overlap), 5 mm high, above the
    joints (2-3 mm) and aisle lines (4 mm), so no two faces are coplanar; a bay where clutter
    (``placed``: its (x, z)) stands within its largest footprint (a 1.6 x 1.4 m crate: 1.06 m
    from its centre) of the bay's (0.75 x 0.65 m) is left out, and so is one whose lines would
    reach into a ``keep_off`` box (x0, x1, z0, z1: the test floor's carpet)."""
    w, d, lw = BAY
    h = 0.005
    out = ["", "// pallet bays: painted storage areas beside the open middle, pallets and loads on some"]
    paint = "floor_paint" if rng.random() < 0.5 else "lane_marking"
    for side in (-1, 1):
        for xc in BAY_ROWS_X:
            x = side * xc
            for z in np.arange(-D / 2 + 9.0, D / 2 - 5.0, d + 2 * lw + 0.25):
                if (rng.random() < 0.25 or any(abs(px - x) < 1.9 and abs(pz - z) < 1.8 for px, pz in placed)
                        or any(x - w / 2 - lw < x1 and x + w / 2 + lw > x0 and z - d / 2 - lw < z1
                               and z + d / 2 + lw > z0 for x0, x1, z0, z1 in keep_off)):
                    continue                     # a gap in the row (a crossing), or clutter stands there
                for sx in (-1, 1):
                    out.append(f"CUBOID id {ids('marking')} material {paint} class floor position "
                               f"{nums((x + sx * (w + lw) / 2, h / 2, z))} dim {nums((lw, h, d + 2 * lw))}")
                for sz in (-1, 1):
                    out.append(f"CUBOID id {ids('marking')} material {paint} class floor position "
                               f"{nums((x, h / 2, z + sz * (d + lw) / 2))} dim {nums((w, h, lw))}")
                if rng.random() < 0.5:
                    yaw = float(rng.normal(0, 3))
                    out.append(asset("pallet", ids("marking"), (x, h, z), yaw, seed=int(rng.integers(1e6))))
                    if rng.random() < 0.5:
                        out.append(asset("crate", ids("marking"), (x, h + 0.144, z), yaw + float(rng.normal(0, 4)),
                                         seed=int(rng.integers(1e6))))
    return out


def bounded_yaw(target_deg: np.ndarray, start_deg: float, start_rate_deg_s: float = 0.0) -> np.ndarray:
    """The heading (deg, one a frame at RATE_HZ) of a multirotor that wants ``target_deg``
    (unwrapped) and turns at most YAW_RATE_MAX_DEG_S, changing that rate by at most
    YAW_ACCEL_MAX_DEG_S2, from ``start_deg`` turning at ``start_rate_deg_s`` the frame before
    the first: it follows the target's own turning and closes on it within YAW_FOLLOW_S
    (braking in time for it: no overshoot at the bounded rate). Causal: a shorter target
    gives the start of a longer one's heading."""
    dt = 1.0 / RATE_HZ
    y, w, last = float(start_deg), float(start_rate_deg_s), float(start_deg)
    out = np.empty(len(target_deg))
    for i, tgt in enumerate(np.asarray(target_deg, dtype=float)):
        e = tgt - y
        want = (tgt - last) / dt + np.sign(e) * min(abs(e) / YAW_FOLLOW_S, np.sqrt(2.0 * YAW_ACCEL_MAX_DEG_S2 * abs(e)))
        want = float(np.clip(want, -YAW_RATE_MAX_DEG_S, YAW_RATE_MAX_DEG_S))
        w += float(np.clip(want - w, -YAW_ACCEL_MAX_DEG_S2 * dt, YAW_ACCEL_MAX_DEG_S2 * dt))
        y, last = y + w * dt, float(tgt)
        out[i] = y
    return out


# V1_01's MAV looks around in glances: its heading (the gyro about gravity, 20-Hz frames over the
# flight, 6-145 s) holds still for most frames (median turn 0.31 deg a frame, p75 1.05, p90 1.56)
# and turns in bursts (1-s means of the rate: median 7 deg/s, p90 28), 87 deg peak to peak over
# 10 s (median; p10-p90 45-158), whichever way it flies
GLANCE_HOLD_S = (0.8, 3.0)       # how long it holds a heading (s)
GLANCE_RATE_DEG_S = (12.0, 28.0)  # a glance's mean turning rate (its peak pi/2 x that, under the bound)
HOVER_YAW_DEG = 1.0              # the heading's slow wander while holding (deg, RMS)


def glances(rng, n: int, start_deg: float, look: float, course_deg: np.ndarray) -> np.ndarray:
    """The heading (deg, one a frame at RATE_HZ) a MAV that looks around wants: it holds a
    heading for GLANCE_HOLD_S, then turns by 0.5-1.5 x ``look`` degrees at GLANCE_RATE_DEG_S
    (eased in and out), two times in three towards its course (``course_deg``, the flight's
    heading at that frame) when that lies further than ``look`` away, else either way. Drawn
    glance by glance from ``rng``: a shorter flight's wanted heading is the start of a longer
    one's."""
    want = np.empty(n)
    y, i = float(start_deg), 0
    while i < n:
        hold = max(int(rng.uniform(*GLANCE_HOLD_S) * RATE_HZ), 1)
        want[i:i + hold] = y
        i += hold
        if i >= n:
            break
        amp = look * rng.uniform(0.5, 1.5)
        off = (course_deg[i] - y + 180.0) % 360.0 - 180.0
        sign = np.sign(off) if abs(off) > look and rng.uniform() < 2 / 3 else (1.0 if rng.uniform() < 0.5 else -1.0)
        dur = max(int(amp / rng.uniform(*GLANCE_RATE_DEG_S) * RATE_HZ), 2)
        ease = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, dur + 1) / dur)
        want[i:i + dur] = (y + sign * amp * ease)[:n - i]
        y, i = y + sign * amp, i + dur
    return want


def _attitude(P: np.ndarray, tt: np.ndarray, rng, look: float, lap: Optional[np.ndarray] = None,
              rest: Optional[tuple] = None, glance_rng=None):
    """Climb yaw, and yaw, pitch, roll (deg) of a multirotor flying the positions P at the
    times tt: looking around in glances of about ``look`` degrees (:func:`glances`, drawn from
    ``glance_rng``) from its start heading, wandering by HOVER_YAW_DEG, turning at a bounded
    rate (:func:`bounded_yaw`), tilting into its accelerations (pitch forward to speed up,
    roll into turns). ``lap``: the laps flown at each pose (a laps flight): the heading then
    follows the velocity and a look-around that follows the place on the loop, the same lap
    after lap but for a slow wander, so that a revisit looks where the last pass looked.
    ``rest``: (heading deg, frames): the MAV rests at that heading (taken nearest the flight's
    first) and climbs for those frames into the flight's first pose, its glances starting
    there; the climb yaw (its first the rest heading) is empty without ``rest``."""
    n = len(P)
    vel = np.gradient(P, tt, axis=0)
    acc = np.gradient(vel, tt, axis=0)
    heading = np.degrees(np.unwrap(np.arctan2(-vel[:, 0], -vel[:, 2])))
    if lap is None:   # glances, whichever way it flies (a multirotor need not face its course)
        lead = rest[1] if rest is not None else 0
        start = heading[0] if rest is None else heading[0] - ((heading[0] - rest[0] + 180.0) % 360.0 - 180.0)
        want = glances(glance_rng, n + lead, start, look, np.concatenate([np.full(lead, heading[0]), heading]))
        want += HOVER_YAW_DEG * smooth_noise(glance_rng, n + lead, 1.0, (3.1, 5.3, 8.9))
        turned = bounded_yaw(want[1:], want[0])
        climb = np.concatenate([want[:1], turned[:lead - 1]]) if lead else np.empty(0)
        yaw = np.concatenate([want[:1], turned])[lead:]
    else:   # whole cycles per lap: continuous from one lap into the next
        phase = 2 * np.pi * np.asarray(lap)
        per_place = sum(np.sin(c * phase + rng.uniform(0, 2 * np.pi)) for c in (1, 2))
        yaw = heading + look * (per_place + 0.25 * smooth_noise(rng, n, 1.0, (0.9, 1.7)))
        climb = np.empty(0)
        yaw = np.concatenate([yaw[:1], bounded_yaw(yaw[1:], yaw[0], np.clip((yaw[1] - yaw[0]) * RATE_HZ, -YAW_RATE_MAX_DEG_S,
                                                                                YAW_RATE_MAX_DEG_S))])
    pitch = FLIGHT_PITCH_DEG + np.degrees(np.clip(-(acc[:, 2] * np.cos(np.radians(yaw)) + acc[:, 0] * np.sin(np.radians(yaw))) / 9.81, -0.1, 0.1)) \
        + 0.5 * smooth_noise(rng, n, 1.0, (9.0, 17.0))
    roll = np.degrees(np.clip((acc[:, 0] * np.cos(np.radians(yaw)) - acc[:, 2] * np.sin(np.radians(yaw))) / 9.81, -0.1, 0.1)) \
        + 0.6 * smooth_noise(rng, n, 1.0, (8.0, 15.0))
    return climb, yaw, pitch, roll


LAP_CENTRE = (0.0, 3.0)          # the loop's middle (x, z): the open floor between the clutter
LAP_HALF = (3.0, 6.5)            # half its width (x) and length (z) to the centre of its rounded ends
LAP_M = 2 * 2 * LAP_HALF[1] + 2 * np.pi * LAP_HALF[0]      # a stadium: two straights, two half circles


def _laps_frames(laps: int, speed: float) -> int:
    return int(round(laps * LAP_M / speed * RATE_HZ)) + 1


def _laps_path(frames: int, laps: int, speed: float, rng) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions (frames, 3), times and laps flown (0..laps) of a drone flying ``laps`` laps of a stadium-shaped loop
    (straights along z, half circles at the ends) counter-clockwise seen from above, at about
    ``speed`` m/s (+-20 %), each lap at its own height (1.2-2.2 m) and a little wider or
    narrower, so that it passes the same places again and again, never exactly the same way."""
    tt = np.arange(frames) / RATE_HZ
    v = speed * (1.0 + 0.2 * smooth_noise(rng, frames, 1.0, (1.3, 3.1)))
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) / RATE_HZ)])
    s *= laps * LAP_M / max(s[-1], 1e-9)                            # exactly ``laps`` laps
    lap = s / LAP_M
    u = (s % LAP_M)
    a, b = LAP_HALF
    straight = 2 * b
    x, z = np.empty(frames), np.empty(frames)
    for i, ui in enumerate(u):               # east straight (towards -z), north end, west straight, south end
        if ui < straight:
            x[i], z[i] = a, b - ui
        elif ui < straight + np.pi * a:
            ang = (ui - straight) / a
            x[i], z[i] = a * np.cos(ang), -b - a * np.sin(ang)
        elif ui < 2 * straight + np.pi * a:
            x[i], z[i] = -a, -b + (ui - straight - np.pi * a)
        else:
            ang = (ui - 2 * straight - np.pi * a) / a
            x[i], z[i] = -a * np.cos(ang), b + a * np.sin(ang)
    heights = rng.uniform(1.2, 2.2, laps + 1)
    widen = rng.uniform(-0.3, 0.3, laps + 1)
    k = np.minimum(np.floor(lap).astype(int), laps - 1)
    f = lap - k
    ease = 0.5 - 0.5 * np.cos(np.pi * f)                              # smooth hand-over between laps
    y = heights[k] + (heights[k + 1] - heights[k]) * ease + 0.1 * smooth_noise(rng, frames, 1.0, (11.0, 23.0))
    w = 1.0 + (widen[k] + (widen[k + 1] - widen[k]) * ease) / a
    P = np.stack([LAP_CENTRE[0] + w * x, y, LAP_CENTRE[1] + z * (1.0 + 0.04 * (w - 1.0))], axis=1)
    return P, tt, lap


if __name__ == "__main__":
    command_line(generate, __doc__, None)
