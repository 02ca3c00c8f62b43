"""The manifest's optional sections -- ``rig_motion``, ``timing``, ``lens``, ``sensor``,
``imu`` (written when a script has the sensor statements) -- as typed records.

Each record has one writer (``to_json``: what ``blender_sesgen.render.sensor.render_plan`` puts
in the manifest) and one validating reader (``from_json``: called once by
``Manifest.from_json``; a defect is a :class:`ContractError` naming the key). Readers use
the records (``Manifest.sections``), never ``.get()`` chains on the raw JSON.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import PurePosixPath
from typing import Optional

import numpy as np

from .errors import ContractError
from .lens import MODELS, Lens
from .rig_motion import KINDS
from .timing import DEFAULT_FPS

RIG_MOTION_RULE = "docs/rendering.md#rig-motion-between-frames"
STAMP_RULE = "middle of the exposure"
ROW_TIME_RULE = "t_row(r) = t_k + (r + 0.5 - H/2) * readout_s / H (r = 0 at the top)"
LENS_OPTICS_APPLY_TO = "sensor images only"
LUT_LAYOUT = ("RobotCar: float64, all W*H u then all W*H v, row-major; "
              "undistorted (pinhole K) pixel -> distorted pixel to sample")
LENS_GROUND_TRUTH = "depth (planar z), ids and flow at the distorted image's pixel centres"
IMU_FRAME = "IMU = body; T_world_imu = T_world_cam(left) @ T_cam_imu"
IMU_STREAMS = ("noisy", "ideal", "groundtruth")
SENSOR_STATE = ("exposure_s", "gain", "metered")     # per frame, filled in while rendering


def camera_record(m: dict) -> dict:
    """The camera model a manifest's frames were made with: its ``lens`` and ``sensor``
    sections without the per-frame state and the file lists. The same script renders
    another camera when a profile's numbers or the metering rule change between versions of
    this package, so resume compares these too, not only the script and the settings."""
    rec = {}
    for key in ("lens", "sensor"):
        section = m.get(key) if isinstance(m, dict) else None
        if isinstance(section, dict):
            rec[key] = {k: v for k, v in section.items() if k not in SENSOR_STATE + ("files",)}
    return rec


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def inside(rel) -> bool:
    """A relative path that stays inside the render folder."""
    return isinstance(rel, str) and bool(rel) and not PurePosixPath(rel).is_absolute() and \
        ".." not in PurePosixPath(rel).parts and "\\" not in rel and "\0" not in rel


class _Reader:
    """Typed access to one section's dict; a defect raises ContractError naming the key."""

    def __init__(self, section: str, d, source: str, limit: float):
        if not isinstance(d, dict):
            raise ContractError(f"'{section}' must be an object", source)
        self.section, self.d, self.source, self.limit = section, d, source, limit

    def bad(self, key: str, want: str, qualified: bool = True):
        name = f"{self.section}.{key}" if qualified else key
        raise ContractError(f"'{name}' must be {want}", self.source)

    def number(self, key: str, default: float, low: Optional[float] = None, positive: bool = False) -> float:
        v = self.d.get(key)
        if v is None:
            return default
        low = -self.limit if low is None else low
        if not (_is_number(v) and low <= v <= self.limit and (v > 0 or not positive)):
            self.bad(key, f"a number in {'(0' if positive else f'[{low:g}'}, {self.limit:g}]", qualified=False)
        return float(v)

    def flag(self, key: str, default: bool) -> bool:
        v = self.d.get(key, default)
        if not isinstance(v, bool):
            self.bad(key, "true or false")
        return v

    def text(self, key: str, default: str = "") -> str:
        v = self.d.get(key, default)
        if v is None:
            return default
        if not isinstance(v, str):
            self.bad(key, "a string")
        return v

    def numbers(self, key: str) -> Optional[tuple]:
        v = self.d.get(key)
        if v is None:
            return None
        if not (isinstance(v, list) and all(_is_number(x) and abs(x) <= self.limit for x in v)):
            self.bad(key, "numbers")
        return tuple(float(x) for x in v)

    def frame_ranges(self, key: str) -> Optional[tuple]:
        """A list of [first, last] frame pairs (0 <= first < last), or None."""
        v = self.d.get(key)
        if v is None:
            return None
        ok = isinstance(v, list) and all(
            isinstance(p, list) and len(p) == 2 and all(isinstance(x, int) and not isinstance(x, bool) for x in p)
            and 0 <= p[0] < p[1] for p in v)
        if not ok:
            self.bad(key, "a list of [first, last] frame pairs")
        return tuple(tuple(p) for p in v)


