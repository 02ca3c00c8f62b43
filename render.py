"""Headless entry: ``blender -b -P render.py -- SCENE.ses --out DIR [options]``.

The same with the bpy wheel: ``python render.py -- SCENE.ses --out DIR [options]`` (the
``--`` is optional there). Identical to ``python -m blender_sesgen render SCENE.ses ...``:
the arguments after ``--`` go to the ``render`` command. Exit codes: 0 ok, 2 bad input,
1 render failure.
"""
import os
import sys


def _render_args(argv: list[str]) -> list[str]:
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    return argv[1:]  # plain `python render.py SCENE.ses ...`


def main() -> int:
    repo = os.path.dirname(os.path.abspath(__file__))
    if repo not in sys.path:
        sys.path.insert(0, repo)
    from blender_sesgen.cli import main as cli_main
    return cli_main(["render", *_render_args(sys.argv)])


if __name__ == "__main__":
    # Blender (-P) turns SystemExit into its own exit status as well
    sys.exit(main())
