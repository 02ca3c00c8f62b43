"""What C libraries print: OpenEXR and libpng (inside OpenCV) write their complaints about a
corrupt file straight to file descriptors 2 (and, for OpenEXR's Python binding, 1),
bypassing Python. A command must still end with one line on stderr, so readers run those
calls inside :func:`captured_stderr` and put the first captured complaint into their own
error message.
"""
from __future__ import annotations

import os
import sys
import tempfile
from contextlib import contextmanager
from typing import Iterator


@contextmanager
def captured_stderr(fds: tuple[int, ...] = (2,)) -> Iterator[list[str]]:
    """Redirect the file descriptors ``fds`` (default: stderr) into a temporary file for the
    block; the lines written land in the yielded list when the block ends (also when it
    raises). A no-op where the descriptors cannot be duplicated."""
    lines: list[str] = []
    try:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(fd) for fd in fds]
    except (OSError, ValueError, AttributeError):
        yield lines
        return
    with tempfile.TemporaryFile() as tmp:
        for fd in fds:
            os.dup2(tmp.fileno(), fd)
        try:
            yield lines
        finally:
            for fd, keep in zip(fds, saved):
                os.dup2(keep, fd)
                os.close(keep)
            tmp.seek(0)
            lines.extend(ln.strip() for ln in tmp.read(65536).decode("utf-8", errors="replace").splitlines()
                         if ln.strip())


def first_complaint(lines: list[str], path) -> str:
    """The first captured line, without the library's repetition of the path, or ''."""
    for ln in lines:
        text = ln.replace(f"{path}: ", "").replace(str(path), "").strip()
        if text:
            return text[:200]
    return ""
