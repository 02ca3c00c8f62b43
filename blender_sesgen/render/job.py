"""A render job: a plan, rendered by a Blender session into an output folder.

    job = RenderJob.prepare("scene.ses", "out/", RenderOptions(samples=16), resume=True)
    job.build()                      # the Blender scene (bpy)
    for k in job.pending_frames():   # the add-on: one frame per timer tick
        job.render_frame(k)          # all views of frame k, atomically, then the manifest

``prepare`` parses and validates everything (:class:`~blender_sesgen.render.plan.RenderPlan`) and
checks the output folder (:class:`~blender_sesgen.render.folder.OutputFolder`), and writes nothing:
a bad script, bad options or a folder holding another scene's output raise
:class:`SesgenError` before any file exists. ``begin()`` (called by ``render_frame`` if
needed) writes the folder's skeleton; each EXR is written under a temporary name and
renamed, then the frame is marked complete. The Cycles seed of each frame and view depends
only on the seed, the frame and the view, so ``--resume`` completes an interrupted folder
with results identical to an uninterrupted run.
"""
from __future__ import annotations

import importlib.util
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from ..contract.atomic import temp_path
from ..contract.manifest import Manifest
from .folder import OutputFolder, display_key, seal_frame
from .sealer import Sealer, WorkerGone, run_here
from .plan import RenderOptions, RenderPlan


@dataclass
class FrameResult:
    frame: int
    wall_s: float
    cycles_s: Optional[float]
    views: dict = field(default_factory=dict)


