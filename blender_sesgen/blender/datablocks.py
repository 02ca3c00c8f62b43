"""The data-blocks this add-on creates: all tagged, all removable in one sweep.

Everything is built into a dedicated Blender scene (``SCENE_NAME``) so that the user's own
scenes are never touched; every data-block created here carries the custom property
``TAG`` and a rebuild removes all of them first (rebuilding replaces, never duplicates).
"""
from __future__ import annotations

import bpy

SCENE_NAME = "SESGen"
TAG = "sesgen"
# ID collections that may hold data-blocks we created (tagged with TAG)
_ID_COLLECTIONS = ("objects", "meshes", "materials", "lights", "cameras", "worlds", "node_groups",
                   "images", "actions", "collections", "pointclouds")


def tag(idblock):
    idblock[TAG] = 1
    return idblock


def clear_previous() -> None:
    """Remove the SESGen scene and every data-block this module created before."""
    old = bpy.data.scenes.get(SCENE_NAME)
    if old is not None:
        others = [s for s in bpy.data.scenes if s != old] or [bpy.data.scenes.new("Scene")]
        wm = bpy.context.window_manager
        for w in (wm.windows if wm is not None else []):
            if w.scene == old:
                w.scene = others[0]
        bpy.data.scenes.remove(old)
    for coll_name in _ID_COLLECTIONS:
        coll = getattr(bpy.data, coll_name, None)
        if coll is None:
            continue
        for idb in [i for i in coll if i.get(TAG)]:
            coll.remove(idb)
