"""Rendering one frame through the sensor path: the beauty render with Cycles' shutter
(motion blur, rolling shutter) and lens, the sharp ground-truth render, and one EXR holding
the beauty of the first and the ground truth of the second (planar depth restored for a
distorting lens)."""
from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ..contract.atomic import temp_path
from ..contract.depth import BACKGROUND_THRESHOLD
from ..contract.exr_format import PASS_NOISY
from ..contract.manifest import render_seed
from ..files.exr import read_exr, write_exr
from ..files.png import write_png
from ..render.sensor import still
from . import compat, object_motion, render, rig, sensor


class SensorSession:
    """The Blender side of a plan's sensor path (cameras re-keyed per frame, lens applied)."""

    def __init__(self, plan, built, fast: bool = False):
        self.plan = plan
        self.fast = fast
        self.sensor = plan.sensor
        self.built = built
        self.scene = built.scene
        self.cameras = built.cameras
        s = self.sensor
        if s.lens is not None:
            for cam in self.cameras.values():
                sensor.apply_lens(cam.data, s.lens, s.width, s.height)
            self._ray_z = s.lens.pixel_rays(s.width, s.height)[..., 2].astype(np.float32)

    def _key(self, k: int, shutters: list[float], shift_frames: float) -> None:
        """Key the cameras at the instants Cycles samples for frame k, with the poses of
        those instants shifted by ``shift_frames`` (the rolling shutter's half line)."""
        bframe = rig.blender_frame(k)
        times = sensor.sparse_instants(bframe, np.concatenate(
            [[float(bframe)]] + [sensor.motion_instants(bframe, s) for s in shutters if s > 0]))
        for view, cam in self.cameras.items():
            sensor.key_camera_instants(cam, times, self.sensor.camera_poses(view, times + shift_frames, rig.FRAME0))
        # moving objects at the same instants, so the shutter sees them move along their own motion
        object_motion.key_instants(self.built, self.plan.scene, times, shift_frames, sensor.MOTION_STEPS)

    def render_frame(self, k: int, exposure_s: float, paths: dict[str, Path],
                     stop: Callable[[], bool] = lambda: False,
                     display_paths: Optional[dict] = None,
                     still_exposure_s: Optional[float] = None) -> dict[str, dict]:
        """Every view of frame k into ``paths[view]`` (and the beauty's display-referred PNG
        into ``display_paths[view]``); {view: render stats}. ``stop()`` is asked before each
        view (KeyboardInterrupt when it says yes).

        ``fast`` (the session's): the renders go through the persistent multiview session
        (``render.render_views``: the active camera never changes, so Cycles keeps the
        synchronised scene, its BVH and the sky from render to render instead of building
        them again for each of a frame's renders), and the sharp ground-truth render draws
        both views at once (its beauty is dropped: the ground-truth passes come from sample 0
        through the pixel centre, whatever the seed). With the ``gt`` preset that sharp render
        of both views is the frame."""
        s = self.sensor
        shutter, duration = s.shutter(exposure_s)
        gt_shutter = s.shutter(0.0)[0] if s.rolling_shutter else 0.0
        shift = sensor.rolling_shift_frames(s.timing.readout_s, s.height, s.rate_hz) if s.rolling_shutter else 0.0
        # in a still stretch the beauty is the stretch's first frame's, drawn again (its poses,
        # its seed) and reprojected to frame k below; the ground truth is frame k's own
        ref = s.still_reference(k)
        beauty_shutter, beauty_duration = (shutter, duration) if ref == k else s.shutter(
            exposure_s if still_exposure_s is None else still_exposure_s)
        # one flat sample through the pixel centre (gt) integrates no shutter: the sharp render
        # of both views is the whole frame, its ground truth that of the other presets
        sharp_only = self.fast and self.plan.settings.preset.deterministic_rgb
        self._key(ref, [gt_shutter] if sharp_only else [beauty_shutter, gt_shutter], shift)
        names = compat.exr_channel_names()
        beauty = set(names["rgb"])
        quiet = not self.plan.options.verbose

        def draw(views, seed: int, targets: dict, display=None, frame: int = k) -> dict:
            bframe = rig.blender_frame(frame)
            if self.fast:
                return render.render_views(self.scene, self.cameras, views, bframe, seed, targets, quiet, display)
            (v,) = views
            return {v: render.render_view(self.scene, self.cameras[v], bframe, seed, str(targets[v]), quiet=quiet,
                                          display_path=str(display[v]) if display else None)}

        views = tuple(self.plan.views)
        tmp = {v: temp_path(Path(paths[v]).with_name("beauty-" + Path(paths[v]).name)) for v in views}
        tmp_gt = {v: temp_path(Path(paths[v]).with_name("gt-" + Path(paths[v]).name)) for v in views}
        stats = {}
        try:
            if sharp_only:
                if stop():
                    raise KeyboardInterrupt
                with sensor.ground_truth_settings(self.scene, gt_shutter, s.rolling_shutter):
                    stats = draw(views, render_seed(self.plan.settings.seed, 0, 0), tmp, display_paths)
            else:
                sensor.set_shutter(self.scene, beauty_shutter, s.rolling_shutter, beauty_duration)
            # the beauty through the sensor's pixel aperture where the ground truth is a render of its own
            aperture = sensor.pixel_aperture(self.scene) if s.shutter_effects else contextlib.nullcontext()
            with aperture:
                for vi, view in enumerate(() if sharp_only else views):
                    if stop():
                        raise KeyboardInterrupt
                    stats.update(draw((view,), render_seed(self.plan.settings.seed, ref, vi), tmp,
                                      {view: display_paths[view]} if display_paths else None, ref))
            # the ground truth's own instants alone: between keys Blender interpolates, so the
            # beauty's shutter instants beside a rolling shutter's row instants would move the
            # rows' poses with the frame's exposure (up to 1e-4 of the depth)
            if ref != k or (s.rolling_shutter and not sharp_only):
                self._key(k, [gt_shutter], shift)
            if s.shutter_effects and not sharp_only:
                with sensor.ground_truth_settings(self.scene, gt_shutter, s.rolling_shutter):
                    gt_stats = {}
                    for vi, group in enumerate([views] if self.fast else [(v,) for v in views]):
                        gt_stats.update(draw(group, render_seed(self.plan.settings.seed, k, vi), tmp_gt))
                for view in views:
                    st, st_gt = stats[view], gt_stats[view]
                    st["cycles_s"] = (None if st_gt["cycles_s"] is None or st["cycles_s"] is None
                                      else st["cycles_s"] + st_gt["cycles_s"])
            for view in views:
                if sharp_only and s.lens is None:   # Blender's file is the frame, as on the plain path
                    os.replace(tmp[view], paths[view])
                    continue
                channels = read_exr(tmp[view])
                if s.shutter_effects and not sharp_only:
                    for n, a in read_exr(tmp_gt[view]).items():
                        if n not in beauty and f".{PASS_NOISY[0]}." not in n:
                            channels[n] = a
                if s.lens is not None:   # a custom camera's Depth pass is the distance along the ray
                    z = channels[names["depth"]]
                    channels[names["depth"]] = np.where(z >= BACKGROUND_THRESHOLD, z, z * self._ray_z)
                if ref != k:
                    T = s.camera_poses(view, np.array([rig.blender_frame(ref), rig.blender_frame(k)]), rig.FRAME0)
                    move = still.reprojection(channels[names["depth"]], s.K, T[0], T[1])
                    held = [n for n in channels if n in beauty or f".{PASS_NOISY[0]}." in n]
                    channels.update(move({n: channels[n] for n in held}))
                    if display_paths:   # the display-referred PNG, reprojected in display values
                        _reproject_png(display_paths[view], move)
                write_exr(Path(paths[view]), channels)
        finally:
            for f in (*tmp.values(), *tmp_gt.values()):
                if os.path.exists(f):
                    os.remove(f)
            sensor.set_shutter(self.scene, 0.0, False, 0.0)
        return stats


def _reproject_png(path, move) -> None:
    """Rewrite an 8-bit RGB PNG of frame r's view as frame k's camera sees it (``move``:
    :func:`still.reprojection` from r to k)."""
    import bpy
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    rgb = px.reshape(h, w, 4)[::-1, :, :3]              # Blender's rows run bottom-up
    out = move({c: rgb[..., c] for c in range(3)})
    write_png(Path(path), np.clip(np.round(np.stack([out[c] for c in range(3)], axis=-1) * 255.0), 0, 255)
              .astype(np.uint8), level=1)
