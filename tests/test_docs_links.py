"""Every relative link of the repository's Markdown pages resolves: the file exists and the
``#anchor`` is a heading of it (tools/check_links.py, GitHub's anchor rule)."""
from __future__ import annotations

import runpy
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
check_links = runpy.run_path(str(REPO / "tools" / "check_links.py"))


def test_every_relative_link_of_the_docs_resolves():
    pages = [REPO / "README.md", REPO / "scenes" / "README.md", REPO / "bench" / "RESULTS.md",
             *sorted((REPO / "docs").glob("*.md"))]
    assert [p for page in pages for p in check_links["broken"](page)] == []


def test_a_missing_page_or_heading_is_found(tmp_path):
    (tmp_path / "a.md").write_text("# Top\n## Two words\n[ok](#two-words) [bad](#three) [gone](b.md)\n")
    found = check_links["broken"](tmp_path / "a.md", root=tmp_path)
    assert [f.split(": ", 1)[1] for f in found] == ["#three (no such heading)", "b.md (no such file)"]
