"""The sensor effects rendered by Cycles, measured against independent oracles (tiny images).

- rolling shutter: checkerboard corners land where the per-row pose projects them;
- motion blur: the blurred frame equals the average of sharp sub-frame renders over the
  exposure, and its ground truth equals the sharp render at mid-exposure;
- lens distortion: 3-D corners projected through the lens model land where the distorted
  render shows them; depth is planar; the lookup table undistorts back to the pinhole render;
- every effect off: pixel-identical to a plain render; sensor images reproducible.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from render_support import read_exr, render_here
from sensor_scenes import checkerboard_lines, grey, inner_corners, project_rows, refine_corners

from blender_sesgen.contract import se3
from blender_sesgen.contract.lens import Lens
from blender_sesgen.contract.rig_motion import RigMotion
from blender_sesgen.contract.timing import row_time_s
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")
cv2 = pytest.importorskip("cv2")

PAN = ["EGO 0.05 0.01 0 1 6 0", "EGO 0.05 0.01 0 1 6 0"]      # fast pan: 120 deg/s at 20 Hz


def _render(tmp: Path, name: str, lines: list[str], *args) -> tuple[Path, dict]:
    """``sesgen render`` of ``lines`` in this process (``render_here``: the subject is what the
    render holds; the render command's process is test_render_cli's and test_render_reliability's)."""
    script = tmp / f"{name}.ses"
    script.write_text("\n".join(lines) + "\n")
    out = tmp / name
    render_here(script, out, "--quiet", *args)
    return out, json.loads((out / "manifest.json").read_text())


def _board_scene(width=320, height=240, focal=240, extra=(), motion=PAN, samples=64, start="0.2 1.0 0.5"):
    return ([f"CAMERA resolution {width} {height} focal {focal} baseline 0", f"START position {start}",
             "WORLD colour 0 0 0", f"RENDER samples {samples}"] + list(extra) + checkerboard_lines() + list(motion))


def _assert_same_exrs(out_a: Path, m_a: dict, out_b: Path, m_b: dict) -> None:
    """Every channel of every EXR of render a equals render b's (the frames both rendered)."""
    assert m_a["frames_complete"] == m_b["frames_complete"]
    for view in m_a["views"]:
        for k in _rendered(m_a):
            a, b = read_exr(out_a / m_a["files"][view][k]), read_exr(out_b / m_b["files"][view][k])
            assert a.keys() == b.keys()
            for name in a:
                assert np.array_equal(a[name], b[name], equal_nan=True), (view, k, name)


def _rendered(m: dict) -> list[int]:
    return [k for k, done in enumerate(m["frames_complete"]) if done]


def _psnr(a, b, peak=1.0):
    return 10 * np.log10(peak**2 / np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2))

@pytest.mark.parametrize("timing", [["TIMING rate 20 exposure 0.03"], ["TIMING rate 20 exposure 0.02 readout 0.03"],
                                    ["TIMING rate 20 exposure 0.03", "SENSOR seed 1", "AUTOEXPOSURE"]],
                         ids=["blur", "rolling", "metering"])
def test_sensor_path_with_an_exposure_preview_renders_the_plain_pixels(tmp_path, timing):
    """The sensor path's persistent session with ``draft``'s samples (enough to share the
    exposure preview's session on the plain path) and an automatic exposure: the preview
    must not share it (synchronised without motion blur, it changed every blurred pixel);
    motion blur, a rolling shutter and a moving object, every channel as a fresh session.
    With a sensor auto-exposure the metering pass reuses the preview's session: the same
    exposure, the same metered brightness of every frame, the same pixels."""
    from render_support import oracle_script
    lines = oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4)).splitlines()
    lines += [*timing, "MOVE id 5 twist 0.04 0 0.02 0 4 0"]
    two = ("--frames", "0:2")                # frame 1: the persistent session's second frame
    out_a, m_a = _render(tmp_path, "plain", lines, "--quality", "draft", "--plain-pipeline", *two)
    out_b, m_b = _render(tmp_path, "fast", lines, "--quality", "draft", *two)
    assert m_a["render"]["pipeline"]["persistent_data"] is False
    assert m_b["render"]["pipeline"]["persistent_data"] is True
    assert m_b["timing"]["motion_blur"] and m_a["files"] == m_b["files"]
    assert m_a["render"]["exposure"] == m_b["render"]["exposure"]
    if "AUTOEXPOSURE" in timing:
        assert len(m_b["sensor"]["metered"]) == m_b["frames"] > 1
        assert m_a["sensor"]["metered"] == m_b["sensor"]["metered"]
        assert m_a["sensor"]["exposure_s"] == m_b["sensor"]["exposure_s"]
    _assert_same_exrs(out_a, m_a, out_b, m_b)
    blurred = read_exr(out_b / m_b["files"]["left"][1])
    assert np.ptp(blurred["ViewLayer.Combined.R"]) > 0


