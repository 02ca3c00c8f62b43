"""The camera and IMU as sensors: TIMING, LENS, SENSOR, AUTOEXPOSURE and IMU statements ->
their :mod:`blender_sesgen.scene.model` values, with their value checks (all optional; an absent
statement leaves its effect off).

Checks that need the rig (the lens folding check needs the image size and K) run in
:func:`sensor_models` after CAMERA is known.
"""
from __future__ import annotations

from typing import Optional

from ..scene import model
from ..contract.lens import Lens as LensModel
from ..contract.lens import fold_problem
from ..contract.timing import stream_problem
from ..scene.camera_profiles import PROFILES, Profile
from .checks import Checks, scalar, vec
from .environment import _seed
from .statements import ParsedStatement

MAX_RATE_HZ = 100_000.0


def _nonneg(stmt, check, *names):
    for n in names:
        check.positive(stmt, n, allow_zero=True)


def timing(stmt: Optional[ParsedStatement], check: Checks, profile: dict = {}) -> Optional[model.Timing]:
    """``profile``: a camera profile's TIMING tags, the defaults (a profile's exposure and readout
    shorten to the frame period of the script's rate)."""
    if stmt is None and not profile:
        return None
    if stmt is None:
        return model.Timing(rate_hz=float(profile.get("rate", model.Timing.rate_hz)),
                            exposure_s=float(profile.get("exposure", 0.0)), readout_s=float(profile.get("readout", 0.0)))
    check.positive(stmt, "rate")
    _nonneg(stmt, check, "exposure", "readout")
    rate = float(scalar(stmt, "rate", profile.get("rate", model.Timing.rate_hz)))
    if rate > MAX_RATE_HZ:
        check.err(stmt.tags["rate"].tokens[0], f"TIMING 'rate' must be at most {MAX_RATE_HZ:g} Hz, got {rate:g}")
    period = 1.0 / rate if rate > 0 else float("inf")
    exposure = float(scalar(stmt, "exposure", min(profile.get("exposure", 0.0), period)))
    readout = float(scalar(stmt, "readout", min(profile.get("readout", 0.0), period)))
    for name, value in (("exposure", exposure), ("readout", readout)):
        if name in stmt.tags and value > period * (1 + 1e-9):
            check.err(stmt.tags[name].tokens[0], f"TIMING '{name}' ({value:g} s) is longer than the frame "
                                                 f"period (1 / rate = {period:g} s)")
    return model.Timing(rate_hz=rate, start_s=float(scalar(stmt, "start", 0.0)), exposure_s=exposure,
                        readout_s=readout, blur=stmt.get("blur", "on") == "on", still=stmt.get("still", "on") == "on")


def lens(stmt: Optional[ParsedStatement], check: Checks, profile: dict = {}) -> Optional[model.Lens]:
    """``profile``: a camera profile's LENS tags, the defaults (a pinhole lens with the
    profile's optics when the script has no LENS)."""
    if stmt is None and not profile:
        return None
    if stmt is None:
        return model.Lens(model="pinhole", coeffs=(), f_number=float(profile.get("fnumber", 0.0)),
                          defocus_px=float(profile.get("defocus", 0.0)),
                          vignetting=float(profile.get("vignetting", 0.0)),
                          chromatic_px=float(profile.get("chromatic", 0.0)))
    if "brown" in stmt.tags and "fisheye" in stmt.tags:
        check.err(stmt.tags["fisheye"].tag, "LENS takes one distortion model: 'brown' or 'fisheye', not both")
    _nonneg(stmt, check, "fnumber", "defocus", "vignetting")
    f_number = float(scalar(stmt, "fnumber", profile.get("fnumber", 0.0)))
    if 0 < f_number < 0.5:
        check.err(stmt.tags["fnumber"].tokens[0], f"LENS 'fnumber' must be at least 0.5 (or 0 = no diffraction), "
                                                  f"got {f_number:g}")
    m, coeffs = "pinhole", ()
    if "brown" in stmt.tags:
        m, coeffs = "brown", tuple(vec(stmt, "brown")) + ((0.0,) if len(stmt.tags["brown"].values) == 4 else ())
    elif "fisheye" in stmt.tags:
        m, coeffs = "kannala_brandt", tuple(vec(stmt, "fisheye"))
    return model.Lens(model=m, coeffs=coeffs, f_number=f_number,
                      defocus_px=float(scalar(stmt, "defocus", profile.get("defocus", 0.0))),
                      vignetting=float(scalar(stmt, "vignetting", profile.get("vignetting", 0.0))),
                      chromatic_px=float(scalar(stmt, "chromatic", profile.get("chromatic", 0.0))))


def _profile(stmt: Optional[ParsedStatement]) -> Optional[Profile]:
    return PROFILES[stmt.get("profile")] if stmt is not None and "profile" in stmt.tags else None


