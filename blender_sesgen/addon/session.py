"""What the operators do, as plain functions over a settings snapshot (bpy, no UI).

Everything goes through the code path of the command line: a
:class:`~blender_sesgen.render.plan.RenderPlan` (parse + validate, writes nothing), a
:class:`~blender_sesgen.blender.session.BlenderSession` (the builder makes the dedicated
scene 'SESGen') and, to render, :class:`~blender_sesgen.render.job.RenderJob` (``render_frame``:
one frame, atomically, then the manifest).
This module only adds what the UI needs around it: leaving the SESGen scene before the
builder replaces it, a curve showing the camera path, copying the settings onto the new
scene, and status/progress for the panel.
"""
from __future__ import annotations

import os
import time
from typing import Callable, Optional

import bpy
import numpy as np

from ..contract.frames import R_BLENDER_SES, camera_matrix_world
from ..errors import SesgenError
from ..render.job import RenderJob
from ..render.plan import RenderPlan
from . import props

SCENE_NAME = "SESGen"          # blender.datablocks.SCENE_NAME (not imported: keeps bpy modules lazy)
PATH_TAG = "sesgen_camera_path"
PATH_NAME = "SESGen camera path"
OBJECT_PATH_PREFIX = "SESGen path: "


# --- status shown in the panel ----------------------------------------------------------

def _settings_scenes(values: dict) -> list:
    names = {values.get("origin_scene") or "", SCENE_NAME}
    return [s for s in bpy.data.scenes if s.name in names and hasattr(s, "sesgen")]


def set_status(values: dict, text: str, progress: Optional[float] = None, context=None) -> None:
    """Show ``text`` (and progress 0..1) in the panel of the origin and SESGen scenes."""
    targets = _settings_scenes(values)
    if context is not None and getattr(context, "scene", None) is not None and context.scene not in targets:
        targets.append(context.scene)
    for s in targets:
        s.sesgen.status = text
        if progress is not None:
            s.sesgen.progress = progress
    _redraw()


def _redraw() -> None:
    wm = bpy.context.window_manager
    for win in getattr(wm, "windows", ()):
        for area in win.screen.areas:
            if area.type in {"VIEW_3D", "IMAGE_EDITOR"}:
                area.tag_redraw()


# --- build ------------------------------------------------------------------------------

def read_settings(context) -> dict:
    """Snapshot of ``context.scene.sesgen`` with its origin scene filled in."""
    values = props.snapshot(context.scene.sesgen)
    if context.scene.name != SCENE_NAME:
        values["origin_scene"] = context.scene.name
    return values


def script_path(values: dict) -> str:
    path = props.abspath(values["script_path"])
    if not path:
        raise SesgenError("choose an SES script first")
    return path


def plan(values: dict) -> RenderPlan:
    """The script with the panel's options and its World and Camera overrides
    (``state.script_with_world``, ``state.script_with_profile``)."""
    world, camera = values.get("world", "script"), values.get("camera_profile", "script")
    edit = None
    if world != "script" or camera != "script":
        from .state import script_with_profile, script_with_world

        def edit(text: str) -> str:
            if world != "script":
                text = script_with_world(text, world, values["world_strength"], values["world_rotation"])
            return text if camera == "script" else script_with_profile(text, camera)
    return RenderPlan.from_file(script_path(values), props.render_options(values), edit=edit)


def prepare_render_job(values: dict) -> RenderJob:
    out = props.abspath(values["output_dir"])
    if not out:
        raise SesgenError("choose an output folder first")
    return RenderJob.of(plan(values), out, resume=values["resume"], force=values["overwrite"])


def _fallback_scene(values: dict):
    origin = bpy.data.scenes.get(values.get("origin_scene") or "")
    if origin is not None and origin.name != SCENE_NAME:
        return origin
    for s in bpy.data.scenes:
        if s.name != SCENE_NAME:
            return s
    return bpy.data.scenes.new("Scene")


def _remove_camera_path() -> None:
    for o in [o for o in bpy.data.objects if o.get(PATH_TAG)]:
        bpy.data.objects.remove(o)
    for c in [c for c in bpy.data.curves if c.get(PATH_TAG)]:
        bpy.data.curves.remove(c)


