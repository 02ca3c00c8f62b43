"""docs/ses-language.md agrees with the parser: examples parse, every keyword/tag is there."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from blender_sesgen.ses import parse_string
from blender_sesgen.ses.grammar import STATEMENTS
from blender_sesgen.textures import BUILTIN_TEXTURES

DOC = (Path(__file__).resolve().parents[1] / "docs" / "ses-language.md").read_text(encoding="utf-8")
BLOCKS = re.findall(r"```ses\n(.*?)```", DOC, flags=re.S)


def test_examples_parse(tmp_path):
    assert len(BLOCKS) >= 2
    complete = parse_string(BLOCKS[0])
    assert complete.frames == 3 and len(complete.objects) == 3
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "chair.obj").write_text("v 0 0 0\n")
    extensions = parse_string(next(b for b in BLOCKS if "// extensions in use" in b), base_dir=str(tmp_path))
    assert extensions.world.kind == "sky" and extensions.fog and extensions.noise and extensions.render.denoise
    assert extensions.render.quality == "final"
    moving = parse_string(next(b for b in BLOCKS if "MOVE" in b))
    assert moving.frames == 20 and moving.moving_ids == (2, 3)


def test_every_keyword_and_tag_is_documented():
    for keyword, spec in STATEMENTS.items():
        assert f"`{keyword}" in DOC, keyword
        for tag in spec.tags:
            assert re.search(rf"\b{tag}\b", DOC), f"{keyword} {tag}"


def _range(text: str) -> tuple[float, float]:
    lo, _, hi = text.strip().partition("–")
    return float(lo), float(hi or lo)


def test_asset_table_lists_every_kind_of_the_registry():
    """The ASSET table: one row per kind of ``blender_sesgen.assets.KINDS``, in its order, with
    the kind's class, what its size means and its default size ranges."""
    from blender_sesgen.assets import KINDS
    rows = re.findall(r"^\| `(\w+)`(?: \(strip\))? \| ([\w ]+) \| ([^|]+) \| ([^|]+) \| ([^|]+) \|$", DOC,
                      flags=re.M)
    assert [r[0] for r in rows] == list(KINDS)
    for (name, cls, meaning, ranges, summary), kind in zip(rows, KINDS.values()):
        assert (cls, meaning.strip(), summary.strip()) == (kind.semantic_class, kind.size_meaning, kind.summary), name
        assert [_range(r) for r in ranges.split("×")] == [tuple(map(float, r)) for r in kind.size_ranges], name


def test_texture_table_matches_textures_py():
    rows = dict(re.findall(r"^\| (\d+) \| `(\w+)` \|", DOC, flags=re.M))
    assert {int(k): v for k, v in rows.items()} == {n: name for n, (name, _) in BUILTIN_TEXTURES.items()}


def test_documented_ego_signs():
    # "positive beta turns the view to the right, positive alpha tilts it up"
    s = parse_string("CUBOID id 1 position 0 0 0 dim 1 1 1\nEGO 0 0 0 10 0 0\nEGO 0 0 0 -10 0 0\nEGO 0 0 0 0 10 0\n")
    T = s.timeline.left()
    assert T[1][1, 2] > 0                                # optical axis gains world +Y: up
    assert np.isclose(T[3][1, 2], 0, atol=1e-12) and T[3][0, 2] > 0  # level again, turned to +X: right
