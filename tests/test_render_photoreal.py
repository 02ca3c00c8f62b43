"""The photoreal engine against independent oracles (Cycles, tiny images, few samples).

- ground truth stays exact with library materials (bump never moves geometry) under an
  HDRI: the analytic ray caster of tests/raycast.py on the oracle scene;
- every library material sticks to its surface (the right view is the left one shifted by
  the disparity) and has moderate, not extreme, contrast;
- the HDRI's rotation follows the documented rule (a turned world seen by a camera turned
  the same way is the same picture);
- the display-referred PNGs exist, are the view transform of the linear EXR (AgX is not
  sRGB) and are what vo_reference reads;
- semantic classes reach the manifest and the Cityscapes export (label ids computed here
  from the script's classes and the published label table).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

import raycast
from render_support import (ORACLE_PRIMS, depth_and_ids, load_manifest, oracle_script, read_exr,
                            render_text, rendered, run_render)
from markers import needs

pytestmark = [pytest.mark.render, needs("bpy")]
pytest.importorskip("OpenEXR")

LIBRARY_ORACLE = {1: "asphalt", 2: "brick", 3: "glass_window", 4: "metal_rusty", 5: "wood_planks", 6: "leaves"}


def test_library_materials_under_an_hdri_keep_depth_and_ids_exact(tmp_path):
    script = tmp_path / "oracle.ses"
    script.write_text(oracle_script(materials=LIBRARY_ORACLE, extra_lines=["WORLD hdri city rotation 40"]))
    out = tmp_path / "out"
    rendered(script, out, "--samples", "1", "--no-denoise", here=True)    # depth and ids: the denoiser does not touch them
    m = load_manifest(out)
    W, H = m["resolution"]
    spheres = {p.id for p in ORACLE_PRIMS if isinstance(p, raycast.SphereP)}
    for view in m["views"]:
        for k in range(m["frames"]):
            depth, ids = depth_and_ids(read_exr(out / m["files"][view][k]), m)
            z_true, id_true, near_edge = raycast.render_truth(ORACLE_PRIMS, m["K"], m["poses"][view][k], W, H)
            assert ((ids != id_true) & ~near_edge).sum() == 0, f"{view} {k}: id mismatches"
            hit = (id_true > 0) & ~near_edge
            rel = np.abs(depth - z_true) / np.where(hit, z_true, 1.0)
            flat = hit & ~np.isin(id_true, list(spheres))
            assert rel[flat].mean() <= 3e-5 and rel[flat].max() <= 2e-4, f"{view} {k}: {rel[flat].max():.2e}"
            assert rel[hit].max() <= 1e-3
            assert np.all(depth[(id_true == 0) & ~near_edge] == m["depth"]["background"])
    assert [o["material"] for o in m["objects"]] == [LIBRARY_ORACLE[i] for i in range(1, 7)]
    assert [o["class"] for o in m["objects"]] == ["road", "building", "window", "pole", "floor", "vegetation"]


# a long focal length far away (a quad still 1 m wide, a pixel 5 cm): every tile is seen within
# 17 deg of the axis (at f = 120 px the outer column was 40 deg out, where window glass's
# angle-dependent reflectance differed between the views by 1 %, ten times the render noise)
TILE, F, Z, SHIFT = 40, 480.0, 24.0, 4


@pytest.fixture(scope="module")
def library_swatches(tmp_path_factory):
    """Every library material (patterns 10x enlarged, ``texture_scale 0.1``, so that they are
    resolved by the pixels) on its own fronto-parallel quad, all in one stereo render whose
    disparity on the quads is exactly SHIFT px, under a uniform white world (reflections
    are uniform too: only the material's own pattern remains). Rendered twice, with two
    seeds: the difference of the two left images is the render noise."""
    from blender_sesgen.scene.materials import LIBRARY
    names = list(LIBRARY)
    cols = 6
    rows = (len(names) + cols - 1) // cols
    W, H = cols * TILE, rows * TILE
    half = Z * TILE / F / 2           # a quad fills its tile exactly
    lines = [f"CAMERA resolution {W} {H} focal {F} baseline {SHIFT * Z / F}", "START position 0 0 0",
             "WORLD colour 1 1 1 strength 1", "LOOK exposure 0"]
    for i, name in enumerate(names):
        r, c = divmod(i, cols)
        x = (c - (cols - 1) / 2) * 2 * half
        y = ((rows - 1) / 2 - r) * 2 * half
        lines.append(f"MATERIAL name t_{name} library {name} texture_scale 0.1")
        lines.append(f"QUAD id {i + 1} material t_{name} vertices {x - half} {y - half} {-Z}  {x + half} {y - half} "
                     f"{-Z}  {x + half} {y + half} {-Z}  {x - half} {y + half} {-Z}")
    base = tmp_path_factory.mktemp("lib")
    (base / "lib.ses").write_text("\n".join(lines) + "\n")
    lum = {}
    for seed in (0, 1):
        out = base / f"out{seed}"
        rendered(base / "lib.ses", out, "--samples", "8", "--seed", seed, here=True)   # margins as at 16 (half the CPU)
        m = load_manifest(out)
        for view in ("left", "right"):
            ch = read_exr(out / m["files"][view][0])
            rgb = np.stack([ch[c] for c in m["channels"]["rgb"][:3]], -1)
            lum[view, seed] = rgb @ np.array([0.2126, 0.7152, 0.0722])
    tiles = {}
    for i, name in enumerate(names):
        r, c = divmod(i, cols)
        sl = (slice(r * TILE + 3, (r + 1) * TILE - 3), slice(c * TILE + 3 + SHIFT, (c + 1) * TILE - 3))
        sr = (sl[0], slice(sl[1].start - SHIFT, sl[1].stop - SHIFT))   # x_right = x_left - d
        tiles[name] = {"left": lum["left", 0][sl], "right": lum["right", 0][sr], "unshifted": lum["left", 0][sr],
                       "left_other_seed": lum["left", 1][sl]}
    return tiles


def _rms(a) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def test_library_materials_stick_to_the_surface(library_swatches):
    """After the disparity shift the two views differ by render noise only (measured between
    two seeds of the same view); unshifted they differ by the pattern as well."""
    can_fail = 0
    for name, t in library_swatches.items():
        assert np.isfinite(t["left"]).all() and t["left"].mean() > 0.01, name
        noise = _rms(t["left"] - t["left_other_seed"])
        shifted = _rms(t["left"] - t["right"])
        unshifted = _rms(t["unshifted"] - t["right"])
        assert shifted <= 1.25 * noise + 0.005 * t["left"].mean(), \
            f"{name}: views differ by {shifted:.4f} after the shift, render noise is {noise:.4f}"
        if unshifted >= 2 * shifted:
            can_fail += 1
    assert can_fail >= 6, "enough patterns resolved for the test to be able to fail"


def _background(tmp_path, name, rotation, yaw) -> np.ndarray:
    script = tmp_path / f"{name}.ses"
    script.write_text("CAMERA resolution 48 24 focal 20 baseline 0\n"
                      f"START position 0 1 0 10 {yaw} 0\n"
                      "CUBOID id 1 position 0 -50 0 dim 1 1 1\n"       # out of view
                      f"WORLD hdri sunset rotation {rotation}\nLOOK exposure 0\n")
    rendered(script, tmp_path / name, "--samples", "1", here=True)
    m = load_manifest(tmp_path / name)
    ch = read_exr(tmp_path / name / m["files"]["left"][0])
    return np.stack([ch[c] for c in m["channels"]["rgb"][:3]], -1)


def test_hdri_rotation_turns_the_world_like_the_sun_azimuth(tmp_path):
    """``rotation 90`` moves what was straight ahead (SES -Z) to the right (+X): a camera
    turned right by 90 deg (START ry -90) then sees what an unturned camera saw before."""
    ahead = _background(tmp_path, "a", 0, 0)
    turned = _background(tmp_path, "b", 90, -90)
    other = _background(tmp_path, "c", 90, 90)
    assert np.abs(turned - ahead).max() <= 1e-3 * ahead.max() + 1e-4
    assert np.abs(other - ahead).max() > 0.05 * ahead.max(), "the test must be able to fail"


def test_display_images_are_the_view_transform_and_what_vo_reads(tmp_path):
    cv2 = pytest.importorskip("cv2")
    from blender_sesgen.contract.colour import linear_to_srgb8
    from vo_reference.io.render import RenderSequence
    render_text(tmp_path, "CAMERA resolution 64 48 focal 50 baseline 0.1\nSTART position 0 1.5 3 -15 0 0\n"
                "QUAD id 1 material concrete vertices -5 0 5  5 0 5  5 0 -5  -5 0 -5\n"
                "CUBOID id 2 material brick position 0 0.5 0 dim 1 1 1\n"
                "SPHERE id 3 material chrome position 1.2 0.4 0.5 dim 0.4\n", "--samples", "4", here=True)
    m = load_manifest(tmp_path / "out")
    assert m["display"]["view_transform"] == "AgX"
    seq = RenderSequence(tmp_path / "out")
    for view in m["views"]:
        png = cv2.imread(str(tmp_path / "out" / m["display"]["files"][view][0]))[..., ::-1]
        assert np.array_equal(seq.image_rgb(0, view), png)
        srgb = linear_to_srgb8(seq.rgb_linear(0, view))
        assert np.abs(png.astype(int) - srgb).mean() > 2, "AgX, not plain sRGB"
        assert (png.max(axis=2) == 255).mean() < 0.01, "highlights are not clipped"
    # default lighting (no LIGHT, no WORLD): sky + sun and the automatic exposure
    assert m["render"]["exposure_rule"].startswith("auto")


def test_cityscapes_export_of_classes(tmp_path):
    cv2 = pytest.importorskip("cv2")
    from blender_sesgen.contract import semantics
    from vo_reference.io.render import RenderSequence
    from vo_reference.exporters.driver import export
    render_text(tmp_path, "CAMERA resolution 64 48 focal 40 baseline 0.2\nSTART position 0 1.2 4 -10 0 0\n"
                "QUAD id 1 material asphalt vertices -6 0 6  6 0 6  6 0 -6  -6 0 -6\n"
                "CUBOID id 5 class car position -0.8 0.5 0 dim 1.5 1 1\n"
                "CUBOID id 9 class car position 1.2 0.5 -1 dim 1 1 1\n"
                "CYLINDER id 12 class traffic_light position 0 1 -2 dim 0.1 2\n"
                "SPHERE id 20 position 0.2 1.8 -0.5 dim 0.2\n", "--samples", "1", "--no-denoise", here=True)   # ids and labels
    out = export(tmp_path / "out", "cityscapes", tmp_path / "cs", progress=False)
    seq = RenderSequence(tmp_path / "out")
    expected_label = {0: 23, 1: 7, 5: 26, 9: 26, 12: 19, 20: 4}    # sky, road, car, car, traffic light, static
    expected_instance = {0: 23, 1: 7, 5: 26000, 9: 26001, 12: 19, 20: 4}
    for view, (img_dir, gt_dir) in (("left", ("leftImg8bit", "gtFine")), ("right", ("rightImg8bit", "gtFineRight"))):
        ids = seq.ids(0, view)
        assert set(np.unique(ids)) == set(expected_label), "every object in view"
        stem = out / gt_dir / "train" / "sesgen" / "sesgen_000000_000000"
        labels = cv2.imread(f"{stem}_gtFine_labelIds.png", cv2.IMREAD_UNCHANGED)
        inst = cv2.imread(f"{stem}_gtFine_instanceIds.png", cv2.IMREAD_UNCHANGED)
        colour = cv2.imread(f"{stem}_gtFine_color.png")[..., ::-1]
        objs = cv2.imread(f"{stem}_gtFine_objectIds.png", cv2.IMREAD_UNCHANGED)
        assert labels.dtype == np.uint8 and inst.dtype == np.uint16
        assert np.array_equal(objs, ids)
        for obj_id, label in expected_label.items():
            mask = ids == obj_id
            assert (labels[mask] == label).all() and (inst[mask] == expected_instance[obj_id]).all()
            assert (colour[mask] == semantics.BY_ID[label].colour).all()
        assert (out / img_dir / "train" / "sesgen" / "sesgen_000000_000000_" f"{img_dir}.png").is_file()
    table = json.loads((out / "classes.json").read_text())
    assert {o["id"]: o["instanceId"] for o in table["objects"]} == {i: v for i, v in expected_instance.items() if i}


def test_bevelled_cuboid_is_real_geometry(tmp_path):
    """CUBOID bevel: silhouette and depth of the analytic rounded box (as for cylinders:
    ids exact beyond 0.26 px of a silhouette, depth 1 px inside it within 3e-5 / 2e-4)."""
    script = tmp_path / "bevel.ses"
    script.write_text("CAMERA resolution 160 120 focal 110 baseline 0.1\nSTART position 0 1 3 -8 0 0\n"
                      "QUAD id 1 vertices -3 0 -3  3 0 -3  3 0 4  -3 0 4\n"
                      "CUBOID id 2 material plastic position -0.4 0.5 0 20 35 10 dim 1 0.8 0.6 bevel 0.15\n"
                      "CUBOID id 3 material brick position 0.9 0.45 -0.8 0 -25 0 dim 0.6 0.9 0.7 bevel 0.3\n"
                      "EGO 0 0 0.2 0 2 0\n")
    rendered(script, tmp_path / "out", "--samples", "1", "--no-denoise", here=True)   # depth and ids only
    m = load_manifest(tmp_path / "out")
    W, H = m["resolution"]
    prims = [raycast.QuadP(1, np.array([[-3, 0, -3], [3, 0, -3], [3, 0, 4], [-3, 0, 4]], dtype=float)),
             raycast.RoundedBoxP(2, np.array([-0.4, 0.5, 0.0]), (20, 35, 10), np.array([1.0, 0.8, 0.6]), 0.15),
             raycast.RoundedBoxP(3, np.array([0.9, 0.45, -0.8]), (0, -25, 0), np.array([0.6, 0.9, 0.7]), 0.3)]
    sharp = [prims[0], raycast.BoxP(2, prims[1].centre, prims[1].rotation_deg, prims[1].size),
             raycast.BoxP(3, prims[2].centre, prims[2].rotation_deg, prims[2].size)]
    for view in m["views"]:
        for k in range(m["frames"]):
            depth, ids = depth_and_ids(read_exr(tmp_path / "out" / m["files"][view][k]), m)
            T = m["poses"][view][k]
            z_true, id_true, near = raycast.render_truth(prims, m["K"], T, W, H, edge_eps_px=0.26)
            assert {2, 3} <= set(np.unique(id_true))
            assert ((ids != id_true) & ~near).sum() == 0, f"{view} {k}"
            _, _, near1 = raycast.render_truth(prims, m["K"], T, W, H, edge_eps_px=1.0)
            on = np.isin(id_true, [2, 3]) & ~near1
            rel = np.abs(depth[on] - z_true[on]) / z_true[on]
            assert rel.mean() <= 3e-5 and rel.max() <= 2e-4, f"{view} {k}: {rel.mean():.2e} {rel.max():.2e}"
            # and the rounding is visible: a sharp box would have claimed other pixels
            _, id_sharp, _ = raycast.render_truth(sharp, m["K"], T, W, H)
            assert (id_sharp != id_true).sum() > 20


@pytest.mark.parametrize("line, marker, message", [
    ("QUAD id 2 material asfalt vertices -1 0 -1 1 0 -1 1 0 1 -1 0 1", "asfalt", "is not defined and is not a library"),
    ("WORLD hdri citty", "citty", "neither a built-in HDRI"),
    ("WORLD hdri notes.hdr", "notes.hdr", "not a usable image"),
    ("SPHERE id 2 texture cut.png position 0 0 -3 dim 1", "cut.png", "not a usable image"),
    ("CUBOID id 2 class tree position 0 0 -3 dim 1 1 1", "tree", "not a known class"),
])
def test_bad_input_is_a_located_error_and_nothing_is_written(tmp_path, line, marker, message):
    from image_files import png_bytes
    (tmp_path / "notes.hdr").write_text("#?RADIANCE\nthis is not an image\n")
    (tmp_path / "cut.png").write_bytes(png_bytes(16, 16)[:-30])
    script = tmp_path / "bad.ses"
    script.write_text("CUBOID id 1 position 0 0 -5 dim 1 1 1\n" + line + "\n")
    r = run_render(script, "--out", tmp_path / "out", "--quiet")
    col = line.index(marker) + 1
    assert r.returncode == 2, r.stderr
    assert f"bad.ses:2:{col}: error:" in r.stderr and message in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
    assert not (tmp_path / "out").exists()


def _pixel_contrast(L: np.ndarray, mask: np.ndarray) -> float:
    """The twin bench's pixel-scale contrast (bench/twin.py ``_grain``): the robust deviation of
    the signal over its 5 x 5 box mean, minus one, on ``mask``."""
    import cv2
    x = (L / np.maximum(cv2.blur(L, (5, 5)), 1e-3) - 1.0)[mask]
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def test_bare_blockwork_shows_its_blocks_20_m_away_where_white_render_is_flat(tmp_path, shared_data):
    """KITTI sequence_1's scaffolded building is bare sand-lime blockwork (frame 40, above the
    scaffold: pixel-scale contrast 0.16 at half size, its camera's noise included); the white
    render the twin had there is flat at that distance. Two walls 20 m ahead at KITTI's half-size
    focal length: the blockwork's own contrast (no sensor noise) is at least half the real wall's
    through its camera, the white render's under a fifth."""
    import cv2
    img = cv2.imread(str(shared_data / "kitti" / "sequence_1" / "image_l" / "000040.png"), 0)
    half = cv2.resize(img, (613, 185), interpolation=cv2.INTER_AREA).astype(np.float64)
    from blender_sesgen.scene.camera_profiles import PROFILES, black_8bit
    sensor = PROFILES["kitti"].sensor                # the linear signal, as the bench reads it
    gamma = 1.0 if sensor.get("response") == "linear" else float(sensor.get("gamma", 1.0))
    half = np.clip((half - black_8bit(sensor)) / (255.0 - black_8bit(sensor)), 0, 1) ** gamma
    box = np.zeros(half.shape, bool)
    box[2:31, 415:430] = True                      # (827, 0, 863, 66) at full size, 2 px in
    kitti = _pixel_contrast(half, box)
    text = "\n".join([
        "CAMERA resolution 192 96 focal 353.5 baseline 0.54 near 0.1 far 100",
        "WORLD sky strength 1 elevation 40 azimuth 180 aerosol 2.5", "RENDER samples 16 denoise on",
        "START position 0 2 0 0 0 0", "MATERIAL name blocks library blockwork",
        "MATERIAL name white_render library plaster colour 0.8 0.79 0.76 seed 0",
        "QUAD id 1 material blocks vertices -5.2 -1 -20  -0.2 -1 -20  -0.2 5 -20  -5.2 5 -20",
        "QUAD id 2 material white_render vertices 0.2 -1 -20  5.2 -1 -20  5.2 5 -20  0.2 5 -20"]) + "\n"
    out = render_text(tmp_path, text, "--frames", "0:1", here=True)
    exr = read_exr(out / "exr" / "left" / "000000.exr")
    L = sum(w * exr[f"ViewLayer.Combined.{c}"] for w, c in ((0.2126, "R"), (0.7152, "G"), (0.0722, "B")))
    ids = exr["ViewLayer.Object Index.X"].astype(int)
    got = {i: _pixel_contrast(L, cv2.erode((ids == i).astype(np.uint8), np.ones((7, 7))) > 0) for i in (1, 2)}
    assert 0.12 < kitti < 0.2 and got[1] > 0.5 * kitti and got[2] < 0.2 * kitti, (kitti, got)
