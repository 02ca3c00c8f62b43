"""A render that reuses another render's EXRs: only the post-render camera chain runs
(``render SCENE --out DIR --reuse-exr BASE``; pure, no Blender).

Two scripts that differ only in what happens after Cycles -- the ``SENSOR`` statement
(gain, noise, CFA, response), the lens's optics on the sensor images (``LENS fnumber``,
``defocus``, ``vignetting``, ``chromatic``) and ``NOISE`` -- render the same EXRs. This
session stands in for the Blender session of such a script: each frame's EXRs (and
display-referred PNGs) are copied from BASE, then the job runs the sensor chain on them and
records the frame as usual (checksums, completion log, manifest), so the folder is an
ordinary render of the script, made in the time of a file copy. What makes two scripts
"the same render" is checked before anything is written (:func:`check_reusable`): the
scenes equal once the post-render parts are set aside, the same pixel-affecting settings
and timing, no AUTOEXPOSURE (its schedule sets the motion blur), every frame complete in
BASE. A verification study (docs/studies.md) uses it for its sensor-stage variants.
"""
from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path
from typing import Callable, Optional

from ..contract.errors import ContractError
from ..contract.manifest import Manifest, display_relpath, exr_relpath
from ..errors import SesgenError


def rendering_part(scene) -> dict:
    """The scene as Cycles sees it: its JSON without the source, the post-render camera
    chain (SENSOR, the lens's optics on sensor images) and NOISE."""
    lens = scene.lens
    if lens is not None:
        lens = dataclasses.replace(lens, f_number=0.0, defocus_px=0.0, vignetting=0.0, chromatic_px=0.0)
        if not lens.distorted:
            lens = None
    s = dataclasses.replace(scene, source="", sensor=None, noise=None, lens=lens)
    return s.to_json()


def _base_scene(base: Path, manifest: dict):
    from ..ses.parser import parse_bytes
    src = manifest.get("scene_source") or ""
    folder = Path(src).parent if src and Path(src).parent.is_dir() else base
    try:
        return parse_bytes((base / "scene.ses").read_bytes(), str(base / "scene.ses"), str(folder))
    except OSError as e:
        raise SesgenError(f"--reuse-exr {base}: cannot read its scene.ses ({e.strerror or e})") from None


def check_reusable(plan, base: Path) -> Manifest:
    """The base render's manifest if ``plan`` may reuse its EXRs; SesgenError saying why not."""
    from .folder import OutputFolder
    base = Path(base)
    try:
        m = Manifest.read(base)
    except (ContractError, OSError) as e:
        raise SesgenError(f"--reuse-exr {base}: not a readable render folder ({e})") from None
    raw = m.to_json()
    if plan.scene.autoexposure is not None:
        raise SesgenError("--reuse-exr: a script with AUTOEXPOSURE renders its own exposure schedule (its motion "
                          "blur depends on it); render it")
    if not OutputFolder.same_settings(raw, plan.settings):
        raise SesgenError(f"--reuse-exr {base}: rendered with other settings (quality, samples, seed, resolution, "
                          "passes or timing)")
    if rendering_part(_base_scene(base, raw)) != rendering_part(plan.scene):
        raise SesgenError(f"--reuse-exr {base}: its scene differs from this script in more than the post-render "
                          "camera chain (SENSOR, the lens's optics, NOISE); render it")
    missing = [k for k in plan.frames if not m.frames_complete[k]]
    if missing:
        raise SesgenError(f"--reuse-exr {base}: frame(s) {missing[:5]} are not rendered there")
    return m


class ReusedSession:
    """What :class:`~blender_sesgen.render.job.RenderJob` needs of a Blender session, answered
    from the base render (module docstring)."""

    def __init__(self, plan, base):
        self.plan = plan
        self.base = Path(base).resolve()
        self.base_manifest = check_reusable(plan, self.base)
        self.built = None
        self.culling = None      # nothing is built here (the base's render culled, if it did)
        r = self.base_manifest.render
        self.exposure = r.get("exposure")
        self.metering, self.metering_s = None, None     # AUTOEXPOSURE is refused here (check_reusable)

    @property
    def channels(self) -> dict:
        m = self.base_manifest
        return {**m.channels, "layout": m.render.get("exr", {}).get("layout")}

    @property
    def blender_version(self) -> Optional[str]:
        return self.base_manifest.generator.get("blender")

    def manifest_extra(self) -> dict:
        r = self.base_manifest.render
        extra = {k: r[k] for k in ("exposure", "exposure_rule", "pipeline", "gpu") if k in r}
        extra["exr_layout"] = r.get("exr", {}).get("layout")
        extra["reused_exr_from"] = str(self.base)
        return extra

    @property
    def imported_objects(self) -> list:
        return [o for o in self.base_manifest.objects if o.get("shape") == "blend"]

    @property
    def jpeg_writer(self) -> Optional[Callable]:
        if self.plan.scene.sensor is None or not self.plan.scene.sensor.jpeg_quality:
            return None
        from ..blender.sensor import save_jpeg   # Blender's JPEG writer (needs bpy)
        return save_jpeg

    def render_frame(self, k: int, paths: dict, stop: Callable[[], bool] = lambda: False,
                     exposure_s: Optional[float] = None, display_paths: Optional[dict] = None,
                     still_exposure_s: Optional[float] = None) -> dict:
        """Frame k's EXRs (and PNGs) copied from BASE (a still stretch's held beauty included:
        BASE drew it, so ``still_exposure_s`` has nothing to do here)."""
        stats = {}
        for view, tmp in paths.items():
            if stop():
                raise KeyboardInterrupt
            shutil.copyfile(self.base / exr_relpath(view, k), tmp)
            if display_paths:
                shutil.copyfile(self.base / display_relpath(view, k), display_paths[view])
            stats[view] = {"cycles_s": None, "reused": True}
        return stats
