"""Exports are transactions: a whole export becomes visible at once, an interrupted one leaves
the previous export or nothing (never a mix of two runs, never temporary folders), and an
export never deletes anything that is not an earlier export of ours.

Interruptions are real: the export runs in a forked process that is killed (``os._exit``,
as ``kill -9``) or sent SIGINT right after its N-th rename, for every N; a full disk is a
real tmpfs mounted in a user namespace. The oracle is the byte content of exports made
without interruption.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")

from synthetic_render import plane_scene  # noqa: E402

from blender_sesgen.contract import atomic  # noqa: E402
from vo_reference.cli import main as vo_main  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def tree(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` (relative path -> bytes); symbolic links as their target."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
            p = Path(dirpath) / name
            out[p.relative_to(root).as_posix()] = os.readlink(p).encode() if p.is_symlink() else p.read_bytes()
    return out


def leftovers(*folders: Path) -> list[str]:
    """Names of our temporary folders or files in ``folders`` (recursively)."""
    found = []
    for folder in folders:
        if not folder.exists():
            continue
        for dirpath, dirnames, filenames in os.walk(folder):
            found += [os.path.join(dirpath, n) for n in dirnames + filenames
                      if atomic.is_temp_name(n) or atomic.is_transaction_name(n) or n.endswith(".old")]
    return found


def export(render, target, out, *args) -> int:
    return vo_main(["export", str(render), str(out), "--to", target, "--progress", "off", *map(str, args)])


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    base = tmp_path_factory.mktemp("txn")
    return plane_scene(base / "r1", frames=3), plane_scene(base / "r2", frames=2, step_m=0.3), base


# --- nothing that is not ours is ever deleted -------------------------------------------------

def test_an_export_onto_an_earlier_export_that_holds_the_render_is_refused_and_the_render_kept(tmp_path, capsys):
    render = plane_scene(tmp_path / "r", frames=2)
    out = tmp_path / "E"
    assert export(render, "png", out) == 0
    inside = out / "render"
    shutil.move(str(render), inside)
    before = tree(inside)
    assert export(inside, "png", out) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "render" in err, err
    assert tree(inside) == before
    assert (out / "export.json").is_file() and not leftovers(tmp_path)


def test_an_export_never_deletes_files_the_earlier_export_did_not_write(tmp_path, capsys):
    render = plane_scene(tmp_path / "r", frames=2)
    out = tmp_path / "E"
    assert export(render, "png", out) == 0
    first = tree(out)
    (out / "left" / "my-notes.txt").write_text("mine")
    assert export(render, "png", out, "--noise", 3) == 2
    err = capsys.readouterr().err
    assert "my-notes.txt" in err and err.strip().count("\n") == 0
    assert (out / "left" / "my-notes.txt").read_text() == "mine"
    assert {k: v for k, v in tree(out).items() if k != "left/my-notes.txt"} == first
    (out / "left" / "my-notes.txt").unlink()
    assert export(render, "png", out, "--noise", 3) == 0          # ours alone: replaced whole
    assert tree(out) != first and not leftovers(tmp_path)


def test_a_tree_export_refuses_a_slot_part_that_is_not_its_own(tmp_path, capsys):
    """kitti-odometry's slot spans sequences/NN and poses/NN.txt: a poses/00.txt that no
    export of ours wrote (real KITTI ground truth, say) is never replaced."""
    render = plane_scene(tmp_path / "r", frames=2)
    out = tmp_path / "kitti"
    (out / "dataset" / "poses").mkdir(parents=True)
    (out / "dataset" / "poses" / "00.txt").write_text("real ground truth\n")
    assert export(render, "kitti-odometry", out) == 2
    assert "00.txt" in capsys.readouterr().err
    assert (out / "dataset" / "poses" / "00.txt").read_text() == "real ground truth\n"
    assert not (out / "dataset" / "sequences").exists() and not leftovers(tmp_path)
    assert export(render, "kitti-odometry", out, "--sequence", "01") == 0   # another slot is free
    assert (out / "dataset" / "poses" / "00.txt").read_text() == "real ground truth\n"


def test_a_render_inside_a_tree_export_is_kept_when_it_is_outside_the_slot(tmp_path):
    render = plane_scene(tmp_path / "kitti" / "renders" / "r", frames=2)
    out = tmp_path / "kitti"
    assert export(render, "kitti-odometry", out) == 0
    assert export(render, "kitti-odometry", out, "--noise", 2) == 0
    assert (render / "manifest.json").is_file() and not leftovers(tmp_path)


# --- interrupted at every rename ----------------------------------------------------------------

def _interrupted_export(render, out, args, n: int, how: str) -> int:
    """Run the export in a forked child that is killed (``kill``: ``os._exit``) or sent SIGINT
    (``sigint``) right after its n-th rename; the child's exit status (130 = interrupted)."""
    pid = os.fork()
    if pid == 0:  # child
        try:
            count = [0]
            real = {name: getattr(os, name) for name in ("replace", "rename")}

            def hooked(name):
                def call(*a, **k):
                    r = real[name](*a, **k)
                    count[0] += 1
                    if count[0] == n:
                        if how == "kill":
                            os._exit(99)
                        os.kill(os.getpid(), signal.SIGINT)
                    return r
                return call
            for name in real:
                setattr(os, name, hooked(name))
            signal.signal(signal.SIGINT, signal.default_int_handler)
            rc = export(render, "kitti-odometry", out, *args)
        except BaseException:  # noqa: BLE001 - the child must never return into pytest
            rc = 98
        os._exit(rc)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


