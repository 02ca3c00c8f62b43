"""The render folder contract ``sesgen-render/1``: its layout, and the manifest's one writer
and one validating reader (:class:`Manifest`).

::

    OUT/manifest.json          everything a reader needs (this module)
    OUT/scene.ses              the script as rendered
    OUT/poses/<view>.tum.txt   TUM trajectories, one per view (contract.trajectory_files)
    OUT/poses/<view>.kitti.txt KITTI trajectories
    OUT/poses/ego.txt          the per-step EGO table
    OUT/exr/<view>/NNNNNN.exr  one multilayer EXR per frame and view (float32, ZIP, scene-linear)
    OUT/rgb/<view>/NNNNNN.png  the display-referred 8-bit sRGB image (manifest ``display``)
    OUT/sensor/state/NNNNNN.json  a frame's sensor state (exposure_s, gain, metered), written
                               with the frame (state_relpath; merged by readers like the logs)
    OUT/.sesgen/               the render's own state (locks, completion logs): not data

Poses are ``T_world_cam``: OpenCV camera (x right, y down, z forward) in the SES world (Y up).
Depth and disparity conventions: contract.depth. Timestamps: contract.timing.

Frame completion is recorded in two places that readers merge: ``frames_complete`` in the
manifest (the state when it was last written) and append-only completion logs
``.sesgen/done-*.jsonl`` (one JSON object per completed frame, written by a running render
so that marking a frame complete costs O(1), whatever the sequence length). Likewise a
complete frame's sensor state (``sensor.exposure_s``, ``gain``, ``metered``) is in the
manifest once a writer took it in, and until then in the frame's state file
(:func:`state_relpath`): :func:`fill_sensor_state` merges it, for every reader
(:meth:`Manifest.read`) and every writer (``render.folder``).
"""
from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from . import rig
from .atomic import dumps_json_sealed, write_text
from .camera import K_problem
from .depth import DEPTH_BACKGROUND
from .errors import ContractError
from .inputs import read_text
from .manifest_schema import check_types
from .manifest_sections import SENSOR_STATE, Sections
from .se3 import not_rotations
from .timing import TIME_LIMIT_S

FORMAT = "sesgen-render/1"
MANIFEST = "manifest.json"
SCENE_COPY = "scene.ses"
POSES_DIR = "poses"
EXR_DIR = "exr"
DISPLAY_DIR = "rgb"           # the display-referred 8-bit PNGs (the view transform's image)
STATE_DIR = ".sesgen"
SENSOR_DIR = "sensor"         # the sensor images and the per-frame sensor state files
SEAL = "seal"                 # SHA-256 of the rest of the manifest (seal_of)
DONE_LOG_GLOB = "done-*.jsonl"
VIEWS = ("left", "right")
POSES_CONVENTION = "T_world_cam: OpenCV camera (x right, y down, z forward) in the SES world (Y up)"
OBJECT_POSES_CONVENTION = ("T_world_obj: the object frame (origin at the object's position, axes turned by its "
                           "rotation; a QUAD's is its vertex centroid with the world axes) in the SES world (Y up); "
                           "a point fixed on the object is at T_world_obj[k] @ X_obj at frame k")
OBJECT_MOTIONS = ("keys", "twist", "trajectory")
SEED_RULE = "cycles seed = (seed * 1000003 + 2 * frame + view_index) mod (2^31 - 1)"
LIMIT = 1e9  # no coordinate, focal length or size of ours is larger: beyond it a value is corrupt
POSE_TOLERANCE = 1e-6  # max |R^T R - I| of a pose in a manifest (written from float64 products)


def render_seed(seed: int, frame: int, view_index: int) -> int:
    """Cycles seed of one (frame, view) (``SEED_RULE``): deterministic, different for every
    frame and view (a fixed noise pattern shared by both views would look like texture)."""
    return (int(seed) * 1_000_003 + 2 * int(frame) + int(view_index)) % (2**31 - 1)


def object_motion_fields(motion: str | None = None, T_world_obj=None) -> dict:
    """The keys an ``objects`` entry carries about motion (their one writer): ``moving``
    for every object and, for a moving one, ``motion`` (keys | twist | trajectory) and
    ``T_world_obj`` (one 4x4 per frame; :data:`OBJECT_POSES_CONVENTION`)."""
    if motion is None:
        return {"moving": False}
    return {"moving": True, "motion": motion, "T_world_obj": np.asarray(T_world_obj, dtype=float).tolist()}


