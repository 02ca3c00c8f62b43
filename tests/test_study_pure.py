"""Verification studies without rendering: the study file, the factors, the same-path
variants, the designs, the plan, the system runner, results and compare (docs/studies.md)."""
from __future__ import annotations

import io
import json
import re
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from study_scenes import ROOM, study_file, write

REPO = Path(__file__).resolve().parents[1]
SYSTEM = """
[[systems]]
name = "perfect"
cmd = "{python} -c 'pass' {sequence} {out}"
layout = "kitti-folder"
format = "kitti"
"""


def cli(*argv) -> tuple[int, str, str]:
    from blender_sesgen.commands.main import main
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = main(list(argv))
    return rc, out.getvalue(), err.getvalue()


def load(tmp_path, body: str, script: str = ROOM):
    from blender_sesgen.study.spec import load
    return load(study_file(tmp_path, body, script))


def scene_of(text: str):
    from blender_sesgen.ses.parser import parse_text
    return parse_text(text, "<test>", "/")


# --- the study file ------------------------------------------------------------------------------

def test_a_toml_syntax_error_is_one_line_with_file_line_and_column(tmp_path):
    path = study_file(tmp_path, '[world]\nscript = "scene.ses"\nframes = \n')
    rc, out, err = cli("study", "run", str(path), "--out", str(tmp_path / "o"))
    assert rc == 2 and out == ""
    assert re.fullmatch(rf"{re.escape(str(path))}:3:\d+: error: .+\n", err), err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("body, key, words", [
    ('[world]\nscript = "scene.ses"\n[factors.exposure_tme]\nlevels = [0.01]\n' + SYSTEM,
     "factors.exposure_tme", "did you mean 'exposure_time'"),
    ('[world]\nscript = "scene.ses"\n[factors.exposure_time]\nlevels = ["fast"]\n' + SYSTEM,
     "factors.exposure_time.levels[0]", "expected a number"),
    ('[world]\nscript = "scene.ses"\ngenerator = "street"\n' + SYSTEM, "world", "exactly one of"),
    ('[world]\nscript = "missing.ses"\n' + SYSTEM, "world.script", "no such file"),
    ('[world]\nscript = "scene.ses"\nquality = "best"\n' + SYSTEM, "world.quality", "expected one of"),
    ('[world]\nscript = "scene.ses"\n[[systems]]\ncmd = "my_vo {dataset}"\nlayout = "kitti-folder"\n'
     'format = "kitti"\n', "systems[0].cmd", "{out}"),
    ('[world]\nscript = "scene.ses"\n[[systems]]\ncmd = "my_vo {dataset} {output}"\nlayout = "kitti-folder"\n'
     'format = "kitti"\n', "systems[0].cmd", "unknown placeholder {output}"),
    ('[world]\nscript = "scene.ses"\n[[systems]]\ncmd = "vo {out}"\nlayout = "kitti"\nformat = "kitti"\n',
     "systems[0].layout", "kitti-folder"),
    ('[world]\nscript = "scene.ses"\n[[systems]]\nbuiltin = "orb-slam"\n', "systems[0].builtin", "accurate-stereo"),
    ('[world]\nscript = "scene.ses"\n[design]\nkind = "grid"\n[factors.gain]\nlevels = [2]\n' + SYSTEM,
     "design.kind", "exactly two factors"),
    ('[world]\nscript = "scene.ses"\n[factors.fogg]\nstatement = "FOG"\ntag = "density"\nlevels = [1]\n' + SYSTEM,
     "factors.fogg.tag", "FOG has no tag 'density'"),
    ('[world]\nscript = "scene.ses"\n[factors.lamp]\nstatement = "LIGHT"\ntag = "strength"\nlevels = [1]\n' + SYSTEM,
     "factors.lamp.match", "match"),
    ('[world]\nscript = "scene.ses"\nsamples = 0\n' + SYSTEM, "world.samples", ">= 1"),
    ('[world]\nscript = "scene.ses"\n[evaluation]\nbreak_multiple = 0.5\n' + SYSTEM, "evaluation.break_multiple",
     "> 1"),
    ('[world]\nscript = "scene.ses"\n[wrld]\n' + SYSTEM, "wrld", "unknown key"),
])
def test_a_semantic_error_names_its_key(tmp_path, body, key, words):
    path = study_file(tmp_path, body)
    rc, out, err = cli("study", "run", str(path), "--out", str(tmp_path / "o"))
    assert rc == 2, err
    assert err.startswith(f"{path}: error: {key}"), err
    assert words in err and err.count("\n") == 1
    assert not (tmp_path / "o").exists()


def test_a_level_that_makes_a_bad_script_names_the_factor_and_level(tmp_path):
    body = '[world]\nscript = "scene.ses"\n[factors.lens_distortion]\nlevels = [-0.1, -3.0]\n' + SYSTEM
    rc, _, err = cli("study", "run", str(study_file(tmp_path, body)), "--out", str(tmp_path / "o"), "--plan")
    assert rc == 2 and "factors.lens_distortion: level -3.0" in err and "folds the image" in err, err


def test_the_help_documents_the_study_file_and_placeholders():
    from blender_sesgen.commands.study import EPILOG
    for word in ("[world]", "[factors.", "[design]", "[[systems]]", "{dataset}", "{out}", "{workdir}", "builtin",
                 "timeout_s", "trials", "statement", "generator"):
        assert word in EPILOG
    rc, out, _ = cli("study", "factors")
    assert rc == 0 and "exposure_time" in out and "Hz" in out


# --- the script editor --------------------------------------------------------------------------

