"""Atomic file writes: a reader (or a crash) never sees a half-written file under its name.

Every writer in both packages goes through :func:`temp_path` + ``os.replace``: the data is
written to ``.NAME.tmp-PID.EXT`` in the same folder (the extension stays last, because
OpenCV and OpenEXR pick the codec from it), then renamed. :func:`is_temp_name` recognises
those names, so a resumed job can remove the leftovers of an interrupted one.
"""
from __future__ import annotations

import json
import math
import os
import re
import shutil
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from .errors import ContractError

_TEMP = re.compile(r"^\..+\.tmp-\d+(\.[A-Za-z0-9]+)?$")


def temp_path(path: Path) -> Path:
    """The temporary name under which ``path`` is written before the rename."""
    path = Path(path)
    return path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")


def is_temp_name(name: str) -> bool:
    """True for the names :func:`temp_path` makes (any process)."""
    return bool(_TEMP.match(name))


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def replacing(path, durable: bool = False) -> Iterator[Path]:
    """``with replacing(final) as tmp: write tmp`` -> renamed onto ``final`` if the block
    succeeds, removed if it raises. ``durable``: fsync the file and its folder (a crash
    right after leaves either the old or the new file, never a torn one)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_path(path)
    try:
        yield tmp
        if durable:
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
        if durable:
            _fsync_dir(path.parent)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextmanager
def replacing_folder(path) -> Iterator[Path]:
    """``with replacing_folder(final) as tmp: fill tmp`` -> the folder ``tmp`` (``.NAME.tmp-PID``
    beside ``final``) takes the place of ``final`` if the block succeeds; if it raises (or is
    interrupted) the partial folder is removed and ``final`` stays as it was. An existing
    ``final`` is moved aside (``.NAME.tmp-PID.old``), then deleted: a reader sees the old
    folder or the new one, never a mix (for an instant, neither). The caller decides whether
    ``final`` may be replaced."""
    final = Path(path)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_path(final)
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = tmp.with_name(tmp.name + ".old")
    if final.exists():
        os.replace(final, old)
    os.replace(tmp, final)
    if old.exists():
        shutil.rmtree(old, ignore_errors=True)


def write_bytes(path, data: bytes, durable: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`replacing`)."""
    with replacing(path, durable) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
    return Path(path)


def write_text(path, text: str, durable: bool = False) -> Path:
    return write_bytes(path, text.encode("utf-8"), durable)


def dumps_json(obj, source: str | None = None) -> str:
    """JSON text with one space of indent; NaN and infinities are refused (they are not JSON)."""
    try:
        return json.dumps(obj, indent=1, allow_nan=False) + "\n"
    except ValueError:
        raise ContractError(f"refusing to write non-finite numbers into JSON ({_first_non_finite(obj)})",
                            source) from None


def write_json(path, obj, durable: bool = False) -> Path:
    return write_text(path, dumps_json(obj, str(path)), durable)


def _first_non_finite(obj, where: str = "") -> str:
    if isinstance(obj, float) and not math.isfinite(obj):
        return f"{where or 'value'} = {obj}"
    if isinstance(obj, dict):
        items = obj.items()
    elif isinstance(obj, (list, tuple)):
        items = enumerate(obj)
    else:
        return ""
    for k, v in items:
        hit = _first_non_finite(v, f"{where}[{k!r}]" if where else repr(k))
        if hit:
            return hit
    return ""
