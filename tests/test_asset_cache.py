"""The disk cache of generated asset meshes (blender_sesgen/scene/assets/cache.py): what it serves
is what the generator makes, bit for bit; a damaged file is made again; off means off."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.scene import assets
from blender_sesgen.scene.assets import cache

CASES = [("tree", (4.0, 6.0, 4.0), 3, (0.0,), 0.0), ("car", (1.8, 1.5, 4.3), 11, (0.0,), 0.0),
         ("road", (7.0, 0.1, 30.0), 2, (4.0, -3.0), 1.5), ("building", (14.0, 12.0, 10.0), 5, (0.0,), 0.0)]


@pytest.fixture
def root(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    return tmp_path / "cache"


def _same(a, b):
    for name in ("vertices", "faces", "face_surface", "smooth"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), name
    assert a.surfaces == b.surfaces


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_a_cached_mesh_is_the_generated_one_bit_for_bit(root, case):
    direct = assets.generate(*case)
    first = cache.generate(*case)            # generated, written
    files = list(root.rglob("*.npz"))
    assert len(files) == 1 and files[0].parent.name == f"v-{cache.version()}"
    second = cache.generate(*case)           # read back
    _same(direct, first)
    _same(direct, second)
    assert second.vertices is not first.vertices


def test_other_parameters_are_other_files(root):
    kind, size, seed, bend, offset = CASES[1]
    cache.generate(kind, size, seed, bend, offset)
    cache.generate(kind, size, seed + 1, bend, offset)
    cache.generate(kind, (1.8, 1.5, 4.4), seed, bend, offset)
    assert len(list(root.rglob("*.npz"))) == 3


def test_a_damaged_file_is_generated_again(root):
    case = CASES[1]
    cache.generate(*case)
    (path,) = root.rglob("*.npz")
    for damage in (path.read_bytes()[: path.stat().st_size // 2], b"not a zip file"):
        path.write_bytes(damage)
        _same(assets.generate(*case), cache.generate(*case))
        assert np.load(path)["faces"].shape[1] == 3         # replaced by a whole file


def test_off_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV, "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache.folder() is None
    _same(assets.generate(*CASES[1]), cache.generate(*CASES[1]))
    assert list(tmp_path.rglob("*")) == []


def test_old_versions_are_pruned(root):
    for i in range(5):
        (root / f"v-old{i}").mkdir(parents=True)
    cache.generate(*CASES[1])
    assert len([p for p in root.iterdir() if p.name.startswith("v-")]) == cache.KEEP_VERSIONS
    assert (root / f"v-{cache.version()}").is_dir()


@pytest.mark.parametrize("mode", ["off", "on"])
def test_a_box_of_a_mesh_made_in_this_process_is_not_generated_again(tmp_path, monkeypatch, mode):
    """The manifest's object boxes (scene/bounds.py) of the meshes the builder made: their
    vertices' [min, max], equal to the generator's (the oracle: a mesh generated apart), read
    from what ``generate`` kept (no second generation; before, every thing asset was made twice)."""
    from blender_sesgen.scene.bounds import object_box
    from blender_sesgen.scene.model import Asset
    monkeypatch.setenv(cache.ENV, "off" if mode == "off" else str(tmp_path / "cache"))
    case = ("car", (1.8, 1.5, 4.3), 12, (0.0,), 0.0)
    V = assets.generate(*case).vertices
    made = []
    real = assets.generate
    monkeypatch.setattr(assets, "generate", lambda *a: made.append(a) or real(*a))
    cache._BOXES.clear()
    cache.generate(*case)                              # the builder's
    car = Asset(id=1, name="car", kind="car", size=case[1], seed=case[2], semantic_class="car", position=(0, 0, 0))
    box = object_box(car)
    assert len(made) == 1 and box.tolist() == [V.min(axis=0).tolist(), V.max(axis=0).tolist()]
    cache._BOXES.clear()                               # a mesh this process has not made: generated
    assert object_box(car).tolist() == box.tolist() and len(made) == 1 + (mode == "off")
