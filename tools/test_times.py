"""Sum the per-file test times that ``SESGEN_TEST_TIMES=FILE make test`` wrote (tests/conftest.py).

    python tools/test_times.py FILE [--top 40] [--base OTHER]

Prints the files by CPU seconds (worker + waited-for children) with wall seconds and the worker,
each worker's busy span, and with ``--base`` the CPU seconds of an earlier run beside them;
``--order N`` prints the N costliest files as tests/conftest.py's SLOWEST_FIRST list.
"""
from __future__ import annotations

import argparse
import json
from collections import defaultdict


def load(path: str) -> dict[str, dict]:
    files: dict[str, dict] = {}
    with open(path) as f:
        for line in f:
            rec = json.loads(line)
            old = files.get(rec["file"])
            if old:   # a file split over workers (--dist load): add its parts
                for key in ("cpu_s", "wall_s", "tests"):
                    rec[key] += old[key]
                rec["start"], rec["end"] = min(rec["start"], old["start"]), max(rec["end"], old["end"])
            files[rec["file"]] = rec
    return files


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("times")
    ap.add_argument("--base", help="an earlier run's file, shown beside")
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--order", type=int, metavar="N", help="print the N costliest files as SLOWEST_FIRST")
    args = ap.parse_args()
    files = load(args.times)
    if args.order:
        names = [path.rsplit("/", 1)[-1] for path, _ in sorted(files.items(), key=lambda kv: -kv[1]["cpu_s"])]
        print("SLOWEST_FIRST = [")
        for name in names[:args.order]:
            print(f'    "{name}",')
        print("]")
        return
    base = load(args.base) if args.base else {}
    t0 = min(r["start"] for r in files.values())
    print(f"{'file':46s} {'tests':>5s} {'cpu_s':>7s} {'wall_s':>7s} {'start':>6s} {'end':>6s} worker"
          + ("  base_cpu_s" if base else ""))
    for path, r in sorted(files.items(), key=lambda kv: -kv[1]["cpu_s"])[:args.top]:
        extra = f"  {base[path]['cpu_s']:9.1f}" if path in base else ""
        print(f"{path:46s} {r['tests']:5d} {r['cpu_s']:7.1f} {r['wall_s']:7.1f} {r['start'] - t0:6.0f} "
              f"{r['end'] - t0:6.0f} {r['worker']}{extra}")
    spans: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0.0])
    for r in files.values():
        s = spans[r["worker"]]
        s[0] += r["cpu_s"]
        s[1] += r["wall_s"]
        s[2] = max(s[2], r["end"] - t0)
    for worker, (cpu, wall, end) in sorted(spans.items()):
        print(f"worker {worker}: cpu {cpu:.0f} s, busy {wall:.0f} s, last test ended at {end:.0f} s")
    total = sum(r["cpu_s"] for r in files.values())
    print(f"all files: {total:.0f} CPU s" + (f" (base {sum(r['cpu_s'] for r in base.values()):.0f})" if base else ""))


if __name__ == "__main__":
    main()
