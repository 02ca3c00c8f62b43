"""One progress reporter for every long command -- render, export, stereo-vo, mono-vo, run
(and later the farm) -- and for Python callers (stdlib only).

Modes (``--progress MODE``):

- ``bar``: one line rewritten in place with '\\r' (a terminal only), e.g.
  ``export tartanair [#######.......] 12/41 29% 3.1 s ETA 7.5 s  <detail>``;
- ``plain``: whole lines for logs and pipes (never a '\\r'): a line whenever another 5 % of
  the work is done or 5 s have passed since the last line, and at the end, e.g.
  ``export tartanair: 12/41 (29%) 3.1 s, ETA 7.5 s  <detail>`` -- so slow tasks (renders)
  log every frame and fast ones about twenty lines;
- ``json``: one JSON object per line and event, for tools: ``{"event": "start", "task",
  "total", "unit"}``, ``{"event": "progress", "task", "done", "total", "fraction",
  "elapsed_s", "eta_s", ...}`` (every update, with the fields the caller adds),
  ``{"event": "note", "task", "message"}`` and ``{"event": "end", "task", "done", "total",
  "elapsed_s", "status": "ok" | "error" | "interrupted"}``;
- ``off``: nothing;
- ``auto`` (the default): ``bar`` when the stream is a terminal, else ``plain``.

Everything goes to one stream (stderr by default), so a command's results on stdout stay
clean. ``callback(event)`` receives every event as the dict the json mode prints, whatever
the mode (the Python API's hook). Notes (warnings, failed steps) are printed in every
mode but ``off``: as a line of their own (above the bar on a terminal).
"""
from __future__ import annotations

import json
import math
import shutil
import sys
import time
from typing import Callable, Optional

__all__ = ["MODES", "Progress", "add_progress_argument", "progress_mode", "resolve_mode"]

MODES = ("auto", "bar", "plain", "json", "off")
PLAIN_STEP = 0.05        # a plain line for every 5 % ...
PLAIN_INTERVAL_S = 5.0   # ... or every 5 s, whichever comes first


def _is_tty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def resolve_mode(mode: str, stream) -> str:
    """``auto`` -> ``bar`` on a terminal, else ``plain``; other modes as given."""
    if mode not in MODES:
        raise ValueError(f"progress mode {mode!r}: expected one of {', '.join(MODES)}")
    if mode == "auto":
        return "bar" if _is_tty(stream) else "plain"
    return mode


