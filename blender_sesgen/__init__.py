"""blender_sesgen: SES scripts -> Blender Cycles stereo sequences with exact ground truth.

The pure modules (``ses``, ``model``, ``poses``, ``intrinsics``, ``textures``, ``contract``)
import without bpy. The bpy layer lives in ``blender/`` (builder, rig, render) and the
add-on UI in ``addon/``; ``register()``/``unregister()`` import them lazily so that this
package stays importable outside Blender.
"""
__version__ = "0.1.0"


def register():  # Blender extension entry point
    from .addon import register as _register
    _register()


def unregister():
    from .addon import unregister as _unregister
    _unregister()
