"""Writes scenes/city_loop.ses: a city of blocks driven through by the KITTI rig, with loop closures.

A grid of rectangular blocks of random sizes (some joined two by two, leaving T-junctions)
with two-way streets: flat asphalt with dashed centre lines, stop lines and zebra
crossings, junction squares, kerbs and sidewalks around every block. Each block has its own
style: downtown (tall perimeter buildings around a paved courtyard), residential (houses
with front yards, hedges and fences, gardens behind), park (lawn, trees, bushes, paths and
benches) or commercial (a large low building behind its car park). Street lights, street
trees, traffic lights and stop signs at junctions, bins and bollards; parked cars along the
kerbs; a ring of buildings around the city. Moving traffic: cars driving their own routes
on the streets (MOVE keyframes), keeping their lanes. A physical sky with its sun and, by
default, a haze that fades everything to the sky's colour at the camera's far plane.

The rig is KITTI's (1226 x 370 px, f = 707 px, baseline 0.54 m, 1.65 m above the road) at
KITTI's 10 Hz. It drives a route planned on the street graph (``road_network``): in the
right lane, turning only at junctions (no U-turns), slowing for turns, stopping at some
junctions, within a top speed and acceleration limits; at least ``route_m`` metres long,
returning ``closures`` times to a street driven at least ``gap_s`` seconds before -- in the
same direction, the opposite one, or alternately (``direction``) -- and driving every
other street once. The script's header lists the loop closures (frames and time gap).

    python -m blender_sesgen.generators.builtin.city_grid [--seed N] [--route-m M] [--closures N] > scenes/city_loop.ses

``generate(seed, **options)`` returns the script (the checked-in city_loop.ses is seed 0
with the defaults). Every seed lays out its own city and route; a seed other than 0 also
varies (:class:`Variation`) the time of day (sun elevation 15-65 deg, any azimuth, or one
time in three a bundled daylight HDRI), the asphalt and paving, and the driver (top speed
9-13 m/s, how often it stops).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import road_network as rn
from .sesgen_layout import (ASPHALT, HAZE, KITTI_CAMERA_HEIGHT, Frontage, Ids, Lighting, asset, command_line,
                           derived_material, draw_lighting, draw_street_surfaces, kerb_cars, kitti_rig, line_street_side, num, nums,
                           script_with_poses, SeededVariation, smooth_noise, street_lights, VariantPool)

RATE_HZ = 10.0                   # KITTI odometry's frame rate
HALF_ROAD, LANE = 5.0, 1.75      # asphalt half width; the lane's centre right of the axis (m)
KERB_W, KERB_H, WALK_W = 0.2, 0.13, 3.0
LOT_Y = 0.14                     # top of a block's lots (1 cm above the sidewalks)
PARKED = 0.95                    # a parked car's centre from the kerb (m)
# id ranges (ids say what an object is); the generator checks that none runs into the next
ID_STARTS = {"street": 1, "marking": 1500, "block": 5000, "building": 7000, "tree": 10000, "veg": 13000,
             "furniture": 16000, "car": 21000, "traffic": 24000, "ground": 24500}
POOLS = {"tree": 10, "conifer": 4, "bush": 8, "hedge": 6, "fence": 6, "car": 12, "bin": 4, "streetlight": 3,
         "bench": 3, "bollard": 2, "traffic_light": 2, "pole": 2, "sign": 6}   # asset variants (shared meshes)
STYLES = {   # how each kind of block lines its sides (sesgen_layout.Frontage)
    "downtown": Frontage(start=(0.0, 1.0), p_green=0.03, width=(14.0, 26.0), depth=(12.0, 16.0),
                         height_low=(12.0, 20.0), height_high=(20.0, 34.0), p_high=0.5, setback=(0.2, 1.0),
                         gap=(0.0, 1.5), p_second_row=0.0),
    "residential": Frontage(start=(1.0, 5.0), p_green=0.18, green_length=(15.0, 25.0), green_depth=(3.0, 12.0),
                            width=(9.0, 15.0), depth=(8.0, 12.0), height_low=(6.0, 9.0), height_high=(9.0, 13.0),
                            p_high=0.3, setback=(3.0, 7.0), gap=(3.0, 9.0), p_second_row=0.0),
}


@dataclass(frozen=True)
class Variation(SeededVariation, salt=0xC1D):
    """What a seed changes besides the layout and route; the defaults are city_loop.ses's (seed 0)."""
    lighting: Lighting = Lighting(sun=(40.0, 140.0))
    road: Optional[tuple] = None         # (colour, wear) of the asphalt; None: the library's
    paving: Optional[tuple] = None       # (colour, wear) of the sidewalks' paving
    v_max: float = 11.0                  # the driver's top speed (m/s)
    p_stop: float = 0.25                 # the share of junctions where it stops

    @classmethod
    def draw(cls, rng: np.random.Generator) -> "Variation":
        tone = float(rng.uniform(0.8, 1.35))
        return cls(lighting=draw_lighting(rng, elevation=(15.0, 65.0), p_hdri=1 / 3),
                   **draw_street_surfaces(rng, tone),
                   v_max=round(float(rng.uniform(9.0, 13.0)), 2), p_stop=round(float(rng.uniform(0.15, 0.4)), 2))