def exr_relpath(view: str, frame: int) -> str:
    return f"{EXR_DIR}/{view}/{frame:06d}.exr"


def display_relpath(view: str, frame: int) -> str:
    return f"{DISPLAY_DIR}/{view}/{frame:06d}.png"


def state_relpath(frame: int) -> str:
    """The per-frame sensor state (exposure, gain, metered brightness), written with the frame
    before it is recorded complete, so that a render stopped at any point resumes the same
    auto-exposure schedule and a reader of a folder whose writer was killed sees the frame's
    state (:func:`fill_sensor_state`)."""
    return f"{SENSOR_DIR}/state/{frame:06d}.json"


def fill_sensor_state(root, sensor, complete: Sequence[bool]) -> bool:
    """Fill, in the manifest's ``sensor`` dict (its per-frame lists ``SENSOR_STATE``), the null
    values of frames ``complete`` says are complete from each frame's state file
    (:func:`state_relpath`): a render killed after its frames recorded them there and in its
    completion log only (its manifest was written before them). Only null values are filled,
    with finite numbers; a missing or unreadable file leaves them null (a regular file of
    bounded size only: a FIFO there must not block). True if anything was filled."""
    if not isinstance(sensor, dict):
        return False
    n = len(complete)
    state = {key: sensor.get(key) for key in SENSOR_STATE}
    if not all(isinstance(v, list) and len(v) == n for v in state.values()):
        return False
    filled = False
    for k, done in enumerate(complete):
        if not done or all(state[key][k] is not None for key in SENSOR_STATE):
            continue
        try:
            st = json.loads(read_text(Path(root) / state_relpath(k), 1 << 16, "sensor state"))
        except (ContractError, ValueError):
            continue
        if not isinstance(st, dict):
            continue
        for key in SENSOR_STATE:
            v = st.get(key)
            if state[key][k] is None and isinstance(v, (int, float)) and not isinstance(v, bool) \
                    and math.isfinite(v):
                state[key][k] = float(v)
                filled = True
    return filled


def trajectory_relpaths(views: Sequence[str]) -> dict:
    return {
        "tum": {v: f"{POSES_DIR}/{v}.tum.txt" for v in views},
        "kitti": {v: f"{POSES_DIR}/{v}.kitti.txt" for v in views},
        "ego": f"{POSES_DIR}/ego.txt",
    }


# the keys every manifest holds, in the order they are written
_KEYS = ("format", "generator", "scene", "scene_source", "scene_sha256", "resolution", "K", "baseline", "near",
         "far", "frames", "fps", "timestamps", "views", "depth", "segmentation", "channels", "objects",
         "object_poses_convention", "poses_convention", "poses", "trajectories", "files", "frames_complete",
         "render", "seal")


