"""blender_sesgen: SES scripts -> Blender Cycles stereo sequences with exact ground truth.

Everything outside ``blender/`` and ``addon/`` imports without bpy: the SES language
(``ses``), the scene model (``model``, ``dynamics``, ``assets``), the on-disk contract
shared with ``vo_reference`` (``contract``), the render plan and its output folder
(``plan``, ``output``, ``job``). The bpy layer lives in ``blender/`` (builder, rig, render)
and the add-on UI in ``addon/``; ``register()``/``unregister()`` import them lazily so that
this package stays importable outside Blender. Public Python API: ``api`` and ``pipeline``
(docs/api.md).
"""
__version__ = "0.1.0"


def register():  # Blender extension entry point
    from .addon import register as _register
    _register()


def unregister():
    from .addon import unregister as _unregister
    _unregister()
