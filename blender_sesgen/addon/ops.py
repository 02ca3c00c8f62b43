"""Operators: gather the settings, call ``session`` (hence the pipeline), report.

Expected failures (:class:`SesgenError`, e.g. a script error ``file:line:col: error: ...``)
are reported as errors and shown in the panel's status line; they create nothing.
"""
from __future__ import annotations

import os

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ImportHelper

from ..errors import SesgenError
from . import props, session, state


def _fail(op, context, values, e: Exception):
    text = str(e)
    op.report({"ERROR"}, text)
    shown = state.error_line(e)
    session.set_status(values, f"Error: {shown}", context=context)
    return {"CANCELLED"}


def _run(op, context, action) -> set:
    """``action(values) -> message`` on a settings snapshot; the message is reported, a
    SesgenError reported as an error and shown in the panel."""
    values = session.read_settings(context)
    try:
        msg = action(values)
    except SesgenError as e:
        return _fail(op, context, values, e)
    op.report({"INFO"}, msg)
    return {"FINISHED"}


def _check(context, values) -> str:
    path = session.script_path(values)
    state.forget(path)
    msg = "Script OK: " + "; ".join(state.summary_lines(state.parse_script(path))[:2])
    session.set_status(values, msg, context=context)
    return msg


class _WhenIdle:
    """Operators that change the scene or the output folder: not while a render runs."""

    @classmethod
    def poll(cls, context):
        return session.RenderSession.active is None and context.scene is not None


class SESGEN_OT_check(bpy.types.Operator):
    """Parse the script again and report its summary or its errors"""
    bl_idname = "sesgen.check"
    bl_label = "Check Script"

    def execute(self, context):
        return _run(self, context, lambda values: _check(context, values))


class SESGEN_OT_build(_WhenIdle, bpy.types.Operator):
    """Build the script's scene (objects, stereo rig with keyframes, camera path) in the scene 'SESGen'; rebuilding replaces it"""
    bl_idname = "sesgen.build"
    bl_label = "Build Scene"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        return _run(self, context, lambda values: session.build_scene(context, values))


class SESGEN_OT_render(_WhenIdle, bpy.types.Operator):
    """Render the sequence into the output folder (ESC cancels; the folder stays resumable)"""
    bl_idname = "sesgen.render"
    bl_label = "Render Sequence"

    _timer = None
    _session = None

    def execute(self, context):  # headless: every frame, synchronously
        return _run(self, context, lambda values: session.render_all(context, values))

    def invoke(self, context, event):  # interactive: one frame per timer tick
        values = session.read_settings(context)
        try:
            self._session = session.RenderSession.start(context, values)
        except SesgenError as e:
            return _fail(self, context, values, e)
        if self._session.finished:
            self.report({"INFO"}, self._session.close())
            return {"FINISHED"}
        wm = context.window_manager
        wm.progress_begin(0, self._session.total)
        self._status(context)
        self._timer = wm.event_timer_add(0.01, window=context.window)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _status(self, context, text=None):
        ws = getattr(context, "workspace", None)
        if ws is not None:
            ws.status_text_set(text if text is not None else
                               f"SESGen: {self._session.describe()}   (Esc: cancel, resumable)")

    def _end(self, context, msg, level="INFO"):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        self._status(context, None)
        self.report({level}, msg)

    def modal(self, context, event):
        s = self._session
        if event.type == "ESC" and event.value == "PRESS":
            self._end(context, s.cancel(), "WARNING")
            return {"CANCELLED"}
        if event.type != "TIMER" or event.timer is not self._timer:
            return {"PASS_THROUGH"}
        try:
            s.step()
        except Exception as e:  # noqa: BLE001 - reported; completed frames stay on disk
            self._end(context, s.fail(e), "ERROR")
            return {"CANCELLED"}
        context.window_manager.progress_update(s.done)
        self._status(context)
        if s.finished:
            self._end(context, s.close())
            return {"FINISHED"}
        return {"RUNNING_MODAL"}

    def cancel(self, context):  # Blender stops the operator (e.g. the file is closed)
        if self._session is not None and not self._session.finished:
            self._end(context, self._session.cancel(), "WARNING")


class SESGEN_OT_open_output(bpy.types.Operator):
    """Open the output folder in the system's file browser"""
    bl_idname = "sesgen.open_output"
    bl_label = "Open Output Folder"

    @classmethod
    def poll(cls, context):
        return os.path.isdir(props.abspath(context.scene.sesgen.output_dir))

    def execute(self, context):
        return bpy.ops.wm.path_open(filepath=props.abspath(context.scene.sesgen.output_dir))


class SESGEN_OT_verify(_WhenIdle, bpy.types.Operator):
    """Check every file of the output folder against its manifest (missing, truncated, changed, undecodable); bad frames are rendered again by Render with Resume"""
    bl_idname = "sesgen.verify"
    bl_label = "Verify Output"

    def execute(self, context):
        return _run(self, context, session.verify)


