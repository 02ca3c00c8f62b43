"""The add-on's Study panel without Blender: the study file it writes, the levels it reads,
the ``study run`` child process it follows (blender_sesgen/addon/study_job.py)."""
from __future__ import annotations

import sys

import pytest

from blender_sesgen.addon import study_job
from study_scenes import ROOM, write


def test_levels_are_read_as_the_factor_wants_them():
    assert study_job.parse_levels("exposure_time", "0.005, 0.01 0.02") == [0.005, 0.01, 0.02]
    assert study_job.parse_levels("moving_cars", "0 2 4") == [0, 2, 4]
    assert study_job.parse_levels("hdri", "night, sunset") == ["night", "sunset"]
    for factor, text, words in (("exposure_time", "fast", "numbers"), ("exposure_time", "", "type"),
                                ("hdri", "moon", "not one of"), ("nope", "1", "unknown factor")):
        with pytest.raises(study_job.StudyJobError, match=words):
            study_job.parse_levels(factor, text)


def test_the_panel_writes_a_one_factor_study_that_checks(tmp_path):
    from blender_sesgen.study.spec import load
    script = write(tmp_path, "room.ses", ROOM)
    text = study_job.study_toml(str(script), "exposure_time", [0.005, 0.02], ["accurate-stereo", "opencv-stereo"],
                                frames=4, resolution=0.5)
    path = study_job.write_study(tmp_path / "study", text)
    s = load(path)
    assert s.world.script == script.resolve() and s.world.frames == 4 and s.world.resolution == ("scale", 0.5)
    assert [(f.name, f.levels) for f in s.factors] == [("exposure_time", (0.005, 0.02))]
    assert [x.name for x in s.systems] == ["accurate-stereo", "opencv-stereo"] and s.design.kind == "oat"
    bad = study_job.study_toml(str(script), "exposure_time", [0.01], ["orb-slam"])
    with pytest.raises(study_job.StudyJobError, match="unknown built-in system 'orb-slam'"):
        study_job.write_study(tmp_path / "bad", bad)


def test_the_command_and_the_child_process(tmp_path, monkeypatch):
    assert study_job.study_command("/opt/v env/bin/python -m blender_sesgen") == ["/opt/v", "env/bin/python", "-m",
                                                                                   "blender_sesgen"]
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(study_job.StudyJobError, match="Study Command"):
        study_job.study_command("")
    script = write(tmp_path, "room.ses", ROOM)
    path = study_job.write_study(tmp_path / "s", study_job.study_toml(str(script), "gain", [2.0], ["mono"]))
    taken = tmp_path / "taken"
    write(taken.parent, "taken", "")
    taken.unlink()
    taken.mkdir()
    write(taken, "mine.txt", "not a study")
    p = study_job.StudyProcess([sys.executable, "-m", "blender_sesgen"], path, taken)
    assert p.wait(120) == 2
    assert "holds something else than a study" in p.error and p.report is None
    assert p.line == "study: starting"