def test_the_script_editor_rewrites_only_what_it_touches():
    from blender_sesgen.study.script import Script
    s = Script(ROOM)
    s.set_tag("TIMING", "exposure", 0.004)
    s.set_tag("CAMERA", "baseline", 0.3)
    s.drop("LIGHT")
    lines = s.text.splitlines()
    before = ROOM.splitlines()
    assert [ln for ln in before if not ln.startswith(("CAMERA", "LIGHT"))] == \
        [ln for ln in lines if not ln.startswith(("CAMERA", "TIMING"))]
    assert "CAMERA resolution 96 64 focal 60 baseline 0.3 near 0.1 far 100" in lines
    assert "TIMING exposure 0.004" in lines
    sc = scene_of(s.text)
    assert sc.timing.exposure_s == 0.004 and sc.rig.baseline == 0.3 and not sc.lights


# --- factors and their variants -----------------------------------------------------------------

MOVING = ROOM.replace("LIGHT sun", "MOVE id 6 twist 0.05 0 0 0 10 0\nMOVE id 5 frame 4 position -0.4 0.4 -1.2 0 30 0\n"
                                   "LIGHT sun")

SAMPLES = {"frame_rate": 50, "rig_speed": 2.0, "rotation_rate": 30, "hand_shake": 0.5, "car_speed": 12,
           "moving_cars": 2, "object_speed": 2.0, "resolution": 0.5, "baseline": 0.3, "lens_distortion": -0.1,
           "readout_time": 0.02, "exposure_time": 0.01, "sun_elevation": 10, "hdri": "night", "illuminance": 0.1,
           "fog_density": 0.2, "texture_richness": 0.3, "gain": 4.0, "read_noise": 5.0, "full_well": 2000,
           "cfa": "rggb", "response": "linear", "vignetting": 1.0}


def test_every_factor_of_the_registry_has_a_sample_here():
    from blender_sesgen.study.factors import FACTORS
    assert set(SAMPLES) == set(FACTORS)


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_every_factor_makes_a_checked_variant_that_differs_from_the_base(tmp_path, name):
    from blender_sesgen.study.factors import FACTORS
    from blender_sesgen.study.variants import make_variant
    world = '[world]\nscript = "scene.ses"\n' + ('set = { moving_cars = 2 }\n' if name == "car_speed" else "")
    body = f'{world}[factors.{name}]\nlevels = [{json.dumps(SAMPLES[name])}]\n' + SYSTEM
    study = load(tmp_path, body, script=MOVING if name == "object_speed" else ROOM)
    base = make_variant(study, {}, 0, tmp_path)
    v = make_variant(study, {name: SAMPLES[name]}, 0, tmp_path)
    assert v.script != base.script
    assert v.stage == FACTORS[name].stage
    if FACTORS[name].stage == "sensor":       # the render is the base's: only the camera chain differs
        assert v.render_script == base.script and v.developed
    else:
        assert v.render_script == v.script and not v.developed
    scene_of(v.script)


def test_factors_change_what_they_say_and_nothing_else(tmp_path):
    from blender_sesgen.study.variants import make_variant
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n' + SYSTEM)
    base = scene_of(make_variant(study, {}, 0, tmp_path).script)
    sc = lambda p: scene_of(make_variant(study, p, 0, tmp_path).script)   # noqa: E731
    assert sc({"exposure_time": 0.01}).timing.exposure_s == 0.01
    assert sc({"readout_time": 0.02}).timing.readout_s == 0.02
    assert sc({"gain": 4.0}).sensor.gain == 4.0
    assert sc({"read_noise": 5.0}).sensor.read_noise_e == 5.0
    assert sc({"cfa": "rggb"}).sensor.cfa == "rggb"
    assert sc({"vignetting": 1.0}).lens.vignetting == 1.0
    assert sc({"baseline": 0.3}).rig.baseline == 0.3
    assert sc({"fog_density": 0.2}).fog.end == pytest.approx(5.0)
    w = sc({"sun_elevation": 10}).world
    assert w.kind == "sky" and w.sun_elevation_deg == 10
    assert sc({"hdri": "night"}).world.hdri == "night"
    lit = sc({"illuminance": 0.1})
    assert lit.lights[0].strength == pytest.approx(0.3) and lit.world.strength == pytest.approx(0.1)
    half = sc({"resolution": 0.5}).rig
    assert (half.width, half.height, half.focal_px) == (48, 32, 30) and half.cx == pytest.approx(23.5)
    lens = sc({"lens_distortion": -0.1}).lens
    assert lens.model == "brown" and lens.coeffs[0] == -0.1
    for p in ({"exposure_time": 0.01}, {"gain": 4.0}, {"fog_density": 0.2}, {"sun_elevation": 10}):
        v = sc(p)   # geometry and motion untouched
        assert [o.to_json() if hasattr(o, "to_json") else o for o in v.objects] == list(base.objects)
        assert np.array_equal(v.timeline.left(), base.timeline.left())


def test_texture_richness_keeps_a_nested_seeded_share_and_the_geometry(tmp_path):
    from blender_sesgen.study.variants import make_variant
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n' + SYSTEM)
    textured = []
    for f in (0.0, 0.3, 0.7, 1.0):
        s = scene_of(make_variant(study, {"texture_richness": f}, 0, tmp_path).script)
        textured.append({o.id for o in s.objects if o.texture is not None})
        geo = [(o.id, o.shape, getattr(o, "vertices", None), getattr(o, "position", None)) for o in s.objects]
        assert geo == [(o.id, o.shape, getattr(o, "vertices", None), getattr(o, "position", None))
                       for o in scene_of(ROOM).objects]
        assert [o.semantic_class for o in s.objects] == [o.semantic_class for o in scene_of(ROOM).objects]
    assert textured[0] == set() and textured[-1] == {1, 2, 3, 4, 5, 6}
    assert textured[1] <= textured[2] <= textured[3]