class SESGEN_OT_preview(bpy.types.Operator):
    """Show one rendered frame's ground truth (disparity, segmentation, depth) or RGB in an image editor"""
    bl_idname = "sesgen.preview"
    bl_label = "Preview Ground Truth"

    def execute(self, context):
        return _run(self, context, lambda values: f"preview: {session.preview(context, values)[1]} "
                                                  f"(image '{session.PREVIEW_IMAGE}')")


class _ChildProcess(_WhenIdle):
    """An operator that runs a tool as a child process (``start(values)``: its process, with
    ``poll``, ``finished``, ``fraction``, ``cancel``, ``wait``; ``finish(values, proc,
    context)``: its message or SesgenError; ``running(values, proc)``: the status line)."""

    _timer = None
    _proc = None
    interval_s = 0.1
    stopped = "stopped"

    def execute(self, context):  # headless: runs to the end
        values = session.read_settings(context)
        try:
            proc = self.start(values)
            proc.wait()
            msg = self.finish(values, proc, context)
        except SesgenError as e:
            return _fail(self, context, values, e)
        self.report({"INFO"}, msg)
        return {"FINISHED"}

    def invoke(self, context, event):  # interactive: the progress bar follows the tool's JSON events
        values = session.read_settings(context)
        try:
            self._proc = self.start(values)
        except SesgenError as e:
            return _fail(self, context, values, e)
        self._values = values
        wm = context.window_manager
        self._timer = wm.event_timer_add(self.interval_s, window=context.window)
        wm.modal_handler_add(self)
        session.set_status(values, self.running(values, self._proc), 0.0, context=context)
        return {"RUNNING_MODAL"}

    def _stop_timer(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None

    def modal(self, context, event):
        p, values = self._proc, self._values
        if event.type == "ESC" and event.value == "PRESS":
            p.cancel()
            self._stop_timer(context)
            session.set_status(values, self.stopped, context=context)
            self.report({"WARNING"}, self.stopped)
            return {"CANCELLED"}
        if event.type != "TIMER" or event.timer is not self._timer:
            return {"PASS_THROUGH"}
        p.poll()
        if not p.finished:
            session.set_status(values, self.running(values, p) + " (Esc to stop)", p.fraction, context=context)
            return {"RUNNING_MODAL"}
        self._stop_timer(context)
        try:
            msg = self.finish(values, p, context)
        except SesgenError as e:
            return _fail(self, context, values, e)
        self.report({"INFO"}, msg)
        return {"FINISHED"}

    def cancel(self, context):
        if self._proc is not None and not self._proc.finished:
            self._proc.cancel()
        self._stop_timer(context)


class SESGEN_OT_export(_ChildProcess, bpy.types.Operator):
    """Export the rendered frames of the output folder to a dataset layout (runs vo_reference; Esc cancels)"""
    bl_idname = "sesgen.export"
    bl_label = "Export Dataset"
    stopped = "export cancelled (nothing half-written is left)"
    start, finish = staticmethod(session.start_export), staticmethod(session.finish_export)
    running = staticmethod(lambda values, proc: f"exporting to {values['export_target']}: {proc.done}/{proc.total}"
                           if proc.total else f"exporting to {values['export_target']}...")


class SESGEN_OT_study_run(_ChildProcess, bpy.types.Operator):
    """Run a one-factor study of the script: render every level, run the systems, evaluate, report (sesgen study run; Esc stops it, running it again resumes)"""
    bl_idname = "sesgen.study_run"
    bl_label = "Run Study"
    interval_s = 0.5
    stopped = "study stopped (Run Study again resumes it)"
    start, finish = staticmethod(session.start_study), staticmethod(session.finish_study)
    running = staticmethod(lambda values, proc: proc.line)


class SESGEN_OT_study_report(bpy.types.Operator):
    """Open the study's report (report.html) in the web browser"""
    bl_idname = "sesgen.study_report"
    bl_label = "Open Report"

    @classmethod
    def poll(cls, context):
        return os.path.isfile(os.path.join(props.abspath(context.scene.sesgen.study_dir), "report.html"))

    def execute(self, context):
        values = session.read_settings(context)
        try:
            path = session.study_report(values)
        except SesgenError as e:
            return _fail(self, context, values, e)
        bpy.ops.wm.url_open(url="file://" + path)
        return {"FINISHED"}


class SESGEN_OT_import(_WhenIdle, bpy.types.Operator, ImportHelper):
    """Import an SES scene script: set it in the SESGen panel and build its scene"""
    bl_idname = "sesgen.import_ses"
    bl_label = "Import SES Script"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".ses"
    filter_glob: StringProperty(default="*.ses", options={"HIDDEN"})

    def execute(self, context):
        context.scene.sesgen.script_path = self.filepath
        return _run(self, context, lambda values: session.build_scene(context, values))


def menu_import(self, context):
    self.layout.operator(SESGEN_OT_import.bl_idname, text="SES Script (.ses)")


CLASSES = (SESGEN_OT_check, SESGEN_OT_build, SESGEN_OT_render, SESGEN_OT_open_output,
           SESGEN_OT_preview, SESGEN_OT_export, SESGEN_OT_import, SESGEN_OT_verify, SESGEN_OT_study_run,
           SESGEN_OT_study_report)