def test_rolling_shutter_ground_truth_does_not_depend_on_the_exposure(tmp_path):
    """A rolling shutter's ground truth shows each row at its own capture instant, whatever
    the frame's exposure (an auto-exposure changes it from frame to frame): depth and ids of two
    renders that differ only in the exposure are equal, and equal the ``gt`` preset's (no beauty,
    no exposure at all). Session 19's code keyed the beauty's shutter instants beside the rows'
    for both renders, and Blender interpolating between them moved depth by up to 1e-4."""
    from render_support import oracle_script
    base = oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4)).splitlines()
    base += ["MOVE id 5 twist 0.04 0 0.02 0 4 0"]
    two = ("--frames", "0:2")
    runs = [_render(tmp_path, name, base + [f"TIMING rate 20 exposure {e} readout 0.03"], *q, *two)
            for name, e, q in [("short", 0.004, ("--samples", "2")), ("long", 0.021, ("--samples", "2")),
                               ("gt", 0.004, ("--quality", "gt"))]]
    (out_a, m_a) = runs[0]
    assert m_a["timing"]["rolling_shutter"]
    gt_names = [m_a["depth"]["channel"], m_a["segmentation"]["channel"]]
    for out_b, m_b in runs[1:]:
        for view in m_a["views"]:
            for k in _rendered(m_a):
                a, b = read_exr(out_a / m_a["files"][view][k]), read_exr(out_b / m_b["files"][view][k])
                for name in gt_names:
                    assert np.array_equal(a[name], b[name], equal_nan=True), (m_b["files"][view][k], name)


def test_rolling_shutter_corners_land_where_the_row_poses_project_them(tmp_path):
    readout = 0.04
    out, m = _render(tmp_path, "rs", _board_scene(extra=[f"TIMING rate 20 readout {readout}"], samples=32))
    K = np.array(m["K"])
    W, H = m["resolution"]
    assert m["timing"]["rolling_shutter"] and len(m["timing"]["row_offsets_s"]) == H
    motion = RigMotion(np.array(m["poses"]["left"]), 20.0, 0.0, m["rig_motion"]["interpolation"])
    X = inner_corners()
    for k in range(m["frames"]):
        img = grey(read_exr(out / m["files"]["left"][k]))
        tk = m["timestamps"][k]
        rows = project_rows(X, lambda v: motion.T_world_cam(row_time_s(tk, v, H, readout)), K, H)
        frame = project_rows(X, lambda v: motion.T_world_cam(np.full(len(v), tk)), K, H)
        seen = (rows[:, 0] > 8) & (rows[:, 0] < W - 9) & (rows[:, 1] > 8) & (rows[:, 1] < H - 9)
        found = refine_corners(img, rows[seen])
        err = np.linalg.norm(found - rows[seen], axis=1)
        print(f"frame {k}: {seen.sum()} corners, per-row pose error median {np.median(err):.4f} px, "
              f"max {err.max():.4f} px; one pose for the frame: {np.median(np.linalg.norm(found - frame[seen], axis=1)):.3f} px")
        assert seen.sum() >= 30
        assert err.max() <= 0.1                                              # the bound
        assert np.median(np.linalg.norm(found - frame[seen], axis=1)) > 1.0   # the effect is real
        # the ground truth shows each row at its capture time: around each corner the four
        # pixels carry two square ids (black squares) and the board's where the rows predict
        ids = np.rint(read_exr(out / m["files"]["left"][k])[m["segmentation"]["channel"]]).astype(int)
        for x, y in rows[seen]:
            patch = ids[int(np.floor(y)):int(np.floor(y)) + 2, int(np.floor(x)):int(np.floor(x)) + 2]
            assert 1 in patch and (patch > 1).any(), (x, y, patch)


