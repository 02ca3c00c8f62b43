"""The auto-exposure's converged start (``AUTOEXPOSURE start converged``, the default): a real
camera has run before the sequence's first frame, so frame 0 is exposed at the controller's
steady state for what it sees, the fixed point E_0 = target * S * t_nom / m_0(E_0) of frame 0's
own metering (m_0 depends on E through the clipping at full scale), within the exposure and
gain limits; ``start nominal`` keeps the camera switched on at t_nom * g_nom.

Oracles: closed forms from the image's own pixels (a uniform scene: E_0 = T S t_nom / l; a
window a share a of the image far above full scale, the rest at l: E_0 = (T - a) S t_nom /
((1 - a) l)), the chain's own output (its normalised raw signal's mean is the target at frame
0), the limits, and the schedule of the whole sequence for any split of the frames. Pure."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.errors import ScriptError
from blender_sesgen.render.sensor import autoexposure, pipeline
from blender_sesgen.ses import parse_string
from blender_sesgen.ses.parser import parse_text

HEAD = "CAMERA resolution 256 192 focal 200 baseline 0.1\nFRAMES 2\nSPHERE id 1 position 0 0 5 dim 1\n"


def _plan(lines: str):
    from blender_sesgen.render.plan import EffectiveSettings, RenderOptions
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    sc = parse_text(HEAD + lines)
    return SensorPlan.create(sc, EffectiveSettings.of(sc, RenderOptions()))


def _signal(plan, image, exposure_s, gain):
    """The chain's normalised raw signal (0 at black, 1 at full scale) of ``image``."""
    cam = pipeline.Camera(sensor=plan.sensor, lens=plan.lens_spec, rays=plan.pixel_rays(),
                          cx=plan.K[0, 2], cy=plan.K[1, 2], nominal_exposure_s=plan.nominal_exposure_s())
    out = pipeline.process(image, cam, pipeline.Shot(exposure_s, gain, 0, 0))
    full = 2 ** plan.sensor.bits - 1
    x = (out.raw_dn.astype(np.float64) - plan.sensor.black_level_dn) / (full - plan.sensor.black_level_dn)
    return x.mean(axis=-1) if x.ndim == 3 else x


def _start(plan, image):
    """Frame 0's metered value (as the metering pass takes it) and frame 0's (exposure_s, gain)."""
    m0 = plan.meter(image, [])
    return m0, plan.exposures([m0])[0]


@pytest.mark.parametrize("profile", ["kitti", "euroc"])
def test_a_uniform_scene_starts_at_the_exposure_that_meters_the_target(profile):
    """Unclipped: m_0 does not depend on E, so E_0 = T S t_nom / l in closed form (l the
    scene's level, S the linear value of full scale at t_nom and gain 1); the chain's frame 0
    then reads the target, and frame 1 keeps the exposure (the steady state). The old start
    (t_nom, g_nom) reads level l * S^-1 instead (0.05 here: the target is 0.25)."""
    plan = _plan(f"SENSOR profile {profile} native 256 readnoise 0 fullwell 1e9\nLENS vignetting 0\n"
                 "AUTOEXPOSURE target 0.25 speed 3\n")
    level = 0.02
    image = np.full((plan.height, plan.width, 3), level)
    m0, (t0, g0) = _start(plan, image)
    S, t_nom = plan.full_scale(plan.nominal_exposure_s(), 1.0), plan.nominal_exposure_s()
    assert m0 == pytest.approx(level, rel=1e-12)
    assert t0 * g0 == pytest.approx(0.25 * S * t_nom / level, rel=1e-9)
    assert _signal(plan, image, t0, g0).mean() == pytest.approx(0.25, abs=0.003)
    t1, g1 = plan.exposures([m0, plan.meter(image, [m0])])[1]
    assert t1 * g1 == pytest.approx(t0 * g0, rel=1e-9)
    assert abs(t0 * g0 / (t_nom * plan.sensor.gain) - 1) > 0.5       # not where the camera was switched on


@pytest.mark.parametrize("profile", ["kitti", "euroc", "robotcar"])
def test_a_scene_with_a_burnt_out_window_starts_at_its_clipped_fixed_point(profile):
    """A share a of the image at radiance 40 (far above full scale at any exposure the
    controller reaches), the rest at l: the output's mean is the target T at frame 0 when
    E_0 = (T - a) S t_nom / ((1 - a) l) (the burnt-out pixels count at full scale) - the closed
    form from the image's own pixels; the fixed point's equation E_0 m_0(E_0) = T S t_nom holds
    to 1e-6, and the chain's frame 0 reads T. Also for a colour sensor (each channel clips)."""
    plan = _plan(f"SENSOR profile {profile} native 256 readnoise 0 fullwell 1e9\nLENS vignetting 0\n"
                 "AUTOEXPOSURE target 0.4 speed 3 max_gain 1\n")
    image = np.full((plan.height, plan.width, 3), 0.02)
    a_cols = plan.width // 4
    image[:, :a_cols] = 40.0
    a = a_cols / plan.width
    m0, (t0, g0) = _start(plan, image)
    S, t_nom = plan.full_scale(plan.nominal_exposure_s(), 1.0), plan.nominal_exposure_s()
    assert t0 * g0 == pytest.approx((0.4 - a) * S * t_nom / ((1 - a) * 0.02), rel=1e-6)
    assert t0 * g0 * plan.meter_at(image, t0, g0) == pytest.approx(0.4 * S * t_nom, rel=1e-6)
    x = _signal(plan, image, t0, g0)
    assert x.mean() == pytest.approx(0.4, abs=0.01) and (x[:, :a_cols] >= 1).all()