def _rig_motion(text):
    from blender_sesgen.study.paths import rig_motion
    return rig_motion(scene_of(text))


@pytest.mark.parametrize("factor, level", [("frame_rate", 50), ("frame_rate", 10), ("rig_speed", 2.0),
                                           ("rig_speed", 0.5)])
def test_same_path_variants_lie_on_the_base_path(tmp_path, factor, level):
    """Every frame of the variant is the base's continuous motion at some instant: frame k
    of a frame-rate variant at t = k / rate, of a rig-speed variant at t = k * speed / rate."""
    from blender_sesgen.contract.se3 import relative, rotation_angle_rad
    from blender_sesgen.study.variants import make_variant
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n' + SYSTEM)
    base = make_variant(study, {}, 0, tmp_path)
    v = scene_of(make_variant(study, {factor: level}, 0, tmp_path).script)
    m = _rig_motion(base.script)
    k = np.arange(v.frames)
    t = k / level if factor == "frame_rate" else k * level / 25.0
    T_base = m.T_world_cam(t)
    T_var = v.timeline.left()
    assert np.abs(T_var[:, :3, 3] - T_base[:, :3, 3]).max() < 1e-7
    assert max(float(rotation_angle_rad(relative(a, b)[:3, :3])) for a, b in zip(T_var, T_base)) < 1e-7
    duration = (scene_of(base.script).frames - 1) / 25.0
    assert t[-1] <= duration + 1e-9 and t[-1] + (1 / level if factor == "frame_rate" else level / 25) > duration
    if factor == "frame_rate":
        assert v.timing.rate_hz == level


def test_a_pan_and_a_shake_turn_the_camera_in_place(tmp_path):
    from blender_sesgen.study import paths
    from blender_sesgen.contract.se3 import so3_log
    from blender_sesgen.study.variants import make_variant
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n' + SYSTEM)
    base = scene_of(make_variant(study, {}, 0, tmp_path).script)
    for p in ({"rotation_rate": 30}, {"hand_shake": 0.5}):
        v = scene_of(make_variant(study, p, 0, tmp_path).script)
        assert np.abs(v.timeline.left()[:, :3, 3] - base.timeline.left()[:, :3, 3]).max() < 1e-8
    # the pan's peak rate is the level: finite differences of the added turn over one period
    t = np.linspace(0, 2, 4001)
    T0 = np.tile(np.eye(4), (len(t), 1, 1))
    yaw = np.array([so3_log(R[:3, :3])[1] for R in paths.pan(T0, t, 30.0)])
    assert np.degrees(np.abs(np.diff(yaw) / np.diff(t))).max() == pytest.approx(30.0, rel=1e-3)
    # the shake's RMS per axis is the level (over a long stretch)
    t = np.linspace(0, 60, 6001)
    ang = np.array([so3_log(R[:3, :3]) for R in paths.shake(np.tile(np.eye(4), (len(t), 1, 1)), t, 0.5, seed=3)])
    assert np.degrees(np.sqrt((ang ** 2).mean(axis=0))) == pytest.approx([0.5, 0.5, 0.5], rel=0.05)


def test_a_resampled_clock_keeps_the_moving_objects_on_their_own_motion(tmp_path):
    from blender_sesgen.scene.dynamics import pose_at
    from blender_sesgen.study.variants import make_variant
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n' + SYSTEM, script=MOVING)
    base = scene_of(make_variant(study, {}, 0, tmp_path).script)
    for p, tau in (({"frame_rate": 50}, lambda k: k / 2), ({"rig_speed": 2.0}, lambda k: k),
                   ({"object_speed": 0.5}, lambda k: k * 0.5)):
        v = scene_of(make_variant(study, p, 0, tmp_path).script)
        for om in base.object_motions:
            kind = "twist" if om.kind == "twist" else "keys"
            got = v.motion_of(om.id).poses()
            want = np.array([pose_at(om.poses(), tau(k), kind) for k in range(v.frames)])
            assert np.abs(got - want).max() < 1e-7, (p, om.id)


def test_moving_cars_drive_along_the_path_beside_the_camera(tmp_path):
    from blender_sesgen.study.variants import make_variant
    street = ROOM.replace("EGO 0.02 0 0.12 0 1.5 0", "EGO 0 0 1.2 0 0.5 0")
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n[factors.moving_cars]\nlevels = [3]\n' + SYSTEM,
                 script=street)
    v = scene_of(make_variant(study, {"moving_cars": 3, "car_speed": 8.0}, 0, tmp_path).script)
    cars = [o for o in v.objects if o.shape == "asset" and o.kind == "car"]
    assert len(cars) == 3 and len({o.id for o in cars}) == 3
    cam = v.timeline.left()[:, :3, 3]
    for o in cars:
        P = v.motion_of(o.id).poses()[:, :3, 3]
        assert np.linalg.norm(P - cam, axis=1).min() > 2.5
        speed = np.linalg.norm(np.diff(P, axis=0), axis=1) * 25
        assert np.median(speed) == pytest.approx(8.0, rel=0.05)


# --- designs and the plan ------------------------------------------------------------------------

