"""Atomic file writes: a reader (or a crash) never sees a half-written file under its name.

Every writer in both packages goes through :func:`temp_path` + ``os.replace``: the data is
written to ``.NAME.tmp-PID.EXT`` in the same folder (the extension stays last, because
OpenCV and OpenEXR pick the codec from it), then renamed. :func:`is_temp_name` recognises
those names, and the ones Blender makes of them for a multiview render (the view's suffix
after the pid: ``.000003.tmp-PID_left.png``, ``.000003_left.tmp-PID``), so a resumed job can
remove the leftovers of an interrupted one.
"""
from __future__ import annotations

import json
import math
import os
import re
import shutil
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from .errors import ContractError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None

_TEMP = re.compile(r"^\..+\.tmp-\d+(_[A-Za-z0-9]+)?(\.[A-Za-z0-9]+)?$")


def temp_path(path: Path) -> Path:
    """The temporary name under which ``path`` is written before the rename."""
    path = Path(path)
    return path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")


def is_temp_name(name: str) -> bool:
    """True for the names :func:`temp_path` makes (any process)."""
    return bool(_TEMP.match(name))


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def replacing(path, durable: bool = False) -> Iterator[Path]:
    """``with replacing(final) as tmp: write tmp`` -> renamed onto ``final`` if the block
    succeeds, removed if it raises. ``durable``: fsync the file and its folder (a crash
    right after leaves either the old or the new file, never a torn one)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_path(path)
    try:
        yield tmp
        if durable:
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
        if durable:
            _fsync_dir(path.parent)
    finally:
        if tmp.exists():
            tmp.unlink()


@contextmanager
def replacing_folder(path) -> Iterator[Path]:
    """``with replacing_folder(final) as tmp: fill tmp`` -> the folder ``tmp`` takes the place of
    ``final`` if the block succeeds (a :class:`Transaction` with the one unit ``final``); if
    it raises (or is interrupted) the partial folder is removed and ``final`` stays as it was.
    The caller decides whether ``final`` may be replaced."""
    with transaction(path) as tx:
        yield tx.stage
        tx.commit(["."])


# --- transactions: several paths made visible together ----------------------------------

_TXN_INSIDE = ".sesgen-txn-"           # OUT/.sesgen-txn-PID: OUT is a mount point
_TXN_NAME = re.compile(r"^\.(?:.+\.txn|sesgen-txn)-(\d+)$")
JOURNAL = "journal.json"
TRANSACTION_FORMAT = "sesgen-transaction/1"


def is_transaction_name(name: str) -> bool:
    """True for the working folders of :class:`Transaction` (any process)."""
    return bool(_TXN_NAME.match(name))


def is_transaction_path(rel: str) -> bool:
    """True when a relative path lies in (or is) a transaction's working folder."""
    return any(is_transaction_name(part) for part in Path(rel).parts)


