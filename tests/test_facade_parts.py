"""bench/facade_parts.py's bad input: a clear message and exit code 2, no traceback."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _run(*args):
    return subprocess.run([sys.executable, str(REPO / "bench" / "facade_parts.py"), *args],
                          capture_output=True, text=True, cwd=REPO)


def test_a_folder_without_a_render_is_refused(tmp_path):
    r = _run(str(tmp_path))
    assert r.returncode == 2 and "no manifest.json" in r.stderr and "Traceback" not in r.stderr


def test_no_frames_is_refused(tmp_path):
    (tmp_path / "manifest.json").write_text("{}")
    r = _run(str(tmp_path), "--frames", "0")
    assert r.returncode == 2 and "--frames" in r.stderr and "Traceback" not in r.stderr
