"""docs/api.md: its Python blocks run as written, in order, in a fresh interpreter (with a
real Cycles render where bpy is installed; otherwise the render block is replaced by a
synthetic render folder); the public names of the two façades are all documented."""
from __future__ import annotations

import importlib
import importlib.util
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "api.md"
RENDER_MARK = "<!-- api-test: render -->"
HAVE_BPY = importlib.util.find_spec("bpy") is not None

# stands in for section 3 without Blender: the doc's `room` ray-cast by the test oracle
# (tests/raycast.py), textured with random colour cells fixed in the world
SYNTHETIC_RENDER = textwrap.dedent("""
    import numpy as np
    import raycast
    from synthetic_render import write_render

    def _cells(X):
        c = np.floor(X * 4.0).astype(np.int64)
        h = (c[..., 0] * 73856093) ^ (c[..., 1] * 19349663) ^ (c[..., 2] * 83492791)
        return np.stack([((h >> s) & 255) / 255.0 for s in (0, 8, 16)], -1).astype(np.float32) * 0.8 + 0.1

    _prims = [raycast.QuadP(o.id, np.array(o.vertices, float)) if o.shape == "quad"
              else raycast.BoxP(o.id, np.array(o.position), o.rotation_deg, np.array(o.size)) for o in room.objects]
    _K, _B, _W, _H = room.rig.K(), room.rig.baseline, room.rig.width, room.rig.height
    _frames = []
    for _T in room.timeline.left():
        _fr = {}
        for _view, _dx in (("left", 0.0), ("right", _B)):
            _Tv = _T.copy()
            _Tv[:3, 3] += _dx * _T[:3, 0]
            _z, _ids, _ = raycast.render_truth(_prims, _K, _Tv, _W, _H)
            _v, _u = np.mgrid[0:_H, 0:_W].astype(float)
            _rays = np.stack([(_u - _K[0, 2]) / _K[0, 0], (_v - _K[1, 2]) / _K[1, 1], np.ones_like(_u)], -1)
            _X = _Tv[:3, 3] + (_rays * np.where(np.isfinite(_z), _z, 0)[..., None]) @ _Tv[:3, :3].T
            _fr[_view] = (_cells(_X), _z.astype(np.float32), _ids.astype(np.int32))
        _frames.append(_fr)
    write_render("out/api_demo", K=_K, baseline_m=_B, T_world_left=room.timeline.left(), frames=_frames)
""")


def doc_blocks() -> list[tuple[bool, str]]:
    """(is the render block, code) of every ```python block of docs/api.md, in order."""
    text = DOC.read_text(encoding="utf-8")
    out = []
    for m in re.finditer(r"```python\n(.*?)```", text, re.S):
        before = text[:m.start()].rstrip()
        out.append((before.endswith(RENDER_MARK), m.group(1)))
    return out


def run_doc(tmp_path: Path, with_bpy: bool) -> subprocess.CompletedProcess:
    for folder in ("scenes", "studies"):
        (tmp_path / folder).symlink_to(REPO / folder, target_is_directory=True)
    parts = []
    for is_render, code in doc_blocks():
        parts.append(code if (with_bpy or not is_render) else SYNTHETIC_RENDER)
    script = tmp_path / "api_examples.py"
    script.write_text("\n".join(parts), encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=f"{REPO}{os.pathsep}{REPO / 'tests'}")
    return subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=600, env=env)


def test_the_doc_has_the_sections_the_api_promises():
    blocks = doc_blocks()
    assert len(blocks) == 8 and sum(r for r, _ in blocks) == 1
    text = DOC.read_text(encoding="utf-8")
    headings = re.findall(r"^## \d\. (.*)$", text, re.M)
    assert headings == ["Parse and check a script", "Build a scene in Python",
                        "Render, with options and a progress callback", "Open a sequence",
                        "Derive ground-truth products, export a dataset layout", "Run visual odometry", "Evaluate",
                        "Run a verification study"]


@pytest.mark.parametrize("module", ["blender_sesgen.api", "blender_sesgen.pipeline", "vo_reference.api",
                                    "blender_sesgen.contract.progress"])
def test_every_public_name_exists_and_is_documented(module):
    mod = importlib.import_module(module)
    table = DOC.read_text(encoding="utf-8").split("## What is public", 1)[1]
    row = next(line for line in table.splitlines() if line.startswith(f"| `{module}`"))
    documented = set(re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", row.split("|")[2]))
    assert documented == set(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name


def test_every_render_option_is_in_the_table_with_its_default():
    """docs/api.md's RenderOptions table: a row for every field (quality and timing included),
    each with the field's default."""
    import dataclasses
    from blender_sesgen.api import RenderOptions
    text = DOC.read_text(encoding="utf-8").split("`RenderOptions` holds", 1)[1].split("\n\n")[1]   # the table
    rows = re.findall(r"^\| (`[^|]+`) \| `?([^|`]+?)`?(?: \(all\))? \| ", text, re.M)
    documented = {name: default for names, default in rows for name in re.findall(r"`(\w+)`", names)}
    fields = {f.name: f.default for f in dataclasses.fields(RenderOptions)}
    assert set(documented) == set(fields)
    for name, default in fields.items():
        shown = getattr(default, "value", default)          # Device.CPU is "cpu"
        assert documented[name] == (f'"{shown}"' if isinstance(shown, str) else repr(shown)), name


@pytest.mark.slow
def test_doc_examples_run_without_blender(tmp_path):
    pytest.importorskip("OpenEXR")
    r = run_doc(tmp_path, with_bpy=False)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "bad.ses:2:1: error: CUBOID needs the tag 'dim'" in r.stdout
    assert (tmp_path / "out/api_demo_tartanair/pose_left.txt").is_file()
    assert "APE translation" in r.stdout


@pytest.mark.render
@pytest.mark.skipif(not HAVE_BPY, reason="needs the bpy wheel (pip install 'blender-sesgen[render]')")
def test_doc_examples_run_with_a_real_render(tmp_path):
    r = run_doc(tmp_path, with_bpy=True)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "4 frames" in r.stdout and (tmp_path / "out/api_demo/manifest.json").is_file()
    assert "APE translation" in r.stdout