def test_designs_one_at_a_time_grid_and_latin_hypercube(tmp_path):
    from blender_sesgen.study import design
    factors = '[factors.gain]\nlevels = [1.0, 4.0]\n[factors.exposure_time]\nlevels = [0.0, 0.02]\n'
    s = load(tmp_path, '[world]\nscript = "scene.ses"\n' + factors + SYSTEM)
    assert design.points(s.design, s.factors) == [{}, {"gain": 1.0}, {"gain": 4.0}, {"exposure_time": 0.0},
                                                   {"exposure_time": 0.02}]
    s = load(tmp_path, '[world]\nscript = "scene.ses"\n[design]\nkind = "grid"\n' + factors + SYSTEM)
    assert len(design.points(s.design, s.factors)) == 1 + 4
    s = load(tmp_path, '[world]\nscript = "scene.ses"\n[design]\nkind = "lhs"\nsamples = 8\nseed = 3\n'
             + factors + SYSTEM)
    pts = design.points(s.design, s.factors)[1:]
    assert pts == design.points(s.design, s.factors)[1:]             # seeded
    for name, lo, hi in (("gain", 1.0, 4.0), ("exposure_time", 0.0, 0.02)):
        strata = sorted(int((p[name] - lo) / (hi - lo) * 8) for p in pts)
        assert strata == list(range(8))                               # one sample per stratum


def test_a_plan_costs_its_distinct_renders(tmp_path):
    from blender_sesgen.study.variants import make_plan
    body = ('[world]\nscript = "scene.ses"\nseeds = [0, 1]\n[factors.gain]\nlevels = [1.0, 2.0, 8.0]\n'
            '[factors.exposure_time]\nlevels = [0.0, 0.02]\n' + SYSTEM)
    plan = make_plan(load(tmp_path, body), tmp_path)
    assert len(plan.variants) == 2 * 6
    # per seed: the base (= gain 1 = exposure 0) and exposure 0.02 are rendered; gain 2 and 8 developed
    assert len(plan.renders) == 2 * 2 and len(plan.develops) == 2 * 2
    for v in plan.variants:
        if v.point.get("gain", 1.0) != 1.0:
            assert v.developed and v.render_key == plan.base_of(v.seed).key
    assert plan.base_of(0).key != plan.base_of(1).key        # a script world's seed is its render seed


# --- systems --------------------------------------------------------------------------------------

def test_a_system_run_records_crashes_timeouts_and_a_read_only_dataset(tmp_path):
    from blender_sesgen.study import systems
    data = tmp_path / "data"
    (data / "sub").mkdir(parents=True)
    write(data / "sub", "f.txt", "x")
    systems.set_read_only(data)
    py = sys.executable
    r = systems.run([py, "-c", "import sys; print('going down', file=sys.stderr); sys.exit(7)"], tmp_path / "a", 10)
    assert r["rc"] == 7 and r["error"] == "exit code 7" and r["stderr_tail"] == ["going down"]
    r = systems.run([py, "-c", "import time; time.sleep(60)"], tmp_path / "b", 1.0)
    assert r["timed_out"] and "timeout" in r["error"] and r["wall_s"] < 10
    r = systems.run([py, "-c", f"open({str(data / 'sub' / 'g.txt')!r}, 'w')"], tmp_path / "c", 10)
    assert r["rc"] == 1 and "Permission denied" in "\n".join(r["stderr_tail"])
    r = systems.run([py, "-c", "import os; open('mine.txt', 'w').write(os.getcwd())"], tmp_path / "d", 10)
    assert r["rc"] == 0 and (tmp_path / "d" / "work" / "mine.txt").read_text() == str(tmp_path / "d" / "work")
    systems.remove_tree(data)
    assert not data.exists()


def test_templates_expand_and_refuse_unknown_placeholders():
    from blender_sesgen.errors import SesgenError
    from blender_sesgen.study import systems
    argv = systems.expand(["{vo}", "stereo-vo", "{sequence}", "--out", "{out}", "t{trial}"],
                          {"sequence": "/d/s", "out": "/r/e.txt", "trial": 2}, ["py", "-m", "vo_reference"])
    assert argv == ["py", "-m", "vo_reference", "stereo-vo", "/d/s", "--out", "/r/e.txt", "t2"]
    for bad in (["x", "{nope}"], ["x{vo}"], ["{"]):
        with pytest.raises(SesgenError):
            systems.check_template(bad)


# --- results and compare -----------------------------------------------------------------------

def _runs(points: dict, system="s") -> list:
    """Synthetic run records: {label point: [error or None (failed), ...]}."""
    out = []
    for point, errs in points:
        for t, e in enumerate(errs):
            out.append({"point": point, "system": system, "trial": t, "status": "ok" if e is not None else "failed",
                        "metrics": {"ape_trans_rmse": e} if e is not None else {}})
    return out


