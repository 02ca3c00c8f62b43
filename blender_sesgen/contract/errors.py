"""The contract's one exception: malformed data at the boundary between the packages.

Both command lines treat it as a user error (one line, exit code 2). ``source`` and ``line``
locate it where there is a file; ``detail`` is the message without the location, for
callers that report the place their own way (the SES parser does: file:line:col).
"""
from __future__ import annotations

from typing import Optional


class ContractError(ValueError):
    """Data that breaks the on-disk contract or one of its conventions."""

    def __init__(self, detail: str, source: Optional[str] = None, line: Optional[int] = None):
        self.detail = detail
        self.source = source
        self.line = line
        where = f"{source}:{line}: " if source and line else f"{source}: " if source else ""
        super().__init__(where + detail)
