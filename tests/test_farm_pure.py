"""The render farm without Ray or Blender: names, chunks, the render options passed on, a
task's subprocess (events, exit status, the lock of a killed render), the binding of a render
to its worker's life, and the scheduling loop's retries and failures on a stand-in for Ray."""
from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from types import SimpleNamespace

import pytest


from blender_sesgen.farm import chunk as chunk_mod
from blender_sesgen.commands import farm as farm_cli
from blender_sesgen.farm.driver import Farm
from blender_sesgen.farm.work import (FarmScene, Outcome, error_line, find_scripts, frame_ranges, outcome_of,
                                      unique_names)

REPO = Path(__file__).resolve().parents[1]


# --- names, chunks, exit codes --------------------------------------------------------------

def test_names_are_file_names_and_repeats_are_numbered_in_order():
    assert unique_names([Path("a/street.ses"), Path("b/street.ses"), Path("room.ses"), Path("c/street.ses")]) == \
        ["street", "street-2", "room", "street-3"]
    # a repeat must not take a name that a later script has as its own
    assert unique_names([Path("x.ses"), Path("y/x.ses"), Path("x-2.ses")]) == ["x", "x-2", "x-2-2"]


def test_frame_ranges_cut_runs_at_multiples_of_the_chunk():
    assert frame_ranges(range(10), 4) == [(0, 4), (4, 8), (8, 10)]
    assert frame_ranges([0, 1, 2, 3, 4, 5, 6], 2) == [(0, 2), (2, 4), (4, 6), (6, 7)]
    # a resumed scene: the same chunks minus what is done
    assert frame_ranges([1, 2, 3, 6, 9], 4) == [(1, 4), (6, 7), (9, 10)]
    assert frame_ranges([], 3) == []
    for frames, size in (([0, 2, 3, 4, 8, 9, 15], 3), (range(0, 40, 3), 5), (range(7), 1)):
        covered = [k for a, b in frame_ranges(frames, size) for k in range(a, b)]
        assert covered == sorted(frames)
        assert all(b - a <= size and (b - 1) // size == a // size for a, b in frame_ranges(frames, size))


def test_exit_codes_decide_retries():
    assert outcome_of(0) is Outcome.OK
    assert outcome_of(2) is Outcome.USER_ERROR
    assert outcome_of(130) is Outcome.INTERRUPTED
    for rc in (1, -9, -11, 137, None):
        assert outcome_of(rc) is Outcome.LOST


def test_the_error_line_is_the_last_error():
    assert error_line(["sesgen render: ...", "/x/bad.ses:3:1: error: unknown statement 'FOO'", ""]) == \
        "/x/bad.ses:3:1: error: unknown statement 'FOO'"
    assert error_line(["Traceback (most recent call last):", '  File "x"', "MemoryError"]) == "MemoryError"
    assert error_line([]) is None
    assert error_line(["sesgen render: s.ses -> out: 5 of 5 frames to render"]) is None   # killed: said nothing


def test_scripts_come_from_files_and_folders_once(tmp_path):
    (tmp_path / "d").mkdir()
    for n in ("b.ses", "a.ses", "notes.txt"):
        (tmp_path / "d" / n).write_text("x")
    found = find_scripts([str(tmp_path / "d"), str(tmp_path / "d" / "a.ses")])
    assert [p.name for p, _ in found] == ["a.ses", "b.ses"]
    # a folder written by generate: its index's order, and each script's split and seed
    (tmp_path / "d" / "dataset.json").write_text(json.dumps({
        "format": "sesgen-dataset/1", "kind": "scripts", "generator": {"name": "g"},
        "sequences": [{"script": "b.ses", "split": "val", "seed": 5},
                      {"script": "a.ses", "split": "train", "seed": 6}]}))
    found = find_scripts([str(tmp_path / "d")])
    assert [(p.name, m.get("split"), m.get("seed")) for p, m in found] == [("b.ses", "val", 5), ("a.ses", "train", 6)]
    assert found[0][1]["generator"] == {"name": "g"}


# --- the render options a farm passes on -------------------------------------------------------

def _farm_args(*argv):
    p = argparse.ArgumentParser()
    farm_cli.add_arguments(p)
    return p.parse_args(["s.ses", "--out", "R", *argv])


def test_every_render_option_is_a_farm_option_and_reaches_the_render_unchanged():
    from blender_sesgen.commands import render as render_cli
    rp = argparse.ArgumentParser()
    render_cli.add_arguments(rp)
    passed_on = {a.dest for a in farm_cli.render_actions()}
    own = {a.dest for a in rp._actions if a.option_strings} - farm_cli.CONTROLLED
    assert passed_on == own and {"samples", "denoise", "seed", "resolution_scale", "device"} <= passed_on
    argv = ["--samples", "3", "--no-denoise", "--seed", "9", "--resolution-scale", "0.25", "--normal-pass",
            "--device", "gpu", "--rate", "20", "--motion-blur", "--no-still"]
    args = _farm_args(*argv)
    fwd = farm_cli.forwarded_argv(args)
    direct = rp.parse_args(["s.ses", "--out", "o", *argv])
    via_farm = rp.parse_args(["s.ses", "--out", "o", *fwd])
    assert vars(direct) == vars(via_farm)
    assert farm_cli.forwarded_argv(_farm_args()) == []         # defaults are the render's own
    assert farm_cli.forwarded_argv(_farm_args("--denoise")) == ["--denoise"]
    opts = farm_cli.render_options(args)
    assert opts == render_cli.render_options(direct)      # what every chunk's render makes of them
    assert (opts.samples, opts.denoise, opts.seed, opts.resolution_scale, opts.normal_pass, opts.rate_hz,
            opts.motion_blur, opts.still) == (3, False, 9, 0.25, True, 20.0, True, False)


def test_scenes_are_prepared_before_ray_with_each_user_error_on_its_scene(tmp_path):
    good = tmp_path / "good.ses"
    good.write_text((REPO / "scenes" / "minimal.ses").read_text())
    bad = tmp_path / "bad.ses"
    bad.write_text("CAMERA resolution 64 48 focal 40\nSTART position 0 1 3\nFOG start 10\n"
                   "CUBOID id 1 position 0 0 0 dim 1 1 1\n")
    taken = tmp_path / "sub" / "good.ses"        # same name: ROOT/good-2, which holds another scene
    taken.parent.mkdir()
    taken.write_text(good.read_text() + "// changed\n")
    (tmp_path / "R" / "good-2").mkdir(parents=True)
    (tmp_path / "R" / "good-2" / "manifest.json").write_text(json.dumps(
        {"format": "sesgen-render/1", "scene_sha256": "0" * 64, "scene_source": "other.ses"}))
    p = argparse.ArgumentParser()
    farm_cli.add_arguments(p)
    args = p.parse_args([str(good), str(bad), str(taken), "--out", str(tmp_path / "R"), "--samples", "2"])
    root, scenes = farm_cli.prepare(args)
    assert root == tmp_path / "R" and [s.name for s in scenes] == ["good", "bad", "good-2"]
    ok, b, t = scenes
    assert ok.error is None and ok.pending == [0, 1, 2] and ok.plan.settings.samples == 2
    assert b.error == f"{bad}:3:1: error: FOG needs the tag 'end' (end e)"
    assert "holds the output of a different scene" in t.error and f"farm: remove {root / 'good-2'}" in t.error


def test_cpus_per_task_share_the_machine():
    from blender_sesgen.farm.work import auto_cpus_per_task
    assert auto_cpus_per_task(2, 10) == 1          # more chunks than CPUs: one CPU each
    assert auto_cpus_per_task(16, 3) == 5          # few chunks: no CPU left idle (3 x 5 of 16)
    assert auto_cpus_per_task(8, 1) == 8
    assert auto_cpus_per_task(0, 4) == 1


# --- one task's subprocess ---------------------------------------------------------------------

def _fake_render(tmp_path, body: str) -> list[str]:
    script = tmp_path / "fake_render.py"
    script.write_text(textwrap.dedent(body))
    return [sys.executable, str(script)]


def test_a_task_relays_the_render_events_and_keeps_its_error_lines(tmp_path):
    argv = _fake_render(tmp_path, """
        import json, sys
        print("sesgen render: header on stdout", flush=True)
        for k in (4, 5):
            print(json.dumps({"event": "progress", "task": "render", "frame": k}), file=sys.stderr, flush=True)
        print("/x/s.ses:2:1: error: something", file=sys.stderr, flush=True)
        sys.exit(2)
    """)
    got = []
    res = chunk_mod.run_chunk(argv, "s[4:6]#1", str(tmp_path / "out"), got.append)
    assert res["rc"] == 2 and res["frames_done"] == 2 and res["pid"] > 0
    assert error_line(res["tail"]) == "/x/s.ses:2:1: error: something"
    assert got[0]["kind"] == "started" and got[0]["pid"] == res["pid"]
    assert [m["event"]["frame"] for m in got[1:]] == [4, 5]


def test_a_cancel_that_came_before_the_interrupt_could_be_raised_stops_the_render(tmp_path):
    """A Ray cancel arriving while the worker still ignored SIGINT raises nothing (it was lost,
    and the render ran to its end with exit 0: test_farm_ray's cancel test, now and then);
    Ray's flag still says so, and run_chunk asks it while the render runs: the render gets
    SIGINT and stops like a Ctrl-C'd one, well before its end. A flag already up before the
    render started: the task ends cancelled (KeyboardInterrupt) and starts nothing."""
    argv = _fake_render(tmp_path, """
        import sys, time
        from blender_sesgen.farm.child import restore_interrupts
        try:
            restore_interrupts()          # what the farm's render child does first
            time.sleep(60)
        except KeyboardInterrupt:
            sys.exit(130)
    """)
    t0, got = time.monotonic(), []
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})   # as in a Ray worker: the child inherits it
    try:
        asked = []                # up from its second question: the render has started
        res = chunk_mod.run_chunk(argv, "s[0:2]#1", str(tmp_path / "out"), cancelled=lambda: bool(asked.append(1)) or
                                  len(asked) > 1)
        with pytest.raises(KeyboardInterrupt):
            chunk_mod.run_chunk(argv, "s[0:2]#2", str(tmp_path / "out"), got.append, cancelled=lambda: True)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
    assert res["cancelled"] and res["rc"] == 130 and time.monotonic() - t0 < 30, res
    assert res["stopped_by"] == "cancel flag" and got == []     # the second: no render, nothing reported
    assert not chunk_mod._cancel_requested()     # outside a Ray task: never, and no Ray started
    assert "ray" not in sys.modules or not sys.modules["ray"].is_initialized()


