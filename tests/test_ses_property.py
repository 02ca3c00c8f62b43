"""Property test: whatever the text, parsing returns a Scene or raises the project's error.

Random scripts are built from the language's own vocabulary (keywords, tags, numbers,
strings, junk) and from mutations of the scenes in scenes/ (deleted, duplicated or swapped
tokens and characters); nothing but SesgenError (ScriptError is one) may escape.
"""
from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from blender_sesgen.errors import SesgenError
from blender_sesgen.scene.model import Scene
from blender_sesgen.ses import parse_bytes, parse_string
from blender_sesgen.ses.grammar import STATEMENTS
from markers import examples

REPO = Path(__file__).resolve().parents[1]
SCENES = [p.read_text(encoding="utf-8") for p in sorted((REPO / "scenes").glob("*.ses"))]
VOCAB = sorted({k.lower() for k in STATEMENTS} | {k for k in STATEMENTS}
               | {t for s in STATEMENTS.values() for t in s.tags} | {"color", "tum", "kitti", "on", "off"})

numbers = st.one_of(st.integers(-40000, 40000).map(str),
                    st.floats(allow_nan=True, allow_infinity=True).map(repr),
                    st.sampled_from(["nan", "-inf", "1e999", "0", "-0", ".5", "5.", "1e-3", "+2"]))
words = st.one_of(st.sampled_from(VOCAB), st.text(min_size=1, max_size=8),
                  st.sampled_from(['"a b.png"', '"', "//", "noise", "../../etc/passwd", "\x00", "\ufeff"]))
token = st.one_of(numbers, words)
line = st.lists(token, min_size=0, max_size=16).map(" ".join)
script = st.lists(line, max_size=12).map("\n".join)


def _check(text_or_bytes, tmp_path: Path) -> None:
    try:
        if isinstance(text_or_bytes, bytes):
            result = parse_bytes(text_or_bytes, source="fuzz.ses", base_dir=str(tmp_path))
        else:
            result = parse_string(text_or_bytes, source="fuzz.ses", base_dir=str(tmp_path))
    except SesgenError:
        return
    assert isinstance(result, Scene)
    assert result.frames >= 1 and result.objects
    result.to_json()


FUZZ = settings(max_examples=examples(300), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@FUZZ
@given(script)
def test_random_scripts(tmp_path, text):
    _check(text, tmp_path)


@FUZZ
@given(st.binary(max_size=200))
def test_random_bytes(tmp_path, data):
    _check(data, tmp_path)


@st.composite
def mutated_scene(draw):
    lines = draw(st.sampled_from(SCENES)).splitlines()
    for _ in range(draw(st.integers(1, 4))):
        k = draw(st.integers(0, len(lines) - 1))
        tokens = lines[k].split()
        op = draw(st.sampled_from(["drop", "dup", "swap", "replace", "char", "line"]))
        if op == "line":
            lines.insert(draw(st.integers(0, len(lines))), lines[k])
            continue
        if not tokens:
            continue
        i = draw(st.integers(0, len(tokens) - 1))
        if op == "drop":
            del tokens[i]
        elif op == "dup":
            tokens.insert(i, tokens[i])
        elif op == "swap":
            j = draw(st.integers(0, len(tokens) - 1))
            tokens[i], tokens[j] = tokens[j], tokens[i]
        elif op == "replace":
            tokens[i] = draw(token)
        else:
            t = tokens[i]
            p = draw(st.integers(0, len(t)))
            tokens[i] = t[:p] + draw(st.characters()) + t[p + 1:]
        lines[k] = " ".join(tokens)
    return "\n".join(lines)


# each example parses a whole checked-in scene (city_loop.ses: 0.5 MB): fewer by default, all 300 under fuzz
@pytest.mark.slow
@settings(FUZZ, max_examples=examples(300, quick_most=20))
@given(mutated_scene())
def test_mutated_scenes(tmp_path, text):
    _check(text, tmp_path)
