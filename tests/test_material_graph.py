"""The library's node graphs (blender/library/graph.py: ``G``; blender/library: its groups) as
bpy builds them.

``G`` skips the writes that would change nothing (Blender updates the whole tree on every
write) and places the nodes in one ``foreach_set``. Oracle: the same graphs built with every
write done (``_same`` never true) and each node placed as it is made: every node's type,
properties, socket values, enabled sockets, location and every link must be equal, for every
library material, procedural texture and shared group. The shared parts of the library graphs
(coordinates, per-object variation, dirt) are node groups built once per scene; oracle: every
library material rendered with the parts written inline, every EXR channel equal. The rocks'
icosphere is made once per process: each rock gets arrays of its own.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from blender_sesgen.blender import library, textures  # noqa: E402
from blender_sesgen.blender.library import graph  # noqa: E402
from blender_sesgen.scene import materials  # noqa: E402
from blender_sesgen.scene.model import TextureRef  # noqa: E402
from blender_sesgen.ses.materials import library_material  # noqa: E402

SKIPPED = {"location", "location_absolute", "name", "select", "dimensions", "width", "height", "rna_type",
           "internal_links", "inputs", "outputs", "parent", "type", "bl_idname", "bl_label", "bl_description",
           "bl_icon", "bl_static_type", "bl_width_default", "bl_width_min", "bl_width_max", "bl_height_default",
           "bl_height_min", "bl_height_max", "is_active_output"}


def _value(v):
    if isinstance(v, (str, bool, int, type(None))):
        return v
    if isinstance(v, float):
        return float(np.float32(v))
    if isinstance(v, bpy.types.ID):
        return v.name
    try:
        return tuple(float(np.float32(x)) for x in v)
    except TypeError:
        return str(type(v))


def dump(nt) -> dict:
    """Everything Cycles reads from a tree (and where a person sees its nodes)."""
    nodes = {}
    for n in nt.nodes:
        props = {p.identifier: _value(getattr(n, p.identifier)) for p in n.bl_rna.properties
                 if p.identifier not in SKIPPED and p.type != "POINTER" and p.type != "COLLECTION"}
        if n.bl_idname == "ShaderNodeValToRGB":
            props["ramp"] = (n.color_ramp.interpolation,
                             tuple((_value(e.position), _value(e.color)) for e in n.color_ramp.elements))
        if n.bl_idname == "ShaderNodeTexImage":
            props["image"] = n.image.name if n.image else None
        nodes[n.name] = (n.bl_idname, props, _value(n.location),
                         tuple((s.identifier, s.enabled, _value(getattr(s, "default_value", None))) for s in n.inputs),
                         tuple((s.identifier, s.enabled) for s in n.outputs))
    links = sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name, lk.to_socket.identifier)
                   for lk in nt.links)
    return {"nodes": nodes, "links": links}


def every_write(monkeypatch) -> None:
    """G as it was: every write done, each node placed as it is made."""
    monkeypatch.setattr(graph, "_same", lambda current, value: False)
    made = graph.G.node

    def node(self, kind, inputs=None, **props):
        n = made(self, kind, inputs, **props)
        n.location = self._placed[n.as_pointer()]
        return n
    monkeypatch.setattr(graph.G, "node", node)


def _library_tree(name: str):
    mat = bpy.data.materials.new(f"test_{name}")
    nt = mat.node_tree
    nt.nodes.clear()
    m = library_material(name)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(library.build_shader(nt, m, (0.5, 0.4, 0.3)), out.inputs["Surface"])
    return nt


def _texture_tree(name: str):
    mat = bpy.data.materials.new(f"test_tex_{name}")
    nt = mat.node_tree
    nt.nodes.clear()
    textures.texture_colour(nt, TextureRef(kind="builtin", name=name, scale=2.0))
    return nt


BUILTINS = sorted({name for name, _ in textures.BUILTIN_TEXTURES.values()})


def test_library_graphs_equal_the_graphs_built_with_every_write(monkeypatch):
    def groups():
        return [g for g in bpy.data.node_groups if g.name.startswith(library.GROUPS)]
    for g in groups():
        bpy.data.node_groups.remove(g)
    fast = {name: dump(_library_tree(name)) for name in materials.LIBRARY}
    fast.update({f"tex {t}": dump(_texture_tree(t)) for t in BUILTINS})
    # the shared parts' groups: each built once, used by every material
    assert sorted(g.name for g in groups()) == sorted(library.GROUPS)
    fast.update({g.name: dump(g) for g in groups()})
    for g in groups():
        bpy.data.node_groups.remove(g)
    with monkeypatch.context() as mp:
        every_write(mp)
        slow = {name: dump(_library_tree(name)) for name in materials.LIBRARY}
        slow.update({f"tex {t}": dump(_texture_tree(t)) for t in BUILTINS})
        slow.update({g.name: dump(g) for g in groups()})
    assert set(fast) == set(slow)
    for name in fast:
        assert fast[name] == slow[name], name
    # the oracle is not vacuous: the graphs have their nodes placed apart and constants set
    concrete = fast["concrete"]["nodes"]
    assert len({loc for _, _, loc, _, _ in concrete.values()}) > 10
    assert len(concrete) > 20 and len(fast[library.COORDINATES_GROUP]["nodes"]) > 30


@pytest.mark.parametrize("current, value, same", [
    (0.5, 0.5, True), (0.1, 0.1, True), (0.5, 0.25, False), (0.5, 0.5001, False), (1e-6, 0.0, False), (1.0, 1, True), ("ADD", "ADD", True),
    ("ADD", "MULTIPLY", False), (False, False, True), (False, 0, False), (True, False, False),
    ((1.0, 2.0, 3.0), (1, 2, 3), True), ((1.0, 2.0, 3.0), (1.0, 2.0, 3.5), False),
    ((1.0, 1.0, 1.0, 1.0), (1.0, 1.0, 1.0), False), (None, object(), False)])
def test_a_write_is_skipped_only_when_it_changes_nothing(current, value, same):
    assert graph._same(current, value) is same


def test_rocks_get_an_icosphere_of_their_own():
    from blender_sesgen.scene.assets import nature
    V, F = nature._icosphere(4)
    assert V.shape == (2562, 3) and F.shape == (5120, 3)
    assert np.allclose(np.linalg.norm(V, axis=1), 1.0)
    V[:] = 0.0
    F[:] = 0
    V2, F2 = nature._icosphere(4)
    assert np.allclose(np.linalg.norm(V2, axis=1), 1.0) and F2.max() == 2561


def _render_library(tmp_path, shared: bool) -> np.ndarray:
    """Every library material on a cube of its own (per-object variation on), lit by a sun,
    2 samples at 96 x 64: the EXR's channels stacked."""
    from blender_sesgen.files.exr import read_exr
    scene = bpy.data.scenes.new(f"graph_test_{shared}")
    scene.render.engine = "CYCLES"
    c = scene.cycles
    c.device, c.samples, c.use_denoising, c.seed = "CPU", 2, False, 7
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 96, 64, 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    world = bpy.data.worlds.new(f"graph_test_{shared}")
    world.color = (0.3, 0.35, 0.4)
    scene.world = world
    sun = bpy.data.objects.new(f"sun_{shared}", bpy.data.lights.new(f"sun_{shared}", "SUN"))
    sun.rotation_euler = (0.7, 0.2, 0.5)
    sun.data.energy = 3.0
    scene.collection.objects.link(sun)
    names = sorted(materials.LIBRARY)
    cols = int(np.ceil(np.sqrt(len(names))))
    mesh = bpy.data.meshes.new(f"cube_{shared}")
    mesh.from_pydata([(x, y, z) for x in (-0.45, 0.45) for y in (-0.45, 0.45) for z in (-0.45, 0.45)], [],
                     [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)])
    for i, name in enumerate(names):
        mat = bpy.data.materials.new(f"lib_{name}_{shared}")
        nt = mat.node_tree
        nt.nodes.clear()
        out = nt.nodes.new("ShaderNodeOutputMaterial")
        m = library_material(name)   # its texture scale and relief away from their defaults
        m = dataclasses.replace(m, library=dataclasses.replace(m.library, scale=1.0 + 0.15 * (i % 4), bump=1.5))
        nt.links.new(library.build_shader(nt, m, (0.6, 0.5, 0.4), shared_parts=shared), out.inputs["Surface"])
        me = mesh.copy()
        me.materials.append(mat)
        obj = bpy.data.objects.new(f"cube_{name}_{shared}", me)
        obj.location = (i % cols - cols / 2, i // cols - cols / 2, 0.0)
        obj.rotation_euler = (0.3, 0.4, 0.1 * i)
        obj.scale = (1.0, 1.0 + 0.1 * (i % 3), 1.0)
        scene.collection.objects.link(obj)
        library.object_properties(obj, seed=3, object_id=i + 1)
    cam = bpy.data.objects.new(f"cam_{shared}", bpy.data.cameras.new(f"cam_{shared}"))
    cam.location = (0.0, -1.5, 1.2 * cols)
    cam.rotation_euler = (0.25, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.filepath = str(tmp_path / f"library_{shared}.exr")
    with bpy.context.temp_override(scene=scene):
        bpy.ops.render.render(write_still=True, scene=scene.name)
    ch = read_exr(scene.render.filepath)
    bpy.data.scenes.remove(scene)
    return np.stack([ch[k] for k in sorted(ch)])


@pytest.mark.render
def test_the_shared_groups_render_the_graph_written_inline(tmp_path):
    grouped = _render_library(tmp_path, True)
    inline = _render_library(tmp_path, False)
    assert grouped.shape == inline.shape and np.isfinite(grouped).all()
    assert float(grouped.std()) > 0.01            # the materials are seen, not a flat frame
    assert np.array_equal(grouped, inline)


def _sphere_means(tmp_path, names_colour) -> dict:
    """Mean linear luminance of a sphere per (library name or 'diffuse') in the given colour,
    each alone under a sun from behind the camera over a dark world (the street's side of a
    tube: lit by the sun, reflecting little), 16 samples at 64 x 64."""
    from blender_sesgen.files.exr import read_exr
    out = {}
    for key, (name, colour) in names_colour.items():
        scene = bpy.data.scenes.new(f"sphere_{key}")
        scene.render.engine = "CYCLES"
        c = scene.cycles
        c.device, c.samples, c.use_denoising, c.seed = "CPU", 16, False, 7
        scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 64, 100
        scene.render.image_settings.file_format = "OPEN_EXR"
        scene.render.image_settings.color_depth = "32"
        scene.render.film_transparent = True          # alpha 1 on the sphere only
        world = bpy.data.worlds.new(f"sphere_{key}")
        world.color = (0.03, 0.03, 0.03)
        scene.world = world
        sun = bpy.data.objects.new(f"sun_{key}", bpy.data.lights.new(f"sun_{key}", "SUN"))
        sun.rotation_euler = (0.5, 0.3, 0.0)
        sun.data.energy = 3.0
        scene.collection.objects.link(sun)
        mat = bpy.data.materials.new(f"m_{key}")
        nt = mat.node_tree
        nt.nodes.clear()
        o = nt.nodes.new("ShaderNodeOutputMaterial")
        if name == "diffuse":
            shader = nt.nodes.new("ShaderNodeBsdfDiffuse")
            shader.inputs["Color"].default_value = (*colour, 1.0)
            nt.links.new(shader.outputs[0], o.inputs["Surface"])
        else:
            m = library_material(name)
            nt.links.new(library.build_shader(nt, m, colour, shared_parts=False), o.inputs["Surface"])
        me = bpy.data.meshes.new(f"s_{key}")
        import bmesh
        bm = bmesh.new()
        bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=0.5)
        bm.to_mesh(me)
        bm.free()
        for p in me.polygons:
            p.use_smooth = True
        me.materials.append(mat)
        obj = bpy.data.objects.new(f"s_{key}", me)
        scene.collection.objects.link(obj)
        library.object_properties(obj, seed=3, object_id=1)
        cam = bpy.data.objects.new(f"cam_{key}", bpy.data.cameras.new(f"cam_{key}"))
        cam.location = (0.0, 0.0, 3.0)
        cam.data.lens = 50
        scene.collection.objects.link(cam)
        scene.camera = cam
        scene.render.filepath = str(tmp_path / f"sphere_{key}.exr")
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(write_still=True, scene=scene.name)
        ch = read_exr(scene.render.filepath)
        bpy.data.scenes.remove(scene)
        pick = lambda c: next(v for k, v in ch.items() if k == c or k.endswith("." + c))  # noqa: E731
        lum = 0.2126 * pick("R") + 0.7152 * pick("G") + 0.0722 * pick("B")
        alpha = pick("A")
        out[key] = float(lum[alpha > 0.99].mean())
    return out


@pytest.mark.render
def test_galvanised_steel_scatters_the_sun_as_its_albedo_where_a_mirror_metal_reflects_the_world(tmp_path):
    """Weathered galvanised tubes (scaffolds, fences) read light grey in the sun (KITTI
    sequence_1's scaffold against its wall), as a diffuse surface of their albedo; a mirror-
    like metal of the same colour (what the scaffold was made of) reads its dark surroundings."""
    grey = materials.entry("galvanised").colour
    m = _sphere_means(tmp_path, {"diffuse": ("diffuse", grey), "galvanised": ("galvanised", grey),
                                 "brushed": ("metal_brushed", grey)})
    assert 0.7 < m["galvanised"] / m["diffuse"] < 1.3, m
    assert m["brushed"] / m["diffuse"] < 0.6, m       # the oracle tells the two apart


def test_scaffolds_and_fences_are_galvanised_steel():
    from blender_sesgen.scene.assets import street_detail
    for make, size in ((street_detail.scaffold, (8.0, 6.0, 0.9)), (street_detail.site_fence, (7.0, 2.0, 0.3))):
        mats = {s.material for s in make(size, 3).surfaces}
        assert "galvanised" in mats and "metal_brushed" not in mats, (make.__name__, mats)
