"""A scene's build after an update of the package: what the asset cache keeps across it.

    PYTHONPATH=. .venv/bin/python bench/build_after_update.py [--revs 3d4fe64 HEAD] [--scenes hall office forest]
        [--touch farm/local.py generators/builtin/city_kitti.py] [--scale 0.25] [--samples 8] [--frames 1]

For each revision, scene and touched file: a copy of the revision's tree (``git archive``, compiled to
.pyc), a fresh asset cache (``SESGEN_ASSET_CACHE``), then three builds in fresh processes through
bench/profile_scenes.py's child (the real job): ``cold`` (the cache empty: a machine's first build),
``warm`` (the second build), ``after`` (a comment line appended to the touched file of the copy, as an
update of the package that changes no behaviour, compiled again, then built). Each row: CPU s to
frame 0's first sample, and the exposure preview's CPU s (0.00: read back from the cache) and the
asset generators' (small: read back). A file a revision does not have is skipped. ``nice -n 5`` it
on a shared machine; CPU seconds are the process's user + system time.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def build(code: Path, cache: Path, scene: str, a) -> dict:
    cmd = [sys.executable, str(code / "bench" / "profile_scenes.py"), "--child", "--scene",
           str(code / "scenes" / f"{scene}.ses"), "--feature", "baseline", "--quality", "final", "--scale", str(a.scale),
           "--frames", str(a.frames), "--samples", str(a.samples)]
    env = dict(os.environ, PYTHONPATH=str(code), SESGEN_ASSET_CACHE=str(cache))
    out = subprocess.run(cmd, cwd=code, env=env, capture_output=True, text=True)
    line = next((ln for ln in out.stdout.splitlines() if ln.startswith("PROFILE ")), None)
    if out.returncode != 0 or line is None:
        raise SystemExit(f"{scene} failed in {code}:\n{out.stderr[-3000:]}")
    r = json.loads(line[len("PROFILE "):])
    return {"cpu": r["to_first_sample"]["cpu"], "exposure": r["build"]["exposure"], "assets": r["build"]["assets"]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--revs", nargs="+", default=["HEAD"])
    p.add_argument("--scenes", nargs="+", default=["hall", "office", "forest"])
    p.add_argument("--touch", nargs="+", default=["farm/local.py"],
                   help="files of the package (relative to blender_sesgen/) an update changes")
    p.add_argument("--scale", type=float, default=0.25)
    p.add_argument("--samples", type=int, default=8)
    p.add_argument("--frames", type=int, default=1)
    a = p.parse_args(argv)
    print(f"# load {os.getloadavg()[0]:.1f}; scale {a.scale}, {a.samples} samples, {a.frames} frame(s); CPU s to the "
          "first sample (exposure preview, asset generators)", flush=True)
    with tempfile.TemporaryDirectory(prefix="sesgen-update-") as tmp:
        for rev in a.revs:
            sha = subprocess.run(["git", "rev-parse", "--short", rev], cwd=REPO, check=True, capture_output=True,
                                 text=True).stdout.strip()
            for scene in a.scenes:
                for touched in a.touch:
                    code = Path(tmp) / f"{sha}-{scene}-{touched.replace('/', '_')}"
                    code.mkdir()
                    archive = subprocess.run(["git", "archive", rev], cwd=REPO, check=True, capture_output=True).stdout
                    subprocess.run(["tar", "-x", "-C", str(code)], input=archive, check=True)
                    target = code / "blender_sesgen" / touched
                    if not target.is_file():
                        print(f"{sha} {scene}: no {touched}, skipped", flush=True)
                        continue
                    compile_ = [sys.executable, "-m", "compileall", "-q", str(code / "blender_sesgen")]
                    subprocess.run(compile_, check=True, capture_output=True)
                    cache = code / "cache"
                    rows = [("cold", build(code, cache, scene, a)), ("warm", build(code, cache, scene, a))]
                    with open(target, "a") as f:
                        f.write("\n# an update\n")
                    subprocess.run(compile_, check=True, capture_output=True)
                    rows.append(("after", build(code, cache, scene, a)))
                    cells = "  ".join(f"{k} {r['cpu']:.2f} ({r['exposure']:.2f}, {r['assets']:.2f})" for k, r in rows)
                    print(f"{sha} {scene:8s} {touched:34s} {cells}  load {os.getloadavg()[0]:.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
