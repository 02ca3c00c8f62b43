"""What a farm renders (pure: no Ray, no bpy): its scenes, their output folders and names,
the chunks of frames, the render command of a chunk and how its end is read.

Names: every scene renders into ``ROOT/<name>``, ``<name>`` being the script's file name
without ``.ses``; when several scripts share a name they get ``-2``, ``-3``, ... in the order
they were given (the first keeps the plain name), so the same command line always maps the
same script to the same folder.
"""
from __future__ import annotations

import enum
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Optional, Sequence

from ..files.dataset import read_index
from ..errors import ScriptError, SesgenError

SCRIPT_SUFFIX = ".ses"
ERROR_TAIL = 20                      # non-event output lines a task keeps for its report


@dataclass
class FarmScene:
    """One scene of a farm: its script, output folder and what is still to render."""
    name: str
    script: Path                     # absolute
    out: Path                        # absolute: ROOT/name
    meta: dict = field(default_factory=dict)      # from a dataset index beside the script (split, seed, ...)
    plan: object = None              # plan.RenderPlan once prepared
    pending: list = field(default_factory=list)   # frames to render
    error: Optional[str] = None      # why the scene cannot be rendered (a user error line)
    args: list = field(default_factory=list)      # render arguments of this scene only (e.g. --reuse-exr BASE)
    meters: bool = False             # its renders would meter the auto-exposure (none stored yet)

    @property
    def frames(self) -> int:
        return 0 if self.plan is None else len(self.plan.frames)


def find_scripts(args: Sequence[str]) -> list[tuple[Path, dict]]:
    """``(script, meta)`` for every SCENE argument: a script, or a folder whose scripts are
    taken in the order of its dataset index (``dataset.json``, written by ``generate``) or,
    without one, sorted by name. ``meta`` is the script's entry in a dataset index beside
    it, if there is one. The same script given twice is rendered once."""
    out, seen = [], set()
    for arg in args:
        p = Path(arg)
        if p.is_dir():
            index = read_index(p)
            listed = [p / s["script"] for s in index.get("sequences", [])] if index else []
            scripts = listed or sorted(q for q in p.iterdir() if q.suffix == SCRIPT_SUFFIX and q.is_file())
            if not scripts:
                raise SesgenError(f"{arg}: a folder with no {SCRIPT_SUFFIX} scripts")
        else:
            scripts = [p]
        for s in scripts:
            key = s.resolve() if s.exists() else s.absolute()
            if key in seen:
                continue
            seen.add(key)
            out.append((key, _meta_of(key)))
    return out


def _meta_of(script: Path) -> dict:
    index = read_index(script.parent)
    if not index:
        return {}
    for s in index.get("sequences", []):
        if s.get("script") == script.name:
            meta = {k: s[k] for k in ("split", "seed") if k in s}
            if index.get("generator"):
                meta["generator"] = index["generator"]
            return meta
    return {}


def unique_names(scripts: Iterable[Path]) -> list[str]:
    """Folder names: the file name without ``.ses``; repeats get ``-2``, ``-3``, ... in order."""
    names, used = [], set()
    for s in scripts:
        stem = Path(s).stem if Path(s).suffix == SCRIPT_SUFFIX else Path(s).name
        name, n = stem, 1
        while name in used:
            n += 1
            name = f"{stem}-{n}"
        used.add(name)
        names.append(name)
    return names


def folder_problem(name: str) -> Optional[str]:
    """Why ``ROOT/<name>`` cannot be a scene's folder (None when it can): ``..`` leaves ROOT,
    ``.`` is ROOT, the index's own name, a hidden name (``.x``: where state lives)."""
    from ..files.dataset import INDEX
    if name in ("", ".", ".."):
        return f"its folder would be ROOT/{name}, {'outside ROOT' if name == '..' else 'ROOT itself'}"
    if name == INDEX:
        return f"its folder would be ROOT/{name}, the farm's dataset index"
    if name.startswith("."):
        return f"its folder would be ROOT/{name}, a hidden name"
    return None