def _pose_lines(T_world_cam: np.ndarray) -> list[str]:
    out = []
    for T in T_world_cam:
        rx, ry, rz = se3.R_to_euler_xyz_deg(T[:3, :3] @ np.diag([1.0, -1.0, -1.0]))
        out.append("POSE " + " ".join(f"{v:.17g}" for v in (*T[:3, 3], rx, ry, rz)))
    return out


def test_motion_blur_equals_the_average_of_sharp_subframes(tmp_path):
    exposure, rate, M, base = 0.025, 20.0, 24, 16                    # half a frame: ~3 px of blur
    scene = _board_scene(80, 60, 60, extra=[f"TIMING rate {rate} exposure {exposure}"])
    out, m = _render(tmp_path, "blur", scene, "--frames", "1:2", "--samples", str(M * base))
    motion = RigMotion(np.array(m["poses"]["left"]), rate, 0.0, m["rig_motion"]["interpolation"])
    t1 = m["timestamps"][1]
    sub_t = t1 - exposure / 2 + (np.arange(M) + 0.5) / M * exposure    # midpoint rule over the exposure
    sharp_scene = [ln for ln in _board_scene(80, 60, 60) if not ln.startswith(("EGO", "START"))]
    out_s, m_s = _render(tmp_path, "subframes", sharp_scene + _pose_lines(motion.T_world_cam(sub_t)),
                         "--samples", str(base))
    names = [f"ViewLayer.Combined.{c}" for c in "RGB"]
    blurred = np.stack([read_exr(out / m["files"]["left"][1])[n] for n in names], -1)
    average = np.mean([np.stack([read_exr(out_s / f)[n] for n in names], -1) for f in m_s["files"]["left"]], axis=0)
    psnr = _psnr(np.clip(blurred, 0, 1), np.clip(average, 0, 1))
    print(f"motion blur vs {M} averaged sub-frames: PSNR {psnr:.1f} dB")
    assert psnr >= 35.0
    # ... and much further from the sharp frame at mid-exposure
    out_m, m_m = _render(tmp_path, "mid", sharp_scene + _pose_lines(motion.T_world_cam([t1])), "--samples", str(M * base))
    sharp_mid = read_exr(out_m / m_m["files"]["left"][0])
    print(f"sharp frame at mid-exposure vs the blurred: PSNR "
          f"{_psnr(np.clip(np.stack([sharp_mid[n] for n in names], -1), 0, 1), np.clip(blurred, 0, 1)):.1f} dB")
    assert _psnr(np.clip(np.stack([sharp_mid[n] for n in names], -1), 0, 1), np.clip(blurred, 0, 1)) < psnr - 8
    # ground truth of the blurred frame = the sharp render at mid-exposure (depth and ids)
    gt = read_exr(out / m["files"]["left"][1])
    assert np.array_equal(np.rint(gt[m["segmentation"]["channel"]]), np.rint(sharp_mid[m_m["segmentation"]["channel"]]))
    z, z_mid = gt[m["depth"]["channel"]], sharp_mid[m_m["depth"]["channel"]]
    assert np.abs(z - z_mid).max() <= 1e-5 * np.abs(z_mid).max()


BROWN = "LENS brown -0.3 0.09 0.001 -0.0015 -0.01"
FISHEYE = "LENS fisheye -0.02 0.01 -0.004 0.0005"