def _renames_of_one_export(render, out, args) -> int:
    counted = [0]
    real = {name: getattr(os, name) for name in ("replace", "rename")}
    mp = pytest.MonkeyPatch()
    for name in real:
        def call(*a, _f=real[name], **k):
            counted[0] += 1
            return _f(*a, **k)
        mp.setattr(os, name, call)
    try:
        assert export(render, "kitti-odometry", out, *args) == 0
    finally:
        mp.undo()
    return counted[0]


@pytest.mark.parametrize("how", ["kill", "sigint"])
def test_kitti_odometry_interrupted_at_every_rename_never_mixes_two_runs(renders, tmp_path, how):
    """The slot spans sequences/00 and poses/00.txt: after an interruption at any instant
    both come from one run (the earlier export or the new one), never images of one run
    with the poses of the other; SIGINT leaves no temporary folder, a kill leaves one that
    the next access rolls forward or back."""
    r1, r2, _ = renders
    ref_a, ref_b = tmp_path / "A", tmp_path / "B"
    assert export(r1, "kitti-odometry", ref_a) == 0
    n_renames = _renames_of_one_export(r2, ref_b, ())
    A, B = tree(ref_a), tree(ref_b)
    assert A != B
    for n in range(1, n_renames + 2):
        out = tmp_path / f"out-{n}"
        shutil.copytree(ref_a, out)
        rc = _interrupted_export(r2, out, (), n, how)
        seq, poses = out / "dataset" / "sequences" / "00", out / "dataset" / "poses" / "00.txt"
        # what any reader sees at once: never one run's images with the other's poses
        if seq.exists() and poses.exists():
            got = {k: v for k, v in tree(out).items() if not atomic.is_transaction_path(k)}
            assert got in (A, B), f"rename {n}: a mix of two runs"
        if how == "sigint":
            assert rc in (0, 130), (n, rc)
            assert not leftovers(tmp_path / f"out-{n}", tmp_path), (n, leftovers(out))
        else:
            assert rc in (0, 99), (n, rc)
            atomic.recover(out)        # the next access: roll forward or back
            assert not leftovers(out), (n, leftovers(out))
        assert tree(out) in (A, B), f"rename {n} ({how}): neither the earlier export nor the new one"
        if rc == 0:
            assert tree(out) == B


def test_an_export_interrupted_before_its_commit_leaves_nothing_where_there_was_nothing(renders, tmp_path):
    r1, _, _ = renders
    out = tmp_path / "fresh"
    rc = _interrupted_export(r1, out, (), 3, "sigint")
    assert rc == 130
    assert not out.exists() and not leftovers(tmp_path)


# --- a full disk ------------------------------------------------------------------------------

