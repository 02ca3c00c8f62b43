"""A user's system in a real study (docs/studies.md, "Systems"): a study folder whose path
has spaces and quotes reaches the system as whole words; the system's environment is the
study's own on a local Ray and with ``--no-ray`` alike (a Ray worker's adds RAY_JOB_ID,
OMP_NUM_THREADS=1, ...: a system's speed or threads must not depend on the path it ran on);
the render folders (the ground truth) are read-only to it; a run that writes no trajectory,
and one that exits non-zero after writing a whole one, are failures saying so."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

from render_support import run_loaded
from study_scenes import ROOM, study_file, world

pytestmark = [pytest.mark.render, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[1]

# writes what it was given (argv, its folder, its environment) into the folder DUMP_TO, a file
# per variant, then the ground truth as its trajectory (a run that succeeds)
DUMP = ("import json, os, shutil, sys; json.dump(dict(argv=sys.argv[1:], cwd=os.getcwd(), "
        "env=dict(os.environ)), open(os.path.join(os.environ['DUMP_TO'], sys.argv[2].split(os.sep)[-4]), 'w')); "
        "shutil.copy(os.path.join(sys.argv[1], 'poses.txt'), sys.argv[2])")

# writes into its variant's render folder (the ground truth), found from its dataset's path
VANDAL = ("import os, sys; top, rest = sys.argv[1].split(os.sep + 'exports' + os.sep); "
          "open(os.path.join(top, 'renders', rest.split(os.sep)[0], 'manifest.json'), 'a').write('x')")
# 2.4 MB of poses for 2 frames
HUGE = "import sys; open(sys.argv[1], 'w').write(('1 0 0 0 0 1 0 0 0 0 1 0' + chr(10)) * 100000)"
# writes a whole trajectory, then exits 3
REGRETS = ("import os, shutil, sys; shutil.copy(os.path.join(sys.argv[1], 'poses.txt'), sys.argv[2]); "
           "sys.exit(3)")


def run_study(study: Path, out: Path, *extra) -> "subprocess.CompletedProcess":
    env = {**os.environ, "PYTHONPATH": str(REPO), "RAY_USAGE_STATS_ENABLED": "0"}
    return run_loaded([sys.executable, "-m", "blender_sesgen", "study", "run", str(study), "--out", str(out),
                       "--progress", "plain", *extra], 1500, env=env)


def test_paths_with_spaces_and_quotes_and_the_same_environment_on_ray_and_without(tmp_path):
    folder = tmp_path / "my \"odd\" study's dir"
    folder.mkdir()
    dump = folder / "dumps"
    dump.mkdir()
    body = f"""
[study]
name = "paths"
{world(frames=2, quality="draft", samples=1, resolution=0.5)}[factors.gain]
levels = [2.0]

[[systems]]
name = "dump"
cmd = {json.dumps('{python} -c "' + DUMP + '" {sequence} {out} {workdir} {trial} {frames}')}
layout = "kitti-folder"
format = "kitti"
env = {{ DUMP_TO = {json.dumps(str(dump))}, MY_SETTING = "a b 'c'" }}

[[systems]]
name = "vandal"
cmd = {json.dumps('{python} -c "' + VANDAL + '" {dataset} {out}')}
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "silent"
cmd = "{{python}} -c pass {{out}}"
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "huge"
cmd = {json.dumps('{python} -c "' + HUGE + '" {out}')}
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "regrets"
cmd = {json.dumps('{python} -c "' + REGRETS + '" {sequence} {out}')}
layout = "kitti-folder"
format = "kitti"
"""
    study = study_file(folder, body, ROOM)
    out = folder / "out dir"
    p = run_study(study, out)
    assert p.returncode == 0, p.stdout + p.stderr
    doc = json.loads((out / "results.json").read_text())
    runs = {}
    for r in doc["runs"]:
        runs.setdefault(r["system"], []).append(r)
    assert [r["status"] for r in runs["dump"]] == ["ok", "ok"], [r.get("failure") for r in runs["dump"]]
    for r in runs["vandal"]:          # the ground truth is read-only to the systems, as their datasets
        assert r["status"] == "failed" and "exit code 1" in r["failure"] and \
            "Permission denied" in "\n".join(r["stderr_tail"]), r
    for v in doc["variants"]:         # ... and writable again after the runs
        render = out / v["render"]
        json.loads((render / "manifest.json").read_text())
        assert (render / "manifest.json").stat().st_mode & 0o777 == 0o644 and render.stat().st_mode & 0o777 == 0o755
    assert all(r["status"] == "failed" and r["failure"] == "wrote no trajectory file" for r in runs["silent"]), \
        runs["silent"]
    assert all(r["status"] == "failed" and r["failure"] == "exit code 3" for r in runs["regrets"]), runs["regrets"]
    assert all(r["status"] == "failed" and r["failure"].startswith("wrote a trajectory of 2400000 bytes for 2 frame(s)")
               for r in runs["huge"]), runs["huge"]
    on_ray = {p.name: json.loads(p.read_text()) for p in dump.iterdir()}
    assert len(on_ray) == 2
    for key, seen in on_ray.items():
        seq, est, work, trial, frames = seen["argv"]
        assert Path(seq).is_dir() and seq.startswith(str(out)) and (Path(seq) / "poses.txt").is_file()
        assert Path(est) == out / "runs" / key / Path(est).parent.parent.name / "t0" / "est.txt"
        assert work == seen["cwd"] == str(Path(est).parent / "work") and (trial, frames) == ("0", "2")
        assert seen["env"]["TMPDIR"] == str(Path(work) / "tmp") and seen["env"]["MY_SETTING"] == "a b 'c'"
        assert "SESGEN_FARM_PARENT_PID" not in seen["env"]

    p = run_study(study, out, "--no-ray", "--rerun", "dump")
    assert p.returncode == 0, p.stdout + p.stderr
    for key, seen in on_ray.items():
        local = json.loads((dump / key).read_text())
        assert local["argv"] == seen["argv"] and local["cwd"] == seen["cwd"]
        added = {k: seen["env"][k] for k in seen["env"].keys() - local["env"].keys()}
        changed = {k: (local["env"][k], seen["env"][k]) for k in local["env"].keys() & seen["env"].keys()
                   if local["env"][k] != seen["env"][k]}
        assert not added and not changed and seen["env"].keys() == local["env"].keys(), (added, changed)
