"""Bring your own world: a glTF's and an OBJ's own materials and textures are kept; a
.blend file's objects load with exact ids and classes and never run the file's scripts.

The files are written here with bpy (in a child process) or by hand; the renders are
checked against the analytic ray caster of tests/raycast.py and the textures' colours.
"""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import raycast
from render_support import depth_and_ids, load_manifest, read_exr, rendered, run_render
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")


def _bpy(tmp_path: Path, code: str) -> None:
    script = tmp_path / "make.py"
    script.write_text(textwrap.dedent(code))
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr


MAKE_TEXTURED_PLANE = """
    import bpy, numpy as np
    bpy.ops.wm.read_factory_settings(use_empty=True)
    img = bpy.data.images.new("rg", 8, 8)
    px = np.zeros((8, 8, 4), np.float32); px[..., 3] = 1
    px[:, :4, 0] = 0.8   # left half (u < 0.5) red
    px[:, 4:, 1] = 0.8   # right half green
    img.pixels.foreach_set(px.ravel()); import os; img.filepath_raw = os.path.abspath("rg.png"); img.file_format = "PNG"; img.save()
    me = bpy.data.meshes.new("plane")
    me.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    uv = me.uv_layers.new(name="UVMap")
    uv.data.foreach_set("uv", [0, 0, 1, 0, 1, 1, 0, 1])
    mat = bpy.data.materials.new("rg"); nt = mat.node_tree
    bsdf = nt.nodes["Principled BSDF"]; tex = nt.nodes.new("ShaderNodeTexImage"); tex.image = img
    nt.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
    me.materials.append(mat)
    ob = bpy.data.objects.new("plane", me); bpy.context.scene.collection.objects.link(ob)
    bpy.ops.export_scene.gltf(filepath="plane.glb", export_format="GLB")
"""


def _halves(tmp_path, mesh_line: str, start: str = "0 0 3") -> tuple[np.ndarray, np.ndarray]:
    script = tmp_path / "s.ses"
    script.write_text(f"CAMERA resolution 40 20 focal 30 baseline 0\nSTART position {start}\n"
                      "WORLD colour 1 1 1\nLOOK exposure 0\n" + mesh_line + "\n")
    rendered(script, tmp_path / "out", "--samples", "4", here=True)
    m = load_manifest(tmp_path / "out")
    ch = read_exr(tmp_path / "out" / m["files"]["left"][0])
    rgb = np.stack([ch[c] for c in m["channels"]["rgb"][:3]], -1)
    return rgb[6:14, 8:16].reshape(-1, 3).mean(0), rgb[6:14, 24:32].reshape(-1, 3).mean(0)


def test_gltf_keeps_its_own_textured_material(tmp_path):
    _bpy(tmp_path, MAKE_TEXTURED_PLANE)
    # the exporter writes Blender's z-up plane as a y-up glTF: a floor, seen from above
    left, right = _halves(tmp_path, "MESH id 1 file plane.glb", start="0 3 0 -90 0 0")
    assert left[0] > 2 * left[1] and right[1] > 2 * right[0], (left, right)   # (+ a white specular)


def test_obj_keeps_its_mtl_texture(tmp_path):
    _bpy(tmp_path, MAKE_TEXTURED_PLANE.split('    me = bpy.data.meshes.new("plane")')[0])
    (tmp_path / "plane.mtl").write_text("newmtl rg\nKd 1 1 1\nmap_Kd rg.png\n")
    (tmp_path / "plane.obj").write_text("mtllib plane.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                                        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl rg\nf 1/1 2/2 3/3 4/4\n")
    left, right = _halves(tmp_path, "MESH id 1 file plane.obj")
    assert left[0] > 2 * left[1] and right[1] > 2 * right[0], (left, right)   # (+ a white specular)


MAKE_BLEND = """
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    def box(name, loc, size):
        bpy.ops.mesh.primitive_cube_add(size=1, location=loc)
        ob = bpy.context.object; ob.name = name; ob.scale = size
        return ob
    a = box("Box", (1.0, 3.0, 0.5), (1.0, 1.0, 1.0)); a["sesgen_id"] = 40
    box("Box2", (-1.2, 2.0, 0.4), (0.8, 0.6, 0.8))
    bpy.ops.mesh.primitive_plane_add(size=8, location=(0, 2, 0)); f = bpy.context.object
    f.name = "Floor"; f["sesgen_class"] = "road"
    bpy.ops.object.camera_add(location=(0, 5, 1))       # not a mesh: left out
    t = bpy.data.texts.new("evil.py")
    t.write("open(r'MARKER', 'w').write('ran')\\n"); t.use_module = True
    bpy.ops.wm.save_as_mainfile(filepath="env.blend")
"""