@pytest.mark.parametrize("lens_line", [BROWN, FISHEYE], ids=["brown", "fisheye"])
def test_distorted_render_matches_the_lens_model(tmp_path, lens_line):
    still = ["EGO 0 0 0 0 0 0"]
    out, m = _render(tmp_path, "lens", _board_scene(extra=[lens_line], motion=still, samples=32, start="0 1 -1.2"),
                     "--frames", "0:1")                              # a still camera: frame 0 is all it shows
    lens = Lens.from_K(m["lens"]["model"], m["lens"]["coeffs"], np.array(m["K"]))
    W, H = m["resolution"]
    T = np.array(m["poses"]["left"][0])
    X = inner_corners()
    Xc = (np.linalg.inv(T) @ np.c_[X, np.ones(len(X))].T).T[:, :3]
    px = lens.project(Xc)
    exr = read_exr(out / m["files"]["left"][0])
    found = refine_corners(grey(exr), px)
    err = np.linalg.norm(found - px, axis=1)
    pinhole = (np.array(m["K"]) @ (Xc / Xc[:, 2:]).T).T[:, :2]
    print(f"{m['lens']['model']}: corner error median {np.median(err):.4f} px, max {err.max():.4f} px "
          f"(distortion moves them by up to {np.abs(pinhole - px).max():.1f} px)")
    assert np.median(err) <= 0.05 and np.abs(pinhole - px).max() > 5
    # planar depth at the distorted pixel centres: the board (fronto-parallel) is at z = 2.5 / 2.501
    ids = np.rint(exr[m["segmentation"]["channel"]]).astype(int)
    z = exr[m["depth"]["channel"]]
    board_z = -3.0 - T[2, 3]
    depth_of = {1: -board_z}
    squares = ids > 1
    assert np.abs(z[ids == 1] - depth_of[1]).max() < 1e-4 * depth_of[1]
    assert np.abs(z[squares] - (depth_of[1] - 0.001)).max() < 1e-4 * depth_of[1]
    # the manifest's files: the OpenCV calibration and the RobotCar lookup table
    fs = cv2.FileStorage(str(out / m["lens"]["files"]["opencv"]["left"]), cv2.FILE_STORAGE_READ)
    assert np.allclose(fs.getNode("distortion_coefficients").mat().ravel(), lens.coeffs)
    assert (out / m["lens"]["files"]["undistort_lut"]).stat().st_size == 2 * 8 * W * H


def test_lookup_table_undistorts_to_the_pinhole_render(tmp_path):
    from vo_reference.camera.undistort import read_lut, remap
    still = ["EGO 0 0 0 0 0 0"]
    # emissive surfaces only: the renders' sole noise is the pixel filter's, so the comparison
    # measures the lens and the table, not path-tracing noise
    extra = ["MATERIAL name tex colour 0 0 0 texture 4 emission 1 1 1 emission_strength 1",
             "CUBOID id 90 material tex position 0.6 0.9 -2 20 30 0 dim 0.5 0.5 0.5"]
    scene = _board_scene(samples=32, motion=still, start="0 1 -1.2") + extra
    out_p, m_p = _render(tmp_path, "pinhole", scene, "--frames", "0:1")       # a still camera: frame 0
    out_d, m_d = _render(tmp_path, "distorted", scene + [BROWN], "--frames", "0:1")
    W, H = m_d["resolution"]
    names = [f"ViewLayer.Combined.{c}" for c in "RGB"]
    pin = np.clip(np.stack([read_exr(out_p / m_p["files"]["left"][0])[n] for n in names], -1), 0, 1)
    dist = np.clip(np.stack([read_exr(out_d / m_d["files"]["left"][0])[n] for n in names], -1), 0, 1)
    mx, my = read_lut(out_d / m_d["lens"]["files"]["undistort_lut"], W, H)
    und = remap(dist.astype(np.float32), mx, my)
    inner = (slice(24, H - 24), slice(32, W - 32))
    psnr = _psnr(und[inner], pin[inner])
    print(f"LUT-undistorted vs pinhole render: PSNR {psnr:.1f} dB (distorted vs pinhole {_psnr(dist[inner], pin[inner]):.1f} dB)")
    assert psnr >= 35.0