def add_camera_path(built, scene) -> object:
    """A poly curve through the left camera's positions (not rendered)."""
    P = np.array([camera_matrix_world(T)[:3, 3] for T in scene.timeline.left()], dtype=float)
    return _path_curve(built, PATH_NAME, P)


def add_object_paths(built, scene) -> list:
    """One poly curve per moving object through its origin's positions, frame by frame."""
    names = {o.id: o.name for o in scene.objects}
    return [_path_curve(built, f"{OBJECT_PATH_PREFIX}{names.get(m.id, m.id)}",
                        m.poses()[:, :3, 3] @ R_BLENDER_SES.T) for m in scene.object_motions]


def _path_curve(built, name: str, P: np.ndarray) -> object:
    """A poly curve (not rendered) through the Blender-world points ``P`` (N, 3)."""
    cu = bpy.data.curves.new(name, "CURVE")
    cu[PATH_TAG] = 1
    cu.dimensions = "3D"
    spline = cu.splines.new("POLY")
    spline.points.add(len(P) - 1)
    co = np.concatenate([P, np.ones((len(P), 1))], axis=1).astype(np.float32)
    spline.points.foreach_set("co", co.ravel())
    ob = bpy.data.objects.new(name, cu)
    ob[PATH_TAG] = 1
    ob["sesgen"] = 1          # the builder's tag: its next clear removes this object too
    ob.hide_render = True
    built.collection.objects.link(ob)
    return ob


def _tag_camera_actions(built) -> None:
    """Tag the cameras' keyframe actions with the builder's tag so that the next build
    removes them too (else every rebuild leaves two orphan actions behind)."""
    for cam in built.cameras.values():
        ad = cam.animation_data
        if ad is not None and ad.action is not None:
            ad.action["sesgen"] = 1


def build(context, values: dict, make_session: Callable, scene):
    """``make_session()`` (it builds the scene) plus the camera path of ``scene``; the windows
    showing SESGen keep showing it. Returns the session."""
    wm = context.window_manager
    windows = list(getattr(wm, "windows", ()))
    showing = [w for w in windows if w.scene.name == SCENE_NAME]
    if getattr(context, "window", None) is not None and context.window not in showing:
        showing.append(context.window)
    if showing:
        fallback = _fallback_scene(values)
        for w in showing:
            w.scene = fallback
    _remove_camera_path()
    session = make_session()
    built = session.built
    _tag_camera_actions(built)
    add_camera_path(built, scene)
    add_object_paths(built, scene)
    values = dict(values)
    props.restore(built.scene.sesgen, values)
    for w in showing:
        w.scene = built.scene
    return session


def build_scene(context, values: dict) -> str:
    """The Build Scene button (no output folder involved): returns a one-line report."""
    from ..blender.session import BlenderSession
    the_plan = plan(values)
    built = build(context, values, lambda: BlenderSession(the_plan, meter=False), the_plan.scene).built
    n = sum(len(v) for v in built.objects.values())
    msg = (f"built {n} objects, {len(built.cameras)} camera(s) keyed over {the_plan.scene.frames} frames "
           f"in scene '{built.scene.name}'")
    set_status(values, msg)
    return msg


# --- render -----------------------------------------------------------------------------

