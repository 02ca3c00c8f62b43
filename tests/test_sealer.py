"""The sealing worker (blender_sesgen.render.sealer): frames sealed in another process exactly as
in this one, failures reported as the render's own, a dead worker replaced by sealing here."""
from __future__ import annotations

import hashlib
import shutil
import signal
from pathlib import Path

import numpy as np
import pytest

from blender_sesgen.files.exr import read_exr, write_exr
from blender_sesgen.render.folder import RenderWriteError, seal_frame
from blender_sesgen.render.sealer import Sealer, WorkerGone

CHANNELS = ("ViewLayer.Combined.R", "ViewLayer.Depth.Z")


def _frame(tmp_path: Path, k: int) -> dict:
    rng = np.random.default_rng(k)
    out = {}
    for v in ("left", "right"):
        p = tmp_path / f".{k:06d}_{v}.tmp-1.exr"
        write_exr(p, {c: rng.random((12, 16), dtype=np.float32) for c in CHANNELS})
        out[v] = p
    return out


def test_the_worker_seals_like_this_process(tmp_path):
    (tmp_path / "a").mkdir()
    frames = {k: _frame(tmp_path / "a", k) for k in range(4)}
    copies = {}
    for k, files in frames.items():
        copies[k] = {}
        for v, p in files.items():
            (tmp_path / "b").mkdir(exist_ok=True)
            copies[k][v] = Path(shutil.copy(p, tmp_path / "b" / p.name))
    with Sealer() as s:
        assert s.in_background
        answers = [s.submit(k, files, CHANNELS) for k, files in frames.items()]
        results = [a.result() for a in answers]
    for (k, files), sums in zip(frames.items(), results):
        assert sums == seal_frame(k, copies[k], CHANNELS)           # same hashes as sealed here
        for v, p in files.items():
            assert p.read_bytes() == copies[k][v].read_bytes()
            assert sums[f"exr/{v}/{k:06d}.exr"] == hashlib.sha256(p.read_bytes()).hexdigest()
            assert set(read_exr(p)) == set(CHANNELS)


def test_a_bad_file_is_a_write_error_and_later_frames_still_seal(tmp_path):
    bad, good = _frame(tmp_path, 0), _frame(tmp_path, 1)
    bad["left"].write_bytes(bad["left"].read_bytes()[:200])       # truncated: a full disk
    with Sealer() as s:
        a, b = s.submit(0, bad, CHANNELS), s.submit(1, good, CHANNELS)
        with pytest.raises(RenderWriteError, match="frame 0 .*not written completely"):
            a.result()
        assert set(b.result()) == {"exr/left/000001.exr", "exr/right/000001.exr"}
    assert not bad["left"].exists() and not bad["right"].exists()  # the bad frame's files removed


def test_a_dead_worker_is_reported_and_replaced(tmp_path):
    files = _frame(tmp_path, 0)
    # dies with a frame submitted: WorkerGone (the job then seals that frame itself)
    s = Sealer()
    s._proc.send_signal(signal.SIGSTOP)                 # cannot answer...
    a = s.submit(0, files, CHANNELS)
    s._proc.kill()                                      # ...and dies
    with pytest.raises(WorkerGone):
        a.result()
    assert not s.in_background
    # afterwards frames are sealed in this process, exactly as the worker would have
    assert set(s.submit(0, files, CHANNELS).result()) == {"exr/left/000000.exr", "exr/right/000000.exr"}
    # dead before a submit: sealed here at once
    s = Sealer()
    s._proc.kill()
    s._proc.wait()
    assert len(s.submit(0, files, CHANNELS).result()) == 2 and not s.in_background
    s.close()


def test_disabled_seals_here(tmp_path):
    with Sealer(enabled=False) as s:
        assert not s.in_background
        assert len(s.submit(0, _frame(tmp_path, 0), CHANNELS).result()) == 2


def test_display_pngs_lose_blenders_wall_clock_text_chunks():
    """Blender writes its render metadata (date, render time) into the display PNG's tEXt
    chunks; sealing drops every text/time chunk and nothing else, so the same frame gives
    the same bytes. The PNG is written by OpenCV (an independent encoder), the chunks by hand."""
    import zlib

    import cv2
    import numpy as np

    from blender_sesgen.render.folder import strip_png_text
    rgb = np.random.default_rng(0).integers(0, 256, (9, 13, 3), dtype=np.uint8)
    png = cv2.imencode(".png", rgb)[1].tobytes()

    def chunk(kind: bytes, data: bytes) -> bytes:
        return len(data).to_bytes(4, "big") + kind + data + zlib.crc32(kind + data).to_bytes(4, "big")
    stamped = png[:33] + chunk(b"tEXt", b"Date\x002026/12/02 00:29:04") + chunk(b"tIME", bytes(7)) + png[33:]
    assert strip_png_text(stamped) == png
    assert np.array_equal(cv2.imdecode(np.frombuffer(strip_png_text(stamped), np.uint8), cv2.IMREAD_UNCHANGED), rgb)
    assert strip_png_text(stamped[:-5]) == stamped[:-5]   # not a whole chunk list: left for the image check


def test_temporary_names_include_those_blender_makes_for_each_view():
    """A multiview save puts the view's suffix after our pid (before the extension, or at the
    end when there is none); a resumed render must recognise those leftovers of a killed one."""
    from blender_sesgen.contract.atomic import is_temp_name, temp_path
    ours = temp_path(Path("rgb/left/000000.png")).name                 # .000000.tmp-PID.png
    blender = ours.replace(".png", "_left.png")                         # .000000.tmp-PID_left.png
    for name in (ours, blender, ".000003_left.tmp-27333", ".000003.tmp-27333_right.exr"):
        assert is_temp_name(name), name
    for name in ("000000.png", "000000_left.png", ".hidden.png", ".000000.tmp-x_left.png"):
        assert not is_temp_name(name), name