def _blocks_for(route_m: float, block_m) -> int:
    """The smallest square grid (>= 2 x 2 blocks) with about three times the route in streets."""
    n = 2
    while 2 * n * (n + 1) * float(np.mean(block_m)) < 3.0 * route_m:
        n += 1
    return n


def _line_place(p0, h, y: float):
    """``place(s, offset)`` of a straight line from ground point p0 along heading h (offset:
    to the right), at height y."""
    p0, h = np.asarray(p0, float), np.asarray(h, float)
    r = rn.right_of(h)
    yaw = float(rn.yaw_deg(h))

    def place(s, offset):
        q = p0 + float(np.asarray(s).ravel()[0]) * h + offset * r
        return np.array([q[0], y, q[1]]), yaw
    return place


def _cuboid(id_, centre, dim, material: str, cls: Optional[str] = None, name: Optional[str] = None) -> str:
    parts = [f"CUBOID id {id_}"]
    if name:
        parts.append(f"name {name}")
    parts.append(f"material {material}")
    if cls:
        parts.append(f"class {cls}")
    parts.append(f"position {nums(centre)} dim {nums(dim)}")
    return " ".join(parts)


def _streets(g: rn.RoadGraph, rng, ids: Ids, road_mat: str) -> list[str]:
    """Asphalt slabs of the street segments and junction squares (top at y = 0), dashed
    centre lines, stop lines and zebra crossings (paint 4 mm thick)."""
    hr = g.half_road
    out = ["", "// streets: asphalt between the junctions, junction squares, markings"]
    for n, (x, z) in enumerate(g.nodes):
        out.append(_cuboid(ids("street"), (x, -0.15, z), (2 * hr, 0.3, 2 * hr), road_mat, "road", f"junction_{n}"))
    marks = []
    for a, b in g.edges:
        pa, pb = g.nodes[a], g.nodes[b]
        h = g.heading(a, b)
        L = g.length(a, b) - 2 * hr
        c = 0.5 * (pa + pb)
        along_x = abs(h[0]) > 0.5
        dim = (L, 0.3, 2 * hr) if along_x else (2 * hr, 0.3, L)
        out.append(_cuboid(ids("street"), (c[0], -0.15, c[1]), dim, road_mat, "road", f"street_{a}_{b}"))
        # centre line: 3 m dashes, 6 m gaps, clear of the stop lines
        for t in np.arange(hr + 6.0, g.length(a, b) - hr - 6.0 - 3.0, 9.0):
            q = pa + (t + 1.5) * h
            marks.append(((q[0], 0.002, q[1]), (3.0, 0.004, 0.12) if along_x else (0.12, 0.004, 3.0)))
    for n in range(len(g.nodes)):
        nb = g.adjacency[n]
        zebra = len(nb) >= 3 and rng.uniform() < 0.35
        for m in nb:                                    # the approach from m into n
            h = g.heading(m, n)
            r = rn.right_of(h)
            along_x = abs(h[0]) > 0.5
            if len(nb) >= 3:                            # stop line across the incoming lane
                q = g.nodes[n] - (hr + 4.2) * h + 0.5 * hr * r
                marks.append(((q[0], 0.002, q[1]), (0.3, 0.004, hr) if along_x else (hr, 0.004, 0.3)))
            if zebra:                                   # stripes along the street, across its width
                for o in np.arange(-hr + 0.6, hr - 0.5, 1.0):
                    q = g.nodes[n] - (hr + 2.1) * h + o * r
                    marks.append(((q[0], 0.002, q[1]), (3.0, 0.004, 0.5) if along_x else (0.5, 0.004, 3.0)))
    for centre, dim in marks:
        out.append(_cuboid(ids("marking"), centre, dim, "lane_marking", "road"))
    return out