@pytest.mark.parametrize("quality", ["final", "gt"])
def test_blend_environment_loads_with_ids_classes_and_no_scripts(tmp_path, quality):
    """Also under ``--quality gt``, whose flat shading colours the file's objects too (it
    once looked their ids up among the script's objects only and failed every BLEND)."""
    marker = tmp_path / "ran.txt"
    _bpy(tmp_path, MAKE_BLEND.replace("MARKER", str(marker)))
    script = tmp_path / "s.ses"
    script.write_text("CAMERA resolution 80 60 focal 60 baseline 0.2\nSTART position 0.3 1.4 2.5 -20 0 0\n"
                      "BLEND file env.blend id 100 class building position 0.5 0 0\n"
                      "SPHERE id 100 position 0 -50 0 dim 0.5\n"    # takes id 100: the file's get 101, ...
                      "LIGHT sun direction -0.3 -1 -0.2\n")
    r = run_render(script, "--out", tmp_path / "out", "--samples", "1", "--quiet", "--quality", quality)
    assert r.returncode == 0, r.stderr
    assert not marker.exists(), "a script stored in the .blend ran"
    m = load_manifest(tmp_path / "out")
    rows = {o["name"]: o for o in m["objects"]}
    assert (rows["Box"]["id"], rows["Box2"]["id"], rows["Floor"]["id"]) == (40, 101, 102)
    assert (rows["Box"]["class"], rows["Box2"]["class"], rows["Floor"]["class"]) == ("building", "building", "road")
    assert rows["Floor"]["label_id"] == 7 and rows["Box2"]["shape"] == "blend"

    def ses(p_blender):  # Blender (x, y, z) -> SES (x, z, -y), then the statement's shift
        x, y, z = p_blender
        return np.array([x + 0.5, z, -y])
    prims = [raycast.BoxP(40, ses((1.0, 3.0, 0.5)), (0, 0, 0), np.array([1.0, 1.0, 1.0])),
             raycast.BoxP(101, ses((-1.2, 2.0, 0.4)), (0, 0, 0), np.array([0.8, 0.8, 0.6])),
             raycast.QuadP(102, np.array([ses(p) for p in ((-4, -2, 0), (4, -2, 0), (4, 6, 0), (-4, 6, 0))]))]
    W, H = m["resolution"]
    for view in m["views"]:
        depth, ids = depth_and_ids(read_exr(tmp_path / "out" / m["files"][view][0]), m)
        z_true, id_true, near = raycast.render_truth(prims, m["K"], m["poses"][view][0], W, H)
        assert {40, 101, 102} <= set(np.unique(id_true))
        assert ((ids != id_true) & ~near).sum() == 0
        hit = (id_true > 0) & ~near
        assert (np.abs(depth - z_true) / np.where(hit, z_true, 1))[hit].max() <= 2e-4


def test_blend_errors_are_reported_before_anything_is_written(tmp_path):
    (tmp_path / "fake.blend").write_text("not a blend")
    script = tmp_path / "s.ses"
    script.write_text("BLEND file fake.blend id 1\n")
    r = run_render(script, "--out", tmp_path / "out", "--quiet")
    assert r.returncode == 2 and "s.ses:1:12: error: BLEND 'file' 'fake.blend' is not a Blender file" in r.stderr
    assert not (tmp_path / "out").exists()
    _bpy(tmp_path, MAKE_BLEND.replace("MARKER", str(tmp_path / "m")))
    script.write_text("BLEND file env.blend id 1 collection Props\n")
    r = run_render(script, "--out", tmp_path / "out", "--quiet")
    assert r.returncode == 2 and "no collection 'Props'" in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()
    script.write_text("CUBOID id 40 position 0 0 0 dim 1 1 1\nBLEND file env.blend id 1\n")
    r = run_render(script, "--out", tmp_path / "out", "--quiet")
    assert r.returncode == 2 and "sesgen_id 40" in r.stderr, r.stderr
    assert not (tmp_path / "out").exists()




MAKE_BLEND_WITH_IMAGE = """
    import bpy, os
    bpy.ops.wm.read_factory_settings(use_empty=True)
    os.makedirs("outside", exist_ok=True); os.makedirs("env", exist_ok=True)
    img = bpy.data.images.new("tex", 4, 4); img.filepath_raw = os.path.abspath("outside/tex.png")
    img.file_format = "PNG"; img.save()
    mat = bpy.data.materials.new("m"); nt = mat.node_tree
    tex = nt.nodes.new("ShaderNodeTexImage"); tex.image = img
    nt.links.new(tex.outputs["Color"], nt.nodes["Principled BSDF"].inputs["Base Color"])
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 3, 0.5)); bpy.context.object.data.materials.append(mat)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath("env/env.blend"), relative_remap=True)
"""


def test_blend_images_outside_its_folder_are_refused_unless_allowed(tmp_path):
    """Like a MESH model's references (ses/mesh_files.py): a .blend's image that lies outside
    its folder is refused (exit 2, nothing written) unless the statement says allow_external;
    then a corrupt image is still refused (decoded by image_check)."""
    _bpy(tmp_path, MAKE_BLEND_WITH_IMAGE)
    script = tmp_path / "s.ses"
    script.write_text("CAMERA resolution 16 12 focal 12\nBLEND file env/env.blend id 1\n")
    r = run_render(script, "--out", tmp_path / "out", "--samples", "1", "--quiet")
    assert r.returncode == 2 and "lies outside the file's folder" in r.stderr and "allow_external" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and not (tmp_path / "out").exists()
    script.write_text("CAMERA resolution 16 12 focal 12\nBLEND file env/env.blend id 1 allow_external\n")
    rendered(script, tmp_path / "out", "--samples", "1")
    (tmp_path / "outside" / "tex.png").write_bytes((tmp_path / "outside" / "tex.png").read_bytes()[:40])
    r = run_render(script, "--out", tmp_path / "out2", "--samples", "1", "--quiet")
    assert r.returncode == 2 and "is not a usable image" in r.stderr, r.stderr
    assert not (tmp_path / "out2").exists()
