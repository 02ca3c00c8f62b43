"""SES lexer: text -> lines of tokens, each with its 1-based line and column.

Rules (docs/ses-language.md, "Lexical rules"): one statement per line; ``//`` starts a
comment running to the end of the line (outside strings); tokens are separated by
whitespace; a token is a NUMBER (decimal or scientific, optional sign), a double-quoted
STRING (no escapes; may hold spaces and ``//``) or a bare WORD. Columns count characters,
not bytes, so they match what an editor shows.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from .diagnostics import Diagnostics

NUMBER_RE = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
NONFINITE_RE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


@dataclass(frozen=True)
class Token:
    kind: Literal["number", "string", "word"]
    text: str          # the value: for strings, without the quotes
    line: int
    col: int

    @property
    def lower(self) -> str:
        return self.text.lower()

    def is_word(self, *names: str) -> bool:
        return self.kind == "word" and (not names or self.lower in names)

    def shown(self) -> str:
        """The token as written (for messages)."""
        return f'"{self.text}"' if self.kind == "string" else self.text


def decode(data: bytes, diags: Diagnostics) -> str | None:
    """UTF-8 text of a script; None and an error if it is not UTF-8."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        before = data[: e.start]
        line = before.count(b"\n") + 1
        col = len(before[before.rfind(b"\n") + 1:].decode("utf-8", errors="replace")) + 1
        diags.error(line, col, f"the file is not UTF-8 text (byte 0x{data[e.start]:02x} cannot be decoded); "
                    "save it as UTF-8")
        return None
    return text


def tokenize(text: str, diags: Diagnostics) -> list[list[Token]]:
    """Token lists of the non-empty lines, in order (comments and blank lines dropped)."""
    lines = []
    if text.startswith("\ufeff"):  # a UTF-8 byte-order mark is not part of the script
        text = text[1:]
    for lineno, raw in enumerate(text.splitlines(), start=1):
        tokens = _tokenize_line(raw, lineno, diags)
        if tokens:
            lines.append(tokens)
    return lines


def _tokenize_line(raw: str, lineno: int, diags: Diagnostics) -> list[Token]:
    tokens: list[Token] = []
    i, n = 0, len(raw)
    while i < n:
        ch = raw[i]
        if ch.isspace():
            i += 1
        elif raw.startswith("//", i):
            break
        elif ch == '"':
            end = raw.find('"', i + 1)
            if end < 0:
                diags.error(lineno, i + 1, "unterminated string: a closing '\"' is missing on this line")
                return []
            tokens.append(Token("string", raw[i + 1:end], lineno, i + 1))
            i = end + 1
        else:
            j = i
            while j < n and not raw[j].isspace() and raw[j] != '"' and not raw.startswith("//", j):
                j += 1
            text = raw[i:j]
            kind = "number" if NUMBER_RE.fullmatch(text) else "word"
            tokens.append(Token(kind, text, lineno, i + 1))
            i = j
    return tokens
