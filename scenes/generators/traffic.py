"""Writes scenes/street_kitti_traffic.ses: street_kitti.ses's street and KITTI drive with traffic.

The street of ``street.py --kitti`` (KITTI odometry's rig: 1226x370 px, f = 707 px, baseline
0.54 m, 50 steps of ~1.2 m at KITTI's 10 frames/s) gets a cross street ~40 m ahead, and moves:

- cars (a low-poly car mesh, ``scenes/traffic/car.obj``) driving along the street's curve in
  both directions — oncoming in the left lane, one turning out of the cross street into
  ours and leading the way — replayed from TUM trajectory files ``scenes/traffic/*.tum``
  (MOVE ... file), and two crossing the intersection at constant speed (MOVE ... twist);
- people (``scenes/traffic/person.obj``) walking along both sidewalks and crossing the road
  far ahead (MOVE ... twist: walking speed 1.3-1.5 m/s).

Cars carry ``class car`` and people ``class person``, so the cityscapes and vkitti2 exports
label them (car/person, vKITTI 2's Car with an instance).

Lanes are 1.5 m left and right of the street axis (the camera drives on the axis, parked
boxes stand at 3.6 m, people walk 5.5-6.2 m out); nothing moving comes closer than 2 m to the
camera (tests/test_scenes_traffic.py checks that, and that traffic is in view).
Run: python scenes/generators/traffic.py > scenes/street_kitti_traffic.ses
(it also rewrites scenes/traffic/).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from blender_sesgen.contract.trajectory_files import format_tum
from blender_sesgen.generators.builtin import street

HERE = Path(__file__).resolve().parent

ASSETS = HERE.parent / "traffic"          # scenes/traffic: meshes and trajectories (--assets DIR: elsewhere)
RATE = 10.0                               # KITTI: 10 frames per second
FRAMES = street.KITTI_STEPS + 1
CROSSING = (18, 22)                       # street axis segments of the cross street's mouth
LANE = 1.5
FIRST_ID = 5000
# oncoming cars: (name, arc length at frame 0 (m), speed (m/s, negative: towards the camera), texture, colour)
ONCOMING = (("oncoming_1", 70.0, -11.0, 4, (0.8, 0.2, 0.2)), ("oncoming_2", 112.0, -10.0, 9, (0.3, 0.4, 0.8)),
            ("oncoming_3", 150.0, -12.0, 12, (0.9, 0.9, 0.85)))
# cars crossing the intersection: (name, side (+1: towards the right arm), distance from the
# crossing's centre at frame 0 (m), speed (m/s), first frame, colour)
CROSSERS = (("crossing_1", 1, 15.0, 9.0, 0, (0.9, 0.7, 0.1)), ("crossing_2", -1, 12.0, 8.0, 0, (0.5, 0.5, 0.55)))
TURN_WAIT = 2
UP = np.array([0.0, 1.0, 0.0])


# --- meshes (SES-local: Y up, forward +Z, origin on the ground under the centre) -----------

def _box(c, s):
    """Vertices and quads of an axis-aligned box, centre c, size s."""
    c, h = np.asarray(c, float), np.asarray(s, float) / 2
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h + c
    f = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return v, f


def _wheel(c, r, w, n=10):
    """A wheel: an n-gon prism around the x axis."""
    a = 2 * np.pi * np.arange(n) / n
    ring = np.stack([np.zeros(n), r * np.sin(a), r * np.cos(a)], axis=1)
    v = np.concatenate([ring + (c[0] - w / 2, c[1], c[2]), ring + (c[0] + w / 2, c[1], c[2])])
    f = [(i, (i + 1) % n, n + (i + 1) % n, n + i) for i in range(n)] + [tuple(range(n))[::-1], tuple(range(n, 2 * n))]
    return v, f


def _obj(parts) -> str:
    lines, base = [], 0
    for v, f in parts:
        lines += [f"v {x:.4f} {y:.4f} {z:.4f}" for x, y, z in v]
        lines += ["f " + " ".join(str(base + i + 1) for i in face) for face in f]
        base += len(v)
    return "\n".join(lines) + "\n"


def car_obj() -> str:
    """A 4.3 x 1.8 x 1.45 m car: body, cabin, four wheels."""
    parts = [_box((0, 0.55, 0), (1.8, 0.6, 4.3)), _box((0, 1.1, -0.2), (1.6, 0.55, 2.3))]
    for x in (-0.8, 0.8):
        for z in (-1.4, 1.4):
            parts.append(_wheel((x, 0.33, z), 0.33, 0.22))
    return _obj(parts)


def person_obj() -> str:
    """A 1.75 m person: legs, torso, arms, head (boxes)."""
    parts = [_box((-0.1, 0.42, 0), (0.14, 0.84, 0.16)), _box((0.1, 0.42, 0), (0.14, 0.84, 0.16)),
             _box((0, 1.15, 0), (0.42, 0.62, 0.24)), _box((-0.27, 1.12, 0), (0.1, 0.6, 0.12)),
             _box((0.27, 1.12, 0), (0.1, 0.6, 0.12)), _box((0, 1.6, 0), (0.2, 0.26, 0.22))]
    return _obj(parts)


# --- the street's axis as a curve: arc length -> point, heading -------------------------------

class Axis:
    """The drive's ground track (the full 300-frame drive, 0.2-0.4 m apart), extended
    straight by 200 m at both ends; positions and headings by arc length."""

    def __init__(self, T: np.ndarray):
        p = T[:, :3, 3] * [1, 0, 1]
        f0 = self._flat(T[0][:3, 2])
        f1 = self._flat(T[-1][:3, 2])
        ext = np.linspace(0, 200, 101)[1:]
        p = np.concatenate([p[0] - ext[::-1, None] * f0, p, p[-1] + ext[:, None] * f1])
        self.p = p
        self.s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]) - 200.0

    @staticmethod
    def _flat(v):
        v = v * [1, 0, 1]
        return v / np.linalg.norm(v)

    def at(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """(ground point, unit heading) at arc length s (m from the start of the drive)."""
        point = np.array([np.interp(s, self.s, self.p[:, i]) for i in range(3)])
        ahead = np.array([np.interp(s + 1.0, self.s, self.p[:, i]) for i in range(3)])
        behind = np.array([np.interp(s - 1.0, self.s, self.p[:, i]) for i in range(3)])
        return point, self._flat(ahead - behind)

    def project(self, x: np.ndarray) -> float:
        """Arc length of the axis point nearest to ``x``."""
        return float(self.s[np.argmin(np.linalg.norm(self.p - x * [1, 0, 1], axis=1))])


def yaw_deg(heading) -> float:
    """Rotation about +Y that turns local +Z into ``heading``."""
    return float(np.degrees(np.arctan2(heading[0], heading[2])))


def pose(point, heading) -> np.ndarray:
    a = np.radians(yaw_deg(heading))
    T = np.eye(4)
    T[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    T[:3, 3] = point
    return T


def along_street(axis: Axis, s0: float, speed: float, lane: float, frames: int = FRAMES) -> np.ndarray:
    """(frames, 4, 4) poses of a car driving along the street: ``speed`` m/s (negative:
    against the drive's direction), ``lane`` metres right of the axis (of the drive's direction)."""
    out = []
    for k in range(frames):
        s = s0 + speed * k / RATE
        point, h = axis.at(s)
        right = np.cross(h, UP)
        out.append(pose(point + lane * right, h if speed >= 0 else -h))
    return np.stack(out)


def turning_in(axis: Axis, centre_s: float, speed: float, radius: float, wait: int,
               approach: float = 12.0) -> np.ndarray:
    """A car coming out of the cross street's right arm (heading -r, in its right-hand lane),
    turning right on a quarter circle of ``radius`` into the drive's right lane, then driving
    ahead along the street; it starts ``approach`` m before the turn, after ``wait`` frames."""
    c, h = axis.at(centre_s)
    r = np.cross(h, UP)
    start = c + (LANE + radius) * r + LANE * h        # where the turn begins (heading -r)
    centre = start + radius * h                       # the turn's centre (on the car's right)
    s_end = centre_s + radius + LANE                  # the turn ends in the right lane here
    arc = np.pi / 2 * radius
    out = []
    for k in range(FRAMES):
        d = max(k - wait, 0) * speed / RATE
        if d < approach:
            out.append(pose(start + (approach - d) * r, -r))
        elif d < approach + arc:
            phi = (d - approach) / radius
            p = centre - radius * np.cos(phi) * h - radius * np.sin(phi) * r
            out.append(pose(p, np.sin(phi) * h - np.cos(phi) * r))
        else:
            point, hh = axis.at(s_end + d - approach - arc)
            out.append(pose(point + LANE * np.cross(hh, UP), hh))
    return np.stack(out)


def fmt(*v) -> str:
    return street.fmt(*v)


def main(assets: Path = ASSETS) -> None:
    rows, T = street.drive(kitti=True)
    axis = Axis(T)
    pts, heads = street.street_axis(T)
    lines = street.street_lines(kitti=True, crossing=CROSSING)
    lines[0] = "// street_kitti_traffic.ses - street_kitti.ses's street and KITTI drive with a cross street and traffic:"
    lines[1] = ("// cars driving both ways, turning in and crossing, people walking; 1226x370 px, f 707 px, "
                "baseline 0.54 m, 10 frames/s.")
    lines[2] = "// Generated by scenes/generators/traffic.py (edit that, not this file). Y up, metres."
    ego = lines.index(next(ln for ln in lines if ln.startswith("// the drive")))
    assets.mkdir(parents=True, exist_ok=True)
    (assets / "car.obj").write_text(car_obj())
    (assets / "person.obj").write_text(person_obj())
    cross_a, cross_b = pts[CROSSING[0]], pts[CROSSING[1]]
    cross_c = (cross_a + cross_b) / 2
    s_cross = axis.project(cross_c)
    h_cross = (cross_b - cross_a) / np.linalg.norm(cross_b - cross_a)
    r_cross = np.cross(h_cross, UP)

    traffic = ["", "TIMING rate 10", "",
               "// traffic: cars (scenes/traffic/car.obj) replay TUM trajectories or drive at constant speed; "
               "people walk"]
    next_id = FIRST_ID
    cars = [  # (name, poses, texture, colour)
        (name, along_street(axis, s0, speed, -LANE), tex, col) for name, s0, speed, tex, col in ONCOMING
    ] + [("lead_turning_in", turning_in(axis, s_cross, 9.0, 6.0, wait=TURN_WAIT), 1, (0.2, 0.6, 0.3))]
    for name, P, tex, col in cars:
        tum = assets / f"{name}.tum"
        tum.write_text(format_tum(np.arange(FRAMES) / RATE, P,
                                  comment="T_world_obj of a car: x right, y up, z forward; SES world"))
        p0, y0 = P[0][:3, 3], yaw_deg(P[0][:3, 2])
        traffic.append(f"MESH id {next_id} name {name} class car file traffic/car.obj texture {tex} colour {fmt(*col)} "
                       f"position {fmt(*p0)} 0 {y0:.4f} 0")
        traffic.append(f"MOVE id {next_id} file traffic/{name}.tum format tum")
        next_id += 1
    # two cars crossing the intersection at constant speed (own frame: forward = +z), each in
    # its right-hand lane, before the camera gets there
    for name, sgn, dist, speed, start_frame, colour in CROSSERS:
        heading = sgn * r_cross
        right = np.cross(heading, UP)
        p0 = cross_c - heading * dist + LANE * right
        traffic.append(f"MESH id {next_id} name {name} class car file traffic/car.obj texture 7 colour {fmt(*colour)} "
                       f"position {fmt(*p0)} 0 {yaw_deg(heading):.4f} 0")
        traffic.append(f"MOVE id {next_id} twist 0 0 {speed / RATE:.3f} 0 0 0 from {start_frame}")
        next_id += 1
    # people: along both sidewalks, and crossing the street far ahead
    # (lateral offset: walking with the drive keep 5.5 m, against it 6.2 m; arc length at frame 0; speed)
    people = [(-5.5, 8.0, 1.4), (-6.2, 20.0, -1.3), (5.5, 14.0, 1.5), (6.2, 30.0, -1.4),
              (6.2, 52.0, -1.3), (-5.5, 60.0, 1.4)]
    for i, (side, s0, speed) in enumerate(people):
        point, h = axis.at(s0)
        heading = h if speed > 0 else -h
        p0 = point + side * np.cross(h, UP)
        traffic.append(f"MESH id {next_id} name walker_{i + 1} class person file traffic/person.obj colour {fmt(*np.random.default_rng(i).uniform(0.2, 0.9, 3))} "
                       f"position {fmt(*p0)} 0 {yaw_deg(heading):.4f} 0")
        traffic.append(f"MOVE id {next_id} twist 0 0 {abs(speed) / RATE:.3f} 0 0 0")
        next_id += 1
    # a crosswalk ~100 m ahead, mid-way along a (10 m) segment with no parked box on either side
    seg = next(i for i in range(len(pts) - 1) if i % 3 == 1 and axis.project(pts[i]) >= 95.0)
    point, h = axis.at(axis.project((pts[seg] + pts[seg + 1]) / 2))
    for i, (sgn, offset, start) in enumerate(((1, -0.5, 12), (-1, 0.5, 0))):
        heading = sgn * np.cross(h, UP)
        p0 = point - heading * 7.5 + offset * h
        traffic.append(f"MESH id {next_id} name crossing_walker_{i + 1} class person file traffic/person.obj "
                       f"colour {fmt(*np.random.default_rng(10 + i).uniform(0.2, 0.9, 3))} "
                       f"position {fmt(*p0)} 0 {yaw_deg(heading):.4f} 0")
        traffic.append(f"MOVE id {next_id} twist 0 0 0.14 0 0 0 from {start}")
        next_id += 1
    print("\n".join(lines[:ego] + traffic + lines[ego:]))


if __name__ == "__main__":
    args = sys.argv[1:]
    main(Path(args[args.index("--assets") + 1]) if "--assets" in args else ASSETS)