def test_a_cancel_reaches_a_render_that_prints_nothing_at_once(tmp_path):
    """Ray cancels a running task with ``_thread.interrupt_main()``: no signal is sent, so a
    task blocked reading its render's output (a render loading Blender, building a scene: no
    line for seconds, minutes for a city) took the KeyboardInterrupt only at the render's next
    line or its end -- here never within the render's 60 s. The task now watches its render
    every POLL_S: the render gets SIGINT at once and stops (exit 130)."""
    import _thread
    import threading
    argv = _fake_render(tmp_path, """
        import sys, time
        try:
            time.sleep(60)                # silent
        except KeyboardInterrupt:
            sys.exit(130)
    """)
    timer = threading.Timer(1.0, _thread.interrupt_main)    # what Ray's cancel does in the worker
    t0 = time.monotonic()
    timer.start()
    try:
        res = chunk_mod.run_chunk(argv, "s[0:2]#1", str(tmp_path / "out"))
    finally:
        timer.cancel()
    assert res["rc"] == 130 and res["cancelled"] and res["stopped_by"] == "interrupt", res
    assert time.monotonic() - t0 < 1.0 + 10, res


def test_a_cancel_repeated_while_the_render_stops_does_not_kill_it(tmp_path):
    """Ray repeats a cancel every 2 s (``cancellation_retry_ms``) until the task ends: a render
    slow to stop (loading Blender under load) took the second interrupt and was killed (exit
    -9: test_farm_ray's start-cancel test under load 12). Interrupts after the first SIGINT
    wait for the render's own end, within the grace."""
    import threading
    argv = _fake_render(tmp_path, """
        import signal, sys, time
        def stop(*_):
            time.sleep(1.5)              # a render finishing its view before it exits
            sys.exit(130)
        signal.signal(signal.SIGINT, stop)
        print("ready", flush=True)
        time.sleep(60)
    """)
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    timers = [threading.Timer(t, os.kill, (os.getpid(), signal.SIGINT)) for t in (0.4, 0.8)]
    try:
        for t in timers:
            t.start()
        rc = chunk_mod._stop(proc)
    finally:
        for t in timers:      # one not fired yet (the render already ended) fires nothing
            t.cancel()
            t.join()
        signal.signal(signal.SIGINT, old)
        if proc.poll() is None:
            proc.kill()
    assert rc == 130


