"""Buildings: a closed shell with real window and door openings (reveals, recessed glass,
frames with mullions, sills; roller shutters in six buildings of ten, some lowered), a base
band, string courses and a cornice, balconies with railings on the front, shop windows on
some ground floors, a flat roof with a parapet or a pitched tiled roof with gables; a downpipe at
each corner, eaves gutters, attic windows in the gables and roof windows in some slopes.
``shell``: the same block under construction (``building_shell``): its openings unglazed into
rooms of raw concrete, white slab edges, a flat roof, nothing fitted. ``porch``: a house
(``house``): the same building with its front door at the back of a recessed entrance porch.

Asset frame: footprint ``size`` = (width along x, height along y, depth along z) centred
on the origin, ground at y = 0, the front (street) facade facing +z.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import palette
from .mesh import MeshData, pose, start
from .palette import pick

@dataclass
class Opening:
    u0: float
    u1: float
    v0: float
    v1: float
    kind: str          # window | door | shop | french | porch
    recess: float


def _round6(x: float) -> float:
    """``np.round(x, 6)`` bit for bit (x * 1e6 rounded half to even, over 1e6, a zero keeping
    the sign of x * 1e6), without numpy's per-call cost (the shell welds ~10^5 points)."""
    y = x * 1e6
    r = round(y) / 1e6
    return r if r != 0.0 else math.copysign(0.0, y)


class _Shell:
    """The building's outer walls as one welded surface: four facade grids sharing the
    global height breakpoints, with openings cut out, reveals and the glass/door planes."""

    def __init__(self, W: float, D: float, H: float):
        self.W, self.D, self.H = W, D, H
        self.verts: dict[tuple, int] = {}
        self.V: list = []
        self.tris: list = []
        self.surf: list = []

    def vid(self, p) -> int:
        key = tuple(_round6(float(x)) for x in p)
        if key not in self.verts:
            self.verts[key] = len(self.V)
            self.V.append(key)
        return self.verts[key]

    def poly(self, pts, s) -> None:
        """A planar convex polygon (counter-clockwise from outside), fanned from its centroid
        if it has more than 4 points (so collinear boundary points make no slivers)."""
        ids = [self.vid(p) for p in pts]
        if len(ids) == 3:
            self.tris.append(tuple(ids)); self.surf.append(s)
        elif len(ids) == 4:
            self.tris += [(ids[0], ids[1], ids[2]), (ids[0], ids[2], ids[3])]; self.surf += [s, s]
        else:
            c = self.vid(np.mean(np.asarray(pts, float), axis=0))
            for i in range(len(ids)):
                self.tris.append((c, ids[i], ids[(i + 1) % len(ids)])); self.surf.append(s)


def _sides(W, D):
    """(origin at u = 0, v = 0, e_u, outward normal, length) for front, right, back, left."""
    x, z = np.array([1.0, 0, 0]), np.array([0, 0, 1.0])
    return [(np.array([-W / 2, 0, D / 2]), x, z, W), (np.array([W / 2, 0, D / 2]), -z, x, D),
            (np.array([W / 2, 0, -D / 2]), -x, -z, W), (np.array([-W / 2, 0, -D / 2]), z, -x, D)]


