"""A plan's scene built in Blender and ready to render frames: the bpy side of a render job.

``BlenderSession(plan)`` builds the scene (``builder``), configures Cycles as the plan's
quality preset says (``render``, ``presets``) and fixes the film exposure;
``render_frame(k, paths)`` renders every view of frame k into the given EXR paths. It knows
nothing of output folders or manifests beyond what it reports for them (channel names,
exposure, Blender's version, how it renders).

Speed: the Cycles session persists from frame to frame (``use_persistent_data``: a static
scene is synchronised, its shaders compiled and its BVH built once, not per view), and
when the beauty pass uses no random numbers (the ``gt`` preset) both views are rendered
in one multiview render. Both give the same pixels as a fresh render per view
(tests/test_quality_presets.py, bench/identical_renders.py); ``fast=False`` renders the
plain way.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional

from ..contract.manifest import render_seed
from ..plan import Device, RenderPlan
from ..presets import EXPOSURE_PREVIEW
from . import builder, compat, exposure, render, rig, shading

EXPOSURE_RULE_AUTO = "auto: default lighting, 90th-percentile luminance of frame 0 = 0.6"
EXPOSURE_RULE_LIGHTS = "1 (the script's own lights)"
EXPOSURE_RULE_FLAT = "1 (gt: flat shading, no lights)"


class BlenderSession:
    """The built scene of one plan (see the module docstring)."""

    def __init__(self, plan: RenderPlan, known_exposure: Optional[float] = None, fast: bool = True):
        """``known_exposure``: the exposure of frames already rendered for this plan (resume),
        reused so that resumed frames match; measured when None (default lighting only).
        ``fast``: persistent Cycles data and multiview (same pixels, less time)."""
        self.plan = plan
        s = plan.settings
        self.built = builder.build_scene(plan.scene, width=s.width, height=s.height, K=s.K,
                                         view_poses=plan.view_poses)
        gpu = s.device is Device.GPU
        self.gpu = render.enable_gpu() if gpu else None
        self._configure = dict(gpu=gpu, threads=plan.options.threads, normal_pass=plan.options.normal_pass,
                               position_pass=plan.options.position_pass)
        self.flat = s.preset.shading == "flat"
        self.exposure = self._exposure(known_exposure)
        render.configure(self.built.scene, s.preset, **self._configure)
        exposure.set_exposure(self.built.scene, self.exposure)
        if self.flat:
            shading.apply_flat_shading(self.built, plan.scene, builder.tag)
        self.persistent = bool(fast)
        self.built.scene.render.use_persistent_data = self.persistent
        self.multiview = bool(fast and s.preset.deterministic_rgb and render.can_render_multiview(self.built.cameras))

    def _exposure(self, known: Optional[float]) -> float:
        """Default lighting only: one film exposure for the whole sequence (blender/exposure.py),
        measured with the same preview settings whatever the preset."""
        if self.flat or self.plan.scene.lights:
            return 1.0
        if known is not None:
            return float(known)
        render.configure(self.built.scene, EXPOSURE_PREVIEW, **self._configure)
        return exposure.measure_exposure(self.built.scene, self.built.cameras["left"], rig.blender_frame(0))

    @property
    def channels(self) -> dict:
        """EXR channel names of each product, as this Blender writes them."""
        return compat.exr_channel_names()

    @property
    def blender_version(self) -> str:
        return compat.version_string()

    def manifest_extra(self) -> dict:
        """What this session adds to the manifest's ``render`` entry."""
        rule = EXPOSURE_RULE_FLAT if self.flat else EXPOSURE_RULE_LIGHTS if self.plan.scene.lights \
            else EXPOSURE_RULE_AUTO
        extra = {"exr_layout": self.channels["layout"], "exposure": self.exposure, "exposure_rule": rule,
                 "pipeline": {"persistent_data": self.persistent, "multiview": self.multiview}}
        if self.gpu:
            extra["gpu"] = self.gpu
        return extra

    def render_frame(self, k: int, paths: dict[str, Path]) -> dict[str, dict]:
        """Render frame ``k`` of each view into ``paths[view]``; {view: render stats}."""
        quiet = not self.plan.options.verbose
        bframe = rig.blender_frame(k)
        seed = self.plan.settings.seed
        if self.multiview:  # the RGB uses no random numbers: one seed for the sequence
            return render.render_views(self.built.scene, self.built.cameras, bframe, render_seed(seed, 0, 0),
                                       paths, quiet=quiet)
        stats = {}
        for vi, view in enumerate(self.plan.views):
            stats[view] = render.render_view(self.built.scene, self.built.cameras[view], bframe,
                                             render_seed(seed, k, vi), str(paths[view]), quiet=quiet,
                                             fast=self.persistent)
        return stats
