"""Without bpy (a VO-only install), `render` says how to get it: exit 2, no output folder."""
from __future__ import annotations

import subprocess
import sys
import textwrap


def test_render_without_bpy_is_a_clear_user_error(repo, tmp_path):
    out = tmp_path / "out"
    code = textwrap.dedent(f"""
        import sys, importlib.abc
        class Block(importlib.abc.MetaPathFinder):
            def find_spec(self, name, path, target=None):
                if name.split(".")[0] in ("bpy", "mathutils"):
                    raise ImportError(name)
        sys.meta_path.insert(0, Block())
        from blender_sesgen.commands.main import main
        sys.exit(main(["render", {str(repo / "scenes" / "minimal.ses")!r}, "--out", {str(out)!r}]))
    """)
    r = subprocess.run([sys.executable, "-c", code], cwd=repo, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2, r.stderr
    assert "needs Blender's Python module 'bpy'" in r.stderr and "Traceback" not in r.stderr
    assert not out.exists()