def test_breaking_points_and_compare(tmp_path):
    from blender_sesgen.study.results import aggregate, compare, curves_and_breaks
    body = ('[world]\nscript = "scene.ses"\n[factors.exposure_time]\nlevels = [0.01, 0.02, 0.04]\n'
            '[[systems]]\nname = "s"\ncmd = "x {out}"\nlayout = "tum"\nformat = "tum"\n')
    study = load(tmp_path, body)
    runs = _runs([({}, [1.0, 1.2]), ({"exposure_time": 0.01}, [1.1, 1.3]), ({"exposure_time": 0.02}, [2.5, 2.7]),
                  ({"exposure_time": 0.04}, [None, None])])
    curves, base, breaks = curves_and_breaks(study, aggregate(runs, "ape_trans_rmse"), "ape_trans_rmse")
    assert base["s"]["mean"] == pytest.approx(1.1) and base["s"]["std"] == pytest.approx(np.std([1.0, 1.2], ddof=1))
    assert breaks["exposure_time"]["s"]["level"] == 0.02
    assert [c["broken"] for c in curves["exposure_time"]["s"]] == [False, True, True]
    runs2 = _runs([({}, [1.0, 1.2]), ({"exposure_time": 0.01}, [None, None])])
    assert curves_and_breaks(study, aggregate(runs2, "ape_trans_rmse"),
                             "ape_trans_rmse")[2]["exposure_time"]["s"]["level"] == 0.01

    def doc(runs):
        c, b, br = curves_and_breaks(study, aggregate(runs, "ape_trans_rmse"), "ape_trans_rmse")
        return {"format": "sesgen-study-results/1", "study": {"metric": "ape_trans_rmse"},
                "factors": [{"name": "exposure_time", "levels": [0.01, 0.02, 0.04]}], "curves": c, "base": b}
    old = doc(runs)
    assert {r["verdict"] for r in compare(old, doc(runs))} == {"same"}
    worse = _runs([({}, [1.0, 1.2]), ({"exposure_time": 0.01}, [1.6, 1.8]), ({"exposure_time": 0.02}, [2.5, 2.7]),
                   ({"exposure_time": 0.04}, [None, None])])
    rows = {(r["factor"], r["level"]): r["verdict"] for r in compare(old, doc(worse))}
    assert rows[("exposure_time", "0.01")] == "worse" and rows[("exposure_time", "0.02")] == "same"
    within = _runs([({}, [1.0, 1.2]), ({"exposure_time": 0.01}, [1.2, 1.3]), ({"exposure_time": 0.02}, [2.5, 2.7]),
                    ({"exposure_time": 0.04}, [None, None])])
    assert {r["verdict"] for r in compare(old, doc(within))} == {"same"}    # within one spread
    a, b = tmp_path / "old.json", tmp_path / "new.json"
    a.write_text(json.dumps(old))
    b.write_text(json.dumps(doc(worse)))
    rc, out, _ = cli("study", "compare", str(a), str(b))
    assert rc == 1 and "WORSE  exposure_time = 0.01 / s" in out
    rc, _, _ = cli("study", "compare", str(a), str(a))
    assert rc == 0


def test_breaking_points_weigh_the_spread_over_world_seeds(tmp_path):
    """Broken only when the mean exceeds the multiple by more than break_sigmas x the spread
    of that difference, sqrt(std^2 + (multiple x std_base)^2) (hand-computed here)."""
    from blender_sesgen.study.results import aggregate, curves_and_breaks
    body = ('[world]\nscript = "scene.ses"\nseeds = [0, 1]\n[factors.exposure_time]\nlevels = [0.01, 0.02, 0.04]\n'
            '[[systems]]\nname = "s"\ncmd = "x {out}"\nlayout = "tum"\nformat = "tum"\n')
    # base 1.0 +- 0.283 (0.8, 1.2): 0.01 at 3.0 +- 1.414: margin hypot(1.414, 0.566) = 1.523 > 3.0 - 2.0;
    # 0.02 at 2.4 +- 0.141: margin hypot(0.141, 0.566) = 0.583 > 0.4; 0.04 at 4.0 +- 0: 0.566 < 2.0, broken
    runs = _runs([({}, [0.8, 1.2]), ({"exposure_time": 0.01}, [2.0, 4.0]), ({"exposure_time": 0.02}, [2.3, 2.5]),
                  ({"exposure_time": 0.04}, [4.0, 4.0])])
    curves, _, breaks = curves_and_breaks(load(tmp_path, body), aggregate(runs, "ape_trans_rmse"), "ape_trans_rmse")
    cells = curves["exposure_time"]["s"]
    assert cells[0]["margin"] == pytest.approx(np.hypot(np.sqrt(2), 2 * np.std([0.8, 1.2], ddof=1)))
    assert [c["broken"] for c in cells] == [False, False, True]
    assert [c["within_spread"] for c in cells] == [True, True, False]
    assert breaks["exposure_time"]["s"]["level"] == 0.04
    # no spread weighing (break_sigmas = 0): the plain multiple, broken at the first level
    study0 = load(tmp_path, body + "[evaluation]\nbreak_sigmas = 0\n")
    assert curves_and_breaks(study0, aggregate(runs, "ape_trans_rmse"),
                             "ape_trans_rmse")[2]["exposure_time"]["s"]["level"] == 0.01
    # everything within the spread: no breaking point, and the reason says where it came close
    held = _runs([({}, [0.8, 1.2]), ({"exposure_time": 0.01}, [2.0, 4.0]), ({"exposure_time": 0.02}, [1.0, 1.1]),
                  ({"exposure_time": 0.04}, [1.5, 3.5])])
    b = curves_and_breaks(load(tmp_path, body), aggregate(held, "ape_trans_rmse"), "ape_trans_rmse")[2]
    assert b["exposure_time"]["s"]["level"] is None and "within the spread at 0.01, 0.04" in b["exposure_time"]["s"]["reason"]


def test_the_docs_list_every_factor():
    from blender_sesgen.study.factors import FACTORS
    text = (REPO / "docs" / "studies.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([a-z_]+)` \| ([^|]+) \| (\w+) \|", text, flags=re.M)
    assert {name: (unit.strip(), stage) for name, unit, stage in rows} == \
        {f.name: (f.unit, f.stage) for f in FACTORS.values()}


def test_one_study_run_per_folder(tmp_path):
    import fcntl
    path = study_file(tmp_path, '[world]\nscript = "scene.ses"\n[factors.gain]\nlevels = [2.0]\n' + SYSTEM)
    out = tmp_path / "out"
    out.mkdir()
    (out / "plan.json").write_text("{}")
    with open(out / ".study.lock", "a+") as held:          # as a running study holds it
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        rc, _, err = cli("study", "run", str(path), "--out", str(out))
    assert rc == 2 and "another `study run` is writing into it" in err