def test_effects_off_render_is_pixel_identical_and_sensor_images_are_reproducible(tmp_path):
    from render_support import oracle_script
    base = oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4)).splitlines()
    out_a, m_a = _render(tmp_path, "plain", base, "--samples", "2")
    # statements whose effects leave the rendering alone: a frame rate, optics and a sensor
    # (they act on the sensor images only), an IMU
    extra = ["TIMING rate 30", "LENS fnumber 4 vignetting 1 chromatic 0.3",
             "SENSOR cfa gbrg bits 10 readnoise 2 prnu 0.01 dsnu 1 rownoise 0.3 dark 5 seed 4", "IMU"]
    out_b, m_b = _render(tmp_path, "sensor", base + extra, "--samples", "2")
    _assert_same_exrs(out_a, m_a, out_b, m_b)
    assert m_b["timestamps"] == [k / 30 for k in range(m_b["frames"])] and "timing" not in m_a
    # sensor images: listed in the manifest, 10-bit values, the same seed gives the same noise
    out_c, m_c = _render(tmp_path, "again", base + extra, "--samples", "2")
    for kind in ("raw", "rgb"):
        for view in m_b["views"]:
            for rel in m_b["sensor"]["files"][kind][view]:
                a = cv2.imread(str(out_b / rel), cv2.IMREAD_UNCHANGED)
                assert np.array_equal(a, cv2.imread(str(out_c / rel), cv2.IMREAD_UNCHANGED)), rel
                if kind == "raw":
                    assert a.dtype == np.uint16 and a.ndim == 2 and a.max() <= 1023
    left = cv2.imread(str(out_b / m_b["sensor"]["files"]["raw"]["left"][0]), cv2.IMREAD_UNCHANGED)
    right = cv2.imread(str(out_b / m_b["sensor"]["files"]["raw"]["right"][0]), cv2.IMREAD_UNCHANGED)
    assert not np.array_equal(left, right)


@pytest.mark.parametrize("start", ["converged", "nominal"])
def test_auto_exposure_answers_a_step_in_brightness_as_documented(tmp_path, start):
    """The camera slides from a glowing wall of radiance 1 to one of 0.1 after frame 4 (film
    exposure fixed at 1, nothing else in view): the metering pass reads each frame's radiance
    (the oracle: the wall's emission, the whole image), and log(t*g) moves towards
    log(target * saturation * t_nom / m) by 1 - exp(-speed / rate) per frame, one frame late
    (docs/sensors.md, Optics, exposure and the raw sensor), from frame 0's steady state
    target * t_nom / 1 (``start converged``, the default: the camera ran before the sequence)
    or from t_nom (``start nominal``). A culled render of three later frames alone meters the same."""
    n, step, rate, speed, target, t_nom = 12, 5, 20.0, 3.0, 0.18, 0.004
    poses = [f"POSE {-10 if k < step else 10} 0 0 0 0 0" for k in range(n)]
    lines = ["CAMERA resolution 32 24 focal 20 baseline 0", "LOOK exposure 0", "WORLD colour 0 0 0",
             "RENDER samples 1",
             "MATERIAL name bright colour 0 0 0 emission 1 1 1 emission_strength 1 roughness 1 specular 0",
             "MATERIAL name dim colour 0 0 0 emission 1 1 1 emission_strength 0.1 roughness 1 specular 0",
             "QUAD id 1 material bright vertices -30 -20 -5  0 -20 -5  0 20 -5  -30 20 -5",
             "QUAD id 2 material dim vertices 0 -20 -5  30 -20 -5  30 20 -5  0 20 -5",
             f"TIMING rate {rate:g} exposure {t_nom} blur off", "SENSOR seed 1",
             f"AUTOEXPOSURE target {target} speed {speed} start {start}"] + poses
    out, m = _render(tmp_path, "step", lines)
    metered = np.array(m["sensor"]["metered"][:-1])     # the last frame's is not metered (null)
    radiance = np.where(np.arange(n) < step, 1.0, 0.1)
    assert np.allclose(metered, radiance[:-1], rtol=0.01), metered
    assert m["sensor"]["metered"][-1] is None
    E = np.array(m["sensor"]["exposure_s"]) * np.array(m["sensor"]["gain"])
    alpha = 1 - np.exp(-speed / rate)
    logE = [np.log(t_nom if start == "nominal" else target * t_nom / radiance[0])]
    for k in range(1, n):     # frame k answers frame k-1's metering; none of these clip at 1/rate
        logE.append(logE[-1] + alpha * (np.log(target * t_nom / radiance[k - 1]) - logE[-1]))
    assert np.allclose(np.log(E), logE, atol=0.01 * alpha), (np.log(E), logE)
    assert E[step] == pytest.approx(E[step - 1] * (target * t_nom / E[step - 1]) ** alpha, rel=0.01)
    if start == "nominal":
        assert E[step] < E[step - 1] < E[step + 1]   # frame 5 still answers the bright wall: one frame late
    else:   # steady from frame 0 on; frame 5 still answers the bright wall: one frame late
        assert E[step] == pytest.approx(E[0], rel=1e-5) and E[step + 1] > 1.2 * E[step]
    # frames 6-8 alone and culled (built: what any frame sees, for the metering pass): the same
    # schedule; the last rendered frame and those after it are not metered
    _, mc = _render(tmp_path, "step_culled", lines, "--cull", "--frames", "6:9")
    assert mc["sensor"]["metered"][:8] == m["sensor"]["metered"][:8]
    assert mc["sensor"]["metered"][8:] == [None] * (n - 8)
    assert mc["sensor"]["exposure_s"][6:9] == m["sensor"]["exposure_s"][6:9]