class Transaction:
    """Stage the paths an operation writes under ``out`` and make them visible together.

    The operation writes into :attr:`stage`, a folder that mirrors ``out`` (same name); then
    :meth:`commit` takes a list of *units* -- paths relative to ``out`` (``"."`` is ``out``
    itself) that replace what is at their place whole -- and moves them into place:

    1. under an exclusive lock on the folder holding the working folder, ``check(unit,
       dest)`` is asked for every unit whose place is taken (it raises to refuse);
    2. the journal (the list of units) is written, fsync'd: from here on the commit is
       decided and is rolled *forward* by whoever finds it unfinished;
    3. everything in the way of every unit is moved aside into the working folder, then
       each staged unit is renamed into place (``last`` after the others);
    4. the working folder is deleted, with what was moved aside.

    So a reader sees the old units, then none, then the new ones: never one unit of each
    run. SIGINT/SIGTERM wait until the commit has finished (main thread). A process killed
    during 1 leaves a working folder without journal (the next :func:`recover` deletes it:
    nothing changed); killed during 3 or 4 one with a journal (:func:`recover` completes
    the commit). The working folder is ``.NAME.txn-PID`` beside ``out`` (same filesystem,
    so every move is a rename), or ``out/.sesgen-txn-PID`` when ``out`` is a mount point;
    it holds ``lock`` (flock'd by its live owner), ``journal.json``, ``new/NAME`` (the
    stage) and ``old/NAME`` (what was moved aside).
    """

    def __init__(self, out):
        self.out = Path(os.path.abspath(out))
        self.inside = os.path.ismount(self.out)
        base = self.out if self.inside else self.out.parent
        self.work = base / (f"{_TXN_INSIDE}{os.getpid()}" if self.inside else f".{self.out.name}.txn-{os.getpid()}")
        self.stage = self.work / "new" / self.out.name
        self._lock = None
        self._created = False          # the working folder is this transaction's (close may delete it)
        self.committed = False

    def open(self) -> "Transaction":
        self.work.parent.mkdir(parents=True, exist_ok=True)
        recover(self.out)               # earlier ones first (one may have had our pid)
        with held_interrupts():         # a Ctrl-C here would leave a working folder nobody removes
            try:
                self.work.mkdir()
            except FileExistsError:
                raise ContractError("another export into this folder is running in this process",
                                    str(self.out)) from None
            self._created = True
            self._lock = _flock(self.work / "lock", blocking=True)
            self.stage.mkdir(parents=True)
        return self

    def commit(self, units, last: str | None = None, check=None) -> None:
        """Move the staged ``units`` into place (see the class docstring); ``check(unit,
        dest)`` may refuse one whose place is taken (nothing is changed then)."""
        units = _normalised_units(units)
        if "." in units and self.inside:
            raise ContractError(f"{self.out} is a mount point and cannot be replaced whole; "
                                "write into a folder inside it", str(self.out))
        order = sorted(units, key=lambda u: (u == last, u))
        with _folder_lock(self.work.parent):
            if check is not None:
                for u in order:
                    dest = unit_path(self.out, u)
                    if os.path.lexists(dest):
                        check(u, dest)
            with held_interrupts():
                write_json(self.work / JOURNAL, {"format": TRANSACTION_FORMAT, "units": order}, durable=True)
                _roll_forward(self.work, self.out, order)
                self.committed = True
        self.close()

    def close(self) -> None:
        """Delete the working folder (abandoning the stage unless committed); a journal left
        by a commit that failed half-way is kept for :func:`recover`."""
        with held_interrupts():
            if self._created and self.work.exists() and (self.committed or not (self.work / JOURNAL).exists()):
                shutil.rmtree(self.work, ignore_errors=True)
            if self._lock is not None:
                self._lock.close()
                self._lock = None


@contextmanager
def transaction(out) -> Iterator[Transaction]:
    """``with transaction(out) as tx: write under tx.stage; tx.commit(units)``: what was
    staged is deleted if the block raises or never commits (:class:`Transaction`)."""
    tx = Transaction(out)
    try:
        tx.open()
        yield tx
    finally:
        tx.close()


def recover(out) -> list[Path]:
    """Finish the interrupted transactions on ``out`` whose process is gone (no process has
    the pid in the working folder's name, or it is this one; and its lock is free): those
    with a journal rolled forward, the others deleted. Returns their working folders."""
    out = Path(os.path.abspath(out))
    places = [(out.parent, f".{out.name}.txn-"), (out, _TXN_INSIDE)]
    done = []
    for folder, prefix in places:
        try:
            names = sorted(n for n in os.listdir(folder) if n.startswith(prefix) and n[len(prefix):].isdigit())
        except OSError:
            continue
        for name in names:
            work = folder / name
            pid = int(name[len(prefix):])
            if pid != os.getpid() and _alive(pid):   # its owner runs (a lock just being taken is not held yet)
                continue
            lock = _flock(work / "lock", blocking=False) if (work / "lock").exists() else _Flock(-1)
            if lock is None:            # held: a transaction of this process
                continue
            try:
                with held_interrupts(), _folder_lock(folder):
                    journal = work / JOURNAL
                    if journal.exists():
                        units = json.loads(journal.read_text(encoding="utf-8"))["units"]
                        _roll_forward(work, out, _normalised_units(units))
                    shutil.rmtree(work, ignore_errors=True)
            finally:
                lock.close()
            done.append(work)
    return done


