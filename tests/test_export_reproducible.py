"""Every export layout is byte-reproducible: two exports of one render (into different
folders, at different times) are identical file for file, byte for byte."""
from __future__ import annotations

from pathlib import Path

import pytest

from vo_reference.products.exports import EXPORTERS

pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")
N = 3


def tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("target, extra", [(t, {}) for t in sorted(EXPORTERS)] + [("rosbag", {"storage": "sqlite3"})])
def test_two_exports_of_one_render_are_identical(layout_render, tmp_path, target, extra):
    from vo_reference.products.exports import export
    if target == "rosbag":
        pytest.importorskip("rosbags")
    a = export(layout_render, target, tmp_path / "first" / "out", progress=False, extra=extra)
    b = export(layout_render, target, tmp_path / "second" / "elsewhere", progress=False, extra=extra)
    ta, tb = tree(tmp_path / "first" / "out"), tree(tmp_path / "second" / "elsewhere")
    assert ta and sorted(ta) == sorted(tb)
    differ = [name for name in ta if ta[name] != tb[name]]
    assert not differ, f"{target}: {differ[:5]} differ between two exports of one render"
    assert a.relative_to(tmp_path / "first" / "out") == b.relative_to(tmp_path / "second" / "elsewhere")
