"""Stress the render folder's concurrent-writer contract: chunks of one scene rendering into one
folder at the same time, started with random delays, optionally one of them killed -9 after
a random number of its frames (as soon as its completion log holds them: before its end takes
them into the manifest), optionally under CPU burners; every trial's folder checked against a one-run
render of the same scene (docs/output-format.md, "Concurrent writers").

    PYTHONPATH=. .venv/bin/python bench/folder_races.py --out /tmp/races [--trials 10]
        [--chunks 2] [--kill] [--burners 2] [--delay 4] [--code DIR]

``--code DIR``: the blender_sesgen to test (the render children's PYTHONPATH; default this
checkout), e.g. a ``git archive`` of an older commit for a before/after count. The scene: the
sensor test's (tests/test_sensor_exports.py: 64x48, lens, SENSOR, AUTOEXPOSURE, IMU) with
``--frames`` poses (default 8), rendered at 2 samples; ``--chunks`` splits its frames (a render
logs frame k once frame k+1 has rendered, so a chunk killed after some of its frames needs 3).

A trial's folder is judged after the farm's consolidation (``OutputFolder.consolidate``, what
``farm``'s verify task does once every chunk has ended), by what the manifest promises:

- ``chunk failed``: a chunk that was not killed did not exit 0;
- ``incomplete``: without ``--kill``, a frame not recorded complete;
- ``state``: a frame recorded complete whose exposure or gain is not the one-run render's
  (null: lost), or whose metered brightness is set and differs;
- ``checksum``: a frame recorded complete, or a static file (poses, lens table, IMU), whose
  recorded SHA-256 is not the one-run render's or whose file is not what it records;
- ``verify``: ``sesgen verify --quick`` of the folder finds a problem;
- ``reader``: with ``--kill``, before the consolidation: a frame a reader (``Manifest.read``)
  sees complete with an exposure or gain other than the one-run render's (a killed chunk's
  state files not merged: null).

Prints one line per trial and the counts; writes OUT/summary.json. Not a test (minutes).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _scene(frames: int) -> str:
    """The sensor test's scene with ``frames`` poses (its four, then on along the same path)."""
    text = re.search(r'SCENE = """(.*?)"""', (REPO / "tests" / "test_sensor_exports.py").read_text(), re.S).group(1)
    lines = text.splitlines()
    poses = [ln for ln in lines if ln.startswith("POSE ")]
    last = len(poses)
    for k in range(last, frames):
        j = k - last + 1   # on from the last pose (x y z, then the turn in degrees)
        poses.append(f"POSE {0.2 + 0.06 * j:.2f} 0.98 {2.7 - 0.1 * j:.2f} 1 {8 + 2 * j} 0.5")
    rest = [ln for ln in lines if not ln.startswith("POSE ")]
    return "\n".join(rest[:1] + poses[:frames] + rest[1:]) + "\n"


def _env(code: Path) -> dict:
    return dict(os.environ, PYTHONPATH=str(code), SESGEN_SHARED_DATA=os.environ.get(
        "SESGEN_SHARED_DATA", "/work/shared/data"))


def _run_kw(code: Path) -> dict:
    """A child's environment and folder: ``python -m``/``-c`` put the working folder first on
    sys.path, so a child started in this checkout imports its blender_sesgen whatever PYTHONPATH
    says; started in ``code`` it imports that one."""
    return {"env": _env(code), "cwd": str(code)}


def _render_cmd(script: Path, out: Path, *args) -> list[str]:
    return ["nice", "-n", "5", sys.executable, "-m", "blender_sesgen", "render", str(script), "--out", str(out),
            "--samples", "2", "--quiet", *args]


def _chunks(frames: int, n: int) -> list[str]:
    cuts = [round(i * frames / n) for i in range(n + 1)]
    return [f"{a}:{b}" for a, b in zip(cuts, cuts[1:]) if b > a]


def _burn(n: int) -> list[subprocess.Popen]:
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def _consolidate(out: Path, code: Path) -> str:
    r = subprocess.run([sys.executable, "-c", "import sys; from blender_sesgen.render.folder import OutputFolder; "
                        "OutputFolder(sys.argv[1]).consolidate()", str(out)], **_run_kw(code), capture_output=True,
                       text=True)
    return "" if r.returncode == 0 else (r.stderr.strip().splitlines() or ["?"])[-1]