def _block_sides(x0, x1, z0, z1, hr):
    """The four kerb lines of a block (between street axes x0..x1, z0..z1), each with the
    block on its right: (start ground point, heading, length)."""
    X0, X1, Z0, Z1 = x0 + hr, x1 - hr, z0 + hr, z1 - hr
    return [((X0, Z0), (1.0, 0.0), X1 - X0), ((X1, Z0), (0.0, 1.0), Z1 - Z0),
            ((X1, Z1), (-1.0, 0.0), X1 - X0), ((X0, Z1), (0.0, -1.0), Z1 - Z0)]


def _block(rect, style: str, rng, ids: Ids, seeds: VariantPool, paving_mat: str, strip_seed: int) -> list[str]:
    """One block: kerbs and sidewalks around it, its lots (paving or lawn) and what stands on
    them in its ``style``, street lights, street trees, bins and benches on its sidewalks."""
    x0, x1, z0, z1 = rect
    out = [f"// block {nums((x0, x1, z0, z1), 1)}: {style}"]
    edge = KERB_W + WALK_W
    sides = _block_sides(x0, x1, z0, z1, HALF_ROAD)
    for i, (p0, h, length) in enumerate(sides):
        p0, h = np.asarray(p0), np.asarray(h)
        yaw = num(float(rn.yaw_deg(h)), 3)
        short = i % 2 == 1                                   # the z sides fit between the x sides
        k0, kl = (KERB_W, length - 2 * KERB_W) if short else (0.0, length)
        w0, wl = (edge, length - 2 * edge) if short else (KERB_W, length - 2 * KERB_W)
        q = p0 + k0 * h
        out.append(f"ASSET kerb id {ids('block')} seed {strip_seed + 2 * i} position {num(q[0])} 0 {num(q[1])} 0 {yaw} 0 "
                   f"size {nums((KERB_W, KERB_H, kl))} bend 0 offset {num(KERB_W / 2)}")
        q = p0 + w0 * h
        out.append(f"ASSET sidewalk id {ids('block')} seed {strip_seed + 2 * i + 1} position {num(q[0])} 0 {num(q[1])} "
                   f"0 {yaw} 0 size {nums((WALK_W, KERB_H, wl))} bend 0 offset {num(KERB_W + WALK_W / 2)}"
                   f"{paving_mat}")
    X0, X1, Z0, Z1 = x0 + HALF_ROAD + edge, x1 - HALF_ROAD - edge, z0 + HALF_ROAD + edge, z1 - HALF_ROAD - edge
    lot = {"downtown": ("concrete", "sidewalk"), "commercial": ("concrete", "sidewalk")}.get(style, ("grass", "terrain"))
    out.append(_cuboid(ids("block"), ((X0 + X1) / 2, (LOT_Y - 0.2) / 2, (Z0 + Z1) / 2), (X1 - X0, LOT_Y + 0.2, Z1 - Z0),
                       lot[0], lot[1]))
    if style in STYLES:
        st = STYLES[style]
        reserve = st.depth[1] + st.setback[1] + 1.0       # the x sides' lots own the corners
        for i, (p0, h, length) in enumerate(sides):
            p0, h = np.asarray(p0, float), np.asarray(h, float)
            s0 = reserve if i % 2 else 0.0
            place = _line_place(p0 + (edge + s0) * h if i % 2 else p0 + edge * h, h, LOT_Y)
            span = length - 2 * edge - 2 * s0
            if span > st.width[0]:
                out += line_street_side(rng, place, span - 0.7 * st.width[0], 1, edge, ids, st, seeds, limit=span)
        if style == "residential":                        # gardens: trees behind the houses
            for _ in range(int((X1 - X0) * (Z1 - Z0) / 500)):
                p = (rng.uniform(X0 + 16, X1 - 16), LOT_Y, rng.uniform(Z0 + 16, Z1 - 16))
                if X1 - X0 > 34 and Z1 - Z0 > 34:
                    kind = "conifer" if rng.random() < 0.3 else "tree"
                    out.append(asset(kind, ids("tree"), p, rng.uniform(0, 360), seed=seeds(kind)))
        else:                                             # a courtyard: a few trees
            for _ in range(int(rng.integers(0, 4))):
                if X1 - X0 > 2 * reserve + 6 and Z1 - Z0 > 2 * reserve + 6:
                    p = (rng.uniform(X0 + reserve, X1 - reserve), LOT_Y, rng.uniform(Z0 + reserve, Z1 - reserve))
                    out.append(asset("tree", ids("tree"), p, rng.uniform(0, 360), seed=seeds("tree")))
    elif style == "park":
        out += _park((X0, X1, Z0, Z1), rng, ids, seeds)
    elif style == "commercial":
        out += _commercial((X0, X1, Z0, Z1), rng, ids, seeds)
    # on the sidewalks: street lights (arm over the street), street trees, bins, benches
    for i, (p0, h, length) in enumerate(sides):
        p0, h = np.asarray(p0, float), np.asarray(h, float)
        walk = _line_place(p0, h, KERB_H)
        out += street_lights(rng, walk, float(rng.uniform(6, 20)), length - 6, 1, KERB_W + 0.45, ids,
                             seed_of=seeds)
        if style in ("residential", "park") or rng.random() < 0.4:
            for t in np.arange(float(rng.uniform(9, 15)), length - 9, float(rng.uniform(11, 17))):
                p, _ = walk(t, KERB_W + 1.1)
                out.append(asset("tree", ids("tree"), p, rng.uniform(0, 360), (3.5, 7.0, 3.5), seed=seeds("tree")))
        for _ in range(int(rng.integers(0, 3))):
            t = float(rng.uniform(5, length - 5))
            p, yw = walk(t, edge - 0.5)
            kind = "bench" if rng.random() < 0.4 else "bin"
            out.append(asset(kind, ids("furniture"), p, yw + 90, seed=seeds(kind)))
    return out


