"""Read one line's tokens into a keyword and its tagged values (syntax only, no meaning).

Numbers after a ``numbers`` tag are read greedily up to the next non-number token, so
``position 0 1 0.2`` and ``position 0 1 0.2 0 0 0`` both work and the next bare word is
the next tag. Keywords and tags are case-insensitive; ``color`` is ``colour``.
"""
from __future__ import annotations

import difflib
import re
from dataclasses import dataclass, field
from typing import Optional, Union

from .diagnostics import Diagnostics
from .grammar import STATEMENTS, TAG_HINTS, TAG_SYNONYMS, Statement, Tag
from .lexer import NONFINITE_RE, NUMBER_RE, Token

Value = Union[float, int, str, bool]
MAX_ABS = 1e9  # keeps every later product (areas, poses) finite


@dataclass
class TagValue:
    tag: Token                        # the tag word (for messages about the whole tag)
    values: tuple[Value, ...]
    tokens: tuple[Token, ...]         # one per value (for messages about one value)


@dataclass
class ParsedStatement:
    keyword: str                      # canonical upper-case keyword
    token: Token                      # the keyword token
    tags: dict[str, TagValue] = field(default_factory=dict)
    numbers: tuple[float, ...] = ()   # EGO / POSE values
    number_tokens: tuple[Token, ...] = ()

    def has(self, name: str) -> bool:
        return name in self.tags

    def get(self, name: str, default=None):
        tv = self.tags.get(name)
        if tv is None:
            return default
        return tv.values[0] if len(tv.values) == 1 else tv.values


def did_you_mean(word: str, candidates) -> str:
    close = difflib.get_close_matches(word.lower(), [c.lower() for c in candidates], n=1, cutoff=0.6)
    if not close:
        return ""
    original = {c.lower(): c for c in candidates}[close[0]]
    return f"; did you mean '{original}'?"


def kinds(spec: Statement) -> list[str]:
    """The statement's kinds: its flag tags written as the word after the keyword (ASSET car)."""
    return [t.name for t in spec.tags.values() if t.kind == "flag" and t.name not in ("allow_external",)]


def hint(word: str, spec: Statement, following: str = "") -> str:
    """What to write instead of ``word`` in a ``spec`` statement (grammar.TAG_HINTS), as
    "; " + the hint; else a close tag name ("did you mean"); else "". ``following``: the
    next word (``ASSET kind car`` -> ``ASSET car``)."""
    for target, text in TAG_HINTS.get(word.lower(), ()):
        tag = spec.tags.get(target)
        k = kinds(spec)
        if tag is not None or (target == "KIND" and k):
            kind = following.lower() if following.lower() in k else (k or [""])[0]
            return "; " + text.format(usage=tag.usage if tag else "", keyword=spec.keyword, kind=kind)
    return did_you_mean(word, spec.tags)


def tag_list(spec: Statement) -> str:
    """The tags of ``spec`` for a message; many kinds (ASSET's) listed apart."""
    k = kinds(spec)
    if len(k) <= 5:
        return f"tags: {', '.join(spec.tags)}"
    return f"tags: {', '.join(t for t in spec.tags if t not in k)}; kinds: {', '.join(k)}"


def read_statement(tokens: list[Token], diags: Diagnostics) -> Optional[ParsedStatement]:
    """The statement of one line, or None (with errors recorded) if its syntax is wrong."""
    head = tokens[0]
    if head.kind != "word":
        diags.at(head, f"expected a keyword at the start of the statement, got '{head.shown()}'")
        return None
    spec = STATEMENTS.get(head.text.upper())
    if spec is None:
        diags.at(head, f"unknown keyword '{head.text}'{did_you_mean(head.text, STATEMENTS)}"
                       f" (keywords: {', '.join(STATEMENTS)})")
        return None
    before = len(diags.items)
    stmt = ParsedStatement(spec.keyword, head)
    if spec.positional:
        _read_positional(spec, stmt, tokens[1:], diags)
    else:
        _read_tags(spec, stmt, tokens[1:], diags)
    return stmt if len(diags.items) == before else None


def _not_a_number_hint(text: str) -> str:
    """What a near-number is missing: ``640x480`` -> two numbers; ``0,`` -> spaces; ``12cm`` -> no unit."""
    if re.fullmatch(r"[0-9.]+[xX×][0-9.]+", text):
        return f"; write two numbers separated by a space: '{re.sub(r'[xX×]', ' ', text)}'"
    if "," in text and all(NUMBER_RE.fullmatch(p) for p in text.split(",") if p):
        return "; separate numbers with spaces, not commas"
    head = re.match(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)", text)
    if head and re.fullmatch(r"[a-zA-Z°%]+", text[head.end():]):
        return f"; numbers take no unit: write '{head.group()}' (each tag's unit is fixed, docs/ses-language.md)"
    return ""


def _number(tok: Token, where: str, diags: Diagnostics) -> Optional[float]:
    if tok.kind == "word" and NONFINITE_RE.fullmatch(tok.text):
        diags.at(tok, f"{where}: '{tok.text}' is not allowed, numbers must be finite")
        return None
    if tok.kind != "number":
        diags.at(tok, f"{where} expects a number, got '{tok.shown()}'{_not_a_number_hint(tok.text)}")
        return None
    value = float(tok.text)
    if not abs(value) <= MAX_ABS:  # also catches overflow to inf
        diags.at(tok, f"{where}: {tok.text} is out of range (|number| <= {MAX_ABS:g})")
        return None
    return value


