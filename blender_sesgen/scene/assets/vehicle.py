"""Cars: a lofted body (plan-view rounded ends, wheel arches cut into the sills, bonnet,
windscreen, roof, rear window and boot or hatch), glass where the windows are, pillars in
paint, tyres with rims and hubs in the arches, grille and mirrors; the fine detail a camera sees
at 5-20 m: lamps as their reflectors' tilted facets (red, amber, clear: the glints), EU number
plates with embossed dark characters, the mirrors' glass, door shut lines and handles, badges and
the rear bumper's reflectors; since session 19 alloy wheels in the tyres' rim wells (lip, spokes,
brake disc in the well's shadow), the tailgate's or boot lid's shut lines, the bumper cover's
ledge, a boot lip or roof spoiler with the third brake lamp, the rear wiper, tail pipe and rear
fog lamp, bright lamp bezels on some cars, and the cabin seen through the rear glass (headrests
against the windscreen's light).

Asset frame: ``size`` = (width x, height y, length z), ground at y = 0, nose towards +z.
"""
from __future__ import annotations

import numpy as np

from . import palette
from .mesh import MeshData, _box_triangles, pose, rot_x, rot_y, rot_z, start
from .palette import pick

# the fine detail (session 16, measured in KITTI sequence_1's frames 0 and 20 at 12-14 m: the rear
# lamps' sun glints and sky reflections carry 14-30 % of a car's finest contrast, at 5-9x the body's
# median; plates 1.9-4.5x; wheels 2-4x; the rear window 0.26-1x, darker than a grey body)
CABIN = (0.015, 0.015, 0.016)        # a car's interior under its glass: dark seats and trim
LAMP_RED = (0.7, 0.05, 0.04)         # a metallised reflector behind a red lens: a red mirror (library ``vehicle_lamp``)
LAMP_AMBER = (0.7, 0.35, 0.03)
LAMP_CLEAR = (0.6, 0.6, 0.6)         # a clear lens (reversing lamps, headlamps) over its reflector
REFLECTOR_CELL_M = (0.04, 0.035)     # a lamp's reflector facets (pillow optics), width x height
PLATE_M = (0.52, 0.11)               # the EU plate, width x height
PLATE_WHITE = (0.5, 0.5, 0.48)       # retro-reflective sheeting (daytime luminance factor ~0.4-0.5; assumed)
PLATE_INK = (0.03, 0.03, 0.03)
PLATE_BLUE = (0.02, 0.05, 0.25)      # the EU band at the plate's left
GLYPH_M = (0.044, 0.075, 0.009)      # a character's width, height and stroke (FE-Schrift ~47.5 x 75 mm)
# seven-segment glyphs (top, top right, bottom right, bottom, bottom left, top left, middle)
GLYPHS = ("1111110", "0110000", "1101101", "1111001", "0110011", "1011011", "1011111", "1110000",
          "1111111", "1111011", "1110111", "0011111", "1001110", "0111101", "1001111", "1000111", "0110111")
# session 19 (KITTI sequence_1 frames 0 and 20 at 613 px: bright spokes over the dark wheel well,
# the tailgate's and boot lid's shut lines, the wiper and third brake lamp on the rear glass)
RIM_R = 0.66                         # the rim's radius over the tyre's (16-17" rims in 205/55 R16 - 225/45 R17: 0.64-0.68)
RIM_WELL_M = 0.05                    # the wheel's face sits this far into the tyre's sidewall (the well the spokes span)
BRAKE_DISC = (0.28, 0.27, 0.26)      # a cast-iron brake disc behind the spokes (library ``metal_rusty``)
SHUT_GAP_M = 0.005                   # panel gaps: 3.5-5 mm on a current car, seen as a dark slot
WIPER_M = 0.018                      # a rear wiper's arm and blade, across
# what the rear glass shows of the cabin (under the opaque glass, as ``glass_window``'s rooms):
# above the rear seats' backs (at the belt line) the light through the windscreen and side
# glass beyond (the street's light through a tinted rear pane and the windscreen, ~0.3 x a
# grey street), against it the headrests' dark shapes (0.24-0.28 m wide, 0.18-0.22 m tall)
CABIN_THROUGH = (0.06, 0.06, 0.062)


