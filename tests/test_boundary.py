"""Import boundary: the pure modules and all of vo_reference import with bpy blocked.

Runs in a fresh interpreter whose meta path refuses ``bpy`` (and its helpers), so an import
of bpy anywhere in these modules fails loudly instead of passing where bpy is installed.
"""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

PURE = ["blender_sesgen", "blender_sesgen.ses", "blender_sesgen.model", "blender_sesgen.poses",
        "blender_sesgen.intrinsics", "blender_sesgen.textures", "blender_sesgen.errors",
        "blender_sesgen.check", "blender_sesgen.cli"]

PROBE = textwrap.dedent("""
    import importlib, pkgutil, sys

    BLOCKED = {"bpy", "bmesh", "mathutils", "bpy_extras"}

    class Block:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ImportError(f"{name} is blocked by the boundary test")
            return None

    sys.meta_path.insert(0, Block())
    failures = []
    def try_import(name):
        try:
            importlib.import_module(name)
        except Exception as e:
            failures.append(f"{name}: {type(e).__name__}: {e}")

    for name in sys.argv[1:]:
        try_import(name)
    import vo_reference
    try_import("vo_reference")
    for info in pkgutil.walk_packages(vo_reference.__path__, "vo_reference."):
        if not info.name.endswith(".__main__"):  # __main__ runs the CLI when imported
            try_import(info.name)
    # the ses package must not pull vo_reference in (nor bpy)
    leaked = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
    if leaked:
        failures.append(f"blocked modules in sys.modules: {leaked}")
    print("\\n".join(failures))
    sys.exit(1 if failures else 0)
""")


def _run(code: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code, *args], cwd=REPO, capture_output=True, text=True, timeout=300)


def test_pure_modules_and_vo_reference_import_without_bpy():
    result = _run(PROBE, *PURE)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_blocker_really_blocks():
    result = _run(PROBE.replace("for name in sys.argv[1:]:", "try_import('bpy')\nfor name in sys.argv[1:]:"))
    assert result.returncode == 1 and "bpy is blocked" in result.stdout


def test_ses_does_not_import_vo_reference():
    code = ("import sys, blender_sesgen.ses, blender_sesgen.check; "
            "sys.exit(any(m.split('.')[0] == 'vo_reference' for m in sys.modules))")
    assert _run(code).returncode == 0
