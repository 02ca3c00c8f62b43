"""The automatic exposure's preview kept in the asset cache (blender/exposure.py: ``cached_measure``,
``preview_key``; issue 29: the build).

Oracle: the same scene built with the cache off, which renders its preview: a build that reads
the preview back must have the same film exposure and the same metered brightness of frame 0
(taken from the preview's image), float for float; a changed input (the scene, the size, the
code) must render its own preview. ``fingerprint`` and ``reads_files`` against values written
by hand.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from blender_sesgen.scene.assets import cache


def _build(tmp_path, monkeypatch, name: str, extra=(), scale: float = 1.0):
    """A small AUTOEXPOSURE scene built for frames 0:3 (its exposure preview is frame 0's
    metering preview; frame 1's follows in the metering pass, which reuses the exposure
    preview's Cycles session when it renders); (film exposure, metered brightness of frames 0
    and 1, previews rendered)."""
    from blender_sesgen.blender import exposure
    from blender_sesgen.pipeline import RenderJob, RenderOptions
    from render_support import oracle_script
    rendered = []
    real = exposure.measure_exposure
    monkeypatch.setattr(exposure, "measure_exposure", lambda *a, **k: rendered.append(1) or real(*a, **k))
    script = tmp_path / f"{name}.ses"
    script.write_text(oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4), baseline=0,
                                    extra_lines=["TIMING rate 20 exposure 0.02 blur off", "SENSOR seed 1",
                                                 "AUTOEXPOSURE", *extra]))
    job = RenderJob.prepare(script, tmp_path / f"out-{name}-{len(rendered)}-{scale}",
                            RenderOptions(samples=1, frames="0:3", resolution_scale=scale))
    job.build()
    s = job.session
    return s.exposure, tuple(s.metering[:2]), len(rendered)


@pytest.mark.render
def test_a_build_reads_the_preview_back_bit_for_bit_and_a_changed_input_renders_it(tmp_path, monkeypatch):
    from blender_sesgen.blender import exposure
    monkeypatch.setenv(cache.ENV, "off")
    oracle = _build(tmp_path, monkeypatch, "a")                  # the preview rendered
    assert oracle[2] == 1 and oracle[0] > 0 and min(oracle[1]) > 0
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    first = _build(tmp_path, monkeypatch, "a")                   # rendered, kept
    again = _build(tmp_path, monkeypatch, "a")                   # read back: no preview
    assert first == oracle and again[:2] == oracle[:2] and again[2] == 0
    assert len(list((tmp_path / "cache" / "exposure").glob("*.npy"))) == 1
    # a brighter world, another size, another code: each renders its own preview
    world = _build(tmp_path, monkeypatch, "a", extra=["WORLD sky strength 3"])
    assert world[2] == 1 and world[0] != oracle[0]
    small = _build(tmp_path, monkeypatch, "a", scale=0.5)
    assert small[2] == 1
    monkeypatch.setattr(exposure, "code_version", lambda: "another code")
    assert _build(tmp_path, monkeypatch, "a")[2] == 1
    # a damaged file is rendered again, and replaced
    monkeypatch.undo()
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    for f in (tmp_path / "cache" / "exposure").glob("*.npy"):
        f.write_bytes(f.read_bytes()[:100])
    damaged = _build(tmp_path, monkeypatch, "a")
    assert damaged == oracle


def test_fingerprint_tells_every_bit():
    from blender_sesgen.blender.exposure import fingerprint
    from blender_sesgen.scene.model import TextureRef
    a = TextureRef(kind="builtin", name="brick", number=3, scale=1.0)
    assert fingerprint([a, {"k": (1, 2.0)}]) == fingerprint([TextureRef(kind="builtin", name="brick", number=3),
                                                           {"k": (1, 2.0)}])
    for other in (dataclasses.replace(a, scale=np.nextafter(1.0, 2.0)), dataclasses.replace(a, number=4)):
        assert fingerprint(other) != fingerprint(a)
    x = np.arange(6, dtype=np.float64).reshape(2, 3)
    assert fingerprint(x) != fingerprint(x.astype(np.float32)) != fingerprint(x.reshape(3, 2))
    assert fingerprint((1, 2)) != fingerprint([1, 2]) and fingerprint(1) != fingerprint(1.0) != fingerprint("1.0")
    assert fingerprint(np.float64(1.0)) != fingerprint(1.0)


@pytest.mark.render
def test_what_does_not_pickle_is_not_cached():
    from blender_sesgen.blender.exposure import preview_key
    assert preview_key([1.0]) is not None and preview_key([lambda: 1.0]) is None


def test_a_scene_that_reads_files_is_not_cached(repo):
    from blender_sesgen.blender.exposure import reads_files
    from blender_sesgen.ses import parse_file
    from blender_sesgen.scene.model import TextureRef
    scene = parse_file(str(repo / "scenes" / "paper_room.ses"))
    assert not reads_files(scene)
    image = TextureRef(kind="image", name="wall", path="/data/wall.png", source="wall.png")
    obj = next(o for o in scene.objects if hasattr(o, "texture"))
    assert reads_files(dataclasses.replace(scene, objects=(dataclasses.replace(obj, texture=image),)))


# --- the key's code: what the preview imports, not the whole package (issue 29: cold builds) -----

def _package_copy(tmp_path):
    """A copy of the package's sources (no bytecode) and ``digest()``: the preview key's code
    digest of that copy as it is now (``preview_sources`` hashed as ``code_version`` hashes it)."""
    import shutil
    from pathlib import Path

    import blender_sesgen
    from blender_sesgen.blender.exposure import preview_sources
    root = tmp_path / "blender_sesgen"
    shutil.copytree(Path(blender_sesgen.__file__).parent, root, ignore=shutil.ignore_patterns("__pycache__"))

    def digest():
        return cache.sources_digest("versions", ((p.relative_to(root).as_posix(), p) for p in preview_sources(root)))
    return root, digest


def test_the_preview_key_misses_when_the_code_it_imports_changes_and_keeps_otherwise(tmp_path):
    """A change to any module that building the scene and rendering the preview imports (at any
    depth, a function's own imports too: culling, the sensor path), to a new module imported, or
    to a data file of the package changes the key; a change to the command line, the farm, the
    studies or the scene generators (their scripts' models are in the key) keeps it. Where a
    module of the closure imports by a computed name, every file counts."""
    root, digest = _package_copy(tmp_path)

    def edit(rel, text="\n# edited\n"):
        with open(root / rel, "a") as f:
            f.write(text)
    d = digest()
    for rel in ("farm/local.py", "commands/render.py", "study/runner.py", "generators/builtin/hall.py",
                "generators/__init__.py", "pipeline.py", "api.py"):
        edit(rel)
        assert digest() == d, rel
    for rel in ("blender/session.py", "blender/builder.py", "blender/exposure.py", "blender/sky.py",
                "blender/glazing.py", "scene/assets/vegetation.py", "scene/assets/vehicle.py", "scene/presets.py",
                "scene/materials.py", "files/exr.py", "render/plan.py", "render/culling.py",
                "render/sensor/autoexposure.py", "contract/frames.py", "ses/__init__.py", "__init__.py",
                "blender_manifest.toml"):
        edit(rel)
        assert digest() != d, rel
        d = digest()
    # a new module, imported inside a function of the builder (continued lines, an alias)
    (root / "blender" / "extra_light.py").write_text("GAIN = 1.0\n")
    edit("blender/builder.py", "\n\ndef _more():\n    from .compat import (version_string,\n"
                               "                         node_tree as nt)\n    from . import extra_light as x\n")
    d = digest()
    edit("blender/extra_light.py")
    assert digest() != d
    # a computed import in the closure: then the whole package counts
    d = digest()
    edit("farm/local.py")
    assert digest() == d
    edit("blender/lighting.py", "\n\ndef _plugin(name):\n    import importlib\n    return importlib.import_module(name)\n")
    d = digest()
    edit("farm/local.py")
    assert digest() != d


def test_preview_sources_is_the_import_closure_python_sees(repo):
    """Independent oracle: ast (not the regular expressions) over every module, the closure of
    blender/session.py's imports, the packages' __init__ on the way: the same files; and what
    the preview leaves out is the command line, the farm, the studies, the generators."""
    import ast
    from pathlib import Path

    import blender_sesgen
    from blender_sesgen.blender.exposure import preview_sources
    root = Path(blender_sesgen.__file__).parent
    files = {p for p in root.rglob("*.py") if "__pycache__" not in p.parts}
    name = {p: ".".join(("blender_sesgen", *p.relative_to(root).with_suffix("").parts)).removesuffix(".__init__")
            for p in files}
    by_name = {v: k for k, v in name.items()}

    def imports(p):
        package = name[p] if p.name == "__init__.py" else name[p].rpartition(".")[0]
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Import):
                yield from (a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1]) if node.level else ""
                mod = ".".join(x for x in (base, node.module) if x)
                yield mod
                yield from (f"{mod}.{a.name}" for a in node.names)
    seen, todo = set(), ["blender_sesgen.blender.session"]
    while todo:
        parts = todo.pop().split(".")
        for i in range(1, len(parts) + 1):
            p = by_name.get(".".join(parts[:i]))
            if p is not None and p not in seen:
                seen.add(p)
                todo.extend(imports(p))
    got = set(preview_sources(root))
    assert {p for p in got if p.suffix == ".py"} == seen
    assert {p for p in got if p.suffix != ".py"} == {p for p in root.rglob("*") if p.is_file() and
                                                    p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts}
    left = {p.relative_to(root).parts[0] for p in files - seen}
    assert {"commands", "farm", "study", "generators"} <= left
    assert not {p for p in files - seen if p.relative_to(root).parts[0] in ("blender", "ses")}


@pytest.mark.render
def test_every_module_a_build_loads_is_in_the_key(tmp_path):
    """Second oracle, by running it: the package's modules that a fresh process loads to plan,
    build and render a scene's preview (an AUTOEXPOSURE scene: the metering pass too) are all
    among ``preview_sources``."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    import blender_sesgen
    from blender_sesgen.blender.exposure import preview_sources
    from render_support import oracle_script
    script = tmp_path / "s.ses"
    script.write_text(oracle_script(width=32, height=24, focal=22.0, principal=(16.0, 12.0), baseline=0,
                                    extra_lines=["TIMING rate 20 exposure 0.02 blur off", "SENSOR seed 1",
                                                 "AUTOEXPOSURE"]))
    code = ("import json, sys\n"
            "from blender_sesgen.render.plan import RenderOptions, RenderPlan\n"
            "from blender_sesgen.blender.session import BlenderSession\n"
            f"plan = RenderPlan.from_file({str(script)!r}, RenderOptions(samples=1, frames='0:3'))\n"
            "s = BlenderSession(plan)\n"
            "assert s.exposure > 0 and s.metering[1] is not None\n"
            "print(json.dumps(sorted(m.__file__ for n, m in list(sys.modules.items())\n"
            "                        if n.startswith('blender_sesgen') and getattr(m, '__file__', None))))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**__import__("os").environ, cache.ENV: "off"})
    loaded = {Path(f).resolve() for f in json.loads(out.stdout.strip().splitlines()[-1])}
    root = Path(blender_sesgen.__file__).resolve().parent
    assert loaded and loaded <= {p.resolve() for p in preview_sources(root)}
