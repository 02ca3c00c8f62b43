"""Malformed input to every reader of ``vo_reference``: exit code 2, one line on stderr that
names the file (and the line, for text files), no traceback, nothing written.

The cases are the ones found by trying the readers adversarially (issue #19): zero
quaternions, 1e308 estimates, K = 0, NaN rows, NaN in a KITTI calibration, a render whose
frames are incomplete, a corrupt EXR part, a failed export, FIFOs and devices given as
files. The commands run in-process through ``vo_reference.commands.main.main`` with the file
descriptors captured (``capfd``: what C libraries print counts too); two cases run the real
``python -m vo_reference`` to prove the whole path.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from synthetic_render import plane_scene, write_manifest_dict
from vo_reference.commands.main import main

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def render(tmp_path_factory) -> Path:
    return plane_scene(tmp_path_factory.mktemp("r") / "render", frames=4)


@pytest.fixture
def copy(render, tmp_path):
    def make(name="copy") -> Path:
        dst = tmp_path / name
        shutil.copytree(render, dst)
        return dst
    return make


def fails(capfd, *argv) -> str:
    """Run the command; it must exit 2 with exactly one line on stderr: return that line."""
    capfd.readouterr()
    code = main([str(a) for a in argv])
    err = capfd.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def gt_tum(tmp_path) -> Path:
    return write(tmp_path / "gt.tum", "".join(f"{k} {0.1 * k} 0 0 0 0 0 1\n" for k in range(5)))


# --- trajectories -----------------------------------------------------------------------

def test_tum_with_a_zero_quaternion(tmp_path, capfd):
    est = write(tmp_path / "est.tum", "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 0\n")
    assert fails(capfd, "evaluate", "--gt", gt_tum(tmp_path), "--est", est) == \
        f"error: {est}:2: a zero quaternion is not a rotation"


@pytest.mark.parametrize("value", ["1e308", "-1e308", "1e10"])
def test_estimate_with_huge_values_is_an_error_at_its_line(tmp_path, capfd, value):
    est = write(tmp_path / "est.tum", "".join(f"{k} {value} 0 {value} 0 0 0 1\n" for k in range(5)))
    line = fails(capfd, "evaluate", "--gt", gt_tum(tmp_path), "--est", est)
    assert line.startswith(f"error: {est}:1: ") and "not a pose" in line


@pytest.mark.parametrize("row", ["nan nan nan nan nan nan nan nan", "2 0.2 0 nan 0 0 0 1", "2 inf 0 0 0 0 0 1"])
def test_rows_of_nans_are_errors_not_dropped(tmp_path, capfd, row):
    est = write(tmp_path / "est.tum", f"0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n{row}\n3 0.3 0 0 0 0 0 1\n")
    assert fails(capfd, "evaluate", "--gt", gt_tum(tmp_path), "--est", est) == \
        f"error: {est}:3: numbers must be finite"


def test_kitti_times_with_nan(tmp_path, capfd):
    from vo_reference.io.trajectory import read_kitti
    from vo_reference.errors import VoError
    poses = write(tmp_path / "p.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n" * 3)
    times = write(tmp_path / "times.txt", "0\nnan\n0.2\n")
    with pytest.raises(VoError, match=r"times\.txt:2: numbers must be finite"):
        read_kitti(poses, times)
    write(times, "0\n0.2\n0.1\n")
    with pytest.raises(VoError, match=r"times go backwards"):
        read_kitti(poses, times)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_fifo_and_device_as_trajectory_files(tmp_path, capfd):
    fifo = tmp_path / "est.tum"
    os.mkfifo(fifo)
    assert "FIFO" in fails(capfd, "evaluate", "--gt", gt_tum(tmp_path), "--est", fifo)
    assert "character device" in fails(capfd, "evaluate", "--gt", gt_tum(tmp_path), "--est", "/dev/zero",
                                       "--format", "tum")


# --- manifests ----------------------------------------------------------------------------

def _edit_manifest(root: Path, edit) -> Path:
    path = root / "manifest.json"
    path.write_text(edit(path.read_text()))
    return path


def test_manifest_with_k_zero(copy, tmp_path, capfd):
    root = copy()
    m = json.loads((root / "manifest.json").read_text())
    m["K"] = [[0, 0, 0], [0, 0, 0], [0, 0, 1]]
    write_manifest_dict(root, m)   # sealed again: the checks behind the seal are tested
    for argv in (("export", root, tmp_path / "out", "--to", "kitti-stereo", "-q"),
                 ("stereo-vo", root, "--out", tmp_path / "e.txt", "--quiet"),
                 ("evaluate", "--gt", root, "--est", gt_tum(tmp_path))):
        line = fails(capfd, *argv)
        assert f"{root / 'manifest.json'}" in line and "K is not a camera matrix" in line, argv
    assert not (tmp_path / "out").exists() and not (tmp_path / "e.txt").exists()


@pytest.mark.parametrize("bad", ["NaN", "Infinity", "-Infinity", "1e999"])
def test_manifest_with_non_finite_numbers_is_refused_by_export_and_evaluate(copy, tmp_path, capfd, bad):
    root = copy()
    path = _edit_manifest(root, lambda t: t.replace('"baseline": 0.2', f'"baseline": {bad}'))
    line_no = next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if '"baseline"' in ln)
    for argv in (("export", root, tmp_path / "out", "--to", "kitti-odometry", "-q"),
                 ("evaluate", "--gt", root, "--est", gt_tum(tmp_path))):
        assert fails(capfd, *argv) == f"error: {path}:{line_no}: {bad} is not a JSON number"
    assert not (tmp_path / "out").exists()


def test_manifest_that_is_not_json_or_is_a_fifo(copy, tmp_path, capfd):
    root = copy()
    _edit_manifest(root, lambda t: t[: len(t) // 2])
    assert "not valid JSON" in fails(capfd, "stereo-vo", root, "--out", tmp_path / "e.txt")
    if hasattr(os, "mkfifo"):
        (root / "manifest.json").unlink()
        os.mkfifo(root / "manifest.json")
        assert "FIFO" in fails(capfd, "stereo-vo", root, "--out", tmp_path / "e.txt")


# --- render folders -------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["stereo-vo", "mono-vo", "run", "export"])
def test_vo_refuses_incomplete_frames_as_export_does(copy, tmp_path, capfd, command):
    root = copy()
    m = json.loads((root / "manifest.json").read_text())
    m["frames_complete"] = [True, True, False, False]
    write_manifest_dict(root, m)
    argv = {"stereo-vo": ("stereo-vo", root, "--out", tmp_path / "e.txt", "--quiet"),
            "mono-vo": ("mono-vo", root, "--out", tmp_path / "e.txt", "-q"),
            "run": ("run", root, "--report", tmp_path / "rep", "--quiet", "--no-plots"),
            "export": ("export", root, tmp_path / "out", "--to", "png", "-q")}[command]
    assert fails(capfd, *argv) == (f"error: {root}: 2 frame(s) not rendered completely (2, 3); "
                                   "finish the render (--resume) or choose --frames")
    assert not (tmp_path / "e.txt").exists() and not (tmp_path / "out").exists()
    # the complete part still works
    if command == "stereo-vo":
        assert main(["stereo-vo", str(root), "--out", str(tmp_path / "e.txt"), "--quiet", "--frames", "0:2",
                     "--gt-depth"]) == 0


def _incomplete_from(root: Path, first: int) -> Path:
    """The folder as a render writing frames ``first``.. leaves it (or a killed one, or verify
    after finding them bad): recorded not complete, their files still there."""
    m = json.loads((root / "manifest.json").read_text())
    m["frames_complete"] = [k < first for k in range(len(m["frames_complete"]))]
    write_manifest_dict(root, m)
    return root


def test_a_frame_not_rendered_completely_is_never_read_though_its_files_are_there(render, copy):
    """Every pixel read of a render folder (EXR passes, the camera image) refuses a frame not
    recorded complete: the old reader read whatever file lay there (a frame verify found bad,
    one a killed render left) and the study's ground-truth control called two folders
    identical on it. A frame completed after the reader opened the folder (its completion log
    appended by a render still running) is read."""
    from vo_reference.errors import VoError
    from vo_reference.io.render import RenderSequence
    from vo_reference.study.evaluate import ground_truth_identical
    root = _incomplete_from(copy(), 2)
    seq = RenderSequence(root)
    for read in (seq.depth, seq.ids, seq.rgb_linear, seq.image_rgb):
        with pytest.raises(VoError, match="frame 2 is not rendered completely"):
            read(2, "left")
    assert seq.depth(1, "left").shape == (48, 64)
    with pytest.raises(VoError, match="not rendered completely"):
        ground_truth_identical(RenderSequence(root), RenderSequence(render))
    (root / ".sesgen").mkdir(exist_ok=True)
    (root / ".sesgen" / "done-h-1.jsonl").write_text(json.dumps({"frame": 2, "files": {}}) + "\n")
    assert np.array_equal(seq.depth(2, "left"), RenderSequence(render).depth(2, "left"))


@pytest.mark.parametrize("layout", ["kitti-stereo", "kitti-sceneflow", "sceneflow"])
def test_an_export_refuses_a_neighbour_frame_a_render_is_writing(copy, tmp_path, capfd, layout):
    """Layouts that read frame k+1 (k-1) beside the selected frames (pairs, flow) refuse while a
    live render holds that frame, not yet complete: the old exporters wrote its pair and flow
    as at the sequence's end (no *_11 image, NaN flow), exit 0, an export that differed from
    the one made once the render had finished. A neighbour no render is writing (a shorter
    render, a killed one whose lock is stale) is the sequence's end, as documented."""
    import socket
    root = _incomplete_from(copy(), 2)
    for k in (2, 3):   # as mid-render: not there yet
        for view in ("left", "right"):
            (root / "exr" / view / f"{k:06d}.exr").unlink()
    (root / ".sesgen").mkdir(exist_ok=True)
    lock = root / ".sesgen" / f"lock-h-{os.getpid()}.json"    # this process: a live writer of frames 2..3
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": os.getpid(), "frames": [2, 3]}))
    line = fails(capfd, "export", root, tmp_path / "o", "--to", layout, "--frames", "0:2", "-q")
    assert line == (f"error: {root}: frame(s) 2 beside the selected ones are being rendered (pid {os.getpid()} on "
                    f"{socket.gethostname()}, frames 2..3); the {layout} layout reads them (pairs and flow across the "
                    "selection's ends): wait for the render to finish, or choose --frames whose neighbours are rendered")
    assert not (tmp_path / "o").exists()
    if layout != "kitti-sceneflow":   # frames 0:1: every neighbour rendered
        assert main(["export", str(root), str(tmp_path / "o1"), "--to", layout, "--frames", "0:1", "-q"]) == 0
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    lock.write_text(json.dumps({"host": socket.gethostname(), "pid": int(ended.stdout), "frames": [2, 3]}))
    if layout != "kitti-sceneflow":   # its writer is gone: frame 1 is the end (kitti-sceneflow: no pair at all)
        assert main(["export", str(root), str(tmp_path / "o2"), "--to", layout, "--frames", "0:2", "-q"]) == 0