def test_a_textured_partly_clipped_scene_satisfies_the_fixed_point_equation():
    """No closed form: a log-normal image (sky-like highlights) with the lens's vignetting,
    where about a tenth clips at the fixed point. Frame 0's exposure E_0 satisfies E_0 =
    T S t_nom / m_0(E_0) to 1e-6 (m_0 the metering at E_0 itself, computed here from the
    pixels: the vignetted luminance clipped at full scale), and it is the only such E: 5 %
    more or less exposure misses the equation by the clipping's share."""
    plan = _plan("SENSOR profile kitti readnoise 0\nAUTOEXPOSURE target 0.28\n")
    rng = np.random.default_rng(5)
    image = np.exp(rng.normal(-2.0, 1.2, (plan.height, plan.width, 1))) * np.ones(3)
    _, (t0, g0) = _start(plan, image)
    E0, S, t_nom = t0 * g0, plan.full_scale(plan.nominal_exposure_s(), 1.0), plan.nominal_exposure_s()
    lum = (image @ autoexposure.LUMA) * plan.illumination_at(image.shape)

    def m(E):
        return np.minimum(lum, plan.full_scale(E / g0, g0)).mean()

    assert E0 * m(E0) == pytest.approx(0.28 * S * t_nom, rel=1e-6)
    assert 0.03 < (lum >= plan.full_scale(t0, g0)).mean() < 0.3          # it does clip
    assert 1.05 * E0 * m(1.05 * E0) > 1.01 * 0.28 * S * t_nom
    assert 0.95 * E0 * m(0.95 * E0) < 0.99 * 0.28 * S * t_nom


def test_the_converged_start_stays_within_the_exposure_and_gain_limits():
    """A scene too dark for the longest exposure at the highest gain starts there (t = 1 /
    rate - readout, g = max_gain); one too bright for the shortest starts at min_exposure and
    gain 1: the fixed point of the map bounded by the limits."""
    plan = _plan("SENSOR profile kitti native 256 readnoise 0 fullwell 1e9\nLENS vignetting 0\n"
                 "TIMING rate 10 exposure 0.002\nAUTOEXPOSURE target 0.25 max_gain 4 min_exposure 0.0001\n")
    dark = np.full((plan.height, plan.width, 3), 1e-6)
    _, (t, g) = _start(plan, dark)
    assert (t, g) == (pytest.approx(0.1), pytest.approx(4.0))
    bright = np.full((plan.height, plan.width, 3), 1e3)
    _, (t, g) = _start(plan, bright)
    assert (t, g) == (pytest.approx(1e-4), 1.0)


def test_start_nominal_keeps_the_camera_switched_on_at_the_sequence_start():
    """``start nominal``: frame 0 at t_nom * g_nom whatever it meters, and a render of frame 0
    alone meters nothing (the schedule as before the converged start)."""
    plan = _plan("SENSOR profile kitti native 256\nLENS vignetting 0\nAUTOEXPOSURE start nominal\n")
    image = np.full((plan.height, plan.width, 3), 0.02)
    m0 = plan.meter(image, [])
    assert plan.exposures([m0])[0] == (plan.nominal_exposure_s(), plan.sensor.gain)
    assert plan.exposures([])[0] == (plan.nominal_exposure_s(), plan.sensor.gain)
    assert plan.metered_frames([0], 45) == 0 and plan.metered_frames([0, 1], 45) == 1
    converged = _plan("SENSOR profile kitti native 256\nLENS vignetting 0\nAUTOEXPOSURE\n")
    assert converged.metered_frames([0], 45) == 1 and converged.metered_frames([0], 1) == 1
    with pytest.raises(ValueError):
        converged.exposures([])


@pytest.mark.parametrize("frames", [[0], [0, 1], [2], [5, 6, 7], list(range(100)), [99]])
def test_any_split_of_the_frames_gets_the_whole_sequences_converged_exposures(frames):
    """A render meters the frames before its last and, with the converged start, frame 0 too:
    every one of its frames gets the exposure of the whole sequence's schedule (the oracle: the
    schedule from every frame metered), frame 0 alone included."""
    rng = np.random.default_rng(3)
    metered = list(np.exp(rng.normal(-1.5, 1.0, 100)))
    c = autoexposure.ExposureControl(nominal_exposure_s=0.002, nominal_gain=1.0, rate_hz=20.0, readout_s=0.0,
                                     target=0.2, speed=4.0, saturation=1.0, max_exposure_s=0.04, max_gain=8.0,
                                     min_exposure_s=1e-5, converged_start=True)
    whole = autoexposure.exposure_schedule(metered, c)
    upto = autoexposure.metered_frames(frames, len(metered), converged=True)
    part = autoexposure.exposure_schedule(metered[:upto], c)
    assert [part[k] for k in frames] == [whole[k] for k in frames]
    assert upto == max(1, max(frames)) and upto < 100
    t0, g0 = whole[0]
    assert t0 * g0 == pytest.approx(0.2 * 0.002 / metered[0], rel=1e-12)


def test_the_start_tag_parses_and_a_bad_value_is_a_file_line_col_error():
    head = "CAMERA resolution 64 48 focal 50 baseline 0.1\nQUAD id 1 vertices -1 0 -1 1 0 -1 1 1 -1 -1 1 -1\n" \
           "TIMING exposure 0.002\nSENSOR\n"
    assert parse_string(head + "AUTOEXPOSURE\n").autoexposure.start == "converged"
    assert parse_string(head + "AUTOEXPOSURE start nominal\n").autoexposure.start == "nominal"
    with pytest.raises(ScriptError) as e:
        parse_string(head + "AUTOEXPOSURE target 0.2 start later\n", source="s.ses")
    text = str(e.value)
    assert text.startswith("s.ses:5:31: error:") and "start" in text and "converged" in text, text