def _logged(out: Path, pid: int) -> int:
    """Frames the render ``pid`` has logged complete in ``out`` (its completion log's lines)."""
    try:
        return sum(1 for log in (out / ".sesgen").glob(f"done-*-{pid}.jsonl") for _ in open(log))
    except OSError:
        return 0


def _sha(path: Path) -> str:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return "missing"


_READ = """import json, sys
from blender_sesgen.contract.manifest import Manifest
m = Manifest.read(sys.argv[1])
s = m.extra.get("sensor") or {}
print(json.dumps({"complete": m.frames_complete, "exposure_s": s.get("exposure_s"), "gain": s.get("gain")}))
"""


def _as_read(out: Path, ref: dict, code: Path) -> list[str]:
    """``reader`` problems: what a reader of the folder sees before anyone consolidated it
    (``Manifest.read``, as vo_reference reads it): a frame it sees complete with another
    exposure or gain than the one-run render's (null: not merged from the state files)."""
    r = subprocess.run([sys.executable, "-c", _READ, str(out)], **_run_kw(code), capture_output=True, text=True)
    if r.returncode != 0:
        return [f"reader: {(r.stderr.strip().splitlines() or ['?'])[-1]}"]
    seen = json.loads(r.stdout)
    return [f"reader: frame {k} {key} {seen[key][k]} (one run: {ref['sensor'][key][k]})"
            for k, done in enumerate(seen["complete"]) if done for key in ("exposure_s", "gain")
            if seen[key][k] != ref["sensor"][key][k]]


def judge(out: Path, ref: dict, killed: bool, code: Path) -> list[str]:
    """What the trial's folder promises and does not hold (see the module docstring)."""
    reader = _as_read(out, ref, code) if killed else []
    why = _consolidate(out, code)
    if why:
        return [f"consolidate: {why}"]
    m = json.loads((out / "manifest.json").read_text())
    bad = []
    sums, rsums = m.get("checksums") or {}, ref["checksums"]
    frame_files = {}
    for k in range(ref["frames"]):
        files = [ref["files"][v][k] for v in ref["views"]]
        files += [ref["display"]["files"][v][k] for v in ref["views"] if v in (ref.get("display") or {}).get("files", {})]
        files += [ref["sensor"]["files"][kind][v][k] for kind in ref["sensor"]["files"] for v in ref["views"]]
        frame_files[k] = files
    for k, done in enumerate(m["frames_complete"]):
        if not done:
            if not killed:
                bad.append(f"incomplete: frame {k}")
            continue
        for key in ("exposure_s", "gain"):
            if m["sensor"][key][k] != ref["sensor"][key][k]:
                bad.append(f"state: frame {k} {key} {m['sensor'][key][k]} (one run: {ref['sensor'][key][k]})")
        got = m["sensor"]["metered"][k]
        if got is not None and got != ref["sensor"]["metered"][k]:
            bad.append(f"state: frame {k} metered {got} (one run: {ref['sensor']['metered'][k]})")
        for rel in frame_files[k]:
            if sums.get(rel) != rsums.get(rel) or _sha(out / rel) != rsums.get(rel):
                bad.append(f"checksum: {rel}")
    frame_rel = {rel for files in frame_files.values() for rel in files}
    for rel, h in rsums.items():
        if rel not in frame_rel and (sums.get(rel) != h or _sha(out / rel) != h):
            bad.append(f"checksum: {rel} (static)")
    r = subprocess.run([sys.executable, "-m", "blender_sesgen", "verify", str(out), "--quick", "--quiet",
                        "--dry-run"], **_run_kw(code), capture_output=True, text=True)
    if r.returncode != 0:
        bad.append(f"verify: {(r.stdout.strip().splitlines() or r.stderr.strip().splitlines() or ['?'])[0]}")
    return reader + bad


