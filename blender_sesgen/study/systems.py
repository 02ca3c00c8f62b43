"""Systems under test (pure: the standard library): the built-in ones, command templates,
and one run of a system on one dataset as a child process.

A system is a command template -- ``python my_vo.py {dataset} {out}`` -- with the export
layout it reads (any of ``vo_reference``'s, calibration files included), the pose format it
writes (TUM, KITTI, EuRoC), a timeout and a number of trials. Placeholders:

==============  ==========================================================================
``{dataset}``   the exported dataset (read-only: files 0444, folders 0555)
``{sequence}``  the sequence's folder inside a tree layout (kitti-odometry:
                ``dataset/sequences/00``); ``{dataset}`` for the other layouts
``{out}``       the trajectory file the system writes (in its pose format)
``{workdir}``   its own working folder (also its current folder and ``TMPDIR``)
``{trial}``     the trial, 0, 1, ... (a seed for systems that are not deterministic)
``{frames}``    the number of frames
``{python}``    this Python
``{vo}``        the ``vo_reference`` command (several words)
==============  ==========================================================================

A run (:func:`run`) starts the command through :mod:`.launch` (bound to the life of the
process that started it; the dataset's permissions enforced even for root), in a new
session, its output in ``stdout.txt``/``stderr.txt``; past its timeout the whole process
group gets SIGTERM, then SIGKILL. The record says how it ended (exit code, timeout, the
tail of its stderr); whether the trajectory is usable is the evaluation's to say.
"""
from __future__ import annotations

import os
import shutil
import signal
import stat
import string
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

from ..errors import SesgenError

PLACEHOLDERS = ("dataset", "sequence", "out", "workdir", "trial", "frames", "python", "vo")
TAIL_LINES = 20
KILL_GRACE_S = 5.0


@dataclass(frozen=True)
class Builtin:
    cmd: tuple[str, ...]
    layout: str
    format: str
    mono: bool
    doc: str


BUILTIN: dict[str, Builtin] = {
    "paper-stereo": Builtin(("{vo}", "stereo-vo", "{sequence}", "--method", "paper", "--out", "{out}", "--quiet"),
                            "kitti-folder", "kitti", False,
                            "the SESGen paper's stereo VO (Shi-Tomasi, SAD tracking, pixel disparity, Eq. 6)"),
    "accurate-stereo": Builtin(("{vo}", "stereo-vo", "{sequence}", "--method", "accurate", "--out", "{out}",
                                "--quiet"), "kitti-folder", "kitti", False,
                               "the accurate stereo VO (sub-pixel LK, RANSAC, SE(3) refinement)"),
    "opencv-stereo": Builtin(("{vo}", "stereo-vo", "{sequence}", "--method", "opencv-baseline", "--out", "{out}",
                              "--quiet"), "kitti-folder", "kitti", False,
                             "the OpenCV baseline (goodFeaturesToTrack, LK, StereoSGBM depth, solvePnPRansac)"),
    "mono": Builtin(("{vo}", "mono-vo", "{sequence}", "--scale", "none", "--out", "{out}", "--quiet"),
                    "kitti-folder", "kitti", True,
                    "the classic monocular pipeline (KLT, 5-point RANSAC, PnP); unit steps, evaluated with Sim(3)"),
}


def check_template(cmd: Sequence[str]) -> None:
    """SesgenError for a placeholder the template may not use, or a stray brace."""
    for word in cmd:
        try:
            fields = [f for _, f, _, _ in string.Formatter().parse(word) if f is not None]
        except ValueError as e:
            raise SesgenError(f"{word!r}: {e} (write a literal brace as {{{{ or }}}})") from None
        for f in fields:
            if f not in PLACEHOLDERS:
                raise SesgenError(f"unknown placeholder {{{f}}} in {word!r} (placeholders: "
                                  f"{', '.join('{' + p + '}' for p in PLACEHOLDERS)})")
        if "{vo}" in word and word != "{vo}":
            raise SesgenError("{vo} stands for a whole command (several words): write it as a word of its own")


def expand(cmd: Sequence[str], values: dict, vo: Sequence[str]) -> list[str]:
    """The command line of one run: placeholders filled in, ``{vo}`` spread into its words."""
    out = []
    for word in cmd:
        if word == "{vo}":
            out += list(vo)
        else:
            out.append(word.format(**{**values, "vo": " ".join(vo)}))
    return out


def dataset_folder(export_dir: Path) -> Path:
    """``{sequence}`` of an export: the folder that holds its ``export.json`` (a tree layout's
    sequence slot, else the export itself)."""
    found = sorted((p.parent for p in Path(export_dir).rglob("export.json")), key=lambda p: len(p.parts))
    return found[0] if found else Path(export_dir)


# --- read-only datasets ---------------------------------------------------------------------