def test_missing_exr_file_counts_as_incomplete(copy, tmp_path, capfd):
    root = copy()
    (root / "exr" / "right" / "000001.exr").unlink()
    assert "1 frame(s) not rendered completely (1)" in fails(capfd, "stereo-vo", root, "--out", tmp_path / "e.txt")


def _corrupt(path: Path, start_from_end: int = 400, end_from_end: int = 10) -> None:
    data = bytearray(path.read_bytes())
    for i in range(len(data) - start_from_end, len(data) - end_from_end):
        data[i] ^= 0x5A
    path.write_bytes(bytes(data))


def test_corrupt_exr_part_is_called_corrupt_not_a_missing_pass(copy, tmp_path, capfd):
    root = copy()
    exr = root / "exr" / "left" / "000001.exr"
    _corrupt(exr)
    line = fails(capfd, "stereo-vo", root, "--out", tmp_path / "e.txt", "--gt-depth", "--quiet")
    assert line.startswith(f"error: {exr}: corrupt or truncated EXR") and "missing" not in line


def test_truncated_exr_and_exr_that_is_not_one(copy, tmp_path, capfd):
    root = copy()
    exr = root / "exr" / "left" / "000002.exr"
    exr.write_bytes(exr.read_bytes()[:300])
    line = fails(capfd, "export", root, tmp_path / "out", "--to", "png", "-q")
    assert str(exr) in line and ("corrupt" in line or "not a readable EXR" in line)
    exr.write_bytes(b"x")
    assert "not a readable EXR" in fails(capfd, "export", root, tmp_path / "out", "--to", "png", "-q")


