"""A tiny render with every sensor effect and the IMU, read back through vo_reference:
per-row poses and times, IMU streams, EuRoC export (read by evo), ROS 2 bag (read by
rosbags), the mono pipeline's undistortion table; and the IMU noise model against the real
ADIS16448 stream of EuRoC."""
from __future__ import annotations


import numpy as np
import pytest

from render_support import cli_in_process, load_manifest, render_text, rendered

SCENE = """CAMERA resolution 64 48 focal 50 baseline 0.1
POSE 0 1 3 0 0 0
POSE 0.05 1.02 2.9 1 3 0.5
POSE 0.12 1.01 2.82 2 5 1
POSE 0.2 0.98 2.7 1 8 0.5
QUAD id 1 texture 3 vertices -3 0 -2  3 0 -2  3 3 -2  -3 3 -2
CUBOID id 10 texture 4 position -0.5 0.4 0 0 30 0 dim 0.8 0.8 0.8
TIMING rate 20 start 100 exposure 0.008 readout 0.02
LENS brown -0.2 0.05 0.001 0 fnumber 4 vignetting 1
SENSOR cfa rggb bits 12 readnoise 3 jpeg 90 seed 2
AUTOEXPOSURE speed 4
IMU rate 200 position 0.1 0 0.02 0 0 90 offset 0.001 seed 1
"""


@pytest.fixture(scope="module")
def render(tmp_path_factory):
    pytest.importorskip("bpy")
    pytest.importorskip("OpenEXR")
    from vo_reference.io.render import RenderSequence
    return RenderSequence(render_text(tmp_path_factory.mktemp("sensors"), SCENE, "--samples", "2", here=True))


pytestmark = pytest.mark.render


def test_render_reader_gives_rows_imu_and_lens(render):
    seq = render
    m = seq.manifest
    assert np.allclose(seq.timestamps_s, 100 + np.arange(4) / 20)
    rows = seq.row_times_s(1)
    assert len(rows) == 48 and rows[0] == pytest.approx(100.05 - 0.01 + 0.02 / 96)
    assert np.allclose(rows, seq.timestamps_s[1] + np.array(m["timing"]["row_offsets_s"]))
    Tr = seq.T_world_cam_rows(2, "right")
    assert np.allclose(seq.T_world_cam_row(2, 23.5, "right"), seq.T_world_cam("right")[2], atol=1e-12)
    assert not np.allclose(Tr[0], Tr[-1])
    assert m["rig_motion"]["interpolation"] == "c2_spline"
    noisy, ideal = seq.imu("noisy"), seq.imu("ideal")
    assert len(noisy["t_s"]) == 31 and noisy["t_s"][0] == pytest.approx(100.001)
    assert 0 < np.abs(noisy["gyro"] - ideal["gyro"]).max() < 0.1
    gt = seq.imu_groundtruth()
    T_imu0 = seq.T_world_cam("left")[0] @ np.array(m["imu"]["T_cam_imu"])
    assert np.allclose(gt["p"][0], T_imu0[:3, 3]) and gt["t_s"][0] == pytest.approx(100.0)
    assert seq.lens.model == "brown" and seq.undistortion_maps()[0].shape == (48, 64)
    exp = m["sensor"]["exposure_s"]
    # frame 0 converged (AUTOEXPOSURE's default start): the exposure that brings its own metered
    # brightness to the default target 0.18 at saturation 1, t_nom 0.008 (within 1/20 - 0.02 s, gain 1)
    e0 = 0.18 * 1.0 * 0.008 / m["sensor"]["metered"][0]
    assert 1e-5 < e0 < 0.03 and exp[0] == pytest.approx(e0, rel=1e-9) and m["sensor"]["gain"][0] == 1.0
    assert all(e is not None and e > 0 for e in exp)
    assert seq.raw_dn(0).dtype == np.uint16 and seq.raw_dn(0).max() < 4096
    assert seq.image_rgb(0).shape == (48, 64, 3)