@dataclass(frozen=True)
class RigMotionSection:
    """How the rig moves between frame stamps (``contract.rig_motion``)."""
    interpolation: str
    rate_hz: float
    start_s: float

    def to_json(self) -> dict:
        return {"interpolation": self.interpolation, "rate_hz": self.rate_hz, "start_s": self.start_s,
                "rule": RIG_MOTION_RULE}

    @classmethod
    def from_json(cls, d, source: str, limit: float, fps: Optional[float], t0_s: float) -> "RigMotionSection":
        r = _Reader("rig_motion", d, source, limit)
        kind = r.d.get("interpolation", "c2_spline")
        if kind not in KINDS:
            r.bad("interpolation", f"one of {', '.join(KINDS)}")
        return cls(kind, r.number("rate_hz", float(fps or DEFAULT_FPS), positive=True), r.number("start_s", t0_s))


@dataclass(frozen=True)
class TimingSection:
    """Frame timing (``contract.timing``): stamps at the middle of the exposure; with a
    rolling shutter ``row_offsets_s`` holds each row's capture time after the stamp."""
    rate_hz: float
    start_s: float
    exposure_s: float
    readout_s: float
    motion_blur: bool
    rolling_shutter: bool
    row_offsets_s: Optional[tuple] = None
    ground_truth: str = ""
    # [first, last] of each still stretch: frames first+1..last show frame first's beauty
    # reprojected to their own poses (render/sensor/still.py); None: no stretch
    still_frames: Optional[tuple] = None

    def pixel_values(self) -> dict:
        """The values that change pixels and poses (``contract.pixel_settings.TIMING_KEYS``)."""
        return {"rate_hz": self.rate_hz, "start_s": self.start_s, "exposure_s": self.exposure_s,
                "readout_s": self.readout_s, "motion_blur": self.motion_blur,
                "still_frames": None if self.still_frames is None else [list(s) for s in self.still_frames]}

    def to_json(self) -> dict:
        return {**self.pixel_values(), "rolling_shutter": self.rolling_shutter, "stamp": STAMP_RULE,
                "row_time": ROW_TIME_RULE,
                "row_offsets_s": None if self.row_offsets_s is None else list(self.row_offsets_s),
                "ground_truth": self.ground_truth}

    @classmethod
    def from_json(cls, d, source: str, limit: float) -> "TimingSection":
        r = _Reader("timing", d, source, limit)
        return cls(rate_hz=r.number("rate_hz", DEFAULT_FPS, positive=True), start_s=r.number("start_s", 0.0),
                   exposure_s=r.number("exposure_s", 0.0, low=0.0), readout_s=r.number("readout_s", 0.0, low=0.0),
                   motion_blur=r.flag("motion_blur", False), rolling_shutter=r.flag("rolling_shutter", False),
                   row_offsets_s=r.numbers("row_offsets_s"), ground_truth=r.text("ground_truth"),
                   still_frames=r.frame_ranges("still_frames"))