def _park(rect, rng, ids: Ids, seeds: VariantPool) -> list[str]:
    """A park: gravel paths crossing the lawn, benches beside them, trees and bushes."""
    X0, X1, Z0, Z1 = rect
    cx, cz = (X0 + X1) / 2 + rng.uniform(-5, 5), (Z0 + Z1) / 2 + rng.uniform(-5, 5)
    out = [_cuboid(ids("block"), (cx, LOT_Y + 0.005, (Z0 + Z1) / 2), (2.5, 0.01, Z1 - Z0), "gravel", "terrain"),
           _cuboid(ids("block"), ((X0 + X1) / 2, LOT_Y + 0.006, cz), (X1 - X0, 0.012, 2.5), "gravel", "terrain")]
    for t in np.arange(Z0 + 6, Z1 - 6, 14.0):
        if abs(t - cz) > 4 and rng.random() < 0.6:
            out.append(asset("bench", ids("furniture"), (cx + 2.2, LOT_Y, t), -90.0, seed=seeds("bench")))
    n_trees = int((X1 - X0) * (Z1 - Z0) / 140)
    for _ in range(n_trees):
        x, z = rng.uniform(X0 + 3, X1 - 3), rng.uniform(Z0 + 3, Z1 - 3)
        if abs(x - cx) < 4.5 or abs(z - cz) < 4.5:
            continue
        kind = str(rng.choice(["tree", "conifer", "bush"], p=[0.55, 0.2, 0.25]))
        out.append(asset(kind, ids("tree" if kind != "bush" else "veg"), (x, LOT_Y, z), rng.uniform(0, 360),
                         seed=seeds(kind)))
    return out


def _commercial(rect, rng, ids: Ids, seeds: VariantPool) -> list[str]:
    """A large low building at the back of its lot, a car park in front (towards -z)."""
    X0, X1, Z0, Z1 = rect
    W = min(float(rng.uniform(25, 45)), X1 - X0 - 6)
    D = min(float(rng.uniform(18, 30)), (Z1 - Z0) * 0.55)
    H = float(rng.uniform(6, 10))
    out = [asset("building", ids("building"), ((X0 + X1) / 2, LOT_Y, Z1 - 2 - D / 2), 180.0,
                 (round(W, 2), round(H, 2), round(D, 2)), seed=int(rng.integers(1e6)))]
    park_z1 = Z1 - 4 - D
    if park_z1 - Z0 > 12:
        out.append(_cuboid(ids("block"), ((X0 + X1) / 2, LOT_Y + 0.004, (Z0 + 2 + park_z1) / 2),
                           (X1 - X0 - 4, 0.008, park_z1 - Z0 - 2), "road_asphalt", "parking"))
        for row_z in np.arange(Z0 + 6, park_z1 - 3, 7.0):
            for x in np.arange(X0 + 4, X1 - 4, 2.6):
                if rng.random() < 0.45:
                    out.append(asset("car", ids("car"), (x, LOT_Y + 0.008, row_z), float(rng.choice([0.0, 180.0])),
                                     seed=seeds("car")))
    return out


def _styles(blocks, rng) -> list[str]:
    """Each block's style: downtown near the middle of the city, residential further out,
    parks and commercial lots among them."""
    c = np.array([[(b[0] + b[1]) / 2, (b[2] + b[3]) / 2] for b in blocks])
    r = np.linalg.norm(c, axis=1)
    r = r / max(r.max(), 1e-9)
    out = []
    for ri in r:
        u = rng.random()
        if u < 0.12:
            out.append("park")
        elif u < 0.22:
            out.append("commercial")
        else:
            out.append("downtown" if rng.random() < 0.85 - 0.7 * ri else "residential")
    return out