def test_euroc_export_with_imu_is_read_by_evo(render, tmp_path):
    from evo.tools import file_interface
    from vo_reference.exporters.driver import export
    out = export(render.root, "euroc", tmp_path / "euroc", progress=False)
    mav = out / "mav0"
    for f in ("imu0/data.csv", "imu0/sensor.yaml", "cam0/data.csv", "cam1/sensor.yaml", "cam0/row_offsets.csv",
              "state_groundtruth_estimate0/data.csv"):
        assert (mav / f).is_file(), f
    traj = file_interface.read_euroc_csv_trajectory(str(mav / "state_groundtruth_estimate0" / "data.csv"))
    gt = render.imu_groundtruth()
    assert traj.num_poses == len(gt["t_s"])
    assert np.allclose(traj.positions_xyz, gt["p"]) and np.allclose(traj.timestamps, gt["t_s"])
    imu = np.loadtxt(mav / "imu0" / "data.csv", delimiter=",", skiprows=1)
    assert imu.shape == (31, 7) and int(imu[0, 0]) == 100_001_000_000
    cams = np.loadtxt(mav / "cam0" / "data.csv", delimiter=",", skiprows=1, dtype=str)
    assert [int(c) for c in cams[:, 0]] == [100_000_000_000, 100_050_000_000, 100_100_000_000, 100_150_000_000]
    yaml = (mav / "cam0" / "sensor.yaml").read_text()
    coeffs = [float(v) for v in yaml.split("distortion_coefficients: [")[1].split("]")[0].split(",")]
    assert "distortion_model: radial-tangential" in yaml and np.allclose(coeffs, [-0.2, 0.05, 0.001, 0.0])
    assert "rolling_shutter_readout_s: 0.02" in yaml
    pyyaml = pytest.importorskip("yaml")   # every sensor.yaml, the render's IMU file too, loads with PyYAML
    for p in [*mav.rglob("*.yaml"), render.root / "imu" / "sensor.yaml"]:
        assert isinstance(pyyaml.safe_load(p.read_text()), dict), p
    imu_yaml = pyyaml.safe_load((mav / "imu0" / "sensor.yaml").read_text())
    assert imu_yaml["rate_hz"] == 200 and np.allclose(np.array(imu_yaml["T_cam_imu"]["data"]).reshape(4, 4),
                                                      render.manifest["imu"]["T_cam_imu"])


def test_rosbag_export_reads_back(render, tmp_path):
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    from vo_reference.exporters.driver import export
    out = export(render.root, "rosbag", tmp_path / "ros", progress=False)
    ts = get_typestore(Stores.ROS2_HUMBLE)
    frame_ns = [int(round(t * 1e9)) for t in render.timestamps_s]
    with Reader(out / "bag") as r:
        counts = {c.topic: (c.msgtype, c.msgcount) for c in r.connections}
        assert counts["/cam0/image_raw"] == ("sensor_msgs/msg/Image", 4)
        assert counts["/cam1/camera_info"] == ("sensor_msgs/msg/CameraInfo", 4)
        assert counts["/imu0"] == ("sensor_msgs/msg/Imu", 31)
        assert counts["/tf"][0] == "tf2_msgs/msg/TFMessage" and counts["/groundtruth/pose"][1] == counts["/tf"][1]
        stamps = {}
        for c, t, raw in r.messages():
            msg = ts.deserialize_cdr(raw, c.msgtype)
            st = msg.transforms[0].header.stamp if c.topic in ("/tf", "/tf_static") else msg.header.stamp
            assert st.sec * 1_000_000_000 + st.nanosec == t
            stamps.setdefault(c.topic, []).append(t)
            if c.topic == "/cam0/image_raw" and t == frame_ns[0]:
                assert msg.encoding == "mono8" and msg.height == 48 and msg.width == 64
            if c.topic == "/cam0/camera_info":
                assert msg.distortion_model == "plumb_bob" and np.allclose(msg.d[:2], [-0.2, 0.05])
    assert stamps["/cam0/image_raw"] == frame_ns
    assert stamps["/tf_static"] == [min(min(v) for v in stamps.values())]     # once, at the bag's first instant
    noisy = render.imu("noisy")
    assert stamps["/imu0"] == [int(round(t * 1e9)) for t in noisy["t_s"]]


