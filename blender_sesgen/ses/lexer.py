"""SES lexer: text -> lines of tokens, each with its 1-based line and column.

Rules (docs/ses-language.md, "Lexical rules"): one statement per line, lines end at
``\n``, ``\r\n`` or ``\r`` and nowhere else (a form feed or U+2028 in a comment does not
start a line, so later line numbers stay those an editor shows); ``//`` starts a comment
running to the end of the line (outside strings); tokens are separated by spaces and tabs
only; a token is a NUMBER (ASCII digits, decimal or scientific, optional sign), a
double-quoted STRING (no escapes; may hold spaces and ``//``) or a bare WORD. Any other
space, control or format character outside a comment (NBSP, form feed, zero-width space,
bidirectional controls) and any non-ASCII digit is an error at its column. Columns count
characters, not bytes, so they match what an editor shows.
"""
from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass
from typing import Literal

from .diagnostics import Diagnostics

NUMBER_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
LINE_BREAK_RE = re.compile(r"\r\n|\r|\n")
SEPARATORS = " \t"
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

    def shown(self) -> str:
        """The token as written (for messages)."""
        return f'"{self.text}"' if self.kind == "string" else self.text


def decode(data: bytes, diags: Diagnostics) -> str | None:
    """UTF-8 text of a script; None and an error if it is not UTF-8."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        lines = re.split(rb"\r\n|\r|\n", data[: e.start])
        line, col = len(lines), len(lines[-1].decode("utf-8", errors="replace")) + 1
        diags.error(line, col, f"the file is not UTF-8 text (byte 0x{data[e.start]:02x} cannot be decoded); "
                    "save it as UTF-8")
        return None
    return text


def tokenize(text: str, diags: Diagnostics) -> list[list[Token]]:
    """Token lists of the non-empty lines, in order (comments and blank lines dropped)."""
    lines = []
    if text.startswith("\ufeff"):  # a UTF-8 byte-order mark is not part of the script
        text = text[1:]
    for lineno, raw in enumerate(LINE_BREAK_RE.split(text), start=1):
        tokens = _tokenize_line(raw, lineno, diags)
        if tokens:
            lines.append(tokens)
    return lines


def _char_name(ch: str) -> str:
    return f"U+{ord(ch):04X}" + (f" {unicodedata.name(ch)}" if unicodedata.name(ch, "") else "")


def _stray(ch: str, in_string: bool) -> str | None:
    """Why ``ch`` may not appear in a token (or a string), or None if it may."""
    cat = unicodedata.category(ch)
    if cat == "Cc" and ch != "\t" or cat in ("Zl", "Zp"):
        return f"control character {_char_name(ch)} is not allowed" + ("" if in_string else
                                                                        " (only spaces and tabs separate tokens)")
    if in_string:
        return None
    if cat == "Zs" or cat == "Cf":
        return f"{_char_name(ch)} is not allowed here: only spaces and tabs separate tokens"
    if cat == "Nd" and not "0" <= ch <= "9":
        return f"non-ASCII digit {_char_name(ch)}: write numbers with the digits 0-9"
    return None


_PLAIN_RE = re.compile(r"[\t\x20-\x21\x23-\x7e]*")    # printable ASCII and tabs, no '"': nothing to check
_WORD_RE = re.compile(r"[^ \t]+")


def _tokenize_line(raw: str, lineno: int, diags: Diagnostics) -> list[Token]:
    """The line's tokens; a line with a lexical error yields none (its errors are recorded)."""
    code = raw.split("//", 1)[0]
    if _PLAIN_RE.fullmatch(code):   # the common line, at a fraction of the cost: generated cities are long
        return [Token("number" if NUMBER_RE.fullmatch(m.group()) else "word", m.group(), lineno, m.start() + 1)
                for m in _WORD_RE.finditer(code)]
    tokens: list[Token] = []
    bad = False
    i, n = 0, len(raw)
    while i < n:
        ch = raw[i]
        if ch in SEPARATORS:
            i += 1
        elif raw.startswith("//", i):
            break
        elif ch == '"':
            end = raw.find('"', i + 1)
            if end < 0:
                diags.error(lineno, i + 1, "unterminated string: a closing '\"' is missing on this line")
                return []
            for j in range(i + 1, end):
                why = _stray(raw[j], in_string=True)
                if why:
                    diags.error(lineno, j + 1, why)
                    bad = True
            tokens.append(Token("string", raw[i + 1:end], lineno, i + 1))
            i = end + 1
        else:
            j = i
            while j < n and raw[j] not in SEPARATORS and raw[j] != '"' and not raw.startswith("//", j):
                why = _stray(raw[j], in_string=False)
                if why:
                    diags.error(lineno, j + 1, why)
                    bad = True
                j += 1
            text = raw[i:j]
            kind = "number" if NUMBER_RE.fullmatch(text) else "word"
            tokens.append(Token(kind, text, lineno, i + 1))
            i = j
    return [] if bad else tokens