def _outer_ring(bg: rn.BlockGrid, rng, ids: Ids, seeds: VariantPool, paving_mat: str) -> list[str]:
    """Beyond the outer streets: a sidewalk and a row of buildings facing the city."""
    out = ["", "// around the city: sidewalks and buildings facing the outer streets"]
    xs, zs, hr = bg.xs, bg.zs, bg.half_road
    edge = KERB_W + WALK_W
    # the outer kerb lines, each with the outside on its right
    lines = [((xs[-1] + hr, zs[0] - hr), (-1.0, 0.0), xs[-1] - xs[0] + 2 * hr),
             ((xs[0] - hr, zs[0] - hr), (0.0, 1.0), zs[-1] - zs[0] + 2 * hr),
             ((xs[0] - hr, zs[-1] + hr), (1.0, 0.0), xs[-1] - xs[0] + 2 * hr),
             ((xs[-1] + hr, zs[-1] + hr), (0.0, -1.0), zs[-1] - zs[0] + 2 * hr)]
    style = Frontage(start=(0.0, 2.0), p_green=0.15, width=(14.0, 26.0), depth=(10.0, 16.0), height_low=(10.0, 18.0),
                     height_high=(18.0, 30.0), p_high=0.4, setback=(1.0, 4.0), gap=(0.5, 4.0), p_second_row=0.6)
    reserve = style.depth[1] + style.setback[1] + 1.0     # the x lines' lots own the corners
    for i, (p0, h, length) in enumerate(lines):
        p0, h = np.asarray(p0, float), np.asarray(h, float)
        r = rn.right_of(h)
        yaw = num(float(rn.yaw_deg(h)), 3)
        x_line = i % 2 == 0          # x lines run past the corners, the z lines fit between them
        k0, w0 = (-KERB_W, -edge) if x_line else (0.0, -KERB_W)
        for kind, start, width, off, sd in (("kerb", k0, KERB_W, KERB_W / 2, 7000 + i),
                                            ("sidewalk", w0, WALK_W, KERB_W + WALK_W / 2, 7010 + i)):
            q = p0 + start * h
            out.append(f"ASSET {kind} id {ids('block')} seed {sd} position {num(q[0])} 0 {num(q[1])} 0 {yaw} 0 "
                       f"size {nums((width, KERB_H, length - 2 * start))} bend 0 offset {num(off)}"
                       + (paving_mat if kind == "sidewalk" else ""))
        lots0, lots_len = (-edge - 70.0, length + 2 * edge + 140.0) if x_line else (-edge, length + 2 * edge)
        c = p0 + (lots0 + lots_len / 2) * h + (edge + 35.0) * r
        out.append(_cuboid(ids("block"), (c[0], (LOT_Y - 0.2) / 2, c[1]),
                           (lots_len, LOT_Y + 0.2, 70.0) if abs(h[0]) > 0.5 else (70.0, LOT_Y + 0.2, lots_len),
                           "grass", "terrain"))
        s0 = -edge if x_line else reserve - edge
        place = _line_place(p0 + s0 * h, h, LOT_Y)
        span = length - 2 * s0
        out += line_street_side(rng, place, span - 10, 1, edge, ids, style, seeds, limit=span)
    return out


def _junction_furniture(g: rn.RoadGraph, rng, ids: Ids, seeds: VariantPool) -> list[str]:
    """Traffic lights at some crossings, stop signs at some other junctions, facing the
    traffic that arrives; bollards at the corners of a few."""
    out = ["", "// junctions: traffic lights, stop signs, bollards"]
    hr = g.half_road
    for n in range(len(g.nodes)):
        nb = g.adjacency[n]
        u = rng.random()
        kind = "lights" if len(nb) == 4 and u < 0.35 else "stop" if u < 0.55 else None
        for m in nb:
            h = g.heading(m, n)
            r = rn.right_of(h)
            corner = g.nodes[n] - (hr + 1.0) * h + (hr + 0.7) * r        # the near right corner's sidewalk
            face = float(rn.yaw_deg(h))                                  # +z towards the arriving driver
            p = (corner[0], KERB_H, corner[1])
            if kind == "lights":
                out.append(asset("traffic_light", ids("furniture"), p, face, seed=seeds("traffic_light")))
            elif kind == "stop":
                height = 2.4
                out.append(asset("pole", ids("furniture"), p, 0.0, (0.076, height + 0.35, 0.076), seed=seeds("pole")))
                front = np.array([np.sin(np.radians(face)), 0.0, np.cos(np.radians(face))])
                out.append(asset("sign", ids("furniture"), np.add(p, 0.07 * front), face, (0.7, height, 0.025),
                                 seed=seeds("sign")))
            elif rng.random() < 0.3:
                for o in (-0.9, 0.9):
                    q = corner + o * h
                    out.append(asset("bollard", ids("furniture"), (q[0], KERB_H, q[1]), 0.0, seed=seeds("bollard")))
    return out


