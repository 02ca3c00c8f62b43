"""The SES scene language: scripts -> :class:`blender_sesgen.scene.model.Scene` (pure Python + numpy).

``parse_file(path)`` / ``parse_string(text)`` return a frozen Scene with its per-frame
timeline, or raise :class:`blender_sesgen.errors.ScriptError` (``file:line:col: error:
message``) for the first error in source order; every error found is in its ``errors``
attribute. The language is documented in docs/ses-language.md.
"""
from __future__ import annotations

import os
from typing import Optional

from ..contract.errors import ContractError
from ..contract.inputs import MiB, read_bytes
from ..errors import ScriptError, SesgenError
from ..scene.model import Scene
from .parser import parse_bytes, parse_text

__all__ = ["parse_file", "parse_string", "parse_bytes", "ScriptError"]

MAX_SCRIPT_BYTES = 64 * MiB  # ~1.5 million statements; a FIFO, device or larger file is refused


def parse_file(path: "str | os.PathLike[str]") -> Scene:
    """Parse an SES script file; relative texture/mesh/trajectory paths are relative to it.

    The script must be a regular file of at most ``MAX_SCRIPT_BYTES`` (a FIFO or a device
    is refused, never read)."""
    path = os.fspath(path)
    try:
        data = read_bytes(path, MAX_SCRIPT_BYTES, "script")
    except ContractError as e:
        raise SesgenError(f"{path}: {e.detail}") from None
    return parse_bytes(data, source=path, base_dir=os.path.dirname(os.path.abspath(path)))


def parse_string(text: str, source: str = "<string>", base_dir: Optional[str] = None) -> Scene:
    """Parse a script given as text; relative paths resolve against ``base_dir`` (default: cwd)."""
    return parse_text(text, source=source, base_dir=base_dir)
