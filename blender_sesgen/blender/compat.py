"""Blender 4.2 LTS ... 5.0 differences, in one place.

- multilayer EXR: 5.0 needs ``image_settings.media_type`` set before ``file_format``;
- animation: 4.4+ layered actions keep F-curves in a channelbag per slot (5.0 removed
  ``Action.fcurves``);
- node trees of materials/worlds: 5.0 always has one (``use_nodes`` is deprecated), 4.x
  needs ``use_nodes = True``;
- pass names in multilayer EXR channels: ``Object Index`` (5.0) vs ``IndexOB`` (4.x);
- Principled BSDF: ``Specular IOR Level`` (4.0+) vs ``Specular`` (3.x);
- physical sky: ``MULTIPLE_SCATTERING`` (5.0) vs ``NISHITA`` (4.x) (``sky_type_for``); its
  aerosols: ``aerosol_density`` (5.0) vs ``dust_density`` (4.x) (``set_sky_aerosol``);
- evaluated geometry: ``Object.evaluated_geometry()`` (4.5+) vs the point cloud of a
  geometry-nodes object appearing as a depsgraph instance (4.2-4.4) (``evaluated_points``);
- the deflate level of ZIP EXRs: not in Blender's API; set in the OpenEXR library Blender
  loaded, where it can be found (``exr_zip_level``).

Verified with the ``bpy`` wheels 4.2.23 LTS, 4.4.0, 4.5.15 LTS and 5.0.1 (docs/rendering.md,
bench/check_blender_versions.sh).
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import sys

import bpy

from ..contract import exr_format


def version() -> tuple[int, int, int]:
    return tuple(bpy.app.version)


def version_string() -> str:
    return bpy.app.version_string


def set_multilayer_exr(image_settings, codec: str = "ZIP", bits: str = "32") -> None:
    """Multilayer OpenEXR, float32, lossless."""
    if hasattr(image_settings, "media_type"):  # 5.0
        image_settings.media_type = "MULTI_LAYER_IMAGE"
    image_settings.file_format = "OPEN_EXR_MULTILAYER"
    image_settings.color_depth = bits
    image_settings.exr_codec = codec


@functools.cache
def _openexr_core():
    """The OpenEXR core library this Blender writes EXRs with (``ctypes.CDLL``), or None:
    on Linux the one mapped into this process (the bpy wheel's ``lib/libOpenEXRCore``),
    else a build exporting its symbols (OpenEXR linked into the executable). Found once."""
    paths = []
    if sys.platform.startswith("linux"):
        try:
            with open("/proc/self/maps") as f:
                paths = [line.split()[-1] for line in f if "libOpenEXRCore" in line]
        except OSError:
            pass
    for path in dict.fromkeys(paths + [None]):
        try:
            lib = ctypes.CDLL(path)
            lib.exr_set_default_zip_compression_level.argtypes = [ctypes.c_int]
            lib.exr_get_default_zip_compression_level.argtypes = [ctypes.POINTER(ctypes.c_int)]
            return lib
        except (OSError, AttributeError):
            continue
    return None


@contextlib.contextmanager
def exr_zip_level(level: int):
    """ZIP EXRs written inside the block use deflate level ``level`` (1 fastest, 9 smallest;
    OpenEXR's default is 4); the previous default comes back after it. Deflate is lossless
    at every level: only the file's size and the time to write it change, not one decoded
    value (tests/test_quality_presets.py). Blender has no setting for it, so the level is
    set in the OpenEXR library Blender loaded; where that cannot be found (a Blender with
    OpenEXR linked in and not exported), nothing changes. Yields whether it was set."""
    lib = _openexr_core()
    if lib is None:
        yield False
        return
    old = ctypes.c_int(-1)
    lib.exr_get_default_zip_compression_level(ctypes.byref(old))
    lib.exr_set_default_zip_compression_level(int(level))
    try:
        yield True
    finally:
        lib.exr_set_default_zip_compression_level(old.value)


def set_png(image_settings, bits: str = "8") -> None:
    """8-bit RGB PNG (the display-referred image)."""
    if hasattr(image_settings, "media_type"):
        image_settings.media_type = "IMAGE"
    image_settings.file_format = "PNG"
    image_settings.color_mode = "RGB"
    image_settings.color_depth = bits


def exr_channel_names() -> dict:
    """Names of the EXR channels (``layer.pass.channel``) that hold each product, as this
    Blender writes them (contract.exr_format)."""
    new = version() >= (5, 0, 0)
    return exr_format.channel_names(exr_format.PASS_INDEX[0 if new else 1],
                                    exr_format.LAYOUT_PARTS if new else exr_format.LAYOUT_SINGLE)


# the mesh arrays behind the element properties (Blender 4.0+): writing an attribute's values
# is one copy; ``foreach_set`` on the element collection's property goes element by element
# (a 40k-triangle tree: material index and smooth flags 21 ms that way, 0.3 ms as attributes)
_MESH_ATTRIBUTES = {("vertices", "co"): ("position", "vector", "FLOAT_VECTOR", "POINT", False),
                    ("loops", "vertex_index"): (".corner_vert", "value", "INT", "CORNER", False),
                    ("polygons", "material_index"): ("material_index", "value", "INT", "FACE", False),
                    ("polygons", "use_smooth"): ("sharp_face", "value", "BOOLEAN", "FACE", True)}


def set_mesh_array(me, elements: str, prop: str, values) -> None:
    """``me.<elements>.foreach_set(prop, values)``, through the attribute that holds the values
    where this Blender has one (``use_smooth`` is stored negated, as ``sharp_face``)."""
    name, key, kind, domain, negated = _MESH_ATTRIBUTES[elements, prop]
    if version() < (4, 0, 0):
        getattr(me, elements).foreach_set(prop, values)
        return
    attr = me.attributes.get(name) or me.attributes.new(name, kind, domain)
    attr.data.foreach_set(key, ~values if negated else values)


def node_tree(idblock):
    """The shader node tree of a material or world, creating it on 4.x."""
    if getattr(idblock, "node_tree", None) is None:
        idblock.use_nodes = True
    return idblock.node_tree


def object_fcurves(obj):
    """The F-curves animating ``obj`` (layered actions on 4.4+, ``Action.fcurves`` before)."""
    ad = obj.animation_data
    if ad is None or ad.action is None:
        return []
    action = ad.action
    slot = getattr(ad, "action_slot", None)
    if slot is not None and hasattr(action, "layers"):
        from bpy_extras import anim_utils
        cb = anim_utils.action_get_channelbag_for_slot(action, slot)
        return list(cb.fcurves) if cb is not None else []
    return list(action.fcurves)


def principled_input(bsdf, name: str):
    """A Principled BSDF input by its current name (``Specular`` was renamed in 4.0)."""
    aliases = {"Specular IOR Level": ("Specular IOR Level", "Specular"),
               "Emission Color": ("Emission Color", "Emission")}
    for n in aliases.get(name, (name,)):
        if n in bsdf.inputs:
            return bsdf.inputs[n]
    raise KeyError(name)


def sky_type_for(preferred: tuple[str, ...] = ("MULTIPLE_SCATTERING", "NISHITA", "HOSEK_WILKIE")) -> str:
    items = [e.identifier for e in bpy.types.ShaderNodeTexSky.bl_rna.properties["sky_type"].enum_items]
    for p in preferred:
        if p in items:
            return p
    return items[0]


def set_sky_aerosol(sky, density: float) -> None:
    """The physical sky's aerosol density (1 = Blender's default, a city's clear day)."""
    for name in ("aerosol_density", "dust_density"):
        if hasattr(sky, name):
            setattr(sky, name, float(density))
            return


def evaluated_points(obj, depsgraph=None) -> list[tuple]:
    """World-space (centre, radius) of the points of ``obj``'s evaluated point cloud (the
    SPHERE primitive: one point made by geometry nodes on an empty mesh).

    4.5+ reads ``Object.evaluated_geometry().pointcloud``; 4.2-4.4 have no such API, there the
    point cloud is an instance (of the evaluated object) in ``depsgraph.object_instances``.
    """
    dg = depsgraph if depsgraph is not None else bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    if hasattr(ev, "evaluated_geometry"):  # 4.5+
        geometry = ev.evaluated_geometry()  # keep the geometry set alive while reading it
        pc = geometry.pointcloud
        mw = ev.matrix_world
        return [] if pc is None else [(tuple(mw @ p.co), p.radius * mw.to_scale()[0]) for p in pc.points]
    out = []
    for inst in dg.object_instances:
        io = inst.object
        if io.type == "POINTCLOUD" and io.original == obj.original:
            mw = inst.matrix_world
            out += [(tuple(mw @ p.co), p.radius * mw.to_scale()[0]) for p in io.data.points]
    return out