def frame_ranges(frames: Iterable[int], size: int) -> list[tuple[int, int]]:
    """Half-open ranges ``(a, b)`` covering exactly ``frames``: runs of consecutive frames,
    cut every ``size`` frames counted from 0 (so a fresh scene gets the chunks
    ``0:size, size:2*size, ...`` and a resumed one the same chunks minus what is done)."""
    if size < 1:
        raise ValueError("chunk size must be >= 1")
    out: list[tuple[int, int]] = []
    for k in sorted(set(int(f) for f in frames)):
        if out and out[-1][1] == k and k % size != 0:
            out[-1] = (out[-1][0], k + 1)
        else:
            out.append((k, k + 1))
    return out


def auto_cpus_per_task(cpus: float, n_chunks: int) -> float:
    """The cluster's CPUs shared among the chunks: 1 each when there are at least as many
    chunks as CPUs (one single-threaded Cycles per CPU: the least overhead per frame), more
    when there are fewer, so that no CPU idles while the chunks run."""
    if n_chunks <= 0 or cpus <= 0:
        return 1.0
    return float(max(1, int(cpus // min(cpus, n_chunks))))


def prepare_scene(sc, options):
    """``sc`` (a FarmScene) with its plan and pending frames, or its user error line."""
    from ..render.folder import OutputFolder
    from ..render.plan import RenderPlan
    if folder_problem(sc.name):
        sc.error = f"{sc.script}: error: {folder_problem(sc.name)}; rename the script"
        return sc
    try:
        sc.plan = RenderPlan.from_file(sc.script, options)
        folder = OutputFolder(sc.out)
        folder.check(sc.plan, force=False)
        if options.reuse_exr:
            from ..render.reuse import check_reusable
            check_reusable(sc.plan, options.reuse_exr)
        sc.pending = folder.pending(sc.plan, resume=True)
        from ..render.sensor.outputs import stored_metering
        sc.meters = (bool(sc.pending) and sc.plan.sensor.autoexposure is not None and not options.reuse_exr
                     and stored_metering(sc.plan.sensor, folder.resumable(sc.plan)) is None)
    except ScriptError as e:
        sc.error = str(e)
    except SesgenError as e:
        sc.error = f"{sc.script}: error: {e}" if not str(e).startswith(str(sc.script)) else str(e)
        if "--force" in sc.error:   # render's advice; a farm has no --force (chunks would undo each other)
            sc.error += f" (farm: remove {sc.out} or render into another --out)"
    return sc


def render_args(scene: FarmScene, a: int, b: int, threads: int, forwarded: Sequence[str]) -> list[str]:
    """The render command's arguments for frames ``a:b`` of ``scene`` (the task runs them as
    ``python -m blender_sesgen.commands.farm_child render ...`` with its own node's Python)."""
    return ["render", str(scene.script), "--out", str(scene.out), "--frames", f"{a}:{b}", "--resume",
            "--progress", "json", "--threads", str(int(threads)), *forwarded, *scene.args]


class Outcome(enum.Enum):
    """How a chunk's render ended, from the farm's point of view."""
    OK = "ok"                  # exit 0: the chunk is rendered
    USER_ERROR = "user error"  # exit 2: bad input (script, folder); retrying cannot help
    INTERRUPTED = "interrupted"  # exit 130: stopped by Ctrl-C / SIGTERM
    LOST = "lost"              # exit 1, killed by a signal, the worker or node gone: retry


def outcome_of(rc: Optional[int]) -> Outcome:
    if rc == 0:
        return Outcome.OK
    if rc == 2:
        return Outcome.USER_ERROR
    if rc == 130:
        return Outcome.INTERRUPTED
    return Outcome.LOST


def describe_exit(rc: Optional[int]) -> str:
    if rc is None:
        return "no exit status"
    if rc < 0:
        import signal
        try:
            return f"killed by {signal.Signals(-rc).name}"
        except ValueError:
            return f"killed by signal {-rc}"
    return f"exit code {rc}"


_ERROR = re.compile(r"(^|:\s)error:\s")


def error_line(lines: Sequence[str]) -> Optional[str]:
    """The line that says what went wrong: the last ``error:`` line (``file:line:col: error:
    ...`` or ``error: ...``), else the last line of a Python traceback, else None (a render
    killed by a signal says nothing)."""
    text = [ln.rstrip() for ln in lines if ln.strip()]
    for ln in reversed(text):
        if _ERROR.search(ln):
            return ln
    if any(ln.startswith("Traceback (most recent call last)") for ln in text):
        return text[-1]
    return None