@pytest.mark.data
def test_noise_model_against_the_real_adis16448(shared_data):
    """The real stream (EuRoC V1_01, in flight: there is no stretch at rest) against our model
    with its datasheet densities: the real sensor never beats the model's noise floor, and
    our stream's white noise is the configured density (see docs/sensors.md, IMU)."""
    from blender_sesgen.render.sensor import imu
    from vo_reference.evaluate.allan import allan_deviation
    path = shared_data / "euroc" / "mav0" / "imu0" / "data.csv"
    if not path.is_file():
        pytest.skip(f"{path} not found")
    real = np.loadtxt(path, delimiter=",", skiprows=1)
    rate = 1e9 / np.median(np.diff(real[:, 0]))
    assert rate == pytest.approx(200.0, rel=1e-3)
    params = imu.ImuParams()
    w = 600                                                       # quietest 3 s of gyro
    stds = [np.linalg.norm(real[i:i + w, 1:4].std(0)) for i in range(0, len(real) - w, 50)]
    i = 50 * int(np.argmin(stds))
    taus, real_g = allan_deviation(real[i:i + w, 1:4], rate)
    n = 200 * 600
    ours = imu.add_noise(imu.ImuStream(np.arange(n) / 200.0, np.zeros((n, 3)), np.zeros((n, 3))), params)
    _, our_g = allan_deviation(ours.gyro, 200.0, taus_s=taus)
    floor = params.gyro_noise / np.sqrt(taus)
    assert (real_g.min(axis=1) >= floor).all()
    assert np.allclose(our_g[:5].mean(axis=1), floor[:5], rtol=0.05)


def test_flow_of_a_distorted_render_follows_the_lens(render):
    """Flow between distorted images against the render's own ground truth: a pixel moved by
    the flow lands on the same object in the next frame (rendered ids, nearest pixel), and
    the target depth there is the moved point's depth; the pinhole formula would not."""
    from vo_reference.groundtruth.flow import flow_from_depth, sequence_flow
    seq = render
    z0, z1 = seq.depth(0), seq.depth(1)
    ids0, ids1 = seq.ids(0), seq.ids(1)
    H, W = z0.shape
    v, u = np.mgrid[0:H, 0:W]

    def agreement(fl):
        ok = fl.noc
        x = np.rint(u + fl.flow[..., 0])[ok].astype(int)
        y = np.rint(v + fl.flow[..., 1])[ok].astype(int)
        inside = (x >= 0) & (x < W) & (y >= 0) & (y < H)
        return ok.sum(), np.mean(ids1[y[inside], x[inside]] == ids0[ok][inside])

    n, same = agreement(sequence_flow(seq, 0, 1))
    T = seq.T_world_cam("left")
    _, same_pinhole = agreement(flow_from_depth(z0, seq.K, T[0], T[1], z1))
    assert n > 0.5 * H * W and same > 0.97, same
    assert same >= same_pinhole


def _same_frames(render, out, frames):
    """The sensor images of ``frames`` in ``out`` are byte-identical to the one-run render's,
    with the same exposure, gain and metered brightness."""
    m = load_manifest(out)
    for key in ("exposure_s", "gain"):
        assert [m["sensor"][key][k] for k in frames] == [render.manifest["sensor"][key][k] for k in frames], key
    # metered: the frames before the last one rendered there (frame k's exposure follows 0..k-1
    # only), not from it on (unless another writer of the folder metered further)
    last, full, got = max(frames), render.manifest["sensor"]["metered"], m["sensor"]["metered"]
    assert got[:last] == full[:last]
    assert all(v is None or v == f for v, f in zip(got[last:], full[last:]))
    for kind in ("raw", "rgb"):
        for view in ("left", "right"):
            for k in frames:
                rel = render.manifest["sensor"]["files"][kind][view][k]
                assert (out / rel).read_bytes() == (render.root / rel).read_bytes(), rel


