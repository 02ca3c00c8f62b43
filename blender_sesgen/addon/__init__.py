"""The Blender add-on: a 3D-view sidebar tab "SESGen" and File > Import > SES Script.

The UI only gathers settings (``props``), calls the pipeline shared with the command line
(``session``) and reports; see docs/addon.md. bpy is imported only by ``register()`` so
that ``python -m blender_sesgen.addon.package`` runs without Blender.
"""
from __future__ import annotations

_state = {"unregister": None}


def _classes():
    from . import ops, props, ui
    return (props.SESGEN_PG_settings, *ops.CLASSES, *ui.CLASSES)


def register():
    import bpy
    from . import ops, props
    register_classes, unregister_classes = bpy.utils.register_classes_factory(_classes())
    register_classes()
    bpy.types.Scene.sesgen = bpy.props.PointerProperty(type=props.SESGEN_PG_settings)
    bpy.types.TOPBAR_MT_file_import.append(ops.menu_import)
    _state["unregister"] = unregister_classes


def unregister():
    import bpy
    from . import ops, session, state
    active = session.RenderSession.active
    if active is not None:
        active.cancelled = True
        session.RenderSession.active = None
    bpy.types.TOPBAR_MT_file_import.remove(ops.menu_import)
    if hasattr(bpy.types.Scene, "sesgen"):
        del bpy.types.Scene.sesgen
    unregister_classes = _state["unregister"]
    if unregister_classes is None:
        unregister_classes = bpy.utils.register_classes_factory(_classes())[1]
    unregister_classes()
    _state["unregister"] = None
    state.forget()
