"""Renders docs/img/assets.jpg: most asset kinds side by side (docs/ses-language.md).

    .venv/bin/python tools/make_asset_gallery.py [--samples 32] [--out out/asset_gallery]

Three rows on a concrete ground: street and vegetation at the back, indoor furniture in
the middle, industrial and natural clutter at the front; buildings, strips, terrain and
the large hall pieces are left out (they are the scene library's business).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
from blender_sesgen import assets

ROWS = (
    (-7.0, ["car", "tree", "conifer", "bush", "hedge", "streetlight", "traffic_light", "bin", "bollard", "bench",
            "fence", "pole"]),
    (-2.5, ["table", "desk", "chair", "shelf", "cabinet", "sofa", "door", "plant", "monitor", "rug", "ceiling_light"]),
    (1.0, ["machine", "tank", "crate", "pallet", "barrel", "railing", "rock", "log", "stump", "fern", "grass_tuft"]),
)


def script() -> str:
    lines = ["// the asset gallery of docs/ses-language.md (tools/make_asset_gallery.py)",
             "CAMERA resolution 1280 640 focal 780 baseline 0.1",
             "START position 0 7 14 -22 0 0",
             "WORLD sky elevation 40 azimuth -30",
             "RENDER samples 32 denoise on",
             "QUAD id 1 material concrete vertices -40 0 20  40 0 20  40 0 -40  -40 0 -40"]
    next_id = 10
    for z, kinds in ROWS:
        sizes = [assets.default_size(k, 3) for k in kinds]
        widths = [min(s[0], 4.5) + 0.6 for s in sizes]
        x = -sum(widths) / 2
        for k, s, w in zip(kinds, sizes, widths):
            pos = (x + w / 2, 1.6 if k == "ceiling_light" else 0.0, z)
            if k == "pole":
                lines.append(f"ASSET sign id {next_id} seed 3 position {pos[0]:.3f} 0 {z + 0.07:.3f} size 0.7 2.4 0.025")
                next_id += 1
            lines.append(f"ASSET {k} id {next_id} seed 3 position {pos[0]:.3f} {pos[1]:.3f} {pos[2]:.3f}")
            next_id += 1
            x += w
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "out" / "asset_gallery"))
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "gallery.ses").write_text(script())
    env = dict(os.environ, PYTHONPATH=str(REPO))
    subprocess.run([sys.executable, "-m", "blender_sesgen", "render", str(out / "gallery.ses"), "--out",
                    str(out / "render"), "--force", "--quiet"], check=True, env=env, cwd=REPO)
    import cv2
    from vo_reference.io.sequence import open_sequence
    rgb = open_sequence(out / "render").image_rgb(0, "left")
    cv2.imwrite(str(REPO / "docs" / "img" / "assets.jpg"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR),
                [cv2.IMWRITE_JPEG_QUALITY, 88])
    print("docs/img/assets.jpg")
    return 0


if __name__ == "__main__":
    sys.exit(main())