def _fmt_s(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    if seconds < 60:
        return f"{seconds:.1f} s"
    s = int(round(seconds))
    return f"{s // 3600:d}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60:d}:{s % 60:02d}"


class Progress:
    """``with Progress(total, "export tartanair", mode="auto") as p: ... p.update(frame=k)``.

    ``update(n=1, detail=None, **fields)`` counts ``n`` more units done; ``detail`` is a
    short text shown after the counters (plain/bar) and ``fields`` go into the json event.
    ``note(message)`` reports something that must not be lost (a failed step). Leaving the
    ``with`` block ends the task (status ``error`` or ``interrupted`` on an exception).
    ``every_line``: in plain mode, a line for every update (work of few, long units)."""

    def __init__(self, total: int, task: str = "", *, mode: str = "auto", stream=None,
                 callback: Optional[Callable[[dict], None]] = None, unit: str = "frame",
                 min_interval_s: float = 0.1, clock: Callable[[], float] = time.monotonic,
                 every_line: bool = False):
        self.total = max(int(total), 0)
        self.task, self.unit = task, unit
        self.stream = stream if stream is not None else sys.stderr
        self.mode = resolve_mode(mode, self.stream)
        self.callback = callback
        self.min_interval_s = float(min_interval_s)
        self.every_line = bool(every_line)      # plain: a line for every update (one per task)
        self.clock = clock
        self.done = 0
        self.detail: Optional[str] = None
        self._t0 = self._now = clock()
        self._last_draw = -math.inf
        self._last_line_t = self._t0
        self._last_line_frac = 0.0
        self._bar_shown = False
        self._closed = False
        self._emit({"event": "start", "task": task, "total": self.total, "unit": unit})

    # --- public -----------------------------------------------------------------------
    def __enter__(self) -> "Progress":
        if self.mode == "bar":
            self._draw_bar(force=True)
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        status = "ok" if exc_type is None else ("interrupted" if issubclass(exc_type, KeyboardInterrupt) else "error")
        self.close(status)
        return False

    @property
    def elapsed_s(self) -> float:
        """Seconds from the start to the last update (or note, or the end)."""
        return self._now - self._t0

    @property
    def eta_s(self) -> Optional[float]:
        """Seconds left at the mean pace so far; None before the first unit is done."""
        if self.done <= 0 or self.total <= 0:
            return None
        return max(self.elapsed_s / self.done * (self.total - self.done), 0.0)

    def update(self, n: int = 1, detail: Optional[str] = None, **fields) -> None:
        self._now = self.clock()
        self.done += int(n)
        if detail is not None:
            self.detail = str(detail)
        event = self._state("progress")
        if detail is not None:
            event["detail"] = self.detail
        event.update(fields)
        self._emit(event)
        if self.mode == "bar":
            self._draw_bar(force=self.done >= self.total)
        elif self.mode == "plain":
            frac = self._fraction()
            if (self.every_line or self.done >= self.total or frac - self._last_line_frac >= PLAIN_STEP - 1e-12
                    or self._now - self._last_line_t >= PLAIN_INTERVAL_S):
                self._last_line_frac, self._last_line_t = frac, self._now
                self._line(self._plain_text())

    def note(self, message: str) -> None:
        self._now = self.clock()
        self._emit({"event": "note", "task": self.task, "message": str(message)})
        if self.mode in ("bar", "plain"):
            if self.mode == "bar" and self._bar_shown:
                self.stream.write("\r" + " " * self._width() + "\r")
            self._line(str(message))
            if self.mode == "bar" and self._bar_shown:
                self._draw_bar(force=True)

    def close(self, status: str = "ok") -> None:
        if self._closed:
            return
        self._closed = True
        self._now = self.clock()
        if self.mode == "bar":
            self._draw_bar(force=True)
            if self._bar_shown:
                self.stream.write("\n")
                self.stream.flush()
        elif self.mode == "plain" and status != "ok":
            self._line(f"{self.task}: {status} at {self.done}/{self.total}")
        event = self._state("end")
        event["status"] = status
        self._emit(event)

    # --- internals --------------------------------------------------------------------
    def _fraction(self) -> float:
        return min(self.done / self.total, 1.0) if self.total else 1.0

    def _state(self, kind: str) -> dict:
        eta = self.eta_s
        return {"event": kind, "task": self.task, "done": self.done, "total": self.total,
                "fraction": round(self._fraction(), 6), "elapsed_s": round(self.elapsed_s, 3),
                "eta_s": None if eta is None else round(eta, 3)}

    def _emit(self, event: dict) -> None:
        if self.callback is not None:
            self.callback(dict(event))
        if self.mode == "json":
            self.stream.write(json.dumps(event, default=_jsonable) + "\n")
            self.stream.flush()

    def _line(self, text: str) -> None:
        self.stream.write(text + "\n")
        self.stream.flush()

    def _counters(self) -> str:
        eta = self.eta_s
        tail = f", ETA {_fmt_s(eta)}" if eta is not None and self.done < self.total else ""
        return f"{self.done}/{self.total} ({self._fraction():.0%}) {_fmt_s(self.elapsed_s)}{tail}"

    def _plain_text(self) -> str:
        text = f"{self.task}: {self._counters()}"
        return f"{text}  {self.detail}" if self.detail else text

    def _width(self) -> int:
        return max(shutil.get_terminal_size((100, 24)).columns - 1, 20)

    def _draw_bar(self, force: bool = False) -> None:
        if not force and self._now - self._last_draw < self.min_interval_s:
            return
        self._last_draw = self._now
        filled = int(round(self._fraction() * 24))
        text = f"{self.task} [{'#' * filled:<24}] {self._counters()}"
        if self.detail:
            text += "  " + self.detail
        width = self._width()
        self.stream.write("\r" + text[:width].ljust(width))
        self.stream.flush()
        self._bar_shown = True


def _jsonable(x):
    """numpy scalars and arrays (and anything else) in json events."""
    for attr in ("tolist", "item"):
        if hasattr(x, attr):
            return getattr(x, attr)()
    return str(x)


def add_progress_argument(parser, quiet_flags: tuple[str, ...] = ("-q", "--quiet")) -> None:
    """``--progress auto|bar|plain|json|off`` and ``-q/--quiet`` on a CLI parser: every long
    command has both, and ``-q`` means ``--progress off`` (no progress report, nor the lines
    that announce and sum up the work; results, warnings and errors still print)."""
    parser.add_argument("--progress", choices=MODES, default="auto", metavar="MODE",
                        help="progress report on stderr: auto (a bar on a terminal, else plain lines), bar, "
                             "plain (whole lines with ETA: one per frame or per 5 %%), json (one JSON object "
                             "per event), off")
    if quiet_flags:
        parser.add_argument(*quiet_flags, dest="quiet", action="store_true",
                            help="no progress report, as --progress off (results, warnings and errors still print)")


def progress_mode(args) -> str:
    """The mode a parsed CLI asked for (``--quiet`` wins)."""
    return "off" if getattr(args, "quiet", False) else getattr(args, "progress", "auto")
