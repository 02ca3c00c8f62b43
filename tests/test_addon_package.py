"""The add-on's pure parts (no bpy): extension manifest, zip packaging, relative imports,
the panel's parse status, the ground-truth preview maths."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest

import blender_sesgen
from blender_sesgen.addon import package, preview, state

REPO = Path(__file__).resolve().parents[1]
PKG = REPO / "blender_sesgen"


def test_manifest_is_a_valid_extension_manifest():
    with open(PKG / "blender_manifest.toml", "rb") as f:
        m = tomllib.load(f)
    assert m["schema_version"] == "1.0.0"
    assert m["id"] == "blender_sesgen" and m["type"] == "add-on"
    assert m["version"] == blender_sesgen.__version__
    assert m["blender_version_min"] == "4.2.0"
    assert m["license"] == ["SPDX:GPL-3.0-or-later"]
    assert m["permissions"]["files"]
    # Blender's manifest rules: short tagline/permission text with no trailing punctuation
    assert len(m["tagline"]) <= 64 and not m["tagline"].endswith((".", "!", "?"))
    assert len(m["permissions"]["files"]) <= 64 and not m["permissions"]["files"].endswith(".")


def test_package_uses_relative_imports_only():
    offenders = []
    for p in PKG.rglob("*.py"):
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
            if re.match(r"\s*(from|import)\s+blender_sesgen\b", line):
                offenders.append(f"{p.relative_to(REPO)}:{n}: {line.strip()}")
    assert not offenders, "absolute imports break the installed extension (bl_ext.<repo>.blender_sesgen):\n" + "\n".join(offenders)


def test_zip_has_manifest_at_root_and_leaves_out_tests_and_caches(tmp_path):
    src = tmp_path / "blender_sesgen"
    shutil.copytree(PKG, src, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    (src / "__pycache__").mkdir()
    (src / "__pycache__" / "x.cpython-311.pyc").write_bytes(b"\0")
    (src / "addon" / "stale.pyc").write_bytes(b"\0")
    (src / "tests").mkdir()
    (src / "tests" / "test_x.py").write_text("def test_x(): pass\n")
    z1 = package.build_zip(tmp_path / "d1", src)
    assert z1.name == f"blender_sesgen-{blender_sesgen.__version__}.zip"
    names = zipfile.ZipFile(z1).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert not any("__pycache__" in n or n.endswith(".pyc") or n.startswith("tests/") for n in names)
    expected = {p.relative_to(PKG).as_posix() for p in PKG.rglob("*.py") if "__pycache__" not in p.parts}
    assert expected <= set(names)
    for sub in ("addon/__init__.py", "addon/ops.py", "blender/builder.py", "ses/parser.py", "pipeline.py"):
        assert sub in names
    z2 = package.build_zip(tmp_path / "d2", src)
    assert z1.read_bytes() == z2.read_bytes(), "the zip must be reproducible"


def test_package_command_runs_without_bpy(tmp_path):
    code = ("import sys, runpy; sys.argv = ['package', '--out', sys.argv[1]];\n"
            "try:\n    runpy.run_module('blender_sesgen.addon.package', run_name='__main__')\n"
            "except SystemExit as e:\n    assert e.code in (0, None), e.code\n"
            "assert 'bpy' not in sys.modules, 'packaging imported bpy'\n")
    r = subprocess.run([sys.executable, "-c", code, str(tmp_path / "dist")], cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "dist" / f"blender_sesgen-{blender_sesgen.__version__}.zip").is_file()


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_make_addon_works_on_a_fresh_checkout_without_a_venv(tmp_path):
    """``make addon`` in a checkout that has no .venv (only the Makefile and the package)."""
    shutil.copy(REPO / "Makefile", tmp_path / "Makefile")
    shutil.copytree(PKG, tmp_path / "blender_sesgen", ignore=shutil.ignore_patterns("__pycache__"))
    assert not (tmp_path / ".venv").exists()
    r = subprocess.run(["make", "addon", f"PYTHON={sys.executable}"], cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "dist" / f"blender_sesgen-{blender_sesgen.__version__}.zip").is_file()
    assert not (tmp_path / ".venv").exists()


def test_version_mismatch_is_refused(tmp_path):
    src = tmp_path / "blender_sesgen"
    src.mkdir()
    (src / "__init__.py").write_text('__version__ = "9.9.9"\n')
    shutil.copy(PKG / "blender_manifest.toml", src)
    with pytest.raises(package.PackageError, match="differs"):
        package.build_zip(tmp_path / "d", src)


# --- what the panel shows ------------------------------------------------------------------

def test_script_info_ok_summarises_the_scene():
    info = state.script_info(str(REPO / "scenes" / "minimal.ses"))
    assert info.ok
    text = "\n".join(info.summary)
    assert "Objects: 5" in text and "1 cuboid" in text and "2 quad" in text
    assert "Frames: 3" in text and "64x48" in text and "baseline 0.1" in text


def test_script_info_error_names_line_and_column(tmp_path):
    bad = tmp_path / "bad.ses"
    bad.write_text("CAMERA resolution 64 48 focal 40\nSTART position 0 0 0\nCUBOID id 1 position 0 0 0 dim 1 1\n")
    info = state.script_info(str(bad))
    assert info.state == "error"
    assert info.message.startswith("line 3:") and "dim" in info.message
    assert info.errors[0][0] == 3
    # the cache follows edits of the file
    bad.write_text("CAMERA resolution 64 48 focal 40\nSTART position 0 0 0\nCUBOID id 1 position 0 0 0 dim 1 1 1\n")
    assert state.script_info(str(bad)).ok
    assert state.script_info(str(tmp_path / "nope.ses")).state == "missing"
    assert state.script_info("").state == "none"


# --- preview maths -----------------------------------------------------------------------

def test_disparity_is_fB_over_Z_and_zero_on_background():
    z = np.array([[2.0, 4.0], [1e10, 0.5]], dtype=np.float32)
    d = preview.disparity_px(z, 400.0, 0.1)
    np.testing.assert_allclose(d, [[20.0, 10.0], [0.0, 80.0]], rtol=1e-6)


def test_preview_refuses_frames_not_rendered(tmp_path):
    from blender_sesgen.errors import SesgenError
    with pytest.raises(SesgenError, match="no render here"):
        preview.preview_rgba(tmp_path, 0, "left", "disparity")


def test_zip_holds_only_the_package_source_whatever_else_lies_in_the_folder(tmp_path):
    """An allowlist: plant secrets, VCS files, backups, copies and symlinks in a copy of the
    package; the zip must hold exactly the tracked source files."""
    src = tmp_path / "blender_sesgen"
    shutil.copytree(PKG, src, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    secret = tmp_path / "outside_secret.py"
    secret.write_text("TOKEN = 'abc'\n")
    (tmp_path / "outside_dir").mkdir()
    (tmp_path / "outside_dir" / "stolen.py").write_text("x = 1\n")
    planted = {
        ".env": "API_KEY=xyz\n", ".git/config": "[remote]\n", ".git/HEAD": "ref\n", "addon/ops.py~": "old\n",
        "addon/ops.py.orig": "old\n", "addon/ops.py.bak": "old\n", "addon/#ops.py#": "old\n",
        "addon/.ops.py.swp": "old\n", "addon/ops copy.py": "old\n", "addon/ops-old.py": "old\n",
        ".hidden/mod.py": "x\n", "secrets/id_rsa": "KEY\n", "notes.txt": "n\n", "build.log": "l\n",
        "backup.py.save": "x\n", "addon/state.pyc": "\0", "test_local.py": "def test(): pass\n",
        "blender/textures/.DS_Store": "x", "dist/blender_sesgen-0.1.0.zip": "PK",
    }
    for rel, text in planted.items():
        (src / rel).parent.mkdir(parents=True, exist_ok=True)
        (src / rel).write_text(text)
    (src / "linked.py").symlink_to(secret)                 # a symlinked module: its target stays out
    (src / "contract" / "linked_dir").symlink_to(tmp_path / "outside_dir", target_is_directory=True)
    (src / "manifest_link.toml").symlink_to(src / "blender_manifest.toml")
    names = set(zipfile.ZipFile(package.build_zip(tmp_path / "d", src)).namelist())
    tracked = set(subprocess.run(["git", "ls-files", "blender_sesgen"], cwd=REPO, capture_output=True,
                                 text=True, check=True).stdout.split())
    expected = {t.removeprefix("blender_sesgen/") for t in tracked if (REPO / t).is_file()}
    assert names == expected, (sorted(names - expected), sorted(expected - names))
    with zipfile.ZipFile(package.build_zip(tmp_path / "d", src)) as z:
        assert not any(b"API_KEY" in z.read(n) or b"TOKEN" in z.read(n) for n in z.namelist())
