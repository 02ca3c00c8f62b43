"""Quality presets (blender_sesgen.scene.presets): precedence, the SES and CLI syntax, what the
manifest records and what resume compares; then rendered: presets change only the RGB
(depth, ids, normals, positions byte-identical across presets), and the fast pipeline
(persistent Cycles data, both views in one multiview render) gives the pixels of a fresh
render per view."""
from __future__ import annotations

import json
import subprocess
from dataclasses import replace

import numpy as np
import pytest

from blender_sesgen.errors import ScriptError, SesgenError
from blender_sesgen.render.folder import OutputFolder
from blender_sesgen.render.plan import RenderOptions, RenderPlan
from blender_sesgen.scene.presets import DEFAULT_QUALITY, PRESETS, QUALITIES, effective, preset
from blender_sesgen.ses import parse_string

from render_support import REPO, read_exr, render_cmd

SCRIPT = """\
CAMERA resolution 64 48 focal 50 baseline 0.1
START position 0 1 3
QUAD id 1 texture 4 vertices -3 0 -3  3 0 -3  3 0 4  -3 0 4
QUAD id 2 texture 3 colour 0.9 0.7 0.5 vertices -3 0 -3  -3 3 -3  3 3 -3  3 0 -3
CUBOID id 3 texture 1 position -0.5 0.4 -0.5 0 25 0 dim 0.8 0.8 0.8
SPHERE id 4 texture 2 colour 0.3 0.6 0.9 position 0.6 0.5 0 dim 0.4
CYLINDER id 5 texture 5 position 1.2 0.5 -1 0 0 0 dim 0.2 1.0
EGO 0.02 0 -0.1 0 1 0
"""


# --- pure: the table, precedence, syntax, manifest, resume -----------------------------

def test_the_table():
    assert QUALITIES == ("gt", "draft", "final", "reference") and DEFAULT_QUALITY == "final"
    gt = PRESETS["gt"]
    assert gt.samples == 1 and gt.max_bounces == 0 and gt.shading == "flat" and not gt.denoise
    assert gt.deterministic_rgb
    for q in ("draft", "final", "reference"):
        p = PRESETS[q]
        assert p.shading == "full" and p.denoise and not p.deterministic_rgb
    # more effort from draft to reference
    assert PRESETS["draft"].samples <= PRESETS["final"].samples <= PRESETS["reference"].samples
    with pytest.raises(ValueError, match="one of gt, draft, final, reference"):
        preset("best")


def test_precedence():
    # nothing given: final
    assert effective(None, None, None) == PRESETS["final"]
    # the script's quality, its samples/denoise over it, the command line's over those
    p = effective(None, None, None, "draft", 64, False)
    assert (p.quality, p.samples, p.denoise, p.adaptive, p.overridden) == ("draft", 64, False, False,
                                                                           ("samples", "denoise"))
    assert effective(None, 2, None, "draft", 64, False).samples == 2
    # a command-line quality replaces the script's RENDER sampling altogether
    assert effective("gt", None, None, "reference", 64, True) == PRESETS["gt"]
    p = effective("reference", 8, None, "draft", 64, False)
    assert p.samples == 8 and p.denoise and not p.adaptive and p.max_bounces == PRESETS["reference"].max_bounces


def test_ses_render_quality_and_errors():
    s = parse_string("CAMERA resolution 64 48 focal 50\nCUBOID id 1 position 0 0 -3 dim 1 1 1\nRENDER quality gt seed 4\n")
    assert (s.render.quality, s.render.samples, s.render.denoise, s.render.seed) == ("gt", None, None, 4)
    with pytest.raises(ScriptError) as e:
        parse_string("CUBOID id 1 position 0 0 -3 dim 1 1 1\nRENDER quality best\n", source="x.ses")
    assert str(e.value).startswith("x.ses:2:16: error:") and "gt, draft, final, reference" in str(e.value)


def _plan(tmp_path, **options):
    p = tmp_path / "s.ses"
    p.write_text(SCRIPT)
    return RenderPlan.from_file(p, RenderOptions(**options))


def test_options_and_manifest_block(tmp_path):
    with pytest.raises(SesgenError, match="--quality must be one of"):
        RenderOptions(quality="ultra")
    plan = _plan(tmp_path, quality="DRAFT", samples=3)
    r = plan.settings.manifest_block()
    assert r["quality"] == "draft" and r["quality_overridden"] == ["samples"] and r["samples"] == 3
    assert r["denoise"] is True
    # every pixel-affecting setting of the preset is recorded
    assert set(r["sampling"]) >= {"adaptive_threshold", "max_bounces", "diffuse_bounces", "glossy_bounces",
                                  "clamp_direct", "clamp_indirect", "light_tree", "path_guiding", "shading",
                                  "denoise_guides", "denoise_prefilter", "caustics"}
    assert _plan(tmp_path).settings.quality == "final"


