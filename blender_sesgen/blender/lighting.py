"""LIGHT, WORLD and FOG -> Blender lights, world shader and per-material fog.

Defaults (a SESGen script has no lights; it must still render well lit, not black):
- world: a soft grey-blue ambient (``DEFAULT_WORLD``);
- a sun from elevation 50 deg, azimuth 30 deg, 2 W/m^2 (lights open scenes);
- a point light at the rig's START position, power chosen so that the irradiance at half
  the scene's extent is ~1.5 W/m^2 (lights closed rooms from the inside; it does not move,
  so the shading is constant over the sequence, as VO assumes);
- a small ambient term (5 % of each surface's own colour, like OpenGL's ambient light) so
  that shadows are never pitch black.
Fog is applied to camera rays only (a mix towards the fog colour by the distance from the
camera), so only the RGB output is fogged; Depth/Object Index are geometry and never fogged.
"""
from __future__ import annotations

import math

import bpy
import numpy as np
from mathutils import Vector

from ..contract.frames import R_BLENDER_SES
from ..model import Fog, Light, Scene, World
from . import compat

DEFAULT_WORLD = World(kind="colour", colour=(0.55, 0.6, 0.7), strength=0.35)
DEFAULT_SUN_ELEVATION_DEG = 50.0
DEFAULT_SUN_AZIMUTH_DEG = 30.0
DEFAULT_SUN_STRENGTH = 2.0
DEFAULT_FILL_IRRADIANCE = 1.5
DEFAULT_AMBIENT = 0.05
# Blender's physical sky is in absolute units: at strength 1 a white ground under a 45 deg
# sun reads ~39 (linear), far past white. ``WORLD sky strength s`` means s / SKY_EXPOSURE,
# so that strength 1 is well exposed (white ground ~0.75 at 45 deg, ~0.35 at 20 deg).
SKY_EXPOSURE = 50.0


def ses_vec_to_blender(v) -> Vector:
    return Vector(tuple(R_BLENDER_SES @ np.asarray(v, dtype=float)))


def _direction_from_angles(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """SES-world direction *towards* the sun: elevation above the XZ ground plane (Y up),
    azimuth from -Z (forward of an unrotated camera) towards +X."""
    el, az = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(el) * math.sin(az), math.sin(el), -math.cos(el) * math.cos(az)])


def _aim(obj, travel_dir_ses) -> None:
    """Point a light's -Z (its emission direction) along ``travel_dir_ses``."""
    d = ses_vec_to_blender(travel_dir_ses)
    if d.length == 0:
        d = Vector((0, 0, -1))
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = d.normalized().to_track_quat("-Z", "Y")


def add_light(bscene, collection, light: Light, name: str):
    data = bpy.data.lights.new(name, type={"sun": "SUN", "point": "POINT", "area": "AREA"}[light.kind])
    data.color = light.colour
    data.energy = float(light.strength)
    if light.kind == "sun":
        data.angle = math.radians(0.5)
    elif light.kind == "point":
        data.shadow_soft_size = float(light.size)
    else:
        data.size = float(light.size) if light.size > 0 else 1.0
    obj = bpy.data.objects.new(name, data)
    if light.position is not None:
        obj.location = ses_vec_to_blender(light.position)
    if light.direction is not None:
        _aim(obj, light.direction)
    collection.objects.link(obj)
    return obj


def default_lights(scene: Scene) -> list[Light]:
    """The lights a script without LIGHT statements gets (see module docstring)."""
    sun = Light(kind="sun", strength=DEFAULT_SUN_STRENGTH,
                direction=tuple(-_direction_from_angles(DEFAULT_SUN_ELEVATION_DEG, DEFAULT_SUN_AZIMUTH_DEG)))
    half_extent = max(scene_extent(scene) / 2.0, 0.5)
    fill = Light(kind="point", strength=4.0 * math.pi * half_extent**2 * DEFAULT_FILL_IRRADIANCE,
                 position=tuple(float(x) for x in scene.timeline.left()[0][:3, 3]) if scene.frames else scene.start_position,
                 size=0.1 * half_extent)
    return [sun, fill]


def scene_extent(scene: Scene) -> float:
    """Diagonal of the bounding box of the objects' reference points and the camera path."""
    pts = []
    for o in scene.objects:
        if hasattr(o, "vertices"):
            pts.extend(o.vertices)
        elif hasattr(o, "position"):
            p = np.asarray(o.position, dtype=float)
            r = max(getattr(o, "radius", 0.0), getattr(o, "height", 0.0) / 2, *(np.asarray(getattr(o, "size", (0, 0, 0))) / 2))
            pts.extend([p - r, p + r])
    if scene.frames:
        pts.extend(scene.timeline.left()[:, :3, 3])
    if not pts:
        return 2.0
    P = np.asarray(pts, dtype=float)
    return float(np.linalg.norm(P.max(axis=0) - P.min(axis=0)))


def build_world(bscene, world: World | None, fog: Fog | None, name: str):
    w = world or DEFAULT_WORLD
    wd = bpy.data.worlds.new(name)
    nt = compat.node_tree(wd)
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = float(w.strength) / (SKY_EXPOSURE if w.kind == "sky" else 1.0)
    if w.kind == "sky":
        sky = nt.nodes.new("ShaderNodeTexSky")
        sky.sky_type = compat.sky_type_for()
        if hasattr(sky, "sun_elevation"):
            sky.sun_elevation = math.radians(w.sun_elevation_deg)
            sky.sun_rotation = math.radians(w.sun_azimuth_deg)
        nt.links.new(sky.outputs["Color"], bg.inputs["Color"])
    else:
        bg.inputs["Color"].default_value = (*w.colour, 1.0)
    shader = bg.outputs["Background"]
    if fog is not None:  # the background is infinitely far: fully fogged for camera rays
        shader = _fog_mix(nt, shader, fog, background=True)
    nt.links.new(shader, out.inputs["Surface"])
    bscene.world = wd
    return wd


def _fog_mix(nt, shader_socket, fog: Fog, background: bool = False):
    """Mix ``shader_socket`` towards an emission of the fog colour, for camera rays only."""
    lp = nt.nodes.new("ShaderNodeLightPath")
    emit = nt.nodes.new("ShaderNodeEmission" if not background else "ShaderNodeBackground")
    emit.inputs["Color"].default_value = (*fog.colour, 1.0)
    emit.inputs["Strength"].default_value = 1.0
    mix = nt.nodes.new("ShaderNodeMixShader")
    if background:
        nt.links.new(lp.outputs["Is Camera Ray"], mix.inputs["Fac"])
    else:
        cam = nt.nodes.new("ShaderNodeCameraData")
        mr = nt.nodes.new("ShaderNodeMapRange")
        mr.clamp = True
        mr.inputs["From Min"].default_value = float(fog.start)
        mr.inputs["From Max"].default_value = float(max(fog.end, fog.start + 1e-6))
        nt.links.new(cam.outputs["View Distance"], mr.inputs["Value"])
        mul = nt.nodes.new("ShaderNodeMath")
        mul.operation = "MULTIPLY"
        nt.links.new(mr.outputs["Result"], mul.inputs[0])
        nt.links.new(lp.outputs["Is Camera Ray"], mul.inputs[1])
        nt.links.new(mul.outputs[0], mix.inputs["Fac"])
    nt.links.new(shader_socket, mix.inputs[1])
    nt.links.new(emit.outputs[0], mix.inputs[2])
    return mix.outputs["Shader"]


fog_mix = _fog_mix
