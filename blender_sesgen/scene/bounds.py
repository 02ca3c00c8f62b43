"""Object-frame bounding boxes of a script's objects (pure, no bpy): the manifest's
``objects[i].box``, from which 3-D box labels (Virtual KITTI 2's ``pose.txt`` dimensions
and bottom centres) are made.

A box is ``[[x_min, y_min, z_min], [x_max, y_max, z_max]]`` in the object's own frame
(:mod:`.dynamics`: origin at ``position``, the object's axes; SES axes, Y up; metres): exact
for QUAD, CUBOID (its bevel stays inside), SPHERE, CYLINDER, MESH files in the OBJ format
(their vertices, times ``scale``) and the ASSETs of *things* (a class with instances: cars,
people, furniture...; the generator's own triangles). Stuff assets (roads, buildings,
vegetation: a city holds thousands, and box labels are made for things), other mesh
formats and BLEND objects have no box (None).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from .assets import cache as asset_cache
from ..contract import semantics
from ..contract.errors import ContractError
from ..contract.inputs import read_text
from .model import Asset, Cuboid, Cylinder, Mesh, Quad, SceneObject, Sphere

__all__ = ["object_box"]

MAX_OBJ_TEXT = 1 << 30   # bytes of an OBJ file read for its vertices


def object_box(obj: SceneObject, cache: Optional[dict] = None) -> Optional[np.ndarray]:
    """(2, 3) float64 [min, max] of ``obj`` in its object frame, or None when unknown.
    ``cache`` (a dict kept across calls) shares the work between equal assets and files."""
    cache = {} if cache is None else cache
    if isinstance(obj, Quad):
        V = np.asarray(obj.vertices, dtype=float)
        V = V - V.mean(axis=0)                       # a QUAD's frame: the centroid, world axes
        return np.stack([V.min(axis=0), V.max(axis=0)])
    if isinstance(obj, Cuboid):
        h = np.asarray(obj.size, dtype=float) / 2
        return np.stack([-h, h])
    if isinstance(obj, Sphere):
        return np.array([[-obj.radius] * 3, [obj.radius] * 3], dtype=float)
    if isinstance(obj, Cylinder):
        r, h = float(obj.radius), float(obj.height) / 2
        return np.array([[-r, -h, -r], [r, h, r]])
    if isinstance(obj, Asset):
        label = semantics.lookup(obj.semantic_class)
        if label is None or not label.has_instances:
            return None
        key = ("asset", obj.kind, tuple(obj.size), obj.seed, tuple(obj.bend), obj.offset)
        if key not in cache:   # the mesh the builder made (assets.cache keeps its box), else generated
            cache[key] = asset_cache.box(obj.kind, obj.size, obj.seed, obj.bend, obj.offset)
        return cache[key]
    if isinstance(obj, Mesh) and obj.path.lower().endswith(".obj"):
        key = ("obj", obj.path)
        if key not in cache:
            cache[key] = _obj_bounds(obj.path)
        if cache[key] is None:
            return None
        corners = cache[key] * np.asarray(obj.scale, dtype=float)
        return np.stack([corners.min(axis=0), corners.max(axis=0)])
    return None


def _obj_bounds(path: str) -> Optional[np.ndarray]:
    """[min, max] of the ``v x y z`` lines of a Wavefront OBJ file (None without vertices)."""
    try:
        text = read_text(path, MAX_OBJ_TEXT, "OBJ file", strict=False)
    except ContractError:
        return None
    rows = [line.split()[1:4] for line in text.splitlines() if line.startswith("v ")]
    try:
        V = np.array(rows, dtype=float).reshape(-1, 3)
    except ValueError:
        return None
    if not len(V) or not np.all(np.isfinite(V)):
        return None
    return np.stack([V.min(axis=0), V.max(axis=0)])