@dataclass
class Manifest:
    """A render folder's manifest, validated: what the renderer writes and every reader reads.

    Arrays are numpy (``K`` (3, 3), ``poses[view]`` (N, 4, 4), ``timestamps_s`` (N,)); keys this
    class does not model (``noise``, ``fog`` and those of later versions) stay in ``extra``.
    ``object_poses`` {id: (N, 4, 4)} holds the moving objects' ``T_world_obj`` (validated from
    ``objects``; empty for a static scene or a render made before moving objects existed).
    """
    resolution: tuple[int, int]
    K: np.ndarray
    baseline: float
    views: tuple[str, ...]
    poses: dict
    files: dict
    timestamps_s: np.ndarray
    fps: float
    near: float = 0.05
    far: float = 1000.0
    frames_complete: list = field(default_factory=list)
    depth: dict = field(default_factory=lambda: {"kind": "planar_z", "background": DEPTH_BACKGROUND, "channel": None})
    segmentation: dict = field(default_factory=lambda: {"kind": "object_index", "background": 0, "channel": None})
    channels: dict = field(default_factory=dict)
    objects: list = field(default_factory=list)
    render: dict = field(default_factory=dict)
    scene_source: str = ""
    scene_sha256: str = ""
    generator: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    object_poses: dict = field(default_factory=dict)
    sections: Optional[Sections] = None

    def __post_init__(self):
        if not self.frames_complete:
            self.frames_complete = [False] * self.frames
        if not self.object_poses:
            self.object_poses = object_poses(self.objects, self.frames)
        if self.sections is None:   # a manifest being written: its sections as the writer put them in extra
            core = {"views": list(self.views), "frames": self.frames, "fps": self.fps,
                    "timestamps": [float(t) for t in self.timestamps_s[:1]]}
            self.sections = Sections.from_json({**core, **{k: self.extra.get(k) for k in Sections.KEYS}},
                                               MANIFEST, LIMIT)

    @property
    def frames(self) -> int:
        return len(self.timestamps_s)

    @property
    def depth_background(self) -> float:
        return float(self.depth.get("background", DEPTH_BACKGROUND))

    # --- writing ------------------------------------------------------------------------
    def to_json(self) -> dict:
        m = {
            "format": FORMAT,
            "generator": self.generator,
            "scene": SCENE_COPY,
            "scene_source": self.scene_source,
            "scene_sha256": self.scene_sha256,
            "resolution": [int(self.resolution[0]), int(self.resolution[1])],
            "K": [[float(x) for x in row] for row in np.asarray(self.K, dtype=float)],
            "baseline": float(self.baseline),
            "near": float(self.near),
            "far": float(self.far),
            "frames": self.frames,
            "fps": float(self.fps),
            "timestamps": [float(t) for t in self.timestamps_s],
            "views": list(self.views),
            "depth": self.depth,
            "segmentation": self.segmentation,
            "channels": self.channels,
            "objects": self.objects,
            "object_poses_convention": OBJECT_POSES_CONVENTION,
            "poses_convention": POSES_CONVENTION,
            "poses": {v: np.asarray(self.poses[v], dtype=float).tolist() for v in self.views},
            "trajectories": trajectory_relpaths(self.views),
            "files": {v: list(self.files[v]) for v in self.views},
            "frames_complete": [bool(x) for x in self.frames_complete],
            "render": self.render,
        }
        m.update(self.extra)
        return m

    def write(self, root, durable: bool = True, on_disk: Optional[dict] = None) -> Path:
        """Write ``root/manifest.json`` atomically (NaN or infinities are refused), sealed
        (:func:`seal_of`); not at all when it would hold ``on_disk`` (what was just read from
        there), seal included."""
        m = self.to_json()
        m.pop(SEAL, None)
        path = Path(root) / MANIFEST
        text, seal = dumps_json_sealed(m, SEAL, _sha256_hex, str(path))
        if on_disk is not None and on_disk.get(SEAL) == seal and {k: v for k, v in on_disk.items() if k != SEAL} == m:
            return path
        return write_text(path, text, durable)

    def frame_files(self, k: int) -> list[str]:
        """Every file of frame ``k`` the manifest lists: each view's EXR (``files``), display
        PNG (``display.files``) and sensor images (``sensor.files``, every kind)."""
        out = [self.files[v][k] for v in self.views]
        display = (self.extra.get("display") or {}).get("files") or {}   # checked by manifest_schema
        out += [display[v][k] for v in self.views if v in display]
        sensor = self.sections.sensor
        if sensor is not None:
            out += [sensor.file(kind, v, k) for kind in sensor.files for v in self.views]
        return [f for f in out if f]

    def static_files(self) -> list[str]:
        """The files the manifest lists once per render: trajectories, the lens's calibration
        and lookup table, the IMU streams."""
        traj = trajectory_relpaths(self.views)
        out = [*traj["tum"].values(), *traj["kitti"].values(), traj["ego"]]
        lens, imu = self.sections.lens, self.sections.imu
        if lens is not None:
            out += list(lens.opencv_files.values()) + ([lens.undistort_lut] if lens.undistort_lut else [])
        if imu is not None:
            out += [p for p in imu.files.values() if isinstance(p, str)]
        return list(dict.fromkeys(out))

    def with_complete(self, complete: Sequence[bool]) -> "Manifest":
        return replace(self, frames_complete=[bool(x) for x in complete])

    # --- reading ------------------------------------------------------------------------
    @classmethod
    def from_json(cls, m, source: str = MANIFEST) -> "Manifest":
        """Validate a manifest dict; :class:`ContractError` naming ``source`` on any defect."""
        if not isinstance(m, dict):
            raise ContractError("expected a JSON object", source)
        fmt = m.get("format")
        if fmt != FORMAT:
            raise ContractError(f"format {fmt!r} is not supported (this reader reads {FORMAT!r})", source)
        missing = [k for k in ("resolution", "K", "baseline", "frames", "views", "poses", "files") if k not in m]
        if missing:
            raise ContractError(f"missing key(s) {', '.join(missing)}", source)
        check_types(m, source, LIMIT)
        sections = Sections.from_json(m, source, LIMIT)
        try:
            W, H = (int(v) for v in m["resolution"])
            K = np.array(m["K"], dtype=float).reshape(3, 3)
            baseline = float(m["baseline"])
            n = int(m["frames"])
            views = tuple(str(v) for v in m["views"])
            near, far = float(m.get("near", 0.05)), float(m.get("far", 1000.0))
        except (TypeError, ValueError) as e:
            raise ContractError(f"bad resolution/K/baseline/frames/views/near/far ({e})", source) from None
        if not (0 < W <= 65536 and 0 < H <= 65536) or n < 1:
            raise ContractError(f"resolution {W}x{H} / {n} frames is not a render", source)
        if K_problem(K, LIMIT):
            raise ContractError(f"K is not a camera matrix ({K_problem(K, LIMIT)}): {K.tolist()}", source)
        if not (math.isfinite(baseline) and 0.0 <= baseline < LIMIT) or not (0 < near < far):
            raise ContractError(f"baseline {baseline} / near {near} / far {far} out of range", source)
        if not views or views[0] != "left" or not set(views) <= set(VIEWS) or len(set(views)) != len(views):
            raise ContractError(f"views must be ['left'] or ['left', 'right'], got {list(views)}", source)
        if "right" not in views:
            baseline = 0.0
        poses = {}
        for v in views:
            try:
                T = np.array(m["poses"][v], dtype=float)
            except (KeyError, TypeError, ValueError):
                raise ContractError(f"no usable poses for view {v!r}", source) from None
            if T.shape != (n, 4, 4):
                raise ContractError(f"poses[{v!r}] has shape {T.shape}, expected ({n}, 4, 4)", source)
            if not np.all(np.isfinite(T)) or np.abs(T).max() > LIMIT:
                raise ContractError(f"poses[{v!r}] holds non-finite or absurdly large values", source)
            R = T[:, :3, :3]
            bad = np.flatnonzero(not_rotations(R, POSE_TOLERANCE) | np.any(T[:, 3] != (0.0, 0.0, 0.0, 1.0), axis=1))
            if bad.size:
                raise ContractError(f"poses[{v!r}][{bad[0]}] is not a rigid transform (rotation and 0 0 0 1 row)",
                                    source)
            poses[v] = T
        if "right" in poses:   # the rig is rigid: the right camera is the left one moved by the baseline
            expect = rig.T_world_view(poses["left"], "right", baseline)
            tol = 1e-6 * (1.0 + baseline + np.abs(poses["left"][:, :3, 3]).max(axis=1))
            bad = np.flatnonzero(np.abs(poses["right"] - expect).max(axis=(1, 2)) > tol)
            if bad.size:
                raise ContractError(f"poses['right'][{bad[0]}] is not the left pose moved by the baseline "
                                    f"({baseline:g} m along its x axis)", source)
        files = {}
        for v in views:
            f = (m["files"] or {}).get(v) if isinstance(m["files"], dict) else None
            if not isinstance(f, list) or len(f) != n or not all(isinstance(x, str) for x in f):
                raise ContractError(f"files[{v!r}] must list {n} paths", source)
            if any(Path(x).is_absolute() or ".." in Path(x).parts for x in f):
                raise ContractError(f"files[{v!r}] must be paths inside the render folder", source)
            files[v] = f
        fps = m.get("fps") or (m.get("render") or {}).get("fps")
        ts = m.get("timestamps")
        try:
            if ts is not None:
                t = np.asarray(ts, dtype=float)
            elif fps:
                t = np.arange(n, dtype=float) / float(fps)
            else:
                t = np.arange(n, dtype=float)
        except (TypeError, ValueError):
            raise ContractError("timestamps must be numbers", source) from None
        if t.shape != (n,) or not np.all(np.isfinite(t)) or np.abs(t).max() > TIME_LIMIT_S \
                or np.any(np.diff(t) <= 0):
            raise ContractError(f"timestamps must be {n} increasing numbers within {TIME_LIMIT_S:g} s", source)
        complete = m.get("frames_complete", [True] * n)
        if not isinstance(complete, list) or len(complete) != n:
            raise ContractError(f"frames_complete must list {n} booleans", source)
        depth = m.get("depth") or {}
        if depth.get("kind", "planar_z") != "planar_z":
            raise ContractError(f"depth kind {depth.get('kind')!r} not supported (planar_z)", source)
        depth = {"kind": "planar_z", "background": DEPTH_BACKGROUND, "channel": None, **depth}
        extra = {k: v for k, v in m.items() if k not in _KEYS}
        objects = list(m.get("objects") or [])
        moving = object_poses(objects, n, source)
        return cls(resolution=(W, H), K=K, baseline=baseline, views=views, poses=poses, files=files,
                   timestamps_s=t, fps=float(fps) if fps else float("nan"), near=near, far=far,
                   frames_complete=[bool(x) for x in complete], depth=depth,
                   segmentation=m.get("segmentation") or {"kind": "object_index", "background": 0, "channel": None},
                   channels=m.get("channels") or {}, objects=objects, object_poses=moving,
                   render=m.get("render") or {}, scene_source=str(m.get("scene_source", "")),
                   scene_sha256=str(m.get("scene_sha256", "")), generator=m.get("generator") or {}, extra=extra,
                   sections=sections)

    @classmethod
    def read(cls, root, sealed: bool = True) -> "Manifest":
        """``root/manifest.json`` validated, with what a running or interrupted render recorded
        beside it merged in: its completion logs (``frames_complete``, ``checksums``) and its
        complete frames' sensor state files (:func:`fill_sensor_state`). ``sealed``:
        ContractError when the manifest's seal does not match its content (edited after it
        was written; a manifest written before seals existed has none and is read as it is)."""
        root = Path(root)
        raw = load_json(root / MANIFEST)
        m = cls.from_json(raw, str(root / MANIFEST))   # first: a value no render has is named as such
        if sealed and seal_problem(raw):
            raise ContractError(seal_problem(raw), str(root / MANIFEST))
        merged = merge_written_beside(raw, root)
        return m if merged is raw else cls.from_json(merged, str(root / MANIFEST))


