"""The command line imports only the command that runs: every render process (a test's, a farm
chunk's, a study variant's) starts through it, and the other commands' modules cost start-up
(``check``'s scene summary alone ~0.4 CPU s). Each case runs in a fresh interpreter, which is
what a render process is."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from blender_sesgen.commands.main import COMMANDS as SESGEN
from blender_sesgen.contract.cli import chosen_command
from vo_reference.commands.main import COMMANDS as VO

# which command modules a fresh interpreter has loaded after ``main([command, "--help"])``
PROBE = """
import contextlib, io, json, sys
from importlib import import_module
cli = import_module(sys.argv[1])
pkg = cli.__package__
code, out = None, io.StringIO()
if sys.argv[2] == "--import":   # the command's module and its arguments alone: what it needs itself
    import argparse
    import_module(cli.COMMANDS[sys.argv[3]][0], pkg).add_arguments(argparse.ArgumentParser())
else:
    with contextlib.redirect_stdout(out):
        try:
            cli.main(sys.argv[2:])
        except SystemExit as e:
            code = e.code
print(json.dumps({"code": code, "help": out.getvalue(),
                  "loaded": sorted(m[len(pkg) + 1:] for m in sys.modules if m.startswith(pkg + "."))}))
"""


def probe(cli: str, *argv: str) -> dict:
    proc = subprocess.run([sys.executable, "-c", PROBE, cli, *argv], capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.splitlines()[-1])


@pytest.mark.parametrize("cli, commands", [("blender_sesgen.commands.main", SESGEN),
                                           ("vo_reference.commands.main", VO)])
def test_a_command_loads_no_other_commands_module(cli, commands):
    modules = {m.lstrip(".") for m, _ in commands.values()}
    for name in commands:
        got = probe(cli, name, "--help")
        assert got["code"] == 0 and f" {name} " in got["help"] and "usage:" in got["help"], (name, got["help"][:200])
        own = set(probe(cli, "--import", name)["loaded"])    # e.g. farm takes render's options
        extra = (set(got["loaded"]) - own) & modules
        assert not extra, (name, sorted(extra))
        assert modules - own, name    # (the check can fail: some command module is not needed)


def test_the_overview_still_lists_every_command_with_its_help():
    got = probe("blender_sesgen.commands.main", "--help")
    assert got["code"] == 0
    for name, (_, help_text) in SESGEN.items():
        assert name in got["help"] and help_text.split()[0] in got["help"]
    # and builds no command's arguments: no command module is loaded
    assert not {m.lstrip(".") for m, _ in SESGEN.values()} & set(got["loaded"])


def test_the_chosen_command_is_the_first_word():
    assert chosen_command(["render", "check", "--out", "o"], SESGEN) == "render"
    assert chosen_command(["--help"], SESGEN) == ""
    assert chosen_command(["-h", "verify", "x"], SESGEN) == "verify"
    assert chosen_command(["rendr", "s.ses"], SESGEN) == ""        # a typo: argparse names the choices
    assert chosen_command([], SESGEN) == ""
