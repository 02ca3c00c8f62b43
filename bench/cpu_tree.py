"""CPU seconds (user + sys) of a whole process tree, sampled from /proc while it runs.

    python bench/cpu_tree.py PID [--every S] [--out FILE.json]

Every ``S`` seconds (default 0.5) it reads every process's utime + stime and parent, and keeps
the latest figure of each process (pid + start time) that descends from PID. When PID ends it
prints the total and per-command sums (children reaped through a dead parent are still counted,
unlike ``wait4``'s rusage; a process that lives less than ``S`` seconds may be missed: the
figure is a lower bound by at most that). Linux only.
"""
from __future__ import annotations

import argparse
import json
import os
import time

TICK = os.sysconf("SC_CLK_TCK")


def snapshot() -> dict:
    out = {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat", "rb") as f:
                raw = f.read().decode("utf-8", "replace")
            with open(f"/proc/{d}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode("utf-8", "replace")[:200]
        except OSError:
            continue
        name = raw[raw.index("(") + 1:raw.rindex(")")]
        rest = raw[raw.rindex(")") + 2:].split()
        ppid, utime, stime, start = int(rest[1]), int(rest[11]), int(rest[12]), int(rest[19])
        out[int(d)] = (ppid, (utime + stime) / TICK, start, cmd or f"({name})")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pid", type=int)
    ap.add_argument("--every", type=float, default=0.5)
    ap.add_argument("--out")
    a = ap.parse_args()
    tree = {a.pid}
    seen = {}                                   # (pid, start) -> (cpu s, cmd)
    t0 = time.monotonic()
    while True:
        snap = snapshot()
        if a.pid not in snap:
            break
        changed = True
        while changed:                          # parents first: children of new members join
            changed = False
            for pid, (ppid, _, _, _) in snap.items():
                if pid not in tree and ppid in tree:
                    tree.add(pid)
                    changed = True
        for pid in tree & snap.keys():
            _, cpu, start, cmd = snap[pid]
            old = seen.get((pid, start))
            # a process that has exited but is not yet reaped has no command line (only its short
            # name, "python"): it keeps the command it was seen with before
            seen[(pid, start)] = (cpu, old[1] if old and cmd.startswith("(") else cmd)
        time.sleep(a.every)
    by = {}
    for cpu, cmd in seen.values():
        words = cmd.split()
        kind = next((w for w in words if w.startswith("blender_sesgen") or w.startswith("vo_reference")
                     or w in ("stereo-vo", "render")), words[0] if words else "?")
        by[kind] = by.get(kind, 0.0) + cpu
    doc = {"cpu_s": round(sum(c for c, _ in seen.values()), 1), "processes": len(seen),
           "wall_s": round(time.monotonic() - t0, 1), "by_command": {k: round(v, 1) for k, v in sorted(by.items())}}
    print(json.dumps(doc, indent=1))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(doc, f, indent=1)


if __name__ == "__main__":
    main()
