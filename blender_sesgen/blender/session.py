"""A plan's scene built in Blender and ready to render frames: the bpy side of a render job.

``BlenderSession(plan)`` builds the scene (``builder``), configures Cycles (``render``) and
fixes the film exposure; ``render_frame(k, paths)`` renders every view of frame k into the
given EXR paths (and the display-referred PNGs). It knows nothing of output folders or manifests beyond what it reports
for them (channel names, exposure, Blender's version).
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

from ..contract.manifest import render_seed
from ..lighting_data import AGX_LOOKS, EXPOSURE_TARGET, VIEW_TRANSFORMS
from ..plan import Device, RenderPlan
from . import builder, compat, exposure, render, rig

EXPOSURE_RULE_AUTO = f"auto: 90th-percentile luminance of frame 0 = {EXPOSURE_TARGET}"


class BlenderSession:
    """The built scene of one plan (see the module docstring)."""

    def __init__(self, plan: RenderPlan, known_exposure: Optional[float] = None):
        """``known_exposure``: the exposure of frames already rendered for this plan (resume),
        reused so that resumed frames match; measured when None (default lighting only)."""
        self.plan = plan
        s = plan.settings
        self.built = builder.build_scene(plan.scene, width=s.width, height=s.height, K=s.K,
                                         view_poses=plan.view_poses)
        gpu = s.device is Device.GPU
        if gpu:
            render.enable_gpu()
        render.configure(self.built.scene, samples=s.samples, denoise=s.denoise, gpu=gpu,
                         threads=plan.options.threads, normal_pass=plan.options.normal_pass,
                         position_pass=plan.options.position_pass,
                         view_transform=VIEW_TRANSFORMS[plan.scene.look.view],
                         look=AGX_LOOKS[plan.scene.look.look])
        self.exposure = self._exposure(known_exposure)
        self.sensor = None          # the sensor path (motion blur, rolling shutter, lens), if any
        if plan.sensor.changes_rendering:
            from .sensor_render import SensorSession
            self.sensor = SensorSession(plan, self.built)

    @property
    def auto_exposure(self) -> bool:
        """``LOOK exposure auto``, or no LOOK exposure and no emitting LIGHT (portals emit nothing)."""
        look = self.plan.scene.look
        if look.auto_exposure is not None:
            return look.auto_exposure
        return not any(light.kind != "portal" for light in self.plan.scene.lights)

    def _exposure(self, known: Optional[float]) -> float:
        """One film exposure for the whole sequence: automatic (blender/exposure.py; the value
        of frames already rendered when resuming) or the LOOK's fixed 2^EV."""
        if not self.auto_exposure:
            value = float(2.0 ** self.plan.scene.look.exposure_ev)
        elif known is not None:
            value = float(known)
        else:
            value = exposure.measure_exposure(self.built.scene, self.built.cameras["left"], rig.blender_frame(0))
        exposure.set_exposure(self.built.scene, value)
        return value

    @property
    def channels(self) -> dict:
        """EXR channel names of each product, as this Blender writes them."""
        return compat.exr_channel_names()

    @property
    def blender_version(self) -> str:
        return compat.version_string()

    def manifest_extra(self) -> dict:
        """What this session adds to the manifest's ``render`` entry."""
        rule = EXPOSURE_RULE_AUTO if self.auto_exposure else \
            f"fixed: {self.plan.scene.look.exposure_ev:g} EV (factor 2^EV)"
        return {"exr_layout": self.channels["layout"], "exposure": self.exposure, "exposure_rule": rule}

    @property
    def imported_objects(self) -> list[dict]:
        """Manifest rows of the objects BLEND files brought (their ids are given when loaded)."""
        return list(self.built.imported)

    @property
    def jpeg_writer(self):
        """Writes the sensor's JPEG images (Blender's image writer)."""
        from .sensor import save_jpeg
        return save_jpeg

    def render_frame(self, k: int, paths: dict[str, Path], stop: Callable[[], bool] = lambda: False,
                     exposure_s: Optional[float] = None,
                     display_paths: Optional[dict[str, Path]] = None) -> dict[str, dict]:
        """Render frame ``k`` of each view into ``paths[view]``; {view: render stats}.
        ``stop()`` is asked before each view (KeyboardInterrupt when it says yes);
        ``exposure_s``: the frame's exposure time on the sensor path (auto-exposure);
        ``display_paths[view]``: where the display-referred PNG goes (plain path only)."""
        if self.sensor is not None:
            return self.sensor.render_frame(k, self.plan.sensor.nominal_exposure_s() if exposure_s is None
                                            else exposure_s, paths, stop)
        stats = {}
        for vi, view in enumerate(self.plan.views):
            if stop():
                raise KeyboardInterrupt
            stats[view] = render.render_view(self.built.scene, self.built.cameras[view], rig.blender_frame(k),
                                             render_seed(self.plan.settings.seed, k, vi), str(paths[view]),
                                             quiet=not self.plan.options.verbose,
                                             display_path=str(display_paths[view]) if display_paths else None)
        return stats
