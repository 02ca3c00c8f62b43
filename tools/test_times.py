"""Sum the per-file test times that ``SESGEN_TEST_TIMES=FILE make test`` wrote (tests/conftest.py).

    python tools/test_times.py FILE [--top 40] [--base OTHER]

Prints the files by CPU seconds (worker + waited-for children) with wall seconds and the worker,
each worker's busy span, and with ``--base`` the CPU seconds of an earlier run beside them;
``--order N`` prints the N costliest files as tests/conftest.py's SLOWEST_FIRST list.
``--workers W`` adds a model of the schedule: W workers each taking the next whole file when
free (xdist --dist loadfile), a file taking its CPU seconds; the finish time with xdist's default
order (most tests first) and with the longest files first. With ``--cores C`` as well, a model that
lets W exceed the cores: each file lasts its wall seconds of the run read and asks for its CPU
seconds over them (cpu_s / wall_s cores: a file that waits on Ray or sleeps asks for less than
one); while the running files ask for more than C cores, all slow down alike (processor sharing).
``--replace OTHER`` takes those files' records from OTHER (e.g. files measured again alone, their
cpu_s the whole tree's: bench/cpu_tree.py counts Ray's workers, which the run's figure does not).
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


def makespan(durations: list[float], workers: int) -> float:
    """When the last of ``durations`` ends, each taken in order by the first worker free."""
    free = [0.0] * workers
    for d in durations:
        i = free.index(min(free))
        free[i] += d
    return max(free)


def shared_makespan(files: list[tuple[float, float]], workers: int, cores: float) -> float:
    """When the last file ends: ``files`` [(cpu_s, wall_s)] taken in order by the first free of
    ``workers``; a running file asks for cpu_s / wall_s cores and progresses at 1 / wall_s per
    second, slowed alike while the running files ask for more than ``cores`` (a fluid model)."""
    queue = list(files)
    running: list[list[float]] = []            # [work left (fraction), cores asked, wall_s]
    t = 0.0
    while queue or running:
        while queue and len(running) < workers:
            cpu, wall = queue.pop(0)
            wall = max(wall, 1e-6)
            running.append([1.0, cpu / wall, wall])
        speed = min(1.0, cores / max(sum(r[1] for r in running), 1e-9))
        dt = min(r[0] * r[2] for r in running) / speed   # until the next file ends
        t += dt
        for r in running:
            r[0] -= dt * speed / r[2]
        running = [r for r in running if r[0] > 1e-9]
    return t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("times")
    ap.add_argument("--base", help="an earlier run's file, shown beside")
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--order", type=int, metavar="N", help="print the N costliest files as SLOWEST_FIRST")
    ap.add_argument("--workers", type=int, metavar="W", help="model the schedule on W workers")
    ap.add_argument("--cores", type=float, metavar="C", help="with --workers: W workers sharing C cores")
    ap.add_argument("--replace", metavar="OTHER", help="these files' records from OTHER (a times file)")
    args = ap.parse_args()
    files = load(args.times)
    if args.replace:
        for path, rec in load(args.replace).items():
            files[path] = {**files.get(path, {}), **{k: rec[k] for k in ("file", "tests", "cpu_s", "wall_s")}}
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
    if args.workers:
        by_name = [files[path] for path in sorted(files)]   # collection order, then sorted (stable)
        for label, key in (("most tests first (xdist's default)", lambda r: -r["tests"]),
                           ("longest first", lambda r: -r["cpu_s"])):
            print(f"model, {args.workers} workers, {label}: the last file ends at "
                  f"{makespan([r['cpu_s'] for r in sorted(by_name, key=key)], args.workers):.0f} s")
        if args.cores:
            longest = sorted(by_name, key=lambda r: -r["wall_s"])
            for w in sorted({2, args.workers}):
                print(f"model, {w} workers sharing {args.cores:g} cores, longest wall first: the last file ends at "
                      f"{shared_makespan([(r['cpu_s'], r['wall_s']) for r in longest], w, args.cores):.0f} s")
    total = sum(r["cpu_s"] for r in files.values())
    print(f"all files: {total:.0f} CPU s" + (f" (base {sum(r['cpu_s'] for r in base.values()):.0f})" if base else ""))


if __name__ == "__main__":
    main()