def merge_written_beside(raw: dict, root) -> dict:
    """The manifest dict ``raw`` (as read from ``root``) with the completion logs and the
    complete frames' sensor state files merged in (a new dict; ``raw`` is not changed and is
    returned as it is when nothing is to merge). Malformed parts are left as they are: the
    validating reader says what is wrong with them."""
    if not isinstance(raw, dict):
        return raw
    n = raw.get("frames")
    complete = raw.get("frames_complete", [True] * n if isinstance(n, int) and not isinstance(n, bool) else None)
    if not isinstance(n, int) or isinstance(n, bool) or not isinstance(complete, list) or len(complete) != n:
        return raw
    out = raw
    done = completed_in_logs(root)
    if done:
        out = {**raw, "frames_complete": [bool(c) or k in done for k, c in enumerate(complete)]}
        sums = dict(raw.get("checksums") or {}) if isinstance(raw.get("checksums") or {}, dict) else None
        if sums is not None:
            for files in done.values():
                sums.update(files)
            out["checksums"] = sums
    sensor = raw.get("sensor")
    if isinstance(sensor, dict):
        copy = {**sensor, **{key: list(sensor[key]) for key in SENSOR_STATE if isinstance(sensor.get(key), list)}}
        if fill_sensor_state(root, copy, [bool(c) for c in out.get("frames_complete", complete)]):
            out = {**out, "sensor": copy}
    return out