def test_a_killed_render_leaves_no_lock_behind(tmp_path):
    from blender_sesgen.render.locks import _safe
    out = tmp_path / "out"
    argv = _fake_render(tmp_path, f"""
        import json, os, signal, socket
        state = {str(out / ".sesgen")!r}
        os.makedirs(state, exist_ok=True)
        name = f"lock-{_safe(socket.gethostname())}-{{os.getpid()}}.json"
        open(os.path.join(state, name), "w").write(json.dumps({{"host": socket.gethostname(), "pid": os.getpid()}}))
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    res = chunk_mod.run_chunk(argv, "s[0:2]#1", str(out))
    assert res["rc"] == -signal.SIGKILL
    assert not list((out / ".sesgen").glob("lock-*.json"))


def test_a_node_that_cannot_see_the_files_answers_with_a_user_error(tmp_path):
    res = chunk_mod.task(["false"], "s[0:2]#1", str(tmp_path / "nowhere" / "s"), None, str(tmp_path / "s.ses"))
    assert res["rc"] == 2 and "cannot see" in error_line(res["tail"]) and res["pid"] == 0


def test_the_render_dies_with_the_worker_that_started_it(tmp_path):
    """child.bind_to_parent: kill the parent (the Ray worker's stand-in) and the child goes."""
    parent_code = textwrap.dedent("""
        import subprocess, sys, time
        child = subprocess.Popen([sys.executable, "-c",
            "import os, time; "
            "from blender_sesgen.farm.child import bind_to_parent; bind_to_parent(os.getppid()); "
            "print('bound', flush=True); time.sleep(120)"], stdout=subprocess.PIPE, text=True)
        child.stdout.readline()
        print(child.pid, flush=True)
        time.sleep(120)
    """)
    parent = subprocess.Popen([sys.executable, "-c", parent_code], stdout=subprocess.PIPE, text=True,
                              env=dict(os.environ, PYTHONPATH=str(REPO)))
    child_pid = int(parent.stdout.readline())
    try:
        assert _alive(child_pid)
        parent.kill()
        parent.wait()
        t0 = time.time()
        while _alive(child_pid) and time.time() - t0 < 10:
            time.sleep(0.05)
        assert not _alive(child_pid), "the render outlived its worker"
    finally:
        if _alive(child_pid):
            os.kill(child_pid, signal.SIGKILL)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


# --- the scheduling loop, on a stand-in for Ray ------------------------------------------------

class _Ref:
    def __init__(self, run):
        self.run, self.done, self.value, self.error, self.cancelled = run, False, None, None, False


class FakeRay:
    """Ray's calls the farm makes, executed in order in this process; ``plan(scene, frames, n)``
    decides what the n-th try of a chunk returns (a dict, or an exception to raise)."""

    def __init__(self, chunk_plan, verify_plan):
        self.chunk_plan, self.verify_plan = chunk_plan, verify_plan
        self.tries: dict = {}
        self.submitted = []

    def remote(self, fn_or_cls=None, **opts):
        if fn_or_cls is None:   # @ray.remote(num_cpus=...)
            return lambda f: self.remote(f)
        ray = self
        if isinstance(fn_or_cls, type):
            class Handle:
                def __init__(self):
                    self.obj = fn_or_cls()

                def __getattr__(self, name):
                    method = getattr(self.obj, name)
                    return SimpleNamespace(remote=lambda *a: _done(method(*a)))
            return SimpleNamespace(remote=lambda: Handle())

        class Fn:
            def options(self, **_):
                return self

            def remote(self, *args):
                if fn_or_cls is chunk_mod.task:
                    argv, key, out, inbox, _scene = args
                    frames = argv[argv.index("--frames") + 1]
                    scene = Path(out).name
                    n = ray.tries[scene, frames] = ray.tries.get((scene, frames), 0) + 1
                    ray.submitted.append((scene, frames))

                    def run():
                        inbox.put.remote({"kind": "started", "key": key, "host": "h", "pid": 1})
                        r = ray.chunk_plan(scene, frames, n)
                        if isinstance(r, BaseException):
                            raise r
                        a, b = map(int, frames.split(":"))
                        if r.get("rc") == 0:
                            for k in range(a, b):
                                inbox.put.remote({"kind": "event", "key": key,
                                                  "event": {"event": "progress", "frame": k}})
                        return {"tail": [], **r}
                    return _Ref(run)
                return _Ref(lambda: ray.verify_plan(args[0]))
        return Fn()

    def wait(self, refs, num_returns=1, timeout=None):
        for r in refs:
            if not r.done and not r.cancelled:
                try:
                    r.value = r.run()
                except BaseException as e:  # noqa: BLE001
                    r.error = e
                r.done = True
                break
        ready = [r for r in refs if r.done or r.cancelled]
        return ready, [r for r in refs if r not in ready]

    def get(self, ref, timeout=None):
        if ref.cancelled and not ref.done:
            raise RuntimeError("TaskCancelledError")
        if ref.error is not None:
            raise ref.error
        return ref.value

    def cancel(self, ref, force=False):
        ref.cancelled = True


def _done(value):
    r = _Ref(None)
    r.done, r.value = True, value
    return r


def _scenes(tmp_path, *specs):
    out = []
    for name, n in specs:
        out.append(FarmScene(name=name, script=tmp_path / f"{name}.ses", out=tmp_path / "root" / name,
                             plan=SimpleNamespace(frames=tuple(range(n))), pending=list(range(n))))
    return out


def _farm(ray, scenes, retries=2, chunk=2):
    cluster = SimpleNamespace(ray=ray, totals=lambda: (2.0, 0.0), here=lambda: None)
    return Farm(cluster, scenes, chunk=chunk, retries=retries, cpus_per_task=1, gpus_per_task=0, threads=1,
                forwarded=["--samples", "2"], progress_mode="off")


def test_lost_chunks_are_retried_until_they_succeed(tmp_path):
    def plan(scene, frames, n):
        if frames == "2:4" and n == 1:
            return {"rc": -9}                                       # render SIGKILLed
        if frames == "2:4" and n == 2:
            return RuntimeError("WorkerCrashedError: the worker died")  # the worker itself
        return {"rc": 0}
    ray = FakeRay(plan, lambda out: {"missing": [], "bad": []})
    res = _farm(ray, _scenes(tmp_path, ("a", 5))).run()
    assert [s.complete for s in res.states] == [True]
    assert ray.tries == {("a", "0:2"): 1, ("a", "2:4"): 3, ("a", "4:5"): 1} and res.retried == 2
    assert res.frames_rendered == 5


def test_a_render_killed_by_a_signal_is_reported_by_its_signal(tmp_path, capsys):
    """The farm names a killed render's signal as why it was lost, not a traceback among its
    last lines (seen under load: "killed by SIGKILL: BrokenPipeError ...")."""
    def plan(scene, frames, n):
        if frames == "0:2" and n == 1:
            return {"rc": -9, "tail": ["Traceback (most recent call last):", "BrokenPipeError: [Errno 32] Broken pipe"]}
        return {"rc": 0}
    ray = FakeRay(plan, lambda out: {"missing": [], "bad": []})
    cluster = SimpleNamespace(ray=ray, totals=lambda: (2.0, 0.0), here=lambda: None)
    res = Farm(cluster, _scenes(tmp_path, ("a", 3)), chunk=2, retries=2, cpus_per_task=1, gpus_per_task=0, threads=1,
               forwarded=["--samples", "2"], progress_mode="plain").run()
    assert [s.complete for s in res.states] == [True] and res.retried == 1
    assert "a[0:2] lost (killed by SIGKILL); retry 1 of 2" in capsys.readouterr().err


@pytest.mark.parametrize("meters", [True, False])
def test_a_scene_to_meter_starts_with_one_chunk_and_the_others_read_its_metering(tmp_path, meters):
    """AUTOEXPOSURE's metering pass runs in whichever render finds none in the folder, over
    the frames before its last: the farm holds a metering scene's other chunks until the last
    chunk (whose pass covers them all) has written a frame (the metering is then in the
    manifest), so that the pass runs once, not once per chunk."""
    seen_when_run = {}

    def plan(scene, frames, n):
        seen_when_run[frames] = len(ray.submitted)
        return {"rc": 0}
    ray = FakeRay(plan, lambda out: {"missing": [], "bad": []})
    scenes = _scenes(tmp_path, ("a", 5))
    scenes[0].meters = meters
    res = _farm(ray, scenes).run()
    assert [s.complete for s in res.states] == [True] and res.frames_rendered == 5
    assert sorted(ray.submitted) == [("a", "0:2"), ("a", "2:4"), ("a", "4:5")]
    # metering: the last chunk ran while it was the only one submitted; otherwise all at once
    assert seen_when_run["4:5"] == (1 if meters else 3)


def test_a_scene_prepared_for_a_farm_meters_only_with_autoexposure_and_none_stored(tmp_path):
    from blender_sesgen.farm.work import prepare_scene
    from blender_sesgen.render.plan import RenderOptions
    base = "CAMERA resolution 16 12 focal 10 baseline 0.1\nCUBOID id 1 position 0 0 -3 dim 1 1 1\nFRAMES 3\n"
    for name, extra, expected in (("plain", "", False), ("auto", "SENSOR profile kitti\nAUTOEXPOSURE\n", True)):
        (tmp_path / f"{name}.ses").write_text(base + extra)
        sc = prepare_scene(FarmScene(name=name, script=tmp_path / f"{name}.ses", out=tmp_path / "root" / name),
                           RenderOptions())
        assert sc.error is None and sc.pending == [0, 1, 2] and sc.meters is expected, (name, sc.error)


def test_a_folder_metered_by_a_whole_render_needs_no_metering_pass(tmp_path):
    """A whole render meters every frame but the last (no exposure follows it), so a folder
    whose ``sensor.metered`` lacks only the last value holds the whole metering (a farm does not
    hold its chunks for a pass; a resumed chunk meters nothing); a gap before it does not."""
    from blender_sesgen.render.plan import RenderOptions, RenderPlan
    from blender_sesgen.render.sensor.outputs import stored_metering
    script = tmp_path / "auto.ses"
    script.write_text("CAMERA resolution 16 12 focal 10 baseline 0.1\nCUBOID id 1 position 0 0 -3 dim 1 1 1\n"
                      "FRAMES 3\nSENSOR profile kitti\nAUTOEXPOSURE\n")
    sensor = RenderPlan.from_file(script, RenderOptions()).sensor
    assert stored_metering(sensor, {"frames": 3, "sensor": {"metered": [0.2, 0.3, None]}}) == [0.2, 0.3, None]
    assert stored_metering(sensor, {"frames": 3, "sensor": {"metered": [0.2, None, None]}}) is None
    assert stored_metering(sensor, {"frames": 3, "sensor": {"metered": [0.2, None, None]}}, upto=1) == [0.2, None, None]


def test_a_chunk_lost_too_often_fails_its_scene_only(tmp_path, capsys):
    def plan(scene, frames, n):
        return {"rc": 1, "tail": ["error: render failed: disk on fire"]} if (scene, frames) == ("b", "0:2") \
            else {"rc": 0}
    ray = FakeRay(plan, lambda out: {"missing": [], "bad": []})
    res = _farm(ray, _scenes(tmp_path, ("a", 2), ("b", 4)), retries=2).run()
    a, b = res.states
    assert a.complete and not b.complete and not b.user_error
    assert "after 2 retries" in b.failed and "disk on fire" in b.failed and ray.tries["b", "0:2"] == 3
    assert farm_cli.report(tmp_path, res, quiet=True) == 1
    assert "b: FAILED" in capsys.readouterr().err


def test_a_user_error_is_not_retried_and_the_other_scenes_finish(tmp_path, capsys):
    ray = FakeRay(lambda scene, frames, n: {"rc": 0}, lambda out: {"missing": [], "bad": []})
    scenes = _scenes(tmp_path, ("good", 4), ("bad", 4))
    scenes[1].error = "/x/bad.ses:3:1: error: unknown statement 'FOO'"
    res = _farm(ray, scenes).run()
    good, bad = res.states
    assert good.complete and not bad.complete and bad.user_error
    assert ray.submitted == [("good", "0:2"), ("good", "2:4")]
    assert farm_cli.report(tmp_path, res, quiet=False) == 2
    err = capsys.readouterr().err
    assert "bad: FAILED: /x/bad.ses:3:1: error: unknown statement 'FOO'" in err


def test_a_render_exit_2_fails_the_scene_without_retry(tmp_path):
    ray = FakeRay(lambda scene, frames, n: {"rc": 2, "tail": ["error: --out x: being rendered by pid 7 on h"]},
                  lambda out: {"missing": [], "bad": []})
    res = _farm(ray, _scenes(tmp_path, ("a", 6)), chunk=2).run()
    (a,) = res.states
    assert a.user_error and "being rendered by pid 7" in a.failed
    assert set(ray.tries.values()) == {1} and res.retried == 0      # nothing retried


def test_frames_the_verification_finds_missing_are_rendered_again(tmp_path):
    checks = []

    def verify(out):
        checks.append(out)
        return {"missing": [3] if len(checks) == 1 else [], "bad": [[3, "exr/left/000003.exr: SHA-256 differs"]]
                if len(checks) == 1 else []}
    ray = FakeRay(lambda scene, frames, n: {"rc": 0}, verify)
    farm = _farm(ray, _scenes(tmp_path, ("a", 5)), chunk=2)
    res = farm.run()
    assert res.states[0].complete and len(checks) == 2
    assert ray.submitted == [("a", "0:2"), ("a", "2:4"), ("a", "4:5"), ("a", "3:4")]
    assert farm.bar.done == farm.bar.total == 5


def test_the_shared_filesystem_check_names_the_node_that_cannot_see_root(tmp_path):
    pytest.importorskip("ray")
    from blender_sesgen.errors import SesgenError
    from blender_sesgen.farm import cluster as cluster_mod

    class ProbeRay:
        """Two nodes; the second one mounts nothing of ours (it probes other paths)."""
        def nodes(self):
            return [{"NodeID": "a" * 56, "Alive": True, "NodeManagerAddress": "10.0.0.1"},
                    {"NodeID": "b" * 56, "Alive": True, "NodeManagerAddress": "10.0.0.2"}]

        def remote(self, fn):
            def call(strategy, probe, token, paths):
                if strategy.node_id.startswith("b"):
                    probe, paths = probe + ".elsewhere", [p + ".elsewhere" for p in paths]
                return fn(probe, token, paths)
            return SimpleNamespace(options=lambda scheduling_strategy, **_: SimpleNamespace(
                remote=lambda *a: call(scheduling_strategy, *a)))

        def get(self, value, timeout=None):
            return value

    script = tmp_path / "s.ses"
    script.write_text("x")
    c = cluster_mod.Cluster.__new__(cluster_mod.Cluster)
    c.ray = ProbeRay()
    root = tmp_path / "R"
    with pytest.raises(SesgenError) as e:
        c.check_shared(root, [script])
    msg = str(e.value)
    assert "node 10.0.0.2" in msg and f"cannot see {root}" in msg and "cannot see 1 script(s)" in msg
    assert "10.0.0.1" not in msg and list(root.iterdir()) == []      # the probe file is gone


@pytest.mark.parametrize("name", ["...ses", "..ses", "dataset.json.ses", ".sesgen.ses"])
def test_a_script_whose_name_is_no_folder_of_root_is_a_user_error_of_its_scene(tmp_path, name):
    """``...ses`` would render into ROOT/.. (outside ROOT), ``..ses`` into ROOT itself,
    ``dataset.json.ses`` onto the farm's index (a traceback), a hidden name among the
    folders' own state: each is refused on its scene, the others still render."""
    good = tmp_path / "good.ses"
    good.write_text((REPO / "scenes" / "minimal.ses").read_text())
    odd = tmp_path / "odd" / name
    odd.parent.mkdir()
    odd.write_text(good.read_text())
    p = argparse.ArgumentParser()
    farm_cli.add_arguments(p)
    root, scenes = farm_cli.prepare(p.parse_args([str(good), str(odd), "--out", str(tmp_path / "R")]))
    ok, bad = scenes
    assert ok.error is None
    assert bad.error is not None and str(odd) in bad.error and "rename the script" in bad.error, bad.error
    assert "\n" not in bad.error


def test_a_refused_scene_keeps_its_entry_in_the_dataset_index(tmp_path):
    """A farm whose scene is refused (its folder holds frames of other settings) must not
    rewrite that sequence's entry -- complete, with its seed -- as incomplete with the new
    seed; a scene refused with no entry yet gets one with its error."""
    from blender_sesgen.files.dataset import read_index, write_render_index
    from blender_sesgen.farm.driver import SceneState
    from blender_sesgen.render.plan import RenderOptions, RenderPlan
    script = tmp_path / "a.ses"
    script.write_text((REPO / "scenes" / "minimal.ses").read_text())
    root = tmp_path / "R"
    first = FarmScene(name="a", script=script, out=root / "a", plan=RenderPlan.from_file(script, RenderOptions(seed=1)))
    write_render_index(root, [SceneState(first, complete=True)])
    before = read_index(root)["sequences"][0]
    assert before["complete"] and before["render"]["seed"] == 1
    refused = FarmScene(name="a", script=script, out=root / "a",
                        plan=RenderPlan.from_file(script, RenderOptions(seed=5)),
                        error=f"{script}: error: --out {root / 'a'}: holds frames rendered with other settings")
    new = FarmScene(name="b", script=script, out=root / "b", error=f"{script}:1:1: error: something")
    write_render_index(root, [SceneState(refused, failed=refused.error, user_error=True),
                              SceneState(new, failed=new.error, user_error=True)])
    index = read_index(root)
    by_name = {e["name"]: e for e in index["sequences"]}
    assert by_name["a"] == before
    assert by_name["b"]["complete"] is False and by_name["b"]["error"] == new.error


def test_a_sigint_sent_while_the_render_process_starts_stops_it(tmp_path):
    """A Ray worker blocks SIGINT and its child starts with it blocked: a cancel that comes
    while the child starts leaves the signal pending. It must stop the command as a Ctrl-C
    does (exit 130, nothing written), not kill the process (-2, which a farm reads as a lost
    task and retries) nor be dropped."""
    script = tmp_path / "big.ses"        # a check that takes a while: the signal comes first
    script.write_text((REPO / "scenes" / "minimal.ses").read_text() + "// pad\n" * 200_000)
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        proc = subprocess.Popen([sys.executable, "-m", "blender_sesgen.commands.farm_child", "check", str(script)], cwd=REPO,
                                env={**os.environ, "PYTHONPATH": str(REPO), chunk_mod.PARENT_ENV: str(os.getpid())},
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        os.kill(proc.pid, signal.SIGINT)   # pending: the child has not unblocked it yet
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, err[-500:])
    assert "Traceback" not in err and "interrupted" in err


def test_a_render_child_keeps_a_cancel_that_came_while_it_started(tmp_path):
    """The farm's render child records a SIGINT from its start (``farm_child``: a
    KeyboardInterrupt raised in the middle of the command's imports came out as numpy's
    ImportError, exit 1, or as a process killed by SIGINT at exit, -2: 13 of 120 cancels sent
    0-0.6 s into a start, none now); the render's own ``deferred_interrupts`` keeps that request,
    so the render stops before its first frame. Here the request is made by hand, in this
    process: the block starts with it (before: it started afresh and the render went on)."""
    from blender_sesgen.render.interrupt import StopRequest, deferred_interrupts
    early = StopRequest()
    old = signal.signal(signal.SIGINT, early)
    try:
        signal.raise_signal(signal.SIGINT)           # the cancel, recorded while the child started
        with deferred_interrupts() as stop:
            assert stop.requested and stop.signal_name == "SIGINT"
        assert signal.getsignal(signal.SIGINT) is early
        signal.signal(signal.SIGINT, signal.default_int_handler)
        with deferred_interrupts() as stop:          # Python's handler: nothing asked before
            assert not stop.requested
    finally:
        signal.signal(signal.SIGINT, old)


def test_a_render_child_interrupted_as_it_starts_writes_nothing(tmp_path):
    """``farm_child render``, SIGINT pending as it starts (as from a farm task cancelled at
    once): exit 130, one line, no folder."""
    out = tmp_path / "out"
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        proc = subprocess.Popen([sys.executable, "-m", "blender_sesgen.commands.farm_child", "render",
                                 str(REPO / "scenes" / "minimal.ses"), "--out", str(out), "--progress", "json"],
                                cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO), chunk_mod.PARENT_ENV: str(os.getpid())},
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        os.kill(proc.pid, signal.SIGINT)
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and err.strip() == "interrupted", (proc.returncode, err[-500:])
    assert not out.exists()


def test_the_verify_task_reports_a_tampered_manifest_as_the_folders_own_problem(tmp_path):
    """The farm then runs one chunk, whose --resume writes the manifest again from the
    script (a ContractError here used to fail the scene, and every later farm with it)."""
    pytest.importorskip("cv2")
    pytest.importorskip("OpenEXR")
    from synthetic_render import complete_render
    root = complete_render(tmp_path / "r")
    assert chunk_mod.verify_task(str(root))["folder"] == []
    m = json.loads((root / "manifest.json").read_text())
    m["K"][0][0] *= 1.01
    (root / "manifest.json").write_text(json.dumps(m))
    res = chunk_mod.verify_task(str(root))
    assert res["missing"] == [] and len(res["folder"]) == 1 and "seal" in res["folder"][0]
