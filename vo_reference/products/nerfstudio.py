"""Export target ``nerfstudio``: a render as a nerfstudio dataset (``ns-train ... --data OUT``;
the ``transforms.json`` convention that NeRF and 3D Gaussian Splatting code shares)::

    OUT/transforms.json            intrinsics, lens, and per image: file_path, transform_matrix,
                                   depth_file_path, mask_path; ply_file_path
    OUT/images/left_000000.png     8-bit RGB (the export's noise applies); right_000000.png likewise
    OUT/depths/left_000000.png     uint16 planar depth in millimetres, 0 = none (sky, or beyond 65.535 m)
    OUT/masks/left_000000.png      8-bit: 255 = train on the pixel, 0 = ignore it (moving objects)
    OUT/sparse_pc.ply              points from the exact depth (as the colmap export's), binary PLY

Conventions, as nerfstudio's ``nerfstudio_dataparser`` and ``Cameras`` read them:

- ``transform_matrix``: camera-to-world in the OpenGL camera axes (x right, y up, z back),
  i.e. ``T_world_cam @ diag(1, -1, -1, 1)``; world = the SES world (Y up), metres.
- Pixels: the top-left pixel's centre is (0.5, 0.5) (nerfstudio casts rays through
  ``pixel + 0.5``), so ``cx``/``cy`` are the OpenCV ones + 0.5.
- Lens: ``camera_model`` ``PINHOLE``; a Brown-Conrady lens is ``OPENCV`` with k1, k2, k3,
  p1, p2; a Kannala-Brandt one ``OPENCV_FISHEYE`` with k1..k4.
- Depth: planar z along the optical axis (nerfstudio's default, ``is_euclidean_depth``
  False), in millimetres: nerfstudio's default ``depth_unit_scale_factor`` 1e-3 turns it
  into metres. ``--opt depth=npy`` writes float32 metres (``.npy``, exact) instead; then
  train with ``--pipeline.datamanager.dataparser.depth-unit-scale-factor 1``. The factor the
  files need is also in transforms.json (``depth_unit_scale_factor``, informative).
- Masks: NeRFs assume a static scene, so pixels of moving objects are masked out (0).
- ``sparse_pc.ply`` seeds splatfacto (``--pipeline.model.load-3D-points`` reads it through
  ``ply_file_path``); ``--opt stride=PX`` sets its density as for the colmap export.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic

from ..errors import VoError
from ..io.files import write_image_atomic, write_png16, write_png_rgb
from .exports import ExportOptions, image_rgb, progress_bar
from .sparse_points import pop_stride, sparse_points

__all__ = ["export_nerfstudio", "opengl_camera_to_world", "nerfstudio_intrinsics", "ply_points_bytes",
           "MM_PER_M"]

OPENGL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])
MM_PER_M = 1000.0


def opengl_camera_to_world(T_world_cam: np.ndarray) -> np.ndarray:
    """nerfstudio's ``transform_matrix`` of an OpenCV ``T_world_cam`` (4x4)."""
    return np.asarray(T_world_cam, dtype=float) @ OPENGL_FROM_CV


def nerfstudio_intrinsics(seq) -> dict:
    """camera_model, fl_x, fl_y, cx, cy, w, h and the lens's coefficients (pixel + 0.5)."""
    K = np.asarray(seq.K, dtype=float)
    W, H = seq.resolution
    out = {"camera_model": "PINHOLE", "fl_x": K[0, 0], "fl_y": K[1, 1], "cx": K[0, 2] + 0.5, "cy": K[1, 2] + 0.5,
           "w": int(W), "h": int(H)}
    lens = seq.lens
    if lens is not None and not lens.is_pinhole:
        if lens.model == "kannala_brandt":
            out["camera_model"] = "OPENCV_FISHEYE"
            out.update(zip(("k1", "k2", "k3", "k4"), lens.coeffs))
        else:
            k1, k2, p1, p2, k3 = lens.coeffs
            out.update(camera_model="OPENCV", k1=k1, k2=k2, k3=k3, p1=p1, p2=p2)
    return {k: (float(v) + 0.0 if isinstance(v, float) else v) for k, v in out.items()}