def unit_path(root: Path, unit: str) -> Path:
    """Where transaction ``unit`` (a relative path, ``"."`` = ``root``) lies under ``root``."""
    return root if unit == "." else root.joinpath(*unit.split("/"))


def _normalised_units(units) -> list[str]:
    out = []
    for u in units:
        p = Path(str(u)).as_posix()
        if Path(p).is_absolute() or ".." in Path(p).parts or (p != "." and "." in Path(p).parts):
            raise ValueError(f"transaction unit {u!r}: expected a relative path inside the folder")
        out.append(p)
    for a in out:
        if any(b != a and (a == "." or b.startswith(a + "/")) for b in out):
            raise ValueError(f"transaction units overlap: {a!r} holds another unit")
    return sorted(set(out))


def _roll_forward(work: Path, out: Path, units: list[str]) -> None:
    """Steps 3 of :class:`Transaction` for the units still staged (idempotent: a commit that
    stopped anywhere continues where it stopped)."""
    new, old = work / "new" / out.name, work / "old" / out.name
    pending = [u for u in units if os.path.lexists(unit_path(new, u))]
    for u in pending:                  # first everything in the way goes aside ...
        dest = unit_path(out, u)
        if os.path.lexists(dest):
            aside = unit_path(old, u)
            if os.path.lexists(aside):
                raise ContractError(f"cannot finish an interrupted export: {dest} and {aside} both exist; "
                                    "move one of them away", str(dest))
            aside.parent.mkdir(parents=True, exist_ok=True)
            os.rename(dest, aside)
    for u in pending:                  # ... then the new units come in
        dest = unit_path(out, u)
        dest.parent.mkdir(parents=True, exist_ok=True)
        os.rename(unit_path(new, u), dest)
    for parent in {unit_path(out, u).parent for u in pending}:
        _fsync_dir(parent)


@contextmanager
def held_interrupts():
    """SIGINT and SIGTERM wait until the block has finished, then take effect (main thread;
    elsewhere they never reach Python code anyway). Unlike ``interrupt.deferred_interrupts``
    (a render polls its flag), the signal is raised again when the block ends."""
    import signal
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    saved = {s: signal.signal(s, lambda signum, frame: caught.append(signum)) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in saved.items():
            signal.signal(s, handler)
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)


class _Flock:
    def __init__(self, fd: int):
        self.fd = fd

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)       # releases the flock
            self.fd = -1


def _flock(path: Path, blocking: bool):
    """An exclusive flock on ``path`` (created), or None when another process holds it
    (``blocking=False``). Without fcntl (Windows) the lock is only the file."""
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    if fcntl is not None:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            os.close(fd)
            return None
        except OSError:             # a filesystem without flock: the pid in the name decides
            pass
    return _Flock(fd)


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this machine (a reused pid counts as alive: its
    working folder then waits for a later recovery, it is never taken from a live owner)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


@contextmanager
def _folder_lock(folder: Path):
    """Exclusive, across processes, for commits and recoveries in ``folder`` (a flock on the
    folder itself: nothing is left behind)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        yield
        return
    try:
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX)
            except OSError:
                pass
        yield
    finally:
        os.close(fd)


def write_bytes(path, data: bytes, durable: bool = False) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`replacing`)."""
    try:
        with replacing(path, durable) as tmp:
            with open(tmp, "wb") as f:
                f.write(data)
    except OSError as e:
        if e.filename is None:   # a failed write() names no file: name the one being written
            raise OSError(e.errno, e.strerror, str(path)) from None
        raise
    return Path(path)


def write_text(path, text: str, durable: bool = False) -> Path:
    return write_bytes(path, text.encode("utf-8"), durable)


_INLINE_MAX = 16     # items of a list written on one line: a vector, a 4x4 matrix, a short list of names
_SCALARS = (str, int, float, bool, type(None))
_ENCODER = json.JSONEncoder(allow_nan=False, sort_keys=True, separators=(",", ":"))
try:           # json's C encoder made once (JSONEncoder.encode makes one per call)
    from json.encoder import c_make_encoder, encode_basestring_ascii
    _C_ENCODE = c_make_encoder(None, _ENCODER.default, encode_basestring_ascii, None, ":", ",", True, False, False)