def set_read_only(folder: Path, read_only: bool = True) -> None:
    """Files 0444 and folders 0555 (``read_only``), or back to 0644/0755."""
    folder = Path(folder)
    if not folder.exists():
        return
    dmode, fmode = (0o555, 0o444) if read_only else (0o755, 0o644)
    walk = list(os.walk(folder))
    for root, dirs, files in (walk if not read_only else reversed(walk)):
        if not read_only:
            os.chmod(root, dmode)
        for f in files:
            p = os.path.join(root, f)
            if not os.path.islink(p):
                os.chmod(p, fmode)
        if read_only:
            os.chmod(root, dmode)


def remove_tree(folder: Path) -> None:
    """Remove a folder this module may have made read-only."""
    folder = Path(folder)
    if not folder.exists():
        return
    def onerror(func, path, exc):
        os.chmod(os.path.dirname(path), stat.S_IRWXU)
        func(path)
    set_read_only(folder, False)
    shutil.rmtree(folder, onerror=onerror)


# --- one run ------------------------------------------------------------------------------------

def _tail(path: Path, n: int = TAIL_LINES, max_bytes: int = 64 * 1024) -> list[str]:
    """The last ``n`` lines of a log, read from its last ``max_bytes`` (a system may write
    gigabytes)."""
    try:
        with open(path, "rb") as f:
            size = f.seek(0, os.SEEK_END)
            f.seek(max(0, size - max_bytes))
            data = f.read()
    except OSError:
        return []
    lines = data.decode("utf-8", errors="replace").splitlines()
    if size > max_bytes and lines:
        lines = lines[1:]                      # the first may be cut
    return lines[-n:]


def run(argv: Sequence[str], run_dir: Path, timeout_s: float, env: Optional[dict] = None,
        base_env: Optional[dict] = None) -> dict:
    """Run one system command in ``run_dir/work`` (made fresh) with its output in
    ``run_dir/stdout.txt`` and ``stderr.txt``; the record of how it ended (module docstring).
    Its environment: ``base_env`` (the study's own; default this process's), ``env`` over it,
    and ``TMPDIR``."""
    run_dir = Path(run_dir)
    work = run_dir / "work"
    remove_tree(work)
    (work / "tmp").mkdir(parents=True)
    proc_env = dict(os.environ if base_env is None else base_env)
    proc_env.update(env or {})
    proc_env["TMPDIR"] = str(work / "tmp")
    from ..farm.child import PARENT_ENV
    proc_env[PARENT_ENV] = str(os.getpid())
    from .launch import command
    launcher = command(work, argv)
    t0 = time.monotonic()
    timed_out = False
    with open(run_dir / "stdout.txt", "wb") as out, open(run_dir / "stderr.txt", "wb") as err:
        try:
            proc = subprocess.Popen(launcher, stdin=subprocess.DEVNULL, stdout=out, stderr=err, cwd=work,
                                    env=proc_env, start_new_session=True)
        except OSError as e:
            return {"rc": None, "timed_out": False, "wall_s": 0.0, "error": f"cannot start: {e}",
                    "stderr_tail": [], "stdout_tail": [], "argv": list(argv)}
        try:
            rc = proc.wait(timeout=timeout_s)
            try:                     # what it left running in the background goes too
                os.killpg(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
        except subprocess.TimeoutExpired:
            timed_out = True
            rc = _kill_group(proc)
        except BaseException:        # interrupted: the system goes with us
            _kill_group(proc)
            raise
    wall = time.monotonic() - t0
    rec = {"rc": rc, "timed_out": timed_out, "wall_s": round(wall, 3), "argv": list(argv),
           "stderr_tail": _tail(run_dir / "stderr.txt"), "stdout_tail": _tail(run_dir / "stdout.txt")}
    if timed_out:
        rec["error"] = f"ran past its timeout of {timeout_s:g} s (killed)"
    elif rc is not None and rc < 0:
        rec["error"] = f"killed by signal {signal.Signals(-rc).name if -rc in signal.valid_signals() else -rc}"
    elif rc != 0:
        rec["error"] = f"exit code {rc}"
    return rec


def _kill_group(proc: subprocess.Popen) -> Optional[int]:
    """SIGTERM to the run's whole process group, SIGKILL after a grace period -- to the
    group, not only its leader: a child that ignores SIGTERM outlives a leader that obeys it
    (and would go on writing the trajectory after the record was made)."""
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except (ProcessLookupError, PermissionError):
        pass
    deadline = time.monotonic() + KILL_GRACE_S
    try:
        proc.wait(timeout=KILL_GRACE_S)
    except subprocess.TimeoutExpired:
        pass
    while _group_alive(proc.pid) and time.monotonic() < deadline:   # the rest of the group's grace
        time.sleep(0.05)
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    return proc.wait()


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
        return True
    except (ProcessLookupError, PermissionError):
        return False
