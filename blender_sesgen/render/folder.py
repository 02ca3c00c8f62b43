"""A render's output folder: what it holds, whether a plan may write into it, and every
write into it (pure: numpy + stdlib; the files' layout is ``contract.manifest``'s).

Rules that keep a folder's data safe:

- **The one comparison of settings** (:meth:`OutputFolder.same_settings`): frames of the
  same scene rendered with the same pixel-affecting settings and the same camera model
  (:meth:`OutputFolder.same_camera`: a profile's numbers, the metering rule) can be resumed;
  anything else is refused unless the user forces it.
- **A lock per frame range** (``locks``): a second render of overlapping frames, or of
  another scene or settings, is refused with the holder's host and pid; disjoint chunks of
  the same plan (a render farm) may write concurrently; stale locks are taken over.
- **Crash-consistent start**: the manifest is written first, so a folder holding anything
  of ours is a render that ``--resume`` continues.
- **Verified writes**: an EXR is written under a temporary name, checked (every chunk inside
  the file, the required channels present) before it replaces the previous file, its
  SHA-256 recorded; a short write (a full disk) is an error and the old file stays. Its
  wall-clock header fields (date, render times) are removed: the same seed gives
  byte-identical files.
- **O(1) completion**: each completed frame is one line appended to this writer's log
  ``.sesgen/done-<host>-<pid>.jsonl``; the manifest takes the logs in when the render ends
  (readers merge them meanwhile), written durably (fsync of the file and its folder).
"""
from __future__ import annotations

import hashlib
import json
import os
import re
import stat
from dataclasses import replace
from pathlib import Path
from typing import Optional

from ..contract import atomic
from ..contract.errors import ContractError
from ..contract.inputs import read_bytes
from ..contract.manifest_sections import SENSOR_STATE, camera_record
from ..contract.pixel_settings import TIMING_KEYS, PixelSettings
from ..contract.manifest import (DISPLAY_DIR, DONE_LOG_GLOB, EXR_DIR, FORMAT, MANIFEST, POSES_DIR, SCENE_COPY, SEAL,
                                STATE_DIR, Manifest, completed_in_logs, display_relpath, exr_relpath,
                                fill_sensor_state, load_json, seal_problem, trajectory_relpaths)
from ..contract.trajectory_files import format_ego_table, format_kitti, format_tum
from ..errors import SesgenError
from ..files.image_check import ImageFileError, check_image_bytes
from ..files.exr import ExrError, check_complete, decode, read_layout, strip_volatile_attributes
from .locks import FolderLocks
from .plan import RenderPlan, EffectiveSettings

_OWN_EXR = re.compile(r"^\d{6}\.exr$")
_OWN_PNG = re.compile(r"^\d{6}\.png$")


