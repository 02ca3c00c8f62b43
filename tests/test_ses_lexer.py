"""Tokens, their kinds and their 1-based line/column (in characters, not bytes)."""
from __future__ import annotations

from blender_sesgen.ses.diagnostics import Diagnostics
from blender_sesgen.ses.lexer import tokenize


def toks(text):
    d = Diagnostics("t.ses")
    return [[(t.kind, t.text, t.line, t.col) for t in line] for line in tokenize(text, d)], d.items


def test_kinds_and_positions():
    lines, errors = toks('// header\n\nQUAD  id 7\t"a b" -1.5e+3 nan x//y\n')
    assert not errors
    assert lines == [[("word", "QUAD", 3, 1), ("word", "id", 3, 7), ("number", "7", 3, 10),
                      ("string", "a b", 3, 12), ("number", "-1.5e+3", 3, 18), ("word", "nan", 3, 26),
                      ("word", "x", 3, 30)]]


def test_columns_count_characters():
    lines, _ = toks('SPHERE name "żółw" id 3\n')
    assert [t[3] for t in lines[0]] == [1, 8, 13, 20, 23]


def test_number_forms():
    lines, _ = toks("1 -0.5 .5 5. 2.5e-3 +1E2 1e 1.2.3 0x10 1_000\n")
    kinds = [t[0] for t in lines[0]]
    assert kinds == ["number"] * 6 + ["word"] * 4


def test_crlf_bom_and_unterminated_string():
    lines, errors = toks('\ufeffEGO 1 2 3 4 5 6\r\nQUAD "oops\r\n')
    assert lines == [[("word", "EGO", 1, 1)] + [("number", str(i), 1, 5 + 2 * (i - 1)) for i in range(1, 7)]]
    assert [(e.line, e.col) for e in errors] == [(2, 6)] and "unterminated" in errors[0].message
