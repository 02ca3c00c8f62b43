"""The background finisher (blender_sesgen.finisher): order, back-pressure, failures, exit."""
from __future__ import annotations

import threading
import time

import pytest

from blender_sesgen.finisher import Finisher


def test_runs_in_order_in_one_background_thread():
    done, threads = [], set()
    main = threading.get_ident()
    with Finisher() as f:
        for k in range(20):
            f.submit(lambda k=k: (time.sleep(0.001), done.append(k), threads.add(threading.get_ident())))
    assert done == list(range(20))            # all finished when the block ends, in order
    assert len(threads) == 1 and main not in threads


def test_submit_blocks_while_two_frames_are_outstanding():
    gate = threading.Event()
    with Finisher() as f:
        f.submit(gate.wait)                   # being finished
        f.submit(lambda: None)                # waiting
        t = threading.Thread(target=f.submit, args=(lambda: None,))
        t.start()
        time.sleep(0.05)
        assert t.is_alive()                   # the third waits for room
        gate.set()
        t.join(1)
        assert not t.is_alive()


def test_a_failure_surfaces_at_the_next_submit_and_stops_later_tasks():
    ran = []

    def boom():
        raise RuntimeError("disk full")
    f = Finisher()
    f.submit(boom)
    f._queue.join()                           # let it fail
    with pytest.raises(RuntimeError, match="disk full"):
        f.submit(lambda: ran.append(1))
    f.submit(lambda: ran.append(2))           # after the failure was raised, it runs again
    f.close()
    assert ran == [2]


def test_the_block_waits_and_reports_a_failure_at_exit():
    with pytest.raises(RuntimeError, match="late"):
        with Finisher() as f:
            f.submit(lambda: (_ for _ in ()).throw(RuntimeError("late")))


def test_an_error_in_the_block_wins_and_pending_work_still_finishes():
    done = []
    with pytest.raises(KeyboardInterrupt):
        with Finisher() as f:
            f.submit(lambda: (time.sleep(0.05), done.append(1)))
            raise KeyboardInterrupt
    assert done == [1]
