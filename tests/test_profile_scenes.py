"""bench/profile_scenes.py's repeated rows: the row shown is one real process's (its stages
add up to its total), the median by CPU to first sample, the lower middle of an even count."""
from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
profile_scenes = pytest.importorskip("profile_scenes")


def _row(cpu: float, tag: str) -> dict:
    return {"to_first_sample": {"cpu": cpu}, "tag": tag}


def test_median_row_is_one_process_row():
    rows = [_row(5.0, "a"), _row(2.0, "b"), _row(9.0, "c")]
    assert profile_scenes.median_row(rows) is rows[0]
    # an even count: the lower middle (a real row, never an average of two)
    rows = [_row(7.0, "a"), _row(2.0, "b"), _row(4.0, "c"), _row(9.0, "d")]
    assert profile_scenes.median_row(rows)["tag"] == "c"
    assert profile_scenes.median_row([_row(3.0, "x")])["tag"] == "x"


def _base_worktrees() -> list[str]:
    out = subprocess.run(["git", "worktree", "list", "--porcelain"], cwd=REPO, capture_output=True, text=True).stdout
    return [ln.split(" ", 1)[1] for ln in out.splitlines()
            if ln.startswith("worktree ") and "sesgen-profile-base-" in ln]


@pytest.mark.skipif(not (REPO / ".git").exists() or shutil.which("git") is None,
                    reason="--base checks out a revision with git: needs a git checkout of the project")
def test_a_killed_run_leaves_no_base_worktree_registered():
    """A profile with --base killed (SIGTERM, as a CI timeout or `kill` sends) removes the base's
    temporary worktree: it must not stay registered in the user's repository."""
    before = set(_base_worktrees())
    proc = subprocess.Popen([sys.executable, str(REPO / "bench" / "profile_scenes.py"), "--scenes", "paper_room",
                             "--scale", "0.1", "--samples", "1", "--frames", "1", "--features", "none",
                             "--base", "HEAD"], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        t0 = time.time()
        while not set(_base_worktrees()) - before:
            assert proc.poll() is None, proc.stderr.read().decode()
            assert time.time() - t0 < 60, "no base worktree appeared"
            time.sleep(0.05)
        new = set(_base_worktrees()) - before
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) == 128 + signal.SIGTERM
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not set(_base_worktrees()) & new, "the killed run left its base worktree registered"
    assert not any(Path(w).parent.exists() for w in new), "the killed run left its temporary folder"
