"""BLEND: append the objects of a user's .blend file (a whole environment) to the SESGen scene.

Safety: the file is appended with Python auto-execution switched off
(``preferences.filepaths.use_scripts_auto_execute``), only objects (and what they use:
meshes, materials, images, node groups) are appended, never text blocks, and any text
block that arrives anyway is removed: no script stored in the file runs.
The files the appended data refers to (unpacked images, linked libraries) must be regular
files in the .blend's folder unless ``allow_external``, and images must decode
(``image_check``), as a MESH model's references (``ses/mesh_files.py``).

Placement: objects keep their place in the file's Blender (Z-up) world, moved as a whole
by the statement's pose (SES world, through ``contract.frames.ses_to_blender_world``) and scale.
Ids: an object's custom property ``sesgen_id`` (1..32767), else the next free id from the
statement's ``id`` in the order of the objects' names; class: ``sesgen_class``, else the
statement's ``class``. Every object's row goes into the manifest's object table.
"""
from __future__ import annotations

import os

import numpy as np
from mathutils import Matrix

import bpy

from ..contract.frames import blender_to_ses_world, object_pose, ses_to_blender_world
from ..contract.errors import ContractError
from ..contract.inputs import check_regular, is_inside
from ..contract.manifest import object_motion_fields
from ..files.image_check import ImageFileError, check_image
from ..contract import semantics
from ..errors import SesgenError
from ..scene.model import BlendImport

MAX_ID = 32767
_NEW_ID_COLLECTIONS = ("objects", "meshes", "materials", "images", "node_groups", "lights", "textures",
                       "curves", "collections", "actions")


def _snapshot() -> dict:
    return {name: set(getattr(bpy.data, name)) for name in _NEW_ID_COLLECTIONS}


def reference_problems(imp: BlendImport, images, libraries) -> list[str]:
    """The files the appended data refers to (images that are not packed, linked
    libraries) must exist as regular files, images must decode (``image_check``), and
    without ``allow_external`` they must lie in the .blend's folder (as MESH references:
    ``ses/mesh_files.py``)."""
    folder = os.path.dirname(os.path.abspath(imp.path))
    refs = [("image", im, im.filepath) for im in images
            if im.source in {"FILE", "SEQUENCE", "TILED"} and im.packed_file is None and im.filepath]
    refs += [("library", lib, lib.filepath) for lib in libraries]
    out = []
    for what, idb, raw in refs:
        path = os.path.abspath(bpy.path.abspath(raw, start=folder, library=getattr(idb, "library", None)))
        if not imp.allow_external and not is_inside(path, folder):
            out.append(f"{what} '{raw}' lies outside the file's folder {folder}; add 'allow_external' to the "
                       "BLEND statement if you trust this file")
            continue
        try:
            check_regular(path, f"{what} file")
            if what == "image":
                check_image(path)
        except ContractError as e:
            out.append(f"{what} '{raw}': {e.detail}")
        except ImageFileError as e:
            out.append(f"{what} '{raw}' is not a usable image: {e}")
    return out