@dataclass(frozen=True)
class LensSection:
    """The lens: its model and coefficients (``contract.lens``), the optics applied to the
    sensor images, and for a distorted render its calibration files and lookup table."""
    model: str
    coeffs: tuple
    f_number: float = 0.0
    defocus_px: float = 0.0
    vignetting: float = 0.0
    chromatic_px: float = 0.0
    calibration: Optional[dict] = None            # Lens.to_json() of the render's K (distorted only)
    opencv_files: dict = field(default_factory=dict)   # {view: calibration YAML}
    undistort_lut: Optional[str] = None

    @property
    def distorted(self) -> bool:
        return self.model == "kannala_brandt" or (self.model == "brown" and any(self.coeffs))

    def lens(self, K) -> Optional[Lens]:
        """The lens on the render's K (None for a pinhole)."""
        return None if self.model == "pinhole" else Lens.from_K(self.model, self.coeffs, K)

    def to_json(self) -> dict:
        entry = {"model": self.model, "coeffs": list(self.coeffs), "f_number": self.f_number,
                 "defocus_px": self.defocus_px, "vignetting": self.vignetting, "chromatic_px": self.chromatic_px,
                 "optics_apply_to": LENS_OPTICS_APPLY_TO}
        if self.calibration is not None:
            entry.update(self.calibration)
            entry["files"] = {"opencv": dict(self.opencv_files), "undistort_lut": self.undistort_lut,
                              "lut_layout": LUT_LAYOUT}
            entry["ground_truth"] = LENS_GROUND_TRUTH
        return entry

    @classmethod
    def from_json(cls, d, source: str, limit: float) -> "LensSection":
        r = _Reader("lens", d, source, limit)
        model = r.d.get("model") or "pinhole"
        if not isinstance(model, str) or model not in MODELS:
            r.bad("model", f"one of {', '.join(MODELS)}")
        coeffs = r.d.get("coeffs", [])
        if model != "pinhole" and not (isinstance(coeffs, list) and len(coeffs) == MODELS[model]
                                       and all(_is_number(c) and abs(c) <= limit for c in coeffs)):
            r.bad("coeffs", f"{MODELS[model]} numbers for the {model} model")
        if model == "pinhole":
            coeffs = [c for c in coeffs if _is_number(c)] if isinstance(coeffs, list) else []
        files = r.d.get("files") or {}
        if not isinstance(files, dict) or (files.get("undistort_lut") is not None and not inside(files["undistort_lut"])):
            r.bad("files", "paths inside the render folder")
        opencv = files.get("opencv") or {}
        if not isinstance(opencv, dict) or not all(isinstance(v, str) and inside(p) for v, p in opencv.items()):
            r.bad("files", "paths inside the render folder")
        calibration = {k: r.d[k] for k in ("model", "coeffs", "fx", "fy", "cx", "cy", "ros_distortion_model")
                       if k in r.d} if "fx" in r.d else None
        return cls(model, tuple(float(c) for c in coeffs), r.number("f_number", 0.0), r.number("defocus_px", 0.0),
                   r.number("vignetting", 0.0), r.number("chromatic_px", 0.0), calibration, dict(opencv),
                   files.get("undistort_lut"))


@dataclass(frozen=True)
class SensorSection:
    """The raw sensor: its settings (``model.Sensor``'s fields), the images it wrote per kind
    (raw | rgb | jpeg) and view, and each frame's exposure, gain and metered brightness."""
    settings: dict
    files: dict                      # {kind: {view: [relpath per frame]}}
    raw_layout: str = ""
    autoexposure: Optional[dict] = None
    exposure_s: tuple = ()
    gain: tuple = ()
    metered: tuple = ()

    def file(self, kind: str, view: str, k: int) -> Optional[str]:
        """Relative path of frame k's image of ``kind`` in ``view``, None when not written."""
        per_view = self.files.get(kind)
        return None if not per_view else per_view[view][int(k)]

    def to_json(self) -> dict:
        s = dict(self.settings)
        s["files"] = {kind: {v: list(p) for v, p in per_view.items()} for kind, per_view in self.files.items()}
        s["raw_layout"] = self.raw_layout
        s["exposure_s"], s["gain"], s["metered"] = list(self.exposure_s), list(self.gain), list(self.metered)
        if self.autoexposure is not None:
            s["autoexposure"] = dict(self.autoexposure)
        return s

    @classmethod
    def from_json(cls, d, source: str, limit: float, views, n: int) -> "SensorSection":
        r = _Reader("sensor", d, source, limit)
        files = r.d.get("files") or {}
        if not isinstance(files, dict) or not all(
                isinstance(per_view, dict) and all(
                    v in per_view and isinstance(per_view[v], list) and len(per_view[v]) == n
                    and all(inside(p) for p in per_view[v]) for v in views)
                for per_view in files.values()):
            raise ContractError(f"'sensor.files' must be for each kind and view, {n} paths inside the render folder",
                                source)
        state = {}
        for key in SENSOR_STATE:
            v = r.d.get(key) or []
            if not (isinstance(v, list) and all(x is None or _is_number(x) for x in v)):
                r.bad(key, "numbers or nulls, one per frame")
            state[key] = tuple(v)
        ae = r.d.get("autoexposure")
        if ae is not None and not isinstance(ae, dict):
            r.bad("autoexposure", "an object")
        settings = {k: v for k, v in r.d.items()
                    if k not in ("files", "raw_layout", "autoexposure") + SENSOR_STATE}
        return cls(settings, {k: {v: list(p[v]) for v in views} for k, p in files.items()},
                   r.text("raw_layout"), ae, **state)


