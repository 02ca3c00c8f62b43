"""A folder of images with timestamps (RobotCar style) as a mono :class:`Sequence`.

Layout::

    DIR/<name>.png ...        the frames, sorted by name (png, jpg, pgm, tif, ...)
    DIR/stereo.timestamps     optional, RobotCar: '<microseconds> <chunk>' per line; an
                              image named '<microseconds>.png' takes that time. Any
                              '*.timestamps' file is read the same way.
    DIR/times.txt             optional, KITTI style: seconds, one line per image
    DIR/poses.txt             optional ground truth: KITTI 3x4 poses, one line per image
    DIR/model.txt             optional RobotCar camera model (fx fy cx cy + G_camera_image)

Without timestamps the frames are 0, 1, 2, ... s; with numeric names of 16 digits
(RobotCar's microseconds) the names are the times. ``raw(k)`` returns the file as stored
(a Bayer mosaic stays a 2-D mosaic); ``image_rgb`` demosaics it when a ``bayer`` pattern is
given. K comes from ``model`` (a RobotCar model file) or ``K``; without either, ``K`` is
None and a caller that needs it must say so.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract.inputs import read_text

from ..errors import VoError, as_vo_error
from .files import read_image
from .base import Sequence, check_frame_view
from .trajectory import read_kitti, read_times

IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff")


def read_robotcar_timestamps(path) -> dict[int, float]:
    """'<microseconds> <chunk>' lines -> {microseconds: seconds}."""
    out = {}
    with as_vo_error():
        text = read_text(path, what="timestamps file", strict=False)
    for lineno, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts:
            continue
        if not parts[0].isdigit():
            raise VoError(f"{path}:{lineno}: expected '<microseconds> <chunk>', got {line[:60]!r}")
        out[int(parts[0])] = int(parts[0]) * 1e-6
    return out


class ImageFolderSequence(Sequence):
    """Monocular image sequence from a folder; see the module docstring."""

    views = ("left",)
    baseline_m = 0.0

    def __init__(self, root, bayer: str | None = None, model=None, K: np.ndarray | None = None):
        self.root = root = Path(root)
        if not root.is_dir():
            raise VoError(f"{root}: no such folder")
        self._files = sorted(p for p in root.iterdir() if p.suffix.lower() in IMAGE_EXTS)
        if not self._files:
            raise VoError(f"{root}: no images ({', '.join(IMAGE_EXTS)})")
        self.num_frames = len(self._files)
        self.bayer = None
        if bayer:
            from ..camera.bayer import check_pattern
            self.bayer = check_pattern(bayer)
        first = read_image(self._files[0])
        self.resolution = (int(first.shape[1]), int(first.shape[0]))
        self.timestamps_s = self._timestamps()
        if model is None and (root / "model.txt").is_file():
            model = root / "model.txt"
        self.model = None
        if model is not None:
            from ..camera.camera_model import read_camera_model
            self.model = read_camera_model(model)
            K = self.model.K if K is None else K
        self.K = None if K is None else np.asarray(K, dtype=float)
        self._poses = None
        if (root / "poses.txt").is_file():
            traj = read_kitti(root / "poses.txt")
            if len(traj) != self.num_frames:
                raise VoError(f"{root / 'poses.txt'}: {len(traj)} poses for {self.num_frames} images")
            self._poses = traj.T_world_cam

    def _timestamps(self) -> np.ndarray:
        stems = [p.stem for p in self._files]
        ts_files = sorted(self.root.glob("*.timestamps"))
        if ts_files:
            table = read_robotcar_timestamps(ts_files[0])
            missing = [s for s in stems if not s.isdigit() or int(s) not in table]
            if missing:
                raise VoError(f"{ts_files[0]}: no timestamp for image {missing[0]} ({len(missing)} missing)")
            return np.array([table[int(s)] for s in stems])
        if (self.root / "times.txt").exists():
            t = read_times(self.root / "times.txt")
            if len(t) != self.num_frames:
                raise VoError(f"{self.root / 'times.txt'}: {len(t)} times for {self.num_frames} images")
            return t
        if all(s.isdigit() and len(s) == 16 for s in stems):
            return np.array([int(s) * 1e-6 for s in stems])
        return np.arange(self.num_frames, dtype=float)

    def image_path(self, k: int, view: str = "left") -> Path:
        check_frame_view(self, k, view)
        return self._files[int(k)]

    def raw(self, k: int, view: str = "left") -> np.ndarray:
        """The image as stored (uint8; a Bayer mosaic stays 2-D; colour in RGB order)."""
        import cv2
        img = read_image(self.image_path(k, view))
        if img.dtype != np.uint8:
            raise VoError(f"{self.image_path(k, view)}: expected an 8-bit image, got {img.dtype}")
        if (img.shape[1], img.shape[0]) != self.resolution:
            raise VoError(f"{self.image_path(k, view)}: size {img.shape[1]}x{img.shape[0]} differs from the first image")
        if img.ndim == 3:
            img = cv2.cvtColor(img[:, :, :3], cv2.COLOR_BGR2RGB)
        return img

    def image_rgb(self, k: int, view: str = "left") -> np.ndarray:
        img = self.raw(k, view)
        if self.bayer:
            from ..camera.bayer import demosaic
            return demosaic(img, self.bayer)
        return np.repeat(img[:, :, None], 3, axis=2) if img.ndim == 2 else img

    def image_gray(self, k: int, view: str = "left") -> np.ndarray:
        from .color import rgb8_to_gray8
        img = self.raw(k, view)
        if img.ndim == 2 and not self.bayer:
            return img
        return rgb8_to_gray8(self.image_rgb(k, view))

    def T_world_cam(self, view: str = "left") -> np.ndarray | None:
        if view not in self.views:
            raise VoError(f"view {view!r} not in this sequence (views: left)")
        return None if self._poses is None else self._poses.copy()

    def __repr__(self) -> str:
        W, H = self.resolution
        return f"ImageFolderSequence({str(self.root)!r}, {self.num_frames} frames, {W}x{H}, bayer={self.bayer})"
