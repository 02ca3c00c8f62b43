"""Reader of KITTI odometry sequence folders as a :class:`Sequence`.

Layout (any one image folder pair; the first present wins)::

    image_0/ image_1/   grey left/right (cameras P0, P1)       NNNNNN.png
    image_2/ image_3/   colour left/right (cameras P2, P3)
    image_l/ image_r/   grey left/right, calibration lines P0, P1
    calib.txt           'P0: 12 numbers' lines, or bare lines in the order P0, P1, P2, P3
    poses.txt           optional; KITTI 3x4 poses of the left (cam0) camera, row-major; else the
                        development kit's layout: dataset/poses/NN.txt for dataset/sequences/NN/
    times.txt           optional; seconds per frame (default 0.1 s steps, KITTI's 10 Hz)

K comes from the left camera's projection matrix; the baseline from the pair:
B = (P_left[0,3] - P_right[0,3]) / fx (for P0/P1: -P1[0,3]/P1[0,0]).
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from blender_sesgen.contract import rig
from blender_sesgen.contract.camera import K_problem
from blender_sesgen.contract.inputs import read_text
from blender_sesgen.contract.manifest import LIMIT

from ..errors import VoError, as_vo_error
from .color import rgb8_to_gray8
from .files import read_image
from .base import Sequence, check_frame_view
from .trajectory import read_kitti, read_times

__all__ = ["KittiSequence", "read_kitti_calib", "looks_like_kitti", "poses_file"]

# (left folder, right folder, left P, right P)
FOLDER_PAIRS = (
    ("image_0", "image_1", "P0", "P1"),
    ("image_2", "image_3", "P2", "P3"),
    ("image_l", "image_r", "P0", "P1"),
)
IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff")


def looks_like_kitti(root) -> bool:
    root = Path(root)
    return (root / "calib.txt").is_file() and any((root / l).is_dir() for l, _, _, _ in FOLDER_PAIRS)


def read_kitti_calib(path) -> dict[str, np.ndarray]:
    """``calib.txt`` -> {'P0': (3, 4), 'P1': ..., 'Tr': ...}. Lines are ``NAME: 12 numbers``
    or bare 12-number lines, named P0, P1, P2, P3, Tr in order; a name given twice is an
    error (which one is meant cannot be known). Every number must be finite
    (an error names its line) and each ``Pn`` a rectified projection matrix K [I | t] whose
    K is a camera matrix (``contract.camera.K_problem``)."""
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such calibration file")
    with as_vo_error():
        text = read_text(path, what="calibration file", strict=False)
    out: dict[str, np.ndarray] = {}
    first_line: dict[str, int] = {}
    bare_names = iter(("P0", "P1", "P2", "P3", "Tr"))
    for lineno, line in enumerate(re.split(r"\r\n|\r|\n", text), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if ":" in s:
            name, rest = s.split(":", 1)
            name = name.strip()
        else:
            name, rest = next(bare_names, f"line{lineno}"), s
        try:
            vals = [float(x) for x in rest.split()]
        except ValueError:
            raise VoError(f"{path}:{lineno}: expected numbers, got {s[:60]!r}") from None
        if len(vals) == 12:
            if not all(math.isfinite(v) and abs(v) < LIMIT for v in vals):
                raise VoError(f"{path}:{lineno}: {name}: numbers must be finite (and below {LIMIT:g})")
            P = np.array(vals).reshape(3, 4)
            if name.startswith("P") and K_problem(P[:, :3], LIMIT):
                raise VoError(f"{path}:{lineno}: {name} is not a camera projection matrix K [I | t] "
                              f"({K_problem(P[:, :3], LIMIT)})")
            if name in first_line:
                raise VoError(f"{path}:{lineno}: {name} is given twice (first on line {first_line[name]}); "
                              "keep the one that is meant")
            out[name], first_line[name] = P, lineno
        elif ":" not in s:
            raise VoError(f"{path}:{lineno}: expected 12 numbers, got {len(vals)}")
    if "P0" not in out and "P2" not in out:
        raise VoError(f"{path}: no P0 (or P2) projection matrix")
    return out


def _list_images(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_EXTS and not p.name.startswith("."))


def poses_file(root: Path) -> Path | None:
    """``root/poses.txt``, else the odometry kit's ``dataset/poses/NN.txt`` for ``dataset/sequences/NN``."""
    if (root / "poses.txt").is_file():
        return root / "poses.txt"
    seq = root.resolve()
    kit = seq.parent.parent / "poses" / f"{seq.name}.txt"
    return kit if seq.parent.name == "sequences" and kit.is_file() else None


