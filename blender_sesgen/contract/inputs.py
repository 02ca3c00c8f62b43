"""Reading a user's input file safely: a regular file of bounded size, or a clear error.

Every reader of a file a user names (an SES script, a TRAJECTORY file, a model's
references, trajectories, manifests, calibration and image files read by ``vo_reference``)
goes through :func:`read_bytes` or :func:`read_text`, so that

- a FIFO, a socket or a device (``/dev/zero``, ``/dev/stdin``) is refused before it is
  opened (opening a FIFO blocks until a writer comes; reading ``/dev/zero`` never ends);
- a file larger than the caller's ``limit`` is refused from its size, and a file that grows
  while it is read stops at ``limit`` + 1 bytes (no MemoryError);
- errors are :class:`ContractError` naming the file, with the reason in words.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path

from .errors import ContractError

MiB = 1 << 20
TEXT_LIMIT = 256 * MiB   # a trajectory, manifest or calibration file of ours is far smaller
BINARY_LIMIT = 4096 * MiB  # a float image read whole (PFM, .flo): 16384 x 16384 x 4 channels of float32


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder")):
        if test(mode):
            return name
    return "not a regular file"


def check_regular(path, what: str = "file") -> int:
    """The size of ``path`` if it is a regular file (symlinks followed); else ContractError."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise ContractError(f"cannot read the {what} (no such file)", str(path)) from None
    except (OSError, ValueError) as e:
        raise ContractError(f"cannot read the {what} ({getattr(e, 'strerror', None) or e})", str(path)) from None
    if not stat.S_ISREG(st.st_mode):
        raise ContractError(f"the {what} is {_kind(st.st_mode)}, not a regular file", str(path))
    return st.st_size


def read_bytes(path, limit: int = TEXT_LIMIT, what: str = "file") -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them (else ContractError)."""
    size = check_regular(path, what)
    if size > limit:
        raise ContractError(f"the {what} is {_size(size)}, more than the {_size(limit)} allowed", str(path))
    try:
        # O_NONBLOCK: should the path have been swapped for a FIFO since the stat, open does not block
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(fd, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):
                raise ContractError(f"the {what} is not a regular file", str(path))
            # what the file holds, not the limit: read(limit + 1) reserves the limit's memory
            # first (16 GiB for an EXR: a MemoryError under an address-space cap)
            data = f.read(min(st.st_size, limit) + 1)
            parts = [data]
            while len(data) > st.st_size and sum(map(len, parts)) <= limit:   # it grew: read on, in steps
                more = f.read(min(MiB, limit + 1 - sum(map(len, parts))))
                if not more:
                    break
                parts.append(more)
            data = b"".join(parts)
    except (OSError, ValueError) as e:
        raise ContractError(f"cannot read the {what} ({getattr(e, 'strerror', None) or e})", str(path)) from None
    if len(data) > limit:
        raise ContractError(f"the {what} grew beyond the {_size(limit)} allowed while it was read", str(path))
    return data


def read_text(path, limit: int = TEXT_LIMIT, what: str = "file", strict: bool = True) -> str:
    """UTF-8 text of a regular file (see :func:`read_bytes`). ``strict``: bytes that are not
    UTF-8 are an error at their line; otherwise they become U+FFFD (a parser then rejects
    them where they matter, and a comment may hold them)."""
    data = read_bytes(path, limit, what)
    if not strict:
        return data.decode("utf-8", errors="replace")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise ContractError(f"not UTF-8 text (byte 0x{data[e.start]:02x})", str(path), line) from None


def _size(n: int) -> str:
    return f"{n / MiB:.3g} MiB" if n >= MiB else f"{n} bytes"


def is_inside(path, folder) -> bool:
    """True when ``path`` (resolved: symlinks and '..' followed) lies inside ``folder``."""
    try:
        Path(path).resolve().relative_to(Path(folder).resolve())
    except ValueError:
        return False
    return True


def is_number(word: str) -> bool:
    """Whether a word of a text file reads as a number (``float`` accepts it)."""
    try:
        float(word)
    except ValueError:
        return False
    return True
