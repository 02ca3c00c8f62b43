"""Export target ``colmap``: a render as a COLMAP reconstruction in the text format, the input
of COLMAP's own tools, pycolmap, 3D Gaussian Splatting and nerfstudio's ``colmap`` parser::

    OUT/images/left_000000.png      8-bit RGB (the export's noise applies); right_000000.png likewise
                                    (flat names: 3D Gaussian Splatting's loaders keep only the base name)
    OUT/sparse/0/cameras.txt        CAMERA_ID MODEL WIDTH HEIGHT PARAMS[] (1 = left, 2 = right)
    OUT/sparse/0/images.txt         IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, then X Y POINT3D_ID ...
    OUT/sparse/0/points3D.txt       POINT3D_ID X Y Z R G B ERROR TRACK[] (IMAGE_ID POINT2D_IDX ...)
    OUT/sparse/0/rigs.txt           the stereo rig (COLMAP >= 3.12; older versions ignore it)
    OUT/sparse/0/frames.txt         one rig frame per source frame (likewise)

Conventions (COLMAP's): the pose is cam_from_world (world -> camera, the OpenCV camera
axes, quaternion scalar first), world = the SES world (metres); pixel coordinates put the
*corner* of the image at (0, 0), so the centre of the top-left pixel is (0.5, 0.5): every
principal point and observation here is the OpenCV one + 0.5. Camera model: ``PINHOLE``,
or the render's lens in COLMAP's own models (``OPENCV`` k1 k2 p1 p2, ``FULL_OPENCV`` when
k3 != 0, ``OPENCV_FISHEYE`` k1..k4 for Kannala-Brandt). Points: from the exact depth,
one per grid cell of ``--opt stride=PX`` (default: about 2000 in the first image), each
observed in every image that sees it (:mod:`.sparse_points`); ERROR is 0 (exact).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.rig import T_left_right
from blender_sesgen.contract.se3 import R_to_quat_xyzw, invert

from ..errors import VoError
from ..io.files import write_png_rgb
from .driver import ExportOptions, image_rgb, progress_bar
from ..groundtruth.sparse_points import SparsePoints, pop_stride, sparse_points

__all__ = ["export_colmap", "colmap_camera", "cam_from_world", "write_colmap_text"]

CAMERA_ID = {"left": 1, "right": 2}


def _num(x) -> str:
    """A float as the shortest text that reads back to the same double (no '-0.0')."""
    return repr(float(x) + 0.0)


def colmap_camera(seq) -> tuple[str, list[float]]:
    """(model, params) of the render's camera in COLMAP's pixel convention (+0.5)."""
    K = np.asarray(seq.K, dtype=float)
    f_c = [K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5]
    lens = seq.lens
    if lens is None or lens.is_pinhole:
        return "PINHOLE", f_c
    if lens.model == "kannala_brandt":
        return "OPENCV_FISHEYE", f_c + list(lens.coeffs)
    k1, k2, p1, p2, k3 = lens.coeffs
    if k3:
        return "FULL_OPENCV", f_c + [k1, k2, p1, p2, k3, 0.0, 0.0, 0.0]
    return "OPENCV", f_c + [k1, k2, p1, p2]


def cam_from_world(T_world_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(q_wxyz (4,), t (3,)) of COLMAP's cam_from_world pose, qw >= 0."""
    T = invert(np.asarray(T_world_cam, dtype=float))
    x, y, z, w = R_to_quat_xyzw(T[:3, :3])
    q = np.array([w, x, y, z])
    return (-q if q[0] < 0 else q), T[:3, 3]


