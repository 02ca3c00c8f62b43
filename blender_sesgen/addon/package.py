"""Build the Blender extension zip: ``python -m blender_sesgen.addon.package --out dist``.

Pure standard library (no bpy). The zip's root is the package's contents, with
``blender_manifest.toml`` at the root, so Blender's "Install from Disk" installs it as
``bl_ext.<repository>.blender_sesgen``. Tests, caches and compiled files are left out; the
archive is deterministic (sorted names, fixed timestamps).
"""
from __future__ import annotations

import argparse
import re
import sys
import tomllib
import zipfile
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[1]
MANIFEST = "blender_manifest.toml"
EXCLUDED_DIRS = {"__pycache__", "tests", "test", ".pytest_cache", ".mypy_cache", ".ruff_cache"}
EXCLUDED_SUFFIXES = (".pyc", ".pyo", ".orig", ".rej", ".swp", "~")
EXCLUDED_NAMES = {".DS_Store", "Thumbs.db"}
_FIXED_TIME = (2024, 1, 1, 0, 0, 0)


class PackageError(Exception):
    pass


def read_manifest(package_dir: Path = PACKAGE_DIR) -> dict:
    path = package_dir / MANIFEST
    try:
        with open(path, "rb") as f:
            m = tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise PackageError(f"{path}: {e}") from None
    for key in ("schema_version", "id", "version", "name", "tagline", "maintainer", "type",
                "blender_version_min", "license"):
        if key not in m:
            raise PackageError(f"{path}: missing '{key}'")
    code_version = _package_version(package_dir)
    if code_version is not None and code_version != m["version"]:
        raise PackageError(f"{path}: version {m['version']} differs from __version__ {code_version}")
    return m


def _package_version(package_dir: Path):
    text = (package_dir / "__init__.py").read_text(encoding="utf-8")
    hit = re.search(r'^__version__\s*=\s*["\']([^"\']+)["\']', text, re.M)
    return hit.group(1) if hit else None


def included_files(package_dir: Path = PACKAGE_DIR) -> list[Path]:
    """Files that go into the zip, relative to the package directory, sorted."""
    out = []
    for p in sorted(package_dir.rglob("*")):
        rel = p.relative_to(package_dir)
        if not p.is_file() or any(part in EXCLUDED_DIRS or part.endswith(".egg-info") for part in rel.parts[:-1]):
            continue
        if p.name in EXCLUDED_NAMES or p.name.endswith(EXCLUDED_SUFFIXES):
            continue
        if rel.parts[0] in EXCLUDED_DIRS or (len(rel.parts) == 1 and p.name.startswith("test_")):
            continue
        out.append(rel)
    return out


def build_zip(out_dir, package_dir: Path = PACKAGE_DIR) -> Path:
    """Write ``<out_dir>/<id>-<version>.zip`` and return its path."""
    package_dir = Path(package_dir)
    m = read_manifest(package_dir)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"{m['id']}-{m['version']}.zip"
    tmp = target.with_name(target.name + ".tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for rel in included_files(package_dir):
            info = zipfile.ZipInfo(rel.as_posix(), date_time=_FIXED_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            z.writestr(info, (package_dir / rel).read_bytes())
    tmp.replace(target)
    return target


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m blender_sesgen.addon.package",
                                description="Build the Blender extension zip of blender_sesgen.")
    p.add_argument("--out", default="dist", metavar="DIR", help="output folder (default: dist)")
    args = p.parse_args(argv)
    try:
        path = build_zip(args.out)
    except PackageError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    with zipfile.ZipFile(path) as z:
        n = len(z.namelist())
    print(f"{path} ({n} files, {path.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
