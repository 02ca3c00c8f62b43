"""A study's system misbehaving, each case a real child process (docs/studies.md, "Systems"):
a run past its timeout takes its whole process group along (a child that ignores SIGTERM, a
leader that does), a clean exit takes what it left running, megabytes of output neither
block nor get lost, the working folder and environment are the promised ones, paths with
spaces and quotes reach it whole, and a study killed mid-run redoes exactly that run."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from blender_sesgen.study import systems, work

PY = sys.executable
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(autouse=True)
def short_grace(monkeypatch):
    monkeypatch.setattr(systems, "KILL_GRACE_S", 1.0)


def gone(pid: int) -> bool:
    """Not running: no such process, or a zombie (dead; this machine's init may not reap it)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            return any(ln.split()[1:2] == ["Z"] for ln in f if ln.startswith("State:"))
    except FileNotFoundError:
        return True


def wait_for(path: Path, timeout_s: float = 60.0) -> str:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout_s:
        if path.is_file() and path.read_text().strip():
            return path.read_text()
        time.sleep(0.05)
    raise AssertionError(f"{path} never written")


# a child that ignores SIGTERM and appends to a file every 20 ms; its pid in FILE.pid
WRITER = ("import os, signal, sys, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
          "open(sys.argv[1] + '.pid', 'w').write(str(os.getpid())); f = open(sys.argv[1], 'a')\n"
          "while True:\n f.write('0 0 0 0 0 0 0 0 0 0 0 0\\n'); f.flush(); time.sleep(0.02)")


def spawn_writer_then(rest: str) -> str:
    return f"import subprocess, sys, time; subprocess.Popen([sys.executable, '-c', {WRITER!r}, sys.argv[1]]); {rest}"


def test_a_timeout_kills_the_whole_group_even_a_child_that_ignores_sigterm(tmp_path):
    """The leader obeys SIGTERM at once; its child ignores it. Until session 21 the SIGKILL
    went only to a leader still alive, so the child went on writing the trajectory."""
    est = tmp_path / "est.txt"
    r = systems.run([PY, "-c", spawn_writer_then("time.sleep(120)"), str(est)], tmp_path / "run", 2.0)
    assert r["timed_out"] and "timeout of 2 s" in r["error"] and r["wall_s"] < 2.0 + 1.0 + 5.0
    pid = int((tmp_path / "est.txt.pid").read_text())
    size = est.stat().st_size
    time.sleep(0.3)
    assert gone(pid) and est.stat().st_size == size


def test_a_system_that_ignores_sigterm_is_killed_after_the_grace(tmp_path):
    r = systems.run([PY, "-c", "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                     "time.sleep(120)"], tmp_path / "run", 1.0)
    assert r["timed_out"] and r["rc"] == -signal.SIGKILL and 2.0 <= r["wall_s"] < 8.0


def test_what_a_clean_exit_leaves_running_is_killed(tmp_path):
    est = tmp_path / "est.txt"
    r = systems.run([PY, "-c", spawn_writer_then("time.sleep(0.5)"), str(est)], tmp_path / "run", 30.0)
    assert r["rc"] == 0 and "error" not in r and not r["timed_out"]
    pid = int(wait_for(tmp_path / "est.txt.pid"))
    size = est.stat().st_size
    time.sleep(0.3)
    assert gone(pid) and est.stat().st_size == size


def test_megabytes_of_output_neither_block_nor_get_lost(tmp_path):
    """Output goes to files (no pipe to fill): whole, however long; the record holds the
    last lines, read from the file's end."""
    mb = 30
    code = ("import sys\nline = 'x' * 1023 + '\\n'\n"
            f"for _ in range({mb} * 1024):\n sys.stdout.write(line); sys.stderr.write(line)\n"
            "print('last words', file=sys.stderr); print('the end')")
    r = systems.run([PY, "-c", code], tmp_path / "run", 120.0)
    assert r["rc"] == 0 and r["wall_s"] < 60
    assert (tmp_path / "run" / "stderr.txt").stat().st_size == mb * 1024 * 1024 + len("last words\n")
    assert (tmp_path / "run" / "stdout.txt").stat().st_size == mb * 1024 * 1024 + len("the end\n")
    assert r["stderr_tail"][-1] == "last words" and r["stdout_tail"][-1] == "the end"
    assert len(r["stderr_tail"]) == systems.TAIL_LINES and r["stderr_tail"][0] == "x" * 1023


def test_the_working_folder_and_environment_are_the_promised_ones(tmp_path):
    """Its current folder and TMPDIR are its own fresh working folder; its environment the
    study's (``base_env``, not this process's), the system's ``env`` over it, without the
    launcher's variable."""
    code = ("import json, os, sys; json.dump({'cwd': os.getcwd(), 'env': dict(os.environ), "
            "'ls': sorted(os.listdir('.'))}, open(sys.argv[1], 'w'))")
    out = tmp_path / "seen.json"
    run_dir = tmp_path / "run"
    (run_dir / "work").mkdir(parents=True)
    (run_dir / "work" / "left-by-last-run.txt").write_text("stale")
    base = {"PATH": os.environ["PATH"], "ONLY_IN_STUDY": "1", "OVERRIDDEN": "study"}
    os.environ["ONLY_IN_THIS_PROCESS"] = "1"
    try:
        r = systems.run([PY, "-c", code, str(out)], run_dir, 30.0, {"OVERRIDDEN": "system", "X": "a b 'c'"}, base)
    finally:
        del os.environ["ONLY_IN_THIS_PROCESS"]
    assert r["rc"] == 0, r
    seen = json.loads(out.read_text())
    work_dir = run_dir / "work"
    assert seen["cwd"] == str(work_dir) and seen["ls"] == ["tmp"]
    env = seen["env"]
    assert env["TMPDIR"] == str(work_dir / "tmp") and env["ONLY_IN_STUDY"] == "1"
    assert env["OVERRIDDEN"] == "system" and env["X"] == "a b 'c'"
    assert "ONLY_IN_THIS_PROCESS" not in env and "SESGEN_FARM_PARENT_PID" not in env


def _export(tmp_path: Path) -> dict:
    data = tmp_path / "a \"quoted\" dataset's folder" / "data"
    (data / "seq 00").mkdir(parents=True)
    (data / "seq 00" / "poses.txt").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n")
    systems.set_read_only(data)
    return {"ok": True, "dataset": str(data), "sequence": str(data / "seq 00")}


def test_placeholders_with_spaces_and_quotes_reach_the_system_whole(tmp_path):
    """No shell: each placeholder fills (part of) one word, whatever its characters."""
    export = _export(tmp_path)
    rd = tmp_path / "runs" / "it's a \"run\"" / "t0"
    cmd = ["{python}", "-c", "import json, sys; json.dump(sys.argv[1:], open(sys.argv[2], 'w'))",
           "{sequence}", "{out}", "--poses={sequence}/poses.txt", "{workdir}", "{trial}", "{frames}"]
    rec = work.run_trial(export, cmd, [PY, "-m", "vo_reference"], str(rd), 0, 1, 30.0, {}, "est.txt")
    assert rec["rc"] == 0, rec
    assert json.loads((rd / "est.txt").read_text()) == [
        export["sequence"], str(rd / "est.txt"), f"--poses={export['sequence']}/poses.txt", str(rd / "work"), "0", "1"]
    systems.remove_tree(tmp_path / "a \"quoted\" dataset's folder")


STUDY_DRIVER = """
import json, sys
from blender_sesgen.study import work
export, runs = json.loads(sys.argv[1]), json.loads(sys.argv[2])
for rd, code in runs:
    work.run_trial(export, [sys.executable, "-c", code, "{out}"], [], rd, 0, 2, 60.0, {}, "est.txt")
"""


def test_a_study_killed_mid_run_redoes_that_run_and_keeps_the_finished_ones(tmp_path):
    """The process that runs the trials (a study, a Ray worker) SIGKILLed while a system runs:
    the system goes with it, its run has no record; run again, the finished run is taken as
    it is (not run again) and the killed one runs from the start."""
    export = _export(tmp_path)
    count = tmp_path / "count.txt"
    first = (f"import sys; open({str(count)!r}, 'a').write('x'); "
             "open(sys.argv[1], 'w').write('1 0 0 0 0 1 0 0 0 0 1 0\\n')")
    second = spawn_writer_then("time.sleep(120)")
    runs = [[str(tmp_path / "t0"), first], [str(tmp_path / "t1"), second]]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    driver = subprocess.Popen([PY, "-c", STUDY_DRIVER, json.dumps(export), json.dumps(runs)], env=env)
    try:
        pid = int(wait_for(tmp_path / "t1" / "est.txt.pid"))
        driver.send_signal(signal.SIGKILL)
        driver.wait(timeout=30)
    finally:
        driver.kill()
    t0 = time.monotonic()
    while not gone(pid) and time.monotonic() - t0 < 10:
        time.sleep(0.05)
    assert gone(pid)                                # the system's whole group went with the study
    assert (tmp_path / "t0" / "run.json").is_file() and not (tmp_path / "t1" / "run.json").is_file()
    assert count.read_text() == "x"
    runs[1][1] = "import sys; open(sys.argv[1], 'w').write('1 0 0 0 0 1 0 0 0 0 1 0\\n')"
    subprocess.run([PY, "-c", STUDY_DRIVER, json.dumps(export), json.dumps(runs)], env=env, check=True, timeout=120)
    assert count.read_text() == "x"                          # the finished run was not run again
    rec = json.loads((tmp_path / "t1" / "run.json").read_text())
    assert rec["rc"] == 0 and "error" not in rec
    assert (tmp_path / "t1" / "est.txt").read_text() == "1 0 0 0 0 1 0 0 0 0 1 0\n"
    systems.remove_tree(tmp_path / "a \"quoted\" dataset's folder")


def test_the_launcher_is_this_package_whatever_the_systems_path_finds(tmp_path):
    """A study's PYTHONPATH (or an installed copy) may hold another ``blender_sesgen``: the
    launcher is the study's own, and the system still sees PYTHONPATH as the study set it."""
    fake = tmp_path / "elsewhere"
    (fake / "blender_sesgen" / "study").mkdir(parents=True)
    for init in ("blender_sesgen/__init__.py", "blender_sesgen/study/__init__.py"):
        (fake / init).write_text("")
    (fake / "blender_sesgen" / "study" / "launch.py").write_text("raise SystemExit('another launcher')")
    out = tmp_path / "seen.txt"
    r = systems.run([PY, "-c", "import os, sys; open(sys.argv[1], 'w').write(os.environ['PYTHONPATH'])", str(out)],
                    tmp_path / "run", 30.0, {"PYTHONPATH": str(fake)})
    assert r["rc"] == 0, r
    assert out.read_text() == str(fake)


def test_render_folders_left_read_only_by_a_killed_study_are_writable_again(tmp_path):
    """The render folders are read-only while the systems run; a study killed then leaves them
    so, and the next ``study run`` (its render step resumes into them) makes them writable first."""
    from blender_sesgen.study.runner import StudyRun
    from blender_sesgen.study.spec import load
    from study_scenes import study_file
    study = load(study_file(tmp_path, '[world]\nscript = "scene.ses"\n[factors.gain]\nlevels = [2.0]\n'
                            '[[systems]]\nname = "s"\ncmd = "{python} -c pass {out}"\nlayout = "kitti-folder"\n'
                            'format = "kitti"\n'))
    out = tmp_path / "out"
    StudyRun(study, out, progress="off").prepare()
    render = out / "renders" / "r0123456789abcdef"
    (render / "exr").mkdir(parents=True)
    (render / "exr" / "f.exr").write_text("x")
    systems.set_read_only(render)
    StudyRun(study, out, progress="off").prepare()
    assert render.stat().st_mode & 0o777 == 0o755 and (render / "exr" / "f.exr").stat().st_mode & 0o777 == 0o644
    (render / "exr" / "g.exr").write_text("y")


def test_a_system_killed_by_a_signal_is_reported_so(tmp_path):
    """The launcher ends as its system did: the same signal, no core of its own."""
    r = systems.run([PY, "-c", "import os, signal; os.kill(os.getpid(), signal.SIGSEGV)"], tmp_path / "run", 30.0)
    assert r["rc"] == -signal.SIGSEGV and r["error"] == "killed by signal SIGSEGV" and not r["timed_out"]
    r = systems.run([PY, "-c", "import sys; sys.exit(200)"], tmp_path / "run", 30.0)
    assert r["rc"] == 200 and r["error"] == "exit code 200"
    r = systems.run(["/no/such/vo", "{out}"], tmp_path / "run", 30.0)
    assert r["rc"] == 127 and r["stderr_tail"] == ["error: cannot run /no/such/vo: No such file or directory"]


def test_a_huge_trajectory_is_a_failure_not_read(tmp_path):
    """Past 4 KiB a frame (+ 1 MiB) the trajectory is not handed to the evaluation; the record
    says how big it was."""
    export = _export(tmp_path)
    big = "import sys; open(sys.argv[1], 'w').write('1 0 0 0 0 1 0 0 0 0 1 0\\n' * 100000)"
    rec = work.run_trial(export, ["{python}", "-c", big, "{out}"], [], str(tmp_path / "t0"), 0, 10, 30.0, {}, "est.txt")
    size = len("1 0 0 0 0 1 0 0 0 0 1 0\n") * 100000
    assert rec["rc"] == 0 and rec["est_bytes"] == size
    assert rec["error"] == f"wrote a trajectory of {size} bytes for 10 frame(s) (more than {10 * 4096 + (1 << 20)}: not read)"
    rec = work.run_trial(export, ["{python}", "-c", big, "{out}"], [], str(tmp_path / "t1"), 0, 1000, 30.0, {}, "est.txt")
    assert rec["rc"] == 0 and "error" not in rec                 # 2.4 MB for 1000 frames: read
    systems.remove_tree(tmp_path / "a \"quoted\" dataset's folder")