def generate(size, seed: int, shell: bool = False, porch: bool = False) -> MeshData:
    """A finished building; ``shell``: the same block under construction (``building_shell``:
    ``SHELL``'s unglazed openings into dark rooms, slab edges, nothing fitted); ``porch``: a house
    (``house``) whose front door stands at the back of a recessed entrance porch (``PORCH``)."""
    rng, W, H, D, b = start(size, seed)
    brick = rng.random() < 0.25
    wall_material = ("brick", pick(rng, palette.BRICK)) if brick else ("plaster", pick(rng, palette.PLASTER))
    wall = b.surface(*wall_material)
    base = b.surface("concrete", pick(rng, palette.STONE))
    trim = b.surface("plaster", (0.70, 0.69, 0.66)) if brick or rng.random() < 0.5 else wall
    frame_colour = pick(rng, palette.FRAME)
    frame = b.surface("metal_painted", frame_colour)
    glass = b.surface("glass_window")
    sill = b.surface("concrete", (0.45, 0.44, 0.42))
    door = b.surface("wood_planks", pick(rng, palette.DOOR))
    rail = b.surface("metal_painted", (0.05, 0.05, 0.05) if rng.random() < 0.6 else (0.70, 0.70, 0.70))
    roof_s = b.surface("roof_tiles", pick(rng, palette.ROOF))
    pipe = b.surface("metal_brushed")
    # the ground floor's walls: the walls' material in a slot of their own, which an ASSET's
    # ``ground_material`` replaces (a white insulated ground floor under bare blockwork)
    ground = b.surface(*wall_material, part="ground")
    if shell:   # its own stream: the finished building's draws stay as they are
        srng = np.random.default_rng([int(seed) % 2 ** 63, SHELL_STREAM])
        inside = b.surface("concrete", SHELL_INSIDE)
        slab_s = b.surface("concrete", SHELL_SLAB)
    if porch:   # its own stream too: the building's own draws stay as they are
        prng = np.random.default_rng([int(seed) % 2 ** 63, PORCH_STREAM])

    pitched = rng.random() < 0.45 and W <= 24
    roof_h = min(0.55 * D * np.tan(np.radians(rng.uniform(28, 42))), 0.6 * H) if pitched else 0.0
    if shell:   # a new build: a flat roof (its floors up to it)
        pitched, roof_h = False, 0.0
    wall_h = H - roof_h
    ground_h = float(np.clip(rng.uniform(3.0, 4.2), 2.6, wall_h))
    floor_h = rng.uniform(2.85, 3.3)
    n_upper = max(int((wall_h - ground_h - (0.0 if pitched else 0.6)) // floor_h), 0)
    floor_y = [0.0, ground_h] + [ground_h + i * floor_h for i in range(1, n_upper + 1)]
    floor_y = [y for y in floor_y if y < wall_h - 2.2] or [0.0]
    base_h = rng.uniform(0.35, 0.9)
    shop = rng.random() < 0.35 and ground_h >= 3.4
    balconies = rng.random() < 0.4 and len(floor_y) > 2
    cornice_h = rng.uniform(0.3, 0.5)
    bay = rng.uniform(2.5, 3.6)
    win_w = float(np.clip(rng.uniform(0.9, 1.5), 0.6, bay - 0.9))
    win_h = rng.uniform(1.25, 1.65)
    sill_y = rng.uniform(0.8, 0.95)
    recess = rng.uniform(0.12, 0.24)
    mullion = win_w > 1.15
    transom = rng.random() < 0.35
    if shell:   # no balconies or shop fronts; its openings the shell's
        shop, balconies = False, False
        win_w = float(np.clip(srng.uniform(*SHELL["win_w"]), 0.6, bay - 0.7))
        win_h, sill_y = srng.uniform(*SHELL["win_h"]), srng.uniform(*SHELL["sill"])

    # --- openings per side -----------------------------------------------------------
    sides = _sides(W, D)
    openings: list[list[Opening]] = []
    balcony_bays = []
    for si, (_, _, _, L) in enumerate(sides):
        ops: list[Opening] = []
        n = max(int((L - 1.2) // bay), 0)
        if n == 0:
            openings.append(ops)
            continue
        margin = (L - n * bay) / 2
        centres = margin + bay * (np.arange(n) + 0.5)
        door_bay = int(rng.integers(n)) if si == 0 else -1
        bal = set(rng.choice(n, size=max(1, n // 2), replace=False).tolist()) if balconies and si == 0 else set()
        if bal:
            balcony_bays.extend((c, fy) for c in centres[sorted(bal)] for fy in floor_y[1:])
        for fi, fy in enumerate(floor_y):
            top = floor_y[fi + 1] if fi + 1 < len(floor_y) else wall_h - cornice_h - 0.25
            for bi, c in enumerate(centres):
                if fi == 0:
                    if bi == door_bay:
                        dw = min(rng.uniform(1.0, 1.3), bay - 0.6)
                        dh = min(rng.uniform(2.15, 2.45), top - 0.4)
                        if porch:
                            o = _porch_opening(prng, centres, bi, bay, top, D)
                            while ops and ops[-1].u1 > o.u0:     # it spans bays before too
                                ops.pop()
                            ops.append(o)
                        else:
                            ops.append(Opening(c - dw / 2, c + dw / 2, 0.0, dh, "door", 0.3))
                    elif porch and si == 0 and ops and ops[-1].kind == "porch" and ops[-1].u1 > c - win_w / 2:
                        continue        # the porch spans this bay too
                    elif shop and si in (0, 1, 3):
                        sw = min(bay - 0.5, 2.8)
                        ops.append(Opening(c - sw / 2, c + sw / 2, base_h + 0.05, min(top - 0.5, 3.0), "shop", 0.15))
                    elif si == 0 or rng.random() < 0.85:
                        ops.append(Opening(c - win_w / 2, c + win_w / 2, max(sill_y, base_h + 0.1),
                                           min(max(sill_y, base_h + 0.1) + win_h, top - 0.35), "window", recess))
                    continue
                if bi in bal:
                    fw = min(win_w + 0.2, bay - 0.7)
                    ops.append(Opening(c - fw / 2, c + fw / 2, fy + 0.12, min(fy + 2.2, top - 0.3), "french", recess))
                elif si == 0 or rng.random() < 0.9:
                    v0 = fy + sill_y
                    ops.append(Opening(c - win_w / 2, c + win_w / 2, v0, min(v0 + win_h, top - 0.3), "window", recess))
        openings.append([Opening(*(round(float(x), 6) for x in (o.u0, o.u1, o.v0, o.v1)), o.kind, o.recess)
                         for o in ops if o.v1 - o.v0 > 0.5])
    if shell:   # each opening a room behind it: as deep as the corners and the opposite side allow
        room = float(srng.uniform(*SHELL["room"]))
        openings = [[Opening(o.u0, o.u1, o.v0, o.v1, o.kind,
                             round(max(min(room, o.u0 - 0.05, L - o.u1 - 0.05, (D if si % 2 == 0 else W) / 2 - 0.1),
                                       SHELL_WALL_M + 0.05), 6)) for o in ops]
                    for si, ((_, _, _, L), ops) in enumerate(zip(sides, openings))]

    # --- the shell -------------------------------------------------------------------
    ground_top = floor_y[1] if len(floor_y) > 1 else wall_h     # the ground floor's walls end at its ceiling
    ys = {0.0, wall_h, base_h, round(ground_top, 6)}
    for ops in openings:
        for o in ops:
            ys |= {o.v0, o.v1}
    ys = np.array(sorted(round(y, 6) for y in ys if 0 <= y <= wall_h))
    shell_ = _Shell(W, D, wall_h)
    for (origin, e_u, n, L), ops in zip(sides, openings):
        us = {0.0, L}
        for o in ops:
            us |= {o.u0, o.u1}
        us = np.array(sorted(round(u, 6) for u in us))

        def P(u, v, w=0.0, o=tuple(map(float, origin)), e=tuple(map(float, e_u)), n=tuple(map(float, n))):
            # origin + u e_u + v (0, 1, 0) - w n in Python floats: numpy's operations in its order
            u, v, w = float(u), float(v), float(w)
            return (o[0] + u * e[0] + v * 0.0 - w * n[0], o[1] + u * e[1] + v * 1.0 - w * n[1],
                    o[2] + u * e[2] + v * 0.0 - w * n[2])

        for i in range(len(us) - 1):
            for j in range(len(ys) - 1):
                um, vm = (us[i] + us[i + 1]) / 2, (ys[j] + ys[j + 1]) / 2
                if any(o.u0 < um < o.u1 and o.v0 < vm < o.v1 for o in ops):
                    continue
                s = base if vm < base_h else ground if vm < ground_top else wall
                shell_.poly([P(us[i], ys[j]), P(us[i + 1], ys[j]), P(us[i + 1], ys[j + 1]), P(us[i], ys[j + 1])], s)
        for o in ops:
            ui = [u for u in us if o.u0 <= u <= o.u1]
            vi = [v for v in ys if o.v0 <= v <= o.v1]
            r = o.recess

            def reveal(p, q, s, P=P, r=r):
                # the quad from the facade's edge p-q (u, v pairs) back to the recess; a shell's
                # opening: the wall's thickness in its own material, then the room inside
                if not shell:
                    shell_.poly([P(*p), P(*p, r), P(*q, r), P(*q)], s)
                    return
                shell_.poly([P(*p), P(*p, SHELL_WALL_M), P(*q, SHELL_WALL_M), P(*q)], s)
                shell_.poly([P(*p, SHELL_WALL_M), P(*p, r), P(*q, r), P(*q, SHELL_WALL_M)], inside)
            # reveals: bottom, right, top, left (each split where the wall grid has points)
            for a, bb in zip(ui[:-1], ui[1:]):
                reveal((bb, o.v0), (a, o.v0), (sill if o.kind not in ("door", "porch") else base) if not shell else
                       ground if o.v0 < ground_top else wall)
                reveal((a, o.v1), (bb, o.v1), ground if o.v1 <= ground_top else wall)
            for a, bb in zip(vi[:-1], vi[1:]):
                side = ground if (a + bb) / 2 < ground_top else wall
                reveal((o.u1, bb), (o.u1, a), side)
                reveal((o.u0, a), (o.u0, bb), side)
            # the closing plane (glass or door leaf; a shell's room's back wall), with the same boundary points
            ring = ([P(u, o.v0, r) for u in ui] + [P(o.u1, v, r) for v in vi[1:]] +
                    [P(u, o.v1, r) for u in ui[::-1][1:]] + [P(o.u0, v, r) for v in vi[::-1][1:-1]])
            shell_.poly(ring, inside if shell else door if o.kind == "door" else ground if o.kind == "porch" else glass)
    # roof cap and floor
    top = [(-W / 2, wall_h, D / 2), (W / 2, wall_h, D / 2), (W / 2, wall_h, -D / 2), (-W / 2, wall_h, -D / 2)]
    top_pts = _perimeter_points(shell_, wall_h)
    shell_.poly(top_pts if len(top_pts) > 4 else top, inside if shell else roof_s if not pitched else wall)
    bottom_pts = _perimeter_points(shell_, 0.0)
    shell_.poly(bottom_pts[::-1], base)
    b.add(np.array(shell_.V), shell_.tris, shell_.surf, closed=True)
    if shell:   # nothing fitted yet: the floor slabs' edges between the storeys, the roof slab's
        for fy in floor_y[1:] + [wall_h]:
            _band(b, W, D, fy - SHELL["slab_edge"], fy + (0.0 if fy < wall_h else 0.02), 0.015, slab_s)
        return b.build()

    # --- details: frames, sills, door furniture ---------------------------
    for (origin, e_u, n, L), ops in zip(sides, openings):
        R = np.column_stack([e_u, [0, 1.0, 0], n])   # facade frame: u, v, out
        T_side = pose(R, origin)
        for o in ops:
            if o.kind == "porch":
                _porch_details(b, prng, o, T_side, door, frame, pipe, sill, glass, bay, (win_w, win_h, sill_y))
            else:
                _opening_details(b, o, T_side, frame, sill, mullion, transom)
    # --- roller shutters: their own random stream, so the rest of the building is unchanged
    _roller_shutters(b, np.random.default_rng([int(seed) % 2 ** 63, 28]), sides, openings)
    # --- bands: base course, string course over the ground floor, cornice ------------------
    proj = rng.uniform(0.15, 0.35)
    _band(b, W, D, wall_h - cornice_h, wall_h + (0.0 if pitched else 0.25), proj, trim)
    if len(floor_y) > 1 and rng.random() < 0.7:
        _band(b, W, D, floor_y[1] - 0.12, floor_y[1] + 0.1, 0.06, trim)
    # --- balconies on the front ------------------------------------------------------------
    for c, fy in balcony_bays:
        _balcony(b, rng, -W / 2 + c, fy, D / 2, min(bay - 0.4, 2.6), rng.uniform(1.1, 1.5), sill, rail)
    # --- roof ------------------------------------------------------------------------------
    over = 0.0
    if pitched:
        over = rng.uniform(0.3, 0.55)
        _gable_roof(b, W, D, wall_h, roof_h, over, roof_s, wall, trim)
        if rng.random() < 0.6:
            cx, cz = rng.uniform(-W / 3, W / 3), rng.uniform(-D / 5, D / 5)
            b.box((cx - 0.3, wall_h, cz - 0.3), (cx + 0.3, H + 0.6, cz + 0.3), wall)
    elif rng.random() < 0.6:  # a plant room / lift housing on the flat roof
        w2, d2 = rng.uniform(2, 4), rng.uniform(2, 4)
        cx, cz = rng.uniform(-W / 4, W / 4), rng.uniform(-D / 4, D / 4)
        b.box((cx - w2 / 2, wall_h, cz - d2 / 2), (cx + w2 / 2, wall_h + rng.uniform(1.8, 2.6), cz + d2 / 2), wall)
    # --- a downpipe at a front corner --------------------------------------------------------
    px = (W / 2 - 0.15) * (1 if rng.random() < 0.5 else -1)
    b.cylinder(0.05, 0.0, wall_h - 0.1, 10, pipe, T=pose(None, (px, 0, D / 2 + 0.08)))
    # --- gutters, downpipes, attic and roof windows: their own stream, their surfaces last
    _fittings(b, np.random.default_rng([int(seed) % 2 ** 63, FITTINGS_STREAM]), W, D, wall_h, roof_h, over,
              cornice_h, px, pitched, wall_material, frame_colour)
    return b.build()


# a block under construction (issue 28, session 17), as KITTI sequence_1's scaffolded new build
# 45-100 m ahead right (frames 15-50, full size): its openings unglazed, dark rooms behind them; on
# its sunlit long side (frame 45) storey-high openings (0.7-0.85 of the floor-to-floor height),
# on its end wall (frame 20) ~2 m wide ones; the upper floors bare sand-lime blocks, the slab
# edges white bands ~0.3 m high at each floor (the slab-edge insulation), the ground floor's
# walls white (its insulation: the ASSET's ground_material). Rooms 3.5-5 m deep (a flat's room
# behind its window); walls 30 cm (17.5 cm blocks + 12 cm insulation, its strips at the edges).
SHELL = {"win_w": (1.0, 2.4), "win_h": (1.8, 2.4), "sill": (0.1, 0.6), "room": (3.5, 5.0), "slab_edge": 0.3}
SHELL_WALL_M = 0.3
SHELL_STREAM = 17
SHELL_INSIDE = (0.40, 0.39, 0.37)      # raw concrete and blocks inside, never sunlit but through the opening
SHELL_SLAB = (0.78, 0.78, 0.75)        # the slab edges' white insulation strips (KITTI: as white as the ground floor's)


def shell(size, seed: int) -> MeshData:
    """A block under construction (``building_shell``): ``generate``'s building with ``shell``."""
    return generate(size, seed, shell=True)


# a house's recessed ground floor (issue 28, session 18), as KITTI sequence_1's near right houses
# (frames 0-24 at full size): the upper storeys run on over a ground floor set back under them,
# its wall in shade (KITTI's grey there: median 62-96 of 255 where the sunlit facade clips, p10
# 28-41: the doors and windows in it), the front door, its windows, letterboxes and a lamp in the
# recess. KITTI's SGBM points 10-22 m from the camera, 13-37 m ahead of frame 0 (frames 0, 6, 12,
# 18; tests/test_scene_library.py): 5.5-7 m up they peak 9.5-10 m right (the facade), and half
# of those 1.5-3 m up lie 11.25 m right or further (the wall behind, ~1.5-2 m back), along nearly
# all of 13-43 m ahead; its ORB VO's upper-right inliers reach 11.4 m right (p90) where the
# render's facade stopped them at 9.3 m. The recess: four fifths of the front's bays to all (the
# door's among them), 1.4-2.0 m deep, 2.5-3.0 m high; a pier of 0.3 m at each end.
PORCH = {"depth": (1.4, 2.0), "height": (2.5, 3.0), "share": (0.8, 1.0), "pier": 0.3}
PORCH_STREAM = 18


def house(size, seed: int) -> MeshData:
    """A house (``house``): ``generate``'s building with its entrance in a recessed porch."""
    return generate(size, seed, porch=True)


def _porch_opening(rng, centres, bi: int, bay: float, top: float, D: float) -> Opening:
    """The recess in the front's ground floor: ``PORCH['share']`` of its bays (at least one),
    bay ``bi`` (the door's) among them; a pier of ``PORCH['pier']`` at each end, as deep as the
    house allows."""
    n = len(centres)
    k = int(np.clip(round(n * float(rng.uniform(*PORCH["share"]))), 1, n))
    j0 = int(np.clip(bi - int(rng.integers(k)), 0, n - k))
    a, c = centres[j0] - bay / 2 + PORCH["pier"], centres[j0 + k - 1] + bay / 2 - PORCH["pier"]
    v1 = min(float(rng.uniform(*PORCH["height"])), top - 0.3)
    depth = min(float(rng.uniform(*PORCH["depth"])), D / 2 - 0.5)
    return Opening(round(float(a), 6), round(float(c), 6), 0.0, round(v1, 6), "porch", round(depth, 6))


def _porch_details(b, rng, o: Opening, T_side, door, frame, metal, sill, glass, bay: float, window) -> None:
    """In the recess (its back wall the ground floor's wall): the front door (leaf, frame, bar
    handle), the ground floor's windows in the other bays (``window`` = width, height, sill: the
    building's), a column of 2-4 letterboxes on a side wall, a lamp under the ceiling; a step
    across its mouth (as a door's)."""
    r, w = o.recess, o.u1 - o.u0
    b.box((o.u0 - 0.2, -0.02, -0.02), (o.u1 + 0.2, 0.15, 0.35), sill, T=T_side)
    dw = float(rng.uniform(1.0, 1.2))
    du = o.u0 + float(rng.uniform(0.3, max(w - dw - 0.3, 0.31)))
    dh = min(float(rng.uniform(2.05, 2.2)), o.v1 - 0.1)
    b.box((du, 0.0, -r), (du + dw, dh, -r + 0.05), door, T=T_side)                       # the leaf
    for lo, hi in (((du - 0.07, 0.0, -r), (du, dh + 0.07, -r + 0.08)), ((du + dw, 0.0, -r), (du + dw + 0.07, dh + 0.07, -r + 0.08)),
                   ((du, dh, -r), (du + dw, dh + 0.07, -r + 0.08))):
        b.box(lo, hi, frame, T=T_side)
    hu = du + dw - 0.12
    b.box((hu - 0.02, 1.0, -r), (hu + 0.02, 1.3, -r + 0.09), metal, T=T_side)            # a bar handle
    win_w, win_h, sill_y = window
    top = min(sill_y + win_h, o.v1 - 0.3)
    c = o.u0 - PORCH["pier"] + bay / 2
    while c + win_w / 2 <= o.u1 - 0.1 and top - sill_y > 0.5:        # the windows: the bays clear of the door
        a0, a1 = c - win_w / 2, c + win_w / 2
        if a0 >= o.u0 + 0.1 and (a1 < du - 0.25 or a0 > du + dw + 0.25):
            b.box((a0, sill_y, -r), (a1, top, -r + 0.02), glass, T=T_side)
            for lo, hi in (((a0 - 0.06, sill_y - 0.06, -r), (a1 + 0.06, sill_y, -r + 0.07)),
                           ((a0 - 0.06, top, -r), (a1 + 0.06, top + 0.06, -r + 0.07)),
                           ((a0 - 0.06, sill_y, -r), (a0, top, -r + 0.07)), ((a1, sill_y, -r), (a1 + 0.06, top, -r + 0.07)),
                           (((a0 + a1) / 2 - 0.03, sill_y, -r), ((a0 + a1) / 2 + 0.03, top, -r + 0.06))):
                b.box(lo, hi, frame, T=T_side)
        c += bay
    left = rng.random() < 0.5                                                             # the letterboxes' wall
    u_wall, sgn = (o.u0, 1.0) if left else (o.u1, -1.0)
    n = int(rng.integers(2, 5))
    w0 = -r + float(rng.uniform(0.2, max(r - 0.8, 0.21)))
    ua, ub = sorted((u_wall, u_wall + sgn * 0.12))
    for k in range(n):                           # the letterboxes: a column of boxes, 0.38 m apart
        v = 0.95 + 0.38 * k
        b.box((ua, v, w0), (ub, v + 0.34, w0 + 0.4), frame, T=T_side)
    lu = (o.u0 + o.u1) / 2
    b.box((lu - 0.12, o.v1 - 0.06, -r / 2 - 0.12), (lu + 0.12, o.v1, -r / 2 + 0.12), metal, T=T_side)   # the lamp


def _perimeter_points(shell: _Shell, y: float) -> list:
    """Every shell vertex on the roof (or ground) outline at height y, in counter-clockwise
    order seen from above (so the cap shares the walls' vertices: watertight)."""
    W, D = shell.W, shell.D
    pts = [np.array(p) for p in shell.V if abs(p[1] - y) < 1e-5 and
           (abs(abs(p[0]) - W / 2) < 1e-5 or abs(abs(p[2]) - D / 2) < 1e-5)]
    # outline parameter going counter-clockwise seen from +Y: front (+z) left->right, right side, back, left
    def t(p):
        x, z = p[0], p[2]
        if abs(z - D / 2) < 1e-5 and x < W / 2 - 1e-5:
            return (x + W / 2)
        if abs(x - W / 2) < 1e-5 and z > -D / 2 + 1e-5:
            return W + (D / 2 - z)
        if abs(z + D / 2) < 1e-5 and x > -W / 2 + 1e-5:
            return W + D + (W / 2 - x)
        return 2 * W + D + (z + D / 2)
    pts.sort(key=t)
    return pts


def _opening_details(b, o: Opening, T_side, frame, sill, mullion, transom):
    w, h, r = o.u1 - o.u0, o.v1 - o.v0, o.recess
    fw, fd = 0.06, 0.07          # frame profile width and depth
    z_front = -r + fd            # frame runs from the glass plane (-r) outwards by fd (facade frame: +w out)
    if o.kind in ("window", "french", "shop"):
        u0, u1, v0, v1 = o.u0, o.u1, o.v0, o.v1
        bars = [((u0, v0, -r), (u1, v0 + fw, z_front)), ((u0, v1 - fw, -r), (u1, v1, z_front)),
                ((u0, v0, -r), (u0 + fw, v1, z_front)), ((u1 - fw, v0, -r), (u1, v1, z_front))]
        if mullion or o.kind == "shop" or w > 1.15:
            parts = 2 if w < 2.2 else 3
            for k in range(1, parts):
                um = u0 + w * k / parts
                bars.append(((um - fw / 2, v0, -r), (um + fw / 2, v1, z_front - 0.01)))
        if (transom and o.kind == "window") or o.kind == "shop":
            vt = v1 - min(0.45, h * 0.3)
            bars.append(((u0, vt - fw / 2, -r), (u1, vt + fw / 2, z_front - 0.01)))
        for lo, hi in bars:
            b.box(lo, hi, frame, T=T_side)
        if o.kind != "shop":   # the sill below the opening
            b.box((u0 - 0.05, v0 - 0.05, -0.02), (u1 + 0.05, v0, 0.06), sill, T=T_side)
    else:  # door: a frame, a handle, a step
        u0, u1, v0, v1 = o.u0, o.u1, o.v0, o.v1
        for lo, hi in [((u0, v1 - 0.08, -r), (u1, v1, -r + 0.08)), ((u0, v0, -r), (u0 + 0.08, v1, -r + 0.08)),
                       ((u1 - 0.08, v0, -r), (u1, v1, -r + 0.08))]:
            b.box(lo, hi, frame, T=T_side)
        hu = u1 - 0.15
        b.box((hu - 0.02, 1.0, -r), (hu + 0.02, 1.08, -r + 0.06), frame, T=T_side)
        b.box((u0 - 0.2, -0.02, -0.02), (u1 + 0.2, 0.15, 0.35), sill, T=T_side)


# roller shutters (issue 28, session 16), as on KITTI sequence_1's near right houses (frames 0 and
# 10, full size, ~15-22 m away): 4 of the 9 windows seen have their shutter lowered 0.4-0.75 of the
# opening, the rest up (a housing and the end bar under the head); the curtain as light as the white
# render (0.94-0.97 of the wall's signal, the glass below it 0.21-0.50), its slats a +-3-7 % ripple.
# Residential shutters: PVC or aluminium slats of 37-55 mm ("mini" / "maxi" profiles) in two side
# rails, a housing of 15-25 cm at the head; most buildings of a German street have them.
P_SHUTTERS = 0.6                # the share of buildings with roller shutters on their windows
P_LOWERED = 0.45                # a window's shutter down, by a share of the opening from U(0.25, 1)
SHUTTER = (((0.74, 0.74, 0.72), 5.0), ((0.58, 0.58, 0.57), 2.5), ((0.36, 0.36, 0.35), 1.5),
           ((0.10, 0.10, 0.11), 1.0))   # white PVC, light grey, grey, anthracite aluminium


def _roller_shutters(b, rng, sides, openings) -> None:
    """Roller shutters in the windows (not doors or shop fronts) of a building that has them
    (``P_SHUTTERS``): a housing at the opening's head, two side rails and the curtain lowered from
    under the housing, its slats a sawtooth profile (the sun draws a shadow line on each)."""
    if rng.random() >= P_SHUTTERS:
        return
    s = b.surface("metal_painted", pick(rng, SHUTTER))
    pitch = rng.uniform(0.037, 0.055)         # one slat
    head = rng.uniform(0.15, 0.25)            # the housing's height
    for (origin, e_u, n, L), ops in zip(sides, openings):
        T = pose(np.column_stack([e_u, [0, 1.0, 0], n]), origin)
        for o in ops:
            if o.kind not in ("window", "french") or o.v1 - o.v0 < head + 0.4:
                continue
            lowered = rng.uniform(0.25, 1.0) if rng.random() < P_LOWERED else 0.0
            _roller_shutter(b, o, T, s, pitch, head, lowered)


_VUW = np.array([[0.0, 1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def _roller_shutter(b, o: Opening, T, s, pitch, head, lowered) -> None:
    r = o.recess
    wc = min(-r + 0.07 + 0.025, -0.03)        # the curtain's face: in front of the frame (-r + 0.07)
    u0, u1, v0, v1 = o.u0 + 0.001, o.u1 - 0.001, o.v0, o.v1 - 0.001
    top = v1 - head
    b.box((u0, top, -r + 0.001), (u1, v1, wc + 0.005), s, T=T)                 # the housing
    for a, c in ((u0, u0 + 0.035), (u1 - 0.035, u1)):                             # the side rails
        b.box((a, v0 + 0.001, wc - 0.02), (c, top, wc + 0.01), s, T=T)
    bottom = top - lowered * (top - v0)
    if lowered > 0:                           # the curtain: a groove every pitch, the slat's crest between
        k = max(int(round((top - bottom - 0.05) / pitch)), 1)   # the end bar below the slats
        vs = np.linspace(top, bottom + 0.05, 2 * k + 1)
        ws = np.where(np.arange(2 * k + 1) % 2 == 0, wc - 0.008, wc)
        # a closed slab (the kind is closed): the slats' profile in (v, w) with a flat back 2 cm
        # behind, swept across the opening; the prism's (x, y, z) are the side's (v, u, -w)
        profile = np.concatenate([np.column_stack([vs, -ws]), [(bottom + 0.05, -(wc - 0.02)), (top, -(wc - 0.02))]])
        b.prism(profile, u0 + 0.035, u1 - 0.035, s, T=np.asarray(T) @ _VUW)
    # the end bar: at the curtain's foot, or under the housing when the shutter is up
    eb = max(bottom - (0.05 if lowered == 0 else 0.0), v0 + 0.001)
    b.box((u0 + 0.035, eb, wc - 0.012), (u1 - 0.035, eb + 0.05, wc + 0.004), s, T=T)


def _band(b, W, D, y0, y1, proj, s):
    """A horizontal band projecting ``proj`` around the whole footprint (four boxes)."""
    b.box((-W / 2 - proj, y0, D / 2 - 0.01), (W / 2 + proj, y1, D / 2 + proj), s)
    b.box((-W / 2 - proj, y0, -D / 2 - proj), (W / 2 + proj, y1, -D / 2 + 0.01), s)
    b.box((-W / 2 - proj, y0, -D / 2 + 0.005), (-W / 2 + 0.01, y1, D / 2 - 0.005), s)
    b.box((W / 2 - 0.01, y0, -D / 2 + 0.005), (W / 2 + proj, y1, D / 2 - 0.005), s)


def _balcony(b, rng, cx, fy, zf, width, depth, slab, rail):
    t = 0.16
    b.box((cx - width / 2, fy - t, zf - 0.02), (cx + width / 2, fy, zf + depth), slab)
    top = fy + 1.0
    solid = rng.random() < 0.35
    x0, x1, z1 = cx - width / 2 + 0.03, cx + width / 2 - 0.03, zf + depth - 0.03
    if solid:
        for lo, hi in [((x0, fy, z1 - 0.03), (x1, top, z1)), ((x0, fy, zf), (x0 + 0.03, top, z1)),
                       ((x1 - 0.03, fy, zf), (x1, top, z1))]:
            b.box(lo, hi, rail)
        return
    for lo, hi in [((x0, top - 0.05, z1 - 0.05), (x1, top, z1)), ((x0, top - 0.05, zf), (x0 + 0.05, top, z1)),
                   ((x1 - 0.05, top - 0.05, zf), (x1, top, z1))]:
        b.box(lo, hi, rail)
    n = int((x1 - x0) / 0.12)
    for k in range(n + 1):
        x = x0 + (x1 - x0) * k / n
        b.box((x - 0.012, fy, z1 - 0.035), (x + 0.012, top - 0.05, z1 - 0.012), rail)
    n = int((z1 - zf) / 0.12)
    for k in range(1, n + 1):
        z = zf + (z1 - zf) * k / n
        for x in (x0 + 0.025, x1 - 0.025):
            b.box((x - 0.012, fy, z - 0.012), (x + 0.012, top - 0.05, z + 0.012), rail)


def _gable_roof(b, W, D, y0, rh, over, roof_s, wall, trim):
    """A gable roof, ridge along x: two sloped slabs with eaves overhang, gable triangles."""
    for sx in (-1, 1):   # gables: triangular prisms on the x ends, in the wall material
        x = sx * W / 2
        b.extrude([(x, y0, -D / 2), (x, y0, D / 2), (x, y0 + rh, 0.0)], (-sx * 0.2, 0, 0), wall)
    slope = np.arctan2(rh, D / 2)
    run = (D / 2 + over) / np.cos(slope)
    thick = 0.18
    x0, x1 = -W / 2 - over * 0.6, W / 2 + over * 0.6
    for sz in (-1, 1):
        down = np.array([0.0, -np.sin(slope), sz * np.cos(slope)])
        nrm = np.array([0.0, np.cos(slope), sz * np.sin(slope)])
        ridge = np.array([x0, y0 + rh, 0.0]) + nrm * 0.01
        b.oriented_box(ridge, (x1 - x0, 0, 0), down * run, nrm * thick, roof_s)
    b.box((x0, y0 + rh - 0.05, -0.12), (x1, y0 + rh + 0.2, 0.12), trim)


# gutters, downpipes, attic and roof windows (issue 28, session 20): the mid-scale structure of
# KITTI sequence_1's houses at 20-60 m (frames 0-44, full size) that the render's plain walls and
# roofs lacked: the render's generic buildings (the left row at 30-40 m, the far ones) carried
# 0.17-0.27 of the near houses' contrast power at 16-92 cycles per image height (session 19's
# 45-frame EXRs by object id, bench/facade_parts.py). A pitched roof drains into a half-round
# eaves gutter (DIN EN 612: 125 or 150 mm across, zinc-grey titanium zinc, some white PVC or
# copper) hung under the eaves, a 100 mm downpipe at each of the four corners with a swan neck
# out to it; a flat roof's downpipes run up under the cornice. A German house's gable holds its
# attic's windows (one, or two side by side) in a plaster surround (``Faschen``), proud of the
# wall, on a sill; a converted loft's roof slope holds roof windows (VELUX's 78 x 118 cm and
# 78 x 98 cm: a grey aluminium frame 10-12 cm proud of the tiles around the glass).
FITTINGS_STREAM = 20
GUTTER = (((0.34, 0.35, 0.36), 6.0), ((0.74, 0.74, 0.72), 2.0), ((0.30, 0.17, 0.11), 1.0))  # zinc, PVC, copper
GUTTER_RADIUS = (0.0625, 0.075)        # half of 125 / 150 mm
DOWNPIPE_RADIUS = 0.05                 # DN 100
P_GABLE_WINDOWS = 0.85                 # a pitched building's gables hold attic windows
P_ROOF_WINDOWS = 0.45                  # a roof slope holds roof windows
ROOF_WINDOW = ((0.78, 1.18), (0.78, 0.98), (1.14, 1.18))   # VELUX MK06, MK04, SK06 outer sizes (m)
ROOF_WINDOW_FRAME = (0.16, 0.16, 0.17)                     # grey aluminium cladding (RAL 7043)


def _fittings(b, rng, W, D, wall_h, roof_h, over, cornice_h, px, pitched, wall_material, frame_colour) -> None:
    """Gutters and downpipes on every building; on a pitched one also attic windows in its gables
    and roof windows in its slopes (``FITTINGS_STREAM``'s draws; their surfaces are registered
    after every other surface of the building, tagged part ``fittings``)."""
    zinc = b.surface("galvanised", pick(rng, GUTTER), part="fittings")
    glass = b.surface("glass_window", part="fittings")
    surround = b.surface(*(("plaster", palette.scaled(wall_material[1], 1.12)) if wall_material[0] == "plaster"
                           else ("plaster", (0.70, 0.69, 0.66))), part="fittings")     # brick: a stone-grey surround
    alu = b.surface("metal_painted", ROOF_WINDOW_FRAME, part="fittings")
    frame_s = b.surface("metal_painted", frame_colour, part="fittings")     # the building's windows' colour
    if pitched:
        slope = np.arctan2(roof_h, D / 2)
        rg = float(rng.choice(GUTTER_RADIUS))
        # the eave's lower edge (``_gable_roof``'s slab: from 1 cm above the ridge down ``run``)
        run = (D / 2 + over) / np.cos(slope)
        y_e = wall_h + roof_h + 0.01 * np.cos(slope) - np.sin(slope) * run
        z_e = D / 2 + over + 0.01 * np.sin(slope)
        x0, x1 = -W / 2 - over * 0.6, W / 2 + over * 0.6
        for sz in (-1, 1):                     # the eaves gutters: along x under each eave's edge
            b.cylinder(rg, x0, x1, 12, zinc, T=pose(_Y_TO_X, (0.0, y_e - 0.6 * rg, sz * (z_e + 0.4 * rg))))
        y_top = y_e - 0.6 * rg - 0.45          # the swan neck: from the wall out and up into the gutter
        for sx in (-1, 1):
            for sz in (-1, 1):
                x = sx * (W / 2 - 0.15)
                z_w, z_g = sz * (D / 2 + 0.08), sz * (z_e + 0.4 * rg)
                if not (sz == 1 and abs(x - px) < 1e-9):       # the front corner's old downpipe stays
                    b.cylinder(DOWNPIPE_RADIUS, 0.0, y_top, 10, zinc, T=pose(None, (x, 0.0, z_w)))
                b.tube([(x, y_top - 0.1, z_w), (x, y_top + 0.12, z_w), (x, y_top + 0.3, z_g), (x, y_e - 0.6 * rg, z_g)],
                       [DOWNPIPE_RADIUS * 0.9] * 4, 8, zinc)
        _gable_windows(b, rng, W, D, wall_h, roof_h, surround, frame_s, glass)
        _roof_windows(b, rng, W, D, wall_h, roof_h, over, alu, glass)
        return
    for sx in (-1, 1):                         # a flat roof: downpipes up under the cornice
        for sz in (-1, 1):
            x = sx * (W / 2 - 0.15)
            if not (sz == 1 and abs(x - px) < 1e-9):
                b.cylinder(DOWNPIPE_RADIUS, 0.0, wall_h - cornice_h - 0.02, 10, zinc, T=pose(None, (x, 0.0, sz * (D / 2 + 0.08))))


_Y_TO_X = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])     # local y along world x


def _gable_windows(b, rng, W, D, wall_h, roof_h, surround, frame_s, glass) -> None:
    """Attic windows in both gables (``P_GABLE_WINDOWS``): one, or two side by side where the
    gable is wide enough, under the roof's line by 0.35 m at least; each a pane in a frame with a
    glazing bar, a plaster surround 12 cm wide proud of the wall and a sill."""
    if rng.random() >= P_GABLE_WINDOWS:
        return
    ww, wh = float(rng.uniform(0.7, 1.0)), float(rng.uniform(0.95, 1.3))
    v0 = wall_h + float(rng.uniform(0.6, 0.95))
    two = rng.random() < 0.5
    def fits(zc):      # the window's outer corner under the gable's line (0.35 m and the surround)
        z = abs(zc) + ww / 2 + 0.12
        return v0 + wh + 0.12 + 0.35 <= wall_h + roof_h * (1 - z / (D / 2))
    zs = [-D / 6, D / 6] if two and fits(D / 6) and D / 3 - ww > 0.6 else [0.0] if fits(0.0) else []
    for sx in (-1, 1):
        # the gable's facade frame: u along the wall (from its corner), v up, w out (``_sides``)
        R = np.column_stack([(0, 0, -1.0), (0, 1.0, 0), (1.0, 0, 0)]) if sx > 0 else \
            np.column_stack([(0, 0, 1.0), (0, 1.0, 0), (-1.0, 0, 0)])
        T = pose(R, (sx * W / 2, 0.0, D / 2 if sx > 0 else -D / 2))
        for zc in zs:
            uc = D / 2 - zc if sx > 0 else zc + D / 2
            a0, a1, v1 = uc - ww / 2, uc + ww / 2, v0 + wh
            for lo, hi in (((a0 - 0.12, v0 - 0.12, 0.0), (a1 + 0.12, v0, 0.025)), ((a0 - 0.12, v1, 0.0), (a1 + 0.12, v1 + 0.12, 0.025)),
                           ((a0 - 0.12, v0, 0.0), (a0, v1, 0.025)), ((a1, v0, 0.0), (a1 + 0.12, v1, 0.025))):
                b.box(lo, hi, surround, T=T)                                          # the surround
            b.box((a0, v0, 0.0), (a1, v1, 0.01), glass, T=T)                          # the pane
            for lo, hi in (((a0, v0, 0.0), (a1, v0 + 0.06, 0.06)), ((a0, v1 - 0.06, 0.0), (a1, v1, 0.06)),
                           ((a0, v0, 0.0), (a0 + 0.06, v1, 0.06)), ((a1 - 0.06, v0, 0.0), (a1, v1, 0.06)),
                           ((uc - 0.03, v0, 0.0), (uc + 0.03, v1, 0.05))):
                b.box(lo, hi, frame_s, T=T)                                           # the frame, a bar
            b.box((a0 - 0.16, v0 - 0.17, 0.0), (a1 + 0.16, v0 - 0.12, 0.08), surround, T=T)   # the sill


def _roof_windows(b, rng, W, D, wall_h, roof_h, over, alu, glass) -> None:
    """Roof windows in each slope that has them (``P_ROOF_WINDOWS``): 1-3 of one ``ROOF_WINDOW``
    size at one height, below the chimney's band about the ridge, above the eaves by 0.8 m at
    least; the frame 12 cm proud of the tiles, the pane on it inset 7 cm."""
    slope = np.arctan2(roof_h, D / 2)
    run = (D / 2 + over) / np.cos(slope)
    thick = 0.18                                       # ``_gable_roof``'s slab
    for sz in (-1, 1):
        if rng.random() >= P_ROOF_WINDOWS:
            continue
        w, h = ROOF_WINDOW[int(rng.integers(len(ROOF_WINDOW)))]
        s_lo = (D / 5) / np.cos(slope) + 0.3           # below the chimney's band (``generate``: |z| < D/5)
        s_hi = run - over / np.cos(slope) - 0.8 - h    # its foot 0.8 m above the wall's line
        n = int(rng.integers(1, 4))
        span = W - 2.4
        if s_hi < s_lo or span < w:
            continue
        n = max(1, min(n, int(span // (w + 1.0))))
        s = float(rng.uniform(s_lo, s_hi))
        down = np.array([0.0, -np.sin(slope), sz * np.cos(slope)])
        nrm = np.array([0.0, np.cos(slope), sz * np.sin(slope)])
        ridge = np.array([0.0, wall_h + roof_h, 0.0]) + nrm * (0.01 + thick - 0.02)
        for k in range(n):
            xc = -span / 2 + span * (k + 0.5) / n
            o = ridge + down * s + np.array([xc - w / 2, 0.0, 0.0])
            b.oriented_box(o, (w, 0, 0), down * h, nrm * 0.14, alu)
            b.oriented_box(o + np.array([0.07, 0, 0]) + down * 0.07 + nrm * 0.14, (w - 0.14, 0, 0), down * (h - 0.14),
                           nrm * 0.01, glass)
