"""The sensor path's share of a render folder (pure): manifest entries and the files
written once at the start, the per-frame exposure (auto-exposure follows the metering
pass's values, stored in the manifest, so any split of the frames gives the same exposures),
and the sensor images of each frame."""
from __future__ import annotations

import hashlib

from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ...contract.manifest import state_relpath   # noqa: F401 - its home is the contract; used here and by bench/
from ...contract.manifest_sections import SENSOR_STATE
from ...errors import SesgenError
from ...files.png import write_png
from .render_plan import SENSOR_DIR, SensorPlan

EXR_LAYOUT = "single part holding every pass (beauty of the sensor render, ground truth of the sharp render)"
# deflate level of the sensor images' PNGs, as the EXRs' and display PNGs': a KITTI view's raw
# and RGB images cost 0.17 CPU s at zlib's default 6 and 0.03 at 1 (bench/profile_scenes.py,
# the gt frame), files ~10 % larger; the decoded pixels are the same at every level
PNG_LEVEL = 1


def stored_metering(plan: SensorPlan, kept: Optional[dict], upto: Optional[int] = None) -> Optional[list]:
    """The metering pass's values in ``kept`` (the folder's manifest, when it may be
    resumed): every frame's metered brightness (None for frames not metered yet), or None
    when any of the first ``upto`` is missing (not stored: meter); default: every frame a
    whole render meters (``metered_frames``: all but the last)."""
    if plan.autoexposure is None or not kept:
        return None
    metered = (kept.get("sensor") or {}).get("metered") or []
    n = kept.get("frames")
    if upto is None:
        upto = plan.metered_frames(range(n or 0), n or 0)
    if len(metered) != n or any(v is None for v in metered[:upto]):
        return None
    return list(metered)


STATE_KEYS = SENSOR_STATE   # the per-frame state, in the manifest and in each frame's state_relpath file


def prepare_manifest(plan: SensorPlan, m, kept: Optional[dict], out: Optional[Path] = None,
                     metering: Optional[list] = None) -> None:
    """Finish a new manifest ``m`` (a ``contract.manifest.Manifest`` holding the plan's
    entries in ``extra``): the EXR layout of the sensor path, the metering pass's values
    (``metering``: every frame's metered brightness, with AUTOEXPOSURE), and the per-frame
    exposure state of frames kept from ``kept`` (the previous manifest when resuming) and
    from the per-frame state files in ``out``."""
    if not plan.active:
        return
    if plan.changes_rendering:
        m.render.setdefault("exr", {})["layout"] = EXR_LAYOUT
    if "sensor" not in m.extra:
        return
    if kept is None:
        if metering is not None:
            m.extra["sensor"]["metered"] = [None if v is None else float(v) for v in metering]
        return
    prev = kept.get("sensor") or {}
    for key in STATE_KEYS:
        old = prev.get(key) or []
        m.extra["sensor"][key] = [old[j] if j < len(old) else None for j in range(m.frames)]
    if out is not None:
        import json
        for k in range(m.frames):
            p = Path(out) / state_relpath(k)
            if p.is_file():
                try:
                    st = json.loads(p.read_text(encoding="utf-8"))
                    for key in STATE_KEYS:
                        m.extra["sensor"][key][k] = st[key]
                except (OSError, ValueError, KeyError):
                    pass
    if metering is not None:   # a frame this render did not meter keeps the folder's value
        m.extra["sensor"]["metered"] = [float(v) if v is not None else old for v, old in
                                        zip(metering, m.extra["sensor"]["metered"])]


def make_folders(plan: SensorPlan, out: Path) -> None:
    """The sensor image folders (the files written once per render, lens tables and IMU
    streams, are ``plan.static_files``: the output folder writes them with its own)."""
    if not plan.active:
        return
    for kind in plan.sensor_kinds():
        for view in plan.views:
            (Path(out) / SENSOR_DIR / view / kind).mkdir(parents=True, exist_ok=True)
    if plan.sensor is not None:
        (Path(out) / SENSOR_DIR / "state").mkdir(parents=True, exist_ok=True)


def exposure_for(plan: SensorPlan, extra: Optional[dict], k: int) -> tuple[float, float]:
    """(exposure_s, gain) of frame k: nominal, or auto-exposure from the metering pass's
    values of frames 0..k-1 (frame 0's too with the converged start; ``extra``: the manifest's
    extra entries)."""
    if plan.autoexposure is None:
        return plan.exposures([])[0]
    metered = ((extra or {}).get("sensor") or {}).get("metered") or []
    have = [metered[j] if j < len(metered) else None for j in range(max(k, int(plan.converged_start)))]
    if any(v is None for v in have):
        raise SesgenError(f"AUTOEXPOSURE: the metering pass's values of frames before {max(k, len(have))} are missing from the "
                          "manifest; render again with --force")
    return plan.exposures(have)[k]


_CACHE: dict = {}


def write_sensor_images(plan: SensorPlan, m, out: Path, k: int, exposure_s: float, gain: float,
                        exrs: dict, jpeg_writer: Optional[Callable] = None) -> dict[str, str]:
    """Run the camera chain on frame k's EXRs (``exrs[view]``: their paths) and write raw /
    RGB / JPEG images; record the exposure, gain and metered brightness of the frame in the
    manifest ``m`` (a Manifest) and in the frame's state file (without AUTOEXPOSURE the
    metered brightness is the frame's own, by the metering rule at its exposure; with it, the
    metering pass's value).
    Returns {relative path: SHA-256} of the images written (recorded with the frame, checked
    by ``verify``)."""
    from ...files.exr import read_exr
    from . import pipeline
    key = (id(plan), "rays")
    if key not in _CACHE:
        _CACHE.clear()
        _CACHE[key] = plan.pixel_rays()
        _CACHE[(id(plan), "fpn")] = {}
    rays, fpn = _CACHE[key], _CACHE[(id(plan), "fpn")]
    rgb_names = m.channels["rgb"][:3]
    metered, sums = None, {}
    for vi, view in enumerate(plan.views):
        ch = read_exr(exrs[view], rgb_names)
        lin = np.stack([ch[n] for n in rgb_names], axis=-1).astype(np.float64)
        if vi == 0:   # what the camera meters of this frame (SensorPlan.meter's rule at its exposure)
            metered = plan.meter_at(lin, exposure_s, gain)
        camera = pipeline.Camera(plan.sensor, plan.lens_spec, rays, plan.K[0, 2], plan.K[1, 2],
                                 plan.nominal_exposure_s())
        f = pipeline.process(lin, camera, pipeline.Shot(exposure_s, gain, k, vi), fpn_cache=fpn)
        written = [plan.sensor_relpath("raw", view, k), plan.sensor_relpath("rgb", view, k)]
        write_png(Path(out) / written[0], f.raw_dn, PNG_LEVEL)
        write_png(Path(out) / written[1], f.rgb8, PNG_LEVEL)
        if plan.sensor.jpeg_quality and jpeg_writer is not None:
            written.append(plan.sensor_relpath("jpeg", view, k))
            jpeg_writer(str(Path(out) / written[-1]), f.rgb8, plan.sensor.jpeg_quality)
        sums.update({rel: hashlib.sha256((Path(out) / rel).read_bytes()).hexdigest() for rel in written})
    s = m.extra["sensor"]
    s["exposure_s"][k], s["gain"][k] = float(exposure_s), float(gain)
    if plan.autoexposure is None:
        s["metered"][k] = metered
    from ...contract import atomic
    atomic.write_json(Path(out) / state_relpath(k), {key: s[key][k] for key in STATE_KEYS})
    return sums
