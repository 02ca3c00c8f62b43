"""Make docs/img/city_loop_map.png: a top-down map of a generated city (scenes/city_loop.ses) with
the camera's route coloured by time and its loop closures: the frames where the camera
passes within ``--radius`` metres of where it was at least ``--gap`` seconds before (drawn
thick, joined to where it was then); with ``--covisibility RENDER`` the ground truth's
loop-closure pairs of that render instead (vo_reference.groundtruth.covisibility): every query
frame, each 10th joined to its most covisible match (docs/img/city_loop_covisibility_map.png).

    python tools/make_city_map.py scenes/city_loop.ses [--covisibility out/city_loop] [--out PNG]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from blender_sesgen.contract.frames import object_pose
from blender_sesgen.scene.model import Asset, Cuboid, Quad
from blender_sesgen.ses import parse_file

OUT = Path(__file__).resolve().parents[1] / "docs" / "img" / "city_loop_map.png"
COLOURS = {"road": "#4a4a4a", "sidewalk": "#b9b4aa", "terrain": "#a9c98f", "building": "#c0714f",
           "vegetation": "#3f7a3a", "car": "#3465a4", "parking": "#6a6a6a", "pole": "#222222"}


def footprint(o) -> np.ndarray | None:
    """The ground outline (4, 2) x, z of a cuboid or a sized asset (asset frame: origin mid
    footprint; strips run along -z)."""
    if isinstance(o, Quad):
        return np.asarray(o.vertices)[:, [0, 2]]
    if isinstance(o, Cuboid):
        hx, hz = o.size[0] / 2, o.size[2] / 2
        local = np.array([(-hx, 0, -hz), (hx, 0, -hz), (hx, 0, hz), (-hx, 0, hz)])
    elif isinstance(o, Asset):
        w, _, d = o.size
        if o.kind in ("kerb", "sidewalk", "road", "verge"):
            local = np.array([(o.offset - w / 2, 0, 0), (o.offset + w / 2, 0, 0), (o.offset + w / 2, 0, -d),
                              (o.offset - w / 2, 0, -d)])
        else:
            local = np.array([(-w / 2, 0, -d / 2), (w / 2, 0, -d / 2), (w / 2, 0, d / 2), (-w / 2, 0, d / 2)])
    else:
        return None
    T = object_pose(o.position, o.rotation_deg)
    return (local @ T[:3, :3].T + T[:3, 3])[:, [0, 2]]


def geometric_closures(P: np.ndarray, t: np.ndarray, radius: float, gap: float) -> list[tuple[int, int]]:
    """(k, j): frame k passes within ``radius`` of frame j's position, j at least ``gap`` s earlier."""
    out = []
    for k in range(len(P)):
        old = np.flatnonzero(t <= t[k] - gap)
        if len(old):
            d = np.linalg.norm(P[old] - P[k], axis=1)
            if d.min() < radius:
                out.append((k, int(old[np.argmin(d)])))
    return out


def best_matches(loops: np.ndarray, c) -> list[tuple[int, int]]:
    """(query, match) of each query frame's most covisible match among the loop-closure pairs."""
    best: dict[int, tuple[float, int]] = {}
    for (q, m), cq in zip(loops, c):
        if cq > best.get(int(q), (-1.0, 0))[0]:
            best[int(q)] = (cq, int(m))
    return [(q, best[q][1]) for q in sorted(best)]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("script")
    ap.add_argument("--covisibility", metavar="RENDER", help="draw the loop-closure pairs of this render's ground truth")
    ap.add_argument("--radius", type=float, default=4.0)
    ap.add_argument("--gap", type=float, default=30.0)
    ap.add_argument("--out", default=str(OUT))
    a = ap.parse_args(argv)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection, PolyCollection

    scene = parse_file(a.script)
    T = scene.timeline.left()
    P = T[:, :3, 3][:, [0, 2]]
    rate = scene.timing.rate_hz if scene.timing else 25.0
    t = np.arange(len(P)) / rate
    polys, cols = [], []
    order = {"terrain": 0, "sidewalk": 1, "road": 2, "parking": 2}
    objs = sorted(scene.objects, key=lambda o: order.get(o.semantic_class, 3))
    for o in objs:
        if o.name == "ground" or scene.motion_of(o.id) is not None:
            continue
        fp = footprint(o)
        if fp is not None:
            polys.append(fp)
            cols.append(COLOURS.get(o.semantic_class, "#999999"))
    fig, ax = plt.subplots(figsize=(9, 9), dpi=110)
    ax.add_collection(PolyCollection(polys, facecolors=cols, edgecolors="none"))
    seg = np.stack([P[:-1], P[1:]], axis=1)
    lc = LineCollection(seg, cmap="viridis", linewidths=1.6)
    lc.set_array(t[:-1])
    ax.add_collection(lc)
    if a.covisibility:
        from vo_reference.groundtruth.covisibility import read_covisibility
        cov = read_covisibility(a.covisibility)
        loops = cov.loop_closures
        pairs = best_matches(loops, [cov.c(q, m) for q, m in loops])
        label = (f"the {len(pairs)} query frames of {len(loops)} loop-closure pairs\n(ground truth: "
                 f"c >= {cov.params.loop_threshold:g}, >= {cov.params.min_gap_s:g} s apart)")
        step, line_label = 10, "each 10th query frame to its most covisible match"
        dots = dict(s=30, alpha=0.35, edgecolors="none", zorder=1.5)      # under the route: many frames
    else:
        pairs = geometric_closures(P, t, a.radius, a.gap)
        label = f"passes within {a.radius:g} m of a place >= {a.gap:g} s earlier"
        step, line_label = max(len(pairs) // 40, 1), None
        dots = dict(s=7, zorder=3)
    if pairs:
        k = np.array(sorted({p[0] for p in pairs}))
        ax.scatter(P[k, 0], P[k, 1], c="#e8262b", label=label, **dots)
        for n, (i, j) in enumerate(pairs[::step]):
            ax.plot([P[i, 0], P[j, 0]], [P[i, 1], P[j, 1]], color="#e8262b", lw=0.6, alpha=0.6,
                    label=line_label if n == 0 else None)
    ax.plot(*P[0], marker="o", color="white", mec="black", ms=8, zorder=4, label="start")
    ax.plot(*P[-1], marker="s", color="white", mec="black", ms=8, zorder=4, label="end")
    span = np.ptp(P, axis=0).max() / 2 + 60
    c = (P.max(axis=0) + P.min(axis=0)) / 2
    ax.set_xlim(c[0] - span, c[0] + span)
    ax.set_ylim(c[1] + span, c[1] - span)          # z grows towards the viewer: north (-z) up
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")
    cb = fig.colorbar(lc, ax=ax, shrink=0.7)
    cb.set_label("time (s)")
    ax.legend(loc="lower left", fontsize=8)
    ax.set_title(f"{Path(a.script).name}: {len(P)} frames, {np.linalg.norm(np.diff(P, axis=0), axis=1).sum():.0f} m")
    fig.tight_layout()
    fig.savefig(a.out)
    print(a.out)


if __name__ == "__main__":
    main()