def sensor(stmt: Optional[ParsedStatement], check: Checks) -> Optional[model.Sensor]:
    """SENSOR; ``profile NAME`` gives every tag the script leaves out the camera's value."""
    if stmt is None:
        return None
    prof = _profile(stmt)
    p = prof.sensor if prof else {}

    def val(name, default):
        return scalar(stmt, name, p.get(name, default))

    for n in ("fullwell", "saturation", "pixel", "gain", "gamma", "native"):
        check.positive(stmt, n)
    _nonneg(stmt, check, "readnoise", "dark", "prnu", "dsnu", "rownoise", "black", "fill", "olpf")
    bits = stmt.tags.get("bits")
    if bits is not None and not 8 <= bits.values[0] <= 16:
        check.err(bits.tokens[0], f"SENSOR 'bits' must lie in 8..16, got {bits.tokens[0].text}")
    jpeg = stmt.tags.get("jpeg")
    if jpeg is not None and not 1 <= jpeg.values[0] <= 100:
        check.err(jpeg.tokens[0], f"SENSOR 'jpeg' quality must lie in 1..100, got {jpeg.tokens[0].text}")
    for n in ("fill", "nir"):
        t = stmt.tags.get(n)
        if t is not None and not 0 <= t.values[0] <= 1:
            what = ("the pixel aperture as a fraction of the pitch" if n == "fill" else
                    "the share of the signal the sensor takes from 700-1000 nm")
            check.err(t.tokens[0], f"SENSOR '{n}' is {what} (0..1), got {t.tokens[0].text}")
    nbits = int(val("bits", model.Sensor.bits))
    black = float(val("black", 0.0))
    if black >= 2 ** nbits - 1:
        tok = stmt.tags["black"].tokens[0] if "black" in stmt.tags else stmt.tags["bits"].tokens[0]
        check.err(tok, f"SENSOR 'black' ({black:g} DN) must be below the white level {2 ** nbits - 1} of {nbits} bits")
    response = stmt.get("response", p.get("response"))
    if "gamma" in stmt.tags and (response or "gamma") != "gamma":
        check.err(stmt.tags["gamma"].tag, "SENSOR 'gamma' needs 'response gamma'")
    mono = stmt.get("mono", p.get("mono", "off")) == "on"
    cfa = stmt.get("cfa", p.get("cfa"))
    if mono and cfa:
        tag = stmt.tags.get("mono") or stmt.tags["cfa"]
        check.err(tag.tag, "SENSOR 'mono on' is a sensor without colour filters: it takes no 'cfa' "
                           "(write 'mono off' for a colour sensor)")
    d = model.Sensor
    return model.Sensor(
        full_well_e=float(val("fullwell", d.full_well_e)), read_noise_e=float(val("readnoise", 0.0)),
        dark_current_e_s=float(val("dark", 0.0)), prnu=float(val("prnu", 0.0)),
        dsnu_e=float(val("dsnu", 0.0)), row_noise_e=float(val("rownoise", 0.0)),
        cfa=cfa, mono=mono, bits=nbits, gain=float(val("gain", 1.0)), black_level_dn=black,
        saturation=float(val("saturation", 1.0)),
        response=response or ("gamma" if "gamma" in stmt.tags else "srgb"),
        gamma=float(val("gamma", d.gamma)), pixel_um=float(val("pixel", d.pixel_um)),
        fill_factor=float(val("fill", 0.0)), olpf_px=float(val("olpf", 0.0)),
        jpeg_quality=int(val("jpeg", 0)), seed=_seed(stmt, check), profile=prof.name if prof else None,
        native_width_px=int(scalar(stmt, "native", prof.native_width_px if prof else 0)),
        nir_share=float(val("nir", 0.0)))


def autoexposure(stmt: Optional[ParsedStatement], check: Checks, profile: dict = {}) -> Optional[model.AutoExposure]:
    """``profile``: a camera profile's AUTOEXPOSURE tags, the defaults (only where the script
    writes AUTOEXPOSURE: exposure control is the script's choice)."""
    if stmt is None:
        return None
    for n in ("target", "speed", "max_gain", "min_exposure"):
        check.positive(stmt, n)
    check.positive(stmt, "max_exposure", allow_zero=True)
    target = float(scalar(stmt, "target", profile.get("target", model.AutoExposure.target)))
    if target >= 1.0:
        check.err(stmt.tags["target"].tokens[0], f"AUTOEXPOSURE 'target' is a fraction of full scale (< 1), got {target:g}")
    max_gain = float(scalar(stmt, "max_gain", model.AutoExposure.max_gain))
    if 0 < max_gain < 1:
        check.err(stmt.tags["max_gain"].tokens[0], f"AUTOEXPOSURE 'max_gain' must be at least 1, got {max_gain:g}")
    d = model.AutoExposure
    return model.AutoExposure(target=target, speed=float(scalar(stmt, "speed", profile.get("speed", d.speed))),
                              max_exposure_s=float(scalar(stmt, "max_exposure", 0.0)), max_gain=max_gain,
                              min_exposure_s=float(scalar(stmt, "min_exposure", d.min_exposure_s)),
                              start=stmt.get("start", d.start))