class KittiSequence(Sequence):
    """A KITTI odometry folder (real data; no depth or ids ground truth)."""

    def __init__(self, root):
        self.root = root = Path(root)
        if not root.is_dir():
            raise VoError(f"{root}: no such folder")
        pair = next(((l, r, pl, pr) for l, r, pl, pr in FOLDER_PAIRS if (root / l).is_dir()), None)
        if pair is None:
            raise VoError(f"{root}: no image folder (image_0/image_1, image_2/image_3 or image_l/image_r)")
        left_dir, right_dir, p_left, p_right = pair
        self.calib = calib = read_kitti_calib(root / "calib.txt")
        if p_left not in calib:
            raise VoError(f"{root / 'calib.txt'}: no {p_left} for the images in {left_dir}/")
        P_l = calib[p_left]
        self.K = P_l[:, :3].copy()
        fx = float(self.K[0, 0])
        self._folders = {"left": root / left_dir}
        self._files = {"left": _list_images(root / left_dir)}
        if not self._files["left"]:
            raise VoError(f"{root / left_dir}: no images")
        self.num_frames = len(self._files["left"])
        # offset of the left camera from cam0 (P = K [I | t]): nonzero for P2/P3
        self._t_left = np.linalg.solve(self.K, P_l[:, 3])
        if (root / right_dir).is_dir() and p_right in calib:
            self._folders["right"] = root / right_dir
            self._files["right"] = _list_images(root / right_dir)
            if len(self._files["right"]) != self.num_frames:
                raise VoError(f"{root}: {self.num_frames} left images but {len(self._files['right'])} right images")
            self.baseline_m = float((P_l[0, 3] - calib[p_right][0, 3]) / fx)
            self.views = ("left", "right")
        else:
            self.baseline_m = 0.0
            self.views = ("left",)
        first = read_image(self._files["left"][0])
        self.resolution = (int(first.shape[1]), int(first.shape[0]))
        self._colour = first.ndim == 3
        self._poses = None
        self.poses_path = poses_file(root)
        if self.poses_path is not None:
            traj = read_kitti(self.poses_path)
            if len(traj) != self.num_frames:
                raise VoError(f"{self.poses_path}: {len(traj)} poses for {self.num_frames} frames")
            # poses.txt holds cam0 poses; the left camera of this pair sits at -t_left in cam0
            T_cam0_left = np.eye(4)
            T_cam0_left[:3, 3] = -self._t_left
            self._poses = traj.T_world_cam @ T_cam0_left
        if (root / "times.txt").exists():
            t = read_times(root / "times.txt")
            if len(t) != self.num_frames:
                raise VoError(f"{root / 'times.txt'}: {len(t)} times for {self.num_frames} frames")
            self.timestamps_s = t
        else:
            self.timestamps_s = np.arange(self.num_frames, dtype=float) * 0.1

    def image_path(self, k: int, view: str = "left") -> Path:
        check_frame_view(self, k, view)
        return self._files[view][int(k)]

    def _read(self, k, view):
        img = read_image(self.image_path(k, view))
        if img.dtype != np.uint8:
            raise VoError(f"{self.image_path(k, view)}: expected an 8-bit image, got {img.dtype}")
        if (img.shape[1], img.shape[0]) != self.resolution:
            raise VoError(f"{self.image_path(k, view)}: size {img.shape[1]}x{img.shape[0]} differs from "
                          f"{self.resolution[0]}x{self.resolution[1]}")
        return img

    def image_rgb(self, k: int, view: str = "left") -> np.ndarray:
        import cv2
        img = self._read(k, view)
        if img.ndim == 2:
            return np.repeat(img[:, :, None], 3, axis=2)
        return cv2.cvtColor(img[:, :, :3], cv2.COLOR_BGR2RGB)

    def image_gray(self, k: int, view: str = "left") -> np.ndarray:
        img = self._read(k, view)
        if img.ndim == 2:
            return img
        return rgb8_to_gray8(self.image_rgb(k, view))

    def T_world_cam(self, view: str = "left") -> np.ndarray | None:
        if view not in self.views:
            raise VoError(f"view {view!r} not in this sequence (views: {', '.join(self.views)})")
        if self._poses is None:
            return None
        return rig.T_world_view(self._poses, view, self.baseline_m)

    def __repr__(self) -> str:
        W, H = self.resolution
        return f"KittiSequence({str(self.root)!r}, {self.num_frames} frames, {W}x{H}, views={self.views})"
