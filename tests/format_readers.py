"""Readers of the dataset layouts written from each format's own documentation, not from our
writers (they import nothing of vo_reference): the oracles of the layout round-trip tests.

- PFM: the format's definition (Paul Debevec's page, as Middlebury and SceneFlow use it):
  a text header "PF" (3 channels) or "Pf" (1), "width height", a scale whose sign gives the
  byte order (negative = little-endian), then float32 rows from the bottom row up.
- TartanAir: tartanair_tools' README and data_type.md: np.load for depth, segmentation, flow
  and mask; pose files 'tx ty tz qx qy qz qw' per line in the NED frame; file names
  000000_left.png, 000000_left_depth.npy, 000000_left_seg.npy, 000000_000001_flow.npy.
- TartanAir V2: tartanairpy (its TartanAirIterator walks ROOT/ENV/Data_DIFF/TRAJ, sorts the
  files of each MODALITY_CAMERA folder and reads pose_CAMERA.txt with np.loadtxt; its
  TartanAirImageReader decodes depth as cv2.IMREAD_UNCHANGED bytes viewed as '<f4', flow PNG
  as (flow16 - 32768) / 64 with the mask in the third channel, flow npz as flow_fwd[0] CHW;
  its data cacher names files FRAME_lcam_front_depth.png, FRAME_NEXT_flow.png, ...).
- MPI-Sintel: its SDK's sintel_io (depth_read: float32 tag, int32 width, height, float32
  depth; cam_read: float32 tag, 9 float64 M, 12 float64 N).
- Virtual KITTI 2: the README of vkitti_2.0.3 (Naver Labs Europe): depth PNG uint16 in cm;
  flow PNG decoded as in its read_vkitti_png_flow snippet; text files with a header line
  and 'frame cameraID ...' rows; extrinsic = the 4x4 world-to-camera matrix.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np


def read_pfm(path) -> np.ndarray:
    """(H, W) or (H, W, 3) float32, row 0 = top of the image."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        dims = f.readline()
        while dims.strip().startswith(b"#"):
            dims = f.readline()
        w, h = (int(x) for x in dims.split())
        scale = float(f.readline().strip())
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4")
    channels = {b"PF": 3, b"Pf": 1}[kind]
    a = data[: w * h * channels].reshape(h, w, channels) if channels == 3 else data[: w * h].reshape(h, w)
    return np.flipud(a).astype(np.float32)


def quat_xyzw_to_matrix(q) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w), the textbook formula."""
    x, y, z, w = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def read_tartanair_poses(path) -> np.ndarray:
    """(N, 4, 4) camera-to-world poses from a TartanAir pose file."""
    rows = np.loadtxt(path, ndmin=2)
    assert rows.shape[1] == 7, rows.shape
    T = np.tile(np.eye(4), (len(rows), 1, 1))
    for i, r in enumerate(rows):
        T[i, :3, :3] = quat_xyzw_to_matrix(r[3:7])
        T[i, :3, 3] = r[:3]
    return T


def tartanair_files(root, kind: str) -> list[Path]:
    """Sorted files of one TartanAir folder: image_left, depth_left, seg_left, flow, mask, ..."""
    patterns = {"image_left": ("image_left", r"\d{6}_left\.png"), "image_right": ("image_right", r"\d{6}_right\.png"),
                "depth_left": ("depth_left", r"\d{6}_left_depth\.npy"),
                "depth_right": ("depth_right", r"\d{6}_right_depth\.npy"),
                "seg_left": ("seg_left", r"\d{6}_left_seg\.npy"), "seg_right": ("seg_right", r"\d{6}_right_seg\.npy"),
                "flow": ("flow", r"\d{6}_\d{6}_flow\.npy"), "mask": ("flow", r"\d{6}_\d{6}_mask\.npy")}
    folder, pat = patterns[kind]
    return sorted(p for p in (Path(root) / folder).iterdir() if re.fullmatch(pat, p.name))


def read_vkitti_png_flow(path) -> tuple[np.ndarray, np.ndarray]:
    """(flow (H, W, 2) float32, invalid (H, W) bool), as vKITTI 2's README decodes it."""
    import cv2
    bgr = cv2.imread(str(path), cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH)
    h, w, c = bgr.shape
    assert bgr.dtype == np.uint16 and c == 3
    invalid = bgr[..., 0] == 0                                  # b == 0: invalid flow
    out = 2.0 / (2 ** 16 - 1.0) * bgr[..., 2:0:-1].astype("f4") - 1   # g, r = flow_y, flow_x normalised
    out[..., 0] *= w - 1
    out[..., 1] *= h - 1
    return out, invalid


