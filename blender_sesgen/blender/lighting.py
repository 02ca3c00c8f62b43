"""LIGHT, WORLD and FOG -> Blender lights, world shader and per-material fog.

Worlds (``lighting`` holds the numbers):
- ``WORLD colour``: a uniform background;
- ``WORLD sky``: Blender's physical sky (multiple scattering, 5.0) *without* its sun disc,
  plus a sun lamp of the disc's direction, colour and measured irradiance (a lamp is
  sampled directly: half the noise on sunlit surfaces); on 4.x (single-scattering Nishita)
  the disc stays in the sky;
- ``WORLD hdri``: an equirectangular image (a bundled HDRI found through
  ``bpy.utils.system_resource``, or the user's .exr/.hdr), turned about the vertical.

Default lighting (a script with neither LIGHT nor WORLD, e.g. every SESGen script): a
clear-sky day (``lighting.DEFAULT_SKY``: sky + sun), plus, when the rig starts inside
a closed space (rays from START hit geometry in >= 90 % of directions), a ceiling light:
a downward area light just under whatever is above START (or a point light at START when
nothing is), of power giving ~1.5 W/m^2 at half the scene's extent. No ambient term: every
bit of light comes from a light source, as in a camera.

Fog is applied to camera rays only (a mix towards the fog colour by the distance from the
camera), so only the RGB output is fogged; Depth/Object Index are geometry and never fogged.
"""
from __future__ import annotations

import math
import os

import bpy
import numpy as np
from mathutils import Vector

from ..scene import lighting
from ..contract.frames import R_BLENDER_SES
from ..errors import SesgenError
from ..scene.model import Fog, Light, Scene, World
from . import compat
from . import sky as sky_table
from .datablocks import load_image


def ses_vec_to_blender(v) -> Vector:
    return Vector(tuple(R_BLENDER_SES @ np.asarray(v, dtype=float)))


def _aim(obj, travel_dir_ses) -> None:
    """Point a light's -Z (its emission direction) along ``travel_dir_ses``."""
    d = ses_vec_to_blender(travel_dir_ses)
    if d.length == 0:
        d = Vector((0, 0, -1))
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = d.normalized().to_track_quat("-Z", "Y")


_TYPES = {"sun": "SUN", "point": "POINT", "spot": "SPOT", "area": "AREA", "portal": "AREA"}


def add_light(bscene, collection, light: Light, name: str):
    data = bpy.data.lights.new(name, type=_TYPES[light.kind])
    data.color = light.colour
    data.energy = float(light.strength)
    if light.kind == "sun":
        data.angle = math.radians(lighting.SUN_ANGLE_DEG)
    elif light.kind in ("point", "spot"):
        data.shadow_soft_size = float(light.size)
        if light.kind == "spot":
            data.spot_size = math.radians(light.spot_angle_deg)
            data.spot_blend = float(light.spot_blend)
    else:  # area, portal
        edge = float(light.size) if light.size > 0 else 1.0
        if light.size_y is not None:
            data.shape = "RECTANGLE"
            data.size, data.size_y = edge, float(light.size_y)
        else:
            data.shape = "SQUARE"
            data.size = edge
        if light.kind == "portal":
            data.cycles.is_portal = True
    obj = bpy.data.objects.new(name, data)
    if light.position is not None:
        obj.location = ses_vec_to_blender(light.position)
    if light.direction is not None:
        _aim(obj, light.direction)
    collection.objects.link(obj)
    return obj


def scene_lights(scene: Scene, bscene, file_lamps: bool = False) -> list[Light]:
    """Every lamp the scene gets: the script's LIGHTs, the sky's sun, or the default lighting
    (after the objects are built: the enclosure test casts rays against them). A BLEND
    file's own lamps (``file_lamps``) count as the script's lights."""
    lights = list(scene.lights)
    world = effective_world(scene, file_lamps)
    if world.kind == "sky" and _sky_without_disc():
        sun = lighting.sky_sun_light(world)
        if sun is not None:
            lights.append(sun)
    if not scene.lights and not file_lamps and scene.world is None:
        lights += _enclosure_lights(scene, bscene)
    return lights


def effective_world(scene: Scene, file_lamps: bool = False) -> World:
    """The script's WORLD; without one, the default sky (no LIGHT either) or, for a script
    with its own LIGHTs (or a BLEND file's lamps), the soft uniform ``LIGHTS_ONLY_WORLD``."""
    return lighting.effective_world(scene.world, bool(scene.lights) or file_lamps)


def _start_position(scene: Scene) -> np.ndarray:
    return np.asarray(scene.timeline.left()[0][:3, 3] if scene.frames else scene.start_position, dtype=float)


