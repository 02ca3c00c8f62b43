"""The one exception family of blender_sesgen.

Every *expected* failure (bad script, bad arguments, a folder that holds another
scene's output) is a :class:`SesgenError`; the CLI prints it as one line and exits 2.
Anything else is a bug or a render failure (exit 1).
"""
from __future__ import annotations


class SesgenError(Exception):
    """A user error: printed as one line, exit code 2."""


class ScriptError(SesgenError):
    """An error located in an SES script: ``file:line:col: error: message``.

    ``line`` and ``col`` are 1-based; ``col`` points at the offending token.
    """

    def __init__(self, message: str, file: str = "<script>", line: int = 0, col: int = 0):
        self.message = message
        self.file = file
        self.line = line
        self.col = col
        super().__init__(str(self))

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}: error: {self.message}"
