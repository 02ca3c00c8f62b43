"""Headless entry: ``blender -b -P render.py -- SCENE.ses --out DIR [options]``.

The same with the bpy wheel: ``python render.py -- SCENE.ses --out DIR [options]`` (the
``--`` is optional there). Identical to ``python -m blender_sesgen render SCENE.ses ...``:
the arguments after ``--`` go to the ``render`` command. Exit codes: 0 ok, 2 bad input,
1 render failure.
"""
import importlib
import importlib.util
import os
import sys


def _render_args(argv: list[str]) -> list[str]:
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    return argv[1:]  # plain `python render.py SCENE.ses ...`


def _package_beside_this_file() -> None:
    """Import the ``blender_sesgen`` beside this file as the package: ``python render.py``
    finds it anyway (the script's folder is on the path), Blender's ``-P`` does not."""
    if "blender_sesgen" in sys.modules:
        return
    pkg = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_sesgen")
    spec = importlib.util.spec_from_file_location("blender_sesgen", os.path.join(pkg, "__init__.py"),
                                                  submodule_search_locations=[pkg])
    module = importlib.util.module_from_spec(spec)
    sys.modules["blender_sesgen"] = module
    spec.loader.exec_module(module)


def main() -> int:
    _package_beside_this_file()
    cli_main = importlib.import_module("blender_sesgen.cli").main
    return cli_main(["render", *_render_args(sys.argv)])


if __name__ == "__main__":
    # Blender (-P) turns SystemExit into its own exit status as well
    sys.exit(main())