def test_auto_exposure_does_not_depend_on_how_the_frames_are_split(render, tmp_path):
    """The metering pass fixes every frame's exposure before the frames render: frames 0:2
    then --resume, frame 2 alone in a new folder, and two chunks rendering at the same time
    into one folder (what a farm does) give the exposures and the bytes of one run."""
    import os
    import subprocess
    from render_support import REPO, render_cmd
    script = render.root.parent / "s.ses"
    whole = render.manifest["sensor"]["metered"]     # the last frame's: no exposure follows it
    assert all(v is not None and v > 0 for v in whole[:-1]) and whole[-1] is None
    assert "metering pass" in render.manifest["sensor"]["autoexposure"]["metering"]
    resumed = tmp_path / "resumed"
    # split and resumed in this process (the render command's own code); the concurrent chunks below: children
    assert cli_in_process("blender_sesgen", "render", script, "--out", resumed, "--samples", "2", "--frames", "0:2",
                          "--quiet").returncode == 0
    assert cli_in_process("blender_sesgen", "render", script, "--out", resumed, "--samples", "2", "--resume",
                          "--quiet").returncode == 0
    _same_frames(render, resumed, range(4))
    alone = tmp_path / "alone"
    rendered(script, alone, "--samples", "2", "--frames", "2:3", here=True)
    _same_frames(render, alone, [2])
    chunks = tmp_path / "chunks"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    procs = [subprocess.Popen(render_cmd(script, "--out", chunks, "--samples", "2", "--frames", f, "--resume",
                                         "--quiet"), cwd=REPO, env=env, stderr=subprocess.PIPE, text=True)
             for f in ("0:2", "2:4")]
    for proc in procs:
        assert proc.wait(timeout=900) == 0, proc.stderr.read()
    _same_frames(render, chunks, range(4))


def test_a_chunk_beginning_after_another_ended_keeps_that_chunks_exposures(render, tmp_path):
    """A chunk prepared (built, metered) while its folder was still empty and beginning only
    after another chunk rendered frames 0:2 there and ended keeps the exposure, gain and metered
    brightness that chunk recorded (the order CI met once: frames 0:2 done while 2:4 metered;
    the late chunk's manifest wrote them over with nulls)."""
    import argparse
    from blender_sesgen.commands.render import add_arguments, render_options
    from blender_sesgen.render.job import RenderJob
    script, out = render.root.parent / "s.ses", tmp_path / "chunks"
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    a = parser.parse_args([str(script), "--out", str(out), "--samples", "2", "--frames", "2:4", "--resume"])
    late = RenderJob.prepare(a.scene, a.out, render_options(a), resume=True)
    late.build()
    manifest = late.new_manifest()            # the folder holds nothing yet
    rendered(script, out, "--samples", "2", "--frames", "0:2", "--resume", here=True)
    late.folder.begin(late.plan, manifest, resume=True, force=False)
    late.folder.release()
    _same_frames(render, out, range(2))


def _chunk(script, out, frames: str):
    """A RenderJob of ``frames`` ("a:b", --resume) into ``out``, as a farm's chunk runs it."""
    import argparse
    from blender_sesgen.commands.render import add_arguments, render_options
    from blender_sesgen.render.job import RenderJob
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    a = parser.parse_args([str(script), "--out", str(out), "--samples", "2", "--frames", frames, "--resume"])
    return RenderJob.prepare(a.scene, a.out, render_options(a), resume=True)


def _killed_chunk(script, out, frames: str) -> None:
    """``frames`` rendered into ``out`` by a chunk killed -9 after its last frame was committed:
    in this process under the name of a pid that has ended, its lock then removed (what the farm
    does for a killed render), never released: its completion log and per-frame state files are
    all that records its frames."""
    import socket
    import subprocess
    import sys
    from blender_sesgen.render.locks import _safe
    ended = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                               text=True, check=True).stdout)
    job = _chunk(script, out, frames)
    job.folder.locks.writer = f"{_safe(socket.gethostname())}-{ended}"
    for k in job.pending_frames():
        job.render_frame(k)
    job.folder._log.close()
    job.folder.locks.drop()


