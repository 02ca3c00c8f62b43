"""The near facades' fine detail, KITTI sequence_1 vs a city render (issue 28, session 16).

KITTI: hand-marked boxes on the near right row's white houses (wall, windows with their frames,
blinds and sills; 14-22 m away by its full-size SGBM), frames 0 and 10. The render: its building
pixels 12-35 m away in the upper right of the frame (x > W/2, y < 0.6 H), by object id and depth,
frames 0, 4, ... Both at the render's size (613 x 185), linear (twin.py's _linear).
Figures: pixel-scale contrast (twin.py's robust deviation over the 5 x 5 mean), contrast power
(the frame over its mean, band-passed) at 48-72 and 72-92 cycles per image height, the share of
pixels darker than half the region's median (openings, blinds, shadow lines) and that share's
part of the top band's power.

    PYTHONPATH=. .venv/bin/python bench/facade_detail.py /work/runs/lead/before24_s16/city
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import twin  # noqa: E402

# (x0, y0, x1, y1) at 1226 x 370: the white houses' walls and windows (no tree, post or sky)
KITTI_FACADES = {0: (895, 20, 1025, 150), 10: (870, 20, 1040, 175)}


def _figures(L: np.ndarray, grey8: np.ndarray, mask: np.ndarray) -> dict:
    bands = twin.band_images(grey8, ((48, 72), (72, 92)))
    med = np.median(L[mask])
    dark = mask & (L < 0.5 * med)
    top = bands[1] ** 2
    return {"grain": twin._grain(L, mask), "p48_72": 1e4 * float(np.mean(bands[0][mask] ** 2)),
            "p72_92": 1e4 * float(np.mean(top[mask])), "dark": float(dark.sum() / mask.sum()),
            "dark_top": float(top[dark].sum() / max(top[mask].sum(), 1e-12)), "px": int(mask.sum())}


def kitti(size=(613, 185), boxes=None, figures=None) -> list[dict]:
    """``figures`` (default ``_figures``) of KITTI's hand-marked ``boxes`` ({frame: (x0, y0, x1, y1)}
    at 1226 x 370; default ``KITTI_FACADES``), each frame at the render's ``size``."""
    W, H = size
    out = []
    for k, (x0, y0, x1, y1) in (boxes or KITTI_FACADES).items():
        img = twin.kitti_marked_frame(k)
        sx, sy = W / img.shape[1], H / img.shape[0]
        g8 = cv2.resize(img, (W, H), interpolation=cv2.INTER_AREA)
        L = twin._linear(g8, "kitti")
        m = np.zeros((H, W), bool)
        m[int(np.ceil(y0 * sy)) + 1:int(y1 * sy) - 1, int(np.ceil(x0 * sx)) + 1:int(x1 * sx) - 1] = True
        out.append({"frame": k, **(figures or _figures)(L, g8, m)})
    return out


def render(folder: Path, frames=range(0, 24, 4)) -> list[dict]:
    seq, cls = twin.render_classes(folder)
    bld = [i for i, c in cls.items() if c == "building"]
    out = []
    for k in frames:
        g8 = cv2.imread(str(folder / "sensor" / "left" / "rgb" / f"{k:06d}.png"), 0)
        H, W = g8.shape
        L = twin._linear(g8, "kitti")
        ids = np.asarray(seq.ids(k, "left")).astype(int)
        depth = np.asarray(seq.depth(k, "left"))
        m = np.isin(ids, bld) & (depth > 12) & (depth < 35)
        m = cv2.erode(m.astype(np.uint8), np.ones((3, 3))) > 0
        m[int(0.6 * H):, :] = False
        m[:, :W // 2] = False
        if m.sum() > 200:
            out.append({"frame": k, **_figures(L, g8, m)})
    return out


def _summary(rows: list[dict]) -> str:
    keys = ("grain", "p48_72", "p72_92", "dark", "dark_top")
    return ", ".join(f"{key} {np.median([r[key] for r in rows]):.3f}" for key in keys) + \
        f" ({len(rows)} frames, {int(np.median([r['px'] for r in rows]))} px)"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    real = kitti()
    print("KITTI near facades:", _summary(real))
    for r in real:
        print("  ", json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in r.items()}))
    for f in argv:
        ours = render(Path(f))
        print(f"render {f}:", _summary(ours))
        for r in ours:
            print("  ", json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in r.items()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
