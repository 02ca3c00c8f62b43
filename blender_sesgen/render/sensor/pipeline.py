"""The per-frame camera chain: linear render -> optics -> electrons -> noise -> CFA ->
quantised raw -> demosaic (a mono sensor: luminance, one channel) -> response -> 8-bit RGB (numpy only; runs at render time).

The EXR beauty and every ground-truth pass stay clean: this chain only writes the sensor
images (docs/output-format.md, "Sensor images").
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ...contract import cfa
from . import optics, raw
from .autoexposure import LUMA


def output8(x: np.ndarray, sensor) -> np.ndarray:
    """The camera's 8-bit output of normalised linear values x (0 at the black level, 1 at
    white): the response curve above the black level, which the output keeps (as the files of
    KITTI, EuRoC and RobotCar hold it: their darkest pixels sit there), quantised to 8 bits.
    The response runs on the raw values, so a raw of more bits than 8 leaves no unused codes."""
    pedestal = sensor.black_level_dn / (2 ** sensor.bits - 1)
    return raw.quantise(pedestal + (1.0 - pedestal) * raw.response(x, sensor.response, sensor.gamma), 8)


@dataclass(frozen=True)
class SensorFrame:
    raw_dn: np.ndarray            # (H, W) mosaic or grey, or (H, W, 3); uint16, values 0 .. 2^bits - 1
    rgb8: np.ndarray              # (H, W, 3) uint8 after demosaic and response
    exposure_s: float
    gain: float


def optical_image(linear_rgb: np.ndarray, lens, sensor, rays: Optional[np.ndarray], cx: float, cy: float) -> np.ndarray:
    """Lens MTF, chromatic aberration and vignetting on the linear render."""
    img = np.asarray(linear_rgb, dtype=np.float64)[..., :3]
    if lens is None and sensor is None:
        return img
    f_number = lens.f_number if lens else 0.0
    defocus = lens.defocus_px if lens else 0.0
    fill = sensor.fill_factor if sensor else 0.0
    olpf = sensor.olpf_px if sensor else 0.0
    if f_number or defocus or fill or olpf:
        img = optics.apply_mtf(img, pixel_um=sensor.pixel_um if sensor else 3.0, f_number=f_number,
                               defocus_px=defocus, fill_factor=fill, olpf_px=olpf)
    if lens is not None and lens.chromatic_px:
        img = optics.chromatic_aberration(img, cx, cy, lens.chromatic_px)
    if lens is not None and lens.vignetting and rays is not None:
        img = img * optics.vignetting(rays, lens.vignetting)[..., None]
    return img


@dataclass(frozen=True)
class Camera:
    """What stays fixed over a render: the sensor (``model.Sensor``), the lens's optics
    (``model.Lens``), each pixel's unit ray (vignetting), the principal point (chromatic
    aberration) and the nominal exposure."""
    sensor: object
    lens: object = None
    rays: Optional[np.ndarray] = None
    cx: float = 0.0
    cy: float = 0.0
    nominal_exposure_s: float = 0.0


@dataclass(frozen=True)
class Shot:
    """One view of one frame: its exposure and gain, and the frame and view (the noise seeds)."""
    exposure_s: float
    gain: float
    frame: int
    view_index: int


def photosite_signal(img: np.ndarray, sensor, exposure_s: float, nominal_exposure_s: float) -> np.ndarray:
    """The mean signal (electrons, before clipping at the full well) each photosite collects from
    the optical image ``img`` (linear, the render's scale: ``sensor.saturation`` fills the well at
    the nominal exposure): a grey sensor's luminance, a colour sensor's mosaic."""
    ratio = exposure_s / nominal_exposure_s if nominal_exposure_s > 0 else 1.0
    signal = np.clip(img, 0.0, None) * (sensor.full_well_e / sensor.saturation * ratio)
    if sensor.mono:
        return signal @ LUMA
    if sensor.cfa:
        return cfa.mosaic(signal, sensor.cfa)
    return signal


def process(linear_rgb: np.ndarray, camera: Camera, shot: Shot, fpn_cache: Optional[dict] = None) -> SensorFrame:
    """One view of one frame through the whole chain (see the module docstring)."""
    sensor, lens, nominal_exposure_s = camera.sensor, camera.lens, camera.nominal_exposure_s
    exposure_s, gain, frame, view_index = shot.exposure_s, shot.gain, shot.frame, shot.view_index
    img = optical_image(linear_rgb, lens, sensor, camera.rays, camera.cx, camera.cy)
    signal = photosite_signal(img, sensor, exposure_s, nominal_exposure_s)
    key = (view_index, signal.shape)
    cache = fpn_cache if fpn_cache is not None else {}
    if key not in cache:
        cache[key] = raw.fixed_pattern(signal.shape, sensor.prnu, sensor.dsnu_e, sensor.seed, view_index)
    prnu_map, dsnu_map = cache[key]
    rng = np.random.default_rng([int(sensor.seed), int(frame), int(view_index), 0x5E5])
    dn = raw.capture(signal, sensor, gain=gain, exposure_s=exposure_s, rng=rng,
                     fixed_pattern=(prnu_map if sensor.prnu else None, dsnu_map if sensor.dsnu_e else None))
    full = 2 ** sensor.bits - 1
    if sensor.cfa:
        x = (dn.astype(np.float64) - sensor.black_level_dn) / (full - sensor.black_level_dn)
        rgb8 = output8(raw.demosaic_mhc(x, sensor.cfa), sensor)
    else:   # each output value follows from one raw value: the chain run once per level, looked up
        levels = (np.arange(full + 1, dtype=np.float64) - sensor.black_level_dn) / (full - sensor.black_level_dn)
        rgb8 = output8(levels, sensor)[dn]
        if sensor.mono:
            rgb8 = np.repeat(rgb8[..., None], 3, axis=-1)
    return SensorFrame(dn, rgb8, float(exposure_s), float(gain))