@dataclass(frozen=True)
class ImuSection:
    """The IMU: rate, noise densities (EuRoC/Kalibr units), its pose on the left camera
    (``T_cam_imu``), clock offset, gravity, seed, and its three CSV streams."""
    rate_hz: float
    gyroscope_noise_density: float
    gyroscope_random_walk: float
    accelerometer_noise_density: float
    accelerometer_random_walk: float
    T_cam_imu: tuple
    time_offset_s: float
    gravity_world: tuple
    seed: int
    files: dict                      # noisy, ideal, groundtruth (CSV), yaml

    @property
    def T_cam_imu_matrix(self) -> np.ndarray:
        return np.array(self.T_cam_imu, dtype=float)

    def to_json(self) -> dict:
        return {"rate_hz": self.rate_hz, "gyroscope_noise_density": self.gyroscope_noise_density,
                "gyroscope_random_walk": self.gyroscope_random_walk,
                "accelerometer_noise_density": self.accelerometer_noise_density,
                "accelerometer_random_walk": self.accelerometer_random_walk,
                "T_cam_imu": [list(row) for row in self.T_cam_imu], "time_offset_s": self.time_offset_s,
                "gravity_world": list(self.gravity_world), "seed": self.seed, "files": dict(self.files),
                "frame": IMU_FRAME}

    @classmethod
    def from_json(cls, d, source: str, limit: float) -> "ImuSection":
        r = _Reader("imu", d, source, limit)
        files = r.d.get("files")
        if not (isinstance(files, dict) and all(inside(files.get(k)) for k in IMU_STREAMS)
                and all(inside(p) for p in files.values())):
            raise ContractError("'imu.files' must be paths inside the render folder (noisy, ideal, groundtruth)",
                                source)
        T = r.d.get("T_cam_imu", np.eye(4).tolist())
        try:
            T = np.array(T, dtype=float)
        except (TypeError, ValueError):
            T = None
        if T is None or T.shape != (4, 4) or not np.all(np.isfinite(T)) or np.abs(T).max() > limit:
            r.bad("T_cam_imu", "a 4x4 matrix of numbers")
        g = r.numbers("gravity_world") or (0.0, -9.81, 0.0)
        seed = r.d.get("seed", 0)
        if not isinstance(seed, int) or isinstance(seed, bool):
            r.bad("seed", "a whole number")
        return cls(r.number("rate_hz", 200.0, positive=True), r.number("gyroscope_noise_density", 0.0, low=0.0),
                   r.number("gyroscope_random_walk", 0.0, low=0.0), r.number("accelerometer_noise_density", 0.0, low=0.0),
                   r.number("accelerometer_random_walk", 0.0, low=0.0), tuple(map(tuple, T.tolist())),
                   r.number("time_offset_s", 0.0), g, seed, dict(files))


@dataclass(frozen=True)
class Sections:
    """The optional sections of one manifest (None where absent)."""
    rig_motion: Optional[RigMotionSection] = None
    timing: Optional[TimingSection] = None
    lens: Optional[LensSection] = None
    sensor: Optional[SensorSection] = None
    imu: Optional[ImuSection] = None

    KEYS = ("rig_motion", "timing", "lens", "sensor", "imu")

    def to_json(self) -> dict:
        return {k: getattr(self, k).to_json() for k in self.KEYS if getattr(self, k) is not None}

    @classmethod
    def from_json(cls, m: dict, source: str, limit: float) -> "Sections":
        """The sections of manifest ``m`` (a dict whose core keys are checked), validated."""
        views = m["views"] if isinstance(m.get("views"), list) else []
        n = m.get("frames") if isinstance(m.get("frames"), int) else -1
        ts = m.get("timestamps")
        t0 = float(ts[0]) if isinstance(ts, list) and ts and _is_number(ts[0]) else 0.0
        fps = m.get("fps") if _is_number(m.get("fps")) else None
        got = {k: m.get(k) for k in cls.KEYS}
        for k, v in got.items():
            if v is not None and not isinstance(v, dict):
                raise ContractError(f"'{k}' must be an object", source)
        return cls(
            rig_motion=None if got["rig_motion"] is None else RigMotionSection.from_json(got["rig_motion"], source,
                                                                                        limit, fps, t0),
            timing=None if got["timing"] is None else TimingSection.from_json(got["timing"], source, limit),
            lens=None if got["lens"] is None else LensSection.from_json(got["lens"], source, limit),
            sensor=None if not got["sensor"] else SensorSection.from_json(got["sensor"], source, limit, views, n),
            imu=None if not got["imu"] else ImuSection.from_json(got["imu"], source, limit))
