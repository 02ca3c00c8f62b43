"""Whether a lock's holder is gone, on this host, and what a render killed during its first
writes leaves (pure: no render)."""
import os
import socket
import subprocess
import sys
import time

import pytest

from blender_sesgen.contract.writers import stale as _stale, zombie as _zombie


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="zombies are read from /proc (Linux)")
def test_a_holder_that_ended_but_was_not_reaped_is_gone(tmp_path):
    """A render orphaned by a killed farm worker is a zombie until its new parent reaps it:
    its lock must count as stale, or the retried chunk finds its own folder busy."""
    lock = tmp_path / "lock"
    lock.write_text("x")
    host = socket.gethostname()
    live = subprocess.Popen(["sleep", "30"])
    ended = subprocess.Popen(["true"])          # not waited for: a zombie once it exits
    try:
        deadline = time.monotonic() + 10
        while not _stale(host, ended.pid, lock) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _stale(host, ended.pid, lock), "an ended, unreaped process holds no lock"
        assert not _stale(host, live.pid, lock), "a running process keeps its lock"
    finally:
        live.kill()
        live.wait()
        ended.wait()
    assert _stale(host, ended.pid, lock), "a reaped process holds no lock"


def test_a_folder_left_by_a_render_killed_during_its_first_writes_is_still_its_own(tmp_path):
    """Killed between taking its lock and renaming its first manifest into place, a render leaves
    only its state folder and the manifest's temporary: ``--resume`` must take the folder up (the
    kill -9 trials of test_render_reliability.py hit it); a user's file there is still refused."""
    from blender_sesgen.errors import SesgenError
    from blender_sesgen.render.folder import OutputFolder
    from blender_sesgen.render.plan import RenderOptions, RenderPlan
    script = tmp_path / "s.ses"
    script.write_text("CAMERA resolution 64 48 focal 50\nQUAD id 1 vertices -1 -1 -2  1 -1 -2  1 1 -2  -1 1 -2\n")
    plan = RenderPlan.from_file(script, RenderOptions())
    out = tmp_path / "out"
    (out / ".sesgen").mkdir(parents=True)
    (out / ".sesgen" / "lock-host-999999.json").write_text("{}")
    (out / ".manifest.tmp-999999.json").write_text('{"format": "sesgen-')
    OutputFolder(out).check(plan, force=False)
    (out / ".scene.tmp-999999.ses").write_text("CAMERA")
    OutputFolder(out).check(plan, force=False)
    for name in ("notes.txt", ".notes.tmp-999999.txt"):
        (out / name).write_text("mine")
        with pytest.raises(SesgenError, match="holds no render"):
            OutputFolder(out).check(plan, force=False)
        (out / name).unlink()


def test_a_writer_locking_while_stale_temporaries_are_removed_keeps_its_own(tmp_path):
    """A render beginning removes the temporary files of writers that are gone. A chunk that
    takes its lock after that render looked at the locks and writes its first files (the
    script's copy, the manifest, an EXR) while the folder is being scanned (a long folder,
    chunks of a farm beginning together) keeps them: the old code removed them (the snapshot
    of live writers was taken before the scan) and the chunk failed at its rename."""
    from blender_sesgen.render.folder import OutputFolder
    out = tmp_path / "out"
    (out / "exr" / "left").mkdir(parents=True)
    folder = OutputFolder(out)
    folder.state.mkdir()
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead = out / "exr" / "left" / f".000003.tmp-{int(ended.stdout)}.exr"   # a killed writer's
    dead.write_bytes(b"x")
    sleeper = subprocess.Popen(["sleep", "30"])
    theirs = [out / f".scene.tmp-{sleeper.pid}.ses", out / "exr" / "left" / f".000007.tmp-{sleeper.pid}.exr"]
    snapshot = folder.locks.live_pids

    def live_pids():   # the other chunk takes its lock and writes right after the first look
        pids = snapshot()
        if not (folder.state / f"lock-h-{sleeper.pid}.json").exists():
            (folder.state / f"lock-h-{sleeper.pid}.json").write_text("{}")
            for f in theirs:
                f.write_bytes(b"y")
        return pids
    folder.locks.live_pids = live_pids
    try:
        folder._remove_stale_temporaries()
    finally:
        sleeper.kill()
        sleeper.wait()
    assert not dead.exists()
    assert [f.exists() for f in theirs] == [True, True]


# --- a slow frame's lock on a multi-host farm (render.heartbeat) -----------------------------

