"""The add-on's export runs ``vo-reference export --progress json`` as a child process (Blender's
Python has no OpenCV): its layout list matches vo_reference's, the command line is built as
documented, and the JSON events drive the progress (pure: no bpy needed)."""
from __future__ import annotations

import sys

import pytest

from blender_sesgen.addon import export_job
from vo_reference.products.exports import EXPORTERS, get_exporter

PY_VO = [sys.executable, "-m", "vo_reference"]


def test_the_layout_list_is_vo_references():
    assert [t[0] for t in export_job.TARGETS] == list(EXPORTERS)
    assert export_job.TAKES_SEQUENCE == {n for n in EXPORTERS if getattr(get_exporter(n), "takes_sequence", False)}


def test_command_line():
    cmd = export_job.export_command(["vo-reference"], "/r", "/o", "kitti-odometry", " 03 ", "1:5")
    assert cmd == ["vo-reference", "export", "/r", "/o", "--to", "kitti-odometry", "--progress", "json",
                   "--sequence", "03", "--frames", "1:5"]
    assert export_job.vo_command("/opt/v env/bin/python -m vo_reference") == ["/opt/v", "env/bin/python", "-m",
                                                                              "vo_reference"]
    assert export_job.vo_command("'/opt/v env/bin/vo-reference'") == ["/opt/v env/bin/vo-reference"]
    for bad in (("tum", "x"), ("nope", "")):
        with pytest.raises(export_job.ExportError):
            export_job.export_command(["vo"], "/r", "/o", bad[0], bad[1])
    with pytest.raises(export_job.ExportError, match="choose an export folder"):
        export_job.export_command(["vo"], "/r", "", "tum")


def test_a_real_export_reports_progress_and_its_result(tmp_path):
    pytest.importorskip("OpenEXR")
    from synthetic_render import plane_scene
    render = plane_scene(tmp_path / "r", frames=3)
    p = export_job.ExportProcess(export_job.export_command(PY_VO, str(render), str(tmp_path / "k"), "kitti-odometry",
                                                           "4"))
    p.wait(300)
    assert p.returncode == 0, p.error
    assert p.done == p.total == 3 and p.fraction == 1.0
    assert "exported" in p.summary and (tmp_path / "k/dataset/sequences/04/image_0/000002.png").is_file()
    bad = export_job.ExportProcess(export_job.export_command(PY_VO, str(tmp_path / "none"), str(tmp_path / "b"), "tum"))
    bad.wait(300)
    assert bad.returncode == 2 and "no manifest.json" in bad.error and "\n" not in bad.error


def test_a_missing_tool_is_a_clear_error(tmp_path):
    with pytest.raises(export_job.ExportError, match="pip install 'blender-sesgen\\[vo\\]'"):
        export_job.ExportProcess([str(tmp_path / "no-such-vo-reference"), "export"])


def test_undistort_reaches_the_tool(tmp_path):
    """A lens render: the layout without a lens model reports the tool's one line naming
    --undistort; the panel's Undistort adds the option and the export succeeds."""
    pytest.importorskip("OpenEXR")
    import json
    from synthetic_render import plane_scene, write_manifest_dict
    render = plane_scene(tmp_path / "r", frames=2)
    m = json.loads((render / "manifest.json").read_text())
    m["lens"] = {"model": "brown", "coeffs": [-0.1, 0.01, 0.0, 0.0, 0.0]}
    write_manifest_dict(render, m)
    cmd = export_job.export_command(PY_VO, str(render), str(tmp_path / "t"), "tum")
    assert "--undistort" not in cmd
    p = export_job.ExportProcess(cmd)
    p.wait(300)
    assert p.returncode == 2 and "--undistort" in p.error and "\n" not in p.error
    cmd = export_job.export_command(PY_VO, str(render), str(tmp_path / "t"), "tum", undistort=True)
    assert cmd[-1] == "--undistort"
    p = export_job.ExportProcess(cmd)
    p.wait(300)
    assert p.returncode == 0, p.error
    assert "undistorted" in json.loads((tmp_path / "t/export.json").read_text())