def _file_key(path: Path) -> Optional[tuple]:
    """What tells one version of a regular file from another (None: no such file): every
    write of the manifest replaces the file (``contract.atomic``), so a new inode and times."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns) if stat.S_ISREG(st.st_mode) else None


class RenderWriteError(RuntimeError):
    """A file could not be written completely (a full disk, a failing device): exit 1."""


DISPLAY_KEY = "display:"   # written[DISPLAY_KEY + view]: that view's display-referred PNG


def display_key(view: str) -> str:
    return DISPLAY_KEY + view


def is_display_key(key: str) -> bool:
    return key.startswith(DISPLAY_KEY)


def display_view(key: str) -> str:
    return key[len(DISPLAY_KEY):]


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_TEXT_CHUNKS = {b"tEXt", b"iTXt", b"zTXt", b"tIME"}


def camera_change(manifest: dict, plan: RenderPlan) -> Optional[str]:
    """The first difference between the camera model ``manifest`` records and ``plan``'s
    (``contract.manifest_sections.camera_record``), as "key: old -> new"; None when equal."""
    old = camera_record(manifest)
    new = camera_record(json.loads(json.dumps(plan.sensor.manifest_entries(plan.scene.frames))))
    for section in sorted(set(old) | set(new)):
        a, b = old.get(section), new.get(section)
        if a == b:
            continue
        if not (isinstance(a, dict) and isinstance(b, dict)):
            return f"{section}: {'none' if a is None else 'present'} -> {'none' if b is None else 'present'}"
        key = next(k for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k))
        return f"{section}.{key}: {a.get(key)!r} -> {b.get(key)!r}"
    return None


def _first_write(name: str) -> bool:
    """The temporary of the manifest or the script's copy (``.manifest.tmp-PID.json``): what a
    render killed during its first writes leaves beside its state folder (``begin`` removes it);
    the folder is ours all the same, and ``--resume`` completes it."""
    stem = name.split(".tmp-", 1)[0]
    return atomic.is_temp_name(name) and stem in {"." + Path(f).stem for f in (MANIFEST, SCENE_COPY)}


def strip_png_text(buf: bytes) -> bytes:
    """The PNG without its text and time chunks: Blender writes its render metadata there
    (date, render time, memory: wall-clock values), so two renders of one frame would
    differ in bytes. Other chunks are kept as they are (their CRCs stay valid); a file that
    is not a well-formed chunk list is returned unchanged (the image check then says why)."""
    if not buf.startswith(_PNG_SIGNATURE):
        return buf
    out, i = [buf[:8]], 8
    while i + 12 <= len(buf):
        n = int.from_bytes(buf[i:i + 4], "big")
        end = i + 12 + n
        if end > len(buf):
            return buf
        if buf[i + 4:i + 8] not in _PNG_TEXT_CHUNKS:
            out.append(buf[i:end])
        i = end
    return b"".join(out) if i == len(buf) else buf


def seal_frame(k: int, written: dict[str, Path], required_channels: tuple) -> dict[str, str]:
    """Check each view's freshly written EXR (``written[view]``, a temporary file) and strip
    its wall-clock header fields (the file rewritten), and decode its display-referred PNG
    (``written[display_key(view)]``) if there is one, its text chunks (Blender's render
    metadata, wall-clock values) dropped; {relative path: sha256}.
    RenderWriteError (every temporary file removed) if a file is short or lacks a channel.
    Touches nothing but those files, so it may run in another process (``sealer``)."""
    def sealed(tmp, view: str, what: str, seal) -> bytes:
        try:
            buf = seal(Path(tmp).read_bytes())
            with open(tmp, "wb") as f:
                f.write(buf)
            return buf
        except (OSError, ImageFileError, ExrError) as e:
            for t in written.values():
                Path(t).unlink(missing_ok=True)
            raise RenderWriteError(f"frame {k} ({view}): the {what} was not written completely ({e}); "
                                   "is the disk full? The previous files were kept") from None

    def png(buf: bytes) -> bytes:
        buf = strip_png_text(buf)
        check_image_bytes(buf)
        return buf

    sums = {}
    for key, tmp in written.items():   # the display PNGs first: decoded (image_check)
        if is_display_key(key):
            view = display_view(key)
            sums[display_relpath(view, k)] = hashlib.sha256(sealed(tmp, view, "display PNG", png)).hexdigest()
    for view, tmp in written.items():
        if not is_display_key(view):
            rel = exr_relpath(view, k)
            buf = sealed(tmp, view, "EXR", lambda b: strip_volatile_attributes(
                b, check_complete(b, rel, required_channels, read_layout(b, rel))))
            sums[rel] = hashlib.sha256(buf).hexdigest()
    return sums


class OutputFolder:
    """The folder ``root`` as seen by one render (see the module docstring)."""

    def __init__(self, root):
        self.root = Path(root)
        self.state = self.root / STATE_DIR
        self._previous: Optional[dict] = None
        self._loaded = False
        self._read: tuple = (None, None)      # (file key, dict) of the manifest last read here
        self._written_key = None              # the file key of the manifest this render last wrote
        self._kept: Optional[dict] = None
        self._kept_for: Optional[RenderPlan] = None
        self.manifest: Optional[Manifest] = None    # this render's manifest, once begun
        self.checksums: dict[str, str] = {}
        self._own: set[str] = set()           # the files this render wrote (their checksums are its own)
        self.locks = FolderLocks(self.state)
        self._log = None

    # --- what is there ------------------------------------------------------------------
    def previous(self) -> Optional[dict]:
        """The manifest found in the folder (raw dict, read once), or None."""
        if not self._loaded:
            self._previous = self._read_manifest()
            self._loaded = True
        return self._previous

    def _read_manifest(self) -> Optional[dict]:
        """manifest.json as a dict (None if there is none), read again only if the file changed
        since this object last read it: a long route's manifest takes ~0.3 s to read, and
        check, begin and release all look at it."""
        path = self.root / MANIFEST
        key = _file_key(path)
        if key is None:
            return None
        if key != self._read[0]:
            self._read = (key, load_json(path))
        return self._read[1]

    @staticmethod
    def same_settings(manifest: Optional[dict], settings: EffectiveSettings) -> bool:
        """True when ``manifest``'s frames were rendered with the pixel-affecting ``settings``
        (``contract.pixel_settings``: device aside, the same output is expected on any device)."""
        return bool(manifest) and PixelSettings.from_manifest(manifest) == settings.pixel

    @staticmethod
    def same_camera(manifest: Optional[dict], plan: RenderPlan) -> bool:
        """True when ``manifest``'s frames were made by the camera model ``plan`` describes
        (its lens and sensor sections, the per-frame state aside): a newer version of this
        package may give the same script another profile or metering rule."""
        return bool(manifest) and camera_change(manifest, plan) is None

    @staticmethod
    def settings_key(settings: EffectiveSettings) -> str:
        """The pixel-affecting settings as one string (what the locks compare)."""
        return settings.pixel.key()

    def resumable(self, plan: RenderPlan) -> Optional[dict]:
        """The previous manifest if its frames may be kept for ``plan`` (same scene and
        settings), else None. Decided once per plan."""
        if self._kept_for is not plan:
            prev = self.previous()
            same = (prev and prev.get("scene_sha256") == plan.scene_sha256 and self.same_settings(prev, plan.settings)
                    and self.same_camera(prev, plan))
            self._kept, self._kept_for = (prev if same else None), plan
        return self._kept

    def _completed(self, kept: dict) -> list[bool]:
        """Completion of a kept manifest with the logs merged (frames whose files exist)."""
        n = int(kept.get("frames", 0))
        done = list(kept.get("frames_complete", [])) + [False] * n
        for k in completed_in_logs(self.root):
            if 0 <= k < n:
                done[k] = True
        return done[:n]

    def check(self, plan: RenderPlan, force: bool) -> None:
        """Refuse a folder that is not ours or holds another scene's output (unless ``force``).
        Writes nothing."""
        out = self.root
        if out.exists() and not out.is_dir():
            raise SesgenError(f"--out {out}: exists and is not a folder")
        if not out.exists():
            return
        if self.state.is_dir():  # a render writing here now is the first thing to say
            with self.locks.mutex():
                self.locks.refuse_conflicts((min(plan.frames), max(plan.frames)), plan.scene_sha256,
                                            self.settings_key(plan.settings), out)
        try:
            previous = self.previous()
        except ContractError as e:
            self._previous, self._loaded = None, True
            if not force:
                raise SesgenError(f"--out {out}: unreadable manifest.json ({e.detail}); use --force to overwrite") \
                    from None
            return
        if previous is None:
            if any(p.name != STATE_DIR and not _first_write(p.name) for p in out.iterdir()) and not force:
                raise SesgenError(f"--out {out}: folder is not empty and holds no render (no manifest.json); "
                                  "use --force to write into it anyway")
            return
        if previous.get("format") != FORMAT and not force:
            raise SesgenError(f"--out {out}: holds a render of format {previous.get('format')!r}; "
                              "use --force to overwrite")
        if previous.get("scene_sha256") != plan.scene_sha256 and not force:
            raise SesgenError(f"--out {out}: holds the output of a different scene ({previous.get('scene_source')}); "
                              "use --force to replace it")
        if not self.same_settings(previous, plan.settings) and any(self._completed(previous)) and not force:
            old = PixelSettings.from_manifest(previous)
            if old is not None and replace(old, timing=None) == replace(plan.settings.pixel, timing=None):
                timing = previous.get("timing")
                raise SesgenError("the output folder holds frames rendered with other timing "
                                  f"({ {k: timing.get(k) for k in TIMING_KEYS} if timing else None}); "
                                  "use --force to re-render")
            r = previous.get("render", {})
            raise SesgenError(f"--out {out}: holds frames rendered with other settings "
                              f"(quality {r.get('quality')}, samples {r.get('samples')}, denoise {r.get('denoise')}, "
                              f"seed {r.get('seed')}, "
                              f"resolution {previous.get('resolution')}); use --force to re-render")

        change = camera_change(previous, plan)
        if change and any(self._completed(previous)) and not force:
            raise SesgenError(f"--out {out}: holds frames made by another camera model ({change}; a profile's "
                              "numbers or the metering rule, e.g. rendered by another version of blender-sesgen); "
                              "use --force to re-render")

    def pending(self, plan: RenderPlan, resume: bool) -> list[int]:
        """The plan's frames still to render (all of them unless resuming)."""
        if self.manifest is not None:
            done = self.manifest.frames_complete
        elif resume and self.resumable(plan) is not None:
            kept = self.resumable(plan)   # a frame recorded complete whose files are gone is rendered again
            try:                          # validated once (a long route's manifest: 0.2 s), not once per frame
                m = Manifest.from_json(kept, str(self.root / MANIFEST))
            except ContractError:         # an earlier manifest that does not describe this render
                m = None
            done = [d and m is not None and self._files_exist(m, k) for k, d in enumerate(self._completed(kept))]
        else:
            return list(plan.frames)
        return [k for k in plan.frames if not (k < len(done) and done[k])]

    # --- the lock -------------------------------------------------------------------------
    def acquire(self, plan: RenderPlan) -> None:
        """Take this render's lock (see ``locks``): SesgenError if a live writer holds
        overlapping frames, or renders another scene or other settings here."""
        if self.locks.path is None:
            self.locks.take((min(plan.frames), max(plan.frames)), plan.scene_sha256,
                            self.settings_key(plan.settings), self.root)

    def drop_lock_of(self, host: str, pid: int) -> bool:
        """Remove the lock of writer ``pid`` on ``host``, known to be dead (a farm task saw its
        render process killed, or lost the worker that ran it), so that a retry on another
        host need not wait ``STALE_LOCK_S``; its completion log stays and is taken into the
        manifest by the next writer. True if there was such a lock."""
        return self.locks.drop_dead(host, pid)

    def consolidate(self) -> None:
        """Take every completion log into manifest.json and remove the logs (what a render
        does when it ends; a farm does it once all chunks of a folder have ended, since a
        killed chunk leaves its log). Refused while a render writes into the folder."""
        self.mark_incomplete(())

    def release(self) -> None:
        """Take the completion log into the manifest and drop the lock (end of a render,
        also after an error or an interrupt)."""
        if self._log is not None:
            self._log.close()
            self._log = None
        if self.locks.path is None:
            return
        try:
            if self.manifest is not None:
                with self.locks.mutex():
                    self._merge_logs()
        finally:
            self.locks.drop()

    # --- writing ------------------------------------------------------------------------
    def begin(self, plan: RenderPlan, manifest: Manifest, resume: bool, force: bool,
              static_files: Optional[dict] = None) -> None:
        """Lock, then write the manifest first (keeping the completion of frames already
        rendered with the same scene and settings), scene.ses, poses/ and ``static_files``
        ({relative path: bytes}: the sensor's lens tables and IMU streams), their SHA-256
        recorded in the manifest."""
        self.acquire(plan)
        out = self.root
        with self.locks.mutex():
            self._loaded, self._kept_for = False, None  # another chunk may have begun since check()
            prev = self.previous()
            if prev is not None and force and prev.get("scene_sha256") != plan.scene_sha256:
                self._remove_own_outputs()
            kept = self.resumable(plan)
            if kept is not None:
                prev_done = self._completed(kept)
                self.checksums = dict(kept.get("checksums") or {})
                for files in completed_in_logs(out).values():
                    self.checksums.update(files)
                redo = set() if resume else set(plan.frames)
                manifest = manifest.with_complete(
                    [bool(prev_done[k] and k not in redo and self._files_exist(manifest, k))
                     for k in range(manifest.frames)])
            self.manifest = manifest
            if kept is not None:   # a chunk that ended after this render's manifest was made
                self._merge_frame_state(kept)   # recorded its frames' exposures: keep them
            files = {**self._pose_files(plan, manifest), **(static_files or {})}
            self.checksums.update({rel: hashlib.sha256(data).hexdigest() for rel, data in files.items()})
            self._own.update(files)
            self._write_manifest(dead_logs_only=True, on_disk=prev)   # resuming: often what is there
        atomic.write_text(out / SCENE_COPY, plan.scene_text, durable=True)
        for view in plan.views:
            (out / EXR_DIR / view).mkdir(parents=True, exist_ok=True)
            if plan.writes_display:
                (out / DISPLAY_DIR / view).mkdir(parents=True, exist_ok=True)
        self._remove_stale_temporaries()
        for rel, data in files.items():
            atomic.write_bytes(out / rel, data)

    def exr_path(self, view: str, k: int) -> Path:
        return self.root / exr_relpath(view, k)

    def display_path(self, view: str, k: int) -> Path:
        return self.root / display_relpath(view, k)

    def commit_frame(self, k: int, written: dict[str, Path], required_channels: tuple) -> None:
        """Check each view's freshly written EXR (``written[view]``, a temporary file; and
        ``written[display_key(view)]``, its display-referred PNG), strip its wall-clock header
        fields, move it into place and record frame ``k`` complete; RenderWriteError (the
        previous files kept) if a file is short or lacks a channel."""
        self.commit_sealed(k, written, seal_frame(k, written, required_channels))

    def commit_sealed(self, k: int, written: dict[str, Path], sums: dict[str, str]) -> None:
        """Move frame ``k``'s sealed files (:func:`seal_frame`) into place and record it
        complete with ``sums`` (theirs and those of the frame's other files, its sensor
        images): the display PNGs first (an EXR in place means a whole frame)."""
        for key, tmp in written.items():
            if is_display_key(key):
                os.replace(tmp, self.root / display_relpath(display_view(key), k))
        for view, tmp in written.items():
            if not is_display_key(view):
                os.replace(tmp, self.root / exr_relpath(view, k))
        self.manifest.frames_complete[k] = True
        self.checksums.update(sums)
        self._own.update(sums)
        self._append_log({"frame": int(k), "files": sums})

    def _append_log(self, record: dict) -> None:
        if self._log is None:
            self._log = open(self.state / f"done-{self.locks.writer}.jsonl", "a", encoding="utf-8")
        # flushed, not fsync'd: a killed process loses nothing (the page cache survives it);
        # after a power cut a frame whose line was lost is rendered again, and one whose
        # EXR was lost is caught by its checksum (`verify`)
        self._log.write(json.dumps(record) + "\n")
        self._log.flush()
        self.locks.touch()

    def _merge_logs(self) -> None:
        """Under the mutex: what the manifest on disk holds now (other chunks may have merged
        theirs) and the logs' completions, into the manifest; own and dead logs removed."""
        try:   # the manifest this render wrote last is still there: nothing to take from it
            on_disk = {} if self._written_key and _file_key(self.root / MANIFEST) == self._written_key \
                else load_json(self.root / MANIFEST)
            done = on_disk.get("frames_complete") or []
            if on_disk.get("scene_sha256") == self.manifest.scene_sha256 and len(done) == self.manifest.frames:
                self.manifest.frames_complete = [a or bool(b) for a, b in zip(self.manifest.frames_complete, done)]
                # newer than what this render carried since it began (another chunk may have
                # written a frame again since), older than what it wrote itself
                self.checksums = {**self.checksums, **dict(on_disk.get("checksums") or {}),
                                  **{rel: self.checksums[rel] for rel in self._own if rel in self.checksums}}
                self._merge_frame_state(on_disk)
        except ContractError:
            pass
        for k, files in completed_in_logs(self.root).items():
            if 0 <= k < self.manifest.frames:
                self.manifest.frames_complete[k] = True
                self.checksums.update(files)
        self._write_manifest(dead_logs_only=False)

    def _merge_frame_state(self, on_disk: dict) -> None:
        """The per-frame sensor state (exposure, gain, metered brightness) of frames another
        chunk rendered, from the manifest it wrote: ours has None there."""
        mine, theirs = self.manifest.extra.get("sensor"), on_disk.get("sensor")
        if not isinstance(mine, dict) or not isinstance(theirs, dict):
            return
        for key in SENSOR_STATE:
            a, b = mine.get(key), theirs.get(key)
            if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
                mine[key] = [x if x is not None else y for x, y in zip(a, b)]

    def _state_from_files(self) -> None:
        """The per-frame sensor state of frames complete in our manifest that it holds none for,
        from the state file each frame's render wrote before committing it
        (``contract.manifest.fill_sensor_state``, what every reader merges too): a chunk killed
        after its frames recorded them there and in its completion log only (its manifest was
        written before its frames), and every later writer took the log's completion in with
        null exposures."""
        fill_sensor_state(self.root, self.manifest.extra.get("sensor"), self.manifest.frames_complete)

    def _write_manifest(self, dead_logs_only: bool, on_disk: Optional[dict] = None) -> None:
        self._state_from_files()
        if self.checksums:
            self.manifest.extra["checksums"] = dict(sorted(self.checksums.items()))
        self._written_key = _file_key(self.manifest.write(self.root, on_disk=on_disk))
        live = self.locks.live_writers()
        for log in self.state.glob(DONE_LOG_GLOB):
            writer = log.stem.replace("done-", "", 1)
            if writer not in live or (not dead_logs_only and writer == self.locks.writer):
                log.unlink(missing_ok=True)

    def _files_exist(self, m: Manifest, k: int) -> bool:
        """Every file of frame ``k`` that manifest ``m`` lists is in the folder."""
        try:
            return all((self.root / rel).is_file() for rel in m.frame_files(k))
        except IndexError:   # an earlier manifest that does not describe this render
            return False

    @staticmethod
    def _pose_files(plan: RenderPlan, manifest: Manifest) -> dict[str, bytes]:
        """poses/: each view's TUM and KITTI trajectory and the EGO table."""
        rel = trajectory_relpaths(manifest.views)
        out = {}
        for view, T in plan.view_poses.items():
            out[rel["tum"][view]] = format_tum(manifest.timestamps_s, T, "T_world_cam: OpenCV camera, SES world")
            out[rel["kitti"][view]] = format_kitti(T)
        out[rel["ego"]] = format_ego_table(plan.scene.timeline.ego_table())
        return {k: v.encode("utf-8") for k, v in out.items()}

    # --- checking ---------------------------------------------------------------------------
    def verify(self, full: bool = True, progress=None) -> list[tuple[Optional[int], str]]:
        """What is wrong with the folder, as (frame, what) -- frame None for the folder's own
        files: a manifest whose seal does not match it (then nothing else is checked: none of
        its values can be trusted) or that has none, a ``scene.ses`` that is not the script
        rendered, a trajectory, lens table or IMU file missing or not what was written; and
        for every frame recorded complete, each file the manifest lists for it (EXRs,
        display PNGs, sensor images) missing, truncated, lacking a channel the manifest names,
        differing from its recorded SHA-256 or (``full``) not decoding.
        ``progress(i, n)`` after each frame."""
        raw = load_json(self.root / MANIFEST)
        if seal_problem(raw):   # first: an edit is named as such, whatever it broke
            return [(None, f"{MANIFEST}: {seal_problem(raw)}")]
        m = Manifest.read(self.root, sealed=False)   # malformed: ContractError (a user error)
        bad: list[tuple[Optional[int], str]] = []
        if SEAL not in raw:
            bad.append((None, f"{MANIFEST}: not sealed (written before manifests were sealed): its values "
                              "cannot be proven; `render --resume` writes it again"))
        sums = dict(m.extra.get("checksums") or {})
        try:   # a regular file only: a FIFO there must not block verify
            if hashlib.sha256(read_bytes(self.root / SCENE_COPY, 64 << 20, "script")).hexdigest() != m.scene_sha256:
                bad.append((None, f"{SCENE_COPY}: not the script that was rendered (its SHA-256 differs from the "
                                  "manifest's scene_sha256)"))
        except ContractError as e:
            bad.append((None, f"{SCENE_COPY}: missing" if not (self.root / SCENE_COPY).exists() else
                        f"{SCENE_COPY}: {e.detail}"))
        # no file of a render is larger (an EXR of every pass, the lens table, the IMU streams):
        # a larger one is damaged, and is not read to be hashed
        limit = 64 * m.resolution[0] * m.resolution[1] + (1 << 30)
        for rel in m.static_files():
            why = self._check_file(rel, sums, full, None, limit)
            if why:
                bad.append((None, why))
        required = []
        for v in m.channels.values():
            required += [v] if isinstance(v, str) else list(v)
        exrs = {f for v in m.views for f in m.files[v]}
        done = [k for k in range(m.frames) if m.frames_complete[k]]
        for i, k in enumerate(done):
            for rel in m.frame_files(k):
                why = self._check_file(rel, sums, full, tuple(required) if rel in exrs else None, limit)
                if why:
                    bad.append((k, why))
                    break
            if progress:
                progress(i + 1, len(done))
        return bad

    def _check_file(self, rel: str, sums: dict, full: bool, exr_channels, limit: int) -> str:
        """'' when the file ``rel`` is whole and what was written (its SHA-256 in ``sums``);
        ``exr_channels``: an EXR that must hold them; else ``full`` decodes an image; a file
        larger than ``limit`` bytes is not read."""
        try:
            buf = read_bytes(self.root / rel, limit, "file")
            if exr_channels is not None:
                check_complete(buf, rel, exr_channels)
            if rel in sums and hashlib.sha256(buf).hexdigest() != sums[rel]:
                return f"{rel}: its SHA-256 differs from the one recorded when it was written"
            if full and exr_channels is not None:
                decode(buf, rel)
            elif full and rel.endswith((".png", ".jpg", ".jpeg")):
                check_image_bytes(buf)
        except ContractError as e:
            return f"{rel}: missing" if not (self.root / rel).exists() else f"{rel}: {e.detail}"
        except (OSError, ExrError) as e:
            return str(e) if isinstance(e, ExrError) else f"{rel}: {e.strerror or e}"
        except ImageFileError as e:
            return f"{rel}: {e}"
        return ""

    def mark_incomplete(self, frames) -> None:
        """Record ``frames`` as not rendered (``--resume`` renders them again); refused while
        a render writes into the folder."""
        with self.locks.mutex():
            live = self.locks.live()
            if live:
                raise SesgenError(f"--out {self.root}: being rendered by pid {live[0]['pid']} on {live[0]['host']}; "
                                  "verify again when it has finished")
            self.manifest = Manifest.read(self.root)
            self.checksums = dict(self.manifest.extra.get("checksums") or {})
            for k in frames:
                self.manifest.frames_complete[k] = False
                for rel in self.manifest.frame_files(k):
                    self.checksums.pop(rel, None)
            self.manifest.extra["checksums"] = self.checksums
            self._write_manifest(dead_logs_only=False)

    def _remove_own_outputs(self) -> None:
        """Delete the files a previous render wrote (our own names only; nothing else)."""
        for view in ("left", "right"):
            for folder, own in ((EXR_DIR, _OWN_EXR), (DISPLAY_DIR, _OWN_PNG)):
                d = self.root / folder / view
                if d.is_dir():
                    for f in d.iterdir():
                        if own.match(f.name) or atomic.is_temp_name(f.name):
                            f.unlink()
        pd = self.root / POSES_DIR
        if pd.is_dir():
            for f in pd.iterdir():
                if f.name.endswith((".tum.txt", ".kitti.txt")) or f.name == "ego.txt":
                    f.unlink()
        for log in self.state.glob(DONE_LOG_GLOB):
            log.unlink()
        (self.root / MANIFEST).unlink(missing_ok=True)
        self._previous, self._loaded, self._kept_for = None, True, None

    def _remove_stale_temporaries(self) -> None:
        """Temporary files of interrupted writers (never those of a live one: its pid is in the name).
        The folder is scanned without the mutex (a long one takes a while) and what looks stale
        is removed under it, the live writers read again: every writer takes its lock (under the
        mutex) before it writes anything here, so a chunk that began during the scan -- farm
        chunks begin together -- keeps its first files (the old single look removed them and
        the chunk failed at its rename)."""
        live = self.locks.live_pids()
        folders = [self.root / d / v for d in (EXR_DIR, DISPLAY_DIR) for v in ("left", "right")]
        folders += [self.root, self.root / POSES_DIR, self.state]
        stale = []
        for d in folders:
            if not d.is_dir():
                continue
            for f in d.iterdir():
                m = re.search(r"\.tmp-(\d+)", f.name)
                if m and atomic.is_temp_name(f.name) and int(m.group(1)) not in live and f.is_file():
                    stale.append((f, int(m.group(1))))
        if not stale:
            return
        with self.locks.mutex():
            live = self.locks.live_pids()
            for f, pid in stale:
                if pid not in live:
                    f.unlink(missing_ok=True)
