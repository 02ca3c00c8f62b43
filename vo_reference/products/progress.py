"""A one-line progress bar on stderr (rewritten in place with '\\r')."""
from __future__ import annotations

import sys
import time


class Progress:
    """``with Progress(total, "kitti-odometry") as p: ... p.update()``.

    Draws ``label [#####.....] 12/50  3.1 s  ETA 9.8 s`` at most every ``min_interval``
    seconds; silent when ``enabled`` is False (or total < 2)."""

    def __init__(self, total: int, label: str = "", stream=None, enabled: bool = True,
                 width: int = 30, min_interval: float = 0.1):
        self.total, self.label, self.width = int(total), label, width
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled and self.total >= 2
        self.min_interval = min_interval
        self.done = 0
        self._t0 = time.monotonic()
        self._last = -1e9

    def __enter__(self):
        self._draw(force=True)
        return self

    def update(self, n: int = 1) -> None:
        self.done += n
        self._draw(force=self.done >= self.total)

    def _draw(self, force: bool = False) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if not force and now - self._last < self.min_interval:
            return
        self._last = now
        el = now - self._t0
        frac = min(self.done / self.total, 1.0) if self.total else 1.0
        bar = "#" * int(round(frac * self.width))
        eta = f"  ETA {el / self.done * (self.total - self.done):.1f} s" if 0 < self.done < self.total else ""
        self.stream.write(f"\r{self.label} [{bar:<{self.width}}] {self.done}/{self.total}  {el:.1f} s{eta}  ")
        self.stream.flush()

    def __exit__(self, *exc):
        if self.enabled:
            if self.done < self.total:
                self._draw(force=True)
            self.stream.write("\n")
            self.stream.flush()
        return False
