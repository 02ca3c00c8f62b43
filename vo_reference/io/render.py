"""Reader of render folders in the ``sesgen-render/1`` format (docs/output-format.md).

::

    OUT/manifest.json          everything a reader needs (K, baseline, poses, files...)
    OUT/exr/left/NNNNNN.exr    multilayer EXR per frame and view, one part per pass:
    OUT/exr/right/NNNNNN.exr   ViewLayer.Combined.R/G/B/A, ViewLayer.Depth.Z,
                               ViewLayer.Object Index.X (float32)

Blender 4.x writes the same channels in one single-part file and names the index pass
``IndexOB`` (``ViewLayer.IndexOB.X``): both layouts and both names read the same.

Depth is planar z; Cycles writes 1e10 (the manifest's ``depth.background``) where a ray
hits nothing: the reader returns +inf there, never a finite depth.
"""
from __future__ import annotations

import hashlib
from collections import OrderedDict
from pathlib import Path

import numpy as np

from blender_sesgen.contract import rig
from blender_sesgen.contract.colour import linear_to_srgb8
from blender_sesgen.contract.depth import depth_from_pass
from blender_sesgen.contract.exr_format import PASS_COMBINED, PASS_DEPTH, PASS_INDEX, VIEW_LAYER
from blender_sesgen.contract.inputs import read_bytes, read_text
from blender_sesgen.contract.manifest import FORMAT, MANIFEST, Manifest
from blender_sesgen.contract.manifest_sections import RigMotionSection
from blender_sesgen.contract.timing import DEFAULT_FPS

from ..errors import VoError, as_vo_error
from .color import rgb8_to_gray8
from .base import Sequence, check_frame_view
from .exr import find_pass, read_exr_channels
from .files import read_image

__all__ = ["RenderSequence", "read_manifest"]



def read_manifest(root) -> Manifest:
    """The validated manifest of a render folder (completion logs merged); VoError on any defect."""
    root = Path(root)
    if not (root / MANIFEST).exists():
        raise VoError(f"{root}: no manifest.json (not a render folder)")
    with as_vo_error():
        return Manifest.read(root)


