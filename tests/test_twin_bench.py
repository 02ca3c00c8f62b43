"""bench/twin.py's sensor-noise draws: each draw develops the same EXRs with the sensor's seed
+ d (reproducible, different per draw, the same as a script that names that seed), frames
start.. as the whole run's, and the table judges each target on the median draw."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from layout_scene import B, F, H, W, write_layout_render
from synthetic_render import write_manifest_dict

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
twin = pytest.importorskip("twin")
N = 4


METERED = [0.2, 0.35, 0.15, 0.3]     # brightness per frame: the auto-exposure moves between frames


def _folder(root: Path, sensor_line: str, first: int = 0) -> Path:
    """The layout render (tests/layout_scene.py, no Blender) with what a twin render adds: the
    script with a camera profile and AUTOEXPOSURE, the render's scale and the state of each
    frame from ``first`` on (a render of frames K.. holds none before K; its manifest holds the
    metering pass's brightness of every frame)."""
    root = write_layout_render(root, n=N)
    (root / "scene.ses").write_text(f"CAMERA resolution {W} {H} focal {F} baseline {B}\nSTART position 0 0 0\n"
                                    f"CUBOID id 1 position 0 0 -5 dim 1 1 1\n{sensor_line}\nAUTOEXPOSURE\n")
    m = json.loads((root / "manifest.json").read_text())
    m["render"]["resolution_scale"] = 1.0
    if first:
        m["sensor"] = {"metered": METERED}
    write_manifest_dict(root, m)
    for k in range(first, N):
        (root / "sensor" / "state").mkdir(parents=True, exist_ok=True)
        (root / "sensor" / "state" / f"{k:06d}.json").write_text(
            json.dumps({"exposure_s": 0.002, "gain": 1.0, "metered": METERED[k]}))
    return root


@pytest.fixture(scope="module")
def folders(tmp_path_factory):
    base = tmp_path_factory.mktemp("twin")
    return (_folder(base / "seed0", "SENSOR profile kitti"), _folder(base / "seed1", "SENSOR profile kitti seed 1"),
            _folder(base / "from2", "SENSOR profile kitti", first=2))


def _imgs(fr):
    return np.stack(fr._img["left"] + fr._img["right"])


def test_draws_are_reproducible_and_are_the_scripts_seeds(folders):
    seed0, seed1, _ = folders
    d0, d1 = twin.resensor(seed0, N, draw=0), twin.resensor(seed0, N, draw=1)
    assert np.array_equal(_imgs(d0), _imgs(twin.resensor(seed0, N, draw=0)))       # reproducible
    assert np.mean(_imgs(d0) != _imgs(d1)) > 0.05     # another noise draw (48 px: the sensor binned ~25x)
    assert abs(float(_imgs(d0).mean()) - float(_imgs(d1).mean())) < 1.0            # of the same image
    # draw 1 of the seed-0 script is the script that names seed 1 (the parser's seed, not the bench's)
    assert np.array_equal(_imgs(d1), _imgs(twin.resensor(seed1, N, draw=0)))
    assert twin._sensor_seed(seed1) == 1 and twin._sensor_seed(seed0) == 0


def test_start_develops_the_frames_of_the_whole_run(folders):
    whole, part = twin.resensor(folders[0], N, draw=2), twin.resensor(folders[0], 2, start=2, draw=2)
    assert np.array_equal(_imgs(part), np.stack(whole._img["left"][2:] + whole._img["right"][2:]))
    assert np.allclose(part.T_world_cam(), whole.T_world_cam()[2:])
    assert np.allclose(part.timestamps_s, whole.timestamps_s[2:])
    # a render of frames 2.. alone: the schedule from the manifest's metering of frames 0..
    assert np.array_equal(_imgs(part), _imgs(twin.resensor(folders[2], 2, start=2, draw=2)))
    assert not np.array_equal(_imgs(part), _imgs(twin.resensor(folders[0], 2, draw=2)))   # frames 0, 1


def _figs(t_rpe: float) -> dict:
    f = {"slope": -2.5, "klt": 0.1, "clipped": 0.02, "sgbm": 0.7, "corners": 500.0}
    for vo in twin.VOS:
        f.update({f"{vo}/t_rpe_pct": 3.0, f"{vo}/t_rpe_turned_pct": t_rpe, f"{vo}/r_rpe_deg": 0.02,
                  f"{vo}/drift_pct": 1.0, f"{vo}/sim3_pct": 0.1})
    return f


def _row(rows, label):
    return [c.strip() for c in next(r for r in rows if r.startswith(f"| {label}")).strip("|").split("|")]


def test_table_judges_the_median_draw_and_prints_the_range():
    real = _figs(1.0)
    rows = twin.table("real", real, [_figs(2.0), _figs(1.2), _figs(0.5)], (48, 32), N)   # draw 0 misses
    assert "median of 3 draws" in rows[0] and "range over the draws" in rows[0]
    cells = _row(rows, "orb: translation RPE, each one's poses' heading turned out")
    assert cells[1:] == ["1.000", "1.200", "1.20", "0.50 to 2.00", "0.67-1.5: met"]
    assert _row(rows, "orb: translation RPE (median")[-1] == "judged turned, next row"     # as the poses say: shown
    rows = twin.table("real", real, [_figs(1.2), _figs(2.0), _figs(1.8)], (48, 32), N)   # draw 0 meets
    assert _row(rows, "accurate: translation RPE, each")[-1] == "0.67-1.5: missed"
    assert _row(rows, "power-spectrum slope")[3:] == ["+0.00", "+0.00 to +0.00", "within 0.2: met"]


def test_one_draw_prints_the_single_run_table():
    rows = twin.table("real", _figs(1.0), [_figs(1.6)], (48, 32), N)
    assert "range" not in rows[0] and len(rows[1].split("|")) == 7
    assert _row(rows, "opencv-baseline: translation RPE, each")[1:] == ["1.000", "1.600", "1.60", "0.67-1.5: missed"]


def test_hall_table_judges_the_klt_at_equal_shake():
    """The hall's standing camera (no VOs): the plain KLT is a row, unjudged; the judged row is
    the error over EuRoC's at each pair's own shake, the same rule on both sides (as the city's
    RPE with each one's heading turned out)."""
    real = {"slope": -2.6, "klt": 0.0002, "klt_shake": 1.0, "clipped": 0.11, "sgbm": 0.55, "corners": 185.0}
    shaken = dict(real, klt=0.0004, klt_shake=1.1)         # twice the plain error, at twice the shake
    rows = twin.table("real", real, [shaken], (376, 240), N)
    assert _row(rows, "KLT forward-backward error (px)")[1:] == ["0.0002", "0.0004", "2.00", "judged at equal shake, next row"]
    assert _row(rows, "KLT forward-backward error over EuRoC's")[-1] == "within 25 %: met"
    rows = twin.table("real", real, [dict(shaken, klt_shake=1.4)], (376, 240), N)
    assert _row(rows, "KLT forward-backward error over EuRoC's")[-1] == "within 25 %: missed"
    assert not any(r.startswith("| KLT forward-backward error over") for r in twin.table("real", _figs(1.0), [_figs(1.0)],
                                                                                         (48, 32), N))


def test_klt_over_shake_reads_the_error_at_each_pairs_own_shift():
    """``klt_over_shake`` on EuRoC's line (``shake_fit``): the same camera shaken 20 x harder reads ~1,
    four times the noise more than 2; the real camera's own frames ~1."""
    real = _shaken(np.exp(np.random.default_rng(2).uniform(np.log(0.01), np.log(0.6), 40)), 0.7, 3)
    fit = twin.shake_fit(real, shaken_from=0)
    assert 0.75 < twin.klt_over_shake(_shaken([0.4] * 11, 0.7, 5), 12, fit) < 1.33
    assert twin.klt_over_shake(_shaken([0.4] * 11, 2.8, 6), 12, fit) > 2
    assert 0.75 < twin.klt_over_shake(real, 12, fit) < 1.33


def test_bad_draws_exit_2(shared_data, capsys):
    assert twin.main(["--draws", "0", "--no-render"]) == 2
    assert "--draws" in capsys.readouterr().err


def test_start_past_the_euroc_excerpt_exits_2(shared_data, capsys):
    """The excerpt has 95 frames: --start 93 leaves 2 to compare (clear error, no render, no
    IndexError); 92 passes the check and fails later only because --no-render finds no frames."""
    assert twin.main(["--scene", "hall", "--start", "93", "--no-render", "--out", "/nonexistent"]) == 2
    assert "the EuRoC excerpt has 95 frames" in capsys.readouterr().err


def _rig(pitch_deg_per_step, step_m: float = 1.2) -> np.ndarray:
    """T_world_cam of a rig driving along its z, pitching by the given angle each step."""
    from blender_sesgen.contract.se3 import se3
    import cv2
    T = [np.eye(4)]
    for a in pitch_deg_per_step:
        T.append(T[-1] @ se3(cv2.Rodrigues(np.array([np.radians(a), 0.0, 0.0]))[0], np.array([0.0, 0.0, step_m])))
    return np.array(T)


def _kitti_digits(T: np.ndarray) -> np.ndarray:
    """Poses as KITTI's poses.txt holds them: 7 significant digits (its rotations are off
    orthonormal by up to 1.5e-7)."""
    return np.vectorize(lambda x: float(f"{x:.6e}"))(T)


def test_rotation_change_is_what_constant_velocity_misses():
    assert np.allclose(twin.rotation_change_deg(_rig([0.3] * 6), 7), 0.0, atol=1e-9)     # a steady turn: none
    assert np.allclose(twin.rotation_change_deg(_rig([0.2, -0.2] * 3), 7), 0.4)         # a sway: twice its step
    # KITTI's 7-digit poses of a steady turn: ~0, where the trace's arccos reads ~0.02 deg
    assert twin.rotation_change_deg(_kitti_digits(_rig([0.04] * 20)), 21).max() < 2e-3


def test_step_errors_on_exact_and_broken_steps():
    T = _kitti_digits(_rig([0.1, -0.05, 0.02, 0.0, 0.1]))
    steps = [np.linalg.inv(T[k]) @ T[k + 1] for k in range(5)]
    t, r = twin.step_errors(T, steps)
    assert t.max() < 1e-3 and r.max() < 2e-3                   # the ground truth itself: no error
    steps[2] = steps[2].copy()
    steps[2][:3, 3] *= 1.12                                    # one step 12 % long
    t, r = twin.step_errors(T, steps)
    assert np.isclose(t[2], 12.0, atol=1e-3) and np.sum(t > twin.BAD_STEP_PCT) == 1


def _pnp_scatter(P, K, trials: int = 400) -> float:
    """Monte Carlo: the root of the summed translation variances of PnP on P's exact pixels
    plus 1 px of noise per coordinate (the oracle of the bound)."""
    import cv2
    rng = np.random.default_rng(3)
    q = P[:, :2] / P[:, 2:] * [K[0, 0], K[1, 1]] + K[:2, 2]
    ts = []
    for _ in range(trials):
        ok, r, t = cv2.solvePnP(P, q + rng.normal(0, 1, q.shape), K, None, np.zeros(3), np.zeros(3), True)
        ts.append(t.ravel())
    return float(np.sqrt(np.var(ts, axis=0).sum()))


@pytest.mark.parametrize("spread", ["wide", "one side"])
def test_pnp_translation_bound_is_the_scatter_of_pnp_under_pixel_noise(spread):
    rng = np.random.default_rng(0)
    K = np.array([[350.0, 0, 306], [0, 350.0, 92], [0, 0, 1]])
    n = 60
    Z = rng.uniform(8, 40, n)
    u = rng.uniform(0, 612, n) if spread == "wide" else rng.uniform(420, 612, n)
    v = rng.uniform(20, 170, n)
    P = np.stack([(u - K[0, 2]) / K[0, 0] * Z, (v - K[1, 2]) / K[1, 1] * Z, Z], 1)
    bound, mc = twin.pnp_translation_bound(P, K), _pnp_scatter(P, K)
    assert 0.85 < bound / mc < 1.15, (bound, mc)
    # fewer points, the same placement: the bound grows as 1 / sqrt(count)
    assert np.isclose(twin.pnp_translation_bound(P[::4], K) / bound, 2.0, rtol=0.35)


def _plane_sequence(n: int = 4, Z: float = 12.0, step_m: float = 0.5):
    """A textured fronto-parallel plane Z m ahead of a stereo rig driving straight at it:
    frame k is the texture scaled about the principal point by Z / (Z - k step), the right
    view shifted by its disparity. Exact poses."""
    import cv2
    rng = np.random.default_rng(1)
    W, H, f, B = 320, 160, 300.0, 0.5
    tex = cv2.GaussianBlur((rng.random((H, W)) * 255).astype(np.float32), (0, 0), 1.2)
    tex = cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX)
    K = np.array([[f, 0, W / 2], [0, f, H / 2], [0, 0, 1]])
    left, right = [], []
    for k in range(n):
        s = Z / (Z - k * step_m)
        A = np.array([[s, 0, (1 - s) * W / 2], [0, s, (1 - s) * H / 2]])
        img = cv2.warpAffine(tex, A, (W, H), flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
        d = f * B / (Z - k * step_m)
        right_img = cv2.warpAffine(img, np.array([[1.0, 0, -d], [0, 1, 0]]), (W, H), flags=cv2.INTER_CUBIC,
                                   borderMode=cv2.BORDER_REFLECT)
        left.append(np.clip(img, 0, 255).astype(np.uint8))
        right.append(np.clip(right_img, 0, 255).astype(np.uint8))
    T = np.array([np.block([[np.eye(3), np.array([[0], [0], [k * step_m]])], [np.zeros((1, 3)), np.ones((1, 1))]])
                  for k in range(n)])
    return twin.Frames(left, right, K, B, T)


def test_orb_funnel_counts_the_matches_the_true_step_carries():
    seq = _plane_sequence()
    f = twin.orb_funnel(seq, 4)
    assert f["matches"] >= f["with_depth"] >= f["inliers"] > 50
    assert f["consistent"] > 0.6                 # a rigid plane: most matches agree with the true step
    assert np.isfinite(f["bound_pct"]) and f["bound_pct"] > 0
    # poses that claim the rig moved sideways by its steps: few matches agree with them
    T = seq.T_world_cam().copy()
    T[:, 0, 3], T[:, 2, 3] = T[:, 2, 3], 0.0
    wrong = twin.Frames(seq._img["left"], seq._img["right"], seq.K, seq.baseline_m, T)
    assert twin.orb_funnel(wrong, 4)["consistent"] < 0.3
    # ORB kept to a quarter of the image: fewer inliers, a looser bound on the step
    quarter = np.zeros((160, 320), np.uint8)
    quarter[:80, 160:] = 255
    g = twin.orb_funnel(seq, 4, mask=lambda k: quarter)
    assert g["keypoints"] < f["keypoints"] and g["inliers"] < f["inliers"] and g["bound_pct"] > f["bound_pct"]


def test_street_surfaces_read_a_kerbs_sunlit_top_not_its_shaded_face(shared_data, tmp_path, monkeypatch):
    """A kerb as the half-size render sees it 8 m ahead: its sunlit top 2 px high above its face
    in shade, 6 px; the road beside it. The kerb's brightness is its top's (KITTI's marks are
    sunlit tops), where an erosion would have kept only the face."""
    Hh, Ww = 60, 120
    ids = np.ones((Hh, Ww), np.int32)                 # road
    img = np.full((Hh, Ww), 120, np.uint8)
    ids[20:22, 10:110], img[20:22, 10:110] = 2, 200   # the kerb's top, sunlit
    ids[22:28, 10:110], img[22:28, 10:110] = 2, 40    # its face, in shade
    (tmp_path / "manifest.json").write_text(json.dumps({"objects": [{"id": 1, "kind": "road", "class": "road"},
                                                                    {"id": 2, "kind": "kerb", "class": "sidewalk"}]}))

    class Ids:
        def ids(self, k, view="left"):
            return ids
    monkeypatch.setattr(twin, "open_sequence", lambda out: Ids())
    frames = twin.Frames([img] * 2, [img] * 2, np.eye(3), 0.5)
    _, ours = twin.street_surfaces(tmp_path, frames, 2)
    L = twin._linear(np.array([200, 120], np.uint8), "kitti")
    kerb = float(ours.split("kerb ")[1].split()[0])
    assert np.isclose(kerb, L[0] / L[1], atol=0.01), ours


def _kinds_grain(tmp_path, monkeypatch, ids, img) -> dict:
    """``kinds_grain``'s render figures ({kind: value}) for two frames of ``img`` whose object ids
    are ``ids`` (1 a building, 2 vegetation, 0 sky)."""
    (tmp_path / "manifest.json").write_text(json.dumps({"objects": [{"id": 1, "class": "building"},
                                                                    {"id": 2, "class": "vegetation"}]}))

    class Ids:
        def ids(self, k, view="left"):
            return ids
    monkeypatch.setattr(twin, "open_sequence", lambda out: Ids())
    frames = twin.Frames([img] * 2, [img] * 2, np.eye(3), 0.5)
    _, ours = twin.kinds_grain(tmp_path, frames, 2)
    return {k: float(v) for k, v in (x.split() for x in ours.split(", "))}


def test_kinds_grain_reads_each_kinds_own_detail_not_its_edges(shared_data, tmp_path, monkeypatch):
    """A textured facade beside a flat crown: the facade's pixel-scale contrast is its texture's,
    the crown's none (its edge against the facade is not its detail)."""
    rng = np.random.default_rng(2)
    Hh, Ww = 60, 120
    ids = np.full((Hh, Ww), 2, np.int32)                       # the crown, flat
    img = np.full((Hh, Ww), 90, np.uint8)
    ids[:, 60:] = 1                                            # the facade, textured
    img[:, 60:] = np.clip(150 + rng.normal(0, 12, (Hh, 60)), 0, 255).astype(np.uint8)
    got = _kinds_grain(tmp_path, monkeypatch, ids, img)
    L = twin._linear(img, "kitti")
    inner = np.zeros(img.shape, bool)
    inner[3:-3, 63:-3] = True
    assert got["tree"] < 1e-6 and np.isclose(got["facade"], twin._grain(L, inner), rtol=0.05), got


def test_street_surfaces_read_the_kerb_on_its_top_by_height(shared_data, tmp_path, monkeypatch):
    """Both the kerb's top (13 cm high) and its road-facing face in the sun, the face darker:
    the kerb's brightness is its top's, picked by the world height of its pixels (true depth,
    the rig 1.65 m up looking level along -Z)."""
    Hh, Ww, f, cy = 60, 120, 100.0, 10.0
    K = np.array([[f, 0, (Ww - 1) / 2], [0, f, cy], [0, 0, 1]])
    ids = np.ones((Hh, Ww), np.int32)
    img = np.full((Hh, Ww), 120, np.uint8)
    height = np.zeros((Hh, Ww))
    ids[20:22, 10:110], img[20:22, 10:110], height[20:22] = 2, 200, 0.13      # the top
    ids[22:28, 10:110], img[22:28, 10:110], height[22:28] = 2, 150, 0.06      # the face, sunlit too
    v = np.arange(Hh, dtype=float)[:, None] * np.ones((1, Ww))
    depth = np.where(v > cy, (1.65 - height) * f / np.maximum(v - cy, 1e-3), np.inf)
    T = np.array([[1.0, 0, 0, 0], [0, -1, 0, 1.65], [0, 0, -1, 0], [0, 0, 0, 1]])
    (tmp_path / "manifest.json").write_text(json.dumps({"objects": [
        {"id": 1, "kind": "road", "class": "road"},
        {"id": 2, "kind": "kerb", "class": "sidewalk", "size": [0.2, 0.13, 50.0],
         "T_world_obj_rest": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}]}))

    class Render:
        def ids(self, k, view="left"):
            return ids

        def depth(self, k, view="left"):
            return depth.astype(np.float32)

        def T_world_cam(self, view="left"):
            return np.array([T, T])
    monkeypatch.setattr(twin, "open_sequence", lambda out: Render())
    frames = twin.Frames([img] * 2, [img] * 2, K, 0.5)
    _, ours = twin.street_surfaces(tmp_path, frames, 2)
    L = twin._linear(np.array([200, 120], np.uint8), "kitti")
    assert np.isclose(float(ours.split("kerb ")[1].split()[0]), L[0] / L[1], atol=0.01), ours


def test_kinds_grain_crown_holds_the_sky_seen_through_it(shared_data, tmp_path, monkeypatch):
    """A crown of flat leaves with small sky gaps under open sky, beside a flat facade: the
    crown's pixel-scale contrast is that of its leaves and gaps together (as KITTI's crown boxes
    read), neither the open sky above nor the facade beside it; its leaves alone have none."""
    Hh, Ww = 60, 120
    ids = np.zeros((Hh, Ww), np.int32)                         # sky (no object)
    img = np.full((Hh, Ww), 200, np.uint8)
    ids[20:, :60], img[20:, :60] = 2, 60                      # the crown, flat leaves
    for y in range(24, 56, 6):                                 # 2 x 2 px sky gaps through it
        for x in range(4, 56, 6):
            ids[y:y + 2, x:x + 2], img[y:y + 2, x:x + 2] = 0, 200
    ids[:, 60:], img[:, 60:] = 1, 150                          # the facade, flat
    got = _kinds_grain(tmp_path, monkeypatch, ids, img)
    L = twin._linear(img, "kitti")
    inner = np.zeros(img.shape, bool)
    inner[23:, :57] = True                                     # 3 px in (an erosion keeps the frame's borders)
    assert got["facade"] < 1e-6, got
    assert got["crown"] > 0.1 and np.isclose(got["crown"], twin._grain(L, inner), rtol=0.1), got


def test_facade_brightness_reads_the_sunlit_walls_in_the_upper_quantiles(tmp_path, monkeypatch):
    """A facade 16 % in the sun (4x the shaded part): the median and the 75th percentile read
    its shade, the 90th percentile its sunlit wall (why the render's all-pixel facade figure sits below KITTI's
    hand-marked sunlit boxes)."""
    Hh, Ww = 40, 100
    ids = np.zeros((Hh, Ww), np.int32)
    ids[:, 50:] = 1                                            # the facade; the rest sky (id 0)
    img = np.full((Hh, Ww), 120, np.uint8)
    img[:, 50:92] = 60                                         # shade
    img[:, 92:] = 240                                          # sun
    (tmp_path / "manifest.json").write_text(json.dumps({"objects": [{"id": 1, "class": "building"}]}))

    class Ids:
        def ids(self, k, view="left"):
            return ids
    monkeypatch.setattr(twin, "open_sequence", lambda out: Ids())
    frames = twin.Frames([img] * 2, [img] * 2, np.eye(3), 0.5)
    got = dict(x.split()[:2] for x in twin.facade_brightness(tmp_path, frames, 2).split(";")[0].split(", "))
    L = frames.linear(0, "kitti")
    assert np.isclose(float(got["median"]), L[0, 60] / L.mean(), atol=0.01), got
    assert np.isclose(float(got["p75"]), L[0, 60] / L.mean(), atol=0.01), got
    assert np.isclose(float(got["p90"]), L[0, 95] / L.mean(), atol=0.01), got


def test_corners_by_region_counts_each_sixth_of_the_image():
    """Bright 14 px squares on a dark 240 x 120 frame, four corners each: three in the lower right
    sixth and one in the upper left give 4 / 0 / 0 / 0 / 0 / 12 a frame in REGIONS' order (upper
    left first, lower right last), averaged over the frames; rows and columns swapped (a mutant)
    put them elsewhere."""
    img = np.zeros((120, 240), np.uint8)
    for x0, y0 in ((165, 65), (200, 65), (182, 95)):      # lower right: x >= 160, y >= 60
        img[y0:y0 + 14, x0:x0 + 14] = 200
    img[10:24, 10:24] = 200                                 # upper left
    frames = twin.Frames([img, img], [img, img], np.eye(3), 0.5)
    c = twin.corners_by_region(frames, 2)
    assert twin.REGIONS[0] == "upper left" and twin.REGIONS[5] == "lower right"
    assert c[0] == 4 and c[5] == 12 and c[1:5].sum() == 0, c


def test_orb_inliers_by_region_counts_each_sixth_and_its_depth():
    """Hand-made ORB steps (points in camera k, K of a 600 x 200 image): two inliers 10 m ahead in
    the lower right (pixel x >= 400, y >= 100) and one 50 m ahead in the upper left, a matched
    point that is no inlier left out, and a failed step: 1 / 0 / 0 / 0 / 0 / 2 inliers over the
    two steps' mean (0.5 / ... / 1) at 50 m and 10 m."""
    K = np.array([[300.0, 0.0, 300.0], [0.0, 300.0, 100.0], [0.0, 0.0, 1.0]])
    P = np.array([[5.0, 2.0, 10.0], [6.0, 3.0, 10.0], [-40.0, -10.0, 50.0], [0.0, 0.0, 20.0]])
    steps = [twin.OrbStep(100, 50, P, np.zeros((4, 2)), np.array([0, 1, 2])),
             twin.OrbStep(100, 0, np.zeros((0, 3)), np.zeros((0, 2)), np.array([], int))]
    counts, depth = twin.orb_inliers_by_region(steps, K, (600, 200))
    assert np.allclose(counts, [0.5, 0, 0, 0, 0, 1.0]), counts
    assert depth[0] == 50.0 and depth[5] == 10.0 and np.isnan(depth[1:5]).all(), depth


def test_orb_near_inliers_count_each_side_by_run_of_steps():
    """Hand-made ORB steps: step 0 has inliers 10 m ahead 6 m and 8 m right, one 12 m ahead 5 m left,
    one 1 m right (on the axis: neither side), one 30 m ahead 7 m right (too far) and a matched
    point that is no inlier (9 m right, 10 m ahead); step 1 failed; step 2 one inlier 15 m ahead
    7 m right. In two runs (steps 0-1, 2): right 2 / 2 = 1.0 at 7 m and left 0.5; right 1 at 7 m
    and left 0."""
    P0 = np.array([[6.0, 0.0, 10.0], [8.0, 0.0, 10.0], [-5.0, 0.0, 12.0], [1.0, 0.0, 10.0], [7.0, 0.0, 30.0],
                   [9.0, 0.0, 10.0]])
    steps = [twin.OrbStep(100, 50, P0, np.zeros((6, 2)), np.array([0, 1, 2, 3, 4])),
             twin.OrbStep(100, 0, np.zeros((0, 3)), np.zeros((0, 2)), np.array([], int)),
             twin.OrbStep(100, 50, np.array([[7.0, 1.0, 15.0]]), np.zeros((1, 2)), np.array([0]))]
    a, b = twin.orb_near_inliers(steps, parts=2)
    assert a["steps"] == (0, 1) and b["steps"] == (2, 2)
    assert a["right"] == 1.0 and a["left"] == 0.5 and a["right_x_m"] == 7.0, a
    assert b["right"] == 1.0 and b["left"] == 0.0 and b["right_x_m"] == 7.0, b


def test_start_past_kittis_excerpt_exits_2(shared_data, capsys):
    """The city compares frames K.. of both (session 20): past KITTI sequence_1's frames a clear
    error (exit 2, no render)."""
    assert twin.main(["--scene", "city", "--start", "1000", "--no-render", "--out", "/nonexistent"]) == 2
    assert "KITTI sequence_1 has" in capsys.readouterr().err


def test_translation_rpe_is_judged_with_each_ones_poses_heading_turned_out():
    """Poses turned 0.35 deg against the images (KITTI sequence_1's, measured by three VOs) put
    every step 7 mm to the side: VOs that read the images' steps exactly have a plain RPE of ~0.6 %
    of the step and 0 with the poses' heading turned out; the same rule on exact poses changes
    nothing (the render's side)."""
    from blender_sesgen.contract.se3 import se3
    psi = np.radians(0.35)
    true_steps = np.array([[0.01 * np.sin(k), 0.0, 1.2] for k in range(20)])   # the images' steps
    T = [np.eye(4)]
    for t in true_steps:                        # poses whose steps lie psi to the right of the images'
        c, s_ = np.cos(psi), np.sin(psi)
        tp = np.array([c * t[0] + s_ * t[2], t[1], -s_ * t[0] + c * t[2]])
        T.append(T[-1] @ se3(np.eye(3), tp))
    T = np.array(T)
    figs = {f"{vo}/steps_m": true_steps for vo in twin.VOS}
    out = twin.with_heading_out(figs, T, len(T))
    assert out["heading_rad"] == pytest.approx(psi, rel=0.02)
    import gt_noise as gn
    plain = np.median(gn.rpe_pct(gn.step_vectors(T), true_steps))
    assert plain == pytest.approx(100 * psi, rel=0.05)                   # ~0.61 % of the step
    assert all(out[f"{vo}/t_rpe_turned_pct"] < 0.01 for vo in twin.VOS)
    T_exact = [np.eye(4)]
    for t in true_steps:
        T_exact.append(T_exact[-1] @ se3(np.eye(3), t))
    exact = twin.with_heading_out(figs, np.array(T_exact), len(T_exact))
    assert abs(exact["heading_rad"]) < 1e-9 and all(exact[f"{vo}/t_rpe_turned_pct"] < 1e-6 for vo in twin.VOS)


def _shaken(shifts, noise_dn: float, seed: int):
    """A still camera's frames: one smooth random texture (a few px to tens of px, 40-200 DN)
    moved by ``shifts`` (px, along a fixed direction, frame to frame; Fourier shift: exact), with
    white noise of ``noise_dn`` and the 8-bit rounding."""
    rng = np.random.default_rng(0)
    import cv2
    base = sum(cv2.GaussianBlur(rng.normal(0, 1, (240, 376)), (0, 0), s) * s for s in (1.5, 4, 12))
    base = 120 + 40 * base / base.std()
    fy, fx = np.meshgrid(np.fft.fftfreq(240), np.fft.fftfreq(376), indexing="ij")
    F = np.fft.fft2(base)
    noise = np.random.default_rng(seed)
    pos, out = np.zeros(2), []
    for s in [0.0] + list(shifts):
        pos += s * np.array([0.8, 0.6])
        img = np.fft.ifft2(F * np.exp(-2j * np.pi * (fx * pos[0] + fy * pos[1]))).real
        out.append(np.clip(np.round(img + noise.normal(0, noise_dn, img.shape)), 0, 255).astype(np.uint8))
    return twin.Frames(out, out, np.eye(3), 0.11)


def test_hall_klt_is_read_at_the_shake_of_each_pair():
    """A standing camera's KLT error grows with how far the pair moved (EuRoC V1_01: its calm
    frames 30-49 move 0.02 px, elsewhere 0.09-0.16). ``pair_klt`` reads a known shift; ``klt_at_shake``
    judges the render's error at its own shift on the real camera's line of error against shift:
    the same camera shaken 20 x harder than the real one's compared frames reads ~1 there (its
    plain ratio ~1.9 is not), and four times the noise reads more than 2. (At EuRoC's noise, 0.7 DN
    here, the error is near OpenCV's own floor: 0.00016 px without noise at 0.02 px, 0.00043 at 0.4.)"""
    fb, shift = twin.pair_klt(*_shaken([0.2], 0.7, 1)._img["left"])
    assert abs(shift - 0.2) < 0.025 and 0 < fb < 0.01, (fb, shift)      # LK reads 0.21
    real = _shaken(np.exp(np.random.default_rng(2).uniform(np.log(0.01), np.log(0.6), 40)), 0.7, 3)
    calm = _shaken([0.02] * 11, 0.7, 4)
    ours = _shaken([0.4] * 11, 0.7, 5)
    noisy = _shaken([0.4] * 11, 2.8, 6)

    def ratio(line):
        return float(line.split("at the render's shift ")[1].split()[0])
    plain = np.median([twin.pair_klt(a, b)[0] for a, b in zip(ours._img["left"], ours._img["left"][1:])]) / \
        np.median([twin.pair_klt(a, b)[0] for a, b in zip(calm._img["left"], calm._img["left"][1:])])
    assert plain > 1.5, plain
    assert 0.75 < ratio(twin.klt_at_shake(real, ours, 12, 0, shaken_from=0)) < 1.33
    assert ratio(twin.klt_at_shake(real, noisy, 12, 0, shaken_from=0)) > 2