def test_a_chunk_prepared_before_a_killed_chunk_began_keeps_that_chunks_exposures(render, tmp_path):
    """A chunk prepared (metered) while its folder was empty that begins after another chunk
    rendered frames 0:2 there and was killed -9 before it ended: the killed chunk's exposures
    are only in its per-frame state files (its manifest was written before its frames; its
    log holds completion and checksums). They are kept (the old code recorded frames 0:2
    complete with null exposure, gain and metered brightness, and removed the dead log)."""
    script, out = render.root.parent / "s.ses", tmp_path / "chunks"
    late = _chunk(script, out, "2:4")
    late.build()
    manifest = late.new_manifest()            # the folder holds nothing yet
    _killed_chunk(script, out, "0:2")
    late.folder.begin(late.plan, manifest, resume=True, force=False)
    late.folder.release()
    _same_frames(render, out, range(2))


def test_a_chunk_ending_after_a_killed_one_records_its_exposures(render, tmp_path):
    """Two chunks begun together; the one of frames 0:2 is killed -9 after its frames, the other
    ends and takes the dead chunk's completion log into the manifest: with the exposures that
    chunk recorded in its state files (the old code: frames 0:2 complete, exposures null)."""
    script, out = render.root.parent / "s.ses", tmp_path / "chunks"
    other = _chunk(script, out, "2:4")
    other.begin()
    _killed_chunk(script, out, "0:2")
    other.folder.release()
    _same_frames(render, out, range(2))


def test_consolidating_a_folder_after_a_killed_chunk_records_its_exposures(render, tmp_path):
    """The farm's consolidation (``verify_task``: the logs into the manifest once every chunk
    has ended) of a folder whose only chunk was killed -9 after its frames: the exposures from
    its state files (the old code: frames 0:2 complete, exposures null)."""
    script, alone = render.root.parent / "s.ses", tmp_path / "alone"
    _killed_chunk(script, alone, "0:2")
    from blender_sesgen.render.folder import OutputFolder
    OutputFolder(alone).consolidate()
    _same_frames(render, alone, range(2))


def test_a_reader_of_a_folder_left_by_a_killed_chunk_sees_its_exposures(render, tmp_path):
    """A folder whose only chunk was killed -9 after its frames and never consolidated (a reader
    during a farm's render, or after a farm that was stopped): every reader of the on-disk
    contract (``Manifest.read``, vo_reference's RenderSequence) sees the frames complete WITH
    the exposure, gain and metered brightness their render recorded in its state files, as the
    manifest promises (the old reader merged the logs' completion only: exposures null)."""
    from blender_sesgen.contract.manifest import Manifest
    from vo_reference.io.render import RenderSequence
    script, out = render.root.parent / "s.ses", tmp_path / "killed"
    _killed_chunk(script, out, "0:2")
    assert list((out / ".sesgen").glob("done-*.jsonl")), "the dead chunk's log is still there (not consolidated)"
    import json
    on_disk = json.loads((out / "manifest.json").read_text())   # written before the frames
    assert on_disk["frames_complete"][:2] == [False, False] and on_disk["sensor"]["exposure_s"][:2] == [None, None]
    whole = render.manifest["sensor"]
    m = Manifest.read(out)
    assert m.frames_complete == [True, True, False, False]
    s = m.sections.sensor
    for key, n in (("exposure_s", 2), ("gain", 2), ("metered", 1)):   # metered: frames before the chunk's last
        assert list(getattr(s, key))[:n] == whole[key][:n], key
        assert m.extra["sensor"][key][:n] == whole[key][:n], key
    seq = RenderSequence(out)
    assert seq.manifest["sensor"]["exposure_s"][:2] == whole["exposure_s"][:2]
    assert [seq.frame_complete(k) for k in range(4)] == [True, True, False, False]
