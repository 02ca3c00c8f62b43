"""A disk cache of generated asset meshes, shared by the render processes of a machine.

Generating the procedural meshes is the largest part of a big scene's build (city_kitti:
~10 of its ~27 CPU s before the first sample, 78 trees of ~30k triangles each), and every
render process pays it again: each farm chunk, each study variant, each resumed render.
``generate`` returns exactly what :func:`blender_sesgen.scene.assets.generate` returns (the same
arrays, bit for bit: the file holds them uncompressed, unchanged), read from
``FOLDER/v-VERSION/KIND-KEY.npz`` when an earlier process wrote it.

``VERSION`` hashes the asset generators' source and numpy's version, so editing a
generator never serves an old mesh. The folder is ``$SESGEN_ASSET_CACHE``, else
``$XDG_CACHE_HOME/blender-sesgen/assets`` (``~/.cache/...``); ``SESGEN_ASSET_CACHE=off``
switches the cache off. Files are written atomically (a reader never sees half a file); a
file that cannot be read is generated again and replaced; a folder that cannot be written
only costs the time. The newest ``KEEP_VERSIONS`` version folders are kept, older ones
removed (delete the folder to reclaim all of it: it is only a cache).

``cached_array`` keeps other things a render process would compute again (the physical sky's
table, ``blender/sky.py``; the glowing panes' irradiance maps, ``blender/glazing.py``) under
``FOLDER/KIND/KEY.npy``, the ``KEEP_ARRAYS`` (or the kind's own ``keep``) of a kind used last.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import zipfile
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ...contract.atomic import replacing
from .. import assets as _package
from .mesh import MeshData, Surface

ENV = "SESGEN_ASSET_CACHE"
KEEP_VERSIONS = 3
KEEP_ARRAYS = 64


def folder() -> Optional[Path]:
    """The cache's root folder, or None when ``SESGEN_ASSET_CACHE=off``."""
    value = os.environ.get(ENV)
    if value is not None:
        return None if value.strip().lower() in ("", "off", "0", "no") else Path(value)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "blender-sesgen" / "assets"


def sources_digest(head: str, files) -> Optional[str]:
    """What a cached thing's code is, as 16 hex digits: a sha256 of ``head`` (the versions it
    also depends on) and each ``(name, path)`` of ``files`` (its name and bytes); None where a
    file cannot be read (a package without its .py files: then nothing is cached)."""
    h = hashlib.sha256(head.encode())
    try:
        for name, path in files:
            h.update(name.encode() + b"\0" + Path(path).read_bytes())
    except OSError:
        return None
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def version() -> str:
    """The generators' source (every module of this package) and numpy's version, hashed."""
    here = sorted(Path(__file__).resolve().parent.glob("*.py"))
    digest = sources_digest(np.__version__, ((p.name, p) for p in here))
    if digest is None:
        raise OSError(f"the asset generators' sources in {here[0].parent if here else __file__} cannot be read")
    return digest


def _digest(key) -> str:
    """A file name for ``key`` (JSON: what the cached thing depends on)."""
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:24]


def _key(kind: str, size, seed: int, bend, offset: float) -> str:
    return _digest([kind, [float(v) for v in size], int(seed), [float(v) for v in np.atleast_1d(bend)], float(offset)])


def generate(kind: str, size, seed: int, bend=(0.0,), offset: float = 0.0) -> MeshData:
    """``blender_sesgen.scene.assets.generate(kind, size, seed, bend, offset)``, through the cache."""
    root = folder()
    if root is None:
        data = _package.generate(kind, size, seed, bend, offset)
    else:
        path = root / f"v-{version()}" / f"{kind}-{_key(kind, size, seed, bend, offset)}.npz"
        data = _read(path)
        if data is None:
            data = _package.generate(kind, size, seed, bend, offset)
            _write(path, data)
    if len(data.vertices):
        _BOXES[_box_key(kind, size, seed, bend, offset)] = np.stack([data.vertices.min(axis=0),
                                                                    data.vertices.max(axis=0)])
    return data