# --- exports leave nothing half-written -------------------------------------------------------

def test_failed_export_leaves_no_folder_and_keeps_an_earlier_export(copy, tmp_path, capfd):
    root = copy()
    out = tmp_path / "exports" / "kitti"
    assert main(["export", str(root), str(out), "--to", "kitti-stereo", "-q"]) == 0
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    assert (out / "export.json").is_file() and before
    _corrupt(root / "exr" / "left" / "000003.exr")
    fails(capfd, "export", root, out, "--to", "kitti-stereo", "-q")
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before      # the earlier export, intact
    assert os.listdir(out.parent) == ["kitti"]                                 # no temporary folder left
    fresh = tmp_path / "exports" / "fresh"
    fails(capfd, "export", root, fresh, "--to", "kitti-stereo", "-q")
    assert os.listdir(out.parent) == ["kitti"]                                 # nothing half-written


def test_export_refuses_to_replace_a_folder_that_is_not_an_export(render, tmp_path, capfd):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    assert "is not an export of ours" in fails(capfd, "export", render, mine, "--to", "png", "-q")
    assert (mine / "notes.txt").read_text() == "keep me"


# --- KITTI folders ----------------------------------------------------------------------------

@pytest.fixture
def kitti(render, tmp_path) -> Path:
    out = tmp_path / "kitti"
    assert main(["export", str(render), str(out), "--to", "kitti-folder", "-q"]) == 0
    return out


