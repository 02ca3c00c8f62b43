"""Verification studies end to end, with real renders and real systems as child processes
(docs/studies.md): controlled variants, render reuse, failing systems, an external OpenCV
stereo VO reading the KITTI layout, compare, the report, a study killed and resumed, the
sensor factors' physics measured on the images, and a third-party estimator from PyPI
(pycolmap) run through the harness. The harness, the kill and the SIGTERM run on a real
local Ray; the physics, pycolmap, compare's second version and the resume after the kill run
``--no-ray`` (the tasks from the study's process: no Ray start-up), and a finished study run
again starts none."""
from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from render_support import cli_in_process, processes_mentioning, run_loaded
from study_scenes import NOISY, PERFECT, ROOM, WALL, WALL_FOCAL, WALL_SPEED, WALL_Z, study_file, world, write

pytestmark = [pytest.mark.render, pytest.mark.slow]

REPO = Path(__file__).resolve().parents[1]

OPENCV_VO = r'''
"""A small stereo VO with OpenCV, reading one KITTI odometry folder: SGBM depth, LK tracks, PnP."""
import sys
from pathlib import Path
import cv2
import numpy as np

seq, out = Path(sys.argv[1]), sys.argv[2]
P = {l.split(":")[0]: np.array(l.split()[1:], float).reshape(3, 4) for l in open(seq / "calib.txt") if ":" in l}
K = P["P0"][:, :3]
B = -P["P1"][0, 3] / K[0, 0]
left = sorted((seq / "image_0").glob("*.png"))
right = sorted((seq / "image_1").glob("*.png"))
sgbm = cv2.StereoSGBM_create(0, 32, 5, P1=8 * 25, P2=32 * 25, uniquenessRatio=5)
T = np.eye(4)
poses = [T.copy()]
for k in range(len(left) - 1):
    a, b = cv2.imread(str(left[k]), 0), cv2.imread(str(right[k]), 0)
    c = cv2.imread(str(left[k + 1]), 0)
    disp = sgbm.compute(a, b).astype(np.float32) / 16
    pts = cv2.goodFeaturesToTrack(a, 300, 0.01, 3)
    step = np.eye(4)
    if pts is not None:
        nxt, st, _ = cv2.calcOpticalFlowPyrLK(a, c, pts, None)
        p0, p1 = pts[st[:, 0] == 1, 0], nxt[st[:, 0] == 1, 0]
        d = disp[p0[:, 1].astype(int), p0[:, 0].astype(int)]
        ok = d > 1
        if ok.sum() >= 6:
            Z = K[0, 0] * B / d[ok]
            X = np.c_[(p0[ok, 0] - K[0, 2]) * Z / K[0, 0], (p0[ok, 1] - K[1, 2]) * Z / K[1, 1], Z]
            good, r, t, _ = cv2.solvePnPRansac(X, p1[ok], K, None, reprojectionError=2.0)
            if good:
                step[:3, :3], step[:3, 3] = cv2.Rodrigues(r)[0], t[:, 0]
    T = T @ np.linalg.inv(step)
    poses.append(T.copy())
np.savetxt(out, np.array([p[:3].ravel() for p in poses]))
'''

PERFECT_SYSTEM = """
[[systems]]
name = "perfect"
cmd = "{python} -c \\"%s\\" {sequence} {out}"
layout = "kitti-folder"
format = "kitti"
""" % PERFECT.replace('"', "'")

SYSTEMS = """
[[systems]]
builtin = "accurate-stereo"

[[systems]]
builtin = "mono"

[[systems]]
name = "opencv-script"
cmd = "{python} %(opencv)s {sequence} {out}"
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "perfect"
cmd = "{python} -c \\"%(perfect)s\\" {sequence} {out}"
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "noisy"
cmd = "{python} %(noisy)s {sequence} {out} %(sigma)s {trial}"
layout = "kitti-folder"
format = "kitti"
trials = 3

[[systems]]
name = "crash"
cmd = "{python} -c \\"import sys; print('segfault in my_vo', file=sys.stderr); sys.exit(3)\\" {out}"
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "hang"
cmd = "{python} -c \\"import time; time.sleep(120)\\" {out}"
layout = "kitti-folder"
format = "kitti"
timeout_s = 3

[[systems]]
name = "garbage"
cmd = "{python} -c \\"open('{out}', 'w').write('these are not poses\\\\n')\\""
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "short"
cmd = "sh -c \\"head -n 2 {sequence}/poses.txt > {out}\\""
layout = "kitti-folder"
format = "kitti"

[[systems]]
name = "writes-into-dataset"
cmd = "{python} -c \\"open('{sequence}/mine.txt', 'w')\\" {out}"
layout = "kitti-folder"
format = "kitti"
"""


