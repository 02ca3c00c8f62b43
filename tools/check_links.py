"""Check the relative links of the repository's Markdown files: every linked file exists and every
``#anchor`` names a heading of its page (GitHub's rule: lower case, punctuation dropped, spaces
to hyphens, ``-1``, ``-2`` for repeats).

    python tools/check_links.py [FILE.md ...]      # default: every tracked *.md

Prints one line per broken link (``file:line: target``) and exits 1 if there is any.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    fenced = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        slug = re.sub(r"[^\w\- ]", "", m.group(1).lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def broken(path: Path, root: Path = REPO) -> list[str]:
    out = []
    fenced = False
    for no, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
        if fenced:
            continue
        for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):      # http:, mailto:, ...
                continue
            file, _, anchor = target.partition("#")
            dest = (path.parent / file).resolve() if file else path
            if not dest.exists():
                out.append(f"{path.relative_to(root)}:{no}: {target} (no such file)")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                out.append(f"{path.relative_to(root)}:{no}: {target} (no such heading)")
    return out


def main(argv: list[str]) -> int:
    files = [Path(a).resolve() for a in argv] or [
        REPO / f for f in subprocess.run(["git", "ls-files", "*.md"], cwd=REPO, capture_output=True,
                                          text=True, check=True).stdout.split()]
    problems = [p for f in files for p in broken(f)]
    print("\n".join(problems) if problems else f"{len(files)} files: every relative link resolves")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
