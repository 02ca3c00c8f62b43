"""Prove that a change left the renders alone: every shipped scene, rendered by a base
revision and by the working tree, must give the same pixels in every channel of every EXR
and the same manifest (timing and version fields aside).

    .venv/bin/python bench/identical_renders.py [--base REV] [--scenes scenes/*.ses]
                                                [--scale 0.25] [--samples 2] [--keep DIR] [--no-last]
                                                [--base-args "..."] [--head-args "..."]

The base revision is checked out into a temporary git worktree and run with the same
Python; each scene renders frames 0, 1 and its last frame (both views; ``--no-last``: not the
last) at ``--scale`` with ``--samples`` samples in a fresh process per side; a channel that
differs is listed with its largest difference and PSNR (peak: the base's largest value). Exit code 0 when everything is
identical, 1 otherwise (the differing files and channels are listed). ``--keep DIR`` keeps
the base renders there and reuses them on the next run (same base commit and settings).
``--base-args`` / ``--head-args`` add render options to one side, e.g. the same revision
rendered the plain way (a fresh Cycles session per view) against the fast path:

    bench/identical_renders.py --base HEAD --base-args "--plain-pipeline --quality gt" --head-args "--quality gt"

Manifest keys a side does not write (added by a later revision: ``render.quality``,
``render.sampling``) and the record of how it was rendered (``render.pipeline``; and the
``seal``, a hash over it, when the two records differ) are not compared; every other key is.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
from blender_sesgen.files.exr import read_exr  # the pure reader: no OpenEXR needed

# manifest keys that may differ between two identical renders
VOLATILE = {"generator"}


def git(*args: str, cwd: Path = REPO) -> str:
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True, text=True).stdout.strip()


def frame_count(code_root: Path, scene: Path) -> int:
    code = ("import sys; from blender_sesgen.ses import parse_file; "
            "print(parse_file(sys.argv[1]).frames)")
    out = subprocess.run([sys.executable, "-c", code, str(scene)], cwd=code_root, capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=str(code_root)), check=True)
    return int(out.stdout.strip())


def render(code_root: Path, scene: Path, out: Path, frames: str, args, extra: str = "") -> None:
    # the scene path relative to the code root: the manifest records it as given
    cmd = [sys.executable, "-m", "blender_sesgen", "render", str(scene), "--out", str(out), "--frames", frames,
           "--samples", str(args.samples), "--resolution-scale", str(args.scale), "--quiet", "--resume",
           *shlex.split(extra)]
    proc = subprocess.run(cmd, cwd=code_root, env=dict(os.environ, PYTHONPATH=str(code_root)),
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"render failed in {code_root} for {scene.name} {frames}:\n{proc.stderr}")


def render_scene(code_root: Path, scene: Path, out: Path, args, extra: str = "") -> None:
    n = frame_count(code_root, scene)  # scene: relative to code_root
    for frames in sorted({"0:2" if n > 1 else "0:1"} | (set() if args.no_last else {f"{n - 1}:{n}"})):
        render(code_root, scene, out, frames, args, extra)


def comparable(manifest: dict, other: dict) -> dict:
    """``manifest`` without the keys not compared (see the module docstring)."""
    m = {k: v for k, v in manifest.items() if k not in VOLATILE}
    r = dict(m.get("render") or {})
    if r.pop("pipeline", None) != (other.get("render") or {}).get("pipeline"):
        m.pop("seal", None)    # the seal hashes the rest of the manifest, the pipeline's record too
    for k in ("quality", "quality_overridden", "sampling"):
        if k not in (other.get("render") or {}):
            r.pop(k, None)
    m["render"] = r
    return m


def compare(base: Path, head: Path) -> list[str]:
    problems = []
    mb = json.loads((base / "manifest.json").read_text())
    mh = json.loads((head / "manifest.json").read_text())
    mb, mh = comparable(mb, mh), comparable(mh, mb)
    for key in sorted(set(mb) | set(mh)):
        if mb.get(key) != mh.get(key):
            problems.append(f"manifest key {key!r} differs")
    for exr in sorted(base.glob("exr/*/*.exr")):
        other = head / exr.relative_to(base)
        if not other.is_file():
            problems.append(f"{exr.relative_to(base)} missing in the working tree's render")
            continue
        a, b = read_exr(exr), read_exr(other)
        if set(a) != set(b):
            problems.append(f"{exr.relative_to(base)}: channels {sorted(a)} vs {sorted(b)}")
            continue
        for name in sorted(a):
            if a[name].dtype != b[name].dtype or not np.array_equal(a[name], b[name], equal_nan=True):
                d = np.abs(a[name].astype(float) - b[name].astype(float))
                mse, peak = np.nanmean(d ** 2), np.nanmax(np.abs(a[name].astype(float)))
                psnr = f", PSNR {10 * np.log10(peak ** 2 / mse):.1f} dB (peak {peak:.3g})" if mse > 0 and peak > 0 else ""
                problems.append(f"{exr.relative_to(base)}: channel {name} differs (max |diff| {np.nanmax(d):.3g}{psnr})")
    return problems


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--base", default="HEAD", help="git revision to compare against (default HEAD)")
    p.add_argument("--scenes", nargs="*", type=Path, default=sorted((REPO / "scenes").glob("*.ses")))
    p.add_argument("--scale", type=float, default=0.25)
    p.add_argument("--samples", type=int, default=2)
    p.add_argument("--no-last", action="store_true",
                   help="frames 0 and 1 only (a scene's last frame makes an AUTOEXPOSURE render meter every frame)")
    p.add_argument("--keep", type=Path, help="keep (and reuse) the base renders in this folder")
    p.add_argument("--base-args", default="", help="extra render options for the base revision")
    p.add_argument("--head-args", default="", help="extra render options for the working tree")
    args = p.parse_args(argv)
    commit = git("rev-parse", args.base)
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-identical-"))
    tag = hashlib.sha256(args.base_args.encode()).hexdigest()[:8]
    base_root = args.keep.resolve() / f"{commit[:12]}-s{args.scale}-n{args.samples}-{tag}" if args.keep else tmp / "base"
    worktree = tmp / "src"
    failures = 0
    try:
        git("worktree", "add", "--detach", str(worktree), commit)
        for scene in args.scenes:
            scene = scene.resolve()
            rel = scene.relative_to(REPO)
            base_out, head_out = base_root / scene.stem, tmp / "head" / scene.stem
            if not (base_out / "manifest.json").is_file():
                render_scene(worktree, rel, base_out, args, args.base_args)
            render_scene(REPO, rel, head_out, args, args.head_args)
            problems = compare(base_out, head_out)
            n_exr = len(list(base_out.glob("exr/*/*.exr")))
            status = "identical" if not problems else f"{len(problems)} difference(s)"
            print(f"{rel}: {n_exr} EXRs, every channel compared: {status}", flush=True)
            for line in problems[:20]:
                print(f"    {line}")
            failures += bool(problems)
    finally:
        git("worktree", "remove", "--force", str(worktree))
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"base {commit[:12]} vs working tree: {'all identical' if not failures else f'{failures} scene(s) differ'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
