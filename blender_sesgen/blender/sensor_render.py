"""Rendering one frame through the sensor path: the beauty render with Cycles' shutter
(motion blur, rolling shutter) and lens, the sharp ground-truth render, and one EXR holding
the beauty of the first and the ground truth of the second (planar depth restored for a
distorting lens)."""
from __future__ import annotations

import os

import numpy as np

from .. import contract
from ..exr import read_exr, write_exr
from . import render, rig, sensor


class SensorSession:
    """The Blender side of a job's sensor plan (cameras re-keyed per frame, lens applied)."""

    def __init__(self, job):
        self.job = job
        self.plan = job.sensor
        self.scene = job.built.scene
        self.cameras = job.built.cameras
        if self.plan.lens is not None:
            for cam in self.cameras.values():
                sensor.apply_lens(cam.data, self.plan.lens, self.plan.width, self.plan.height)
            self._ray_z = self.plan.lens.pixel_rays(self.plan.width, self.plan.height)[..., 2].astype(np.float32)

    def _key(self, k: int, shutters: list[float], shift_frames: float) -> None:
        """Key the cameras at the instants Cycles samples for frame k, with the poses of
        those instants shifted by ``shift_frames`` (the rolling shutter's half line)."""
        bframe = rig.blender_frame(k)
        times = np.concatenate([[float(bframe)]] + [sensor.motion_instants(bframe, s) for s in shutters if s > 0])
        for view, cam in self.cameras.items():
            sensor.key_camera_instants(cam, times, self.plan.camera_poses(view, times + shift_frames, rig.FRAME0))

    def render_frame(self, k: int, exposure_s: float) -> tuple[dict, float | None]:
        plan, job = self.plan, self.job
        shutter, duration = plan.shutter(exposure_s)
        gt_shutter = plan.shutter(0.0)[0] if plan.rolling_shutter else 0.0
        sub = sensor.rolling_shift_frames(plan.timing.readout_s, plan.height, plan.rate_hz) if plan.rolling_shutter else 0.0
        self._key(k, [shutter, gt_shutter], sub)
        stats, cycles_s = {}, 0.0
        names = job.manifest["channels"]
        beauty_names = [n for n in read_names(names) if n]
        for vi, view in enumerate(plan.views):
            final = job.out_dir / contract.exr_relpath(view, k)
            tmp = final.with_name(f".{final.name}.tmp-{os.getpid()}.exr")
            tmp_gt = final.with_name(f".{final.name}.gt-{os.getpid()}.exr")
            seed = contract.render_seed(job.settings.seed, k, vi)
            sensor.set_shutter(self.scene, shutter, plan.rolling_shutter, duration)
            st = render.render_view(self.scene, self.cameras[view], rig.blender_frame(k), seed, str(tmp),
                                    quiet=not job.options.verbose)
            channels = read_exr(tmp)
            if plan.shutter_effects:
                with sensor.ground_truth_settings(self.scene, gt_shutter, plan.rolling_shutter):
                    st_gt = render.render_view(self.scene, self.cameras[view], rig.blender_frame(k), seed,
                                               str(tmp_gt), quiet=not job.options.verbose)
                gt = read_exr(tmp_gt)
                for n, a in gt.items():
                    if n not in beauty_names and ".Noisy Image." not in n:
                        channels[n] = a
                os.remove(tmp_gt)
                if st_gt["cycles_s"] is not None and st["cycles_s"] is not None:
                    st["cycles_s"] += st_gt["cycles_s"]
            if plan.lens is not None:
                z = channels[names["depth"]]
                channels[names["depth"]] = np.where(z >= 0.5 * contract.DEPTH_BACKGROUND, z, z * self._ray_z)
            write_exr(final, channels)
            os.remove(tmp)
            stats[view] = st
            cycles_s = None if (cycles_s is None or st["cycles_s"] is None) else cycles_s + st["cycles_s"]
        sensor.set_shutter(self.scene, 0.0, False, 0.0)
        return stats, cycles_s


def read_names(channels: dict) -> list[str]:
    """The beauty channels (Combined RGBA) named in the manifest."""
    rgb = channels.get("rgb") or []
    return list(rgb) if isinstance(rgb, list) else [rgb]