def load_blend(imp: BlendImport, bscene, collection, used_ids: set, tag) -> tuple[list, list]:
    """Append ``imp``'s objects into ``collection`` (of ``bscene``). Returns (rows for the manifest's object
    table, lamps). ``used_ids`` (the script's ids) is extended with the ids given out."""
    prefs = bpy.context.preferences.filepaths
    saved = prefs.use_scripts_auto_execute
    before = _snapshot()
    texts_before = set(bpy.data.texts)
    libraries_before = set(bpy.data.libraries)
    prefs.use_scripts_auto_execute = False
    try:
        with bpy.data.libraries.load(imp.path, link=False) as (src, dst):
            if imp.collection is not None:
                if imp.collection not in src.collections:
                    raise SesgenError(f"BLEND {imp.source}: no collection '{imp.collection}' in the file "
                                      f"(collections: {', '.join(src.collections) or 'none'})")
                dst.collections = [imp.collection]
            else:
                dst.objects = list(src.objects)
    except OSError as e:
        raise SesgenError(f"BLEND {imp.source}: cannot load the file ({e})") from None
    finally:
        prefs.use_scripts_auto_execute = saved
    for text in set(bpy.data.texts) - texts_before:   # never keep (or run) a script
        bpy.data.texts.remove(text)
    for name, old in before.items():
        for idb in set(getattr(bpy.data, name)) - old:
            tag(idb)
    problems = reference_problems(imp, [i for i in set(bpy.data.images) - before["images"]],
                                  [lib for lib in set(bpy.data.libraries) - libraries_before])
    if problems:
        raise SesgenError(f"BLEND {imp.source}: {problems[0]}" + (f" (and {len(problems) - 1} more)"
                                                                   if len(problems) > 1 else ""))
    objects = (list(dst.collections[0].all_objects) if imp.collection is not None
               else [o for o in dst.objects if o is not None])
    keep_types = {"MESH", "CURVE", "SURFACE", "META", "FONT"} | ({"LIGHT"} if imp.lights else set())
    for o in list(objects):
        if o.type not in keep_types:
            objects.remove(o)
    place = _placement(imp)
    rows, lamps = [], []
    meshes = sorted((o for o in objects if o.type != "LIGHT"), key=lambda o: o.name)
    explicit = {}
    for o in meshes:
        if "sesgen_id" in o.keys():
            try:
                value = int(o["sesgen_id"])
            except (TypeError, ValueError):
                raise SesgenError(f"BLEND {imp.source}: object '{o.name}' has a non-integer sesgen_id") from None
            if not 1 <= value <= MAX_ID or value in used_ids or value in explicit.values():
                raise SesgenError(f"BLEND {imp.source}: object '{o.name}' has sesgen_id {value}, which is "
                                  f"outside 1..{MAX_ID} or already in use")
            explicit[o.name] = value
    used = set(used_ids) | set(explicit.values())
    next_id = imp.first_id
    for o in objects:          # link first: their world matrices come from the evaluation
        for coll in list(o.users_collection):
            coll.objects.unlink(o)
        collection.objects.link(o)
    bscene.view_layers[0].update()
    worlds = {o.name: np.array(o.matrix_world) for o in objects}
    for o in objects:
        o.parent = None
        o.matrix_world = Matrix((place @ worlds[o.name]).tolist())
        if o.type == "LIGHT":
            lamps.append(o)
    for o in meshes:
        obj_id = explicit.get(o.name)
        if obj_id is None:
            while next_id in used:
                next_id += 1
            if next_id > MAX_ID:
                raise SesgenError(f"BLEND {imp.source}: ids run past {MAX_ID} (choose a lower 'id')")
            obj_id = next_id
            used.add(obj_id)
        cls = str(o.get("sesgen_class", imp.semantic_class))
        label = semantics.lookup(cls)
        if label is None:
            raise SesgenError(f"BLEND {imp.source}: object '{o.name}' has the unknown sesgen_class '{cls}'")
        o.pass_index = obj_id
        o["sesgen_id"] = obj_id
        rows.append({"id": obj_id, "name": o.name, "shape": "blend", "texture": None, "material": None,
                     "class": label.name, "label_id": label.id, "file": imp.source, **object_motion_fields()})
    used_ids |= used
    if not rows:
        raise SesgenError(f"BLEND {imp.source}: holds no mesh object")
    return rows, lamps


def _placement(imp: BlendImport) -> np.ndarray:
    """Blender-world 4x4 moving the file's objects by the statement's SES pose and scale:
    C T S C^-1, C the SES -> Blender axis change (identity for the default pose)."""
    S = np.diag([*imp.scale, 1.0])
    T = object_pose(imp.position, imp.rotation_deg) @ S
    return ses_to_blender_world(T) @ blender_to_ses_world(np.eye(4))