def _enclosure_lights(scene: Scene, bscene) -> list[Light]:
    """A ceiling light when START is inside a closed space (module docstring)."""
    with bpy.context.temp_override(scene=bscene, view_layer=bscene.view_layers[0]):
        depsgraph = bpy.context.evaluated_depsgraph_get()
    start = _start_position(scene)
    origin = ses_vec_to_blender(start)
    hits = 0
    dirs = lighting.fibonacci_directions(64)
    for d in dirs:
        hit = bscene.ray_cast(depsgraph, origin, ses_vec_to_blender(d), distance=1e6)
        hits += bool(hit[0])
    if hits < lighting.ENCLOSED_HIT_FRACTION * len(dirs):
        return []
    half_extent = max(scene_extent(scene) / 2.0, 0.5)
    power = 4.0 * math.pi * half_extent**2 * lighting.DEFAULT_FILL_IRRADIANCE
    up = bscene.ray_cast(depsgraph, origin, ses_vec_to_blender((0.0, 1.0, 0.0)), distance=1e6)
    if up[0] and up[1].z - origin.z > 0.3:
        height = (up[1].z - origin.z) - 0.05
        edge = float(np.clip(0.25 * half_extent, 0.3, 2.0))
        return [Light(kind="area", strength=power, size=edge, direction=(0.0, -1.0, 0.0),
                      position=tuple(start + np.array([0.0, height, 0.0])))]
    return [Light(kind="point", strength=power, position=tuple(start), size=0.1 * half_extent)]


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


def _sky_without_disc() -> bool:
    """Whether the physical sky's disc is replaced by a lamp (the calibrated 5.0 sky only)."""
    return compat.sky_type_for() == "MULTIPLE_SCATTERING"


def sky_sun_lamp() -> bool:
    """Whether a ``WORLD sky``'s sun shines as a lamp (``scene.lighting.sky_sun_light``)."""
    return _sky_without_disc()


def hdri_path(world: World) -> str:
    """The image file of ``WORLD hdri``: the user's file, or a bundled HDRI found through
    bpy's own resource path."""
    if world.hdri_path:
        return world.hdri_path
    folder = bpy.utils.system_resource("DATAFILES", path="studiolights/world")
    path = os.path.join(folder, f"{world.hdri}.exr") if folder else ""
    if not os.path.isfile(path):
        raise SesgenError(f"WORLD hdri {world.hdri}: this Blender has no bundled HDRI of that name "
                          f"(looked for {path or 'datafiles/studiolights/world'})")
    return path


# The world's importance map (what Cycles samples background light by). Left automatic,
# Cycles makes it 4096 x 2048 for any sky without its sun disc or any HDRI (a sun disc
# alone gets 512 x 256): 8.4 million shader evaluations, 1.3-2.2 CPU s at the start of
# every render session. The disc-less sky is smooth (its sun is a lamp): it gets the
# resolution Cycles gives a sky with a disc; an HDRI gets its own width (one cell per
# texel). Only the noise of the background's sampling depends on it, never its mean.
SKY_MAP_WIDTH = 512


def _importance_map(wd, width: int) -> None:
    if hasattr(wd, "cycles") and width > 0:
        wd.cycles.sampling_method = "MANUAL"
        wd.cycles.sample_map_resolution = int(width)


def build_world(bscene, w: World, fog: Fog | None, name: str, tag=lambda x: x, threads: int = 0):
    """The world ``w`` (and the scene's ``fog``) as a Blender world named ``name``; ``threads``:
    the CPU threads of the sky table's bake (0: automatic)."""
    wd = bpy.data.worlds.new(name)
    nt = compat.node_tree(wd)
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = float(w.strength) / (lighting.SKY_EXPOSURE if w.kind == "sky" else 1.0)
    if w.kind == "sky":
        sky = nt.nodes.new("ShaderNodeTexSky")
        sky.sky_type = compat.sky_type_for()
        if hasattr(sky, "sun_elevation"):
            sky.sun_elevation = math.radians(w.sun_elevation_deg)
            sky.sun_rotation = math.radians(w.sun_azimuth_deg)
        compat.set_sky_aerosol(sky, w.aerosol)
        if hasattr(sky, "sun_disc") and _sky_without_disc():
            sky.sun_disc = False  # the sun is a lamp (scene_lights)
        # 5.0's sky from its table baked once, not computed in every Cycles session (sky.py)
        colour = sky_table.lookup(nt, sky, tag, threads) if sky_table.available() else sky.outputs["Color"]
        nt.links.new(colour, bg.inputs["Color"])
        _importance_map(wd, SKY_MAP_WIDTH)
    elif w.kind == "hdri":
        img = tag(load_image(hdri_path(w)))
        env = nt.nodes.new("ShaderNodeTexEnvironment")
        env.image = img
        env.interpolation = "Linear"
        coords = nt.nodes.new("ShaderNodeTexCoord")
        mapping = nt.nodes.new("ShaderNodeMapping")
        mapping.vector_type = "POINT"
        # the SES vertical is Blender's Z; a positive rotation moves the image's content
        # from SES -Z (ahead) towards +X, the rule of the sun's azimuth
        mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(w.rotation_deg))
        nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        nt.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
        nt.links.new(env.outputs["Color"], bg.inputs["Color"])
        _importance_map(wd, img.size[0])
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