def _parked(g: rn.RoadGraph, bg: rn.BlockGrid, rng, ids: Ids, seeds: VariantPool) -> list[str]:
    """Cars parked along both kerbs of every street segment, clear of the junctions."""
    out = ["", "// parked cars along the kerbs, facing the way their lane drives"]
    hr = g.half_road
    for a, b in g.edges:
        h = g.heading(a, b)
        L = g.length(a, b)
        axis = _line_place(g.nodes[a], h, 0.0)
        for side in (1, -1):
            out += kerb_cars(rng, axis, hr + float(rng.uniform(8, 14)), L - hr - 10, side, hr - PARKED,
                             float(rng.uniform(0.25, 0.6)), ids, seed_of=seeds)
    return out


def _keyframes(xz: np.ndarray, yaw: np.ndarray, tol_m: float = 0.03, tol_deg: float = 0.3,
               max_turn: float = 60.0) -> list[int]:
    """Frames to key so that straight-line + slerp interpolation between them reproduces
    every frame's pose within ``tol_m`` and ``tol_deg`` (frame 0 is the object's own pose)."""
    keys, a, n = [0], 0, len(xz)
    while a < n - 1:
        b = a + 1
        while b + 1 < n:
            c = b + 1
            s = (np.arange(a, c + 1) - a) / (c - a)
            p = xz[a] + s[:, None] * (xz[c] - xz[a])
            y = yaw[a] + s * (yaw[c] - yaw[a])
            if (np.abs(np.linalg.norm(p - xz[a:c + 1], axis=1)).max() > tol_m
                    or np.abs(y - yaw[a:c + 1]).max() > tol_deg or abs(yaw[c] - yaw[a]) > max_turn):
                break
            b = c
        keys.append(b)
        a = b
    return keys


def _traffic(g: rn.RoadGraph, ego: rn.Drive, n_cars: int, rng, ids: Ids, seeds: VariantPool, p: rn.DriveParams) -> list[str]:
    """Cars driving their own random routes (no U-turns, in their lanes) during the whole
    sequence, never within 8 m of the camera car nor 6 m of each other: an ASSET car each with
    MOVE keyframes."""
    out = ["", "// moving traffic: cars on their own routes (keyframes wherever the path bends)"]
    frames = len(ego.t)
    placed = []
    for _ in range(n_cars):
        for _try in range(25):
            route = rn.random_walk(g, rng, (ego.duration_s + 80.0) * p.v_max)
            params = rn.DriveParams(v_max=float(rng.uniform(7.0, 12.0)), p_stop=0.3, dwell_s=(1.0, 4.0),
                                    start_m=float(rng.uniform(5, 40)), step_m=0.5)
            try:
                d = rn.drive(g, route, RATE_HZ, params, rng, t_offset=float(rng.uniform(5.0, 60.0)), frames=frames)
            except rn.RouteError:
                continue
            if np.linalg.norm(d.xz - ego.xz, axis=1).min() < 8.0:
                continue
            if any(np.linalg.norm(d.xz - q.xz, axis=1).min() < 6.0 for q in placed):
                continue
            placed.append(d)
            break
    for d in placed:
        yaw = np.degrees(np.unwrap(np.arctan2(d.h[:, 0], d.h[:, 1])))   # +z (the car's nose) towards h
        i = ids("traffic")
        out.append(asset("car", i, (d.xz[0, 0], 0.0, d.xz[0, 1]), yaw[0], seed=seeds("car")))
        for k in _keyframes(d.xz, yaw)[1:]:
            out.append(f"MOVE id {i} frame {k} position {nums((d.xz[k, 0], 0.0, d.xz[k, 1]))} 0 {num(yaw[k], 3)} 0")
    return out


