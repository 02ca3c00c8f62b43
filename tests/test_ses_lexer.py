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


# --- line breaks, separators and digits (only \n, \r\n, \r break lines; only space and tab separate)

def test_only_newline_cr_and_crlf_break_lines():
    for sep in ("\f", "\x0b", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029"):
        lines, errors = toks(f"// a comment with {sep} inside\nQUAD id 1\n")
        assert not errors, sep
        assert lines[0][0][2] == 2, f"{sep!r} shifted the line numbers"
    lines, errors = toks("A 1\rB 2\r\nC 3\nD 4")
    assert not errors and [ln[0][1:3] for ln in lines] == [("A", 1), ("B", 2), ("C", 3), ("D", 4)]


def test_unicode_space_and_control_characters_are_errors_at_their_column():
    for ch in ("\u00a0", "\u2003", "\u200b", "\f", "\x0b", "\x85", "\u2028", "\u202e", "\x00"):
        lines, errors = toks(f"// ok {ch}\nQUAD id{ch}1\nSPHERE id 2\n")
        assert [(e.line, e.col) for e in errors] == [(2, 8)], repr(ch)
        assert "U+" in errors[0].message
        assert [ln[0][1] for ln in lines] == ["SPHERE"]  # the faulty line yields no tokens


def test_tab_still_separates_and_strings_may_hold_unicode_spaces():
    lines, errors = toks('QUAD\tid\t1 name "a\u00a0b"\n')
    assert not errors and [t[1] for t in lines[0]] == ["QUAD", "id", "1", "name", "a\u00a0b"]
    _, errors = toks('QUAD name "a\x00b"\n')
    assert [(e.line, e.col) for e in errors] == [(1, 13)]


def test_non_ascii_digits_are_errors():
    for digits in ("\u0661\u0662", "\uff11", "1\u0663", "\u096f.5", "\U0001d7d9"):
        lines, errors = toks(f"EGO {digits} 0 0 0 0 0\n")
        assert [(e.line, e.col) for e in errors][:1] == [(1, 5 + next(i for i, c in enumerate(digits) if not c.isascii()))]
        assert "non-ASCII digit" in errors[0].message and lines == []
    lines, errors = toks("EGO 123 0 0 0 0 0\n")
    assert not errors and lines[0][1][0] == "number"


def test_undecodable_byte_located_after_cr_line_breaks():
    from blender_sesgen.ses.lexer import decode
    d = Diagnostics("t.ses")
    assert decode(b"A\rB\rCC \xff", d) is None
    assert [(e.line, e.col) for e in d.items] == [(3, 4)]
