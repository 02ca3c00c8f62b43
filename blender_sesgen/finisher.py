"""Finishing frames off the render's critical path (pure: stdlib only).

Once Blender has written a frame's EXRs under their temporary names, what is left —
checking the files, renaming them into place, recording the frame complete — needs no
Blender. :class:`Finisher` runs those steps in one background thread, in submission order,
while the next frame renders (Cycles releases the GIL while it renders). At most one frame
is being finished and one waits (``submit`` blocks beyond that), so temporary files and
memory do not pile up; after a failure no further task runs, and the failure is raised in
the rendering thread at the next :meth:`Finisher.submit` or at :meth:`Finisher.close`. Leaving the ``with`` block
(normally, on an error or on Ctrl-C) waits for the submitted frames, so the folder is
consistent: a frame is complete only once its files are in place.
"""
from __future__ import annotations

import queue
import threading
from typing import Callable, Optional


class Finisher:
    """``with Finisher() as f: f.submit(finish_frame_k)`` (see the module docstring)."""

    def __init__(self, depth: int = 1):
        self._queue: queue.Queue = queue.Queue(maxsize=max(1, int(depth)))
        self._error: Optional[BaseException] = None
        self._thread = threading.Thread(target=self._work, name="sesgen-finisher", daemon=True)
        self._thread.start()

    def _work(self) -> None:
        while True:
            task = self._queue.get()
            try:
                if task is None:
                    return
                if self._error is None:
                    task()
            except BaseException as e:  # noqa: BLE001 - handed to the rendering thread
                self._error = e
            finally:
                self._queue.task_done()

    def _raise(self) -> None:
        if self._error is not None:
            e, self._error = self._error, None
            raise e

    def submit(self, task: Callable[[], None]) -> None:
        """Queue ``task`` (blocks while the previous frame is still being finished)."""
        self._raise()
        self._queue.put(task)

    def wait(self) -> None:
        """Block until every submitted task has run; raise the first failure."""
        self._queue.join()
        self._raise()

    def close(self) -> None:
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        self._raise()

    def __enter__(self) -> "Finisher":
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            self.close()
        except BaseException:
            if exc_type is None:
                raise  # a finishing failure is the error to report
