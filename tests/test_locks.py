"""Whether a lock's holder is gone, on this host (pure: no render)."""
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
