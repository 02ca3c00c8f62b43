"""The 3D-view sidebar tab "SESGen": script, build, render, preview, export, study."""
from __future__ import annotations

import bpy

from . import props, session, state


def _toggled(layout, settings, heading: str, toggle: str, text: str, names) -> None:
    """A column: a checkbox, then the properties it switches on (greyed out while off)."""
    col = layout.column(heading=heading)
    col.prop(settings, toggle, text=text)
    sub = col.column(align=True)
    sub.active = getattr(settings, toggle)
    for name in names:
        sub.prop(settings, name)


class _SidebarPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "SESGen"


class _SettingsSubpanel(_SidebarPanel):
    """A closed sub-panel of the main one (its ``draw`` from :func:`_settings_draw`)."""
    bl_parent_id = "SESGEN_PT_main"
    bl_options = {"DEFAULT_CLOSED"}


def _settings_draw(names: tuple, operator: str, icon: str, note: str = "", more: tuple = ()):
    """A panel's draw: its settings, an optional note, the button of its operator (and the
    buttons of ``more``: (operator, icon) pairs, on the same row)."""
    def draw(self, context):
        s = context.scene.sesgen
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        for name in names:
            layout.prop(s, name)
        if note:
            layout.label(text=note)
        row = layout.row(align=True)
        for op, ic in ((operator, icon), *more):
            row.operator(op, icon=ic)
    return draw


class SESGEN_PT_main(_SidebarPanel, bpy.types.Panel):
    bl_label = "SES Scene"

    def draw(self, context):
        s = context.scene.sesgen
        layout = self.layout
        row = layout.row(align=True)
        row.prop(s, "script_path", text="")
        row.operator("sesgen.check", text="", icon="FILE_REFRESH")
        info = state.script_info(props.abspath(s.script_path))
        box = layout.box()
        if info.state == "none":
            box.label(text="Choose an .ses script", icon="INFO")
        elif info.state in ("missing", "error"):
            box.alert = True
            box.label(text=info.message, icon="ERROR")
            for line, col, msg in info.errors[1:4]:
                box.label(text=f"line {line}:{col}: {msg}")
            if len(info.errors) > 4:
                box.label(text=f"... and {len(info.errors) - 4} more errors")
        else:
            box.label(text="Script OK", icon="CHECKMARK")
            col = box.column(align=True)
            for line in info.summary:
                col.label(text=line)
        layout.operator("sesgen.build", icon="SCENE_DATA")
        if s.status:  # the last build/render/preview result or error
            box = layout.box()
            box.alert = s.status.startswith("Error")
            box.label(text=s.status, icon="ERROR" if box.alert else "INFO")


class SESGEN_PT_render(_SidebarPanel, bpy.types.Panel):
    bl_label = "Render"
    bl_parent_id = "SESGEN_PT_main"

    def draw(self, context):
        s = context.scene.sesgen
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        _toggled(layout, s, "Frames", "use_frame_range", "Range", ("frame_first", "frame_stop"))
        layout.prop(s, "quality")
        layout.prop(s, "camera_profile")
        layout.prop(s, "world")
        if s.world != "script":
            layout.prop(s, "world_strength")
            layout.prop(s, "world_rotation")
        _toggled(layout, s, "Sampling", "override_render", "Override Script", ("samples", "denoise", "seed"))
        _toggled(layout, s, "Timing", "override_timing", "Override Script",
                 ("rate_hz", "exposure_ms", "readout_ms", "motion_blur", "still"))
        layout.prop(s, "resolution_scale")
        layout.prop(s, "device")
        layout.prop(s, "output_dir")
        col = layout.column(heading="Existing Output")
        col.prop(s, "resume")
        col.prop(s, "overwrite")
        layout.use_property_split = False
        running = session.RenderSession.active is not None
        if running and hasattr(layout, "progress"):
            layout.progress(factor=s.progress, type="BAR", text=f"{s.progress:.0%} (Esc to cancel)")
        row = layout.row()
        row.scale_y = 1.4
        row.operator("sesgen.render", icon="RENDER_ANIMATION")
        row = layout.row(align=True)
        row.operator("sesgen.open_output", icon="FILE_FOLDER")
        row.operator("sesgen.verify", icon="CHECKMARK")


class SESGEN_PT_preview(_SettingsSubpanel, bpy.types.Panel):
    bl_label = "Ground-Truth Preview"
    draw = _settings_draw(("preview_kind", "preview_frame", "preview_view"), "sesgen.preview", "IMAGE_DATA")


class SESGEN_PT_export(_SettingsSubpanel, bpy.types.Panel):
    bl_label = "Export Dataset"
    draw = _settings_draw(("export_target", "export_dir", "export_sequence", "export_undistort", "vo_command"), "sesgen.export", "EXPORT",
                          "Frames: the Render panel's range; source: its Output folder")


class SESGEN_PT_study(_SettingsSubpanel, bpy.types.Panel):
    bl_label = "Study"
    draw = _settings_draw(("study_factor", "study_levels", "study_systems", "study_frames", "study_resolution",
                           "study_dir", "study_command"), "sesgen.study_run", "GRAPH",
                          "Quality: the Render panel's (draft when it is Script)", (("sesgen.study_report", "URL"),))


CLASSES = (SESGEN_PT_main, SESGEN_PT_render, SESGEN_PT_preview, SESGEN_PT_export, SESGEN_PT_study)