class RenderSequence(Sequence):
    """A render folder as a :class:`~vo_reference.io.sequence.Sequence`.

    Extras: ``manifest`` (the dict), ``root``, ``near``/``far``, ``noise`` ((sigma, seed)
    or None), ``objects``, :meth:`rgb_linear`, :meth:`alpha`, :meth:`frame_complete`,
    :meth:`exr_path`.
    """

    def __init__(self, root, cache_frames: int = 4, verify: bool = False):
        """``verify``: check every EXR read against the SHA-256 the renderer recorded for it
        (VoError on a mismatch: the file changed or was damaged after it was written)."""
        self.root = Path(root)
        self.verify = bool(verify)
        self.info = m = read_manifest(self.root)
        self.manifest = m.to_json()
        self.resolution = m.resolution
        self.K = m.K
        self.baseline_m = m.baseline
        self.num_frames = m.frames
        self.views = m.views
        self.depth_background = m.depth_background
        self.near, self.far = m.near, m.far
        self.objects = m.objects
        self._object_poses = m.object_poses
        noise = m.extra.get("noise")
        self.noise = (float(noise["sigma"]), int(noise.get("seed", 0))) if isinstance(noise, dict) else None
        self._poses = m.poses
        self._files = m.files
        self.timestamps_s = m.timestamps_s
        self._cache: OrderedDict = OrderedDict()
        self._cache_frames = max(1, int(cache_frames))

    # --- files ------------------------------------------------------------------------
    def exr_path(self, k: int, view: str = "left") -> Path:
        check_frame_view(self, k, view)
        self._require_rendered(k)
        rel = self._files[view][int(k)]
        if not rel:
            raise VoError(f"{self.root}: frame {k} ({view}) was not rendered")
        return self.root / rel

    def provenance(self) -> dict:
        """The render's format and scene hash (what an export records about its source)."""
        return {"format": FORMAT, "scene_sha256": self.info.scene_sha256}

    def _require_rendered(self, k: int) -> None:
        """VoError unless frame ``k`` is recorded complete: the pixels of a frame a render is
        writing now, one a killed render left unfinished or one ``verify`` found bad are never
        read (its files may be missing, or there and damaged: the old reader read whatever lay
        there). The folder is read again first: a render may have completed it since this
        reader opened it (completion logs, or its manifest once it ended)."""
        k = int(k)
        if self.info.frames_complete[k]:
            return
        try:
            fresh = read_manifest(self.root)
        except VoError:
            fresh = None
        if fresh is not None and fresh.scene_sha256 == self.info.scene_sha256 and fresh.frames == self.num_frames \
                and fresh.frames_complete[k]:
            self.info = fresh
            self.manifest = fresh.to_json()
            return
        raise VoError(f"{self.root}: frame {k} is not rendered completely (a render is writing it, or one was "
                      "interrupted, or `verify` found it bad): finish the render (--resume) or choose other frames")

    def frame_complete(self, k: int) -> bool:
        """True when frame k is recorded complete and every file the manifest lists for it
        (EXRs, display PNGs, sensor images) exists."""
        if not 0 <= int(k) < self.num_frames or not self.info.frames_complete[int(k)]:
            return False
        return all((self.root / rel).is_file() for rel in self.info.frame_files(int(k)))

    def _channels(self, k: int, view: str) -> dict:
        key = (int(k), view)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        path = self.exr_path(k, view)
        if self.verify:
            self._check_sha256(path)
        ch = read_exr_channels(path)
        W, H = self.resolution
        shape = next(iter(ch.values())).shape
        if shape != (H, W):
            raise VoError(f"{path}: image is {shape[1]}x{shape[0]}, manifest says {W}x{H}")
        ch["__path__"] = path
        self._cache[key] = ch
        while len(self._cache) > self._cache_frames:
            self._cache.popitem(last=False)
        return ch

    def _check_sha256(self, path: Path) -> None:
        rel = path.relative_to(self.root).as_posix()
        want = (self.info.extra.get("checksums") or {}).get(rel)
        if want is None:
            raise VoError(f"{path}: no checksum recorded for it (rendered before checksums existed?)")
        with as_vo_error():  # a regular file only (a FIFO must not block the reader)
            got = hashlib.sha256(read_bytes(path, 16 << 30, "EXR file")).hexdigest()
        if got != want:
            raise VoError(f"{path}: differs from the file the renderer wrote (SHA-256 mismatch); "
                          "run `sesgen verify` on the folder and re-render with --resume")

    def _pass(self, k, view, names, comps, what, key=None):
        ch = self._channels(k, view)
        found = None
        named = self.info.channels.get(key) if key else None
        if named:  # the manifest names the channels: use them exactly
            named = [named] if isinstance(named, str) else list(named)[:len(comps)]
            found = named if all(n in ch for n in named) else None
        if found is None:
            found = find_pass(ch, names, comps)
        if found is None:
            have = sorted(n for n in ch if n != "__path__")
            raise VoError(f"{ch['__path__']}: missing {what} pass "
                          f"(expected {VIEW_LAYER}.{names[0]}.{'/'.join(comps)}; channels: {', '.join(have)})")
        return [ch[n] for n in found]

    # --- images and ground truth ------------------------------------------------------
    def rgb_linear(self, k: int, view: str = "left") -> np.ndarray:
        """float32 (H, W, 3) scene-linear RGB (the Combined pass as written)."""
        r, g, b = self._pass(k, view, PASS_COMBINED, ("R", "G", "B"), "Combined (RGB)", "rgb")
        return np.stack([r, g, b], axis=-1).astype(np.float32)

    def alpha(self, k: int, view: str = "left") -> np.ndarray | None:
        found = find_pass(self._channels(k, view), PASS_COMBINED, ("A",))
        return None if found is None else self._channels(k, view)[found[0]].astype(np.float32)

    def display_path(self, k: int, view: str = "left") -> Path | None:
        """The display-referred 8-bit PNG of frame k (manifest ``display.files``), or None
        when the render has none (``gt`` renders, the sensor path, renders made before it
        existed). A PNG the manifest lists but the folder lacks is an error: no other image
        stands in for it."""
        check_frame_view(self, k, view)
        files = ((self.manifest.get("display") or {}).get("files") or {}).get(view)
        if not files:
            return None
        self._require_rendered(k)
        path = self.root / files[int(k)]
        if not path.is_file():
            raise VoError(f"{path}: missing (the manifest lists it as frame {k}'s {view} image); "
                          "run `python -m blender_sesgen verify` on the folder and render again with --resume")
        return path

    def image_rgb(self, k: int, view: str = "left") -> np.ndarray:
        """uint8 (H, W, 3): the camera's image — the sensor's demosaiced RGB where the render
        has a SENSOR (noise, CFA, response curve); else the display-referred image Blender
        wrote through the view transform (manifest ``display``); else (older renders) the
        EXR beauty sRGB-encoded (IEC 61966-2-1 transfer function, clipped)."""
        import cv2
        rel = self.sensor_file("rgb", k, view)
        if rel is not None:
            self._require_rendered(k)
            return cv2.cvtColor(read_image(self.root / rel, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
        path = self.display_path(k, view)
        if path is None:
            return linear_to_srgb8(self.rgb_linear(k, view))
        img = read_image(path, cv2.IMREAD_COLOR)
        W, H = self.resolution
        if img.shape[:2] != (H, W):
            raise VoError(f"{path}: image is {img.shape[1]}x{img.shape[0]}, manifest says {W}x{H}")
        return np.ascontiguousarray(img[..., ::-1])

    # --- the camera and IMU as sensors (docs/output-format.md) -----------------------------
    def sensor_file(self, kind: str, k: int, view: str = "left"):
        """Relative path of a sensor image (kind raw | rgb | jpeg) or None when not rendered."""
        sensor = self.info.sections.sensor
        if sensor is None or not sensor.files.get(kind):
            return None
        check_frame_view(self, k, view)
        return sensor.file(kind, view, k)

    def raw_dn(self, k: int, view: str = "left") -> np.ndarray | None:
        """uint16 raw sensor values (CFA mosaic or RGB), 0 .. 2^bits - 1; None without a SENSOR."""
        rel = self.sensor_file("raw", k, view)
        if rel is None:
            return None
        self._require_rendered(k)
        from .files import read_image
        return read_image(self.root / rel)

    @property
    def lens(self):
        """The lens (``blender_sesgen.contract.lens.Lens``) of a distorted render, else None."""
        section = self.info.sections.lens
        return None if section is None else section.lens(self.K)

    def undistortion_maps(self):
        """(map_x, map_y) of the render's lookup table (pinhole K <- distorted image), or None."""
        section = self.info.sections.lens
        if section is None or not section.undistort_lut:
            return None
        from ..camera.undistort import read_lut
        return read_lut(self.root / section.undistort_lut, *self.resolution)

    @property
    def rate_hz(self) -> float:
        """Frames per second (the manifest's ``fps``)."""
        return self.info.fps if np.isfinite(self.info.fps) else super().rate_hz

    def rig_motion(self):
        """The rig's continuous motion (``blender_sesgen.contract.rig_motion.RigMotion``)."""
        from blender_sesgen.contract.rig_motion import RigMotion
        rm = self.info.sections.rig_motion or RigMotionSection(
            "c2_spline", self.info.fps if np.isfinite(self.info.fps) else DEFAULT_FPS,
            float(self.timestamps_s[0]) if len(self.timestamps_s) else 0.0)
        return RigMotion(self._poses["left"], rm.rate_hz, rm.start_s, rm.interpolation)

    def T_world_cam_at(self, t_s, view: str = "left") -> np.ndarray:
        """(n, 4, 4) camera poses at any times (seconds; the rig's motion between frames)."""
        if view not in self.views:
            raise VoError(f"view {view!r} not in this sequence (views: {', '.join(self.views)})")
        return rig.T_world_view(self.rig_motion().T_world_cam(np.atleast_1d(t_s)), view, self.baseline_m)

    @property
    def readout_s(self) -> float:
        timing = self.info.sections.timing
        return 0.0 if timing is None else timing.readout_s

    def row_times_s(self, k: int) -> np.ndarray:
        """(H,) capture time of every image row of frame k (all equal for a global shutter)."""
        from blender_sesgen.contract.timing import row_offsets_s
        return self.timestamps_s[int(k)] + row_offsets_s(self.resolution[1], self.readout_s)

    def T_world_cam_rows(self, k: int, view: str = "left") -> np.ndarray:
        """(H, 4, 4) pose of every image row of frame k (a rolling shutter's per-row poses)."""
        check_frame_view(self, k, view)
        return self.T_world_cam_at(self.row_times_s(k), view)

    def T_world_cam_row(self, k: int, row: float, view: str = "left") -> np.ndarray:
        """(4, 4) pose of (fractional) image row ``row`` of frame k."""
        from blender_sesgen.contract.timing import row_time_s
        return self.T_world_cam_at(row_time_s(self.timestamps_s[int(k)], row, self.resolution[1], self.readout_s),
                                   view)[0]

    def imu_calibration(self):
        """The IMU's calibration and files (``contract.manifest_sections.ImuSection``), or None."""
        return self.info.sections.imu

    def imu(self, kind: str = "noisy") -> dict | None:
        """The IMU stream (kind noisy | ideal) as {t_s, gyro (n,3) rad/s, accel (n,3) m/s^2}, or
        None without an IMU; ``imu_groundtruth()`` gives the body states."""
        entry = self.info.sections.imu
        if entry is None:
            return None
        if kind not in ("noisy", "ideal"):
            raise VoError(f"IMU stream {kind!r} not in this render (noisy, ideal)")
        a = _read_csv(self.root / entry.files[kind])
        return {"t_s": a[:, 0] * 1e-9, "gyro": a[:, 1:4], "accel": a[:, 4:7]}

    def imu_groundtruth(self) -> dict | None:
        """EuRoC-style body (IMU) states at the IMU's instants: t_s, p, q_wxyz, v, gyro/accel bias."""
        entry = self.info.sections.imu
        if entry is None:
            return None
        a = _read_csv(self.root / entry.files["groundtruth"])
        return {"t_s": a[:, 0] * 1e-9, "p": a[:, 1:4], "q_wxyz": a[:, 4:8], "v": a[:, 8:11],
                "gyro_bias": a[:, 11:14], "accel_bias": a[:, 14:17]}

    def image_gray(self, k: int, view: str = "left") -> np.ndarray:
        return rgb8_to_gray8(self.image_rgb(k, view))

    def depth(self, k: int, view: str = "left") -> np.ndarray:
        """float32 (H, W) planar z in metres, +inf where nothing was hit."""
        (z,) = self._pass(k, view, PASS_DEPTH, ("Z",), PASS_DEPTH[0], "depth")
        return depth_from_pass(z, self.depth_background)

    def ids(self, k: int, view: str = "left") -> np.ndarray:
        """int32 (H, W) object ids (the script's ``id``), 0 = background."""
        (x,) = self._pass(k, view, PASS_INDEX, ("X",), PASS_INDEX[0], "object_index")
        return np.rint(np.nan_to_num(x, nan=0.0)).astype(np.int32)

    def T_world_cam(self, view: str = "left") -> np.ndarray:
        if view not in self.views:
            raise VoError(f"view {view!r} not in this sequence (views: {', '.join(self.views)})")
        return self._poses[view].copy()

    @property
    def moving_ids(self) -> tuple[int, ...]:
        """Ids of the objects that move (manifest ``objects[i].moving``); () for a static scene
        or a render written before moving objects existed."""
        return tuple(sorted(self._object_poses))

    def T_world_obj(self, obj_id: int) -> np.ndarray | None:
        """(N, 4, 4) per-frame pose of a moving object's frame in the world (manifest
        ``objects[i].T_world_obj``), or None for an object that does not move."""
        T = self._object_poses.get(int(obj_id))
        return None if T is None else T.copy()

    def __repr__(self) -> str:
        W, H = self.resolution
        return f"RenderSequence({str(self.root)!r}, {self.num_frames} frames, {W}x{H}, views={self.views})"


def _read_csv(path) -> np.ndarray:
    """A numeric CSV with '#' header lines (EuRoC style), first column integer ns kept exact."""
    from pathlib import Path as _P
    p = _P(path)
    if not p.exists():
        raise VoError(f"{p}: no such file")
    with as_vo_error():
        text = read_text(p, what="CSV file", strict=False)
    rows = [ln.split(",") for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    try:
        return np.array([[int(r[0])] + [float(v) for v in r[1:]] for r in rows], dtype=np.float64).reshape(len(rows), -1)
    except (ValueError, IndexError):
        raise VoError(f"{p}: not a numeric CSV") from None
