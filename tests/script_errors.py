"""The check of an error table's row (tests/test_ses_errors.py, tests/test_ses_object_motion.py):
the script fails to parse with a ScriptError at the given line and at the column of a marker."""
from __future__ import annotations

import re

import pytest

from blender_sesgen.errors import ScriptError
from blender_sesgen.ses import parse_file


def expected_col(script: str, line: int, marker) -> int:
    """1-based column of ``marker`` on ``line`` (None: the line's first non-blank character)."""
    text = script.splitlines(keepends=True)[line - 1]
    if marker is None:
        return len(text) - len(text.lstrip()) + 1
    return text.index(marker) + 1


def parse_error(tmp_path, script: str, line: int, marker, pattern: str):
    """(path, error) of ``script`` written to a file and parsed: a ScriptError at ``line`` and
    the column of ``marker`` whose message matches ``pattern``."""
    path = tmp_path / "scene.ses"
    path.write_text(script, encoding="utf-8")
    with pytest.raises(ScriptError) as info:
        parse_file(path)
    err = info.value
    assert (err.file, err.line, err.col) == (str(path), line, expected_col(script, line, marker)), str(err)
    assert re.search(pattern, err.message), err.message
    return path, err