def _end_outline(W, L, n=800, wrap_deg=75.0):
    """The body's plan outline round one corner (``half_w``'s rounded end, its flat end 2 cm in),
    from the middle of the end (x = 0) to where it faces ``wrap_deg`` sideways (on the flank):
    points (m, 2) as (x, |z|) and their arc length from that flank end, metres."""
    x = np.linspace(0.0, 0.999 * W / 2, n)
    z = np.minimum(L / 2 * (1 - (2 * x / W) ** 7) ** (1 / 7), L / 2 - 0.02)
    slope = np.degrees(np.arctan(np.abs(np.gradient(z, x))))
    keep = np.arange(n) <= np.argmax(slope > wrap_deg)
    P = np.column_stack([x[keep], z[keep]])
    seg = np.hypot(np.diff(P[:, 0]), np.diff(P[:, 1]))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    return P, s[-1] - s


def _lamp(b, rd, arc0, arc1, y0, y1, W, L, rear, sx, colour_of):
    """A lamp as its reflector's facets round the body's corner: cells ``REFLECTOR_CELL_M`` wide
    along the plan outline from arc0 to arc1 (metres of outline from the flank: a lamp that wraps
    round the corner starts at 0), y0..y1 high, each on the outline, facing out, tilted +-30 deg
    at random (the slopes of a reflector's bowls: some face the sun or the sky, the glints of
    real lamps); each a box reaching 4 cm into the body. ``sx``: the side (+1 right, -1 left);
    ``colour_of(i, j, nx, ny)``: the cell's surface, i = 0 the innermost column."""
    P, arc = _end_outline(W, L)
    cw, ch = REFLECTOR_CELL_M
    nx = max(2, int(round((arc1 - arc0) / cw)))
    ny = max(2, int(round((y1 - y0) / ch)))
    ys = np.linspace(y0, y1, ny + 1)
    a_edges = np.linspace(arc1, arc0, nx + 1)          # inner end first
    order = np.argsort(arc)
    sz = -1.0 if rear else 1.0
    cols = []
    for i in range(nx):
        ac = 0.5 * (a_edges[i] + a_edges[i + 1])
        x = float(np.interp(ac, arc[order], P[order, 0]))
        z = float(np.interp(ac, arc[order], P[order, 1]))
        xa = float(np.interp(ac + 0.005, arc[order], P[order, 0]))
        xb = float(np.interp(ac - 0.005, arc[order], P[order, 0]))
        za = float(np.interp(ac + 0.005, arc[order], P[order, 1]))
        zb = float(np.interp(ac - 0.005, arc[order], P[order, 1]))
        tx, tz = xb - xa, zb - za                        # towards the flank
        nxn, nzn = tz, -tx                               # outward (|z| grows, x grows)
        if nzn < 0:
            nxn, nzn = -nxn, -nzn
        yaw = np.degrees(np.arctan2(sx * nxn, sz * nzn))
        w = abs(a_edges[i + 1] - a_edges[i]) / 2
        cols.append((sx * x, sz * z, yaw, w))
        for j in range(ny):
            yc = 0.5 * (ys[j] + ys[j + 1])
            R = rot_y(yaw) @ rot_y(rd.uniform(-30, 30)) @ rot_x(rd.uniform(-30, 30))
            h = (ys[j + 1] - ys[j]) / 2
            b.box((-w, -h, -0.04), (w, h, 0.004), colour_of(i, j, nx, ny), T=pose(R, (sx * x, yc, sz * z)))
    return cols


