"""A plan's scene built in Blender and ready to render frames: the bpy side of a render job.

``BlenderSession(plan)`` builds the scene (``builder``), configures Cycles as the plan's
quality preset says (``render``, ``presets``), the colour management as the script's LOOK
says, and fixes the film exposure; ``render_frame(k, paths)`` renders every view of frame k
into the given EXR paths (and the display-referred PNGs). It knows nothing of output folders
or manifests beyond what it reports for them (channel names, exposure, Blender's version,
how it renders).

Speed (``fast``): the Cycles session persists from frame to frame and the active camera
never changes (``render.render_views``), so a static scene is synchronised, its shaders
compiled and its BVH built once per sequence, not once per view; when the beauty pass uses
no random numbers (the ``gt`` preset) both views are rendered in one multiview render. The
pixels are those of a fresh render per view (tests/test_quality_presets.py,
bench/identical_renders.py); ``fast=False`` renders that plain way.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Callable, Optional

from ..contract.manifest import render_seed
from ..scene.lighting import AGX_LOOKS, EXPOSURE_TARGET, VIEW_TRANSFORMS
from ..render.plan import Device, RenderPlan
from ..render.sensor.autoexposure import METERING_DENOISE
from ..scene.presets import EXPOSURE_PREVIEW
from . import builder, compat, exposure, render, rig, shading

EXPOSURE_RULE_AUTO = f"auto: 90th-percentile luminance of frame 0 = {EXPOSURE_TARGET}"
EXPOSURE_RULE_FLAT = "1 (gt: flat shading, no lights)"


class BlenderSession:
    """The built scene of one plan (see the module docstring)."""

    def __init__(self, plan: RenderPlan, known_exposure: Optional[float] = None, fast: bool = True,
                 known_metering: Optional[list] = None, meter: bool = True,
                 stop: Callable[[], bool] = lambda: False):
        """``known_exposure``: the exposure of frames already rendered for this plan (resume),
        reused so that resumed frames match; measured when None (default lighting only).
        ``fast``: persistent Cycles data and multiview (same pixels, less time).
        ``known_metering``: the sensor auto-exposure's metered brightness of every frame,
        stored in the folder by an earlier writer; the metering pass runs when None and
        ``meter`` (False: a scene built to look at, not to render). ``stop()`` is asked between
        the build's steps and the metering pass's frames: KeyboardInterrupt when it says so
        (a long metering pass stops on SIGTERM as the frames do)."""
        self.plan = plan
        self._stop = stop
        s = plan.settings
        self.flat = s.preset.shading == "flat"
        self.culling, self._exposure_ids, self._metering_ids = None, None, None
        self._preview_session = False   # the metering pass reuses the exposure preview's session
        self._preview_luminance = None  # ... and takes frame 0's value from its preview
        scene = plan.scene
        meters = meter and plan.sensor.autoexposure is not None and known_metering is None
        self._meter = meter
        if plan.options.cull:   # only what the frames can see (and, to meter, what frame 0 sees)
            from ..render.culling import culled_scene, visible_objects
            self.culling = visible_objects(plan, plan.frames)
            keep = set(self.culling.keep)
            if self._measures_exposure(known_exposure):
                self._exposure_ids = visible_objects(plan, [0]).keep
                keep |= self._exposure_ids
            if meters:   # the metering pass sees what every frame it meters sees, in every chunk
                upto = plan.sensor.metered_frames(plan.frames, plan.scene.frames)
                self._metering_ids = visible_objects(plan, range(upto)).keep
                keep |= set(self._metering_ids)
            scene = culled_scene(plan.scene, keep)
        self._built_from = scene      # the model built (the exposure preview's cache key)
        self.built = builder.build_scene(scene, width=s.width, height=s.height, K=s.K,
                                         view_poses=plan.view_poses, threads=plan.options.threads)
        if self.culling is not None:     # meshes shared in the full scene stay instanced (exact depth)
            from collections import Counter

            from ..scene.assets import mesh_key
            from ..scene.model import Asset
            from .assets import keep_instanced
            full = Counter(mesh_key(o) for o in plan.scene.objects if isinstance(o, Asset))
            keep_instanced(self.built, scene.objects, full)
        gpu = s.device is Device.GPU
        self.gpu = render.enable_gpu() if gpu else None
        self._configure = dict(gpu=gpu, threads=plan.options.threads, normal_pass=plan.options.normal_pass,
                               position_pass=plan.options.position_pass,
                               view_transform=VIEW_TRANSFORMS[plan.scene.look.view],
                               look=AGX_LOOKS[plan.scene.look.look])
        self.fast = bool(fast and render.can_render_multiview(self.built.cameras))
        self._configure["persistent"] = self.fast
        self._check_stop()
        self.exposure = self._exposure(known_exposure, then_meters=meters)
        self._check_stop()
        self.metering_s = None      # seconds the metering pass took (None: not run here)
        self.metering = self._metering(known_metering)
        if self._exposure_ids is not None or self._metering_ids is not None:
            self._show(self.culling.keep)    # what only the metering needed stays out of the frames
        render.configure(self.built.scene, s.preset, **self._configure)
        exposure.set_exposure(self.built.scene, self.exposure)
        if self.flat:
            shading.apply_flat_shading(self.built, plan.scene, builder.tag)
        self.sensor = None          # the sensor path (motion blur, rolling shutter, lens), if any
        if plan.sensor.changes_rendering:
            from .sensor_render import SensorSession
            self.sensor = SensorSession(plan, self.built, self.fast)
        self.views_per_render = len(plan.views) if self.fast and s.preset.deterministic_rgb else 1

    def _measures_exposure(self, known: Optional[float]) -> bool:
        return not self.flat and self.auto_exposure and known is None

    def _show(self, ids) -> None:
        """Render only the built objects whose ids are in ``ids`` (the others stay built, hidden)."""
        for oid, objs in self.built.objects.items():
            for b in objs:
                b.hide_render = oid not in ids

    @property
    def auto_exposure(self) -> bool:
        """``LOOK exposure auto``, or no LOOK exposure and no emitting LIGHT (portals emit nothing)."""
        look = self.plan.scene.look
        if look.auto_exposure is not None:
            return look.auto_exposure
        return not any(light.kind != "portal" for light in self.plan.scene.lights)

    def _exposure(self, known: Optional[float], then_meters: bool = False) -> float:
        """One film exposure for the whole sequence: 1 for the flat ``gt`` shading, else
        automatic (blender/exposure.py, measured with the same preview settings whatever the
        preset; the value of frames already rendered when resuming) or the LOOK's fixed 2^EV.
        ``then_meters``: the metering pass follows, whose previews (the same size, samples and
        objects) may then reuse the exposure preview's Cycles session."""
        if self.flat:
            return 1.0
        if not self.auto_exposure:
            return float(2.0 ** self.plan.scene.look.exposure_ev)
        if known is not None:
            return float(known)
        # fast: the preview renders in the persistent Cycles session that the frames then reuse
        # (synchronised and its BVH built once) - if they take at least the preview's samples:
        # a persistent session whose sample count goes down renders other pixels than a fresh
        # one (bpy 5.0.1, its default blue-noise pattern), and resumed frames start fresh; not
        # on the sensor path: a session synchronised without motion blur renders the blurred
        # frames with other pixels than a fresh one (the city street, draft: every pixel)
        share = self.fast and self.plan.settings.preset.samples >= EXPOSURE_PREVIEW.samples \
            and not self.plan.sensor.changes_rendering
        # else the metering pass may reuse the preview's session: the same preview settings and
        # objects (not when culling shows the two other object sets); frame 0's value is the
        # preview's, the pass goes on from frame 1 as a fresh pass would after frame 0
        previews_alike = then_meters and not share and self._exposure_ids is None and self._metering_ids is None
        self._preview_session = self.fast and previews_alike
        render.configure(self.built.scene, EXPOSURE_PREVIEW,
                         **{**self._configure, "persistent": share or self._preview_session})
        if self._exposure_ids is not None:   # culled: frame 0 metered with what frame 0 sees, in every chunk
            self._show(self._exposure_ids)
        denoise = bool(previews_alike and METERING_DENOISE)
        value, luminance = exposure.cached_measure(
            lambda: self._preview_key(share, denoise),
            lambda: exposure.measure_exposure(self.built.scene, self.built.cameras["left"], rig.blender_frame(0),
                                              self.built.cameras if share else None, denoise=denoise))
        # the metering pass's frame 0 is this preview (a plain render of the same objects)
        if previews_alike and exposure.PREVIEW_IS_METERING:
            self._preview_luminance = luminance
        return value

    def _preview_key(self, share: bool, denoise: bool) -> Optional[list]:
        """The asset cache's key of this session's exposure preview (blender/exposure.py:
        ``preview_key``): the scene model built, the plan's settings, poses and options (but the
        frames, where culling does not choose the objects by them, the threads and the log's
        verbosity: the same pixels), the configuration, the objects shown, how the preview
        renders and the GPUs it renders on; None (not cached) when the build reads files
        besides the script."""
        if exposure.reads_files(self._built_from):
            return None
        p = self.plan
        options = {f.name: getattr(p.options, f.name) for f in dataclasses.fields(p.options)
                   if f.name not in ("threads", "verbose") and (f.name != "frames" or p.options.cull)}
        if "frames" in options:
            options["frames"] = p.frames
        configure = {k: v for k, v in self._configure.items() if k not in ("threads", "persistent")}
        ids = None if self._exposure_ids is None else sorted(self._exposure_ids)
        return exposure.preview_key([self._built_from, p.settings, p.view_poses, options, configure, ids,
                                     EXPOSURE_PREVIEW, exposure.PREVIEW_WIDTH, exposure.PREVIEW_SAMPLES,
                                     rig.blender_frame(0), bool(share), bool(denoise), self.fast, self.gpu])

    def _check_stop(self) -> None:
        if self._stop():
            raise KeyboardInterrupt

    def _metering(self, known: Optional[list]) -> Optional[list]:
        """The sensor auto-exposure's metered brightness of the frames before this render's last
        (None without AUTOEXPOSURE; None from its last frame on): ``known`` when the folder
        holds them, else the metering pass (blender/exposure.py: ``meter_frames``), whose value
        of a frame does not depend on which frames this render has, so chunks and resumed
        renders agree."""
        if self.plan.sensor.autoexposure is None or not self._meter:
            return None
        if known is not None:
            return [None if v is None else float(v) for v in known]
        t0 = time.perf_counter()
        # frame k's exposure follows frames 0..k-1: meter the frames before this render's last
        # (a chunk's or --frames A:B's prefix; no render meters the sequence's last frame), the
        # rest left unknown; frames 0:2 need frame 0 only (frames 0:1 too with the converged start,
        # AUTOEXPOSURE's default: frame 0's exposure answers its own metering): the exposure
        # preview's where it is the metering preview, no render here
        upto = self.plan.sensor.metered_frames(self.plan.frames, self.plan.scene.frames)
        first = self._preview_luminance if upto else None
        if upto > (first is not None):
            render.configure(self.built.scene, EXPOSURE_PREVIEW,
                             **{**self._configure, "persistent": self._preview_session})
            if self._metering_ids is not None:
                self._show(self._metering_ids)
        frames = [rig.blender_frame(k) for k in range(upto)]
        metered = exposure.meter_frames(self.built.scene, self.built.cameras["left"], frames, self.exposure,
                                        first=first, progress=lambda i, n: self._check_stop(),
                                        metering=self.plan.sensor.meter) if upto else []
        metered = metered + [None] * (self.plan.scene.frames - upto)
        # switching persistence off frees the previews' session: the frames start their own
        render.configure(self.built.scene, EXPOSURE_PREVIEW, **{**self._configure, "persistent": False})
        self.metering_s = time.perf_counter() - t0
        return metered

    @property
    def channels(self) -> dict:
        """EXR channel names of each product, as this Blender writes them."""
        return compat.exr_channel_names()

    @property
    def blender_version(self) -> str:
        return compat.version_string()

    def manifest_extra(self) -> dict:
        """What this session adds to the manifest's ``render`` entry."""
        rule = EXPOSURE_RULE_FLAT if self.flat else EXPOSURE_RULE_AUTO if self.auto_exposure else \
            f"fixed: {self.plan.scene.look.exposure_ev:g} EV (factor 2^EV)"
        extra = {"exr_layout": self.channels["layout"], "exposure": self.exposure, "exposure_rule": rule,
                 "pipeline": {"persistent_data": self.fast, "views_per_render": self.views_per_render}}
        if self.gpu:
            extra["gpu"] = self.gpu
        return extra

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
                     display_paths: Optional[dict[str, Path]] = None,
                     still_exposure_s: Optional[float] = None) -> dict[str, dict]:
        """Render frame ``k`` of each view into ``paths[view]``; {view: render stats}.
        ``stop()`` is asked before each render (KeyboardInterrupt when it says yes);
        ``exposure_s``: the frame's exposure time on the sensor path (auto-exposure);
        ``display_paths[view]``: where the display-referred PNG goes; ``still_exposure_s``:
        the exposure of the still stretch's first frame, whose beauty frame k shows."""
        if self.sensor is not None:
            return self.sensor.render_frame(k, self.plan.sensor.nominal_exposure_s() if exposure_s is None
                                            else exposure_s, paths, stop, display_paths, still_exposure_s)
        quiet = not self.plan.options.verbose
        bframe = rig.blender_frame(k)
        seed = self.plan.settings.seed
        scene, cameras, views = self.built.scene, self.built.cameras, self.plan.views
        if stop():
            raise KeyboardInterrupt
        if self.views_per_render > 1:  # the RGB uses no random numbers: one seed for the sequence
            return render.render_views(scene, cameras, views, bframe, render_seed(seed, 0, 0), paths, quiet,
                                       display_paths)
        stats = {}
        for vi, view in enumerate(views):
            if vi and stop():
                raise KeyboardInterrupt
            if self.fast:
                stats.update(render.render_views(scene, cameras, (view,), bframe, render_seed(seed, k, vi),
                                                 paths, quiet, display_paths))
            else:
                stats[view] = render.render_view(scene, cameras[view], bframe, render_seed(seed, k, vi),
                                                 str(paths[view]), quiet=quiet,
                                                 display_path=str(display_paths[view]) if display_paths else None)
        return stats
