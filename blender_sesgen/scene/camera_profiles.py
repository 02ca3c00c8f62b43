"""Camera profiles: the measured parameter sets of real cameras (``SENSOR profile NAME``), and
the binning that carries a profile to another render size (pure).

A profile describes the **physical sensor** at its native width: its tags are the SES tags of
SENSOR, LENS, TIMING and AUTOEXPOSURE (a script's own tags override them one by one). Each
number is measured on the real frames in ../shared/data by ``bench/camera_profiles.py`` or
taken from the cited datasheet/paper; docs/sensors.md ("Camera profiles") has the table with
how each was measured. Where neither is available the number is marked *assumed* there.

Binning (:func:`at_width`): a render ``s = native / width`` times narrower than the sensor has
pixels of s x s native pixels: the full well, dark current grow by s^2, the read noise and DSNU
(independent per native pixel) by s, the row noise (s rows of s pixels) by s^1.5, PRNU falls by
1/s, the pitch grows by s; lengths in pixels (defocus, chromatic, OLPF) shrink by 1/s. So a
flat patch's noise, relative to full scale, is 1/s of the native one - as if s x s pixels
were averaged - and blur stays the same size on the sensor.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field


@dataclass(frozen=True)
class Profile:
    name: str
    camera: str                      # what the camera is
    native_width_px: int             # the width the parameters are per pixel of
    native_height_px: int
    sensor: dict                     # SENSOR tags
    lens: dict = field(default_factory=dict)          # LENS tags
    timing: dict = field(default_factory=dict)        # TIMING tags
    autoexposure: dict = field(default_factory=dict)  # AUTOEXPOSURE tags (used when the script has one)
    edge_spread_px: float = 0.0      # measured Gaussian-equivalent edge spread (-> LENS defocus)


# The sensor path's pixel is a box of one pixel (blender/render.py: SENSOR_PIXEL_FILTER), a Gaussian-equivalent
# edge spread of 1/sqrt(12) px at any render size (a binned pixel is a box too); a defocus disc
# of diameter d adds d / 4. So a profile's defocus is 4 sqrt(s_measured^2 - 1/12), s measured at
# the native width (docs/sensors.md, "sharpness").
PIXEL_EDGE_SPREAD_PX = 12 ** -0.5


def defocus_for(edge_spread_px: float) -> float:
    """LENS defocus (px, disc diameter) that gives the render a measured edge spread (px, native)."""
    return round(4 * max(edge_spread_px ** 2 - PIXEL_EDGE_SPREAD_PX ** 2, 0.0) ** 0.5, 2)

PROFILES: dict[str, Profile] = {p.name: p for p in (
    Profile("kitti", "KITTI: Point Grey Flea2 FL2-14S3M (Sony ICX267 CCD, greyscale, global shutter), "
            "rectified 8-bit images as distributed", 1226, 370,
            # the raw at 12 bits (the Flea2's ADC; assumed), the 8-bit files after the response: no
            # unused codes, as in KITTI's; black 112 DN of 4095 = the files' 7 of 255
            sensor=dict(fullwell=4500.0, readnoise=0.0, black=112.0, bits=12, response="gamma", gamma=1.3,
                        pixel=4.65, mono="on", nir=0.2),
            lens=dict(defocus=defocus_for(0.60), vignetting=0.35),
            timing=dict(rate=10.0, exposure=0.002, readout=0.0),
            autoexposure=dict(target=0.28), edge_spread_px=0.60),
    Profile("euroc", "EuRoC MAV: VI-Sensor, Aptina MT9V034 (greyscale, global shutter), raw 752x480", 752, 480,
            # full well and read noise: photon transfer of the standing MAV's still frames (cam0, cam1
            # 18200 / 17200 e-, 29.7 / 26.5 e- at black 13); Immerkaer on flat regions, which counts
            # texture as noise, had given 8400 / 15.6 - twice the temporal variance
            sensor=dict(fullwell=17700.0, readnoise=28.0, black=13.0, bits=8, response="linear", pixel=6.0, mono="on"),
            lens=dict(defocus=defocus_for(0.83), vignetting=0.30),
            timing=dict(rate=20.0, exposure=0.005, readout=0.0),
            autoexposure=dict(target=0.52), edge_spread_px=0.83),
    Profile("tum", "TUM RGB-D: Microsoft Kinect v1 RGB (Aptina MT9M112, Bayer, rolling shutter), 640x480", 640, 480,
            sensor=dict(fullwell=6000.0, readnoise=8.0, black=0.0, bits=8, cfa="grbg", response="srgb",
                        pixel=5.6, jpeg=0),
            lens=dict(fnumber=2.0, vignetting=1.0),
            timing=dict(rate=30.0, exposure=0.01, readout=0.02),
            autoexposure=dict(target=0.3)),
    Profile("robotcar", "Oxford RobotCar: Point Grey Bumblebee XB3 (Sony ICX445 CCD, Bayer GBRG, global shutter), "
            "1280x960", 1280, 960,
            sensor=dict(fullwell=4000.0, readnoise=19.0, black=6.0, bits=8, cfa="gbrg", response="linear",
                        pixel=3.75),
            lens=dict(vignetting=1.0),
            timing=dict(rate=16.0, exposure=0.002, readout=0.0),
            autoexposure=dict(target=0.54)),
    Profile("phone", "a generic phone camera (12 MP, 1.4 um, rolling shutter, JPEG)", 4032, 3024,
            sensor=dict(fullwell=6000.0, readnoise=2.0, black=0.0, bits=10, cfa="rggb", response="srgb",
                        pixel=1.4, jpeg=90),
            lens=dict(fnumber=1.8, vignetting=1.0),
            timing=dict(rate=30.0, exposure=0.008, readout=0.025),
            autoexposure=dict(target=0.18)),
)}


def black_8bit(sensor: dict) -> float:
    """A profile's black level in the 8-bit output's DN (where its files hold it)."""
    return float(sensor.get("black", 0.0)) * 255.0 / (2 ** int(sensor.get("bits", 8)) - 1)


def at_width(sensor, lens, width_px: int):
    """(sensor, lens) per pixel of a render ``width_px`` wide (:mod:`this module`'s binning);
    unchanged when the sensor has no native width."""
    native = int(getattr(sensor, "native_width_px", 0) or 0) if sensor is not None else 0
    if not native or int(width_px) == native:
        return sensor, lens
    s = native / float(width_px)
    a = s * s
    sensor = dataclasses.replace(
        sensor, full_well_e=sensor.full_well_e * a, read_noise_e=sensor.read_noise_e * s,
        dark_current_e_s=sensor.dark_current_e_s * a, dsnu_e=sensor.dsnu_e * s, prnu=sensor.prnu / s,
        row_noise_e=sensor.row_noise_e * s ** 1.5, pixel_um=sensor.pixel_um * s, olpf_px=sensor.olpf_px / s,
        native_width_px=int(width_px))
    if lens is not None:
        lens = dataclasses.replace(lens, defocus_px=lens.defocus_px / s, chromatic_px=lens.chromatic_px / s)
    return sensor, lens