def _camera_poses(ego: rn.Drive, rng) -> tuple:
    """Positions and yaw, pitch, roll (deg) of the left camera 1.65 m above the road in the right lane: lane keeping (a slow lateral
    weave as a function of the distance driven, so a stopped car stands still), heading along
    the path, pitching with the longitudinal and rolling with the lateral acceleration."""
    s = ego.s
    grid = np.arange(0.0, s[-1] + 50.0, 0.5)
    weave = np.interp(s, grid, 0.07 * smooth_noise(rng, len(grid), 1.0, (3.0, 7.0, 13.0)))
    steer = np.interp(s, grid, 0.2 * smooth_noise(rng, len(grid), 1.0, (11.0, 23.0)))
    bounce = np.interp(s, grid, 0.008 * smooth_noise(rng, len(grid), 1.0, (60.0, 130.0)))
    tilt = np.interp(s, grid, 0.15 * smooth_noise(rng, len(grid), 1.0, (40.0, 90.0)))
    r = rn.right_of(ego.h)
    xz = ego.xz + weave[:, None] * r
    ds = np.gradient(s)
    drift = np.degrees(np.gradient(weave) / np.where(ds > 1e-6, ds, np.inf))   # steering follows the weave
    yaw = np.unwrap(np.radians(rn.yaw_deg(ego.h)))
    yaw = np.degrees(yaw) - drift + steer
    pitch = 0.4 * ego.a_long + tilt
    roll = -0.35 * ego.a_lat + 0.5 * tilt
    pos = np.column_stack([xz[:, 0], KITTI_CAMERA_HEIGHT + bounce, xz[:, 1]])
    return pos, yaw, pitch, roll


def _frames_of(ego: rn.Drive, edge: int) -> tuple[int, int]:
    k = np.flatnonzero(ego.edge == edge)
    return (int(k[0]), int(k[-1])) if len(k) else (-1, -1)