class RenderSession:
    """One render through the pipeline, a frame at a time (the modal operator steps it
    on a timer; the headless path steps it in a loop). Every completed frame is on disk
    and marked in the manifest, so stopping between steps leaves a resumable folder."""

    active: Optional["RenderSession"] = None  # at most one render at a time

    def __init__(self, values: dict, job: RenderJob):
        self.values = values
        self.job = job
        self.todo: list[int] = []
        self.done = 0
        self.t0 = time.perf_counter()
        self.cancelled = False

    @classmethod
    def start(cls, context, values: dict) -> "RenderSession":
        """Prepare (SesgenError: nothing created), build, write the folder's skeleton."""
        if cls.active is not None:
            raise SesgenError("a render is already running")
        job = prepare_render_job(values)
        s = cls(values, job)

        def make_session():
            job.build()
            return job.session
        try:
            build(context, values, make_session, job.scene)
            job.begin()
        except BaseException:
            job.close()                      # the folder's lock
            raise
        s.todo = job.pending_frames()
        cls.active = s
        set_status(values, s.describe(), 0.0)
        return s

    @property
    def total(self) -> int:
        return len(self.todo)

    @property
    def finished(self) -> bool:
        return self.cancelled or self.done >= self.total

    def describe(self) -> str:
        st = self.job.settings
        if self.total == 0:
            return f"nothing to render: frames {self.job.frames[0]}..{self.job.frames[-1]} are complete"
        if self.done == 0:
            return f"rendering {self.total} frame(s), {st.width}x{st.height}, quality {st.quality}, {st.samples} samples"
        el = time.perf_counter() - self.t0
        eta = el / self.done * (self.total - self.done)
        return f"frame {self.todo[self.done - 1]}: {self.done}/{self.total} done, ETA {eta:.0f} s"

    def step(self) -> None:
        """Render the next pending frame (all its views) through ``RenderJob.render_frame``."""
        if self.finished:
            return
        k = self.todo[self.done]
        self.job.render_frame(k)
        self.done += 1
        set_status(self.values, self.describe(), self.done / max(self.total, 1))

    def cancel(self) -> str:
        self.cancelled = True
        msg = (f"cancelled after {self.done} of {self.total} frame(s); {self.job.out_dir} is consistent: "
               "Render again with Resume to continue")
        self.close(msg)
        return msg

    def close(self, msg: Optional[str] = None) -> str:
        """End the render (done, cancelled or failed): the folder's lock released, its
        completion log taken into the manifest."""
        self.job.close()
        if RenderSession.active is self:
            RenderSession.active = None
        if msg is None:
            msg = (f"rendered {self.done} frame(s) into {self.job.out_dir} in {time.perf_counter() - self.t0:.1f} s"
                   if self.total else self.describe())
        set_status(self.values, msg, self.done / self.total if self.total else 1.0)
        return msg

    def fail(self, e: BaseException) -> str:
        msg = f"render failed at frame {self.todo[self.done] if self.done < self.total else '?'}: {e}"
        self.cancelled = True
        return self.close(msg)


def render_all(context, values: dict) -> str:
    """The headless path: every pending frame, synchronously."""
    s = RenderSession.start(context, values)
    try:
        while not s.finished:
            s.step()
    except Exception as e:  # noqa: BLE001 - reported; the folder stays consistent
        raise SesgenError(s.fail(e)) from e
    return s.close()


# --- preview ----------------------------------------------------------------------------

PREVIEW_IMAGE = "SESGen preview"


def verify(values: dict) -> str:
    """Check every file of the output folder against its manifest (as ``python -m
    blender_sesgen verify``); bad frames are recorded as not rendered, so that Render with
    Resume renders them again. One line to report."""
    from ..contract.manifest import MANIFEST
    from ..render.folder import OutputFolder
    out = props.abspath(values["output_dir"])
    if not out or not os.path.isfile(os.path.join(out, MANIFEST)):
        raise SesgenError("no render in the output folder to verify")
    folder = OutputFolder(out)
    bad = folder.verify(full=True)
    frames = sorted({k for k, _ in bad if k is not None})
    if not bad:
        msg = "verified: the manifest, its files and every frame recorded complete are intact"
    elif not frames:
        msg = f"{bad[0][1]}; Render with Resume writes it again"
    else:
        folder.mark_incomplete(frames)
        named = ", ".join(map(str, frames[:8])) + (" ..." if len(frames) > 8 else "")
        first = next(why for k, why in bad if k is not None)
        msg = f"{len(frames)} bad frame(s) ({named}: {first}); Render with Resume renders them again"
    set_status(values, msg)
    return msg