def read_vkitti_depth_m(path) -> np.ndarray:
    import cv2
    d = cv2.imread(str(path), cv2.IMREAD_ANYCOLOR | cv2.IMREAD_ANYDEPTH)
    assert d.dtype == np.uint16 and d.ndim == 2
    return d.astype(np.float64) / 100.0


def read_vkitti_table(path) -> tuple[list[str], np.ndarray]:
    """(header names, rows) of intrinsic.txt / extrinsic.txt / pose.txt."""
    lines = Path(path).read_text().splitlines()
    header = lines[0].split()
    rows = np.array([[float(x) for x in line.split()] for line in lines[1:] if line.strip()]).reshape(-1, len(header))
    return header, rows


def read_vkitti_colors(path) -> dict[tuple[int, int, int], str]:
    lines = Path(path).read_text().splitlines()
    assert lines[0].split() == ["Category", "r", "g", "b"]
    out = {}
    for line in lines[1:]:
        name, r, g, b = line.split()
        out[(int(r), int(g), int(b))] = name
    return out


def tartanair_v2_entries(root, camera_names=("lcam_front",), modalities=("image", "depth", "seg", "flow")) -> list:
    """tartanairpy's iterator walk: one entry per frame but the last, {camera: {modality: path}},
    over every ROOT/ENV/Data_*/TRAJ (files matched to frames by their sorted position)."""
    import os
    entries = []
    for env in sorted(os.listdir(root)):
        for diff in sorted(os.listdir(Path(root) / env)):
            if not diff.startswith("Data_") or not (Path(root) / env / diff).is_dir():
                continue
            for traj in sorted(os.listdir(Path(root) / env / diff)):
                tdir = Path(root) / env / diff / traj
                n = len(os.listdir(tdir / f"{modalities[0]}_{camera_names[0]}"))
                listing = {(c, m): sorted(os.listdir(tdir / f"{m}_{c}")) for c in camera_names for m in modalities}
                for i in range(n - 1):
                    entries.append({c: {m: tdir / f"{m}_{c}" / listing[(c, m)][i] for m in modalities}
                                    for c in camera_names})
    return entries


def read_tartanair_v2(path):
    """TartanAirImageReader: depth/seg/flow by modality and extension."""
    import cv2
    path = str(path)
    if "/depth_" in path:
        return np.squeeze(cv2.imread(path, cv2.IMREAD_UNCHANGED).view("<f4"), axis=-1)
    if "/seg_" in path:
        return cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if "/flow_" in path:
        if path.endswith(".npz"):
            with np.load(path) as data:
                return data["flow_fwd"][0].transpose(1, 2, 0), None
        flow16 = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        return (flow16[:, :, :2].astype(np.float32) - 32768) / 64.0, flow16[:, :, 2].astype(np.uint8)
    return cv2.cvtColor(cv2.imread(path), cv2.COLOR_BGR2RGB)


def read_sintel_dpt(path) -> np.ndarray:
    with open(path, "rb") as f:
        assert np.fromfile(f, np.float32, 1)[0] == 202021.25
        w, h = np.fromfile(f, np.int32, 2)
        return np.fromfile(f, np.float32, -1).reshape(h, w)


def read_sintel_cam(path) -> tuple[np.ndarray, np.ndarray]:
    with open(path, "rb") as f:
        assert np.fromfile(f, np.float32, 1)[0] == 202021.25
        M = np.fromfile(f, "float64", 9).reshape(3, 3)
        N = np.fromfile(f, "float64", 12).reshape(3, 4)
        return M, N