def test_resume_compares_what_changes_pixels(tmp_path):
    final, gt = _plan(tmp_path), _plan(tmp_path, quality="gt")
    manifest = {"render": json.loads(json.dumps(final.settings.manifest_block())),
                "resolution": [final.settings.width, final.settings.height]}
    assert OutputFolder.same_settings(manifest, final.settings)
    assert not OutputFolder.same_settings(manifest, gt.settings)
    # same samples and denoise, another light path setting: not the same pixels
    other = replace(final.settings, preset=replace(final.settings.preset, max_bounces=2))
    assert not OutputFolder.same_settings(manifest, other)
    # Filter Glossy off (the quality bench's unbiased reference) is other pixels; at Cycles'
    # default 1.0, which every preset keeps, it is not recorded: older folders still resume
    unfiltered = replace(final.settings, preset=replace(final.settings.preset, filter_glossy=0.0))
    assert not OutputFolder.same_settings(manifest, unfiltered)
    assert "filter_glossy" not in manifest["render"]["sampling"]
    assert all(p.filter_glossy == 1.0 for p in PRESETS.values())


def test_the_quality_bench_reference_is_unbiased():
    """bench/quality.py's converged render: no denoiser, no clamp, no glossy filter."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("quality_bench", REPO / "bench" / "quality.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    ref = bench.reference_preset(4096)
    assert (ref.samples, ref.adaptive, ref.denoise) == (4096, False, False)
    assert ref.clamp_direct == ref.clamp_indirect == ref.filter_glossy == 0.0 and ref.caustics


def test_cli_rejects_an_unknown_quality(tmp_path):
    p = tmp_path / "s.ses"
    p.write_text(SCRIPT)
    r = subprocess.run(render_cmd(p, "--out", tmp_path / "out", "--quality", "ultra"), cwd=REPO,
                       capture_output=True, text=True)
    assert r.returncode == 2 and "invalid choice: 'ultra'" in r.stderr
    assert not (tmp_path / "out").exists()


# --- rendered ---------------------------------------------------------------------------

def _render(tmp_path, name, **options):
    """Frames 0 and 1, both views, normals and positions too: {(view, frame): channels}."""
    pytest.importorskip("bpy")
    from blender_sesgen.render.job import RenderJob
    p = tmp_path / "s.ses"
    p.write_text(SCRIPT)
    out = tmp_path / name
    job = RenderJob.prepare(p, out, RenderOptions(normal_pass=True, position_pass=True, **options))
    job.build()
    job.run()
    m = json.loads((out / "manifest.json").read_text())
    assert all(m["frames_complete"])
    return m, {(v, k): read_exr(out / rel) for v in m["views"] for k, rel in enumerate(m["files"][v])}


@pytest.fixture(scope="module")
def shared_render(tmp_path_factory):
    """``_render`` once per set of options in this module: (folder, manifest, channels); the presets'
    gt and draft renders are the fast pipeline's."""
    done = {}

    def get(**options):
        key = tuple(sorted(options.items()))
        if key not in done:
            tmp = tmp_path_factory.mktemp("quality")
            done[key] = (tmp / "out", *_render(tmp, "out", **options))
        return done[key]
    return get