def test_a_local_ray_that_cannot_start_is_one_line_exit_1_and_the_folder_resumable(tmp_path):
    """Ray's own start failing (its temporary folder a file here; an overloaded machine's node
    timing out in the wild) is a failure of the run: one line, exit 1, no traceback, and the
    folder holds the plan only (the same command runs it later)."""
    import os
    import subprocess
    pytest.importorskip("ray")
    path = study_file(tmp_path, '[world]\nscript = "scene.ses"\n[factors.gain]\nlevels = [2.0]\n' + SYSTEM)
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "blender_sesgen", "study", "run", str(path), "--out", str(out)],
                       capture_output=True, text=True, timeout=300, cwd=REPO,
                       env=dict(os.environ, PYTHONPATH=str(REPO), RAY_TMPDIR=str(not_a_folder)))
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr and "error: cannot start a local Ray: " in r.stderr, r.stderr
    assert "run the same command again" in r.stderr
    assert (out / "plan.json").is_file() and not any((out / "renders").iterdir())


def test_a_fixed_exposure_drops_the_scripts_autoexposure(tmp_path):
    from blender_sesgen.study.variants import make_variant
    auto = ROOM + "TIMING exposure 0.002\nSENSOR readnoise 2\nAUTOEXPOSURE target 0.3\n"
    study = load(tmp_path, '[world]\nscript = "scene.ses"\n' + SYSTEM, auto)
    base = scene_of(make_variant(study, {}, 0, tmp_path).script)
    assert base.autoexposure is not None and base.timing.exposure_s == 0.002
    v = scene_of(make_variant(study, {"exposure_time": 0.02}, 0, tmp_path).script)
    assert v.autoexposure is None and v.timing.exposure_s == 0.02 and v.timing.motion_blur
    assert v.sensor.read_noise_e == 2.0     # the rest of the camera kept


def test_a_sensor_variant_with_autoexposure_is_rendered_not_developed(tmp_path):
    from blender_sesgen.study.variants import make_variant
    body = '[world]\nscript = "scene.ses"\n' + SYSTEM
    plain = make_variant(load(tmp_path, body, ROOM + "TIMING exposure 0.002\nSENSOR readnoise 2\n"),
                         {"gain": 4.0}, 0, tmp_path)
    assert plain.developed
    auto = make_variant(load(tmp_path, body, ROOM + "TIMING exposure 0.002\nSENSOR readnoise 2\nAUTOEXPOSURE\n"),
                        {"gain": 4.0}, 0, tmp_path)
    assert not auto.developed and auto.stage == "sensor" and "gain 4" in auto.script


def test_a_render_folder_held_by_another_writer_fails_the_study(tmp_path):
    """A variant's folder that a live process is writing into (a render of the killed run still
    ending, another study) cannot be rendered: the study says which and why, and exits 1 — its
    results are not a finished study's. Nothing renders here: every render folder is held (the
    gain variant is developed from the base's)."""
    import os
    import socket
    from blender_sesgen.study.spec import load as load_study
    from blender_sesgen.study.variants import make_plan
    path = study_file(tmp_path, '[world]\nscript = "scene.ses"\n[factors.gain]\nlevels = [2.0]\n' + SYSTEM)
    out = tmp_path / "out"
    renders = make_plan(load_study(path), tmp_path / "scripts").renders
    assert renders
    for key in renders:
        state = out / "renders" / key / ".sesgen"
        state.mkdir(parents=True)
        (state / f"lock-{socket.gethostname()}-{os.getpid()}.json").write_text(json.dumps(
            {"host": socket.gethostname(), "pid": os.getpid(), "frames": [0, 99], "started": 0,
             "scene_sha256": "another", "settings": "other"}))
    (out / "plan.json").write_text("{}")                   # the killed run's folder
    rc, stdout, err = cli("study", "run", str(path), "--out", str(out), "--no-ray")
    assert rc == 1, stdout + err
    assert f"being rendered by pid {os.getpid()}" in stdout + err, stdout + err
    doc = json.loads((out / "results.json").read_text())
    assert doc["runs"] and all(r["status"] == "failed" for r in doc["runs"])


