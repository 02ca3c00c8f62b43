"""One way to call the tools, one vocabulary across the commands, and docs that use both:
the installed programs' names, ``-q``/``--quiet`` = ``--progress off`` on every long command,
``--report DIR`` for every report folder, ``--frames A:B`` half-open everywhere."""
from __future__ import annotations

import argparse
import re
import tomllib
from pathlib import Path

import pytest

import blender_sesgen.cli as sesgen_cli
import vo_reference.cli as vo_cli
from blender_sesgen.contract.cli import build_parser
from blender_sesgen.contract.progress import progress_mode
from blender_sesgen.contract.timing import FRAMES_HELP

REPO = Path(__file__).resolve().parents[1]
DOCS = [REPO / "README.md", REPO / "scenes" / "README.md", *sorted((REPO / "docs").glob("*.md"))]
CLIS = {"sesgen": (sesgen_cli, "blender_sesgen"), "vo-reference": (vo_cli, "vo_reference")}
# every long command, with the arguments it needs to parse
LONG = {("sesgen", "render"): ["s.ses", "--out", "o"], ("sesgen", "verify"): ["o"],
        ("sesgen", "farm"): ["s.ses", "--out", "o"], ("sesgen", "generate"): [],
        ("vo-reference", "export"): ["r", "o", "--to", "tum"], ("vo-reference", "stereo-vo"): ["i", "--out", "e"],
        ("vo-reference", "run"): ["i"], ("vo-reference", "mono-vo"): ["i", "--out", "e"]}
REPORTS = {("vo-reference", "run"): ["i"], ("vo-reference", "evaluate"): ["--gt", "g", "--est", "e"],
           ("vo-reference", "evaluate-disparity"): ["--gt", "g", "--est", "e"],
           ("vo-reference", "mono-vo"): ["i", "--out", "e"]}


def parser(program: str) -> argparse.ArgumentParser:
    module, package = CLIS[program]
    return build_parser(module.PROG, module.DESCRIPTION, module.COMMANDS, package)


def subparsers(program: str) -> dict[str, argparse.ArgumentParser]:
    p = parser(program)
    return next(a for a in p._actions if isinstance(a, argparse._SubParsersAction)).choices


def test_the_programs_are_the_installed_commands_and_say_so():
    scripts = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts == {"sesgen": "blender_sesgen.cli:main", "vo-reference": "vo_reference.cli:main"}
    for program, (module, package) in CLIS.items():
        assert module.PROG == program
        text = parser(program).format_help()
        assert text.startswith(f"usage: {program} ") and f"python -m {package}" in " ".join(text.split())


@pytest.mark.parametrize("program, command", sorted(LONG))
def test_every_long_command_takes_progress_and_q_meaning_progress_off(program, command):
    p, args = parser(program), [command, *LONG[program, command]]
    assert progress_mode(p.parse_args(args)) == "auto"
    assert progress_mode(p.parse_args([*args, "--progress", "json"])) == "json"
    for quiet in ("-q", "--quiet"):
        assert progress_mode(p.parse_args([*args, quiet])) == "off"


def test_one_name_for_a_report_folder():
    for (program, command), args in REPORTS.items():
        assert parser(program).parse_args([command, *args, "--report", "R"]).report == "R"
    for program in CLIS:
        for command, sub in subparsers(program).items():
            shown = " ".join(sub.format_help().split())
            assert "--plot" not in shown and "--report-dir" not in shown, (program, command)


def test_every_frames_option_is_half_open_and_says_so():
    seen = []
    for program in CLIS:
        for command, sub in subparsers(program).items():
            for action in sub._actions:
                if "--frames" in action.option_strings:
                    assert FRAMES_HELP in action.help, (command, action.help)
                    seen.append(command)
    assert {"render", "export", "stereo-vo", "run", "mono-vo", "evaluate"} <= set(seen)


def _code(text: str) -> list[str]:
    """Lines of fenced code blocks and inline code spans."""
    blocks = re.findall(r"```[^\n]*\n(.*?)```", text, flags=re.S)
    rest = re.sub(r"```.*?```", "", text, flags=re.S)
    return [line for b in blocks for line in b.splitlines()] + re.findall(r"`([^`\n]+)`", rest)


def test_the_docs_call_the_tools_one_way():
    """README and docs run `sesgen COMMAND` / `vo-reference COMMAND` with commands and options
    that exist, never `python -m blender_sesgen COMMAND` (the --help says that one is the same)."""
    commands = {program: subparsers(program) for program in CLIS}
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        other = re.findall(r"(?:\.venv/bin/)?python3? -m (?:blender_sesgen|vo_reference) [a-z][\w-]*", text)
        assert other == [], (doc.name, other)
        for code in _code(text):
            for program, command, rest in re.findall(r"(?:^|[\s(])(sesgen|vo-reference) ([a-z][\w-]*)(.*)", code):
                assert command in commands[program], (doc.name, code)
                sub = commands[program][command]
                nested = [a for a in sub._actions if isinstance(a, argparse._SubParsersAction)]
                if nested:   # a command with actions of its own (study run, study compare, ...)
                    action = rest.split()[0] if rest.split() else ""
                    if not action:   # the command named alone
                        continue
                    assert action in nested[0].choices, (doc.name, code)
                    sub = nested[0].choices[action]
                options = {o for a in sub._actions for o in a.option_strings}
                used = re.findall(r"(?<![\w-])(--?[a-z][\w-]*)", rest.split("#")[0])
                assert set(used) <= options | {"--no-" + o[2:] for o in options}, (doc.name, code, set(used) - options)


def test_the_first_render_of_the_readme_is_cheap():
    """A draft (or gt) render of a few frames at reduced size: minutes, not an hour."""
    first = next(line for line in _code((REPO / "README.md").read_text(encoding="utf-8"))
                 if line.lstrip().startswith("sesgen render"))
    assert re.search(r"--quality (draft|gt)\b", first), first
    frames = re.search(r"--frames (\d+):(\d+)", first)
    assert frames and int(frames[2]) - int(frames[1]) <= 10, first
    scale = re.search(r"--resolution-scale ([\d.]+)", first)
    assert scale and float(scale[1]) <= 0.5, first
