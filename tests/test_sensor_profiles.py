"""Camera profiles (``SENSOR profile NAME``): the profile's values as defaults of SENSOR, LENS,
TIMING and AUTOEXPOSURE, overridable tag by tag, and binning to the render's size."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from blender_sesgen.errors import ScriptError
from blender_sesgen.render.sensor import pipeline
from blender_sesgen.scene.camera_profiles import PROFILES, at_width
from blender_sesgen.ses.parser import parse_text

HEAD = "CAMERA resolution 256 192 focal 200 baseline 0.1\nFRAMES 2\nSPHERE id 1 position 0 0 5 dim 1\n"


def scene(lines: str):
    return parse_text(HEAD + lines)


def test_a_profile_fills_every_statement_and_each_tag_stays_overridable():
    p = PROFILES["kitti"]
    sc = scene("SENSOR profile kitti readnoise 3\nAUTOEXPOSURE\n")
    s = sc.sensor
    assert (s.profile, s.native_width_px, s.read_noise_e) == ("kitti", p.native_width_px, 3.0)
    assert (s.full_well_e, s.black_level_dn, s.response, s.gamma, s.pixel_um) == (
        p.sensor["fullwell"], p.sensor["black"], "gamma", p.sensor["gamma"], p.sensor["pixel"])
    assert (sc.timing.rate_hz, sc.timing.exposure_s, sc.timing.readout_s) == (10.0, 0.002, 0.0)
    assert (sc.lens.model, sc.lens.defocus_px, sc.lens.vignetting) == ("pinhole", p.lens["defocus"],
                                                                        p.lens["vignetting"])
    assert sc.autoexposure.target == p.autoexposure["target"]
    # the script's statements win tag by tag; the profile fills the rest
    sc = scene("SENSOR profile euroc response srgb\nTIMING rate 100\nLENS vignetting 0 fnumber 4\n"
               "AUTOEXPOSURE target 0.1\n")
    assert (sc.sensor.response, sc.sensor.full_well_e) == ("srgb", PROFILES["euroc"].sensor["fullwell"])
    assert (sc.timing.rate_hz, sc.timing.exposure_s) == (100.0, PROFILES["euroc"].timing["exposure"])
    assert (sc.lens.vignetting, sc.lens.f_number, sc.lens.defocus_px) == (0.0, 4.0, PROFILES["euroc"].lens["defocus"])
    assert sc.autoexposure.target == 0.1
    # a profile's exposure shortens to the script's frame period; auto-exposure stays the script's choice
    sc = scene("SENSOR profile phone\nTIMING rate 1000\n")
    assert sc.timing.exposure_s == pytest.approx(0.001) and sc.timing.readout_s == pytest.approx(0.001)
    assert sc.autoexposure is None and sc.sensor.cfa == "rggb" and sc.sensor.jpeg_quality == 90


def test_without_a_profile_nothing_changes():
    sc = scene("SENSOR readnoise 2\n")
    assert sc.timing is None and sc.lens is None
    assert (sc.sensor.profile, sc.sensor.native_width_px) == (None, 0)
    assert at_width(sc.sensor, None, 64) == (sc.sensor, None)


@pytest.mark.parametrize("line, message", [
    ("SENSOR profile kodak", "SENSOR 'profile' must be one of kitti, euroc, tum, robotcar, phone, got 'kodak'"),
    ("SENSOR profile kitti gamma 2 response srgb", "SENSOR 'gamma' needs 'response gamma'"),
    ("SENSOR profile kitti native 0", "native"),
])
def test_bad_profile_lines_are_one_line_errors(line, message):
    with pytest.raises(ScriptError) as e:
        scene(line + "\n")
    assert message in str(e.value) and "\n" not in str(e.value)


def _flat_raw(sensor, lens, shape, level=0.3, frame=0):
    cam = pipeline.Camera(sensor=sensor, lens=lens, nominal_exposure_s=0.0)
    out = pipeline.process(np.full(shape + (3,), level), cam, pipeline.Shot(0.0, 1.0, frame, 0))
    full = 2 ** sensor.bits - 1
    dn = out.raw_dn if out.raw_dn.ndim == 2 else out.raw_dn[..., 1]
    return (dn.astype(np.float64) - sensor.black_level_dn) / (full - sensor.black_level_dn)


@pytest.mark.parametrize("name", ["kitti", "euroc", "robotcar"])
def test_a_half_size_render_has_the_noise_of_the_sensor_binned_2x2(name):
    """Binning physics as the oracle: the full-size sensor's raw frame averaged over 2x2 blocks
    has the noise (and the level) that the half-size render must have, within 10 %."""
    sc = scene(f"SENSOR profile {name} native 256 bits 12 readnoise 20 rownoise 0 seed 5\n")
    full_s, full_l = at_width(sc.sensor, sc.lens, 256)
    half_s, half_l = at_width(sc.sensor, sc.lens, 128)
    assert (half_s.native_width_px, half_s.full_well_e) == (128, 4 * full_s.full_well_e)
    full = _flat_raw(dataclasses.replace(full_s, seed=1), None, (192, 256))
    binned = full.reshape(96, 2, 128, 2).mean(axis=(1, 3))
    half = _flat_raw(dataclasses.replace(half_s, seed=2), None, (96, 128))
    assert half.mean() == pytest.approx(binned.mean(), rel=0.01)
    assert half.std() == pytest.approx(binned.std(), rel=0.10)
    # and not the unbinned sensor's noise at every render pixel (what the test guards against)
    assert full.std() > 1.6 * half.std()
    # blur stays the same size on the sensor: half the pixels
    assert half_l.defocus_px == pytest.approx(full_l.defocus_px / 2)


def test_resolution_scale_bins_the_profile_in_the_render_plan():
    from blender_sesgen.render.plan import RenderOptions, EffectiveSettings
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    sc = scene("SENSOR profile kitti native 256\n")
    plans = [SensorPlan.create(sc, EffectiveSettings.of(sc, RenderOptions(resolution_scale=r))) for r in (1.0, 0.5)]
    assert [p.width for p in plans] == [256, 128]
    assert plans[1].sensor.full_well_e == pytest.approx(4 * plans[0].sensor.full_well_e)
    assert plans[1].lens_spec.defocus_px == pytest.approx(plans[0].lens_spec.defocus_px / 2)
    settings = plans[1].manifest_entries(2)["sensor"]
    assert (settings["profile"], settings["native_width_px"], settings["full_well_e"]) == (
        "kitti", 128, pytest.approx(4 * PROFILES["kitti"].sensor["fullwell"]))


def test_a_mono_sensor_has_one_channel_and_the_noise_of_a_grey_pixel():
    """A grey camera's noise is per pixel: the same flat patch through a colour sensor
    without CFA, turned grey, has 0.75x less (three independent channels averaged)."""
    from blender_sesgen.render.sensor.autoexposure import LUMA
    mono = scene("SENSOR profile kitti bits 12 response linear seed 1\n").sensor
    assert mono.mono and mono.cfa is None
    colour = dataclasses.replace(mono, mono=False)
    level = np.full((96, 128, 3), 0.3)
    outs = [pipeline.process(level, pipeline.Camera(sensor=s), pipeline.Shot(0.0, 1.0, 0, 0)) for s in (mono, colour)]
    assert outs[0].raw_dn.shape == (96, 128) and outs[1].raw_dn.shape == (96, 128, 3)
    assert (outs[0].rgb8[..., 0] == outs[0].rgb8[..., 2]).all()
    grey_of_colour = outs[1].raw_dn.astype(float) @ LUMA
    assert grey_of_colour.std() / outs[0].raw_dn.std() == pytest.approx(np.linalg.norm(LUMA), rel=0.08)
    with pytest.raises(ScriptError, match="'mono on' is a sensor without colour filters"):
        scene("SENSOR profile kitti cfa rggb\n")


def test_nir_share_is_a_sensor_tag_and_kittis_grey_camera_has_no_ir_cut_filter():
    assert scene("SENSOR profile kitti\n").sensor.nir_share == PROFILES["kitti"].sensor["nir"] > 0
    assert scene("SENSOR profile kitti nir 0\n").sensor.nir_share == 0.0
    assert scene("SENSOR profile euroc\n").sensor.nir_share == 0.0 == scene("SENSOR\n").sensor.nir_share
    with pytest.raises(ScriptError, match="SENSOR 'nir' is the share of the signal the sensor takes from 700-1000 nm"):
        scene("SENSOR nir 1.5\n")


def test_band_colour_mixes_the_entrys_nir_reflectance_in():
    """The sensor's band: (1 - s) visible + s NIR per channel (hand-computed for leaves, whose
    NIR reflectance is ~6x its visible luminance); a darker variant is darker in the NIR too;
    s = 0 and entries without a NIR value are untouched."""
    from blender_sesgen.scene.materials import LIBRARY, band_colour
    leaves = LIBRARY["leaves"]
    out = band_colour(leaves.colour, "leaves", 0.2)
    assert out == pytest.approx(tuple(0.8 * c + 0.2 * leaves.nir for c in leaves.colour))
    dark = band_colour(tuple(0.5 * c for c in leaves.colour), "leaves", 0.2)
    assert dark == pytest.approx(tuple(0.8 * 0.5 * c + 0.2 * 0.5 * leaves.nir for c in leaves.colour))
    assert band_colour(leaves.colour, "leaves", 0.0) == leaves.colour
    assert band_colour((0.1, 0.2, 0.3), "car_paint", 0.5) == (0.1, 0.2, 0.3)
    assert band_colour((0.1, 0.2, 0.3), "not_in_the_library", 0.5) == (0.1, 0.2, 0.3)


@pytest.mark.render
def test_a_sensor_without_ir_cut_filter_sees_foliage_brighter_and_plain_materials_unchanged(tmp_path):
    """Rendered: a patch of library leaves, one of the same material in black (what stays is the
    Principled BSDF's specular layer, which no albedo changes) and a plain grey (non-library)
    patch under the same sky, through SENSOR mono on (visible) and with nir 0.5. The leaves'
    diffuse part relative to grey, (leaves - black) / grey in the EXR beauty, must grow as the
    same material's does, seen in the visible, from its colour to the hand-computed band colour
    ((1 - s) c + s NIR c / luminance per channel, ``MATERIAL ... library leaves colour`` it),
    within 6 %. (Not by the band factor 0.5 + 0.5 NIR / luminance itself: the Principled BSDF's
    diffuse base under its dielectric layer is not linear in the albedo - light the interface
    reflects back down returns -, a plain material's response grows 3.66 x for the factor's
    3.43 here, and the leaves' translucency and tones add to it; session 18.)"""
    from render_support import load_manifest, read_exr, render_text
    from blender_sesgen.scene.materials import LIBRARY, band_colour
    c, nir = LIBRARY["leaves"].colour, LIBRARY["leaves"].nir
    band = band_colour(c, "leaves", 0.5)
    body = ("CAMERA resolution 64 64 focal 40 baseline 0\nSTART position 0 3 0 -90 0 0\n"
            "WORLD sky strength 1 elevation 50 azimuth 30\nLOOK exposure 0\n"
            "MATERIAL name grey colour 0.18 0.18 0.18 roughness 0.9\n"
            "CUBOID id 1 material grey position 0 -0.05 0 dim 20 0.1 20\n"
            "MATERIAL name lv library leaves variation 0\n"
            "MATERIAL name black_leaves library leaves colour 0 0 0 variation 0\n"
            f"MATERIAL name band_leaves library leaves colour {band[0]} {band[1]} {band[2]} variation 0\n"
            "CUBOID id 2 material lv position -1.6 0.01 0 dim 1.2 0.02 1.2\n"
            "CUBOID id 3 material grey position 1.6 0.01 0 dim 1.2 0.02 1.2\n"
            "CUBOID id 4 material black_leaves position 0 0.01 0 dim 1.2 0.02 1.2\n"
            "CUBOID id 5 material band_leaves position 0 0.01 1.6 dim 1.2 0.02 1.2\n")
    ratio = []
    for tag in ("", " nir 0.5"):
        folder = tmp_path / f"r{len(ratio)}"
        folder.mkdir()
        out = render_text(folder, body + f"SENSOR mono on{tag}\n", "--samples", "16")
        m = load_manifest(out)
        exr = read_exr(out / m["files"]["left"][0])
        Y = np.stack([exr[c] for c in m["channels"]["rgb"][:3]], -1) @ np.array([0.2126, 0.7152, 0.0722])
        ids = exr[m["channels"]["object_index"]].astype(int)
        mean = {i: Y[ids == i].mean() for i in range(1, 6)}
        ratio.append((mean[2] - mean[4]) / mean[3])
        if not tag:
            seen = (mean[5] - mean[4]) / (mean[2] - mean[4])     # the band colour seen in the visible
    lum = lambda x: 0.2126 * x[0] + 0.7152 * x[1] + 0.0722 * x[2]  # noqa: E731
    assert lum(band) / lum(c) == pytest.approx(0.5 + 0.5 * nir / lum(c))
    assert seen == pytest.approx(lum(band) / lum(c), rel=0.25)
    assert ratio[1] / ratio[0] == pytest.approx(seen, rel=0.06)


def _settle(plan, image, n=20):
    """The metering values of ``n`` frames of a still ``image`` (each metered at its own
    exposure, as the metering pass does) and the exposure of the frame after them."""
    metered = []
    for _ in range(n):
        metered.append(plan.meter(image, metered))
    return metered, plan.exposures(metered)[-1]


def _signal(plan, image, exposure_s, gain):
    """The chain's normalised raw signal (0 at black, 1 at full scale) of ``image``."""
    cam = pipeline.Camera(sensor=plan.sensor, lens=plan.lens_spec, rays=plan.pixel_rays(),
                          cx=plan.K[0, 2], cy=plan.K[1, 2], nominal_exposure_s=plan.nominal_exposure_s())
    out = pipeline.process(image, cam, pipeline.Shot(exposure_s, gain, 0, 0))
    full = 2 ** plan.sensor.bits - 1
    return (out.raw_dn.astype(np.float64) - plan.sensor.black_level_dn) / (full - plan.sensor.black_level_dn)


def test_auto_exposure_meters_the_vignetted_image_the_sensor_receives():
    """A camera's auto-exposure meters its own image, so the lens's vignetting darkens what it
    meters: on a uniform scene held still the schedule settles where the mean of the image the
    chain forms (optics.vignetting applied by pipeline.process, read back from the raw) is the
    target, with and without vignetting (the metered level alone would leave the vignetted
    image darker than the target); the black level's share of the raw's range is not signal."""
    from blender_sesgen.render.plan import RenderOptions, EffectiveSettings
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    level = 0.05
    for vignetting in (0.0, 0.8):
        sc = scene(f"SENSOR profile kitti native 256 readnoise 0 fullwell 1e9\nLENS vignetting {vignetting}\n"
                   "AUTOEXPOSURE target 0.25 speed 100\n")
        plan = SensorPlan.create(sc, EffectiveSettings.of(sc, RenderOptions()))
        image = np.full((plan.height, plan.width, 3), level)
        metered, (exposure_s, gain) = _settle(plan, image)
        assert _signal(plan, image, exposure_s, gain).mean() == pytest.approx(0.25, abs=0.003)
        if vignetting:
            assert metered[-1] < 0.9 * level      # the test's lens does vignette
        else:
            assert metered[-1] == pytest.approx(level, rel=1e-12)


@pytest.mark.parametrize("profile", ["kitti", "euroc", "robotcar"])
def test_auto_exposure_meters_burnt_out_pixels_at_full_scale(profile):
    """A camera meters its digitised output, where a burnt-out pixel counts at full scale, not
    at its radiance. A still scene a share ``a`` of which is far above full scale (radiance
    40, a window) and the rest at level l settles where the output's mean is the target T:
    the burnt-out pixels at 1 and the rest at (T - a) / (1 - a), so E = (T - a) S t_nom /
    ((1 - a) l) (S: the value of full scale at t_nom and gain 1) - the closed form from the
    image's own pixels; the rule before (the mean radiance, unclipped) exposes ~100 x shorter
    and leaves the rest of the image black. Also for a colour sensor (each channel clips)."""
    from blender_sesgen.render.plan import RenderOptions, EffectiveSettings
    from blender_sesgen.render.sensor.render_plan import SensorPlan
    sc = scene(f"SENSOR profile {profile} native 256 readnoise 0 fullwell 1e9\nLENS vignetting 0\n"
               "AUTOEXPOSURE target 0.4 speed 100 max_gain 1\n")
    plan = SensorPlan.create(sc, EffectiveSettings.of(sc, RenderOptions()))
    image = np.full((plan.height, plan.width, 3), 0.02)
    a_cols = plan.width // 4
    image[:, :a_cols] = 40.0
    a = a_cols / plan.width
    metered, (exposure_s, gain) = _settle(plan, image, 40)
    S, t_nom = plan.full_scale(plan.nominal_exposure_s(), 1.0), plan.nominal_exposure_s()
    E = (0.4 - a) * S * t_nom / ((1 - a) * 0.02)
    assert exposure_s * gain == pytest.approx(E, rel=1e-3)
    x = _signal(plan, image, exposure_s, gain)
    if x.ndim == 3:
        x = x.mean(axis=-1)
    assert x.mean() == pytest.approx(0.4, abs=0.01) and (x[:, :a_cols] >= 1).all()
    # away from the edge (the lens's blur spreads the window's light a few pixels into the rest)
    assert x[:, a_cols + 12:].mean() == pytest.approx((0.4 - a) / (1 - a), abs=0.01)
    unclipped = 0.4 * S * t_nom / image.mean(axis=-1).mean()
    assert E > 50 * unclipped


def test_the_euroc_profile_has_the_temporal_noise_of_euroc_still_frames(shared_data):
    """Oracle: EuRoC's standing MAV (95 still frames of cam0): the variance of consecutive
    frames' difference / 2 by level (photon transfer, bench/camera_profiles.py), at full size
    and binned 2 x 2. The profile's chain on flat fields at those levels, 752 and 376 px wide
    (the binning of at_width), must give it within 15 % at every level 60-200 DN."""
    import importlib.util
    from pathlib import Path
    spec = importlib.util.spec_from_file_location(
        "camera_profiles_bench", Path(__file__).resolve().parents[1] / "bench" / "camera_profiles.py")
    cp = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cp)
    stack = cp.still_frames("euroc")["cam0"]
    n, h, w = stack.shape
    half = stack.reshape(n, h // 2, 2, w // 2, 2).sum(axis=(2, 4), dtype=np.uint16) / 4.0
    sensor = scene("SENSOR profile euroc seed 3\n").sensor
    # the real binned frames are float means (quantisation 1/48 DN^2); the half-size render
    # quantises each binned pixel to 8 bits (1/12), as twin.py's INTER_AREA resize of real frames does
    for width, frames, flat_dn, quantisation in ((752, stack, 1.0, 1 / 12), (376, half, 0.7, 1 / 48)):
        ptc = [(lv, v) for lv, v, _ in cp.temporal_noise(frames, flat_dn=flat_dn) if 60 <= lv <= 200]
        assert len(ptc) >= 8
        levels = np.array([lv for lv, _ in ptc])
        s, _ = at_width(sensor, None, width)
        x = np.repeat((levels - s.black_level_dn) / 255.0, 64)[:, None, None] * np.ones((1, 128, 3))
        dn = [pipeline.process(x, pipeline.Camera(sensor=s), pipeline.Shot(0.0, 1.0, f, 0)).rgb8[..., 0].astype(float)
              for f in (0, 1)]
        model = ((dn[0] - dn[1]) ** 2 / 2).reshape(len(levels), -1).mean(axis=1)
        measured = np.array([v for _, v in ptc]) - quantisation + 1 / 12
        assert model == pytest.approx(measured, rel=0.15), (width, levels, model / measured)
