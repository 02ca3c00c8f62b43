"""What render reuse saves a study: a sensor-stage variant developed from its base's EXRs
(``render --reuse-exr``) against rendering it with Cycles, on the same machine in one run.

    python bench/bench_study.py [--frames 6] [--scale 1.0] [--samples 4] [--repeat 2]

Renders scenes/paper_room.ses (its first ``--frames`` frames, at ``--scale``) with a SENSOR
(the base), then the variant with ``SENSOR gain 4`` twice: by Cycles, and developed from
the base's EXRs. Prints the wall times (best of ``--repeat``), their ratio, and whether the
two variants hold the same EXR bytes (what reuse promises: Cycles renders the base's).
"""
from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def render(script: Path, out: Path, *args) -> float:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "blender_sesgen", "render", str(script), "--out", str(out), "--force",
                    "--quiet", *args], check=True, env=env)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--scale", type=float, default=0.25)
    ap.add_argument("--samples", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="bench_study_"))
    try:
        keep = (REPO / "scenes" / "paper_room.ses").read_text().splitlines()
        base = work / "base.ses"
        base.write_text("\n".join(keep + ["SENSOR readnoise 3 seed 1"]) + "\n")
        variant = work / "gain.ses"
        variant.write_text("\n".join(keep + ["SENSOR readnoise 3 seed 1 gain 4"]) + "\n")
        opts = ["--samples", str(a.samples), "--resolution-scale", str(a.scale), "--frames", f"0:{a.frames}"]
        render(base, work / "base", *opts)
        cycles = min(render(variant, work / "cycles", *opts) for _ in range(a.repeat))
        reuse = min(render(variant, work / "reuse", *opts, "--reuse-exr", str(work / "base"))
                    for _ in range(a.repeat))
        same = all(hashlib.sha256((work / "cycles" / p.relative_to(work / "reuse")).read_bytes()).digest()
                   == hashlib.sha256(p.read_bytes()).digest() for p in (work / "reuse" / "exr").rglob("*.exr"))
        with open("/proc/loadavg") as f:
            load = f.read().split()[:3]
        print(f"paper_room {a.frames} frames x 2 views, resolution x{a.scale:g}, {a.samples} samples; load {' '.join(load)}")
        print(f"  rendered by Cycles:           {cycles:7.2f} s")
        print(f"  developed from the base EXRs: {reuse:7.2f} s")
        print(f"  ratio developed / rendered:   {reuse / cycles:7.3f}")
        print(f"  EXR bytes equal to the base's: {'yes' if same else 'NO'} (the developed variant's are the base's)")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