def seal_of(m: dict) -> str:
    """The manifest's seal: SHA-256 of its canonical JSON (keys sorted, no spaces, the seal
    itself left out). Every write seals (:meth:`Manifest.write`), so a manifest whose
    values were changed afterwards (K, baseline, poses, checksums...) no longer matches."""
    body = {k: v for k, v in m.items() if k != SEAL}
    return _sha256_hex(json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False))


def _sha256_hex(canonical: str) -> str:
    return hashlib.sha256(canonical.encode("ascii")).hexdigest()


def seal_problem(m: dict) -> str:
    """'' when the manifest dict carries a seal that matches it (or none: written before
    seals existed); else what is wrong."""
    if not isinstance(m, dict) or SEAL not in m:   # not a manifest at all: its reader says so
        return ""
    if not isinstance(m[SEAL], str) or m[SEAL] != seal_of(m):
        return ("its content differs from what the renderer wrote (the seal does not match: edited "
                "afterwards?); `render --resume` writes it again from the script")
    return ""


def object_poses(objects: list, n: int, source: str = MANIFEST) -> dict[int, np.ndarray]:
    """{id: (n, 4, 4) T_world_obj} of the ``objects`` entries marked ``moving`` (validated:
    ContractError naming ``source`` for a moving object without n finite rigid poses)."""
    out = {}
    for o in objects:
        if not isinstance(o, dict) or not o.get("moving"):
            continue
        try:
            obj_id = int(o["id"])
            T = np.array(o["T_world_obj"], dtype=float)
        except (KeyError, TypeError, ValueError):
            raise ContractError(f"moving object {o.get('id')!r} has no usable T_world_obj", source) from None
        if T.shape != (n, 4, 4):
            raise ContractError(f"objects[id={obj_id}].T_world_obj has shape {T.shape}, expected ({n}, 4, 4)", source)
        if not np.all(np.isfinite(T)) or np.abs(T).max() > LIMIT or not_rotations(T[:, :3, :3], POSE_TOLERANCE).any():
            raise ContractError(f"objects[id={obj_id}].T_world_obj holds non-rigid or non-finite poses", source)
        out[obj_id] = T
    return out


