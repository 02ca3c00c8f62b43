"""What the disk cache of asset meshes (blender_sesgen/scene/assets/cache.py) saves a render
process's build: every distinct ASSET of a scene made three ways in one run, CPU seconds each.

    PYTHONPATH=. .venv/bin/python bench/bench_asset_cache.py [--scenes city_kitti forest hall office]

- ``off``: generated (``SESGEN_ASSET_CACHE=off``: the build's ``assets`` stage as
  bench/profile_scenes.py measures it);
- ``cold``: generated and written to an empty cache folder (the machine's first render);
- ``warm``: read back from it (every later render process: farm chunks, study variants,
  resumed renders), and whether every array read back is the generated one, bit for bit.

Beside them: the scene's ASSET ``objects``, its distinct ``assets`` (one Blender mesh each:
equal kind, size, seed, bend and offset share one), the triangles of those meshes (``Mtri``,
millions: what Blender and Cycles hold) and of every object (``shown``: what instancing saves).

Each scene runs in a fresh process (the pure package only: no bpy), ratios against ``off``
from the same process; the cache folder is a temporary one, removed at the end.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def child(scene: str, folder: str) -> None:
    from blender_sesgen.scene.assets import cache
    from blender_sesgen.scene.model import Asset
    from blender_sesgen.ses import parse_file
    keys, objects = {}, []
    for o in parse_file(scene).objects:
        if isinstance(o, Asset):
            objects.append((o.kind, tuple(o.size), o.seed, tuple(o.bend), o.offset))
            keys.setdefault(objects[-1], None)
    out = {"assets": len(keys), "objects": len(objects)}
    made = {}
    for mode in ("off", "cold", "warm"):
        os.environ[cache.ENV] = "off" if mode == "off" else folder
        c = cpu_s()
        for k in keys:
            made[mode, k] = cache.generate(*k)
        out[mode] = cpu_s() - c
    out["identical"] = all(made["off", k].faces.tobytes() == made["warm", k].faces.tobytes()
                           and made["off", k].vertices.tobytes() == made["warm", k].vertices.tobytes()
                           and made["off", k].face_surface.tobytes() == made["warm", k].face_surface.tobytes()
                           and made["off", k].smooth.tobytes() == made["warm", k].smooth.tobytes()
                           and made["off", k].surfaces == made["warm", k].surfaces for k in keys)
    faces = {k: len(made["off", k].faces) for k in keys}
    out["triangles"] = sum(faces.values())                    # what Blender holds (shared meshes once)
    out["instanced_triangles"] = sum(faces[k] for k in objects)   # what the scene shows
    out["mib"] = sum(f.stat().st_size for f in Path(folder).rglob("*.npz")) / 2 ** 20
    print("RESULT " + json.dumps(out), flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="+", default=["city_kitti", "forest", "hall", "office"])
    p.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.child:
        child(*a.child)
        return 0
    print(f"# asset cache: CPU s to make every distinct asset of the scene; {os.cpu_count()} CPUs, "
          f"load {os.getloadavg()[0]:.1f}", flush=True)
    print(f"{'scene':12s}{'objects':>8s}{'assets':>8s}{'Mtri':>7s}{'shown':>7s}{'off':>9s}{'cold':>9s}{'warm':>9s}"
          f"{'warm/off':>10s}{'MiB':>8s}  identical")
    for name in a.scenes:
        scene = name if name.endswith(".ses") else f"scenes/{name}.ses"
        with tempfile.TemporaryDirectory(prefix="sesgen-asset-cache-") as tmp:
            proc = subprocess.run([sys.executable, __file__, "--child", scene, tmp], cwd=REPO, capture_output=True,
                                  text=True, env=dict(os.environ, PYTHONPATH=str(REPO)))
        line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")), None)
        if proc.returncode or line is None:
            raise SystemExit(f"{scene}: failed\n{proc.stderr[-2000:]}")
        r = json.loads(line[len("RESULT "):])
        print(f"{Path(scene).stem:12s}{r['objects']:8d}{r['assets']:8d}{r['triangles'] / 1e6:7.2f}"
              f"{r['instanced_triangles'] / 1e6:7.2f}{r['off']:9.2f}{r['cold']:9.2f}{r['warm']:9.2f}"
              f"{r['warm'] / max(r['off'], 1e-9):10.3f}{r['mib']:8.0f}  {r['identical']}", flush=True)
    print(f"# load {os.getloadavg()[0]:.1f} at the end")
    return 0


if __name__ == "__main__":
    sys.exit(main())
