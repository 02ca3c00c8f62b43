"""The add-on installed as an extension (bpy): install/enable/disable, Build, Render, errors.

Each test runs a child Python with ``BLENDER_USER_RESOURCES`` set to a fresh temporary
folder before ``import bpy`` (extension install state is process-global). The child
installs the built zip with ``bpy.ops.extensions.package_install_files``, drives the
add-on's operators and prints facts as JSON; the checks here compare those facts with the
scene model (parsed here by the pure core) and with independent statements of the
conventions in DESIGN.md.
"""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from blender_sesgen.contract import manifest as contract
from blender_sesgen.render.plan import RenderPlan
from blender_sesgen.addon import package
from blender_sesgen.ses import parse_file
from render_support import run_loaded
from raycast import euler_xyz_deg as R_xyz_deg  # the SES rule R = Rz @ Ry @ Rx, written independently

pytestmark = [pytest.mark.render,
              pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs the bpy wheel")]

REPO = Path(__file__).resolve().parents[1]
# the scene library's scripts (thousands of assets, millions of vertices) are left out: this
# test dumps every vertex of every object twice and would take many minutes each; they are
# checked by tests/test_scene_library.py (parsed, rigs and motions, rays cast from every
# camera at every frame against their meshes)
LIBRARY = {"city_kitti.ses", "office.ses", "forest.ses", "hall.ses",
           "city_loop.ses"}   # 2740 objects over 1679 frames: tests/test_city_grid.py and test_culling*.py check it
SCENES = sorted(p for p in (REPO / "scenes").glob("*.ses") if p.name not in LIBRARY)
MODULE = "bl_ext.user_default.blender_sesgen"
# SES world (Y up) -> Blender world (Z up): (x, y, z) -> (x, -z, y)   (DESIGN.md)
C_BLENDER_SES = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
FLIP_CV = np.diag([1.0, -1.0, -1.0, 1.0])  # Blender camera <-> OpenCV camera axes
TOL = 1e-5


def tol_f32(*values) -> float:
    """TOL, or a few float32 steps at the coordinates' magnitude where that is larger: Blender
    stores vertices and object matrices in float32 (a city of blocks has quads 515 m out)."""
    return max(TOL, 4 * float(np.finfo(np.float32).eps) * max(float(np.max(np.abs(v))) for v in values))

PRELUDE = """
import json, os, sys
import bpy
import numpy as np
ZIP = os.environ["SESGEN_TEST_ZIP"]
SESGEN_REPO = os.environ["SESGEN_TEST_REPO"]
r = bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)
assert r == {"FINISHED"}, r
MODULE = "bl_ext.user_default.blender_sesgen"
RESULT = {"install": sorted(r)}
def S():
    return bpy.context.scene.sesgen   # always re-fetch: a build replaces the SESGen scene
def call(op, **kw):
    try:
        return {"result": sorted(op(**kw)), "error": None}
    except RuntimeError as e:
        return {"result": None, "error": str(e)}
def panel(script=None, **values):   # the panel's settings: the script first (it may replace the scene), then values
    if script is not None:
        S().script_path = script
    s = S()
    for name, value in values.items():
        setattr(s, name, value)
    return s
MINIMAL = SESGEN_REPO + "/scenes/minimal.ses"
def counts():
    return {k: len(getattr(bpy.data, k)) for k in ("scenes", "objects", "meshes", "materials", "curves",
            "cameras", "lights", "node_groups", "collections", "worlds", "images", "actions")}
"""


@pytest.fixture(scope="module")
def addon_zip(tmp_path_factory) -> Path:
    return package.build_zip(tmp_path_factory.mktemp("dist"))


def run_child(body: str, zip_path: Path, tmp: Path) -> dict:
    user = tmp / "blender_user"
    user.mkdir(exist_ok=True)
    script = tmp / "child.py"
    script.write_text(PRELUDE + textwrap.dedent(body) + '\nprint("SESGEN_RESULT " + json.dumps(RESULT))\n')
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user), SESGEN_TEST_ZIP=str(zip_path), SESGEN_TEST_REPO=str(REPO))
    r = run_loaded([sys.executable, str(script)], 600, cwd=tmp, env=env)
    lines = [l for l in r.stdout.splitlines() if l.startswith("SESGEN_RESULT ")]
    assert r.returncode == 0 and lines, f"child failed (rc {r.returncode}):\n{r.stdout[-4000:]}\n{r.stderr[-4000:]}"
    return json.loads(lines[-1][len("SESGEN_RESULT "):])


def to_ses(P_blender) -> np.ndarray:
    return np.asarray(P_blender, dtype=float) @ C_BLENDER_SES  # row vectors: C^T p


# --- install, register, unregister -----------------------------------------------------