def generate(seed: int = 0, route_m: float = 1000.0, closures: int = 3, gap_s: float = 30.0, direction: str = "mixed",
             blocks: Optional[int] = None, block_m=(55.0, 85.0), traffic: int = 10, far: float = 250.0,
             haze: bool = True, sun_elevation: Optional[float] = None, sun_azimuth: Optional[float] = None) -> str:
    """The SES script of the city drive for ``seed`` (see the module docstring): a route of at
    least ``route_m`` metres with ``closures`` loop closures at least ``gap_s`` seconds after
    the first drive of their street, ``direction`` same, opposite or mixed; ``blocks`` x
    ``blocks`` blocks of ``block_m`` metres (default: about three times the route in streets);
    ``traffic`` moving cars; the camera's ``far`` plane, with a haze ending there (``haze``)."""
    if int(seed) < 0 or not route_m > 0 or int(closures) < 0 or not gap_s >= 0:
        raise ValueError(f"seed >= 0, route_m > 0, closures >= 0 and gap_s >= 0 needed, got {seed}, {route_m}, "
                         f"{closures}, {gap_s}")
    if direction not in rn.DIRECTIONS:
        raise ValueError(f"direction must be one of {', '.join(rn.DIRECTIONS)}, got {direction!r}")
    seed = int(seed)
    v = Variation.of(seed)
    lighting = v.lighting
    if sun_elevation is not None or sun_azimuth is not None:
        lighting = Lighting(sun=(lighting.sun[0] if sun_elevation is None else float(sun_elevation),
                                 lighting.sun[1] if sun_azimuth is None else float(sun_azimuth)),
                            sky_strength=lighting.sky_strength)
    rng = np.random.default_rng(seed)
    params = rn.DriveParams(v_max=v.v_max, p_stop=v.p_stop)
    n = int(blocks) if blocks is not None else _blocks_for(route_m, block_m)
    for grow in range(4):      # a larger city when this one is too small for the route
        bg = rn.irregular_grid(np.random.default_rng([seed, n + grow]), n + grow, n + grow, tuple(block_m),
                               half_road=HALF_ROAD, lane=LANE)
        g = bg.graph
        try:
            # whole streets: the route is planned a little longer and the drive ends at route_m
            route = rn.plan_route(g, np.random.default_rng([seed, 1]), 1.08 * route_m + params.start_m + 40.0,
                                  int(closures), gap_s * params.v_max, direction)
            break
        except rn.RouteError:
            if blocks is not None or grow == 3:
                raise
    ego = rn.drive(g, route, RATE_HZ, params, np.random.default_rng([seed, 2]), length_m=route_m)
    events = rn.closure_events(g, route, ego, gap_s)
    if len(events) != closures:      # the last return ran past route_m: drive the whole route
        ego = rn.drive(g, route, RATE_HZ, params, np.random.default_rng([seed, 2]))
        events = rn.closure_events(g, route, ego, gap_s)
    if len(events) != closures:
        raise rn.RouteError(f"the drive has {len(events)} loop closures, {closures} planned")
    ids = Ids(ID_STARTS)
    seeds = VariantPool(rng, POOLS)

    length_driven = float(ego.s[-1] - ego.s[0])
    out = ["// city_loop.ses - a city of blocks driven by the KITTI odometry rig (1226x370, f 707 px, baseline",
           f"// 0.54 m) at 10 Hz: a {length_driven:.0f} m drive of {ego.duration_s:.1f} s ({len(ego.t)} frames) "
           f"through {bg.xs.size - 1}x{bg.zs.size - 1} blocks,",
           f"// right lane, turns at junctions, stops; {len(events)} loop closure(s) (a street driven again "
           f">= {num(gap_s)} s later):"]
    for j, e in enumerate(events):
        a0, _ = _frames_of(ego, e.first)
        _, a1 = _frames_of(ego, e.last)
        a, b = route.edges[e.first]
        before = [i for i in range(e.first) if g.key(*route.edges[i]) == g.key(a, b)][-1]
        b0, b1 = _frames_of(ego, before)
        out.append(f"//   closure {j + 1}: frames {a0}-{a1} drive again the street of frames {b0}-{b1} "
                   f"({'same' if e.same else 'opposite'} direction), {e.gap_s:.1f} s later")
    given = {"gap_s": (gap_s, 30.0), "direction": (direction, "mixed"), "blocks": (blocks, None),
             "traffic": (traffic, 10), "far": (far, 250.0), "sun_elevation": (sun_elevation, None),
             "sun_azimuth": (sun_azimuth, None)}
    flags = "".join(f" --{k.replace('_', '-')} {num(v) if isinstance(v, float) else v}"
                    for k, (v, default) in given.items() if v != default)
    flags += "" if haze else " --haze false"
    flags += "" if tuple(block_m) == (55.0, 85.0) else f" (block_m {nums(block_m)})"
    out += [f"// Generated by blender_sesgen/generators/builtin/city_grid.py --seed {seed} --route-m {num(route_m)} --closures "
            f"{closures}{flags} (edit that, not this file). Y up, metres.",
            kitti_rig(far=far), f"TIMING rate {num(RATE_HZ)}", *lighting.lines()]
    if haze and lighting.fog is None:
        out.append(f"FOG start {num(0.4 * far, 1)} end {num(far, 1)} colour {nums(HAZE[0])}")
    out.append("RENDER samples 16 denoise on")
    road_mat, paving_mat = " road_asphalt", ""
    out += ["", "// the city's asphalt and paving (library materials with their tone and wear)",
            derived_material("road_asphalt", "asphalt", v.road[0] if v.road else ASPHALT,
                             v.road[1] if v.road else 0.35, seed=seed)]
    if v.paving is not None:
        out.append(derived_material("paving", "concrete", v.paving[0], v.paving[1], seed=seed))
        paving_mat = " material paving"
    xs, zs = bg.xs, bg.zs
    span = max(xs[-1] - xs[0], zs[-1] - zs[0])
    g_half = span / 2 + far + 100
    out.append(f"QUAD id {ids('ground')} name ground material soil class terrain vertices "
               f"{nums((-g_half, -0.02, -g_half))}  {nums((g_half, -0.02, -g_half))}  "
               f"{nums((g_half, -0.02, g_half))}  {nums((-g_half, -0.02, g_half))}")
    out += _streets(g, rng, ids, road_mat.strip())
    rects = bg.blocks()
    styles = _styles(rects, rng)
    out += ["", f"// {len(rects)} blocks: kerbs, sidewalks, lots; buildings, parks, street furniture"]
    for i, (rect, style) in enumerate(zip(rects, styles)):
        out += _block(rect, style, rng, ids, seeds, paving_mat, (100 * seed + 20 * i) % 2000000000)
    out += _outer_ring(bg, rng, ids, seeds, paving_mat)
    out += _junction_furniture(g, rng, ids, seeds)
    out += _parked(g, bg, rng, ids, seeds)
    out += _traffic(g, ego, int(traffic), np.random.default_rng([seed, 3]), ids, seeds, params)
    names = list(ID_STARTS)
    for a, b in zip(names, names[1:]):
        if ids.next[a] > ID_STARTS[b]:
            raise ValueError(f"too many objects of kind {a} ({ids.next[a] - ID_STARTS[a]}): a smaller city or route")
    return script_with_poses(out, f"the drive: {len(ego.t)} poses of the left camera at {num(RATE_HZ)} Hz",
                             *_camera_poses(ego, np.random.default_rng([seed, 4])))


if __name__ == "__main__":
    command_line(generate, __doc__, None)