@pytest.mark.render
def test_presets_change_only_the_rgb(shared_render):
    # reference and final at their own light paths, denoisers and clamps but with few
    # samples (the sample count cannot matter: ground truth is the first sample's)
    runs = {"gt": {}, "draft": {}, "final": {"samples": 2}, "reference": {"samples": 3}}
    folders, results = {}, {}
    for q, o in runs.items():
        folders[q], *results[q] = shared_render(quality=q, **o)
    m, base = results["gt"]
    ch = m["channels"]
    # Depth, Object Index and Position come from the first sample (the pixel centre). The
    # Normal pass is Cycles' average over a pixel's samples and closures: exact (the
    # pixel-centre shading normal) only with gt's one sample and emission shading.
    gt_channels = [ch["depth"], ch["object_index"], *ch["position"]]
    for q, (mq, exrs) in results.items():
        assert mq["render"]["quality"] == q
        for key, exr in exrs.items():
            for name in gt_channels:
                assert exr[name].dtype == base[key][name].dtype
                assert exr[name].tobytes() == base[key][name].tobytes(), f"{q} {key} {name}"
        if q != "gt":  # and the RGB does change
            rgb = ch["rgb"][0]
            assert not np.array_equal(exrs[("left", 0)][rgb], base[("left", 0)][rgb])
        # display PNGs for the photographs; gt's flat picture stays in its EXR, and readers
        # encode that with the sRGB curve (docs/output-format.md)
        assert ("display" in mq) == (q != "gt") and (folders[q] / "rgb").exists() == (q != "gt")
    from vo_reference.io.sequence import open_sequence
    c = np.clip(np.stack([base[("left", 0)][n] for n in ch["rgb"][:3]], -1).astype(np.float64), 0, 1)
    srgb = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)   # IEC 61966-2-1
    diff = open_sequence(folders["gt"]).image_rgb(0).astype(int) - np.rint(255 * srgb).astype(int)
    assert np.abs(diff).max() <= 1   # rounding at a half only
    # gt's normals are the exact ones: on the sphere (id 4, centre (0.6, 0.5, 0) in the SES
    # world = (0.6, 0, 0.5) in Blender's Z-up world) normal = (position - centre) / |...|
    left = base[("left", 0)]
    ids = np.rint(left[ch["object_index"]]).astype(int)
    P = np.stack([left[c] for c in ch["position"]], -1)[ids == 4]
    N = np.stack([left[c] for c in ch["normal"]], -1)[ids == 4]
    expected = (P - (0.6, 0.0, 0.5)) / np.linalg.norm(P - (0.6, 0.0, 0.5), axis=1, keepdims=True)
    assert len(N) > 20 and np.abs(N - expected).max() < 1e-4
    # gt's flat RGB: the sphere (id 4) in its own colour, brightest face-on
    ids = np.rint(base[("left", 0)][ch["object_index"]]).astype(int)
    rgb = np.stack([base[("left", 0)][c] for c in ch["rgb"][:3]], -1)
    sphere = rgb[ids == 4]
    assert sphere.size and np.allclose(sphere.max(axis=0), (0.3, 0.6, 0.9), atol=0.02)
    assert np.allclose(sphere / sphere[:, 2:3], np.array([0.3, 0.6, 0.9]) / 0.9, atol=1e-3)


@pytest.mark.render
@pytest.mark.parametrize("quality,options", [("gt", {}), ("draft", {"samples": 2}), ("draft", {}),
                                             ("final", {"samples": 12})])
def test_fast_pipeline_gives_the_plain_pixels(shared_render, tmp_path, quality, options):
    """Persistent data (+ multiview for gt) vs a fresh render per view: every channel equal.
    With at least the exposure preview's 8 samples the fast path renders the preview in the
    session the frames reuse (fewer samples: a fresh session, as the plain path)."""
    _, mf, fast = shared_render(quality=quality, **options)
    mp, plain = _render(tmp_path, "plain", quality=quality, fast_pipeline=False, **options)
    assert mf["render"]["pipeline"] == {"persistent_data": True, "views_per_render": 2 if quality == "gt" else 1}
    assert mp["render"]["pipeline"] == {"persistent_data": False, "views_per_render": 1}
    for key in plain:
        assert fast[key].keys() == plain[key].keys()
        for name in plain[key]:
            assert fast[key][name].tobytes() == plain[key][name].tobytes(), f"{key} {name}"
    # the views differ (each view its own camera), so the multiview render did not repeat one
    rgb = mf["channels"]["rgb"][0]
    assert not np.array_equal(fast[("left", 0)][rgb], fast[("right", 0)][rgb])


@pytest.mark.render
def test_the_exr_deflate_level_changes_bytes_not_values(tmp_path, monkeypatch):
    """The renderer writes its ZIP EXRs at deflate level render.EXR_ZIP_LEVEL (1), not
    OpenEXR's default 4: other bytes, the same decoded values in every channel (OpenEXR's
    own reader and the package's)."""
    pytest.importorskip("bpy")
    import ctypes
    from blender_sesgen.blender import compat, render
    from blender_sesgen.files.exr import read_exr as read_exr_pure
    assert render.EXR_ZIP_LEVEL == 1
    with compat.exr_zip_level(7) as found:
        assert found, "the OpenEXR library of the bpy wheel was not found"
        level = ctypes.c_int()
        compat._openexr_core().exr_get_default_zip_compression_level(ctypes.byref(level))
        assert level.value == 7
    runs = {}
    for lvl in (1, 4):
        monkeypatch.setattr(render, "EXR_ZIP_LEVEL", lvl)
        runs[lvl] = _render(tmp_path, f"zip{lvl}", quality="gt", resolution_scale=4.0)
    (m1, exrs1), (m4, exrs4) = runs[1], runs[4]
    assert m1["render"]["exr"]["codec"] == m4["render"]["exr"]["codec"] == "ZIP" and m1["files"] == m4["files"]
    differ = 0
    for key, rel in [((v, k), rel) for v in m1["views"] for k, rel in enumerate(m1["files"][v])]:
        assert exrs1[key].keys() == exrs4[key].keys()
        for name in exrs1[key]:
            assert exrs1[key][name].dtype == exrs4[key][name].dtype
            assert exrs1[key][name].tobytes() == exrs4[key][name].tobytes(), f"{key} {name}"
        pure1, pure4 = read_exr_pure(tmp_path / "zip1" / rel), read_exr_pure(tmp_path / "zip4" / rel)
        assert all(pure1[n].tobytes() == pure4[n].tobytes() == exrs1[key][n].tobytes() for n in exrs1[key])
        differ += (tmp_path / "zip1" / rel).read_bytes() != (tmp_path / "zip4" / rel).read_bytes()
    assert differ == 4   # the level took effect: every file's bytes changed


