"""Fuzz tests of every reader (hypothesis, bounded for CI): whatever the bytes, a reader
returns data or fails with one line naming the file -- never a traceback.

Each target (tests/fuzz_targets.py) is a valid file in a fixture folder and the commands
that read it; hypothesis draws mutation lists (byte flips, truncation, insertion,
deletion, whole-line repeats and swaps, numbers replaced by nan / 1e308 / 0 / non-ASCII
digits...). The examples are derandomised (a failure reproduces) and few per target, so the
module runs in well under a minute (the counts below are the ``fuzz`` profile's; the default
profile runs a fifth of them); ``bench/fuzz_campaign.py`` runs the same targets with
thousands of mutants, each in a child process (docs/reliability.md has its figures).
"""
from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import fuzz_targets as ft
from markers import examples
from blender_sesgen.errors import ScriptError, SesgenError
from blender_sesgen.ses import parse_bytes
from blender_sesgen.ses.diagnostics import Diagnostics
from blender_sesgen.ses.lexer import tokenize

unit = st.floats(0.0, 1.0, allow_nan=False)
op = st.one_of(
    st.tuples(st.just("flip"), unit, st.integers(1, 255)),
    st.tuples(st.just("truncate"), unit),
    st.tuples(st.just("insert"), unit, st.one_of(st.binary(min_size=1, max_size=16),
                                                 st.sampled_from([b"\n", b"\x00", b"nan ", b"\r", b"\xff"]))),
    st.tuples(st.sampled_from(["delete", "duplicate"]), unit, st.integers(1, 64)),
    st.tuples(st.just("number"), unit, st.sampled_from(ft.INTERESTING + ft.VALUES)),
    st.tuples(st.sampled_from(["dupline", "dropline", "swapline"]), unit, unit),
    st.just(("fixcrc", 0.0)),
)
ops = st.lists(op, min_size=1, max_size=4)

# examples per target: cheap readers get more
EXAMPLES = {"tum": 40, "kitti-poses": 30, "euroc": 30, "pfm": 40, "png16-disparity": 30, "kitti-flow-png": 30,
            "manifest": 20, "exr": 15, "kitti-calib": 5, "kitti-folder-poses": 5, "done-log": 8,
            "manifest-sensor": 30, "texture-png": 40, "texture-jpeg": 40, "texture-exr": 30,
            "render-display-png": 10, "render-exr-verify": 5, "render-manifest-seal": 15, "render-scene-ses": 10,
            "render-imu-csv": 10, "model-gltf": 30, "model-obj": 30, "model-stl": 30, "model-ply": 20,
            "hdri-exr": 30, "hdri-hdr": 30, "scripts-index": 15, "renders-index": 20}


def _settings(n: int):
    return settings(max_examples=examples(n), deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory):
    cache = {}

    def get(name):
        if name not in cache:
            folder = tmp_path_factory.mktemp(name)
            cache[name] = (folder, *ft.setup_target(ft.TARGETS[name], folder))
        return cache[name]
    return get


def _one_target(name):
    @_settings(EXAMPLES[name])
    @given(mutations=ops, json_seed=st.one_of(st.none(), st.integers(0, 2**32 - 1)))
    def test(fixtures, mutations, json_seed):
        import random
        folder, path, seed = fixtures(name)
        target = ft.TARGETS[name]
        json_rng = random.Random(json_seed) if (target.json_doc and json_seed is not None) else None
        assert ft.run_mutant(target, folder, path, seed, mutations, json_rng) in ("ok", "user-error")
    test.__name__ = f"test_fuzz_{name.replace('-', '_')}"
    return test


for _name in ft.TARGETS:
    globals()[f"test_fuzz_{_name.replace('-', '_')}"] = _one_target(_name)


def test_every_seed_is_read_without_error(fixtures):
    """The unmutated inputs pass: the fuzz starts from files the readers accept."""
    for name, target in ft.TARGETS.items():
        folder, path, seed = fixtures(name)
        assert ft.run_mutant(target, folder, path, seed, []) == "ok", name


# --- the pure EXR reader (verify, contact sheet, add-on preview) --------------------------------