def run_study(study: Path, out: Path, *extra, timeout=1500) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "RAY_USAGE_STATS_ENABLED": "0"}
    return run_loaded([sys.executable, "-m", "blender_sesgen", "study", "run", str(study), "--out", str(out),
                       "--progress", "plain", *extra], timeout, env=env)


def results(out: Path) -> dict:
    return json.loads((out / "results.json").read_text())


def sha(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def room_study(folder: Path, sigma: float = 0.01) -> Path:
    write(folder, "opencv_vo.py", OPENCV_VO)
    write(folder, "noisy.py", NOISY)
    systems = SYSTEMS % {"opencv": folder / "opencv_vo.py", "perfect": PERFECT.replace('"', "'"),
                         "noisy": folder / "noisy.py", "sigma": sigma}
    body = f"""
[study]
name = "room"
description = "the harness on a small room: controlled variants, reuse, failing systems"
{world(frames=6, quality="draft", samples=2)}[factors.exposure_time]
levels = [0.005, 0.02]
[factors.fog_density]
levels = [0.05]
[factors.texture_richness]
levels = [0.0]
[factors.gain]
levels = [4.0]
{systems}
"""
    return study_file(folder, body, ROOM)


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    folder = tmp_path_factory.mktemp("room")
    out = folder / "out"
    p = run_study(room_study(folder), out)
    assert p.returncode == 0, p.stdout + p.stderr
    return folder, out, p


def runs_of(doc, system):
    return [r for r in doc["runs"] if r["system"] == system]


def test_variants_differ_only_in_their_factor(room):
    """Ground truth (every frame's depth and ids, both views, and the poses) is byte-identical
    to the base's for the image- and sensor-stage factors; checked by the study itself and
    again here from the files. (A 5 ms exposure -- a shutter of 1/8 frame -- once gave its
    sharp frame the pose of a neighbouring shutter instant: Blender takes a key within 0.01
    frame as the evaluated time's; blender/sensor.py keys instants at least 0.0125 apart.)"""
    from vo_reference.io.render import RenderSequence
    _, out, _ = room
    doc = results(out)
    controlled = [v for v in doc["variants"] if v["point"]]
    assert {v["stage"] for v in controlled} == {"image", "sensor"}
    assert all(v["control"]["identical"] for v in controlled), [v["control"] for v in controlled]
    base = RenderSequence(out / next(v for v in doc["variants"] if not v["point"])["render"])
    for v in controlled:
        seq = RenderSequence(out / v["render"])
        for k in (0, base.num_frames - 1):
            for view in ("left", "right"):
                assert seq.depth(k, view).tobytes() == base.depth(k, view).tobytes()
                assert seq.ids(k, view).tobytes() == base.ids(k, view).tobytes()
        assert np.array_equal(seq.T_world_cam("left"), base.T_world_cam("left"))
        assert not np.array_equal(seq.image_rgb(1), base.image_rgb(1))   # ... and the image did change


def test_a_sensor_stage_variant_reuses_the_base_render(room):
    from vo_reference.io.render import RenderSequence
    _, out, _ = room
    doc = results(out)
    c = doc["cost"]
    assert (c["variants"], c["renders"], c["developed"], c["renders_saved"]) == (6, 5, 1, 1)
    assert c["frames_rendered"] == 5 * 6 and c["frames_developed"] == 6
    gain = next(v for v in doc["variants"] if v["point"] == {"gain": 4.0})
    base = next(v for v in doc["variants"] if not v["point"])
    assert gain["developed"] and gain["render_key"] == base["key"]
    seq = RenderSequence(out / gain["render"])
    assert seq.manifest["render"]["reused_exr_from"] == str(out / base["render"])
    for k in range(6):
        for view in ("left", "right"):
            assert sha(out / gain["render"] / f"exr/{view}/{k:06d}.exr") == \
                sha(out / base["render"] / f"exr/{view}/{k:06d}.exr")
    g = RenderSequence(out / gain["render"]).raw_dn(0).astype(float)
    b = RenderSequence(out / base["render"]).raw_dn(0).astype(float)
    unclipped = (b > 10) & (b < 60)         # gain 4 keeps them below 255
    assert np.median(g[unclipped] / np.maximum(b[unclipped], 1)) == pytest.approx(4.0, rel=0.05)


def test_failing_systems_are_recorded_and_the_rest_completes(room):
    _, out, p = room
    doc = results(out)
    n = len(doc["variants"])
    for system, words in (("crash", "exit code 3"), ("hang", "timeout"), ("garbage", "malformed trajectory"),
                          ("short", "short trajectory: poses for 2 of 6 frames"), ("writes-into-dataset", "exit code 1")):
        rs = runs_of(doc, system)
        assert len(rs) == n and all(r["status"] == "failed" and words in r["failure"] for r in rs), rs[0]
    assert all("segfault in my_vo" in r["stderr_tail"][-1] for r in runs_of(doc, "crash"))
    assert all(r["timed_out"] and r["wall_s"] < 30 for r in runs_of(doc, "hang"))
    assert all("Permission denied" in "\n".join(r["stderr_tail"]) for r in runs_of(doc, "writes-into-dataset"))
    for system in ("accurate-stereo", "opencv-script", "perfect", "noisy"):
        rs = runs_of(doc, system)
        assert len(rs) == n * (3 if system == "noisy" else 1)
        assert all(r["status"] == "ok" and r["metrics"]["coverage"] == 1.0 for r in rs), \
            [(r["variant"], r["failure"]) for r in rs if r["status"] != "ok"]
    assert all(r["metrics"]["ape_trans_rmse"] < 1e-5 for r in runs_of(doc, "perfect"))
    mono = runs_of(doc, "mono")                     # the monocular pipeline: evaluated after Sim(3)
    assert len(mono) == n and all(r["status"] == "failed" or r["metrics"]["alignment"].startswith(("sim3", "origin+scale"))
                                  for r in mono)
    assert doc["base"]["noisy"]["std"] > 0                                    # trials spread
    assert doc["breaking_points"]["exposure_time"]["crash"]["level"] == "base"
    assert "breaking point exposure_time / crash: base" in p.stdout


def test_the_report_is_one_self_contained_page(room):
    _, out, _ = room
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64,") >= 4 * 3       # per factor: plot, frame strip, trajectories
    for fetch in ("src=\"http", "href=\"http", "src='http", "<script", "<link", "@import", "url("):
        assert fetch not in page
    for words in ("Breaking points", "Controlled variants", "exposure_time", "segfault in my_vo", "timeout"):
        assert words in page


def test_a_resumed_study_renders_nothing_and_compare_flags_a_regression(room):
    folder, out, _ = room
    old = out.parent / "results-1.json"
    old.write_bytes((out / "results.json").read_bytes())
    p = run_study(room_study(folder, sigma=0.01), out)          # the same study again: all done
    assert p.returncode == 0, p.stderr
    assert "Ray not started" in p.stderr and "local Ray" not in p.stderr   # nothing left to run: no Ray
    assert results(out)["cost"]["frames_rendered"] == 0 and results(out)["cost"]["frames_developed"] == 0
    same = cli_in_process("blender_sesgen", "study", "compare", old, out / "results.json")
    assert same.returncode == 0, same.stdout + same.stderr
    assert "WORSE" not in same.stdout
    p = run_study(room_study(folder, sigma=0.2), out, "--no-ray")   # a new version of "noisy": worse
    assert p.returncode == 0, p.stderr
    assert results(out)["cost"]["frames_rendered"] == 0
    worse = cli_in_process("blender_sesgen", "study", "compare", old, out / "results.json")
    assert worse.returncode == 1, worse.stdout + worse.stderr
    bad = [ln for ln in worse.stdout.splitlines() if ln.startswith("WORSE")]
    assert bad and all("/ noisy" in ln for ln in bad)
    assert any(ln.startswith("same") and "/ perfect" in ln for ln in worse.stdout.splitlines())


# --- killed at any moment ---------------------------------------------------------------------------

def _complete_frames(out: Path) -> dict:
    """{EXR path: (inode, mtime_ns)} of every frame recorded complete in the study's renders."""
    from blender_sesgen.contract.manifest import Manifest
    found = {}
    for r in sorted((out / "renders").glob("r*")):
        try:
            m = Manifest.read(r)
        except Exception:  # noqa: BLE001 - a render that has not written its manifest yet
            continue
        for k, done in enumerate(m.frames_complete):
            if done:
                for view in m.views:
                    p = r / m.files[view][k]
                    st = p.stat()
                    found[str(p)] = (st.st_ino, st.st_mtime_ns)
    return found


def test_a_killed_study_resumes_and_renders_nothing_twice(tmp_path):
    body = f"""
{world(frames=5, quality="draft", samples=2)}[factors.exposure_time]
levels = [0.01, 0.03]
""" + PERFECT_SYSTEM
    study = study_file(tmp_path, body, ROOM)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(REPO), "RAY_USAGE_STATS_ENABLED": "0"}
    # one chunk per render (the default): 3 render processes; the kill finds frames of a render
    # complete and others not, and the resume renders the rest frame by frame
    proc = subprocess.Popen([sys.executable, "-m", "blender_sesgen", "study", "run", str(study), "--out", str(out),
                             "--progress", "plain"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 600
    before = {}
    while time.monotonic() < deadline and len(before) < 2 * 4:     # 4 frames (8 EXRs) recorded complete
        time.sleep(0.5)
        assert proc.poll() is None, "the study ended before it could be killed"
        before = _complete_frames(out) if (out / "renders").is_dir() else {}
    proc.send_signal(signal.SIGKILL)                                # at any moment: mid-render
    proc.wait()
    # its renders end with its Ray's workers (farm.child), seconds later; until then they hold their
    # folders' locks (a new Ray's start-up once hid that wait)
    t0 = time.monotonic()
    while processes_mentioning(str(out)):
        assert time.monotonic() - t0 < 120, processes_mentioning(str(out))
        time.sleep(0.2)
    before = _complete_frames(out)
    assert 8 <= len(before) < 3 * 5 * 2
    p = run_study(study, out, "--no-ray")          # killed on Ray, resumed without (no second Ray start)
    assert p.returncode == 0, p.stdout + p.stderr
    after = _complete_frames(out)
    assert len(after) == 3 * 5 * 2
    assert all(after[path] == ident for path, ident in before.items()), "a complete frame was rendered again"
    doc = results(out)
    assert doc["cost"]["frames_rendered"] == 3 * 5 - len(before) // 2
    assert all(r["status"] == "ok" and r["metrics"]["ape_trans_rmse"] < 1e-5 for r in doc["runs"])



@pytest.mark.parametrize("extra", [(), ("--no-ray",)], ids=["ray", "no-ray"])
def test_sigterm_stops_a_study_as_ctrl_c_does(tmp_path, extra):
    """SIGTERM once Ray runs (ray.init installs its own handler, which aborted the study with
    a stack dump, exit -6): the study stops consistently, says so and exits 130; the same
    without Ray (its running tasks interrupted in their threads, farm.local)."""
    study = study_file(tmp_path, f"{world(frames=5, quality='draft', samples=2)}[factors.exposure_time]\n"
                                 "levels = [0.01]\n" + PERFECT_SYSTEM, ROOM)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(REPO), "RAY_USAGE_STATS_ENABLED": "0"}
    proc = subprocess.Popen([sys.executable, "-m", "blender_sesgen", "study", "run", str(study), "--out", str(out),
                             "--progress", "plain", *extra], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    for line in proc.stdout:                                        # Ray is up once the renders start
        if line.startswith("study: renders:"):
            break
    proc.send_signal(signal.SIGTERM)
    rest = proc.stdout.read()
    rc = proc.wait(timeout=300)
    # 130, not -SIGINT: a SIGTERM that met an import's dataclass left an exec of source text, which
    # CPython then took for an unhandled Ctrl-C (tests/test_cli_interrupt_exit.py)
    assert rc == 130, (rc, rest)
    assert "interrupted:" in rest and "is consistent; run the same command again to continue" in rest, rest
    assert "SIGTERM received" not in rest and "interrupted:" in rest

# --- each sensor factor's effect, measured on the image ---------------------------------------------

@pytest.fixture(scope="module")
def wall(tmp_path_factory):
    folder = tmp_path_factory.mktemp("wall")
    body = f"""
{world(frames=2, quality="draft", samples=64)}[factors.exposure_time]
levels = [0.02]
[factors.read_noise]
levels = [20.0]
[factors.full_well]
levels = [1000.0]
[factors.vignetting]
levels = [1.0]
""" + PERFECT_SYSTEM
    out = folder / "out"
    p = run_study(study_file(folder, body, WALL), out, "--no-ray")
    assert p.returncode == 0, p.stdout + p.stderr
    doc = results(out)
    return out, {(tuple(v["point"].items()) or (("base", 0),))[0][0]: out / v["render"] for v in doc["variants"]}


def _box_blur(profile: np.ndarray, length_px: float, up: int = 50) -> np.ndarray:
    """``profile`` convolved with a box of ``length_px`` (sub-pixel: on a grid ``up`` times finer)."""
    x = np.arange(len(profile))
    fine = np.interp(np.arange(len(profile) * up) / up, x, profile)
    n = max(1, int(round(length_px * up)))
    blurred = np.convolve(np.pad(fine, n, mode="edge"), np.ones(n) / n, mode="same")[n:-n]
    return blurred[::up]


def test_motion_blur_length_is_image_speed_times_exposure(wall):
    """The bars' edges, blurred: the box length that turns the sharp base into the blurred
    variant equals the image speed f v / Z times the exposure (within 10 %)."""
    from vo_reference.io.render import RenderSequence
    _, renders = wall
    sharp = RenderSequence(renders["base"]).rgb_linear(1)[..., 1]
    blurred = RenderSequence(renders["exposure_time"]).rgb_linear(1)[..., 1]
    rows = slice(10, 38)
    a, b = sharp[rows].mean(axis=0), blurred[rows].mean(axis=0)
    lengths = np.arange(0.5, 12.0, 0.05)
    err = [np.abs(_box_blur(a, L) - b)[8:-8].sum() for L in lengths]
    measured = lengths[int(np.argmin(err))]
    expected = WALL_FOCAL * WALL_SPEED / WALL_Z * 0.02          # px/s x s = 5 px
    assert measured == pytest.approx(expected, rel=0.10), (measured, expected)


def _raw_and_signal(render: Path, full_well: float, saturation: float = 1.2):
    """(raw DN, the signal S in electrons the sensor model must have seen) of frame 0's left
    view: S from the render's own linear values (the wall's EXR, shared by the developed variants)."""
    import cv2
    from vo_reference.io.render import RenderSequence
    seq = RenderSequence(render)
    L = seq.rgb_linear(0).astype(float)
    raw = cv2.imread(str(seq.root / seq.sensor_file("raw", 0)), cv2.IMREAD_UNCHANGED)[..., ::-1].astype(float)
    return raw, full_well * L / saturation


@pytest.mark.parametrize("name, full_well, read", [("base", 4000.0, 0.0), ("read_noise", 4000.0, 20.0),
                                                   ("full_well", 1000.0, 0.0)])
def test_sensor_noise_sigma_matches_the_sensor_model(wall, name, full_well, read):
    """Raw values against the model from the render's own linear values: mean K S and
    variance K^2 (S + r^2) + 1/12 (S electrons, K = (2^12 - 1) / full well DN per electron):
    the normalised residual has unit spread (within 10 %) -- a full well the chain ignored
    would leave the spread at 1/2 (the shot noise of 4000 e- instead of 1000 e-)."""
    _, renders = wall
    K = (2 ** 12 - 1) / full_well
    raw, S = _raw_and_signal(renders[name], full_well)
    use = (S < 0.9 * full_well) & (S > 50)
    z = (raw - K * S) / np.sqrt(K ** 2 * (S + read ** 2) + 1 / 12)
    assert use.sum() > 1000
    assert z[use].std() == pytest.approx(1.0, rel=0.10), name


def test_read_noise_adds_in_quadrature_to_the_shot_noise(wall):
    """The read noise's sigma, measured as the excess variance over the base's: r within 10 %."""
    _, renders = wall
    K = (2 ** 12 - 1) / 4000.0
    excess = {}
    for name in ("base", "read_noise"):
        raw, S = _raw_and_signal(renders[name], 4000.0)
        use = (S < 0.9 * 4000.0) & (S > 50)
        excess[name] = ((raw - K * S)[use] ** 2 - K ** 2 * S[use]).mean()
    assert np.sqrt(excess["read_noise"] - excess["base"]) / K == pytest.approx(20.0, rel=0.10)


def test_vignetting_falls_off_as_cos4_of_the_field_angle(wall):
    """The vignetting variant (developed from the base's EXRs): its raw values over the
    model's K S without vignetting follow cos^4 of each pixel's angle off the optical axis
    (from the focal length alone), per ring of the field within 5 %, down to ~0.6 in the corners."""
    from scipy.ndimage import binary_erosion
    _, renders = wall
    K = (2 ** 12 - 1) / 4000.0
    raw, S = _raw_and_signal(renders["vignetting"], 4000.0)
    H, W = S.shape[:2]
    y, x = np.mgrid[0:H, 0:W] + 0.5
    cos4 = (1.0 / np.sqrt(1.0 + ((x - W / 2) ** 2 + (y - H / 2) ** 2) / WALL_FOCAL ** 2)) ** 4
    g = S[..., 1]                                   # the plain wall, away from the bars' edges
    plain = binary_erosion((g > 0.7 * np.median(g)) & (g < 0.9 * 4000.0), iterations=2)
    rings = np.digitize(cos4, [0.7, 0.8, 0.9, 0.95])
    measured = []
    for ring in range(5):
        m = plain & (rings == ring)
        assert m.sum() > 30, ring
        falloff = raw[m].sum() / (K * S[m].sum())
        expected = (cos4[m][:, None] * S[m]).sum() / S[m].sum()
        assert falloff == pytest.approx(expected, rel=0.05), ring
        measured.append(falloff)
    assert measured[0] < 0.72 and measured[-1] > 0.95


# --- a third-party estimator from PyPI --------------------------------------------------------------

COLMAP = r'''
"""pycolmap's incremental mapper on the left images of a KITTI folder; TUM trajectory out."""
import sys
from pathlib import Path
import numpy as np
import pycolmap

seq, out, work = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
P0 = [np.array(l.split()[1:], float).reshape(3, 4) for l in open(seq / "calib.txt") if l.startswith("P0")][0]
times = np.loadtxt(seq / "times.txt", ndmin=1)
db = work / "db.db"
pycolmap.set_random_seed(0)   # RANSAC's draws and one thread each: the same map on every run
reader = pycolmap.ImageReaderOptions()
reader.camera_model = "PINHOLE"
reader.camera_params = ",".join(str(x) for x in (P0[0, 0], P0[1, 1], P0[0, 2], P0[1, 2]))
extraction = pycolmap.FeatureExtractionOptions()
extraction.num_threads = 1
pycolmap.extract_features(db, seq / "image_0", camera_mode=pycolmap.CameraMode.SINGLE, reader_options=reader,
                          extraction_options=extraction, device=pycolmap.Device.cpu)
matching = pycolmap.FeatureMatchingOptions()
matching.num_threads = 1
pycolmap.match_exhaustive(db, matching_options=matching, device=pycolmap.Device.cpu)
opts = pycolmap.IncrementalPipelineOptions()
opts.num_threads = 1
opts.ba_refine_focal_length = False
opts.ba_refine_principal_point = False
opts.ba_refine_extra_params = False
maps = pycolmap.incremental_mapping(db, seq / "image_0", work / "sparse", options=opts)
rec = max(maps.values(), key=lambda r: r.num_reg_images())
lines = []
for img in rec.images.values():
    if not img.has_pose:
        continue
    T = np.eye(4)
    cfw = img.cam_from_world() if callable(img.cam_from_world) else img.cam_from_world
    T[:3] = cfw.inverse().matrix()
    k = int(Path(img.name).stem)
    from scipy.spatial.transform import Rotation
    q = Rotation.from_matrix(T[:3, :3]).as_quat()
    lines.append((times[k], *T[:3, 3], *q))
lines.sort()
out.write_text("".join(" ".join(f"{v:.9f}" for v in l) + "\n" for l in lines))
'''


def test_a_third_party_estimator_from_pypi_runs_through_the_harness(tmp_path):
    pytest.importorskip("pycolmap")
    write(tmp_path, "colmap_vo.py", COLMAP)
    body = f"""
{world(frames=6, resolution=3.0, quality="draft", samples=4)}[factors.exposure_time]
levels = [0.03]
[[systems]]
name = "pycolmap"
cmd = "{{python}} {tmp_path / 'colmap_vo.py'} {{sequence}} {{out}} {{workdir}}"
layout = "kitti-folder"
format = "tum"
mono = true
timeout_s = 600
"""
    out = tmp_path / "out"
    p = run_study(study_file(tmp_path, body, ROOM), out, "--no-ray")
    assert p.returncode == 0, p.stdout + p.stderr
    doc = results(out)
    rs = runs_of(doc, "pycolmap")
    assert len(rs) == 2 and all(r["status"] == "ok" for r in rs), [(r["failure"], r["stderr_tail"]) for r in rs]
    for r in rs:
        m = r["metrics"]
        print(f"pycolmap {r['variant']}: coverage {m['coverage']:.2f} (bound 0.5), APE {m['ape_trans_rmse']:.4f} m "
              f"(bound {0.05 * m['gt_path_length_m'] + 0.02:.4f} m)")
        assert m["coverage"] >= 0.5 and m["alignment"].startswith("sim3") and m["scale"] > 0
        assert m["ape_trans_rmse"] < 0.05 * m["gt_path_length_m"] + 0.02