def write_colmap_text(folder: Path, seq, images: list[tuple[int, str]], names: list[str],
                      pts: SparsePoints | None = None, rig: bool = True) -> None:
    """cameras/images/points3D(/rigs/frames).txt in ``folder``: ``images`` (source frame,
    view), frame by frame with the same views each, named ``names`` (relative to the image
    folder); the points and their observations of ``pts`` (made for the same images), if
    given; ``rig``: also the stereo rig and its frames (COLMAP >= 3.12)."""
    views = list(dict.fromkeys(v for _, v in images))
    W, H = seq.resolution
    model, params = colmap_camera(seq)
    cams = "".join(f"{CAMERA_ID[v]} {model} {int(W)} {int(H)} {' '.join(_num(p) for p in params)}\n" for v in views)
    atomic.write_text(folder / "cameras.txt", "# Camera list with one line of data per camera:\n"
                      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                      f"# Number of cameras: {len(views)}\n" + cams)
    if pts is not None and tuple(pts.images) != tuple(images):
        raise VoError("the points were observed in other images than those of the model")
    n_pts = 0 if pts is None else len(pts.xyz)
    tracks: list[list[str]] = [[] for _ in range(n_pts)]
    lines = []
    n_obs = 0
    for i, ((k, view), name) in enumerate(zip(images, names)):
        q, t = cam_from_world(seq.T_world_cam(view)[k])
        lines.append(f"{i + 1} {' '.join(_num(x) for x in (*q, *t))} {CAMERA_ID[view]} {name}")
        obs = []
        if pts is not None:
            idx, uv = pts.observations[i]
            for j, (p, (u, v)) in enumerate(zip(idx, uv)):
                obs.append(f"{_num(u + 0.5)} {_num(v + 0.5)} {int(p) + 1}")
                tracks[int(p)].append(f"{i + 1} {j}")
            n_obs += len(idx)
        lines.append(" ".join(obs))
    mean_obs = n_obs / len(images) if images else 0.0
    atomic.write_text(folder / "images.txt", "# Image list with two lines of data per image:\n"
                      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
                      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
                      f"# Number of images: {len(images)}, mean observations per image: {mean_obs:.6g}\n"
                      + "\n".join(lines) + "\n")
    rows = []
    for p in range(n_pts):
        x, y, z = pts.xyz[p]
        r, g, b = (int(c) for c in pts.rgb[p])
        rows.append(f"{p + 1} {_num(x)} {_num(y)} {_num(z)} {r} {g} {b} 0 {' '.join(tracks[p])}".rstrip() + "\n")
    mean_track = n_obs / n_pts if n_pts else 0.0
    atomic.write_text(folder / "points3D.txt", "# 3D point list with one line of data per point:\n"
                      "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
                      f"# Number of points: {n_pts}, mean track length: {mean_track:.6g}\n" + "".join(rows))
    if not rig:
        return
    # the rig: camera 1 is the reference; camera 2's pose is cam2_from_cam1 (contract.rig)
    sensors = "CAMERA 1"
    if "right" in views:
        q, t = cam_from_world(T_left_right(seq.baseline_m))
        sensors += " CAMERA 2 1 " + " ".join(_num(x) for x in (*q, *t))
    atomic.write_text(folder / "rigs.txt", "# Rig calib list with one line of data per calib:\n"
                      "#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as (SENSOR_TYPE, "
                      "SENSOR_ID, HAS_POSE, [QW, QX, QY, QZ, TX, TY, TZ])\n"
                      f"# Number of rigs: 1\n1 {len(views)} {sensors}\n")
    frames = []
    for f, i0 in enumerate(range(0, len(images), len(views))):
        k = images[i0][0]
        q, t = cam_from_world(seq.T_world_cam("left")[k])
        data = " ".join(f"CAMERA {CAMERA_ID[v]} {i0 + j + 1}" for j, v in enumerate(views))
        frames.append(f"{f + 1} 1 {' '.join(_num(x) for x in (*q, *t))} {len(views)} {data}\n")
    atomic.write_text(folder / "frames.txt", "# Frame list with one line of data per frame:\n"
                      "#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], NUM_DATA_IDS, "
                      "DATA_IDS[] as (SENSOR_TYPE, SENSOR_ID, DATA_ID)\n"
                      f"# Number of frames: {len(frames)}\n" + "".join(frames))


def export_colmap(seq, out: Path, opts: ExportOptions) -> None:
    extra = dict(opts.extra)
    stride = pop_stride(extra)
    if extra:
        raise VoError(f"colmap export: unknown option(s) {', '.join(sorted(extra))} (stride)")
    views = [v for v in ("left", "right") if v in seq.views]
    frames = list(opts.frames)
    n_img = len(frames) * len(views)
    with progress_bar(opts, 3 * n_img, "colmap") as bar:
        images, names = [], []
        for i, k in enumerate(frames):
            for v in views:
                name = f"{v}_{i:06d}.png"
                write_png_rgb(out / "images" / name, image_rgb(seq, k, v, opts))
                images.append((k, v))
                names.append(name)
                bar.update()
        # the points' colours are those of the exported (noisy) images
        pts = sparse_points(seq, frames, views, stride, rgb_of=lambda k, v: image_rgb(seq, k, v, opts),
                            tick=bar.update)
        write_colmap_text(out / "sparse" / "0", seq, images, names, pts)


export_colmap.keeps_lens = True   # a distorted render is written as it is, with its lens (docs/output-format.md)