@_settings(100)
@given(mutations=ops)
def test_fuzz_pure_exr_reader(fixtures, mutations):
    """``blender_sesgen.files.exr`` (numpy + zlib, no OpenEXR) on a mutated render EXR: channels
    or ExrError; a block never inflates beyond its size, a header never loops."""
    from blender_sesgen.files.exr import ExrError, check_complete, decode
    folder, path, seed = fixtures("exr")
    data = ft.mutate(seed, mutations)
    try:
        check_complete(data, "x.exr", ("ViewLayer.Depth.Z",))
        channels = decode(data, "x.exr")
    except ExrError as e:
        assert "\n" not in str(e)
    else:
        assert channels and all(a.ndim == 2 for a in channels.values())


def test_pure_exr_reader_channels_asked_for_and_the_predictor(fixtures):
    """``names`` returns exactly those channels, equal to a whole decode; the ZIP predictor
    undone as OpenEXR's spec writes it (a running byte sum, minus 128 each, modulo 256, then the
    two halves interleaved), byte by byte in Python."""
    import numpy as np

    from blender_sesgen.files.exr import _unpredict, read_exr
    folder, path, seed = fixtures("exr")
    whole = read_exr(path)
    names = [n for n in whole if ".Combined." in n][:3] + ["ViewLayer.Depth.Z"]
    part = read_exr(path, names)
    assert sorted(part) == sorted(names) and all(np.array_equal(part[n], whole[n]) for n in names)
    raw = np.random.default_rng(5).integers(0, 256, 1001).astype(np.uint8)
    t, acc = [], 0
    for i, b in enumerate(raw.tolist()):
        acc = b if i == 0 else (acc + b - 128) % 256
        t.append(acc)
    half = (len(t) + 1) // 2
    expected = bytes(x for pair in zip(t[:half], t[half:] + [None]) for x in pair if x is not None)
    assert _unpredict(raw) == expected


# --- the SES front end: line numbers and columns whatever the characters ----------------------

SCENE = "CAMERA resolution 64 48 focal 60\nQUAD id 1 vertices 0 0 0 1 0 0 1 1 0 0 1 0\nSPHERE id 2 position 0 1 -3 dim 1\n"
comment_text = st.text(st.characters(blacklist_characters="\r\n"), max_size=30)


def _tokens(text):
    d = Diagnostics("f.ses")
    return [[(t.kind, t.text, t.line, t.col) for t in line] for line in tokenize(text, d)], d.items


@_settings(200)
@given(st.lists(comment_text, min_size=3, max_size=3))
def test_anything_in_a_comment_leaves_tokens_and_lines_alone(comments):
    lines = SCENE.splitlines()
    text = "\n".join(f"{ln} // {c}" for ln, c in zip(lines, comments)) + "\n// " + comments[0] + "\nEGO 0 0 1 0 0 0\n"
    plain = "\n".join(lines) + "\n\nEGO 0 0 1 0 0 0\n"
    assert _tokens(text) == _tokens(plain)


@_settings(300)
@given(st.lists(st.sampled_from(SCENE.splitlines() + ["EGO 0 0 0.1 0 0 0", "// c"]), min_size=1, max_size=6),
       st.sampled_from(["\n", "\r\n", "\r"]), st.data())
def test_errors_point_inside_the_script(lines, newline, data):
    """Insert one random character anywhere: the result parses, or every error is one line
    ``f.ses:L:C: error: ...`` with L a line of the script (lines end only at \\n, \\r\\n, \\r)
    and C within that line (+1 for an error at its end)."""
    text = newline.join(lines) + newline
    pos = data.draw(st.integers(0, len(text)))
    ch = data.draw(st.characters(blacklist_categories=("Cs",)))
    text = text[:pos] + ch + text[pos:]
    try:
        parse_bytes(text.encode("utf-8"), source="f.ses")
    except ScriptError as e:
        src_lines = re.split(r"\r\n|\r|\n", text)
        for err in e.errors:
            assert "\n" not in str(err) and str(err).startswith(f"f.ses:{err.line}:{err.col}: error: ")
            assert 1 <= err.line <= len(src_lines), (text, str(err))
            assert 1 <= err.col <= len(src_lines[err.line - 1]) + 1, (text, str(err))
    except SesgenError as e:
        assert "\n" not in str(e)
