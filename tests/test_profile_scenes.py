"""bench/profile_scenes.py's repeated rows: the row shown is one real process's (its stages
add up to its total), the median by CPU to first sample, the lower middle of an even count."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
profile_scenes = pytest.importorskip("profile_scenes")


def _row(cpu: float, tag: str) -> dict:
    return {"to_first_sample": {"cpu": cpu}, "tag": tag}


def test_median_row_is_one_process_row():
    rows = [_row(5.0, "a"), _row(2.0, "b"), _row(9.0, "c")]
    assert profile_scenes.median_row(rows) is rows[0]
    # an even count: the lower middle (a real row, never an average of two)
    rows = [_row(7.0, "a"), _row(2.0, "b"), _row(4.0, "c"), _row(9.0, "d")]
    assert profile_scenes.median_row(rows)["tag"] == "c"
    assert profile_scenes.median_row([_row(3.0, "x")])["tag"] == "x"
