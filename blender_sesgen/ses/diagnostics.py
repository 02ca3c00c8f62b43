"""Error collection for one parse: every problem is kept with its line and column."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import ScriptError


@dataclass(frozen=True)
class Diagnostic:
    line: int
    col: int
    message: str


class Diagnostics:
    """Collects errors of one script; :meth:`raise_if_any` raises the first as ScriptError."""

    def __init__(self, file: str):
        self.file = file
        self.items: list[Diagnostic] = []

    def error(self, line: int, col: int, message: str) -> None:
        self.items.append(Diagnostic(line, col, message))

    def at(self, token, message: str) -> None:
        self.error(token.line, token.col, message)

    def __bool__(self) -> bool:
        return bool(self.items)

    def raise_if_any(self) -> None:
        """Raise the first error (in source order); all of them ride along as ``.errors``."""
        if not self.items:
            return
        ordered = sorted(self.items, key=lambda d: (d.line, d.col))
        errors = tuple(ScriptError(d.message, self.file, d.line, d.col) for d in ordered)
        first = errors[0]
        first.errors = errors
        raise first
