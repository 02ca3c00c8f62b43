"""What the sensor statements ask of a render, decided once and without Blender (pure).

``SensorPlan.create(scene, settings, overrides)`` gives: the effective timing (script and
command-line overrides), the rig's continuous motion, the lens on the render's K, which
renders a frame needs (a motion-blurred / rolling-shutter / distorted beauty render, a
sharp ground-truth render), the camera instants Cycles samples, the files written once
(lens calibration and lookup table, IMU streams) and the manifest entries. With no sensor
statement and no override the plan is inactive and the render path is the plain one.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ...scene import model
from . import imu as imu_mod
from ...scene import camera_profiles
from ...contract import timing as timing_mod
from ...contract.timing import DEFAULT_FPS
from . import autoexposure, still
from .autoexposure import METERING_RULE, ExposureControl, exposure_schedule
from ...contract.lens import Lens, opencv_calibration_yaml, robotcar_lut_bytes, undistortion_maps
from ...contract import rig
from ...contract.manifest_sections import (ImuSection, LensSection, RigMotionSection, Sections, SensorSection,
                                         TimingSection)
from ...contract.manifest import SENSOR_DIR   # noqa: F401 - the contract's (state_relpath's too)
from ...contract.rig_motion import RigMotion

LENS_DIR = "lens"
IMU_DIR = "imu"
GROUND_TRUTH_RULE = {
    "global": "sharp, at the frame stamp (the middle of the exposure)",
    "rolling": "sharp, each row at its own capture time (timing.row_offsets_s after the frame stamp); "
               "poses[view][k] is the pose at the frame stamp (the middle row), per-row poses from rig_motion",
}


@dataclass(frozen=True)
class TimingOverrides:
    """Command-line overrides of TIMING (None = the script's value)."""
    rate_hz: Optional[float] = None
    exposure_s: Optional[float] = None
    readout_s: Optional[float] = None
    motion_blur: Optional[bool] = None
    still: Optional[bool] = None


def effective_timing(scene: model.Scene, o: TimingOverrides) -> Optional[model.Timing]:
    from ...errors import SesgenError
    t = scene.timing
    if t is None and all(v is None for v in dataclasses.astuple(o)):
        return None
    t = t or model.Timing()
    t = model.Timing(rate_hz=o.rate_hz if o.rate_hz is not None else t.rate_hz, start_s=t.start_s,
                     exposure_s=o.exposure_s if o.exposure_s is not None else t.exposure_s,
                     readout_s=o.readout_s if o.readout_s is not None else t.readout_s,
                     blur=o.motion_blur if o.motion_blur is not None else t.blur,
                     still=o.still if o.still is not None else t.still)
    if not (t.rate_hz > 0 and np.isfinite(t.rate_hz)):
        raise SesgenError(f"--rate must be a positive number, got {t.rate_hz}")
    for name, v in (("exposure", t.exposure_s), ("readout", t.readout_s)):
        if not (v >= 0 and np.isfinite(v)):
            raise SesgenError(f"--{name} must be zero or positive, got {v}")
        if v > 1.0 / t.rate_hz * (1 + 1e-9):
            raise SesgenError(f"--{name} {v:g} s is longer than the frame period 1/{t.rate_hz:g} s")
    return t


@dataclass
class SensorPlan:
    timing: Optional[model.Timing]
    lens_spec: Optional[model.Lens]
    lens: Optional[Lens]                 # distortion on the render's K (None: pinhole)
    sensor: Optional[model.Sensor]
    autoexposure: Optional[model.AutoExposure]
    imu: Optional[model.Imu]
    motion: RigMotion
    width: int
    height: int
    K: np.ndarray
    views: tuple[str, ...]
    baseline: float
    still_refs: tuple[int, ...] = ()     # each frame's still-stretch reference (still.py); () = none

    @classmethod
    def create(cls, scene: model.Scene, settings, overrides: TimingOverrides = TimingOverrides()) -> "SensorPlan":
        t = effective_timing(scene, overrides)
        K = np.array(settings.K, dtype=float)
        lens = None
        if scene.lens is not None and scene.lens.distorted:
            lens = Lens.from_K(scene.lens.model, scene.lens.coeffs, K)
        rate = t.rate_hz if t else DEFAULT_FPS
        start = t.start_s if t else 0.0
        problem = timing_mod.stream_problem(scene.frames, rate, start, scene.imu.rate_hz if scene.imu else None)
        if problem:   # the script was checked: an option of the render command goes beyond a limit
            from ...errors import SesgenError
            raise SesgenError(f"--rate {rate:g}: {problem}")
        motion = RigMotion.for_motion_kind(scene.timeline.left(), rate, start, scene.motion.kind)
        # a profile's sensor is the physical one: bin it to the render's pixels
        sensor, lens_spec = camera_profiles.at_width(scene.sensor, scene.lens, settings.width)
        plan = cls(t, lens_spec, lens, sensor, scene.autoexposure, scene.imu, motion, settings.width,
                   settings.height, K, tuple(scene.rig.views), float(scene.rig.baseline))
        # held noise needs the beauty drawn apart from the ground truth (a shutter), a global
        # shutter and a pinhole (the reprojection is K's), and noise to hold (not gt's one sample)
        if (t is not None and t.still and plan.motion_blur and not plan.rolling_shutter and lens is None
                and not settings.preset.deterministic_rgb):
            frames = np.arange(scene.frames, dtype=float)
            refs = still.still_references({v: plan.camera_poses(v, frames) for v in plan.views}, K,
                                          settings.width, settings.height, world_moves=bool(scene.object_motions))
            if any(r != k for k, r in enumerate(refs)):
                plan = dataclasses.replace(plan, still_refs=refs)
        return plan

    def still_reference(self, k: int) -> int:
        """The frame whose beauty frame k shows, reprojected (itself outside a still stretch)."""
        return self.still_refs[k] if self.still_refs else k

    # --- what to render ------------------------------------------------------------------
    @property
    def rate_hz(self) -> float:
        return self.timing.rate_hz if self.timing else DEFAULT_FPS

    @property
    def motion_blur(self) -> bool:
        return bool(self.timing and self.timing.motion_blur)

    @property
    def rolling_shutter(self) -> bool:
        return bool(self.timing and self.timing.rolling_shutter)

    @property
    def shutter_effects(self) -> bool:
        return self.motion_blur or self.rolling_shutter

    @property
    def changes_rendering(self) -> bool:
        """False: the frame renders exactly as without any sensor statement."""
        return self.shutter_effects or self.lens is not None

    @property
    def writes_sensor_images(self) -> bool:
        return self.sensor is not None

    @property
    def active(self) -> bool:
        return (self.timing is not None or self.lens_spec is not None or self.sensor is not None
                or self.imu is not None)

    def frame_times_s(self, n: int) -> np.ndarray:
        return timing_mod.frame_timestamps(n, self.rate_hz, self.timing.start_s if self.timing else 0.0)

    def nominal_exposure_s(self) -> float:
        return self.timing.exposure_s if self.timing else 0.0

    def shutter(self, exposure_s: float) -> tuple[float, float]:
        """(Cycles shutter in frames, rolling duration) of a frame exposed for ``exposure_s``."""
        e = exposure_s if self.motion_blur else 0.0
        r = self.timing.readout_s if self.rolling_shutter else 0.0
        return timing_mod.cycles_shutter(e, r, self.rate_hz)

    def pixel_rays(self) -> np.ndarray:
        """(H, W, 3) unit ray of each pixel: the lens model's, else the pinhole K's."""
        if self.lens is not None:
            return self.lens.pixel_rays(self.width, self.height)
        K = self.K
        v, u = np.mgrid[0:self.height, 0:self.width].astype(float)
        r = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], axis=-1)
        return r / np.linalg.norm(r, axis=-1, keepdims=True)

    def full_scale(self, exposure_s: float, gain: float) -> float:
        """The linear render value (a mono sensor's luminance, else a channel's) that brings
        the output of a frame exposed at (``exposure_s``, ``gain``) to full scale: where its DN
        clip (``raw.capture``: black + e * gain * (2^bits - 1) / full_well) or, below gain 1,
        its full well is reached."""
        s = self.sensor
        t_nom = self.nominal_exposure_s()
        ratio = exposure_s / t_nom if t_nom > 0 else 1.0
        span = 1.0 - s.black_level_dn / (2 ** s.bits - 1)
        return s.saturation / ratio * min(1.0, span / gain)

    @functools.cached_property
    def _relative_illumination(self) -> Optional[np.ndarray]:
        """(H, W) relative illumination of each pixel (the lens's vignetting; None without)."""
        if self.lens_spec is None or not self.lens_spec.vignetting:
            return None
        from .optics import vignetting
        return vignetting(self.pixel_rays(), self.lens_spec.vignetting)

    def illumination_at(self, shape: tuple) -> Optional[np.ndarray]:
        """The relative illumination at the pixel centres of an image of ``shape`` (h, w) of
        the same view (a metering preview; nearest render pixel), None without vignetting."""
        v = self._relative_illumination
        if v is None:
            return None
        h, w = shape[:2]
        rows = np.minimum(((np.arange(h) + 0.5) * self.height / h).astype(int), self.height - 1)
        cols = np.minimum(((np.arange(w) + 0.5) * self.width / w).astype(int), self.width - 1)
        return v[np.ix_(rows, cols)]

    @property
    def converged_start(self) -> bool:
        """Whether frame 0's exposure is the fixed point of its own metering (``AUTOEXPOSURE
        start converged``, the default; autoexposure.converged_exposure)."""
        return self.autoexposure is not None and self.autoexposure.start == "converged"

    def metered_frames(self, frames, n: int) -> int:
        """How many leading frames a render of ``frames`` meters (``autoexposure.metered_frames``)."""
        return autoexposure.metered_frames(frames, n, self.converged_start)

    def meter(self, linear_rgb: np.ndarray, metered_before: list) -> float:
        """The metered brightness of frame j = len(``metered_before``) from its linear image
        (the render's radiance, any size): what its camera meters (``autoexposure.meter``), the
        image as the sensor receives it (vignetted), each pixel clipped at the output's full
        scale at frame j's exposure, which ``metered_before`` (frames 0..j-1) decides; frame 0's
        with the converged start at the exposure its own metering answers with itself
        (``autoexposure.converged_exposure``: the fixed point)."""
        if self.converged_start and not metered_before:
            at = autoexposure.converged_exposure(lambda t, g: self.meter_at(linear_rgb, t, g),
                                                 self._exposure_control())
            self._schedule_cache = None
            return self.meter_at(linear_rgb, *at)
        return self.meter_at(linear_rgb, *self._exposure_after(metered_before))

    def meter_at(self, linear_rgb: np.ndarray, exposure_s: float, gain: float) -> float:
        """What the camera meters of a linear image (any size) exposed at (``exposure_s``,
        ``gain``): ``autoexposure.meter`` of the image as the sensor receives it (vignetted),
        each pixel clipped at the output's full scale there."""
        return autoexposure.meter(linear_rgb, self.full_scale(exposure_s, gain),
                                  self.illumination_at(np.shape(linear_rgb)), self.sensor.mono)

    def _exposure_after(self, metered: list) -> tuple[float, float]:
        """``exposures(metered)[-1]``, one step from the last call's when ``metered`` extends its
        list by one (the metering pass asks frame after frame)."""
        cached = getattr(self, "_schedule_cache", None)
        if cached is not None and len(metered) == len(cached[0]) + 1 and list(metered[:-1]) == cached[0] \
                and self.autoexposure is not None:
            t, g = autoexposure.exposure_step(*cached[1], metered[-1], self._exposure_control())
        else:
            t, g = self.exposures(metered)[-1]
        self._schedule_cache = (list(metered), (t, g))
        return t, g

    def _exposure_control(self) -> ExposureControl:
        a, s = self.autoexposure, self.sensor
        return ExposureControl(
            nominal_exposure_s=self.nominal_exposure_s(), nominal_gain=s.gain, rate_hz=self.rate_hz,
            readout_s=self.timing.readout_s, target=a.target, speed=a.speed,
            saturation=self.full_scale(self.nominal_exposure_s(), 1.0),
            max_exposure_s=a.max_exposure_s, max_gain=a.max_gain, min_exposure_s=a.min_exposure_s,
            converged_start=self.converged_start)

    def exposures(self, metered: list) -> list[tuple[float, float]]:
        """(exposure_s, gain) for frames 0..len(metered) (auto-exposure or the nominal values;
        the converged start needs ``metered[0]``)."""
        gain = self.sensor.gain if self.sensor else 1.0
        if self.autoexposure is None:
            return [(self.nominal_exposure_s(), gain)] * (len(metered) + 1)
        return exposure_schedule(list(metered), self._exposure_control())

    def camera_poses(self, view: str, blender_frames: np.ndarray, frame0: int = 0) -> np.ndarray:
        """T_world_cam (OpenCV, SES world) of ``view`` at (fractional) Blender frames."""
        t = (self.timing.start_s if self.timing else 0.0) + (np.asarray(blender_frames) - frame0) / self.rate_hz
        return rig.T_world_view(self.motion.T_world_cam(t), view, self.baseline)

    # --- files and manifest ------------------------------------------------------------------
    def sensor_relpath(self, kind: str, view: str, k: int) -> str:
        ext = "jpg" if kind == "jpeg" else "png"
        return f"{SENSOR_DIR}/{view}/{kind}/{k:06d}.{ext}"

    def sensor_kinds(self) -> list[str]:
        if self.sensor is None:
            return []
        return ["raw", "rgb"] + (["jpeg"] if self.sensor.jpeg_quality else [])

    def static_files(self, n_frames: int) -> dict[str, bytes]:
        """Files written once per render: lens calibration + lookup table, IMU streams."""
        files: dict[str, bytes] = {}
        if self.lens is not None:
            for view in self.views:
                files[f"{LENS_DIR}/{view}.yaml"] = opencv_calibration_yaml(self.lens, self.width, self.height,
                                                                            view).encode()
            files[f"{LENS_DIR}/undistort_lut.bin"] = robotcar_lut_bytes(*undistortion_maps(self.lens, self.width,
                                                                                           self.height))
        if self.imu is not None:
            files.update(self._imu_files(n_frames))
        return files

    def imu_params(self) -> imu_mod.ImuParams:
        i = self.imu
        return imu_mod.ImuParams(rate_hz=i.rate_hz, gyro_noise=i.gyro_noise, gyro_walk=i.gyro_walk,
                                 accel_noise=i.accel_noise, accel_walk=i.accel_walk,
                                 T_cam_imu=tuple(map(tuple, i.T_cam_imu())), time_offset_s=i.time_offset_s,
                                 gravity=i.gravity, seed=i.seed)

    def imu_section(self) -> ImuSection:
        """The manifest's ``imu`` section (also what imu/sensor.yaml is written from)."""
        p = self.imu_params()
        return ImuSection(p.rate_hz, p.gyro_noise, p.gyro_walk, p.accel_noise, p.accel_walk,
                          tuple(map(tuple, p.T.tolist())), p.time_offset_s, (0.0, -p.gravity, 0.0), p.seed,
                          {"noisy": f"{IMU_DIR}/data.csv", "ideal": f"{IMU_DIR}/data_ideal.csv",
                           "groundtruth": f"{IMU_DIR}/groundtruth.csv", "yaml": f"{IMU_DIR}/sensor.yaml"})

    def _imu_files(self, n_frames: int) -> dict[str, bytes]:
        from ...contract.sensor_yaml import imu_sensor_yaml
        from .imu_files import groundtruth_csv
        p = self.imu_params()
        t = self.frame_times_s(n_frames)
        stamps = imu_mod.sample_times(t[0], t[-1], p)
        ideal = imu_mod.ideal_stream(self.motion, stamps, p)
        noisy = imu_mod.add_noise(ideal, p)
        T_wi, v_wi, _, _ = imu_mod.imu_state(self.motion, stamps - p.time_offset_s, p)
        return {f"{IMU_DIR}/data.csv": imu_mod.csv_text(noisy).encode(),
                f"{IMU_DIR}/data_ideal.csv": imu_mod.csv_text(ideal).encode(),
                f"{IMU_DIR}/groundtruth.csv": groundtruth_csv(stamps - p.time_offset_s, T_wi, v_wi,
                                                              noisy.gyro_bias, noisy.accel_bias).encode(),
                f"{IMU_DIR}/sensor.yaml": imu_sensor_yaml(self.imu_section()).encode()}

    def timing_section(self) -> Optional[TimingSection]:
        """The manifest's ``timing`` entry (None for an inactive plan: no entry)."""
        if not self.active:
            return None
        t = self.timing or model.Timing()
        return TimingSection(
            rate_hz=t.rate_hz, start_s=t.start_s, exposure_s=t.exposure_s, readout_s=t.readout_s,
            motion_blur=self.motion_blur, rolling_shutter=self.rolling_shutter,
            row_offsets_s=(tuple(timing_mod.row_offsets_s(self.height, t.readout_s).tolist())
                           if self.rolling_shutter else None),
            ground_truth=GROUND_TRUTH_RULE["rolling" if self.rolling_shutter else "global"],
            still_frames=tuple(tuple(s) for s in still.stretches(self.still_refs)) or None)

    def timing_values(self) -> Optional[dict]:
        """The timing values that change pixels and poses (``contract.pixel_settings``)."""
        section = self.timing_section()
        return None if section is None else section.pixel_values()

    def sections(self, n_frames: int) -> Sections:
        """The manifest's sections of the sensor statements (none for an inactive plan)."""
        if not self.active:
            return Sections()
        lens = sensor = imu = None
        if self.lens_spec is not None:
            ls = self.lens_spec
            lens = LensSection(ls.model, tuple(ls.coeffs), ls.f_number, ls.defocus_px, ls.vignetting, ls.chromatic_px)
            if self.lens is not None:
                lens = dataclasses.replace(lens, calibration=self.lens.to_json(),
                                           opencv_files={v: f"{LENS_DIR}/{v}.yaml" for v in self.views},
                                           undistort_lut=f"{LENS_DIR}/undistort_lut.bin")
        if self.sensor is not None:
            none = (None,) * n_frames
            sensor = SensorSection(
                dataclasses.asdict(self.sensor),
                {kind: {v: [self.sensor_relpath(kind, v, k) for k in range(n_frames)] for v in self.views}
                 for kind in self.sensor_kinds()},
                raw_layout=("PNG16, values 0..2^bits-1 (not scaled), CFA mosaic" if self.sensor.cfa
                            else "PNG16 grey, values 0..2^bits-1 (not scaled)" if self.sensor.mono
                            else "PNG16 RGB, values 0..2^bits-1 (not scaled)"),
                autoexposure=None if self.autoexposure is None else {**dataclasses.asdict(self.autoexposure),
                                                                     "metering": METERING_RULE},
                exposure_s=none, gain=none, metered=none)
        if self.imu is not None:
            imu = self.imu_section()
        return Sections(rig_motion=RigMotionSection(self.motion.kind, self.rate_hz, self.motion.start_s),
                        timing=self.timing_section(), lens=lens, sensor=sensor, imu=imu)

    def manifest_entries(self, n_frames: int) -> dict:
        """Manifest keys of the sensor statements (none for an inactive plan)."""
        return self.sections(n_frames).to_json()