def _is_numberish(tok: Token) -> bool:
    return tok.kind == "number" or (tok.kind == "word" and bool(NONFINITE_RE.fullmatch(tok.text)))


def _read_positional(spec: Statement, stmt: ParsedStatement, rest: list[Token], diags: Diagnostics) -> None:
    where = f"{spec.keyword}"
    if len(rest) != spec.positional:
        at = rest[spec.positional] if len(rest) > spec.positional else stmt.token
        diags.at(at, f"{spec.keyword} needs {_count_words((spec.positional,))} ({spec.positional_usage}), "
                     f"got {len(rest)}")
        return
    values = [_number(t, where, diags) for t in rest]
    if None not in values:
        stmt.numbers = tuple(values)
        stmt.number_tokens = tuple(rest)


def _tag_of(tok: Token, spec: Statement) -> Optional[Tag]:
    if tok.kind != "word":
        return None
    name = TAG_SYNONYMS.get(tok.lower, tok.lower)
    return spec.tags.get(name)


def _read_tags(spec: Statement, stmt: ParsedStatement, rest: list[Token], diags: Diagnostics) -> None:
    kw = spec.keyword
    errors_before = len(diags.items)
    i = 0
    while i < len(rest):
        tok = rest[i]
        tag = _tag_of(tok, spec)
        if tag is None:
            if tok.kind == "word" and not NONFINITE_RE.fullmatch(tok.text):
                after = rest[i + 1].text if i + 1 < len(rest) else ""
                why = _not_a_number_hint(tok.text) or hint(tok.text, spec, after)
                diags.at(tok, f"{kw} has no tag '{tok.text}'{why} ({tag_list(spec)})")
            else:
                diags.at(tok, f"{kw}: expected a tag ({', '.join(spec.tags)}), got the value '{tok.shown()}'"
                              + _values_hint(spec, rest, i))
            i += 1
            while i < len(rest) and _tag_of(rest[i], spec) is None:  # skip to the next tag
                i += 1
            continue
        if tag.name in stmt.tags:
            first = stmt.tags[tag.name].tag
            diags.at(tok, f"{kw} tag '{tag.name}' is given twice (first at column {first.col})")
        i = _read_values(spec, tag, tok, rest, i + 1, stmt, diags)
    if len(diags.items) != errors_before:
        return  # a misspelt tag would also show up as a missing one: report only the cause
    for tag in spec.tags.values():
        if tag.required and tag.name not in stmt.tags:
            diags.at(stmt.token, f"{kw} needs the tag '{tag.name}' ({tag.usage})")


def _values_hint(spec: Statement, rest: list[Token], i: int) -> str:
    """Numbers right after the keyword, as many as its first required tag takes: "did you mean"
    them after that tag (``START 0 1 2`` -> ``START position 0 1 2``)."""
    j = i
    while j < len(rest) and rest[j].kind == "number":
        j += 1
    need = next((t for t in spec.tags.values() if t.required and t.kind == "numbers"), None)
    if i != 0 or need is None or j - i not in need.counts:
        return ""
    return f"; did you mean '{spec.keyword} {need.name} {' '.join(t.text for t in rest[i:j])}'?"


def _read_values(spec: Statement, tag: Tag, tag_tok: Token, rest: list[Token], i: int,
                 stmt: ParsedStatement, diags: Diagnostics) -> int:
    """Read the values of ``tag`` from ``rest[i:]``; store them; return the next index."""
    kw = spec.keyword
    where = f"{kw} '{tag.name}'"
    if tag.kind == "flag":
        stmt.tags.setdefault(tag.name, TagValue(tag_tok, (True,), ()))
        return i
    if tag.kind == "numbers":
        j = i
        while j < len(rest) and _is_numberish(rest[j]):
            j += 1
        toks = rest[i:j]
        if len(toks) not in tag.counts:
            if len(toks) < max(tag.counts) and j < len(rest) and _tag_of(rest[j], spec) is None:
                diags.at(rest[j], f"{where} expects a number, got '{rest[j].shown()}'"
                                  f"{_not_a_number_hint(rest[j].text)}")
                return j + 1   # that word was meant as a value: not also an unknown tag
            else:
                diags.at(tag_tok, f"{where} needs {_count_words(tag.counts)} ({tag.usage}), got {len(toks)}")
            return j
        values = [_number(t, where, diags) for t in toks]
        if None not in values:
            stmt.tags.setdefault(tag.name, TagValue(tag_tok, tuple(values), tuple(toks)))
        return j
    # one-token kinds
    if i >= len(rest):
        diags.at(tag_tok, f"{where} needs a value ({tag.usage})")
        return i
    tok = rest[i]
    if tag.kind == "int":
        value = _number(tok, where, diags)
        if value is not None:
            if not float(value).is_integer():
                diags.at(tok, f"{where} must be an integer, got {tok.text}")
            else:
                stmt.tags.setdefault(tag.name, TagValue(tag_tok, (int(value),), (tok,)))
    elif tag.kind == "choice":
        if tok.lower not in tag.choices:
            diags.at(tok, f"{where} must be one of {', '.join(tag.choices)}, got '{tok.shown()}'")
        else:
            stmt.tags.setdefault(tag.name, TagValue(tag_tok, (tok.lower,), (tok,)))
    else:  # text
        stmt.tags.setdefault(tag.name, TagValue(tag_tok, (tok.text,), (tok,)))
    return i + 1


def _count_words(counts: tuple[int, ...]) -> str:
    noun = "number" if counts == (1,) else "numbers"
    return " or ".join(str(c) for c in counts) + f" {noun}"
