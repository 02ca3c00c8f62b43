"""Cars: a lofted body (plan-view rounded ends, wheel arches cut into the sills, bonnet,
windscreen, roof, rear window and boot or hatch), glass where the windows are, pillars in
paint, tyres with rims and hubs in the arches, lamps, number plates, grille and mirrors.

Asset frame: ``size`` = (width x, height y, length z), ground at y = 0, nose towards +z.
"""
from __future__ import annotations

import numpy as np

from . import palette
from .mesh import MeshData, pose, rot_x, rot_z, start
from .palette import pick

def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def generate(size, seed: int) -> MeshData:
    rng, W, H, L, b = start(size, seed)
    paint = b.surface("car_paint", pick(rng, palette.CAR_PAINT))
    glass = b.surface("glass_window")
    trim = b.surface("plastic", (0.03, 0.03, 0.03))
    tyre = b.surface("rubber")
    rim = b.surface("metal_brushed", None if rng.random() < 0.7 else (0.08, 0.08, 0.08))
    head = b.surface("chrome")
    tail = b.surface("plastic", (0.35, 0.01, 0.01))
    plate = b.surface("plastic", (0.75, 0.75, 0.72))

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
    loops, bands = [], []
    tumble = rng.uniform(0.1, 0.16)
    for z in zs:
        hw, yt, yb = half_w(z), top_y(z), bottom_y(z)
        g = _smoothstep((z_ws - z) / 0.15) * _smoothstep((z - z_boot) / 0.15) if style != "estate" else \
            _smoothstep((z_ws - z) / 0.15) * _smoothstep((z - z_boot + 0.1) / 0.1)
        yl = min(max(belt_y, yb + 0.1), yt - 0.02)                                   # belt line
        y_side = np.clip([yb + 0.05, 0.5 * (yb + yl), yl - 0.08], yb + 0.01, yl - 0.01)
        hg = hw - tumble
        r_top = (1 - g) * (hw - 0.05) + g * (hg + 0.02)
        y_top_side = (1 - g) * (yt - 0.015) + g * (yt - 0.06)
        right = [(hw - 0.07, yb), (hw - 0.01, y_side[0]), (hw, y_side[1]), (hw - 0.005, y_side[2]),
                 (hw - 0.02, yl), (r_top, max(y_top_side, yl + 0.005)), (0.55 * r_top, yt + 0.004)]
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
    # lamps, grille, plates
    z_front = L / 2 - 0.02
    for sx in (-1, 1):
        x0, x1 = sorted((sx * (hw_end - 0.08), sx * (hw_end - 0.38)))
        b.box((x0, front_y - 0.01, z_front - 0.12), (x1, front_y + 0.09, z_front + 0.003), head)
        b.box((x0, rear_y - 0.02, -z_front - 0.003), (x1, rear_y + 0.1, -z_front + 0.1), tail)
    b.box((-0.3, front_y - 0.2, z_front - 0.1), (0.3, front_y - 0.04, z_front + 0.004), trim)
    b.box((-0.26, clear + 0.2, z_front - 0.05), (0.26, clear + 0.31, z_front + 0.012), plate)
    b.box((-0.26, rear_y - 0.2, -z_front - 0.012), (0.26, rear_y - 0.09, -z_front + 0.05), plate)
    # mirrors at the base of the A pillars
    for sx in (-1, 1):
        x_in = sx * (half_w(z_ws - 0.1) - 0.02)
        x0, x1 = sorted((x_in, x_in + sx * 0.2))
        b.box((x0, belt_y + 0.03, z_ws - 0.22), (x1, belt_y + 0.15, z_ws - 0.12), paint)
    # wheels: tyre (revolved, rounded shoulders), rim disc, hub
    tw = 0.2 + 0.02 * rng.random()
    prof = [(0, -tw / 2), (rw * 0.62, -tw / 2), (rw * 0.9, -tw / 2 + 0.005), (rw - 0.012, -tw / 2 + 0.025),
            (rw, -tw / 4), (rw, tw / 4), (rw - 0.012, tw / 2 - 0.025), (rw * 0.9, tw / 2 - 0.005),
            (rw * 0.62, tw / 2), (0, tw / 2)]
    for zw in (z_wf, z_wr):
        for sx in (-1, 1):
            xw = sx * (half_w(zw) - tw / 2 - 0.03)
            T = pose(rot_z(90), (xw, rw, zw))          # tyre axis (local Y) along x
            b.revolve(prof, 28, tyre, T=T)
            T_rim = pose(rot_z(90), (xw + sx * (tw / 2 - 0.015), rw, zw))
            b.cylinder(rw * 0.6, -0.012, 0.012, 24, rim, T=T_rim)
            for a in range(5):     # spokes, radial in the rim's plane
                b.box((-0.014, 0.05, -0.025), (0.014, rw * 0.58, 0.025), rim,
                      T=pose(rot_x(72.0 * a + 17.0 * sx), (xw + sx * (tw / 2 - 0.01), rw, zw)))
            b.cylinder(0.06, -0.02, 0.02, 12, head, T=T_rim)
    return b.build()
