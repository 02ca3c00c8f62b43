"""The add-on panel's script summary (pure: no bpy): what it says about moving objects and the
camera as a sensor, checked against the numbers written in the script."""
from blender_sesgen.addon.state import summary_lines
from blender_sesgen.ses import parse_string

SCRIPT = """CAMERA resolution 64 48 focal 50 baseline 0.1
START position 0 1 4
QUAD id 1 texture 3 vertices -3 0 -2  3 0 -2  3 3 -2  -3 3 -2
CUBOID id 7 name car texture 4 position -1 0.5 0 dim 0.6 0.6 0.6
SPHERE id 8 name ball texture 2 position 1 0.5 0 dim 0.3
MOVE id 7 twist 0.2 0 0 0 10 0
MOVE id 8 frame 3 position 1 1 0
TIMING rate 30 exposure 0.004 readout 0.02
LENS brown -0.28 0.07 0.0002 0.00002 fnumber 2.8 vignetting 1
SENSOR fullwell 9000 readnoise 2.5 cfa rggb bits 12 seed 3
IMU rate 200 position 0.05 0 0 seed 4
FRAMES 5
"""


def test_summary_names_moving_objects_timing_lens_sensor_and_imu():
    lines = summary_lines(parse_string(SCRIPT))
    assert "Moving: 2 object(s) (car: twist, ball: keys)" in lines
    assert "Timing: 30 Hz, exposure 4 ms, readout 20 ms, motion blur" in lines
    assert "Lens: brown, f/2.8, vignetting 1" in lines
    assert "Sensor: full well 9000 e-, read noise 2.5 e-, 12 bit, CFA rggb" in lines
    assert "IMU: 200 Hz, seed 4" in lines


def test_a_plain_script_shows_no_sensor_lines():
    lines = summary_lines(parse_string(SCRIPT.split("MOVE")[0] + "FRAMES 2\n"))
    assert not [ln for ln in lines if ln.split(":")[0] in ("Moving", "Timing", "Lens", "Sensor", "IMU")]


def test_the_world_override_replaces_the_scripts_world_and_keeps_its_line_numbers():
    from blender_sesgen.addon.state import script_with_world
    text = SCRIPT.replace("FRAMES 5", "  world sky strength 0.5 // the script's own\nFRAMES 5")
    edited = script_with_world(text, "sunset", 2.0, 30.0)
    old, new = text.splitlines(), edited.splitlines()
    assert new[: len(old)] == [("// " + ln) if ln.lstrip().lower().startswith("world ") else ln for ln in old]
    scene = parse_string(edited)
    w = scene.world
    assert (w.kind, w.hdri, w.strength, w.rotation_deg) == ("hdri", "sunset", 2.0, 30.0)
    assert parse_string(text).world.kind == "sky"


def test_the_summary_names_a_camera_profile():
    lines = summary_lines(parse_string(SCRIPT.replace("SENSOR fullwell 9000", "SENSOR profile kitti mono off fullwell 9000")))
    assert "Sensor: profile kitti (per pixel of 1226 px), full well 9000 e-, read noise 2.5 e-, 12 bit, CFA rggb" in lines


def test_the_camera_override_replaces_the_scripts_sensor_and_keeps_its_line_numbers():
    from blender_sesgen.addon.state import script_with_profile
    edited = script_with_profile(SCRIPT, "euroc")
    old, new = SCRIPT.splitlines(), edited.splitlines()
    assert new[: len(old)] == [("// " + ln) if ln.startswith("SENSOR") else ln for ln in old]
    scene = parse_string(edited)
    from blender_sesgen.scene.camera_profiles import PROFILES
    assert (scene.sensor.profile, scene.sensor.full_well_e, scene.sensor.cfa) == (
        "euroc", PROFILES["euroc"].sensor["fullwell"], None)
    assert scene.timing.rate_hz == 30      # the script's TIMING stays; the profile fills only what it leaves out


def test_the_summary_says_when_the_script_holds_a_still_cameras_noise():
    base = SCRIPT.split("MOVE")[0] + "TIMING rate 20 exposure 0.01{}\nFRAMES 3\n"
    assert "Timing: 20 Hz, exposure 10 ms, readout 0 ms, motion blur, still camera" in summary_lines(
        parse_string(base.format("")))
    assert "Timing: 20 Hz, exposure 10 ms, readout 0 ms, motion blur" in summary_lines(
        parse_string(base.format(" still off")))


def test_the_timing_overrides_still_toggle_reaches_the_render_plan(tmp_path):
    """The panel's Timing override carries Still Camera (default on, as TIMING's) into the
    RenderOptions, and the render plan holds no still stretch when it is off; without the
    override the script's TIMING still rules."""
    import pytest
    pytest.importorskip("bpy")
    from blender_sesgen.addon import props, ui
    from blender_sesgen.render.plan import RenderPlan
    # the property group's annotations are text (``from __future__ import annotations``): evaluated there
    defaults = {k: eval(p, vars(props)).keywords.get("default")
                for k, p in props.SESGEN_PG_settings.__annotations__.items()}
    assert defaults["still"] is True
    import inspect
    assert '"motion_blur", "still")' in inspect.getsource(ui)          # shown beside Motion Blur
    script = tmp_path / "s.ses"
    script.write_text(SCRIPT.split("MOVE")[0] + "TIMING rate 20 exposure 0.01\nSENSOR seed 1\n"
                      "RENDER samples 4 denoise off\nFRAMES 3\n")
    values = dict(defaults, quality="script", override_timing=True, rate_hz=20.0, exposure_ms=10.0, motion_blur=True)
    refs = {}
    for name, v in (("on", dict(values)), ("off", dict(values, still=False)),
                    ("script", dict(values, override_timing=False, still=False))):
        o = props.render_options(v)
        assert o.still is {"on": True, "off": False, "script": None}[name]
        refs[name] = RenderPlan.from_file(script, o).sensor.still_refs
    assert refs == {"on": (0, 0, 0), "off": (), "script": (0, 0, 0)}