def ply_points_bytes(xyz: np.ndarray, rgb: np.ndarray) -> bytes:
    """A binary little-endian PLY of points (float x y z, uchar red green blue)."""
    xyz = np.asarray(xyz, dtype="<f4").reshape(-1, 3)
    rgb = np.asarray(rgb, dtype=np.uint8).reshape(-1, 3)
    rec = np.zeros(len(xyz), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"),
                                     ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    for i, c in enumerate("xyz"):
        rec[c] = xyz[:, i]
    for i, c in enumerate(("red", "green", "blue")):
        rec[c] = rgb[:, i]
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(rec)}\n"
              "property float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n")
    return header.encode("ascii") + rec.tobytes()


def _options(opts: ExportOptions) -> tuple[str, int | None]:
    extra = dict(opts.extra)
    depth = extra.pop("depth", "png")
    stride = pop_stride(extra)
    if extra:
        raise VoError(f"nerfstudio export: unknown option(s) {', '.join(sorted(extra))} (depth, stride)")
    if depth not in ("png", "npy"):
        raise VoError(f"depth={depth!r}: expected png (16-bit millimetres) or npy (float32 metres)")
    return depth, stride


def _depth_file(path: Path, z: np.ndarray, kind: str) -> None:
    z = np.asarray(z, dtype=np.float64)
    finite = np.isfinite(z) & (z > 0)
    if kind == "npy":
        import io
        buf = io.BytesIO()
        np.save(buf, np.where(finite, z, 0.0).astype(np.float32))
        atomic.write_bytes(path, buf.getvalue())
        return
    mm = np.where(finite, np.rint(z * MM_PER_M), 0.0)
    write_png16(path, np.where(mm <= 65535, mm, 0).astype(np.uint16))


def export_nerfstudio(seq, out: Path, opts: ExportOptions) -> None:
    depth_kind, stride = _options(opts)
    views = [v for v in ("left", "right") if v in seq.views]
    frames = list(opts.frames)
    moving = tuple(seq.moving_ids)
    meta = nerfstudio_intrinsics(seq)
    meta["depth_unit_scale_factor"] = 1e-3 if depth_kind == "png" else 1.0
    meta["ply_file_path"] = "sparse_pc.ply"
    entries = []
    n_img = len(frames) * len(views)
    with progress_bar(opts, 3 * n_img, "nerfstudio") as bar:
        for i, k in enumerate(frames):
            for v in views:
                name = f"{v}_{i:06d}"
                write_png_rgb(out / "images" / f"{name}.png", image_rgb(seq, k, v, opts))
                _depth_file(out / "depths" / f"{name}.{depth_kind}", seq.depth(k, v), depth_kind)
                ids = seq.ids(k, v)
                write_image_atomic(out / "masks" / f"{name}.png",
                                   np.where(np.isin(ids, moving), 0, 255).astype(np.uint8))
                entries.append({"file_path": f"images/{name}.png",
                                "transform_matrix": (opengl_camera_to_world(seq.T_world_cam(v)[k]) + 0.0).tolist(),
                                "depth_file_path": f"depths/{name}.{depth_kind}",
                                "mask_path": f"masks/{name}.png"})
                bar.update()
        pts = sparse_points(seq, frames, views, stride, rgb_of=lambda k, v: image_rgb(seq, k, v, opts),
                            tick=bar.update)
    atomic.write_bytes(out / "sparse_pc.ply", ply_points_bytes(pts.xyz, pts.rgb))
    meta["frames"] = entries
    atomic.write_text(out / "transforms.json", json.dumps(meta, indent=2) + "\n")


export_nerfstudio.keeps_lens = True   # a distorted render is written as it is, with its lens (docs/output-format.md)
