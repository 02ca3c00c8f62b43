"""The one progress reporter (blender_sesgen.contract.progress): a live bar on a terminal,
whole lines with ETA in logs and pipes (never a carriage return), one JSON object per
event for tools, a callback for Python callers; and the commands that use it."""
from __future__ import annotations

import argparse
import io
import json

import pytest

from blender_sesgen.contract.progress import Progress, add_progress_argument, progress_mode, resolve_mode


class Clock:
    def __init__(self, step: float):
        self.t, self.step = 0.0, step

    def __call__(self) -> float:
        self.t += self.step
        return self.t


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def run(total, mode, stream, clock_step=0.01, notes=(), **kw):
    with Progress(total, "export tartanair", mode=mode, stream=stream, clock=Clock(clock_step), **kw) as p:
        for i in range(total):
            p.update(detail=f"frame {i}", frame=i)
            if i in notes:
                p.note(f"warning: step {i} failed")
    return stream.getvalue()


def test_auto_is_a_bar_on_a_terminal_and_lines_elsewhere():
    assert resolve_mode("auto", Tty()) == "bar" and resolve_mode("auto", io.StringIO()) == "plain"
    assert resolve_mode("json", Tty()) == "json"
    with pytest.raises(ValueError):
        resolve_mode("loud", io.StringIO())


def test_plain_lines_every_5_percent_with_eta_and_no_carriage_return():
    out = run(100, "plain", io.StringIO(), clock_step=0.01)
    assert "\r" not in out
    lines = out.splitlines()
    assert len(lines) == 20                                   # one per 5 %
    assert lines[0].startswith("export tartanair: 5/100 (5%)") and "ETA" in lines[0] and lines[0].endswith("frame 4")
    assert lines[-1].startswith("export tartanair: 100/100 (100%)") and "ETA" not in lines[-1]


def test_plain_slow_tasks_log_every_step():
    """A render frame takes long: a line every 5 s means one per frame."""
    out = run(200, "plain", io.StringIO(), clock_step=6.0)   # one clock reading per update: 6 s a frame
    assert len(out.splitlines()) == 200 and "\r" not in out
    assert out.splitlines()[0] == "export tartanair: 1/200 (0%) 6.0 s, ETA 19:54  frame 0"   # 199 x 6 s left


def test_bar_on_a_terminal_is_one_line_rewritten_in_place():
    out = run(10, "bar", Tty(), clock_step=1.0)
    assert out.count("\r") >= 10 and out.count("\n") == 1 and out.endswith("\n")
    assert "[########################] 10/10 (100%)" in out


def test_notes_are_kept_in_every_mode():
    plain = run(10, "plain", io.StringIO(), notes=(3,))
    assert "warning: step 3 failed\n" in plain
    bar = run(10, "bar", Tty(), clock_step=1.0, notes=(3,))
    assert "warning: step 3 failed\n" in bar and bar.count("\n") == 2
    assert run(10, "off", io.StringIO(), notes=(3,)) == ""


def test_json_one_object_per_line_and_event():
    out = run(4, "json", io.StringIO(), notes=(1,))
    events = [json.loads(line) for line in out.splitlines()]
    assert [e["event"] for e in events] == ["start", "progress", "progress", "note", "progress", "progress", "end"]
    assert events[0] == {"event": "start", "task": "export tartanair", "total": 4, "unit": "frame"}
    p = events[2]
    assert p["done"] == 2 and p["total"] == 4 and p["fraction"] == 0.5 and p["frame"] == 1
    assert p["detail"] == "frame 1" and p["eta_s"] == pytest.approx(p["elapsed_s"], rel=1e-6)
    assert events[3]["message"] == "warning: step 1 failed"
    assert events[-1]["status"] == "ok" and events[-1]["done"] == 4


def test_end_status_on_errors_and_interrupts():
    for exc, status in ((KeyboardInterrupt, "interrupted"), (RuntimeError, "error")):
        s = io.StringIO()
        with pytest.raises(exc):
            with Progress(5, "t", mode="json", stream=s) as p:
                p.update()
                raise exc()
        assert json.loads(s.getvalue().splitlines()[-1]) == {**json.loads(s.getvalue().splitlines()[-1]),
                                                             "event": "end", "status": status, "done": 1}
        s = io.StringIO()
        with pytest.raises(exc):
            with Progress(5, "t", mode="plain", stream=s):
                raise exc()
        assert s.getvalue().endswith(f"t: {status} at 0/5\n")


def test_callback_sees_every_event_even_when_silent():
    seen = []
    out = run(3, "off", io.StringIO(), callback=seen.append)
    assert out == "" and [e["event"] for e in seen] == ["start", "progress", "progress", "progress", "end"]
    assert seen[2]["frame"] == 1


def test_cli_arguments():
    p = argparse.ArgumentParser()
    add_progress_argument(p)
    assert progress_mode(p.parse_args([])) == "auto"
    assert progress_mode(p.parse_args(["--progress", "json"])) == "json"
    assert progress_mode(p.parse_args(["--progress", "json", "-q"])) == "off"
    with pytest.raises(SystemExit):
        p.parse_args(["--progress", "loud"])


def test_stereo_vo_json_progress_parses_line_by_line(tmp_path, capsys):
    pytest.importorskip("OpenEXR")
    from vo_reference.commands.main import main
    from synthetic_render import plane_scene
    root = plane_scene(tmp_path / "r", frames=4)
    assert main(["stereo-vo", str(root), "--gt-depth", "--gt-flow", "--out", str(tmp_path / "e.txt"),
                 "--progress", "json"]) == 0
    cap = capsys.readouterr()
    events = [json.loads(line) for line in cap.err.splitlines()]
    assert [e["event"] for e in events] == ["start", "progress", "progress", "progress", "end"]
    assert events[1]["task"] == "stereo-vo accurate" and len(events[1]["twist"]) == 6 and events[1]["frame"] == 0
    assert "3 poses" not in cap.err and "poses" in cap.out            # results stay on stdout