def load_json(path: Path) -> dict:
    """A JSON file as a dict; ContractError (naming the file) when missing, not a regular
    file, not JSON, or holding NaN / Infinity / numbers beyond a double (not JSON either:
    Python's json module would read them as non-finite floats)."""
    path = Path(path)
    if not path.exists():
        raise ContractError("no manifest.json (not a render folder)" if path.name == MANIFEST else "no such file",
                            str(path.parent if path.name == MANIFEST else path))
    text = read_text(path, what="JSON file")
    try:   # a number beyond a double (300 digits, a 3-digit exponent) is rare: only then each float is checked
        data = json.loads(text, parse_constant=_not_json,
                          parse_float=_finite_float if _MAYBE_HUGE.search(text) else None)
    except _NonFinite as e:
        raise ContractError(f"{e.args[0]} is not a JSON number", str(path), _line_of_constant(text, e.args[0])) \
            from None
    except (ValueError, RecursionError) as e:
        raise ContractError(f"not valid JSON ({e})", str(path), getattr(e, "lineno", None)) from None
    return data


_MAYBE_HUGE = re.compile(r"[0-9]{300}|[0-9.][eE]\+?0*[1-9][0-9]{2,}(?=[\s,\]}]|$)")   # not in hex digests


class _NonFinite(ValueError):
    pass


def _not_json(name: str):
    raise _NonFinite(name)


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _NonFinite(text)
    return value


def _line_of_constant(text: str, constant: str):
    """The line of the first bare (not quoted) ``constant`` in JSON ``text``."""
    for m in re.finditer(r'"(?:[^"\\]|\\.)*"|' + re.escape(constant), text):
        if not m.group(0).startswith('"'):
            return text.count("\n", 0, m.start()) + 1
    return None


def completed_in_logs(root) -> dict[int, dict]:
    """{frame: {relpath: sha256}} of the frames the completion logs of ``root`` record.

    A torn last line (a crash while appending) is ignored: that frame is simply not complete.
    """
    out: dict[int, dict] = {}
    state = Path(root) / STATE_DIR
    if not state.is_dir():
        return out
    for log in sorted(state.glob(DONE_LOG_GLOB)):
        try:  # a regular file of bounded size (a FIFO here must not block a reader)
            text = read_text(log, what="completion log", strict=False)
        except ContractError:
            continue  # unreadable: its frames count as not complete (they are rendered again)
        for line in text.split("\n"):
            try:
                rec = json.loads(line)
            except ValueError:
                continue
            frame, files = (rec.get("frame"), rec.get("files") or {}) if isinstance(rec, dict) else (None, None)
            if isinstance(frame, int) and not isinstance(frame, bool) and frame >= 0 and isinstance(files, dict) \
                    and all(isinstance(k, str) and isinstance(v, str) for k, v in files.items()):
                out[frame] = dict(files)
    return out
