"""A one-factor study of the open script from the add-on (pure: stdlib only, no bpy).

The panel picks a factor of the registry, its levels and the built-in systems; this module
writes the study file (``study_toml``, checked as ``study run`` would check it) and runs
``python -m blender_sesgen study run`` as a child process with ``--progress json``
(Blender's own Python has no Ray and no OpenCV: the command is a Python where
``pip install 'blender-sesgen[render,vo,farm]'`` was done, like the export's VO command),
turning its events into the panel's progress and status line. docs/addon.md, docs/studies.md.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

from ..errors import SesgenError
from .export_job import ExportError, ExportProcess, tool_command

NOT_FOUND = ("a study needs Ray, OpenCV and Blender's module outside Blender: pip install "
             "'blender-sesgen[render,vo,farm]' in a Python 3.11 and put its sesgen command on PATH, or give the "
             "command under Study Command (e.g. /path/venv/bin/python -m blender_sesgen)")


class StudyJobError(SesgenError):
    """The study could not start or failed; the message is one line for the user."""


def study_command(setting: str = "") -> list[str]:
    """The command prefix that runs ``sesgen``: the setting, else ``sesgen`` on PATH."""
    return tool_command(setting, "sesgen", NOT_FOUND, StudyJobError)


def parse_levels(factor: str, text: str) -> list:
    """The levels typed in the panel ("0.005, 0.01 0.02"; text for text factors)."""
    from ..study.factors import FACTORS
    if factor not in FACTORS:
        raise StudyJobError(f"unknown factor {factor!r}")
    words = [w for w in text.replace(",", " ").split() if w]
    if not words:
        raise StudyJobError("type the factor's levels, e.g. 0.005, 0.01, 0.02")
    f = FACTORS[factor]
    if f.kind == "text":
        levels = words
    else:
        try:
            levels = [int(w) if w.lstrip("+-").isdigit() else float(w) for w in words]
        except ValueError:
            raise StudyJobError(f"levels of {factor} are numbers ({f.unit}): {text!r}") from None
    for lv in levels:
        try:
            f.check_level(lv)
        except SesgenError as e:
            raise StudyJobError(f"{factor} level {lv!r}: {e}") from None
    return levels


def study_toml(script: str, factor: str, levels: list, systems: list[str], *, frames: int = 0,
               resolution: float = 1.0, quality: str = "draft", name: str = "") -> str:
    """The study file of a one-factor study of ``script`` (the built-in ``systems``)."""
    lines = ["# written by the SESGen add-on's Study panel", "[study]",
             f"name = {json.dumps(name or f'{Path(script).stem}-{factor}')}", "", "[world]",
             f"script = {json.dumps(str(Path(script).resolve()))}", f"quality = {json.dumps(quality)}"]
    if frames:
        lines.append(f"frames = {int(frames)}")
    if resolution != 1.0:
        lines.append(f"resolution = {float(resolution)!r}")
    lines += ["", f"[factors.{factor}]", f"levels = {json.dumps(levels)}", ""]
    for s in systems:
        lines += ["[[systems]]", f"builtin = {json.dumps(s)}", ""]
    return "\n".join(lines)


def check_study(path: Path) -> None:
    """StudyJobError with the study file's own message if it would not run."""
    from ..study.spec import load
    try:
        load(path)
    except SesgenError as e:
        raise StudyJobError(str(e)) from None


def write_study(folder: Path, text: str) -> Path:
    """``FOLDER/study.toml`` (checked): the study file in the study's own folder (which
    ``study run`` accepts as it accepts an empty one)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "study.toml"
    from ..contract import atomic
    atomic.write_text(path, text)
    check_study(path)
    return path


class StudyProcess(ExportProcess):
    """A running ``study run`` (an :class:`~.export_job.ExportProcess` of another tool):
    ``poll()`` reads its progress events; ``line`` is what the panel shows, ``report`` the
    page once there is one."""

    def __init__(self, prefix: list[str], study: Path, out: Path):
        self.out = Path(out)
        self.task, self.detail = "", ""
        try:
            super().__init__([*prefix, "study", "run", str(study), "--out", str(out), "--progress", "json"])
        except ExportError as e:
            raise StudyJobError(f"{e} ({NOT_FOUND})") from None

    def poll(self) -> list[dict]:
        events = super().poll()
        for e in events:
            self.task = e.get("task", self.task)
            if e.get("detail"):
                self.detail = str(e["detail"])
        return events

    @property
    def line(self) -> str:
        step = {"farm": "rendering", "study": "running the systems", "study evaluate": "evaluating"}.get(
            self.task, self.task or "starting")
        return f"study: {step} {self.done}/{self.total}" if self.total else f"study: {step}"

    @property
    def report(self) -> Optional[Path]:
        path = self.out / "report.html"
        return path if path.is_file() else None

    @property
    def summary(self) -> str:
        """The study's result line (``study NAME: N run(s), ...``)."""
        return next((ln for ln in self._stdout if ln.startswith("study ")), "")
