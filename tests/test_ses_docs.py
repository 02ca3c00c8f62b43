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
    extensions = parse_string(next(b for b in BLOCKS if "extensions in use" in b), base_dir=str(tmp_path))
    assert extensions.world.kind == "sky" and extensions.fog and extensions.noise and extensions.render.denoise


def test_every_keyword_and_tag_is_documented():
    for keyword, spec in STATEMENTS.items():
        assert f"`{keyword}" in DOC, keyword
        for tag in spec.tags:
            assert re.search(rf"\b{tag}\b", DOC), f"{keyword} {tag}"


def test_texture_table_matches_textures_py():
    rows = dict(re.findall(r"^\| (\d+) \| `(\w+)` \|", DOC, flags=re.M))
    assert {int(k): v for k, v in rows.items()} == {n: name for n, (name, _) in BUILTIN_TEXTURES.items()}


def test_documented_ego_signs():
    # "positive beta turns the view to the right, positive alpha tilts it up"
    s = parse_string("CUBOID id 1 position 0 0 0 dim 1 1 1\nEGO 0 0 0 10 0 0\nEGO 0 0 0 -10 0 0\nEGO 0 0 0 0 10 0\n")
    T = s.timeline.left()
    assert T[1][1, 2] > 0                                # optical axis gains world +Y: up
    assert np.isclose(T[3][1, 2], 0, atol=1e-12) and T[3][0, 2] > 0  # level again, turned to +X: right


def test_asset_kinds_table_is_the_registry():
    from blender_sesgen import assets
    assert assets.kinds_markdown() in DOC


def test_asset_example_parses():
    block = next(b for b in BLOCKS if "ASSET road" in b)
    scene = parse_string(block)
    kinds = [o.kind for o in scene.objects]
    assert kinds == ["road", "kerb", "sidewalk", "building", "car", "tree", "streetlight"]
    assert scene.objects[0].bend == (0.0, 6.0) and scene.objects[2].offset == 5.4


def test_photoreal_example_parses_and_library_and_classes_are_documented():
    from blender_sesgen.contract.semantics import LABELS
    from blender_sesgen.material_library import LIBRARY
    photoreal = [b for b in BLOCKS if "library materials" in b]
    assert len(photoreal) == 1
    s = parse_string(photoreal[0])
    assert s.world.kind == "hdri" and s.material("old_road").library.wear == 0.7
    assert [o.semantic_class for o in s.objects] == ["road", "road", "building", "car", "pole"]
    for name in LIBRARY:
        assert f"| `{name}` |" in DOC, name
    for label in LABELS:
        assert f"{label.name} {label.id}" in DOC, label.name