def imu(stmt: Optional[ParsedStatement], check: Checks) -> Optional[model.Imu]:
    if stmt is None:
        return None
    check.positive(stmt, "rate")
    check.positive(stmt, "gravity", allow_zero=True)
    _nonneg(stmt, check, "gyro_noise", "gyro_walk", "accel_noise", "accel_walk")
    rate = float(scalar(stmt, "rate", model.Imu.rate_hz))
    if rate > MAX_RATE_HZ:
        check.err(stmt.tags["rate"].tokens[0], f"IMU 'rate' must be at most {MAX_RATE_HZ:g} Hz, got {rate:g}")
    pos = vec(stmt, "position", (0.0, 0.0, 0.0))
    d = model.Imu
    return model.Imu(rate_hz=rate, gyro_noise=float(scalar(stmt, "gyro_noise", d.gyro_noise)),
                     gyro_walk=float(scalar(stmt, "gyro_walk", d.gyro_walk)),
                     accel_noise=float(scalar(stmt, "accel_noise", d.accel_noise)),
                     accel_walk=float(scalar(stmt, "accel_walk", d.accel_walk)),
                     position=tuple(pos[:3]), rotation_deg=tuple(pos[3:]) or (0.0, 0.0, 0.0),
                     time_offset_s=float(scalar(stmt, "offset", 0.0)),
                     gravity=float(scalar(stmt, "gravity", d.gravity)), seed=_seed(stmt, check))


def sensor_models(seen: dict[str, ParsedStatement], rig: model.Rig, check: Checks, n_frames: int = 1) -> dict:
    """The Scene fields of the five sensor statements, with the checks across statements
    (``n_frames``: the sequence's, which bounds the IMU stream and the timestamps)."""
    prof = _profile(seen.get("SENSOR"))
    out = dict(timing=timing(seen.get("TIMING"), check, prof.timing if prof else {}),
               lens=lens(seen.get("LENS"), check, prof.lens if prof else {}),
               sensor=sensor(seen.get("SENSOR"), check),
               autoexposure=autoexposure(seen.get("AUTOEXPOSURE"), check, prof.autoexposure if prof else {}),
               imu=imu(seen.get("IMU"), check))
    t, i = out["timing"] or model.Timing(), out["imu"]
    if t.rate_hz > 0 and (i is None or i.rate_hz > 0):
        problem = stream_problem(n_frames, t.rate_hz, t.start_s, i.rate_hz if i is not None else None)
        where = seen.get("IMU") if "IMU stream" in problem else seen.get("TIMING")
        if problem and where is not None:
            check.err(where.token, f"{where.keyword}: {problem}")
    lens_m, lens_stmt = out["lens"], seen.get("LENS")
    if lens_m is not None and lens_m.model != "pinhole":
        tag = lens_stmt.tags["brown" if lens_m.model == "brown" else "fisheye"]
        problem = fold_problem(LensModel.from_K(lens_m.model, lens_m.coeffs, rig.K()), rig.width, rig.height)
        if problem:
            check.err(tag.tag, f"LENS {tag.tag.text}: {problem}")
    ae = seen.get("AUTOEXPOSURE")
    if ae is not None:
        t = out["timing"]
        if seen.get("SENSOR") is None:
            check.err(ae.token, "AUTOEXPOSURE needs a SENSOR statement (it drives the sensor's exposure and gain)")
        if t is None or t.exposure_s <= 0:
            check.err(ae.token, "AUTOEXPOSURE needs TIMING with an exposure > 0 (the nominal exposure time: the scale of its target)")
        a = out["autoexposure"]
        if a is not None and t is not None and t.rate_hz > 0:
            longest = 1.0 / t.rate_hz - t.readout_s    # an exposure ends before the next frame's readout
            for name, value in (("max_exposure", a.max_exposure_s), ("min_exposure", a.min_exposure_s)):
                if name in ae.tags and value > longest * (1 + 1e-9):
                    check.err(ae.tags[name].tokens[0], f"AUTOEXPOSURE '{name}' ({value:g} s) is longer than the frame "
                                                       f"period less the readout (1 / rate - readout = {longest:g} s)")
            if a.max_exposure_s > 0 and a.min_exposure_s > a.max_exposure_s:
                tag = ae.tags.get("min_exposure") or ae.tags["max_exposure"]
                check.err(tag.tokens[0], f"AUTOEXPOSURE 'min_exposure' ({a.min_exposure_s:g} s) is longer than "
                                         f"'max_exposure' ({a.max_exposure_s:g} s)")
    return out