def test_a_measure_missing_from_runs_is_not_averaged_nor_a_break_nor_a_regression(tmp_path):
    """ape_rot_rmse_deg is null where the run's alignment left the rotation free: a point whose
    runs lack it has no mean (not the mean of the others: a selected subset), its breaking point
    says 'not measured' (not 'holds up to'), and compare calls it 'unmeasured' (exit 0)."""
    from blender_sesgen.study.results import FORMAT, aggregate, compare, curves_and_breaks
    body = ('[world]\nscript = "scene.ses"\n[factors.exposure_time]\nlevels = [0.01, 0.02]\n'
            '[[systems]]\nname = "s"\ncmd = "x {out}"\nlayout = "tum"\nformat = "tum"\n'
            '[evaluation]\nmetric = "ape_rot_rmse_deg"\n')
    study = load(tmp_path, body)

    def runs(points):
        out = []
        for point, rots in points:
            for t, rot in enumerate(rots):
                out.append({"point": point, "system": "s", "trial": t, "status": "ok",
                            "metrics": {"ape_trans_rmse": 0.1, "ape_rot_rmse_deg": rot,
                                        "alignment_ill_posed": rot is None, "rotation_sigma_deg": 90.0}})
        return out
    free = runs([({}, [None, None]), ({"exposure_time": 0.01}, [None, 0.4]), ({"exposure_time": 0.02}, [9.0, 9.0])])
    aggs = aggregate(free, "ape_rot_rmse_deg")
    curves, base, breaks = curves_and_breaks(study, aggs, "ape_rot_rmse_deg")
    mixed = curves["exposure_time"]["s"][0]
    assert mixed["mean"] is None and mixed["n_missing"] == 1                    # not 0.4, the one measured run
    assert base["s"]["mean"] is None and base["s"]["n_missing"] == 2 and base["s"]["n_ill_posed"] == 2
    b = breaks["exposure_time"]["s"]
    assert b["level"] is None and b["reason"].startswith("not measured at the base") and "0.01" in b["reason"]
    assert "leaves its rotation free" in b["reason"] and "holds up" not in b["reason"]
    assert aggs[("base", "s")]["metrics"]["ape_trans_rmse"]["mean"] == pytest.approx(0.1)   # the others unchanged

    def doc(rs):
        c, bb, br = curves_and_breaks(study, aggregate(rs, "ape_rot_rmse_deg"), "ape_rot_rmse_deg")
        return {"format": FORMAT, "study": {"metric": "ape_rot_rmse_deg"},
                "factors": [{"name": "exposure_time", "levels": [0.01, 0.02]}], "curves": c, "base": bb}
    old = doc(runs([({}, [120.0, 35.0]), ({"exposure_time": 0.01}, [86.0, 6.0]), ({"exposure_time": 0.02}, [9.0, 9.0])]))
    rows = {(r["factor"], r["level"]): r for r in compare(old, doc(free))}
    assert rows[("(base)", "")]["verdict"] == "unmeasured" and "NEW: ape_rot_rmse_deg missing from 2 of 2" \
        in rows[("(base)", "")]["detail"]
    assert rows[("exposure_time", "0.02")]["verdict"] == "same"
    a, n = tmp_path / "old.json", tmp_path / "new.json"
    a.write_text(json.dumps(old))
    n.write_text(json.dumps(doc(free)))
    rc, out, _ = cli("study", "compare", str(a), str(n))
    assert rc == 0 and "unmeasured (base) / s" in out


def _metric_runs(points, metric: str, system="s", **extra) -> list:
    """Synthetic ok run records: [(point, [value, ...])] of ``metric`` (plus ``extra`` metrics keys)."""
    return [{"point": point, "system": system, "trial": t, "status": "ok", "metrics": {metric: v, **extra}}
            for point, values in points for t, v in enumerate(values)]


@pytest.mark.parametrize("metric, base, small, large", [
    ("tracking_loss", 0.0, 0.025, 0.1),            # none lost at the base; 1 frame in 40; 4 in 40
    ("ape_trans_rmse", 0.0, 5e-4, 0.01),           # a perfect system; half a millimetre; a centimetre
    ("ape_trans_rmse", 1e-9, 3e-9, 0.01)])         # rounding at the base: 3x rounding is not a break
def test_a_base_of_zero_or_rounding_breaks_only_above_the_metrics_floor(tmp_path, metric, base, small, large):
    """Old rule: any error above 2 x 0 (or 2 x 1e-9) was a breaking point -- a tracking loss of one
    frame, a perfect system's rounding. Now a level breaks only above max(2 x the base's, the
    metric's floor), and the reason says the floor decided."""
    from blender_sesgen.study.results import BREAK_FLOOR, aggregate, curves_and_breaks
    body = ('[world]\nscript = "scene.ses"\n[factors.exposure_time]\nlevels = [0.01, 0.02]\n'
            '[[systems]]\nname = "s"\ncmd = "x {out}"\nlayout = "tum"\nformat = "tum"\n'
            f'[evaluation]\nmetric = "{metric}"\n')
    study = load(tmp_path, body)
    assert small < BREAK_FLOOR[metric] < large
    runs = _metric_runs([({}, [base, base]), ({"exposure_time": 0.01}, [small, small]),
                         ({"exposure_time": 0.02}, [large, large])], metric)
    curves, _, breaks = curves_and_breaks(study, aggregate(runs, metric), metric)
    assert [c["broken"] for c in curves["exposure_time"]["s"]] == [False, True]
    b = breaks["exposure_time"]["s"]
    assert b["level"] == 0.02 and f"the floor {BREAK_FLOOR[metric]:g}" in b["reason"]
    # above the floor, the multiple rules as before
    runs = _metric_runs([({}, [0.2, 0.2]), ({"exposure_time": 0.01}, [0.3, 0.3]),
                         ({"exposure_time": 0.02}, [0.5, 0.5])], metric)
    b = curves_and_breaks(study, aggregate(runs, metric), metric)[2]["exposure_time"]["s"]
    assert b["level"] == 0.02 and "2 x the base's 0.2" in b["reason"]