@pytest.mark.render
def test_gpu_without_a_gpu_fails_cleanly(tmp_path):
    pytest.importorskip("bpy")
    from blender_sesgen.blender.render import gpu_devices
    if gpu_devices()[0]:
        pytest.skip("this machine has a GPU: --device gpu renders")
    p = tmp_path / "s.ses"
    p.write_text(SCRIPT)
    r = subprocess.run(render_cmd(p, "--out", tmp_path / "out", "--device", "gpu"), cwd=REPO,
                       capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert lines == ["error: --device gpu: Cycles found no GPU (OptiX/CUDA/HIP/Metal/oneAPI)"], r.stderr
    assert r.stdout == "" and not (tmp_path / "out").exists()


def test_sampling_pattern_is_cycles_default_and_recorded_only_when_changed(tmp_path):
    """``Preset.sampling_pattern`` (issue 29, quality17): every preset keeps Cycles' own default
    (``automatic``: on a render without adaptive sampling, Cycles' blue noise), which a new
    Blender scene holds and which every folder so far was rendered with, so the manifest omits
    it; another pattern is written to Cycles and is other pixels. The oracle: a scene Blender
    made, its pattern untouched, renders pixels equal to one set to ``BLUE_NOISE`` and unequal
    to ``TABULATED_SOBOL`` (a 4-sample render of a lit quad)."""
    import bpy
    from blender_sesgen.blender import render
    from blender_sesgen.scene.presets import SAMPLING_PATTERNS
    assert all(p.sampling_pattern == "automatic" for p in PRESETS.values())
    final = _plan(tmp_path)
    manifest = {"render": json.loads(json.dumps(final.settings.manifest_block())),
                "resolution": [final.settings.width, final.settings.height]}
    assert "sampling_pattern" not in manifest["render"]["sampling"]
    sobol = replace(final.settings, preset=replace(final.settings.preset, sampling_pattern="tabulated_sobol"))
    assert not OutputFolder.same_settings(manifest, sobol)
    assert sobol.manifest_block()["sampling"]["sampling_pattern"] == "tabulated_sobol"
    with pytest.raises(ValueError):
        replace(final.settings.preset, sampling_pattern="halton")
    bscene = bpy.data.scenes.new("q17_pattern")
    try:
        assert bscene.cycles.sampling_pattern == "AUTOMATIC"       # what Blender gives a new scene
        for name in SAMPLING_PATTERNS:
            render.configure(bscene, replace(PRESETS["final"], sampling_pattern=name))
            assert bscene.cycles.sampling_pattern == name.upper()
        render.configure(bscene, PRESETS["final"])
        assert bscene.cycles.sampling_pattern == "AUTOMATIC"
        bscene.render.engine, bscene.cycles.samples = "CYCLES", 4
        bscene.cycles.use_denoising = bscene.cycles.use_adaptive_sampling = False
        bscene.render.resolution_x = bscene.render.resolution_y = 24
        bscene.render.resolution_percentage = 100
        cam = bpy.data.objects.new("q17_cam", bpy.data.cameras.new("q17_cam"))
        cam.location, cam.rotation_euler = (0, -4, 1), (1.4, 0, 0)
        mesh = bpy.data.meshes.new("q17_quad")
        mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 1), (-1, 1, 1)], [], [(0, 1, 2, 3)])
        lamp = bpy.data.objects.new("q17_lamp", bpy.data.lights.new("q17_lamp", "AREA"))
        lamp.data.size, lamp.data.energy, lamp.location = 3.0, 500.0, (0, 0, 3)
        for o in (cam, bpy.data.objects.new("q17_quad", mesh), lamp):
            bscene.collection.objects.link(o)
        bscene.camera = cam
        pixels = {}
        for name in ("automatic", "blue_noise", "tabulated_sobol"):
            bscene.cycles.sampling_pattern = name.upper()
            bscene.render.filepath = str(tmp_path / f"{name}.exr")
            bpy.ops.render.render(write_still=True, scene=bscene.name)
            ch = read_exr(tmp_path / f"{name}.exr")
            pixels[name] = np.stack([ch[k] for k in sorted(ch) if "Combined" in k], -1)
        assert pixels["automatic"].size and np.array_equal(pixels["automatic"], pixels["blue_noise"])
        assert not np.array_equal(pixels["automatic"], pixels["tabulated_sobol"])
    finally:
        bpy.data.scenes.remove(bscene)