def _plate(b, rd, y0, z_face, rear, white, ink, blue):
    """An EU number plate (``PLATE_M``) whose face is at z_face (facing -z at the rear, +z at
    the front), its blue band at the viewer's left and 6-8 embossed dark characters (seven-segment
    shapes of ``GLYPH_M``, 1.5 mm proud) in two or three groups."""
    pw, ph = PLATE_M
    sgn = -1.0 if rear else 1.0
    right = sgn                         # the viewer's right along x (looking at the plate: +z x up)
    za, zb = sorted((z_face, z_face - sgn * 0.05))
    b.box((-pw / 2, y0, za), (pw / 2, y0 + ph, zb), white)
    zo, zi = z_face + sgn * 0.0015, z_face - sgn * 0.001
    zlo, zhi = min(zo, zi), max(zo, zi)
    ux0 = -pw / 2 + 0.005
    xa, xb = sorted((right * ux0, right * (ux0 + 0.04)))
    b.box((xa, y0 + 0.005, zlo), (xb, y0 + ph - 0.005, zhi), blue)
    gw, gh, st = GLYPH_M
    n = int(rd.integers(6, 9))
    gaps = sorted(rd.choice(np.arange(1, n), size=2, replace=False))
    u, v0 = ux0 + 0.055, y0 + (ph - gh) / 2
    for k in range(n):
        if k in gaps:
            u += 0.02
        seg = GLYPHS[int(rd.integers(len(GLYPHS)))]
        boxes = {0: (0, gh - st, gw, gh), 1: (gw - st, gh / 2, gw, gh), 2: (gw - st, 0, gw, gh / 2), 3: (0, 0, gw, st),
                 4: (0, 0, st, gh / 2), 5: (0, gh / 2, st, gh), 6: (0, (gh - st) / 2, gw, (gh + st) / 2)}
        for s, on in enumerate(seg):
            if on == "1":
                a0, b0, a1, b1 = boxes[s]
                xa, xb = sorted((right * (u + a0), right * (u + a1)))
                b.box((xa, v0 + b0, zlo), (xb, v0 + b1, zhi), ink)
        u += gw + 0.009
        if u + gw > pw / 2 - 0.005:
            break


