"""Seeded dataset generation: sequence seeds and splits, the generator registry, the street
generator (seed 0 is scenes/street.ses), and `generate` (deterministic per seed, every
script passes `check`, nothing written on bad input)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from blender_sesgen import generators
from blender_sesgen.cli import main as sesgen
from blender_sesgen.dataset import (assign_splits, path_length_m, sequence_seeds, split_counts,
                                    SEQUENCE_SEEDS)
from blender_sesgen.errors import SesgenError

pytestmark = pytest.mark.slow   # subprocesses and end-to-end runs (left out of make test-fast)

REPO = Path(__file__).resolve().parents[1]


def run_cli(*args, env=None):
    return subprocess.run([sys.executable, "-m", "blender_sesgen", *map(str, args)], cwd=REPO, capture_output=True,
                          text=True, env=dict(os.environ, PYTHONPATH=str(REPO), **(env or {})), timeout=300)


# --- seeds, splits, path length ---------------------------------------------------------------

def test_sequence_seeds_are_deterministic_distinct_and_grow_by_appending():
    a = sequence_seeds(7, 500)
    assert a == sequence_seeds(7, 500) and a[:20] == sequence_seeds(7, 20)
    assert len(set(a)) == 500 and all(0 <= s < SEQUENCE_SEEDS for s in a)
    assert not set(sequence_seeds(8, 50)) & set(sequence_seeds(7, 50))   # neighbouring base seeds share nothing


def test_split_counts_follow_the_fractions_and_add_up():
    assert split_counts(10) == (8, 1, 1)
    assert split_counts(100, (0.7, 0.2, 0.1)) == (70, 20, 10)
    assert split_counts(10, (0.75, 0.25, 0.0)) == (8, 2, 0)   # remainders .5/.5: the earlier split first
    # a small set still gets a sequence in every split with a fraction above zero
    assert [split_counts(n) for n in (1, 2, 3, 5)] == [(1, 0, 0), (1, 1, 0), (1, 1, 1), (3, 1, 1)]
    assert split_counts(4, (1, 0, 0)) == (4, 0, 0)
    for n in range(1, 40):
        c = split_counts(n, (0.6, 0.25, 0.15))
        assert sum(c) == n and (n < 3 or min(c) >= 1)


def test_splits_are_a_seeded_permutation():
    s = assign_splits(20, 3)
    assert s == assign_splits(20, 3) and s != assign_splits(20, 4)
    assert (s.count("train"), s.count("val"), s.count("test")) == (16, 2, 2)
    # membership is spread over the indices, not the first 16 in order
    assert [i for i, x in enumerate(s) if x != "train"] != list(range(16, 20))


def test_path_length_sums_the_camera_steps():
    T = np.tile(np.eye(4), (4, 1, 1))
    T[:, :3, 3] = [[0, 0, 0], [3, 4, 0], [3, 4, 2], [3, 4, 2]]
    assert path_length_m(T) == pytest.approx(5 + 2)
    assert path_length_m(T[:1]) == 0.0


# --- the registry ---------------------------------------------------------------------------

def test_built_in_generators_are_found_by_name():
    g = generators.find("street")
    assert g.origin == "built-in" and Path(g.location) == REPO / "blender_sesgen/generators/builtin/street.py"
    assert g.options() == ["kitti", "steps"]
    assert "street" in generators.available()
    with pytest.raises(SesgenError, match="no generator 'nosuch'.*available: .*street"):
        generators.find("nosuch")
    with pytest.raises(SesgenError, match="unexpected keyword.*it takes: kitti, steps"):
        g.check_options({"stepz": 3})


def test_generators_from_a_file_a_folder_and_a_plugin(tmp_path, monkeypatch):
    gen = tmp_path / "mine" / "boxes.py"
    gen.parent.mkdir()
    gen.write_text("def generate(seed, size=1.0):\n    return f'// seed {seed}\\n'\n")
    assert generators.find(str(gen))(3) == "// seed 3\n"
    monkeypatch.setenv(generators.ENV_PATH, str(gen.parent))
    g = generators.find("boxes")
    assert g.origin == generators.ENV_PATH and g(5, size=2) == "// seed 5\n"
    ep = type("EP", (), {"value": "pkg.mod:gen", "load": lambda self: (lambda seed: "plugin")})()
    monkeypatch.setattr(generators, "_entry_points", lambda: {"plugged": ep})
    assert generators.find("plugged").origin == "plugin" and generators.available()["plugged"] == "plugin: pkg.mod:gen"
    (tmp_path / "nogen.py").write_text("x = 1\n")
    with pytest.raises(SesgenError, match="defines no generate"):
        generators.find(str(tmp_path / "nogen.py"))


def test_the_street_generator_seed_0_is_street_ses_and_other_seeds_vary():
    street = generators.find("street")
    assert street(0) == (REPO / "scenes/street.ses").read_text()
    assert street(0, kitti=True) == (REPO / "scenes/street_kitti.ses").read_text()
    a, b = street(11), street(12)
    assert a != b and a == street(11)
    lines = lambda t, head: [x for x in t.splitlines() if x.startswith(head)]  # noqa: E731
    assert lines(a, "EGO") != lines(b, "EGO") and lines(a, "LIGHT") != lines(b, "LIGHT")
    assert len(lines(street(4, steps=6), "EGO")) == 6


# --- the command ----------------------------------------------------------------------------

def test_generate_is_deterministic_and_every_script_checks(tmp_path, capsys):
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    for out, seed, count in ((a, 5, 6), (b, 5, 6), (c, 6, 3)):
        r = run_cli("generate", "street", "--count", count, "--seed", seed, "--out", out, "-o", "steps=8", "-q")
        assert r.returncode == 0, r.stderr
    files = lambda d: {p.name: p.read_bytes() for p in sorted(d.iterdir())}  # noqa: E731
    assert files(a) == files(b)
    index = json.loads((a / "dataset.json").read_text())
    assert index["format"] == "sesgen-dataset/1" and index["kind"] == "scripts" and index["count"] == 6
    assert index["generator"]["name"] == "street" and index["generator"]["options"] == {"steps": 8}
    seqs = index["sequences"]
    assert [s["seed"] for s in seqs] == sequence_seeds(5, 6) and [s["split"] for s in seqs] == assign_splits(6, 5)
    texts = [(a / s["script"]).read_text() for s in seqs]
    assert len(set(texts)) == 6                                   # varied
    assert not {p.read_text() for p in c.glob("*.ses")} & set(texts)   # another base seed: other scripts
    for s in seqs:
        assert sesgen(["check", str(a / s["script"])]) == 0, s["script"]
        assert s["frames"] == 9 and s["path_length_m"] > 0
    capsys.readouterr()
    # the same scripts a generator gives when called directly with the sequence seeds
    street = generators.find("street")
    assert texts == [street(s["seed"], steps=8) for s in seqs]
    # rerun into its own folder: replaced, same bytes
    assert run_cli("generate", "street", "--count", 6, "--seed", 5, "--out", a, "-o", "steps=8", "-q").returncode == 0
    assert files(a) == files(b)


def test_generate_writes_nothing_on_bad_input_or_a_failing_generator(tmp_path):
    out = tmp_path / "out"
    r = run_cli("generate", "street", "--count", 2, "--out", out, "-o", "stepz=3")
    assert r.returncode == 2 and "it takes: kitti, steps" in r.stderr and not out.exists()
    r = run_cli("generate", "nosuch", "--count", 2, "--out", out)
    assert r.returncode == 2 and "no generator 'nosuch'" in r.stderr and not out.exists()
    bad = tmp_path / "bad_gen.py"
    bad.write_text("def generate(seed):\n    return 'CAMERA resolution 64 48 focal 50\\nSTART position 0 1 3\\n"
                   "CUBOID id 1 position 0 0 0 dim 1 1\\n'\n")
    r = run_cli("generate", bad, "--count", 3, "--out", out)
    assert r.returncode == 1 and ":3:" in r.stderr and "error:" in r.stderr and not out.exists()
    boom = tmp_path / "boom.py"
    boom.write_text("def generate(seed):\n    raise ValueError('no room for the street')\n")
    r = run_cli("generate", boom, "--count", 1, "--out", out)
    assert r.returncode == 1 and "no room for the street" in r.stderr and not out.exists()
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("mine")
    r = run_cli("generate", "street", "--count", 1, "--out", tmp_path / "mine")
    assert r.returncode == 2 and "not written by generate" in r.stderr
    assert [p.name for p in (tmp_path / "mine").iterdir()] == ["notes.txt"]
