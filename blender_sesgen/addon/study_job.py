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
import queue
import shlex
import shutil
import signal
import subprocess
import threading
from pathlib import Path
from typing import Optional

from ..errors import SesgenError

NOT_FOUND = ("a study needs Ray, OpenCV and Blender's module outside Blender: pip install "
             "'blender-sesgen[render,vo,farm]' in a Python 3.11 and put its sesgen command on PATH, or give the "
             "command under Study Command (e.g. /path/venv/bin/python -m blender_sesgen)")


class StudyJobError(SesgenError):
    """The study could not start or failed; the message is one line for the user."""


def study_command(setting: str = "") -> list[str]:
    """The command prefix that runs ``sesgen``: the setting, else ``sesgen`` on PATH."""
    words = shlex.split(setting) if setting and setting.strip() else []
    if words:
        return words
    found = shutil.which("sesgen")
    if found is None:
        raise StudyJobError(NOT_FOUND)
    return [found]


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
    """``FOLDER/study.toml`` (checked); the folder is the study's own."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "study.toml"
    from ..contract import atomic
    atomic.write_text(path, text)
    check_study(path)
    return path


class StudyProcess:
    """A running ``study run``: ``poll()`` reads its progress events; ``line`` is what the
    panel shows, ``finished``/``returncode``/``error`` when it has ended."""

    def __init__(self, prefix: list[str], study: Path, out: Path):
        self.cmd = [*prefix, "study", "run", str(study), "--out", str(out), "--progress", "json"]
        self.out = Path(out)
        try:
            self.proc = subprocess.Popen(self.cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                         stdin=subprocess.DEVNULL)
        except OSError as e:
            raise StudyJobError(f"cannot run {prefix[0]}: {e.strerror or e} ({NOT_FOUND})") from None
        self._events: queue.Queue = queue.Queue()
        self._other: list[str] = []
        self._stdout: list[str] = []
        self._threads = [threading.Thread(target=self._read_stderr, daemon=True),
                         threading.Thread(target=self._read_stdout, daemon=True)]
        for t in self._threads:
            t.start()
        self.task, self.done, self.total, self.detail = "", 0, 0, ""
        self.returncode: Optional[int] = None

    def _read_stderr(self) -> None:
        for line in self.proc.stderr:
            try:
                event = json.loads(line)
            except ValueError:
                event = None
            if isinstance(event, dict) and "event" in event:
                self._events.put(event)
            elif line.strip():
                self._other.append(line.rstrip("\n"))

    def _read_stdout(self) -> None:
        for line in self.proc.stdout:
            self._stdout.append(line.rstrip("\n"))

    def poll(self) -> list[dict]:
        events = []
        while True:
            try:
                events.append(self._events.get_nowait())
            except queue.Empty:
                break
        for e in events:
            self.task = e.get("task", self.task)
            self.total = int(e.get("total", self.total) or 0)
            self.done = int(e.get("done", self.done) or 0)
            if e.get("detail"):
                self.detail = str(e["detail"])
        if self.returncode is None and self.proc.poll() is not None:
            for t in self._threads:
                t.join(timeout=5)
            self.returncode = self.proc.returncode
            events += self.poll()
        return events

    @property
    def finished(self) -> bool:
        return self.returncode is not None

    @property
    def fraction(self) -> float:
        return min(self.done / self.total, 1.0) if self.total else 0.0

    @property
    def line(self) -> str:
        step = {"farm": "rendering", "study": "running the systems", "study evaluate": "evaluating"}.get(
            self.task, self.task or "starting")
        return f"study: {step} {self.done}/{self.total}" if self.total else f"study: {step}"

    @property
    def error(self) -> str:
        msgs = [ln for ln in self._other if "error:" in ln]
        if msgs:
            return msgs[-1]
        return self._other[-1] if self._other else f"the study exited with code {self.returncode}"

    @property
    def report(self) -> Optional[Path]:
        path = self.out / "report.html"
        return path if path.is_file() else None

    @property
    def summary(self) -> str:
        """The study's result line (``study NAME: N run(s), ...``)."""
        return next((ln for ln in self._stdout if ln.startswith("study ")), "")

    def wait(self, timeout: Optional[float] = None) -> int:
        self.proc.wait(timeout)
        self.poll()
        return self.returncode

    def cancel(self) -> None:
        """Stop the study as Ctrl-C would (it resumes where it stopped when run again)."""
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGINT)
            except (ValueError, OSError):
                self.proc.terminate()
            try:
                self.proc.wait(60)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.poll()