def preview(context, values: dict):
    """Make the image data-block 'SESGen preview' for the chosen frame/view/kind."""
    from .preview import preview_rgba
    out = props.abspath(values["output_dir"])
    if not out or not os.path.isdir(out):
        raise SesgenError("no output folder to preview: render first")
    rgba, text = preview_rgba(out, values["preview_frame"], values["preview_view"], values["preview_kind"])
    H, W = rgba.shape[:2]
    img = bpy.data.images.get(PREVIEW_IMAGE)
    if img is not None and tuple(img.size) != (W, H):
        bpy.data.images.remove(img)
        img = None
    if img is None:
        img = bpy.data.images.new(PREVIEW_IMAGE, W, H, alpha=True)
    img.pixels.foreach_set(np.ascontiguousarray(np.flipud(rgba), dtype=np.float32).ravel())
    img.update()
    img["sesgen_preview"] = text
    show_image(context, img)
    return img, text


def show_image(context, img) -> None:
    """Show ``img`` in an image editor: an open one, else a new window (UI sessions only)."""
    wm = context.window_manager
    for win in getattr(wm, "windows", ()):
        for area in win.screen.areas:
            if area.type == "IMAGE_EDITOR":
                area.spaces.active.image = img
                area.tag_redraw()
                return
    if bpy.app.background or getattr(context, "window", None) is None:
        return  # headless: the image data-block is the result
    before = set(wm.windows[:])
    try:
        bpy.ops.wm.window_new()
    except RuntimeError:  # no window to copy from: the image data-block is still there
        return
    new = [w for w in wm.windows if w not in before]
    if not new:
        return
    area = max(new[0].screen.areas, key=lambda a: a.width * a.height)
    area.type = "IMAGE_EDITOR"
    area.spaces.active.image = img


# --- export (vo_reference as a child process) ----------------------------------------------

def start_export(values: dict):
    """Start ``vo-reference export`` on the output folder (export_job.ExportProcess)."""
    from . import export_job
    render_dir = props.abspath(values["output_dir"])
    if render_dir and not os.path.isfile(os.path.join(render_dir, "manifest.json")):
        raise SesgenError(f"{render_dir}: no render here yet (render first, or choose the render's output folder)")
    frames = f"{values['frame_first']}:{values['frame_stop']}" if values["use_frame_range"] else ""
    cmd = export_job.export_command(export_job.vo_command(values["vo_command"]), render_dir,
                                    props.abspath(values["export_dir"]), values["export_target"],
                                    values["export_sequence"], frames, values.get("export_undistort", False))
    return export_job.ExportProcess(cmd)


def finish_export(values: dict, proc, context=None) -> str:
    """The status line of a finished export; ExportError with the tool's message if it failed."""
    from . import export_job
    proc.poll()
    if proc.returncode != 0:
        raise export_job.ExportError(proc.error)
    msg = proc.summary or f"exported to {values['export_target']}"
    set_status(values, msg, 1.0, context=context)
    return msg


# --- a one-factor study (study_job: ``sesgen study run`` as a child process) -----------------------

def start_study(values: dict):
    """Write the panel's study file into the study folder and start ``study run`` on it."""
    from . import study_job
    script = script_path(values)
    out = props.abspath(values["study_dir"])
    if not out:
        raise SesgenError("choose a study folder first")
    factor = values["study_factor"]
    systems = [w.strip() for w in values["study_systems"].replace(",", " ").split() if w.strip()]
    if not systems:
        raise SesgenError("name at least one system (e.g. accurate-stereo)")
    text = study_job.study_toml(script, factor, study_job.parse_levels(factor, values["study_levels"]), systems,
                                frames=values["study_frames"], resolution=values["study_resolution"],
                                quality="draft" if values["quality"] == "script" else values["quality"])
    path = study_job.write_study(out, text)
    return study_job.StudyProcess(study_job.study_command(values["study_command"]), path, out)


def finish_study(values: dict, proc, context=None) -> str:
    """The status line of a finished study; StudyJobError with its message if it failed."""
    from . import study_job
    proc.poll()
    if proc.returncode not in (0, 1) or proc.report is None:
        raise study_job.StudyJobError(proc.error)
    msg = (proc.summary or "study done") + ("" if proc.returncode == 0 else " (a step failed: see the report)")
    set_status(values, msg, 1.0, context=context)
    return msg


def study_report(values: dict) -> str:
    """The study's report.html (to open in a browser)."""
    path = os.path.join(props.abspath(values["study_dir"]), "report.html")
    if not os.path.isfile(path):
        raise SesgenError(f"{path}: no report yet (run the study first)")
    return path
