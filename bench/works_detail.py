"""The far works block's fine contrast, KITTI sequence_1 vs a city render (issue 28, session 17).

KITTI: hand-marked boxes on the scaffolded block being built 45-100 m ahead right (its end wall
in shade behind the scaffold, frames 20 and 30; its sunlit long side's upper floors with their
unglazed openings, frames 40 and 45). The render: its works block's pixels (the ASSET building
with material ``works_blocks`` and the scaffolds, by object id, 3 px in from their edges), frames
0, 2, ... of the render's folder, developed through today's camera chain (twin.resensor, draw 0).
Both at the render's size (613 x 185), linear (twin._linear). Figures as bench/facade_detail.py:
pixel-scale contrast, contrast power at 48-72 and 72-92 cycles per image height, the share of
pixels darker than half the region's median and its part of the top band; and the region's
median signal over the frame's mean.

    PYTHONPATH=. .venv/bin/python bench/works_detail.py /work/runs/lead/before24_s17/city [frames]
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import twin  # noqa: E402
import facade_detail  # noqa: E402

# (x0, y0, x1, y1) at 1226 x 370: the works block with its scaffold (no tree, sign or sky)
KITTI_WORKS = {20: (700, 10, 850, 100), 30: (800, 0, 960, 100), 40: (700, 5, 810, 95), 45: (710, 0, 880, 90)}


def _figures(L, g8, mask):
    f = facade_detail._figures(L, g8, mask)
    f["level"] = float(np.median(L[mask]) / max(L.mean(), 1e-9))
    return f


def kitti(size=(613, 185)) -> list[dict]:
    return facade_detail.kitti(size, KITTI_WORKS, _figures)


def works_ids(folder: Path) -> list[int]:
    """The works block's ids: the building with material works_blocks and every scaffold."""
    man = json.loads((folder / "manifest.json").read_text())
    return [o["id"] for o in man["objects"] if o.get("material") == "works_blocks" or o.get("kind") in
            ("scaffold", "building_shell")]


def render(folder: Path, n: int, step: int = 2) -> list[dict]:
    seq = twin.open_sequence(folder)
    ids_w = works_ids(folder)
    frames = twin.resensor(folder, n)
    out = []
    for k in range(0, n, step):
        g8 = frames.image_gray(k)
        L = twin._linear(g8, "kitti")
        ids = np.asarray(seq.ids(k, "left")).astype(int)
        m = cv2.erode(np.isin(ids, ids_w).astype(np.uint8), np.ones((7, 7))) > 0
        if m.sum() > 100:
            out.append({"frame": k, **_figures(L, g8, m)})
    return out


def _summary(rows: list[dict]) -> str:
    keys = ("grain", "p48_72", "p72_92", "dark", "dark_top", "level")
    return ", ".join(f"{key} {np.median([r[key] for r in rows]):.3f}" for key in keys) + \
        f" ({len(rows)} frames, {int(np.median([r['px'] for r in rows]))} px)"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        print(__doc__)
        return 2
    folder = Path(argv[0])
    n = int(argv[1]) if len(argv) > 1 else 24
    k = kitti()
    for r in k:
        print("KITTI ", r)
    print("KITTI  works block:", _summary(k))
    rr = render(folder, n)
    for r in rr:
        print("render", r)
    print("render works block:", _summary(rr))
    return 0


if __name__ == "__main__":
    sys.exit(main())
