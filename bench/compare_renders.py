"""Pixel-identity check: render scenes with a baseline revision and with this tree, compare
every channel of every EXR (bitwise).

    python bench/compare_renders.py [--baseline main] [--frames 0:2] [--scale 0.25] [--samples 2] SCENE...

The baseline is checked out into a temporary git worktree (removed afterwards). Prints one
line per scene and view; exit code 1 if any channel differs.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from blender_sesgen.exr import read_exr  # noqa: E402


def render(tree: Path, scene: Path, out: Path, args) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(scene), "--out", str(out), "--quiet",
           "--frames", args.frames, "--resolution-scale", str(args.scale), "--samples", str(args.samples)]
    r = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    if r.returncode:
        raise SystemExit(f"render failed in {tree}: {r.stderr}")
    import json
    return json.loads((out / "manifest.json").read_text())


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenes", nargs="+", type=Path)
    p.add_argument("--baseline", default="main")
    p.add_argument("--frames", default="0:2")
    p.add_argument("--scale", type=float, default=0.25)
    p.add_argument("--samples", type=int, default=2)
    args = p.parse_args()
    bad = 0
    with tempfile.TemporaryDirectory(prefix="sesgen-compare-") as tmp:
        base = Path(tmp) / "baseline"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(base), args.baseline],
                       check=True, capture_output=True)
        try:
            for scene in args.scenes:
                scene = scene.resolve()
                ma = render(base, scene, Path(tmp) / f"{scene.stem}_base", args)
                mb = render(REPO, scene, Path(tmp) / f"{scene.stem}_this", args)
                for view in ma["views"]:
                    n_ch, diff = 0, []
                    for k, done in enumerate(ma["frames_complete"]):
                        if not done:
                            continue
                        a = read_exr(Path(tmp) / f"{scene.stem}_base" / ma["files"][view][k])
                        b = read_exr(Path(tmp) / f"{scene.stem}_this" / mb["files"][view][k])
                        for name in sorted(set(a) | set(b)):
                            n_ch += 1
                            if name not in a or name not in b or not np.array_equal(a[name], b[name], equal_nan=True):
                                diff.append(f"{k}:{name}")
                    bad += bool(diff)
                    print(f"{scene.name} {view}: {n_ch} channels compared, "
                          + ("identical" if not diff else f"DIFFERENT: {', '.join(diff[:5])}"))
        finally:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(base)], capture_output=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
