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


def load_image(path: str):
    """``bpy.data.images.load`` (tagged), refusing a float image (an HDRI, a float texture)
    with a sample that is not finite or beyond ``image_check.MAX_PIXEL_VALUE``: Cycles
    renders such an image as black frames and says nothing. ``check`` has decoded what it
    can (Radiance HDR, EXR with NONE/RLE/ZIP); here every float format is checked, as
    Blender decoded it (PIZ, DWA, tiled EXR, float TIFF)."""
    import numpy as np
    from ..errors import SesgenError
    from ..files.image_check import MAX_PIXEL_VALUE
    img = tag(bpy.data.images.load(path, check_existing=True))
    if img.is_float and img.get("sesgen_values") is None:
        px = np.empty(len(img.pixels), dtype=np.float32)
        img.pixels.foreach_get(px)
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~(np.abs(px) <= MAX_PIXEL_VALUE))
        if bad.size:
            raise SesgenError(f"{path}: holds {float(px[bad[0]]):.4g} (and {bad.size - 1} more such samples): "
                              f"an image's values must be finite and within +-{MAX_PIXEL_VALUE:g}")
        img["sesgen_values"] = 1
    return img


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
    # in one batch: removing them one by one remaps every other data-block's users each time
    # (quadratic: 10 s for a built city)
    bpy.data.batch_remove([idb for coll_name in _ID_COLLECTIONS for idb in getattr(bpy.data, coll_name, ())
                           if idb.get(TAG)])