def test_blender_validates_the_zip(addon_zip):
    """Blender's own extension tool (``blender_ext.py validate``) accepts the zip."""
    bpy_dir = Path(importlib.util.find_spec("bpy").origin).parent
    tools = sorted(bpy_dir.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    assert tools, f"no blender_ext.py under {bpy_dir}"
    r = subprocess.run([sys.executable, str(tools[-1]), "validate", str(addon_zip)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_zip_installs_enables_and_disables_cleanly(addon_zip, tmp_path):
    res = run_child("""
        import addon_utils
        OPS = ["check", "build", "render", "open_output", "preview", "export", "import_ses", "verify", "study_run",
               "study_report"]
        PANELS = ["SESGEN_PT_main", "SESGEN_PT_render", "SESGEN_PT_preview", "SESGEN_PT_export", "SESGEN_PT_study"]
        def menu_funcs():
            return [getattr(f, "__module__", "") for f in getattr(bpy.types.TOPBAR_MT_file_import.draw, "_draw_funcs", [])]
        def state():
            ops = {}
            for o in OPS:
                try:
                    bpy.ops.sesgen.__getattr__(o).get_rna_type()
                    ops[o] = True
                except KeyError:
                    ops[o] = False
            return {"enabled": MODULE in bpy.context.preferences.addons,
                    "ops": ops, "op_classes": [c for c in dir(bpy.types) if c.startswith("SESGEN_")],
                    "panels": {p: hasattr(bpy.types, p) for p in PANELS},
                    "scene_prop": "sesgen" in bpy.types.Scene.bl_rna.properties,
                    "scene_attr": hasattr(bpy.types.Scene, "sesgen"),
                    "menu": [m for m in menu_funcs() if "blender_sesgen" in m],
                    "module_file": getattr(sys.modules.get(MODULE), "__file__", None)}
        RESULT["enabled"] = state()
        RESULT["defaults"] = {k: getattr(bpy.context.scene.sesgen, k) for k in ("samples", "resume", "device", "resolution_scale")}
        bpy.ops.preferences.addon_disable(module=MODULE)
        RESULT["disabled"] = state()
        bpy.ops.preferences.addon_enable(module=MODULE)
        RESULT["reenabled"] = state()
    """, addon_zip, tmp_path)
    assert res["install"] == ["FINISHED"]
    on = res["enabled"]
    assert on["enabled"] and all(on["ops"].values()), on["ops"]
    assert all(on["panels"].values()) and on["scene_prop"] and on["scene_attr"]
    assert len(on["menu"]) == 1
    assert "/extensions/user_default/blender_sesgen/" in on["module_file"].replace(os.sep, "/")
    assert res["defaults"] == {"samples": 16, "resume": True, "device": "cpu", "resolution_scale": 1.0}
    off = res["disabled"]
    assert not off["enabled"]
    assert not any(off["ops"].values()), off["ops"]
    assert off["op_classes"] == [] and not any(off["panels"].values())
    assert not off["scene_prop"] and not off["scene_attr"] and off["menu"] == []
    again = res["reenabled"]
    assert again["enabled"] and all(again["ops"].values()) and len(again["menu"]) == 1


def _doc_block(marker: str) -> str:
    """The fenced code block right after ``<!-- marker -->`` in docs/addon.md."""
    text = (REPO / "docs" / "addon.md").read_text(encoding="utf-8")
    after = text.split(f"<!-- {marker} -->", 1)[1]
    return after.split("```", 2)[1].split("\n", 1)[1]


def test_the_three_headless_lines_of_the_docs_install_enable_and_keep_the_addon(addon_zip, tmp_path):
    """docs/addon.md's three lines, run as written from a checkout with the built zip in dist/,
    install and enable the add-on; a later session that reads the saved preferences has it."""
    code = _doc_block("addon-install")
    assert len(code.strip().splitlines()) == 3, code
    (tmp_path / "dist").mkdir()
    (tmp_path / "dist" / addon_zip.name).write_bytes(addon_zip.read_bytes())
    (tmp_path / "install.py").write_text(code + 'print("OPS", hasattr(bpy.ops.sesgen, "check") and '
                                               'bool(bpy.ops.sesgen.check.get_rna_type()))\n')
    (tmp_path / "later.py").write_text("import bpy\nbpy.ops.wm.read_userpref()\n"
                                       f'print("ENABLED", {MODULE!r} in bpy.context.preferences.addons)\n'
                                       'print("OPS", bool(bpy.ops.sesgen.check.get_rna_type()))\n')
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    for script in ("install.py", "later.py"):
        r = subprocess.run([sys.executable, script], cwd=tmp_path, env=env, capture_output=True, text=True,
                           timeout=300)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        assert "OPS True" in r.stdout, (script, r.stdout[-3000:])
    assert "ENABLED True" in r.stdout
    assert (tmp_path / "user" / "extensions" / "user_default" / "blender_sesgen" / "__init__.py").is_file()


# --- Build --------------------------------------------------------------------------------

# The facts of building one script twice (a function of the child: one Blender builds every
# script in turn, as a user builds one after another; each build replaces the one before).
BUILD_FACTS = """
def build_facts(SCRIPT):
    RESULT = {}
    S().script_path = SCRIPT
    RESULT["build1"] = call(bpy.ops.sesgen.build)
    RESULT["counts1"] = counts()
    RESULT["build2"] = call(bpy.ops.sesgen.build)
    RESULT["counts2"] = counts()
    RESULT["window_scene"] = bpy.context.scene.name
    RESULT["panel_script"] = bpy.context.scene.sesgen.script_path
    sc = bpy.data.scenes["SESGen"]
    RESULT["frame_range"] = [sc.frame_start, sc.frame_end]
    RESULT["names"] = sorted(o.name for o in bpy.data.objects)
    objs = []
    for o in sc.objects:
        d = {"name": o.name, "type": o.type, "pass_index": o.pass_index, "hide_render": o.hide_render,
             "collections": [c.name for c in o.users_collection],
             "matrix_world": [list(r) for r in o.matrix_world]}
        if o.type == "MESH" and len(o.data.vertices):
            mw = np.array(o.matrix_world)
            v = np.array([tuple(x.co) for x in o.data.vertices])
            d["world_vertices"] = (v @ mw[:3, :3].T + mw[:3, 3]).tolist()
        if o.type == "MESH" and not len(o.data.vertices):   # a sphere: one point of a point cloud
            from importlib import import_module
            pts = import_module(MODULE + ".blender.compat").evaluated_points(o)  # 4.2+ and 5.0
            d["points"] = [list(c) for c, _ in pts]
            d["radius"] = [r for _, r in pts]
        if o.type == "CURVE":
            d["curve_points"] = [list(o.matrix_world @ p.co.xyz) for s in o.data.splines for p in s.points]
        if o.type == "CAMERA":
            d["poses"] = []                  # filled below: every camera's pose at each frame
            from importlib import import_module
            compat = import_module(MODULE + ".blender.compat")
            d["keys"] = [len(fc.keyframe_points) for fc in compat.object_fcurves(o)]
        objs.append(d)
    cameras = [(o, d) for o, d in zip(sc.objects, objs) if o.type == "CAMERA"]
    for f in range(sc.frame_start, sc.frame_end + 1):     # one pass over the frames for all cameras
        sc.frame_set(f)
        for o, d in cameras:
            d["poses"].append([list(r) for r in o.matrix_world])
    RESULT["objects"] = objs
    return RESULT
"""


@pytest.fixture(scope="module")
def builds(addon_zip, tmp_path_factory) -> dict:
    """{script path: the facts of building it twice}, every script of SCENES in one child."""
    scripts = [str(p) for p in SCENES]
    return run_child(BUILD_FACTS + f"RESULT = {{s: build_facts(s) for s in {scripts!r}}}\n", addon_zip,
                     tmp_path_factory.mktemp("builds"))


@pytest.mark.parametrize("script", SCENES, ids=[p.name for p in SCENES])
def test_build_creates_the_model_objects_rig_and_path(builds, script):
    res = builds[str(script)]
    model = parse_file(script)
    N = model.frames
    assert res["build1"]["error"] is None and res["build2"]["error"] is None
    assert res["counts1"] == res["counts2"], "rebuilding must replace, never duplicate"
    assert not any(n.endswith(".001") for n in res["names"])
    assert res["window_scene"] == "SESGen" and res["panel_script"] == str(script)
    assert res["frame_range"] == [0, N - 1]

    objs = res["objects"]
    by_id = {}
    for o in objs:
        if o["pass_index"]:
            by_id.setdefault(o["pass_index"], []).append(o)
    assert sorted(by_id) == sorted(o.id for o in model.objects), "pass_index = script id, one object each"
    for m in model.objects:
        (o,) = by_id[m.id]
        assert o["collections"] == ["SESGen objects"]
        if m.shape == "quad":
            np.testing.assert_allclose(to_ses(o["world_vertices"]), m.vertices, atol=tol_f32(m.vertices))
        elif m.shape == "cuboid":
            R = R_xyz_deg(*m.rotation_deg)
            half = np.array(m.size) / 2
            corners = [np.array(m.position) + R @ (half * s) for s in
                       np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T]
            got = to_ses(o["world_vertices"])
            assert len(got) == 8
            for c in corners:  # every expected corner is a vertex
                assert np.min(np.linalg.norm(got - c, axis=1)) < tol_f32(corners), (m.name, c)
        elif m.shape == "sphere":
            np.testing.assert_allclose(to_ses(o["points"]), [m.position], atol=tol_f32(m.position))
            np.testing.assert_allclose(o["radius"], [m.radius], rtol=1e-6)
        elif m.shape == "cylinder":
            R = R_xyz_deg(*m.rotation_deg)
            local = (to_ses(o["world_vertices"]) - np.array(m.position)) @ R  # rows: R^T (p - c)
            np.testing.assert_allclose(np.abs(local[:, 1]), m.height / 2, atol=tol_f32(m.position, m.height))
            np.testing.assert_allclose(np.hypot(local[:, 0], local[:, 2]), m.radius, atol=tol_f32(m.position, m.radius))
            assert len(local) >= 16

    cams = {o["name"]: o for o in objs if o["type"] == "CAMERA"}
    expected = RenderPlan.from_scene(model).view_poses
    assert sorted(cams) == sorted(f"SESGen_{v}" for v in expected)
    for view, T_expected in expected.items():
        cam = cams[f"SESGen_{view}"]
        assert cam["keys"] and all(k == N for k in cam["keys"]), cam["keys"]
        assert len(cam["poses"]) == N
        for k, M in enumerate(cam["poses"]):
            T = np.array(M) @ FLIP_CV                    # OpenCV camera in Blender's world
            T_ses = np.eye(4)
            T_ses[:3, :3] = C_BLENDER_SES.T @ T[:3, :3]
            T_ses[:3, 3] = C_BLENDER_SES.T @ T[:3, 3]
            np.testing.assert_allclose(T_ses, T_expected[k], atol=tol_f32(T_expected[k][:3, 3]),
                                       err_msg=f"{view} frame {k}")

    (path,) = [o for o in objs if o["type"] == "CURVE" and o["name"] == "SESGen camera path"]
    object_paths = sorted(o["name"] for o in objs if o["type"] == "CURVE" and o is not path)
    assert object_paths == sorted(f"SESGen path: {m.name}" for m in model.objects if m.id in model.moving_ids), \
        "one drawn path per moving object, none for static ones"
    assert path["hide_render"] and path["pass_index"] == 0
    centres = model.timeline.left()[:, :3, 3]
    np.testing.assert_allclose(to_ses(path["curve_points"]), centres, atol=tol_f32(centres))


# --- Moving objects and camera timing from the panel --------------------------------------------

MOVING_SCRIPT = """CAMERA resolution 48 32 focal 30 baseline 0.1
START position 0 1 4
QUAD id 1 texture 3 vertices -3 0 -2  3 0 -2  3 3 -2  -3 3 -2
CUBOID id 7 name car texture 4 position -1 0.5 0 dim 0.6 0.6 0.6
MOVE id 7 twist 0.2 0 0 0 10 0
FRAMES 4
"""


def test_build_draws_moving_objects_paths_and_render_takes_the_timing_override(addon_zip, tmp_path):
    script = tmp_path / "moving.ses"
    script.write_text(MOVING_SCRIPT)
    out = tmp_path / "out"
    res = run_child(f"""
        S().script_path = {str(script)!r}
        RESULT["build"] = call(bpy.ops.sesgen.build)
        paths = {{o.name: [list(p.co)[:3] for p in o.data.splines[0].points]
                 for o in bpy.data.objects if o.name.startswith("SESGen path: ")}}
        RESULT["paths"] = paths
        s = S()
        s.output_dir = {str(out)!r}
        s.override_render, s.samples = True, 1
        s.override_timing, s.rate_hz, s.exposure_ms = True, 10.0, 20.0
        RESULT["render"] = call(bpy.ops.sesgen.render)
    """, addon_zip, tmp_path)
    assert res["build"]["error"] is None and res["render"]["error"] is None
    assert list(res["paths"]) == ["SESGen path: car"]
    from blender_sesgen.ses import parse_file
    expected = parse_file(script).motion_of(7).poses()[:, :3, 3]          # SES world
    np.testing.assert_allclose(to_ses(res["paths"]["SESGen path: car"]), expected, atol=1e-5)
    m = json.loads((out / "manifest.json").read_text())
    assert m["fps"] == 10.0 and np.diff(m["timestamps"]) == pytest.approx([0.1] * 3)
    assert m["timing"]["exposure_s"] == pytest.approx(0.02)
    assert [o["id"] for o in m["objects"] if o.get("moving")] == [7]


def test_the_world_override_lights_the_build_and_the_render_with_a_bundled_hdri(addon_zip, tmp_path):
    script = tmp_path / "lit.ses"
    script.write_text(MOVING_SCRIPT.replace("FRAMES 4", "WORLD colour 0.2 0.2 0.2\nFRAMES 2"))
    out = tmp_path / "out"
    res = run_child(f"""
        s = S()
        s.script_path = {str(script)!r}
        s.world, s.world_strength, s.world_rotation = "sunset", 2.0, 30.0
        RESULT["build"] = call(bpy.ops.sesgen.build)
        world = bpy.data.scenes["SESGen"].world
        RESULT["images"] = [n.image.filepath for n in world.node_tree.nodes
                            if n.type == "TEX_ENVIRONMENT" and n.image is not None]
        s = S()
        s.output_dir = {str(out)!r}
        s.override_render, s.samples = True, 1
        RESULT["render"] = call(bpy.ops.sesgen.render)
    """, addon_zip, tmp_path)
    assert res["build"]["error"] is None and res["render"]["error"] is None
    assert [Path(p).stem for p in res["images"]] == ["sunset"], res["images"]
    rendered = (out / "scene.ses").read_text()
    assert "// WORLD colour 0.2 0.2 0.2" in rendered and "WORLD hdri sunset strength 2 rotation 30" in rendered
    from blender_sesgen.ses import parse_file
    w = parse_file(out / "scene.ses").world
    assert (w.kind, w.hdri, w.strength, w.rotation_deg) == ("hdri", "sunset", 2.0, 30.0)


# --- Verify: the output folder against its manifest ---------------------------------------------

def test_verify_operator_names_a_damaged_frame_and_resume_renders_it_again(addon_zip, tmp_path):
    out = tmp_path / "out"
    res = run_child(f"""
        import pathlib
        panel(MINIMAL, output_dir={str(out)!r}, override_render=True, samples=1, resolution_scale=0.5)
        RESULT["render"] = call(bpy.ops.sesgen.render)
        RESULT["clean"] = (call(bpy.ops.sesgen.verify), S().status)
        f = pathlib.Path({str(out)!r}) / "exr" / "left" / "000001.exr"
        f.write_bytes(f.read_bytes()[:2000])
        RESULT["damaged"] = (call(bpy.ops.sesgen.verify), S().status)
        S().resume = True
        RESULT["resumed"] = (call(bpy.ops.sesgen.render), S().status)
        RESULT["again"] = (call(bpy.ops.sesgen.verify), S().status)
    """, addon_zip, tmp_path)
    assert res["render"]["error"] is None
    assert res["clean"][0]["error"] is None and res["clean"][1].startswith("verified")
    assert res["damaged"][0]["error"] is None and "1 bad frame(s) (1:" in res["damaged"][1]
    assert "truncated" in res["damaged"][1]
    assert res["resumed"][0]["error"] is None and res["resumed"][1].startswith("rendered 1 frame(s)")
    assert res["again"][1].startswith("verified")


# --- Render (the execute path: every frame synchronously, through RenderJob) -----------------

def test_render_operator_writes_the_output_contract_and_preview(addon_zip, tmp_path):
    out = tmp_path / "out"
    res = run_child(f"""
        panel(MINIMAL, output_dir={str(out)!r}, use_frame_range=True, frame_first=0, frame_stop=2, override_render=True,
              samples=1, seed=3, resolution_scale=0.5)
        RESULT["render"] = call(bpy.ops.sesgen.render)
        RESULT["status"] = S().status
        RESULT["progress"] = S().progress
        previews = {{}}
        for kind in ("segmentation", "disparity", "depth", "rgb"):
            S().preview_kind = kind
            S().preview_view = "right" if kind == "disparity" else "left"
            S().preview_frame = 1
            r = call(bpy.ops.sesgen.preview)
            img = bpy.data.images["SESGen preview"]
            px = np.empty(len(img.pixels), dtype=np.float32)
            img.pixels.foreach_get(px)
            previews[kind] = {{"call": r, "size": list(img.size), "text": img["sesgen_preview"],
                              "pixels": np.flipud(px.reshape(img.size[1], img.size[0], 4)).round(5).tolist()}}
        S().preview_frame = 2
        previews["not_rendered"] = call(bpy.ops.sesgen.preview)
        RESULT["previews"] = previews
    """, addon_zip, tmp_path)
    assert res["render"] == {"result": ["FINISHED"], "error": None}
    assert res["status"].startswith("rendered 2 frame(s)") and res["progress"] == 1.0

    m = json.loads((out / "manifest.json").read_text())
    for key in ("format", "generator", "scene_sha256", "resolution", "K", "baseline", "near", "far", "frames",
                "views", "depth", "segmentation", "channels", "objects", "poses", "trajectories", "files",
                "frames_complete", "render"):
        assert key in m, key
    assert m["format"] == contract.FORMAT
    assert m["resolution"] == [32, 24] and m["frames"] == 3 and m["views"] == ["left", "right"]
    assert m["frames_complete"] == [True, True, False]
    assert m["render"]["samples"] == 1 and m["render"]["seed"] == 3 and m["render"]["resolution_scale"] == 0.5
    assert (out / "scene.ses").read_text() == (REPO / "scenes" / "minimal.ses").read_text()
    for v in m["views"]:
        assert (out / m["trajectories"]["tum"][v]).is_file() and (out / m["trajectories"]["kitti"][v]).is_file()
        for k in (0, 1):
            assert (out / m["files"][v][k]).is_file()
        assert not (out / m["files"][v][2]).exists()
    assert not [p for p in out.rglob("*") if ".tmp-" in p.name]

    # the EXRs hold the contract's channels; read them with the OpenEXR package (independent reader)
    OpenEXR = pytest.importorskip("OpenEXR")
    ids_seen = {}
    for v in m["views"]:
        chans = {}
        with OpenEXR.File(str(out / m["files"][v][1]), separate_channels=True) as f:
            for part in f.parts:
                chans.update({n: c.pixels for n, c in part.channels.items()})
        for n in (*m["channels"]["rgb"], m["channels"]["depth"], m["channels"]["object_index"]):
            assert n in chans and chans[n].shape == (24, 32), n
        ids_seen[v] = np.rint(chans[m["channels"]["object_index"]]).astype(int)
        z = chans[m["channels"]["depth"]]
        assert np.all(z > 0)
        if v == "right":
            z_right = z
    assert set(np.unique(ids_seen["left"])) <= {0, 1, 2, 3, 4, 5}

    # the same images as the command line with the same settings (one code path: RenderJob)
    cli_out = tmp_path / "cli"
    r = subprocess.run([sys.executable, "-m", "blender_sesgen", "render", str(REPO / "scenes" / "minimal.ses"),
                        "--out", str(cli_out), "--frames", "0:2", "--samples", "1", "--seed", "3",
                        "--resolution-scale", "0.5", "--quiet"], cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    m_cli = json.loads((cli_out / "manifest.json").read_text())
    assert m_cli["poses"] == m["poses"] and m_cli["K"] == m["K"] and m_cli["frames_complete"] == m["frames_complete"]
    for v in m["views"]:
        for k in (0, 1):
            a, b = {}, {}
            for path, d in ((out / m["files"][v][k], a), (cli_out / m["files"][v][k], b)):
                with OpenEXR.File(str(path), separate_channels=True) as f:
                    for part in f.parts:
                        d.update({n: c.pixels.copy() for n, c in part.channels.items()})
            assert a.keys() == b.keys()
            for n in a:
                np.testing.assert_array_equal(a[n], b[n], err_msg=f"{v} {k} {n}")

    pv = res["previews"]
    for kind in ("segmentation", "disparity", "depth", "rgb"):
        assert pv[kind]["call"]["error"] is None, pv[kind]
        assert pv[kind]["size"] == [32, 24]
    # segmentation preview: a colour per id, one id per colour, background black
    seg = np.array(pv["segmentation"]["pixels"])[..., :3]
    ids = ids_seen["left"]
    colour_of = {}
    for i in np.unique(ids):
        cols = np.unique(seg[ids == i].reshape(-1, 3), axis=0)
        assert len(cols) == 1, f"id {i} drawn in {len(cols)} colours"
        colour_of[int(i)] = tuple(cols[0])
    assert len(set(colour_of.values())) == len(colour_of)
    if 0 in colour_of:
        assert colour_of[0] == (0, 0, 0)
    assert "ids [" in pv["segmentation"]["text"]
    # disparity preview of the right view: its scale is the largest f*B/Z of that view
    d_max = m["K"][0][0] * m["baseline"] / z_right[z_right < 1e9].min()
    assert f"0..{d_max:.2f} px" in pv["disparity"]["text"]
    assert "not rendered" in pv["not_rendered"]["error"]


def test_export_operator_writes_a_dataset_layout_through_vo_reference(addon_zip, tmp_path):
    """Render two frames, then Export Dataset: the add-on runs vo-reference (here this test's
    Python, which has vo_reference) and reports its result; a missing tool is a clear error."""
    out, ds = tmp_path / "out", tmp_path / "dataset"
    res = run_child(f"""
        panel(MINIMAL, output_dir={str(out)!r}, use_frame_range=True, frame_first=0, frame_stop=2, override_render=True,
              samples=1, resolution_scale=0.5)
        RESULT["render"] = call(bpy.ops.sesgen.render)
        s = S()
        s.export_target, s.export_dir, s.export_sequence = "tartanair", {str(ds)!r}, "room/Easy/P000"
        s.vo_command = {f"{sys.executable} -m vo_reference"!r}
        RESULT["export"] = call(bpy.ops.sesgen.export)
        RESULT["status"], RESULT["progress"] = S().status, S().progress
        S().export_target, S().export_sequence = "kitti-odometry", "05"
        RESULT["kitti"] = call(bpy.ops.sesgen.export)
        S().vo_command = {str(tmp_path / "no-such-tool")!r}
        RESULT["missing"] = call(bpy.ops.sesgen.export)
        S().vo_command, S().export_target = {f"{sys.executable} -m vo_reference"!r}, "tum"
        RESULT["no_slot"] = call(bpy.ops.sesgen.export)
    """, addon_zip, tmp_path)
    assert res["render"]["error"] is None
    assert res["export"] == {"result": ["FINISHED"], "error": None}
    assert res["status"].startswith("exported") and res["progress"] == 1.0
    seq = ds / "room/Easy/P000"
    assert sorted(p.name for p in (seq / "image_left").iterdir()) == ["000000_left.png", "000001_left.png"]
    assert (seq / "flow/000000_000001_flow.npy").is_file() and len((seq / "pose_left.txt").read_text().splitlines()) == 2
    assert res["kitti"]["error"] is None and (ds / "dataset/poses/05.txt").is_file()
    assert res["missing"]["result"] is None and "pip install 'blender-sesgen[vo]'" in res["missing"]["error"]
    assert res["no_slot"]["result"] is None and "no sequence slot" in res["no_slot"]["error"]


# The study command the Study panel runs here: `sesgen study run ... --no-ray` (its tasks from the
# study's own process, farm.local): the panel's part is the same, and the study on a local Ray is
# tests/test_study_render.py's (a Ray start costs ~10 CPU s).
NO_RAY_STUDY = f"sh -c 'exec \"$0\" -m blender_sesgen \"$@\" --no-ray' {sys.executable}"


@pytest.mark.slow
def test_study_operator_runs_a_one_factor_study_and_finds_its_report(addon_zip, tmp_path):
    """The Study panel: a factor and its levels for the open script, Run Study (the add-on runs
    `sesgen study run` -- here this test's Python, which has Ray and vo_reference -- as a child
    process), then the report; a level that is not one is an error in the status line."""
    out = tmp_path / "study"
    res = run_child(f"""
        S().script_path = {str(REPO / 'scenes' / 'minimal.ses')!r}
        s = S()
        s.study_factor, s.study_levels, s.study_systems = "gain", "4", "accurate-stereo"
        s.study_resolution, s.study_dir = 1.0, {str(out)!r}
        s.study_command = {NO_RAY_STUDY!r}
        RESULT["run"] = call(bpy.ops.sesgen.study_run)
        RESULT["status"], RESULT["progress"] = S().status, S().progress
        RESULT["report_ready"] = bpy.ops.sesgen.study_report.poll()
        S().study_levels = "loud"
        RESULT["bad"] = call(bpy.ops.sesgen.study_run)
        RESULT["bad_status"] = S().status
    """, addon_zip, tmp_path)
    assert res["run"] == {"result": ["FINISHED"], "error": None}, res
    assert res["status"].startswith("study minimal-gain: 2 run(s)") and res["progress"] == 1.0
    assert res["report_ready"] and (out / "report.html").is_file()
    doc = json.loads((out / "results.json").read_text())
    assert [v["point"] for v in doc["variants"]] == [{}, {"gain": 4}] and doc["cost"]["developed"] == 1
    # the system really ran on both variants: a study whose runs all failed also writes its report
    assert len(doc["runs"]) == 2 and all(r["status"] == "ok" and r["metrics"]["ape_trans_rmse"] < 0.05
                                         for r in doc["runs"]), [(r["status"], r.get("metrics")) for r in doc["runs"]]
    assert res["bad"]["result"] is None and "numbers" in res["bad"]["error"] and res["bad_status"].startswith("Error")


def test_cancel_leaves_a_resumable_folder_and_resume_completes_it(addon_zip, tmp_path):
    out = tmp_path / "out"
    res = run_child(f"""
        from importlib import import_module
        session = import_module(MODULE + ".addon.session")
        panel(MINIMAL, output_dir={str(out)!r}, override_render=True, samples=1, resolution_scale=0.5)
        # what the modal operator does: one step per timer tick, then ESC
        run = session.RenderSession.start(bpy.context, session.read_settings(bpy.context))
        RESULT["todo"] = list(run.todo)
        run.step()
        RESULT["cancel"] = run.cancel()
        RESULT["active_after_cancel"] = session.RenderSession.active is not None
        RESULT["manifest_after_cancel"] = json.load(open(os.path.join({str(out)!r}, "manifest.json")))["frames_complete"]
        RESULT["mtime0"] = os.path.getmtime(os.path.join({str(out)!r}, "exr/left/000000.exr"))
        RESULT["resume"] = call(bpy.ops.sesgen.render)
        RESULT["status"] = S().status
        RESULT["mtime0_after"] = os.path.getmtime(os.path.join({str(out)!r}, "exr/left/000000.exr"))
        RESULT["again"] = call(bpy.ops.sesgen.render)
        RESULT["status_again"] = S().status
    """, addon_zip, tmp_path)
    assert res["todo"] == [0, 1, 2]
    assert "cancelled after 1 of 3" in res["cancel"] and not res["active_after_cancel"]
    assert res["manifest_after_cancel"] == [True, False, False]
    assert res["resume"]["error"] is None and res["status"].startswith("rendered 2 frame(s)")
    assert res["mtime0_after"] == res["mtime0"], "resume must not re-render complete frames"
    m = json.loads((out / "manifest.json").read_text())
    assert m["frames_complete"] == [True, True, True]
    assert all((out / m["files"][v][k]).is_file() for v in m["views"] for k in range(3))
    assert res["again"]["error"] is None and res["status_again"].startswith("nothing to render")


# --- errors ------------------------------------------------------------------------------------

BAD = "CAMERA resolution 64 48 focal 40\nSTART position 0 1 3\nCUBOID id 1 position 0 0 0 dim 1 1\nEGO 0 0 0.1 0 0 0\n"


def test_bad_script_reports_its_line_and_creates_nothing(addon_zip, tmp_path):
    bad = tmp_path / "bad.ses"
    bad.write_text(BAD)
    out = tmp_path / "out"
    res = run_child(f"""
        before = counts()
        S().script_path = {str(bad)!r}
        S().output_dir = {str(out)!r}
        RESULT["build"] = call(bpy.ops.sesgen.build)
        RESULT["status"] = S().status
        RESULT["render"] = call(bpy.ops.sesgen.render)
        RESULT["import"] = call(bpy.ops.sesgen.import_ses, filepath={str(bad)!r})
        RESULT["check"] = call(bpy.ops.sesgen.check)
        RESULT["unchanged"] = counts() == before
        RESULT["scenes"] = [s.name for s in bpy.data.scenes]
        # a good script with an output folder that holds something else: refused, nothing touched
        S().script_path = {str(REPO / 'scenes' / 'minimal.ses')!r}
        os.makedirs({str(out)!r}); open(os.path.join({str(out)!r}, "notes.txt"), "w").write("mine")
        RESULT["foreign"] = call(bpy.ops.sesgen.render)
        RESULT["out_files"] = sorted(os.listdir({str(out)!r}))
    """, addon_zip, tmp_path)
    for op in ("build", "render", "import", "check"):
        err = res[op]["error"]
        assert err is not None, op
        assert f"{bad}:3:" in err and "dim" in err, (op, err)
    assert res["status"].startswith("Error: line 3:")
    assert res["unchanged"] and res["scenes"] == ["Scene"]
    assert not (out / "manifest.json").exists()
    assert res["foreign"]["error"] is not None and "not empty" in res["foreign"]["error"]
    assert res["out_files"] == ["notes.txt"]


# The two UI-only tests draw the panels (a recording layout, no window) in one Blender child:
# they test what is drawn, not the process (which the tests above start afresh each time).
# The labels are recorded after the panel checks, each with its own recording layout.

def _panels_body(bad: Path) -> str:
    return f"""
        from importlib import import_module
        ui = import_module(MODULE + ".addon.ui")
        problems, drawn = [], []
        class Layout:
            def __init__(self): self.__dict__["attrs"] = {{}}
            def __setattr__(self, k, v): self.attrs[k] = v
            def __getattr__(self, k): return self.attrs.get(k, False)
            def row(self, **kw): return Layout()
            def column(self, **kw): return Layout()
            def box(self): return Layout()
            def label(self, text="", icon="NONE"): drawn.append(text)
            def progress(self, **kw): drawn.append("progress")
            def prop(self, data, name, **kw):
                if name not in data.bl_rna.properties: problems.append("prop " + name)
            def operator(self, idname, **kw):
                mod, op = idname.split(".")
                try:
                    getattr(getattr(bpy.ops, mod), op).get_rna_type()
                except KeyError:
                    problems.append("operator " + idname)
        class Self: pass
        def draw_all(tag):
            for cls in ui.CLASSES:
                me = Self(); me.layout = Layout()
                cls.draw(me, bpy.context)
            RESULT[tag] = list(drawn); drawn.clear()
        draw_all("empty")
        S().script_path = {str(REPO / 'scenes' / 'minimal.ses')!r}
        draw_all("ok")
        S().script_path = {str(bad)!r}
        draw_all("error")
        RESULT["problems"] = problems
    """


LABELS_BODY = """
        from importlib import import_module
        ui = import_module(MODULE + ".addon.ui")
        labels, choices = set(), set()
        class Layout:
            def __init__(self): self.__dict__["attrs"] = {}
            def __setattr__(self, k, v): self.attrs[k] = v
            def __getattr__(self, k): return self.attrs.get(k, False)
            def row(self, **kw): return Layout()
            def column(self, heading="", **kw):
                labels.add(heading)
                return Layout()
            def box(self): return Layout()
            def label(self, text="", icon="NONE"): pass        # status lines, not labels
            def progress(self, **kw): pass
            def prop(self, data, name, text=None, **kw):
                p = data.bl_rna.properties[name]
                labels.add(p.name if text is None else text)
                if p.type == "ENUM":
                    choices.update(item.name for item in p.enum_items)
            def operator(self, idname, text=None, **kw):
                mod, op = idname.split(".")
                labels.add(getattr(getattr(bpy.ops, mod), op).get_rna_type().name if text is None else text)
        class Self: pass
        S().script_path = """ + repr(str(REPO / "scenes" / "minimal.ses")) + """
        for cls in ui.CLASSES:
            labels.add(cls.bl_label)
            me = Self(); me.layout = Layout()
            cls.draw(me, bpy.context)
        labels.add(bpy.ops.sesgen.import_ses.get_rna_type().name)
        RESULT["labels"], RESULT["choices"] = sorted(labels - {""}), sorted(choices)
"""


@pytest.fixture(scope="module")
def drawn(addon_zip, tmp_path_factory) -> dict:
    """What the panels draw (``_panels_body``), then the labels and choices they show
    (``LABELS_BODY``), from one child."""
    tmp = tmp_path_factory.mktemp("ui")
    bad = tmp / "bad.ses"
    bad.write_text(BAD)
    return run_child(textwrap.dedent(_panels_body(bad)) + textwrap.dedent(LABELS_BODY), addon_zip, tmp)


def test_panels_draw_with_real_properties_and_operators(drawn):
    """Each panel's draw() runs against a recording layout that checks every property and
    operator it names exists (no window needed)."""
    res = drawn
    assert res["problems"] == []
    assert "Choose an .ses script" in res["empty"]
    assert "Script OK" in res["ok"] and any(t.startswith("Objects: 5") for t in res["ok"])
    assert any(t.startswith("line 3:") and "dim" in t for t in res["error"])


def test_every_label_the_panels_show_is_in_the_addon_docs(drawn):
    """Panels, headings, checkboxes, fields and buttons as drawn (a recording layout, no window)
    each appear in docs/addon.md as **Label** (a panel as its section's heading); every choice
    of a drop-down appears there too."""
    res = drawn
    doc = " ".join((REPO / "docs" / "addon.md").read_text(encoding="utf-8").split())  # line breaks are spaces
    assert {"SES Scene", "Render", "Render Sequence", "Stop", "Layout"} <= set(res["labels"])
    missing = [x for x in res["labels"] if f"**{x}**" not in doc and f"### {x} " not in doc]
    assert missing == [], " / ".join(missing)
    missing = [x for x in res["choices"] if x not in doc]
    assert missing == [], " / ".join(missing)