def _tmpfs_export(render: Path, mount: Path, size: str, target: str = "png") -> subprocess.CompletedProcess:
    script = (f"mount -t tmpfs -o size={size} tmpfs {mount} && "
              f"{sys.executable} -m vo_reference export {render} {mount}/E --to {target} --progress off; rc=$?; "
              f"ls -A {mount}; exit $rc")
    return subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=300)


def test_a_full_disk_is_one_line_exit_1_and_leaves_nothing(tmp_path):
    """ENOSPC from a real tmpfs of 200 KiB: one line naming the problem, exit 1, the
    partial export removed (the tmpfs is empty again)."""
    if shutil.which("unshare") is None or subprocess.run(["unshare", "-rm", "true"]).returncode != 0:
        pytest.skip("needs `unshare -rm` (user namespaces) to mount a small tmpfs")
    render = plane_scene(tmp_path / "r", W=320, H=240, frames=6)
    mount = tmp_path / "small"
    mount.mkdir()
    r = _tmpfs_export(render, mount, "200k")
    assert r.returncode == 1, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "No space left on device" in lines[0] and "Traceback" not in r.stderr, r.stderr
    assert r.stdout.strip() == "", r.stdout    # `ls -A` of the tmpfs: nothing left


def test_a_write_failure_in_the_middle_of_a_tree_export_leaves_the_earlier_export(renders, tmp_path, monkeypatch,
                                                                                  capsys):
    r1, r2, _ = renders
    out = tmp_path / "kitti"
    assert export(r1, "kitti-odometry", out) == 0
    before = tree(out)
    real, calls = atomic.write_bytes, [0]

    def failing(path, data, durable=False):
        calls[0] += 1
        if calls[0] == 5:
            raise OSError(28, os.strerror(28), str(path))
        return real(path, data, durable)
    monkeypatch.setattr(atomic, "write_bytes", failing)
    assert export(r2, "kitti-odometry", out) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "No space left on device" in err, err
    assert tree(out) == before and not leftovers(tmp_path)


def test_export_json_lists_what_the_export_owns(renders, tmp_path):
    r1, _, _ = renders
    out = tmp_path / "kitti"
    assert export(r1, "kitti-odometry", out, "--sequence", "3") == 0
    info = json.loads((out / "dataset" / "sequences" / "03" / "export.json").read_text())
    owns = info["owns"]
    assert owns["slot"] == "dataset/sequences/03"
    assert sorted(owns["units"]) == ["dataset/poses/03.txt", "dataset/sequences/03"]
    on_disk = sorted(k for k in tree(out))
    assert sorted(owns["files"]) == on_disk
    assert np.all([f.startswith(("dataset/poses/03.txt", "dataset/sequences/03/")) for f in owns["files"]])


def test_recovery_never_touches_a_live_transaction_and_finishes_dead_ones(tmp_path):
    """Another process's open transaction (alive: its stage is being written) is left alone;
    one whose process is gone is removed without a journal and rolled forward with one."""
    out = tmp_path / "OUT"
    code = ("import sys, time; from blender_sesgen.contract import atomic\n"
            f"tx = atomic.Transaction({str(out)!r}).open()\n"
            "(tx.stage / 'f').write_text('x'); print('ready', flush=True); time.sleep(60)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(REPO)})
    try:
        assert proc.stdout.readline().strip() == "ready"
        live = tmp_path / f".OUT.txn-{proc.pid}"
        assert atomic.recover(out) == [] and (live / "new" / "OUT" / "f").is_file()
    finally:
        proc.kill()
        proc.wait()
    dead_stage = tmp_path / ".OUT.txn-999999999"          # no such pid: a killed export
    (dead_stage / "new" / "OUT").mkdir(parents=True)
    assert set(atomic.recover(out)) == {live, dead_stage}
    assert not out.exists() and not leftovers(tmp_path)
    # a killed commit: its journal says the new OUT is decided
    tx = atomic.Transaction(out).open()
    (tx.stage / "g").write_text("new")
    atomic.write_json(tx.work / atomic.JOURNAL, {"format": atomic.TRANSACTION_FORMAT, "units": ["."]})
    tx._lock.close()
    tx._lock = None
    dead = tx.work.rename(tmp_path / ".OUT.txn-999999998")
    assert atomic.recover(out) == [dead]
    assert (out / "g").read_text() == "new" and not leftovers(tmp_path)