@pytest.mark.parametrize("value", ["nan", "inf", "1e300"])
def test_kitti_calib_with_nan_is_an_error_at_its_line(kitti, tmp_path, capfd, value):
    calib = kitti / "calib.txt"
    lines = calib.read_text().splitlines()
    lines[1] = "P1: " + " ".join([value] * 12)
    calib.write_text("\n".join(lines) + "\n")
    for argv in (("mono-vo", kitti, "--out", tmp_path / "e.txt", "-q"),
                 ("stereo-vo", kitti, "--out", tmp_path / "e.txt", "--quiet")):
        assert fails(capfd, *argv).startswith(f"error: {calib}:2: P1: numbers must be finite"), argv


def test_kitti_calib_with_k_zero(kitti, tmp_path, capfd):
    calib = kitti / "calib.txt"
    lines = calib.read_text().splitlines()
    lines[0] = "P0: " + " ".join(["0"] * 12)
    calib.write_text("\n".join(lines) + "\n")
    assert "P0 is not a camera projection matrix" in fails(capfd, "mono-vo", kitti, "--out", tmp_path / "e.txt")


def test_kitti_image_that_is_not_a_png(kitti, tmp_path, capfd):
    img = kitti / "image_0" / "000001.png"
    data = img.read_bytes()
    img.write_bytes(data[:8] + bytes(b ^ 0xFF for b in data[8:60]) + data[60:])
    line = fails(capfd, "stereo-vo", kitti, "--out", tmp_path / "e.txt", "--quiet")
    assert line.startswith(f"error: {img}: not a readable image")


# --- disparity, flow and PFM files -----------------------------------------------------------

def test_disparity_files(tmp_path, capfd):
    from vo_reference.io.pfm import write_pfm
    good = write_pfm(tmp_path / "gt.pfm", np.ones((4, 5), np.float32))
    bad = {"t.pfm": b"Pf\n5 4\n-1.0\n" + b"\0" * 7, "z.pfm": b"Pf\n0 4\n-1.0\n", "s.pfm": b"Pf\n5 4\nnan\n",
           "e.npy": b"", "o.npy": b"\x93NUMPY\x01\x00v\x00{'descr': '|O', 'fortran_order': False, 'shape': (2,), }",
           "t.png": b"\x89PNG\r\n\x1a\n" + b"\0" * 30}
    for name, data in bad.items():
        path = tmp_path / name
        path.write_bytes(data)
        line = fails(capfd, "evaluate-disparity", "--gt", good, "--est", path)
        assert str(path) in line, (name, line)
    assert "character device" in fails(capfd, "evaluate-disparity", "--gt", good, "--est", "/dev/zero")


