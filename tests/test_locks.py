"""Whether a lock's holder is gone, on this host, and what a render killed during its first
writes leaves (pure: no render)."""
import socket
import subprocess
import sys
import time

import pytest

from blender_sesgen.render.locks import _stale


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
