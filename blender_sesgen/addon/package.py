"""Build the Blender extension zip: ``python -m blender_sesgen.addon.package --out dist``.

Pure standard library (no bpy). The zip's root is the package's contents, with
``blender_manifest.toml`` at the root, so Blender's "Install from Disk" installs it as
``bl_ext.<repository>.blender_sesgen``. The archive is deterministic (sorted names, fixed
timestamps and permissions).

What goes in is an allowlist, never "everything but": the package's own source files, i.e.
Python modules with importable names (``name.py``, in folders with importable names) and
``blender_manifest.toml`` at the root (add a data file to ``EXTRA_FILES`` when the extension
needs one). So a ``.env``, ``.git/config``, an editor's backup (``ops.py~``, ``ops.py.orig``,
``#ops.py#``), a copy (``ops copy.py``), hidden files and folders, caches, tests and any
symbolic link (whatever it points to) stay out, even when someone leaves them in the folder.
"""
from __future__ import annotations

import argparse
import os
import re
import stat
import sys
import tomllib
import zipfile
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[1]
MANIFEST = "blender_manifest.toml"
EXTRA_FILES = {MANIFEST}                      # non-Python files the extension needs, relative paths
EXCLUDED_DIRS = {"__pycache__", "tests", "test"}
_MODULE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\.py")
_FOLDER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
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
    """Files that go into the zip (the allowlist above), relative to the package directory, sorted."""
    package_dir = Path(package_dir)
    out = []
    for folder, dirs, files in os.walk(package_dir, followlinks=False):
        here = Path(folder)
        rel_dir = here.relative_to(package_dir)
        dirs[:] = [d for d in dirs if _FOLDER.fullmatch(d) and d not in EXCLUDED_DIRS
                   and not (here / d).is_symlink()]
        for name in files:
            rel = rel_dir / name
            path = here / name
            wanted = rel.as_posix() in EXTRA_FILES or (_MODULE.fullmatch(name) and not name.startswith("test_"))
            if wanted and not path.is_symlink() and stat.S_ISREG(path.lstat().st_mode):
                out.append(rel)
    return sorted(out)


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