def test_flo_with_negative_size(tmp_path):
    from vo_reference.errors import VoError
    from vo_reference.groundtruth.flow import FLO_MAGIC, read_flo
    path = tmp_path / "x.flo"
    path.write_bytes(np.array([FLO_MAGIC], "<f4").tobytes() + np.array([-1, -1], "<i4").tobytes() + b"\0" * 16)
    with pytest.raises(VoError, match="not an image size"):
        read_flo(path)


# --- the whole command, in a fresh interpreter ------------------------------------------------

def test_real_command_line_one_line_exit_2(copy, tmp_path):
    root = copy()
    _corrupt(root / "exr" / "left" / "000001.exr")
    env = {**os.environ, "PYTHONPATH": f"{REPO}{os.pathsep}{REPO / 'tests'}"}
    p = subprocess.run([sys.executable, "-m", "vo_reference", "export", str(root), str(tmp_path / "o"), "--to",
                        "png", "-q"], capture_output=True, text=True, env=env, timeout=300)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "corrupt or truncated EXR" in p.stderr and p.stdout == ""
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("key, value, message", [
    ("lens", {"model": "brown"}, "'lens.coeffs' must be 5 numbers"),
    ("lens", {"model": "fisheye9", "coeffs": [0]}, "'lens.model' must be one of"),
    ("lens", {"model": "pinhole", "files": {"undistort_lut": "/etc/passwd"}}, "'lens.files' must be paths inside"),
    ("sensor", {"files": {"rgb": {"left": ["../../../etc/passwd"] * 4, "right": ["x.png"] * 4}}},
     "'sensor.files' must be"),
    ("sensor", {"files": {"raw": {"left": ["a.png"]}}}, "'sensor.files' must be"),
    ("imu", {"files": {"noisy": "/dev/zero", "ideal": "i.csv", "groundtruth": "g.csv"}}, "'imu.files' must be"),
    ("rig_motion", {"interpolation": "cubic"}, "'rig_motion.interpolation' must be one of"),
    ("rig_motion", {"rate_hz": 0}, "'rate_hz' must be a number"),
    ("timing", {"readout_s": -1}, "'readout_s' must be a number"),
    ("timing", "fast", "'timing' must be an object"),
])
def test_sensor_sections_of_a_manifest_are_checked(copy, tmp_path, capfd, key, value, message):
    """The sensor statements' manifest sections (lens, sensor images, IMU, rig motion, timing):
    a bad value or a path leaving the folder is refused when the manifest is read."""
    root = copy()
    m = json.loads((root / "manifest.json").read_text())
    m[key] = value
    write_manifest_dict(root, m)   # sealed again: the checks behind the seal are tested
    line = fails(capfd, "stereo-vo", root, "--out", tmp_path / "e.txt", "--quiet")
    assert line.startswith(f"error: {root / 'manifest.json'}: ") and message in line, line


@pytest.mark.parametrize("T", ["huge", "strings", "short"])
def test_moving_object_poses_are_checked(copy, tmp_path, capfd, T):
    root = copy()
    m = json.loads((root / "manifest.json").read_text())
    n = m["frames"]
    poses = [np.eye(4).tolist() for _ in range(n)]
    if T == "huge":
        poses[1][0][0] = 1e300
    elif T == "strings":
        poses[1][0][0] = "1"
    else:
        poses = poses[:-1]
    m["objects"] = [{"id": 7, "name": "car", "shape": "CUBOID", "moving": True, "motion": "keys", "T_world_obj": poses}]
    write_manifest_dict(root, m)   # sealed again: the checks behind the seal are tested
    capfd.readouterr()
    line = fails(capfd, "stereo-vo", root, "--out", tmp_path / "e.txt", "--quiet")
    assert line.startswith(f"error: {root / 'manifest.json'}: ") and ("objects" in line or "T_world_obj" in line), line
