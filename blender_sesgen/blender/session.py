"""A plan's scene built in Blender and ready to render frames: the bpy side of a render job.

``BlenderSession(plan)`` builds the scene (``builder``), configures Cycles (``render``) and
fixes the film exposure; ``render_frame(k, paths)`` renders every view of frame k into the
given EXR paths. It knows nothing of output folders or manifests beyond what it reports
for them (channel names, exposure, Blender's version).
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

from ..contract.manifest import render_seed
from ..plan import Device, RenderPlan
from . import builder, compat, exposure, render, rig

EXPOSURE_RULE_AUTO = "auto: default lighting, 90th-percentile luminance of frame 0 = 0.6"
EXPOSURE_RULE_LIGHTS = "1 (the script's own lights)"


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
                         position_pass=plan.options.position_pass)
        self.exposure = self._exposure(known_exposure)

    def _exposure(self, known: Optional[float]) -> float:
        """Default lighting only: one film exposure for the whole sequence (blender/exposure.py)."""
        if self.plan.scene.lights:
            value = 1.0
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
        return {"exr_layout": self.channels["layout"], "exposure": self.exposure,
                "exposure_rule": EXPOSURE_RULE_LIGHTS if self.plan.scene.lights else EXPOSURE_RULE_AUTO}

    def render_frame(self, k: int, paths: dict[str, Path]) -> dict[str, dict]:
        """Render frame ``k`` of each view into ``paths[view]``; {view: render stats}."""
        stats = {}
        for vi, view in enumerate(self.plan.views):
            stats[view] = render.render_view(self.built.scene, self.built.cameras[view], rig.blender_frame(k),
                                             render_seed(self.plan.settings.seed, k, vi), str(paths[view]),
                                             quiet=not self.plan.options.verbose)
        return stats