except (ImportError, TypeError):   # pragma: no cover - Pythons without the C accelerator
    _C_ENCODE = None


def dumps_json(obj, source: str | None = None) -> str:
    """JSON text, one item a line with one space of indent per level, a short list of scalars
    or of such lists (a vector, a matrix) compact on one line; NaN and infinities are refused
    (they are not JSON)."""
    return _text_and_canonical(obj, source)[0] + "\n"


def dumps_json_sealed(obj: dict, seal_key: str, seal, source: str | None = None) -> tuple[str, str]:
    """(:func:`dumps_json` of ``obj`` with ``seal_key: S`` added last, S): S = ``seal(C)``, C ``obj``'s
    canonical JSON (``json.dumps(obj, sort_keys=True, separators=(",", ":"))``, what a seal
    hashes). Both texts come from one encoding, each short list by json's C encoder: a long
    route's manifest, which holds every frame's poses and which every chunk of a farm writes,
    is written in under half the time it took json (indented: its pure-Python encoder) and
    the canonical JSON again."""
    text, canonical = _text_and_canonical(obj, source)
    if canonical is None:   # keys that are not strings: json sorts them its own way
        canonical = json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)
    value = seal(canonical)
    entry = _ENCODER.encode(seal_key) + ": " + _ENCODER.encode(value)
    return ((text[:-2] + ",\n " + entry + "\n}\n") if obj else "{\n " + entry + "\n}\n"), value


def _text_and_canonical(obj, source: str | None) -> tuple[str, str | None]:
    try:
        return _dumps(obj, 0)
    except ValueError:
        raise ContractError(f"refusing to write non-finite numbers into JSON ({_first_non_finite(obj)})",
                            source) from None


def _encode(obj) -> str:
    return "".join(_C_ENCODE(obj, 0)) if _C_ENCODE is not None and isinstance(obj, (list, tuple, dict)) \
        else _ENCODER.encode(obj)


def _short(v) -> bool:
    return len(v) <= _INLINE_MAX and all(isinstance(x, _SCALARS) for x in v)


def _dumps(obj, level: int) -> tuple[str, str | None]:
    """(text, canonical JSON or None where a dict has keys other than strings)."""
    if isinstance(obj, dict) and obj:
        pad = "\n" + " " * (level + 1)
        items = [(k, _ENCODER.encode(k if isinstance(k, str) else {k: 0}), *_dumps(v, level + 1))
                 for k, v in obj.items()]
        text = "{" + pad + ("," + pad).join(f"{key}: {t}" if isinstance(k, str) else f"{key[1:-3]}: {t}"
                                            for k, key, t, _ in items) + "\n" + " " * level + "}"
        if not all(isinstance(k, str) and c is not None for k, _, _, c in items):
            return text, None
        return text, "{" + ",".join(f"{key}:{c}" for _, key, _, c in sorted(items, key=lambda i: i[0])) + "}"
    if isinstance(obj, (list, tuple)) and obj and not (
            len(obj) <= _INLINE_MAX and all(isinstance(x, _SCALARS) or isinstance(x, (list, tuple)) and _short(x)
                                            for x in obj)):
        pad = "\n" + " " * (level + 1)
        items = [_dumps(v, level + 1) for v in obj]
        text = "[" + pad + ("," + pad).join(t for t, _ in items) + "\n" + " " * level + "]"
        return text, (None if any(c is None for _, c in items) else "[" + ",".join(c for _, c in items) + "]")
    text = _encode(obj)    # a scalar, {} or [], a short list (no dicts in it): the same both ways
    return text, text


def write_json(path, obj, durable: bool = False) -> Path:
    return write_text(path, dumps_json(obj, str(path)), durable)


def _first_non_finite(obj, where: str = "") -> str:
    if isinstance(obj, float) and not math.isfinite(obj):
        return f"{where or 'value'} = {obj}"
    if isinstance(obj, dict):
        items = obj.items()
    elif isinstance(obj, (list, tuple)):
        items = enumerate(obj)
    else:
        return ""
    for k, v in items:
        hit = _first_non_finite(v, f"{where}[{k!r}]" if where else repr(k))
        if hit:
            return hit
    return ""