@pytest.mark.parametrize("extra", [
    ["TIMING rate 20 exposure 0.02"],                                   # motion blur
    ["TIMING rate 20 exposure 0.004 readout 0.03", BROWN + " fnumber 4 vignetting 1"]],   # rolling shutter, lens
    ids=["blur", "rolling-lens"])
def test_sensor_path_in_the_persistent_session_renders_the_plain_pixels(tmp_path, extra):
    """The sensor path's renders in one persistent multiview session (the scene synchronised
    once, the sharp ground truth of both views in one render) give every channel of every
    EXR exactly as a fresh Cycles session per render (``--plain-pipeline``)."""
    from render_support import oracle_script
    lines = oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4)).splitlines() + extra
    two = ("--frames", "0:2")                # frame 1: the persistent session's second frame
    out_a, m_a = _render(tmp_path, "plain", lines, "--samples", "2", "--plain-pipeline", *two)
    out_b, m_b = _render(tmp_path, "fast", lines, "--samples", "2", *two)
    assert m_a["render"]["pipeline"]["persistent_data"] is False and m_b["render"]["pipeline"]["persistent_data"] is True
    _assert_same_exrs(out_a, m_a, out_b, m_b)


def test_gt_preset_with_a_shutter_is_the_sharp_frame(tmp_path):
    """``--quality gt`` (one flat sample: no shutter to integrate) renders the sharp frame once
    for both views: every channel equals the render without the shutter, and its ground truth
    is the blurred preset's."""
    from render_support import oracle_script
    base = oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4)).splitlines()
    two = ("--frames", "0:2")
    out_a, m_a = _render(tmp_path, "sharp", base + ["TIMING rate 20"], "--quality", "gt", *two)
    out_b, m_b = _render(tmp_path, "shutter", base + ["TIMING rate 20 exposure 0.02"], "--quality", "gt", *two)
    out_c, m_c = _render(tmp_path, "blurred", base + ["TIMING rate 20 exposure 0.02"], "--samples", "2", *two)
    assert m_b["render"]["pipeline"]["views_per_render"] == 2
    for view in m_a["views"]:
        for k in _rendered(m_a):
            a, b = read_exr(out_a / m_a["files"][view][k]), read_exr(out_b / m_b["files"][view][k])
            c = read_exr(out_c / m_c["files"][view][k])
            assert a.keys() == b.keys()
            for name in a:
                assert np.array_equal(a[name], b[name], equal_nan=True), (view, k, name)
                if "Combined" not in name and "Noisy" not in name and name in c:
                    assert np.array_equal(b[name], c[name], equal_nan=True), (view, k, name)