class RenderJob:
    """One render of one plan into one output folder (see the module docstring)."""

    def __init__(self, plan: RenderPlan, folder: OutputFolder, *, resume: bool = False, force: bool = False):
        self.plan = plan
        self.folder = folder
        self.resume = resume
        self.force = force
        self.session = None                        # blender.session.BlenderSession after build()
        self.timings: list[FrameResult] = []
        self._other_sums: dict[int, dict] = {}     # frame -> SHA-256 of its sensor images

    @classmethod
    def prepare(cls, scene_path, out_dir, options: RenderOptions = RenderOptions(), *,
                resume: bool = False, force: bool = False) -> "RenderJob":
        """Parse and validate ``scene_path`` and check ``out_dir``. Writes nothing."""
        return cls.of(RenderPlan.from_file(scene_path, options), out_dir, resume=resume, force=force)

    @classmethod
    def from_scene(cls, scene, out_dir, options: RenderOptions = RenderOptions(), *,
                   scene_text: Optional[str] = None, resume: bool = False, force: bool = False) -> "RenderJob":
        """Like :meth:`prepare` for a Scene built in Python (``scene_text`` = its script, if any)."""
        plan = RenderPlan.from_scene(scene, options, scene_text=scene_text)
        return cls.of(plan, out_dir, resume=resume, force=force)

    @classmethod
    def of(cls, plan: RenderPlan, out_dir, *, resume: bool = False, force: bool = False) -> "RenderJob":
        folder = OutputFolder(out_dir)
        folder.check(plan, force)
        if plan.options.reuse_exr:
            from .reuse import check_reusable
            check_reusable(plan, plan.options.reuse_exr)
        return cls(plan, folder, resume=resume, force=force)

    # --- what the job is ----------------------------------------------------------------
    @property
    def scene(self):
        return self.plan.scene

    @property
    def settings(self):
        return self.plan.settings

    @property
    def frames(self) -> list[int]:
        return list(self.plan.frames)

    @property
    def out_dir(self) -> Path:
        return self.folder.root

    @property
    def built(self):
        return None if self.session is None else self.session.built

    @property
    def exposure(self) -> Optional[float]:
        return None if self.session is None else self.session.exposure

    @property
    def manifest(self) -> Optional[Manifest]:
        return self.folder.manifest

    def session_needs_no_bpy(self) -> bool:
        """A render that reuses another's EXRs needs Blender only to write JPEGs."""
        sensor = self.plan.scene.sensor
        return bool(self.plan.options.reuse_exr) and not (sensor is not None and sensor.jpeg_quality)

    def pending_frames(self) -> list[int]:
        """Requested frames not complete yet (all requested ones unless resuming)."""
        return self.folder.pending(self.plan, self.resume)

    # --- doing it -----------------------------------------------------------------------
    def build(self, stop: Callable[[], bool] = lambda: False) -> None:
        """Build the scene in Blender (a dedicated scene 'SESGen'; rebuilding replaces).
        Writes nothing into the output folder. ``stop()`` asked between the build's steps and
        the metering pass's frames (KeyboardInterrupt)."""
        if self.plan.options.reuse_exr:   # another render's EXRs: no Blender (blender_sesgen.render.reuse)
            from .reuse import ReusedSession
            self.session = ReusedSession(self.plan, self.plan.options.reuse_exr)
            return
        from ..blender.session import BlenderSession
        from .sensor.outputs import stored_metering
        kept = self.folder.resumable(self.plan)
        self.session = BlenderSession(self.plan, known_exposure=(kept or {}).get("render", {}).get("exposure"),
                                      fast=self.plan.options.fast_pipeline,
                                      known_metering=stored_metering(
                                          self.plan.sensor, kept,
                                          self.plan.sensor.metered_frames(self.plan.frames, self.plan.scene.frames)),
                                      stop=stop)

    def new_manifest(self) -> Manifest:
        """This job's manifest with no frame complete (needs the built session)."""
        m = self.plan.manifest(channels=self.session.channels, render_extra=self.session.manifest_extra(),
                               blender_version=self.session.blender_version)
        m.objects = m.objects + self.session.imported_objects   # BLEND files: ids given when loaded
        from .sensor.outputs import prepare_manifest
        prepare_manifest(self.plan.sensor, m, self.folder.resumable(self.plan), self.out_dir,
                         metering=self.session.metering)
        return m

    def begin(self) -> None:
        """Lock the folder and write its skeleton (the manifest first, scene.ses, poses/); once."""
        if self.folder.manifest is None:
            if self.session is None:
                self.build()
            self.folder.begin(self.plan, self.new_manifest(), self.resume, self.force,
                              static_files=self.plan.sensor.static_files(self.plan.scene.frames)
                              if self.plan.sensor.active else None)
            from .sensor.outputs import make_folders
            make_folders(self.plan.sensor, self.out_dir)

    def render_frame(self, k: int, stop: Callable[[], bool] = lambda: False) -> FrameResult:
        """Render every view of frame ``k`` into temporary files, check them, move them into
        place, record the frame complete. ``stop()`` is asked between views: when it says
        yes the frame is dropped and KeyboardInterrupt raised (the folder stays resumable)."""
        res, temps = self._render(k, stop)
        self._commit(k, temps, run_here(seal_frame, k, temps, self._required_channels()))
        return res

    def _render(self, k: int, stop: Callable[[], bool]) -> tuple[FrameResult, dict]:
        """Frame ``k``'s views rendered into temporary files (removed if it fails)."""
        if self.session is None:
            self.build()
        self.begin()
        temps = {v: temp_path(self.folder.exr_path(v, k)) for v in self.plan.views}
        shown = {v: temp_path(self.folder.display_path(v, k)) for v in self.plan.views} \
            if self.plan.writes_display else None
        t0 = time.perf_counter()
        from .sensor import outputs as sensor_outputs
        exposure_s, gain = sensor_outputs.exposure_for(self.plan.sensor, self.manifest.extra, k)
        ref = self.plan.sensor.still_reference(k)   # a still stretch's beauty is its first frame's
        ref_exposure_s = (sensor_outputs.exposure_for(self.plan.sensor, self.manifest.extra, ref)[0]
                          if ref != k else None)
        try:
            stats = self.session.render_frame(k, temps, stop, exposure_s=exposure_s, display_paths=shown,
                                              still_exposure_s=ref_exposure_s)
            for v, tmp in temps.items():
                if not tmp.is_file() or (shown and not shown[v].is_file()):
                    raise RuntimeError(f"Blender wrote no file for frame {k}, view {v}")
            if self.plan.sensor.writes_sensor_images:   # from the checked-in-a-moment EXRs
                self._other_sums[k] = sensor_outputs.write_sensor_images(
                    self.plan.sensor, self.manifest, self.out_dir, k, exposure_s, gain, temps,
                    jpeg_writer=self.session.jpeg_writer)
        except BaseException:
            for tmp in [*temps.values(), *(shown or {}).values()]:
                tmp.unlink(missing_ok=True)
            raise
        cyc = [st["cycles_s"] for st in stats.values()]
        res = FrameResult(frame=k, wall_s=time.perf_counter() - t0,
                          cycles_s=None if any(c is None for c in cyc) else sum(cyc), views=stats)
        self.timings.append(res)
        # the display PNGs ride with the EXRs through sealing and commit (output.display_key)
        return res, {**temps, **{display_key(v): p for v, p in (shown or {}).items()}}

    def _commit(self, k: int, temps: dict, sealed) -> None:
        """Wait for frame ``k``'s sealing (a Future of ``output.seal_frame``), then move its
        files into place and record it complete; its temporary files never outlive this."""
        try:
            try:
                sums = sealed.result()
            except WorkerGone:  # the worker died: seal here
                sums = seal_frame(k, temps, self._required_channels())
            self.folder.commit_sealed(k, temps, {**sums, **self._other_sums.pop(k, {})})
        finally:
            for tmp in temps.values():
                tmp.unlink(missing_ok=True)

    def _required_channels(self) -> tuple[str, ...]:
        names = []
        for v in self.folder.manifest.channels.values():
            names += [v] if isinstance(v, str) else list(v)
        return tuple(names)

    def run(self, progress: Optional[Callable[[int, int, FrameResult, float], None]] = None,
            stop: Callable[[], bool] = lambda: False) -> list[FrameResult]:
        """Render every pending frame; ``progress(i, n, result, elapsed_s)`` after each;
        ``stop()`` asked between views (KeyboardInterrupt, the folder resumable). Frame k is
        sealed (read back, checked, wall-clock header fields stripped, hashed) in a worker
        process while frame k+1 renders (``sealer``); every rendered frame is committed, the
        lock released and the completion log taken into the manifest, however it ends."""
        out = []
        try:
            self.begin()   # then the frames: the folder may have changed since prepare (verify marked
            todo = self.pending_frames()   # frames bad, another chunk completed some)
            t0 = time.perf_counter()
            pending = None
            with Sealer(enabled=len(todo) > 2) as sealer:
                try:
                    for i, k in enumerate(todo):
                        if stop():
                            raise KeyboardInterrupt
                        r, temps = self._render(k, stop)
                        sealed = sealer.submit(k, temps, self._required_channels())
                        if pending is not None:
                            self._commit(*pending)
                        pending = (k, temps, sealed)
                        out.append(r)
                        if progress:
                            progress(i + 1, len(todo), r, time.perf_counter() - t0)
                finally:
                    if pending is not None:  # the last frame, or the one before an interruption
                        self._commit(*pending)
        finally:
            self.close()
        return out

    def close(self) -> None:
        """Release the folder: the completion log into the manifest, the lock dropped."""
        self.folder.release()


# --- used by the command line and the Python API -------------------------------------------

def frame_progress(bar) -> Callable:
    """Adapter from the pipeline's per-frame hook ``(i, n, FrameResult, elapsed_s)`` to a
    :class:`~blender_sesgen.contract.progress.Progress` (fields ``frame``, ``wall_s``, ``cycles_s``)."""
    def hook(i, n, r, elapsed_s):
        cyc = f", cycles {r.cycles_s:.2f} s" if r.cycles_s is not None else ""
        bar.update(detail=f"frame {r.frame} {r.wall_s:.2f} s{cyc}", frame=r.frame, wall_s=r.wall_s,
                   cycles_s=r.cycles_s)
    return hook


def have_bpy() -> bool:
    """True when Blender's Python module can be imported here."""
    try:
        return importlib.util.find_spec("bpy") is not None
    except ImportError:
        return False
