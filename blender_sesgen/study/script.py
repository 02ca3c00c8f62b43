"""Edit an SES script statement by statement (pure): what a study's factors do to a script.

:class:`Script` keeps the script's lines as they are (comments, blank lines, order) and
rewrites only the statements a factor touches, from their tokens (the language's own lexer
and statement reader), so a variant differs from its base in exactly those lines. Values
are written back in the language's number syntax (``format(x, ".10g")``).

    s = Script(text)
    s.set_tag("TIMING", "exposure", 0.004)      # adds TIMING if the script has none
    s.drop("FOG")
    s.append("MOVE id 9001 frame 3 position 1 0 -4")
    s.text
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Optional, Sequence, Union

from ..ses.diagnostics import Diagnostics
from ..ses.grammar import SINGLETON_KEYWORDS, STATEMENTS
from ..ses.lexer import LINE_BREAK_RE, tokenize
from ..ses.statements import ParsedStatement, read_statement
from ..errors import SesgenError

Value = Union[float, int, str]

# where a new statement goes: after the last of these (the script's head), else at the top
_HEAD = ("CAMERA", "START", "TIMING", "LENS", "SENSOR", "AUTOEXPOSURE", "IMU", "RENDER", "LOOK", "WORLD", "FOG",
         "NOISE")


def number(x: float) -> str:
    """A number as an SES token (no exponent for integers, 10 significant digits)."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return format(x, ".10g")


def word(value: Value) -> str:
    """A value as an SES token: numbers as :func:`number`, text bare or double-quoted."""
    if isinstance(value, bool):
        raise TypeError("booleans are not SES values")
    if isinstance(value, (int, float)):
        return number(value)
    text = str(value)
    if not text or any(c in text for c in ' \t"') or text.startswith("//"):
        if '"' in text:
            raise SesgenError(f"an SES string cannot hold a double quote: {text!r}")
        return f'"{text}"'
    return text


@dataclass
class Statement:
    """One statement of a :class:`Script`: its line index and what the reader made of it."""
    index: int
    parsed: ParsedStatement

    @property
    def keyword(self) -> str:
        return self.parsed.keyword

    def values(self, tag: str) -> Optional[tuple]:
        tv = self.parsed.tags.get(tag)
        return None if tv is None else tuple(tv.values)

    def get(self, tag: str, default=None):
        v = self.values(tag)
        if v is None:
            return default
        return v[0] if len(v) == 1 else v

    @property
    def numbers(self) -> tuple[float, ...]:
        return tuple(self.parsed.numbers)


def statement_line(keyword: str, tags: Sequence[tuple[str, Sequence[Value]]] = (),
                   numbers: Sequence[float] = ()) -> str:
    """``KEYWORD tag v v tag v ...`` (or ``KEYWORD n n n`` for EGO/POSE/FRAMES)."""
    parts = [keyword] + [number(x) for x in numbers]
    for tag, values in tags:
        parts.append(tag)
        parts += [word(v) for v in values]
    return " ".join(parts)


class Script:
    """An SES script as editable statements (see the module docstring)."""

    def __init__(self, text: str, source: str = "<script>"):
        if text.startswith("\ufeff"):
            text = text[1:]
        self.source = source
        self.lines: list[str] = LINE_BREAK_RE.split(text)
        if self.lines and self.lines[-1] == "":
            self.lines.pop()

    # --- reading --------------------------------------------------------------------------
    def _parse(self, i: int) -> Optional[ParsedStatement]:
        diags = Diagnostics(self.source)
        lines = tokenize(self.lines[i], diags)
        if not lines:
            return None
        stmt = read_statement(lines[0], diags)
        if diags or stmt is None:
            first = diags.items[0] if diags.items else None
            raise SesgenError(f"{self.source}:{i + 1}:{first.col if first else 1}: "
                              f"{first.message if first else 'not a statement'}")
        return stmt

    def statements(self, *keywords: str) -> list[Statement]:
        """The statements (of the given keywords, or all), in script order."""
        want = {k.upper() for k in keywords}
        out = []
        for i, line in enumerate(self.lines):
            head = line.strip().split(None, 1)
            if not head or head[0].startswith("//") or (want and head[0].upper() not in want):
                continue
            p = self._parse(i)
            if p is not None:
                out.append(Statement(i, p))
        return out

    def first(self, keyword: str) -> Optional[Statement]:
        found = self.statements(keyword)
        return found[0] if found else None

    def has(self, keyword: str) -> bool:
        return self.first(keyword) is not None

    # --- writing --------------------------------------------------------------------------
    def _line_of(self, p: ParsedStatement, replace: dict, drop: Iterable[str] = ()) -> str:
        """The statement rewritten: tags in ``replace`` get new values (appended if new),
        tags in ``drop`` go; every other tag keeps its tokens."""
        drop = set(drop)
        tags: list[tuple[str, list[str]]] = []
        for name, tv in sorted(p.tags.items(), key=lambda kv: (kv[1].tag.line, kv[1].tag.col)):
            if name in drop:
                continue
            if name in replace:
                tags.append((name, [word(v) for v in replace[name]]))
            else:
                tags.append((tv.tag.text, [t.shown() for t in tv.tokens]))
        for name, values in replace.items():
            if name not in p.tags and name not in drop:
                tags.append((name, [word(v) for v in values]))
        return " ".join([p.token.text] + [w for name, vals in tags for w in (name, *vals)])

    def set_tag(self, keyword: str, tag: str, *values: Value, drop: Iterable[str] = ()) -> None:
        """Give ``tag`` of the (singleton) statement ``keyword`` these values (none for a
        flag), adding the statement when the script has none; ``drop``: tags to remove."""
        self.set_tags(keyword, {tag: values}, drop=drop)

    def set_tags(self, keyword: str, tags: dict, drop: Iterable[str] = ()) -> None:
        keyword = keyword.upper()
        if keyword not in SINGLETON_KEYWORDS:
            raise ValueError(f"{keyword} is not a singleton statement")
        for name in tags:
            if name not in STATEMENTS[keyword].tags:
                raise SesgenError(f"{keyword} has no tag '{name}'")
        stmt = self.first(keyword)
        if stmt is None:
            self.insert_head(statement_line(keyword, [(k, v) for k, v in tags.items()]))
        else:
            self.lines[stmt.index] = self._line_of(stmt.parsed, {k: tuple(v) for k, v in tags.items()}, drop)

    def edit(self, stmt: Statement, tags: dict, drop: Iterable[str] = ()) -> None:
        """Rewrite one statement: new values for ``tags`` (added if absent), ``drop`` removed."""
        self.lines[stmt.index] = self._line_of(stmt.parsed, {k: tuple(v) for k, v in tags.items()}, drop)

    def drop(self, *keywords: str, where=None) -> int:
        """Remove every statement of these keywords (for which ``where(stmt)`` holds); the count."""
        gone = [s.index for s in self.statements(*keywords) if where is None or where(s)]
        for i in reversed(gone):
            del self.lines[i]
        return len(gone)

    def insert_head(self, line: str) -> None:
        """A statement among the script's head statements (after the last of CAMERA, START,
        TIMING, ...), else first."""
        heads = [s.index for s in self.statements(*_HEAD)]
        at = (max(heads) + 1) if heads else 0
        self.lines.insert(at, line)

    def append(self, *lines: str) -> None:
        self.lines.extend(lines)

    @property
    def text(self) -> str:
        return "\n".join(self.lines) + "\n"
