"""Typed reads of a statement's tag values and the value checks every statement shares.

One :class:`Checks` per parse holds the Diagnostics and the script's folder; the
statement modules (parser, materials, motion, environment) report through it, so a
failed check records an error at the offending token and parsing goes on.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

from ..contract.errors import ContractError
from ..contract.inputs import check_regular
from .diagnostics import Diagnostics
from .lexer import Token
from .statements import ParsedStatement


def vec(stmt: ParsedStatement, name: str, default=None):
    """The tag's numbers as a tuple of floats, or ``default`` if the tag is absent."""
    tv = stmt.tags.get(name)
    return tuple(float(v) for v in tv.values) if tv is not None else default


def scalar(stmt: ParsedStatement, name: str, default=None):
    """The tag's first value, or ``default`` if the tag is absent."""
    tv = stmt.tags.get(name)
    return tv.values[0] if tv is not None else default


MAX_SEED = 2**31 - 1           # Cycles seeds are 32-bit signed


class Checks:
    """Value checks that record errors in ``diags``; file tags resolve against ``base_dir``."""

    def __init__(self, base_dir: Path, diags: Diagnostics):
        self.base_dir, self.diags = base_dir, diags

    def err(self, token: Token, message: str) -> None:
        self.diags.at(token, message)

    def positive(self, stmt: ParsedStatement, name: str, allow_zero: bool = False) -> None:
        tv = stmt.tags.get(name)
        if tv is None:
            return
        for value, tok in zip(tv.values, tv.tokens):
            if value < 0 or (value == 0 and not allow_zero):
                need = "zero or positive" if allow_zero else "positive"
                self.err(tok, f"{stmt.keyword} '{name}' must be {need}, got {tok.text}")

    def unit_range(self, stmt: ParsedStatement, name: str) -> None:
        tv = stmt.tags.get(name)
        if tv is None:
            return
        for value, tok in zip(tv.values, tv.tokens):
            if not 0.0 <= value <= 1.0:
                self.err(tok, f"{stmt.keyword} '{name}' values must lie in 0..1, got {tok.text}")

    def seed(self, stmt: ParsedStatement, name: str = "seed") -> int:
        """The integer tag ``name`` (0 if absent), checked to lie in 0..MAX_SEED."""
        tv = stmt.tags.get(name)
        if tv is None:
            return 0
        if not 0 <= tv.values[0] <= MAX_SEED:
            self.err(tv.tokens[0], f"{stmt.keyword} '{name}' must lie in 0..{MAX_SEED}, got {tv.tokens[0].text}")
        return int(tv.values[0])

    def existing_file(self, stmt: ParsedStatement, tag: str, what: str = "") -> Optional[Path]:
        """The absolute path of a file tag's value (relative to the script), or None and an error."""
        tok = stmt.tags[tag].tokens[0]
        try:
            path = Path(os.path.abspath(self.base_dir / tok.text))
            exists = path.exists()
        except (ValueError, OSError):  # embedded NUL, unencodable name, ...
            self.err(tok, f"{stmt.keyword} '{tag}' is not a valid file name: {tok.shown()}")
            return None
        if not exists:
            self.err(tok, what or f"{stmt.keyword} '{tag}' file '{tok.text}' not found (looked for {path})")
            return None
        try:
            check_regular(path)
        except ContractError as e:  # a folder, FIFO or device: never opened
            self.err(tok, f"{stmt.keyword} '{tag}' '{tok.text}': {e.detail}")
            return None
        return path