def _judged_from_another_host(monkeypatch, stale_s: float) -> None:
    """From here on this process judges locks as a writer on another host does: by the lock
    file's time, stale after ``stale_s`` without a touch."""
    from blender_sesgen.contract import writers
    monkeypatch.setattr(writers, "STALE_LOCK_S", stale_s)
    monkeypatch.setattr(writers.socket, "gethostname", lambda: "another-host")


def _live_paths(state) -> list:
    from blender_sesgen.render.locks import FolderLocks
    judge = FolderLocks(state)
    with judge.mutex():
        return [info["path"].name for info in judge.live()]


def test_a_live_writer_slower_than_the_stale_time_keeps_its_lock(tmp_path, monkeypatch):
    """A frame slower than STALE_LOCK_S (no frame completed, so no touch of the lock) must not
    lose its lock to a writer on another host: the old code touched it only per frame, and the
    next writer took it over, removing the live chunk's log and temporaries as a dead one's."""
    from blender_sesgen.render import locks
    monkeypatch.setattr(locks, "HEARTBEAT_S", 0.2, raising=False)
    writer = locks.FolderLocks(tmp_path / ".sesgen")
    writer.take((0, 3), "sha", "settings", tmp_path)
    try:
        _judged_from_another_host(monkeypatch, 3.0)
        time.sleep(7.0)   # more than two stale times without a frame
        assert _live_paths(tmp_path / ".sesgen") == [writer.path.name]
    finally:
        writer.drop()
    assert not list((tmp_path / ".sesgen").glob("lock-*"))


_WRITER = """
import sys, time
from blender_sesgen.render import locks
locks.HEARTBEAT_S = 0.2
locks.HUNG_RENDER_S = float(sys.argv[2])
w = locks.FolderLocks(sys.argv[1])
w.take((0, 3), "sha", "settings", sys.argv[1])
print(getattr(w, "_heartbeat", None) and w._heartbeat.pid, flush=True)
for _ in range(int(sys.argv[3])):   # frames completed, one every 4 s
    time.sleep(4.0)
    w.touch()
time.sleep(600)
"""


def _start_writer(state, hung_s: float, frames: int):
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(state), str(hung_s), str(frames)],
                            stdout=subprocess.PIPE, text=True)
    line = proc.stdout.readline().strip()
    return proc, int(line) if line.isdigit() else None


def _wait_until(cond, timeout_s: float) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if cond():
            return True
        time.sleep(0.1)
    return cond()


def _gone(pid) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return _zombie(pid)


@pytest.mark.skipif(os.name != "posix", reason="the heartbeat needs select on pipes (POSIX)")
def test_a_killed_writers_lock_goes_stale_though_it_had_a_heartbeat(tmp_path, monkeypatch):
    """The heartbeat dies with its writer (kill -9: its pipe closes): the lock is kept while the
    writer lives (longer than the stale time without a frame: fails on the old code) and is
    taken over once it is dead."""
    state = tmp_path / ".sesgen"
    proc, beat = _start_writer(state, 3600.0, 0)
    try:
        _judged_from_another_host(monkeypatch, 3.0)
        time.sleep(6.5)
        assert len(_live_paths(state)) == 1, "a live writer without a frame for 2 stale times keeps its lock"
        proc.kill()
        proc.wait()
        assert beat is not None and _wait_until(lambda: _gone(beat), 10.0), "the heartbeat outlived its writer"
        assert _wait_until(lambda: not _live_paths(state), 10.0), "a dead writer's lock never went stale"
    finally:
        proc.kill()
        proc.wait()


@pytest.mark.skipif(os.name != "posix", reason="the heartbeat needs select on pipes (POSIX)")
def test_a_hung_writers_lock_goes_stale_after_the_hung_time(tmp_path, monkeypatch):
    """A writer whose frames take longer than STALE_LOCK_S each (but less than HUNG_RENDER_S)
    keeps its lock past HUNG_RENDER_S (the old code lost it between frames); one that then
    completes none for HUNG_RENDER_S (a hung render: alive, its heartbeat running) loses it
    STALE_LOCK_S later -- the bound on a hung render's hold of its frames on other hosts."""
    state = tmp_path / ".sesgen"
    proc, beat = _start_writer(state, 5.0, 2)     # a frame every 4 s for ~8 s, then hung
    try:
        _judged_from_another_host(monkeypatch, 3.0)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 10.5:         # frames, then 2.5 s into the hang: still fresh
            assert len(_live_paths(state)) == 1
            time.sleep(0.3)
        assert _wait_until(lambda: not _live_paths(state), 15.0), "a hung writer's lock never went stale"
        assert proc.poll() is None and not _gone(beat), "the writer and its heartbeat are alive (hung)"
    finally:
        proc.kill()
        proc.wait()