def trial(i: int, args, script: Path, ref: dict, rng: random.Random) -> dict:
    out = args.out / f"trial{i:03d}"
    shutil.rmtree(out, ignore_errors=True)
    chunks = _chunks(ref["frames"], args.chunks)
    delays = [rng.uniform(0, args.delay) for _ in chunks]
    victim = rng.randrange(len(chunks)) if args.kill else None
    if victim is not None:   # killed once it has logged this many of its frames (before its end merges them)
        a, b = map(int, chunks[victim].split(":"))
        kill_lines = rng.randint(1, max(1, b - a - 1))   # not after its last: its end follows within ms
    procs, started, t0 = {}, {}, time.monotonic()
    pending = sorted(range(len(chunks)), key=lambda j: delays[j])
    killed_at = None
    while pending or any(p.poll() is None for p in procs.values()):
        while pending and delays[pending[0]] <= time.monotonic() - t0:
            j = pending.pop(0)
            procs[j] = subprocess.Popen(_render_cmd(script, out, "--frames", chunks[j], "--resume"),
                                        **_run_kw(args.code), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                        text=True)
            started[j] = time.monotonic()
        if victim in procs and killed_at is None and procs[victim].poll() is None \
                and _logged(out, procs[victim].pid) >= kill_lines:
            os.kill(procs[victim].pid, signal.SIGKILL)
            killed_at = round(time.monotonic() - started[victim], 2)
        time.sleep(0.005)
    rcs = {chunks[j]: p.returncode for j, p in sorted(procs.items())}
    left_logs = len(list((out / ".sesgen").glob("done-*.jsonl")))   # a killed chunk's log nobody took in yet
    bad = [f"chunk failed: {chunks[j]} exit {p.returncode}: {(p.stderr.read().strip().splitlines() or ['?'])[-1]}"
           for j, p in sorted(procs.items()) if p.returncode != 0 and not (j == victim and p.returncode == -9)]
    really_killed = victim is not None and procs[victim].returncode == -9
    bad += judge(out, ref, really_killed, args.code)
    return {"trial": i, "delays_s": [round(d, 2) for d in delays], "rc": rcs,
            "killed": chunks[victim] if really_killed else None, "killed_after_s": killed_at,
            "logs_left": left_logs, "problems": bad}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--chunks", type=int, default=2)
    ap.add_argument("--frames", type=int, default=8, help="the scene's frames (4 poses of the test, then more)")
    ap.add_argument("--kill", action="store_true", help="kill -9 one chunk of each trial after some of its frames")
    ap.add_argument("--burners", type=int, default=0, help="CPU-bound processes running during the trials")
    ap.add_argument("--delay", type=float, default=4.0, help="each chunk starts after a random 0..DELAY s")
    ap.add_argument("--code", type=Path, default=REPO, help="the blender_sesgen to test (PYTHONPATH)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    args.out = args.out.resolve()
    args.out.mkdir(parents=True, exist_ok=True)
    args.code = args.code.resolve()
    script = args.out / "s.ses"
    script.write_text(_scene(args.frames))
    ref_out = args.out / "one_run"
    shutil.rmtree(ref_out, ignore_errors=True)
    t0 = time.monotonic()
    subprocess.run(_render_cmd(script, ref_out), **_run_kw(args.code), check=True)
    ref_wall = time.monotonic() - t0
    ref = json.loads((ref_out / "manifest.json").read_text())
    rng = random.Random(args.seed)
    burners = _burn(args.burners)
    results = []
    try:
        for i in range(args.trials):
            res = trial(i, args, script, ref, rng)
            results.append(res)
            print(f"trial {i}: delays {res['delays_s']} rc {res['rc']}"
                  f"{' killed ' + res['killed'] + ' after ' + str(res['killed_after_s']) + ' s' if res['killed'] else ''}"
                  f"{', its log left for readers' if res['logs_left'] else ''}"
                  f": {'; '.join(res['problems']) or 'ok'}", flush=True)
    finally:
        for b in burners:
            b.kill()
            b.wait()
    kinds: dict[str, int] = {}
    for res in results:
        for kind in sorted({p.split(":")[0] for p in res["problems"]}):
            kinds[kind] = kinds.get(kind, 0) + 1
    failed = sum(bool(r["problems"]) for r in results)
    left = sum(bool(r["logs_left"]) for r in results)
    summary = {"code": str(args.code), "trials": len(results), "failed": failed, "by_kind": kinds,
               "chunks": args.chunks, "kill": args.kill, "burners": args.burners, "one_run_wall_s": round(ref_wall, 1),
               "load": os.getloadavg(), "results": results}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    summary["logs_left"] = left
    (args.out / "summary.json").write_text(json.dumps(summary, indent=1))
    print(f"folder_races: {failed} of {len(results)} trials with a problem {kinds or ''}; {left} left a killed "
          "chunk's log for readers (not taken in by the other chunk) "
          f"(code {args.code}, {args.chunks} chunks, kill {args.kill}, burners {args.burners}, "
          f"one run {ref_wall:.1f} s, load {os.getloadavg()[0]:.2f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