# [min, max] of the vertices of every mesh ``generate`` made or read in this process: the
# manifest's boxes (scene/bounds.py) of the meshes the builder just made, not generated again
_BOXES: dict = {}


def _box_key(kind: str, size, seed: int, bend, offset: float) -> tuple:
    return kind, tuple(map(float, size)), int(seed), tuple(map(float, np.atleast_1d(bend))), float(offset)


def box(kind: str, size, seed: int, bend=(0.0,), offset: float = 0.0) -> np.ndarray:
    """(2, 3) [min, max] of the vertices of ``generate(kind, size, seed, bend, offset)``'s mesh
    (asset frame): the mesh this process already made, else ``generate``'s."""
    found = _BOXES.get(_box_key(kind, size, seed, bend, offset))
    if found is not None:
        return found
    V = generate(kind, size, seed, bend, offset).vertices
    return np.stack([V.min(axis=0), V.max(axis=0)])


def _read(path: Path) -> Optional[MeshData]:
    try:
        with np.load(path, allow_pickle=False) as z:
            surfaces = tuple(Surface(m, None if c is None else tuple(c), *part)
                             for m, c, *part in json.loads(str(z["surfaces"])))
            data = MeshData(vertices=z["vertices"], faces=z["faces"], face_surface=z["face_surface"],
                            smooth=z["smooth"], surfaces=surfaces)
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile, EOFError):
        return None
    m = len(data.faces)
    if data.faces.shape != (m, 3) or data.face_surface.shape != (m,) or data.smooth.shape != (m,) \
            or data.vertices.ndim != 2 or (m and int(data.faces.max()) >= len(data.vertices)):
        return None
    return data


def _write(path: Path, data: MeshData) -> None:
    surfaces = json.dumps([[s.material, None if s.colour is None else list(s.colour)] + ([s.part] if s.part else [])
                           for s in data.surfaces])
    try:
        fresh = not path.parent.is_dir()
        with replacing(path) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, vertices=data.vertices, faces=data.faces, face_surface=data.face_surface,
                         smooth=data.smooth, surfaces=np.array(surfaces))
        if fresh:
            _prune(path.parent.parent, keep=path.parent)
    except OSError:
        pass   # a read-only or full disk: the mesh was generated, only the cache is lost


def _prune(root: Path, keep: Path) -> None:
    """Remove all but the newest KEEP_VERSIONS version folders (``keep`` always stays)."""
    versions = sorted((p for p in root.glob("v-*") if p.is_dir() and p != keep),
                      key=lambda p: p.stat().st_mtime, reverse=True)
    for old in versions[KEEP_VERSIONS - 1:]:
        shutil.rmtree(old, ignore_errors=True)


def cached_array(kind: str, key, make: Callable[[], np.ndarray],
                 valid: Callable[[np.ndarray], bool] = lambda a: True, keep: Optional[int] = None) -> np.ndarray:
    """``make()``, kept in the cache under ``kind`` and the JSON of ``key`` (what it depends
    on, versions included): read back when an earlier process wrote it and ``valid`` says it
    is whole, made (and written) otherwise; always made when the cache is off. The ``keep``
    (default ``KEEP_ARRAYS``) files of the kind used last stay."""
    root = folder()
    if root is None:
        return make()
    path = root / kind / f"{_digest(key)}.npy"
    try:
        array = np.load(path, allow_pickle=False)
        if valid(array):
            try:
                os.utime(path)   # recently used: kept when the kind's oldest are removed
            except OSError:
                pass
            return array
    except (OSError, ValueError, EOFError):
        pass
    array = make()
    try:
        with replacing(path) as tmp:
            np.save(tmp, array)
        kept = sorted((p for p in path.parent.glob("*.npy") if not p.name.startswith(".")), key=lambda p: p.stat().st_mtime, reverse=True)
        for old in kept[KEEP_ARRAYS if keep is None else keep:]:
            old.unlink(missing_ok=True)
    except OSError:
        pass   # a read-only or full disk: only the cache is lost
    return array