def _lamps_plates_badges(b, rd, W, L, hw_end, front_y, rear_y, clear, head):
    """Tail lamps (red facets; a clear reversing block and an amber indicator row on some cars),
    headlamps (clear facets, amber at the outer end; all library ``vehicle_lamp``), both plates
    with their characters, a chrome badge at each end and red reflectors in the rear bumper."""
    red, amber = b.surface("vehicle_lamp", LAMP_RED), b.surface("vehicle_lamp", LAMP_AMBER)
    lens = b.surface("vehicle_lamp", LAMP_CLEAR)
    white, ink = b.surface("plastic", PLATE_WHITE), b.surface("plastic", PLATE_INK)
    blue = b.surface("plastic", PLATE_BLUE)
    lw, lh = rd.uniform(0.4, 0.55), rd.uniform(0.13, 0.22)     # along the outline, round the corner
    reverse_inner = rd.random() < 0.6                  # the reversing lamp: the lamp's inner block
    amber_top = rd.random() < 0.35                     # the indicator: the lamp's top row
    hlw, hlh = rd.uniform(0.35, 0.5), rd.uniform(0.1, 0.16)

    def tail_cell(i, j, nx, ny):
        if reverse_inner and i < max(1, nx // 4) and j < ny - 1:
            return lens
        return amber if amber_top and j == ny - 1 else red

    def head_cell(i, j, nx, ny):
        return amber if i >= nx - 2 else lens

    tail = []
    for sx in (-1, 1):
        tail += _lamp(b, rd, 0.0, lw, rear_y + 0.01 - lh, rear_y + 0.01, W, L, True, sx, tail_cell)
        _lamp(b, rd, 0.04, 0.04 + hlw, front_y + 0.02 - hlh, front_y + 0.02, W, L, False, sx, head_cell)
        x0, x1 = sorted((sx * (hw_end - 0.1), sx * (hw_end - 0.2)))    # rear bumper reflectors
        b.box((x0, clear + 0.09, -L / 2 - 0.014), (x1, clear + 0.12, -L / 2 - 0.004), red)
    z_end = L / 2 - 0.02
    _plate(b, rd, clear + 0.2, z_end + 0.012, False, white, ink, blue)
    _plate(b, rd, rear_y - 0.2, -z_end - 0.012, True, white, ink, blue)
    T = pose(rot_x(90), (0.0, rear_y - 0.04, -z_end))                  # badges: discs facing out
    b.cylinder(0.04, -0.006, 0.006, 16, head, T=T)
    b.cylinder(0.04, -0.006, 0.006, 16, head, T=pose(rot_x(90), (0.0, front_y - 0.12, z_end + 0.012)))
    return lw, (tail, rear_y + 0.01 - lh, rear_y + 0.01)


def _cabin(b, rd, zs, glass_top, half_w, tumble, z0, z1, y_seat, through):
    """The cabin seen through the rear glass (z0..z1 along the car, the glass's middle band,
    |x| < 0.55 of the roof's half width): thin slabs in the ``through`` glass 2-3 mm over the
    glass where the view passes over the rear seats' backs (above ``y_seat``) to the bright
    windscreen, left out where a headrest stands in it (rear ones on the seat backs, the front
    ones further on, seen higher). ``glass_top``: the glass's height at x = 0 by station."""
    rear = [(s * rd.uniform(0.3, 0.38), rd.uniform(0.12, 0.14), y_seat, y_seat + rd.uniform(0.18, 0.22))
            for s in (-1, 1)]
    if rd.random() < 0.5:
        rear.append((0.0, 0.1, y_seat, y_seat + 0.12))
    lift = rd.uniform(0.1, 0.16)
    front = [(s * rd.uniform(0.3, 0.37), 0.11, y_seat + lift, y_seat + lift + 0.18) for s in (-1, 1)]
    heads = rear + front
    ys = np.array([glass_top(z) for z in zs])
    y_at = lambda x, z, xm: float(np.interp(z, zs, ys)) - 0.006 * abs(x) / xm   # noqa: E731
    n = max(2, int(round((z1 - z0) / 0.02)))
    edges = np.linspace(z0, z1, n + 1)
    tris = _box_triangles(())
    for za, zb in zip(edges[:-1], edges[1:]):
        zc = 0.5 * (za + zb)
        yc = float(np.interp(zc, zs, ys))
        if yc < y_seat:
            continue
        xm = 0.55 * (half_w(zc) - tumble + 0.02)
        cuts = sorted((xc - w, xc + w) for xc, w, y0, y1 in heads if y0 <= yc <= y1)
        for lo, hi in ((-xm + 0.01, 0.0), (0.0, xm - 0.01)):
            a = lo
            for c0, c1 in cuts + [(hi, hi)]:
                b_ = min(c0, hi)
                if b_ - a > 0.01:
                    V = [(x, y_at(x, z, xm) + dy, z) for x in (a, b_) for dy in (-0.002, 0.003) for z in (za, zb)]
                    b.add(V, tris, through, closed=True)
                a = max(a, c1)


def _wheel_style(rd):
    """A wheel's spokes: (count, width m): alloys of 5-10 spokes 2.5-5 cm wide (many-spoked
    ones narrower)."""
    n = int(rd.choice([5, 5, 5, 6, 7, 8, 10]))
    return n, float(rd.uniform(0.035, 0.05) if n <= 6 else rd.uniform(0.022, 0.032))


def _wheel(b, style, face_x, sx, rw, zw, rim, cap, disc):
    """The wheel in the tyre's rim well (``RIM_R``, ``RIM_WELL_M``) whose outer face is at x =
    face_x (sx: the side, +1 right): the rim's lip (a ring 6 % of the tyre's radius wide, flush
    with the sidewall), the spokes from the hub to the lip 8-35 mm in, the centre cap, and behind
    the spokes the brake disc and the rim's barrel 4-5 cm in, where the well's shadow falls: the
    bright spokes over a dark well a camera sees on real wheels."""
    n, w = style
    at = lambda d0, d1: sorted((face_x - sx * d0, face_x - sx * d1))   # noqa: E731  (depths in from the face)
    r_lip = RIM_R * rw
    seg = 24
    half = np.pi * r_lip / seg * 1.08
    x0, x1 = at(0.004, 0.016)
    for k in range(seg):
        b.box((x0, r_lip - 0.06 * rw, -half), (x1, r_lip + 0.003, half), rim, T=pose(rot_x(360.0 * k / seg), (0.0, rw, zw)))
    x0, x1 = at(0.008, 0.035)
    phase = 17.0 * sx + 40.0 * zw
    for k in range(n):
        b.box((x0, 0.05, -w / 2), (x1, r_lip - 0.05 * rw, w / 2), rim, T=pose(rot_x(phase + 360.0 * k / n), (0.0, rw, zw)))
    T = lambda d: pose(rot_z(90), (face_x - sx * d, rw, zw))           # noqa: E731  (axis along x)
    b.cylinder(0.065, -0.012, 0.012, 16, cap, T=T(0.02))
    b.cylinder(0.45 * rw, -0.006, 0.006, 24, disc, T=T(0.042))
    b.cylinder(r_lip - 0.01, -0.002, 0.002, 24, rim, T=T(RIM_WELL_M - 0.003))


def _rear_detail(b, rd, W, L, style, clear, rear_y, z_rr, z_boot, top_y, lw, tail, hw_cap, hw_roof, paint, gap, red,
                 pipe):
    """The rear's shut lines (the tailgate's or boot lid's: dark ``SHUT_GAP_M`` slots up both
    sides just inboard of the tail lamps and across under the plate), a hatch's or estate's
    third brake lamp at the top of the rear glass and its wiper parked across the glass's foot,
    the exhaust's tail pipe under the bumper on most cars, the rear fog lamp in the bumper (ECE
    R38: one, at the driver's side) and, on half the cars, the tail lamps' bright bezels
    (chrome, or the clear lens's edge over its reflector: KITTI's lamps' outlines glint) along
    their tops and feet. ``tail``: the tail lamps' columns (x, z, yaw, half width) and their
    foot and top."""
    cols, y_foot, y_top = tail
    if rd.random() < 0.5:
        for x, z, yaw, w in cols:
            for y0 in (y_top, y_foot - 0.01):
                b.box((-w, y0, -0.03), (w, y0 + 0.01, 0.006), pipe, T=pose(rot_y(yaw), (x, 0.0, z)))
    xf = hw_cap - rd.uniform(0.25, 0.35)                                   # the fog lamp: the car's left (+x)
    for i in range(3):
        for j in range(2):
            R = rot_y(rd.uniform(-30, 30)) @ rot_x(rd.uniform(-30, 30))
            b.box((-0.017, -0.015, -0.004), (0.017, 0.015, 0.02), red,
                  T=pose(R, (xf + 0.034 * (i - 1), clear + 0.095 + 0.03 * j, -L / 2 - 0.012)))
    P, arc = _end_outline(W, L)
    order = np.argsort(arc)
    x_g = min(float(np.interp(lw + 0.02, arc[order], P[order, 0])), hw_cap - 0.04)
    z_c = -(L / 2 - 0.02)                       # the rear's flat face
    y_low = max(clear + 0.2, rear_y - 0.2 - rd.uniform(0.04, 0.1))
    g = SHUT_GAP_M / 2
    z0, z1 = z_c - 0.0015, z_c + 0.01
    for sx in (-1, 1):
        xa, xb = sorted((sx * (x_g - g), sx * (x_g + g)))
        b.box((xa, y_low - g, z0), (xb, rear_y - 0.01, z1), gap)
    b.box((-x_g, y_low - g, z0), (x_g, y_low + g, z1), gap)
    # the bumper's cover in paint under the lid's foot, 4 cm proud of the tail (its top a ledge
    # that mirrors the sky over a face that mirrors the street: the rear's brightest line), and
    # the lid's trailing edge (a sedan's boot lip between the lamps, a hatch's roof spoiler over
    # its glass with the third brake lamp in it)
    b.box((-(hw_cap + 0.03), clear + 0.16, -L / 2 - 0.03), (hw_cap + 0.03, y_low - g, -L / 2 + 0.2), paint)
    if style == "sedan":
        b.box((-(x_g - 0.01), rear_y - 0.01, -L / 2), (x_g - 0.01, rear_y + 0.02, -L / 2 + 0.12), paint)
    else:
        z3 = z_rr - 0.1
        y3 = top_y(z3)
        b.box((-hw_roof, y3 - 0.01, z3), (hw_roof, y3 + 0.035, z_rr + 0.06), paint)
        hw3 = rd.uniform(0.1, 0.16)                                        # the third brake lamp
        b.box((-hw3, y3 + 0.005, z3 - 0.004), (hw3, y3 + 0.03, z3 + 0.01), red)
        if rd.random() < 0.85:                                             # the wiper across the glass's foot
            zw_ = z_boot + 0.1
            side = 1.0 if rd.random() < 0.5 else -1.0
            xa, xb = sorted((side * -0.03, side * rd.uniform(0.3, 0.4)))
            y = top_y(zw_) + 0.006
            b.box((xa, y, zw_ - WIPER_M / 2), (xb, y + WIPER_M, zw_ + WIPER_M / 2), gap)
    if rd.random() < 0.7:                                                  # the tail pipe
        xe = (1.0 if rd.random() < 0.3 else -1.0) * (hw_cap - rd.uniform(0.2, 0.3))
        b.cylinder(0.032, -0.03, 0.05, 16, pipe, T=pose(rot_x(90), (xe, clear + 0.03, -L / 2)))
        b.cylinder(0.024, -0.031, -0.02, 12, gap, T=pose(rot_x(90), (xe, clear + 0.03, -L / 2)))


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def generate(size, seed: int) -> MeshData:
    rng, W, H, L, b = start(size, seed)
    paint = b.surface("car_paint", pick(rng, palette.CAR_PAINT))
    glass = b.surface("glass_window", CABIN)
    trim = b.surface("plastic", (0.03, 0.03, 0.03))
    tyre = b.surface("rubber")
    rim = b.surface("metal_brushed", None if rng.random() < 0.7 else (0.08, 0.08, 0.08))
    head = b.surface("chrome")

    style = rng.choice(["hatch", "sedan", "estate"], p=[0.45, 0.3, 0.25])
    rw = float(np.clip(0.1 * L * rng.uniform(0.68, 0.76), 0.29, 0.36))      # wheel radius
    clear = 0.15
    ov_f, ov_r = L * rng.uniform(0.19, 0.22), L * rng.uniform(0.15, 0.2)
    z_wf, z_wr = L / 2 - ov_f, -L / 2 + ov_r                                   # axles
    ra = rw + 0.055                                                            # arch radius
    bonnet_y = H * rng.uniform(0.6, 0.66)
    belt_y = bonnet_y + rng.uniform(0.02, 0.08)
    z_ws = z_wf - rng.uniform(0.3, 0.5)                                        # windscreen base
    z_rf = z_ws - (H - bonnet_y) * rng.uniform(1.4, 1.8)                       # roof front
    if style == "sedan":
        z_boot = -L / 2 + rng.uniform(0.85, 1.05)
        z_rr = z_boot + (H - belt_y) * rng.uniform(1.5, 1.9)
        tail_y = belt_y + 0.02
    elif style == "estate":
        z_boot = -L / 2 + 0.12
        z_rr = z_boot + 0.25
        tail_y = belt_y + 0.05
    else:
        z_boot = -L / 2 + 0.1
        z_rr = z_boot + rng.uniform(0.45, 0.7)
        tail_y = belt_y + 0.05
    front_y, rear_y = bonnet_y - 0.12, tail_y - 0.1

    def top_y(z):
        """Upper outline (side view) at z."""
        if z >= z_ws:          # bonnet: rounded nose
            t = (z - z_ws) / (L / 2 - z_ws)
            return bonnet_y + 0.03 * (1 - t) - (bonnet_y - front_y) * _smoothstep((t - 0.6) / 0.4) ** 1.5
        if z >= z_rf:          # windscreen
            t = (z_ws - z) / (z_ws - z_rf)
            return bonnet_y + 0.03 + (H - bonnet_y - 0.03) * np.sin(t * np.pi / 2) ** 0.8
        if z >= z_rr:          # roof, slight crown
            t = (z_rf - z) / max(z_rf - z_rr, 1e-6)
            return H - 0.03 * (2 * t - 1) ** 2 * (1 if style != "estate" else 0.3)
        if z >= z_boot:        # rear window
            t = (z_rr - z) / max(z_rr - z_boot, 1e-6)
            return H - 0.03 - (H - 0.03 - tail_y) * t ** 1.2
        t = (z_boot + L / 2 - (z + L / 2)) / max(z_boot + L / 2, 1e-6)  # boot lid / tail
        return tail_y - (tail_y - rear_y) * _smoothstep(t) ** 2

    def bottom_y(z):
        y = clear + 0.12 * _smoothstep((abs(z) - (L / 2 - 0.45)) / 0.4)     # bumpers' lower edges rise
        for zw in (z_wf, z_wr):
            dz = z - zw
            if abs(dz) < ra:
                y = max(y, rw + np.sqrt(ra * ra - dz * dz))
        return y

    def half_w(z):
        u = abs(2 * z / L)
        return W / 2 * (1 - u ** 7) ** (1 / 7) if u < 1 else 0.0

    # stations: dense at the arches and ends
    zs = set(np.linspace(-L / 2 + 0.02, L / 2 - 0.02, 46))
    for zw in (z_wf, z_wr):
        zs |= set(zw + ra * np.cos(np.linspace(0, np.pi, 17)))
    zs |= {z_ws, z_rf, z_rr, z_boot}
    zs = np.array(sorted(z for z in zs if -L / 2 + 0.02 <= z <= L / 2 - 0.02))
    glass_ws = lambda z: z_rf + 0.04 < z < z_ws - 0.03                        # noqa: E731
    glass_rear = lambda z: z_boot + 0.05 < z < z_rr - 0.04 and style != "sedan" or (  # noqa: E731
        style == "sedan" and z_boot + 0.04 < z < z_rr - 0.04)
    z_b = 0.5 * (z_ws + z_rr) + 0.1                                            # B pillar
    side_glass = lambda z: (z_rr - (0.25 if style == "sedan" else 0.12) < z < z_ws - 0.08  # noqa: E731
                            and abs(z - z_b) > 0.06)
    def flank(z):
        """The right flank's section at z, sill to belt line: (x, y) points (the loop's lower part)."""
        hw, yt, yb = half_w(z), top_y(z), bottom_y(z)
        yl = min(max(belt_y, yb + 0.1), yt - 0.02)                                   # belt line
        y_side = np.clip([yb + 0.05, 0.5 * (yb + yl), yl - 0.08], yb + 0.01, yl - 0.01)
        return [(hw - 0.07, yb), (hw - 0.01, y_side[0]), (hw, y_side[1]), (hw - 0.005, y_side[2]), (hw - 0.02, yl)]

    loops, bands = [], []
    tumble = rng.uniform(0.1, 0.16)
    for z in zs:
        hw, yt, yb = half_w(z), top_y(z), bottom_y(z)
        g = _smoothstep((z_ws - z) / 0.15) * _smoothstep((z - z_boot) / 0.15) if style != "estate" else \
            _smoothstep((z_ws - z) / 0.15) * _smoothstep((z - z_boot + 0.1) / 0.1)
        lower = flank(z)
        yl = lower[-1][1]
        hg = hw - tumble
        r_top = (1 - g) * (hw - 0.05) + g * (hg + 0.02)
        y_top_side = (1 - g) * (yt - 0.015) + g * (yt - 0.06)
        right = lower + [(r_top, max(y_top_side, yl + 0.005)), (0.55 * r_top, yt + 0.004)]
        loop = [(0.0, yb)] + right + [(0.0, yt + 0.01)] + [(-x, y) for x, y in right[::-1]]
        loops.append([(x, y, z) for x, y in loop])
        # band surfaces (between points j and j+1 of this loop and the next), decided at the band's middle later
    loops = np.array(loops)
    k = loops.shape[1]
    for i in range(len(zs) - 1):
        zm = 0.5 * (zs[i] + zs[i + 1])
        row = []
        for j in range(k):
            s = paint
            if j in (0, k - 1):
                s = trim                                                     # underbody
            elif j in (5, k - 6) and side_glass(zm):                         # side windows
                s = glass
            elif j in (6, 7, k - 8, k - 7) and (glass_ws(zm) or glass_rear(zm)):
                s = glass
            row.append(s)
        bands.append(row)
    b.loft(loops, bands, paint, smooth=True)
    # bumpers: dark plastic wraps at both ends
    hw_end = half_w(L / 2 - 0.1)
    for zc, zz in ((L / 2 - 0.12, 0.26), (-L / 2 + 0.1, 0.22)):
        b.box((-hw_end + 0.02, clear + 0.06, zc - zz / 2), (hw_end - 0.02, clear + 0.16, zc + zz / 2 + 0.015), trim)
    # lamps, grille, plates, badges (the rear's fine detail: _rear_and_front_detail)
    rd = np.random.default_rng([seed, 16])           # the details' own stream: the body's draws stay
    z_front = L / 2 - 0.02
    lw, tail = _lamps_plates_badges(b, rd, W, L, hw_end, front_y, rear_y, clear, head)
    b.box((-0.3, front_y - 0.2, z_front - 0.1), (0.3, front_y - 0.04, z_front + 0.004), trim)
    for y in (front_y - 0.16, front_y - 0.09):        # grille bars
        b.box((-0.29, y, z_front + 0.004), (0.29, y + 0.012, z_front + 0.012), head)
    # mirrors at the base of the A pillars, their glass facing back
    for sx in (-1, 1):
        x_in = sx * (half_w(z_ws - 0.1) - 0.02)
        x0, x1 = sorted((x_in, x_in + sx * 0.2))
        b.box((x0, belt_y + 0.03, z_ws - 0.22), (x1, belt_y + 0.15, z_ws - 0.12), paint)
        g0, g1 = sorted((x_in + sx * 0.015, x_in + sx * 0.185))
        b.box((g0, belt_y + 0.04, z_ws - 0.226), (g1, belt_y + 0.14, z_ws - 0.218), head)
    # door shut lines (dark gaps) and handles on both flanks, following the flank's section
    doors = [z_ws - 0.06, z_b] + ([z_wr + ra + 0.08] if style != "hatch" else [])
    handles = [z_b - 0.25] + ([z_wr + ra + 0.3] if style != "hatch" else [])
    handle = trim if rd.random() < 0.6 else head
    for zc in doors:
        pts = [(x, y) for x, y in flank(zc)[1:]]
        for sx in (-1, 1):
            for (x0, y0), (x1, y1) in zip(pts[:-1], pts[1:]):
                if y1 - y0 < 1e-3:
                    continue
                b.oriented_box((sx * (x0 + 0.003), y0, zc - 0.003), (sx * (x1 - x0), y1 - y0, 0.0),
                               (-sx * 0.015, 0.0, 0.0), (0.0, 0.0, 0.006), trim)
    for zc in handles:
        pts = np.array(flank(zc))
        x = float(np.interp(belt_y - 0.09, pts[:, 1], pts[:, 0]))
        for sx in (-1, 1):
            x0, x1 = sorted((sx * (x - 0.006), sx * (x + 0.014)))
            b.box((x0, belt_y - 0.105, zc - 0.09), (x1, belt_y - 0.075, zc + 0.09), handle)
    # wheels: tyre (revolved, rounded shoulders) whose rim well shows the wheel (_wheel)
    tw = 0.2 + 0.02 * rng.random()
    rd19 = np.random.default_rng([seed, 19])          # session 19's parts: their own stream
    wheel = _wheel_style(rd19)
    prof = [(0, -tw / 2 + RIM_WELL_M), (rw * RIM_R, -tw / 2 + RIM_WELL_M), (rw * RIM_R, -tw / 2 + 0.004),
            (rw * 0.9, -tw / 2 + 0.005), (rw - 0.012, -tw / 2 + 0.025), (rw, -tw / 4), (rw, tw / 4),
            (rw - 0.012, tw / 2 - 0.025), (rw * 0.9, tw / 2 - 0.005), (rw * RIM_R, tw / 2 - 0.004),
            (rw * RIM_R, tw / 2 - RIM_WELL_M), (0, tw / 2 - RIM_WELL_M)]
    disc = b.surface("metal_rusty", BRAKE_DISC)
    for zw in (z_wf, z_wr):
        for sx in (-1, 1):
            xw = sx * (half_w(zw) - tw / 2 - 0.03)
            T = pose(rot_z(90), (xw, rw, zw))          # tyre axis (local Y) along x
            b.revolve(prof, 28, tyre, T=T)
            _wheel(b, wheel, xw + sx * tw / 2, sx, rw, zw, rim, head, disc)
    # the cabin through the rear glass, the rear's shut lines, third brake lamp, wiper and exhaust (session 19)
    g0, g1 = (z_boot + 0.05, z_rr - 0.04) if style != "sedan" else (z_boot + 0.04, z_rr - 0.04)
    _cabin(b, rd19, zs, lambda z: top_y(z) + 0.01, half_w, tumble, g0 + 0.01, g1 - 0.01, belt_y + 0.05,
           b.surface("glass_window", CABIN_THROUGH))
    _rear_detail(b, rd19, W, L, style, clear, rear_y, z_rr, z_boot, top_y, lw, tail, half_w(L / 2 - 0.02),
                 half_w(z_rr) - tumble - 0.04, paint, trim, b.surface("vehicle_lamp", LAMP_RED), head)
    return b.build()