def test_a_switch_of_definition_is_neither_a_break_nor_a_regression(tmp_path):
    """A level whose runs were aligned otherwise than the base's (session 20's origin fallback on
    a straight path) reads 3x the base by definition alone: not a breaking point, but said; compare
    calls a changed alignment 'unmeasured' and refuses two evaluation versions (exit 2)."""
    from blender_sesgen.study.results import FORMAT, aggregate, compare, curves_and_breaks
    from blender_sesgen.errors import SesgenError
    body = ('[world]\nscript = "scene.ses"\n[factors.exposure_time]\nlevels = [0.01, 0.02]\n'
            '[[systems]]\nname = "s"\ncmd = "x {out}"\nlayout = "tum"\nformat = "tum"\n')
    study = load(tmp_path, body)
    m = "ape_trans_rmse"

    def runs(how_level, version=3, how_base="se3"):
        return (_metric_runs([({}, [0.10, 0.10])], m, alignment=how_base, evaluation_version=version)
                + _metric_runs([({"exposure_time": 0.01}, [0.30, 0.30]), ({"exposure_time": 0.02}, [0.11, 0.11])], m,
                               alignment=how_level, evaluation_version=version))
    mixed = runs("origin (path too straight for se3)")
    curves, _, breaks = curves_and_breaks(study, aggregate(mixed, m), m)
    cell = curves["exposure_time"]["s"][0]
    assert not cell["broken"] and "different definitions (the base: se3, evaluation 3, here: origin, evaluation 3)" in cell["redefined"]
    b = breaks["exposure_time"]["s"]
    assert b["level"] is None and b["unmeasured"] and "not compared with the base at 0.01, 0.02" in b["reason"]
    assert curves_and_breaks(study, aggregate(runs("se3"), m), m)[2]["exposure_time"]["s"]["level"] == 0.01

    def doc(rs):
        c, bb, _ = curves_and_breaks(study, aggregate(rs, m), m)
        return {"format": FORMAT, "study": {"metric": m, "evaluation_versions": sorted(
                    {r["metrics"]["evaluation_version"] for r in rs})},
                "factors": [{"name": "exposure_time", "levels": [0.01, 0.02]}], "curves": c, "base": bb, "runs": rs}
    rows = {(r["factor"], r["level"]): r for r in compare(doc(runs("se3")), doc(runs("sim3", how_base="sim3")))}
    assert {r["verdict"] for r in rows.values()} == {"unmeasured"}
    assert "different definitions" in rows[("exposure_time", "0.01")]["detail"]
    assert {r["verdict"] for r in compare(doc(runs("se3")), doc(runs("se3")))} == {"same"}
    with pytest.raises(SesgenError, match="different definitions .OLD: 2, NEW: 3"):
        compare(doc(runs("se3", version=2)), doc(runs("se3")))
    old = doc(runs("se3"))
    del old["study"]["evaluation_versions"]                   # a results.json of format 2: not recorded
    for r in old["runs"]:
        del r["metrics"]["evaluation_version"]
    a, n = tmp_path / "old.json", tmp_path / "new.json"
    a.write_text(json.dumps(old))
    n.write_text(json.dumps(doc(runs("se3"))))
    rc, out, err = cli("study", "compare", str(a), str(n))
    assert rc == 2 and "not recorded (written before format 3)" in out + err and "Traceback" not in out + err


def test_compare_lists_what_only_one_study_has_and_a_verdict_from_one_run(tmp_path):
    """A renamed system or a new level was skipped silently (0 comparisons, exit 0): now each
    is a row 'unmeasured: only in OLD/NEW'. A verdict from one run on each side says it has no
    spread to judge by."""
    from blender_sesgen.study.results import aggregate, compare, curves_and_breaks
    def doc(systems, levels=(0.01, 0.02), value=1.0):
        body = ('[world]\nscript = "scene.ses"\n[factors.exposure_time]\nlevels = [0.01, 0.02]\n' + "".join(
            f'[[systems]]\nname = "{sy}"\ncmd = "x {{out}}"\nlayout = "tum"\nformat = "tum"\n' for sy in systems))
        rs = [r for sy in systems for r in _runs([({}, [1.0]), *(({"exposure_time": lv}, [value]) for lv in levels)], sy)]
        c, b, _ = curves_and_breaks(load(tmp_path, body), aggregate(rs, "ape_trans_rmse"), "ape_trans_rmse")
        return {"format": "sesgen-study-results/3", "study": {"metric": "ape_trans_rmse"},
                "factors": [{"name": "exposure_time", "levels": list(levels)}], "curves": c, "base": b}
    rows = compare(doc(["s", "t"]), doc(["s", "u"]))
    only = {(r["system"], r["detail"].split(":")[0]) for r in rows if r["verdict"] == "unmeasured"}
    assert only == {("t", "only in OLD"), ("u", "only in NEW")}
    assert len(rows) == 9 and {r["verdict"] for r in rows if r["system"] == "s"} == {"same"}
    worse = [r for r in compare(doc(["s"]), doc(["s"], value=1.5)) if r["verdict"] == "worse"]
    assert len(worse) == 2 and all("one run each: no spread to judge by" in r["detail"] for r in worse)


@pytest.mark.parametrize("factor, levels, note", [("rig_speed", "[2.0, 3.0]", True), ("frame_rate", "[5.0, 20.0]", True),
                                                  ("exposure_time", "[0.01, 0.02]", False)])
def test_a_per_frame_measure_over_a_factor_that_changes_the_step_says_so(tmp_path, factor, levels, note):
    """A VO with a steady 1 % error per metre reads 3x the RPE a frame at 3x the rig's speed: a
    'breaking point' from the unit. The breaking point of a per-frame measure over a factor
    that changes the frame's step says so (and points to the per-metre one)."""
    from blender_sesgen.study.results import aggregate, curves_and_breaks
    body = (f'[world]\nscript = "scene.ses"\n[factors.{factor}]\nlevels = {levels}\n'
            '[[systems]]\nname = "s"\ncmd = "x {out}"\nlayout = "tum"\nformat = "tum"\n'
            '[evaluation]\nmetric = "rpe_trans_rmse"\n')
    study = load(tmp_path, body)
    lv = [float(x) for x in levels.strip("[]").split(",")]
    runs = _metric_runs([({}, [0.01]), ({factor: lv[0]}, [0.02]), ({factor: lv[1]}, [0.03])], "rpe_trans_rmse")
    b = curves_and_breaks(study, aggregate(runs, "rpe_trans_rmse"), "rpe_trans_rmse")[2][factor]["s"]
    assert b["level"] == lv[1]
    assert ("rpe_trans_rmse is per frame and" in b["reason"] and "rpe_trans_per_m does not" in b["reason"]) is note
