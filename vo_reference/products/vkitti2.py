"""Export target ``vkitti2``: one Virtual KITTI 2 scene variation (``SceneXX/clone``) as the
dataset ships it (vkitti_2.0.3; layout and file formats from its README on the Naver Labs
Europe page, "Proxy Virtual Worlds -- Virtual KITTI 2")::

    OUT/frames/rgb/Camera_0/rgb_00000.jpg                   colour, left (Camera_1: right), JPEG quality 95,
                                                            4:4:4; --opt rgb=png for lossless PNG
    OUT/frames/depth/Camera_0/depth_00000.png               uint16, planar depth in centimetres
                                                            (65535 = 655.35 m or more, and nothing hit)
    OUT/frames/classSegmentation/Camera_0/classgt_00000.png 8-bit RGB, the class colours of colors.txt
    OUT/frames/instanceSegmentation/Camera_0/instancegt_00000.png   object id (trackID + 1; 0 = none),
                                                            8-bit grey, 16-bit when an id is > 255
    OUT/frames/forwardFlow/Camera_0/flow_00000.png          flow k -> k+1 (not for the last frame)
    OUT/frames/backwardFlow/Camera_0/backwardFlow_00001.png flow k -> k-1 (not for the first frame)
    OUT/intrinsic.txt   'frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]'
    OUT/extrinsic.txt   'frame cameraID r1,1 r1,2 r1,3 t1 r2,1 ... t3 0 0 0 1': world -> camera 4x4
    OUT/pose.txt        'frame cameraID trackID alpha width height length world_space_X world_space_Y
                        world_space_Z rotation_world_space_y rotation_world_space_x rotation_world_space_z
                        camera_space_X camera_space_Y camera_space_Z rotation_camera_space_y
                        rotation_camera_space_x rotation_camera_space_z'
    OUT/colors.txt      'Category r g b' (vKITTI 2's 15 categories)

Both text files hold one line per frame and camera (camera 0 then 1), after a header line.

Flow (vKITTI 2's 16-bit encoding): a 3-channel uint16 PNG whose R, G hold the flow normalised
by the image size, R = round((u/(W−1) + 1)·(2¹⁶−1)/2), G = round((v/(H−1) + 1)·(2¹⁶−1)/2),
and B the validity (2¹⁶−1 valid, 0 invalid: no surface -- vKITTI's sky -- or a flow beyond
±(W−1), ±(H−1) that the encoding cannot hold). Occluded and out-of-image points keep their
geometric flow, as in vKITTI 2. Decoding (its README): u = (2·R/(2¹⁶−1) − 1)·(W−1).

World frame: vKITTI 2's world has y down (as a KITTI camera); ours is the SES world (Y up),
so the exported world is the SES world turned 180 deg about x: ``F = diag(1, −1, −1)``,
``extrinsic = inv(F · T_world_cam)``.

Classes: the ``class`` of each object in the manifest (the script's ``class`` tag, Cityscapes
names) mapped onto vKITTI 2's categories (:data:`CATEGORY_OF_CLASS`; any other class is
``Misc``); an object without a class is ``Undefined`` (0, 0, 0); pixels that see nothing are
``Sky``. pose.txt lists the objects that carry a pose per frame in the manifest
(``objects[i].T_world_obj``: a 4x4 or one per frame; none in a static render, then only
the header): trackID = id − 1, position = the object's origin (vKITTI 2: the bottom centre
of its box), its axes turned with the world (F·T_world_obj·F; the camera-space pose is
extrinsic·F·T_world_obj·F), Euler angles with R = Ry·Rx·Rz (Unity's order, vKITTI's engine),
alpha = ry_cam − atan2(X_cam, Z_cam) wrapped to [−π, π], width/height/length from the
object's ``dim`` when the manifest has it, else 0.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from ..io.files import write_image_atomic
from .dense_gt import dense_flow
from .exports import ExportOptions, image_rgb, progress_bar, sequence_folder

__all__ = ["export_vkitti2", "CATEGORIES", "CATEGORY_OF_CLASS", "encode_flow", "depth_to_cm16", "class_image"]

# vKITTI 2's categories and colours (its colors.txt), in its order
CATEGORIES = {
    "Terrain": (210, 0, 200), "Sky": (90, 200, 255), "Tree": (0, 199, 0), "Vegetation": (90, 240, 0),
    "Building": (140, 140, 140), "Road": (100, 60, 100), "GuardRail": (250, 100, 255),
    "TrafficSign": (255, 255, 0), "TrafficLight": (200, 200, 0), "Pole": (255, 130, 0), "Misc": (80, 80, 80),
    "Truck": (160, 60, 60), "Car": (255, 127, 80), "Van": (0, 139, 139), "Undefined": (0, 0, 0),
}
# Cityscapes class names (lower case, '_'/'-' read as spaces) -> vKITTI 2 category
CATEGORY_OF_CLASS = {
    "road": "Road", "building": "Building", "pole": "Pole", "polegroup": "Pole",
    "traffic light": "TrafficLight", "traffic sign": "TrafficSign", "vegetation": "Vegetation",
    "tree": "Tree", "terrain": "Terrain", "sky": "Sky", "car": "Car", "truck": "Truck",
    "caravan": "Van", "van": "Van", "guard rail": "GuardRail",
}
F_VK_SES = np.diag([1.0, -1.0, -1.0, 1.0])   # vKITTI world (y down) from the SES world (Y up)
FLOW_MAX = 2 ** 16 - 1
JPEG_QUALITY = 95
POSE_HEADER = ("frame cameraID trackID alpha width height length world_space_X world_space_Y world_space_Z "
               "rotation_world_space_y rotation_world_space_x rotation_world_space_z camera_space_X "
               "camera_space_Y camera_space_Z rotation_camera_space_y rotation_camera_space_x "
               "rotation_camera_space_z")


def jpeg_params() -> list[int]:
    """OpenCV JPEG settings: quality 95, no chroma subsampling (4:4:4)."""
    import cv2
    return [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY, cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]


def category_of(obj: dict) -> str:
    name = obj.get("class")
    if not name:
        return "Undefined"
    key = " ".join(str(name).lower().replace("_", " ").replace("-", " ").split())
    return CATEGORY_OF_CLASS.get(key, "Misc")


def class_image(ids: np.ndarray, objects: list) -> np.ndarray:
    """uint8 (H, W, 3) RGB: each pixel's vKITTI 2 category colour (nothing hit = Sky)."""
    ids = np.asarray(ids)
    out = np.empty(ids.shape + (3,), np.uint8)
    out[...] = CATEGORIES["Undefined"]
    out[ids == 0] = CATEGORIES["Sky"]
    for obj in objects:
        oid = int(obj.get("id", 0))
        if oid != 0:
            out[ids == oid] = CATEGORIES[category_of(obj)]
    return out


def encode_flow(flow: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """uint16 (H, W, 3) R, G, B = normalised u, v, validity (module docstring)."""
    f = np.asarray(flow, dtype=np.float64)
    H, W = f.shape[:2]
    nu = f[..., 0] / max(W - 1, 1)
    nv = f[..., 1] / max(H - 1, 1)
    ok = np.asarray(valid, bool) & np.isfinite(nu) & np.isfinite(nv) & (np.abs(nu) <= 1) & (np.abs(nv) <= 1)
    out = np.zeros((H, W, 3), np.uint16)
    out[..., 0][ok] = np.rint((nu[ok] + 1.0) * FLOW_MAX / 2.0).astype(np.uint16)
    out[..., 1][ok] = np.rint((nv[ok] + 1.0) * FLOW_MAX / 2.0).astype(np.uint16)
    out[..., 2][ok] = FLOW_MAX
    return out


def depth_to_cm16(depth: np.ndarray) -> np.ndarray:
    """uint16 round(z·100); 65535 for z >= 655.35 m and for nothing hit (vKITTI 2's sky)."""
    z = np.asarray(depth, dtype=np.float64)
    cm = np.where(np.isfinite(z), np.rint(z * 100.0), FLOW_MAX)
    return np.clip(cm, 0, FLOW_MAX).astype(np.uint16)


def euler_yxz(R: np.ndarray) -> tuple[float, float, float]:
    """(ry, rx, rz) with R = Ry(ry)·Rx(rx)·Rz(rz)."""
    from scipy.spatial.transform import Rotation
    ry, rx, rz = Rotation.from_matrix(np.asarray(R, float)).as_euler("YXZ")
    return float(ry), float(rx), float(rz)


def _row(values) -> str:
    return " ".join(str(v) if isinstance(v, (int, np.integer)) else f"{v:.9g}" for v in values)


def object_poses(seq) -> list[tuple[dict, np.ndarray]]:
    """(object, (N, 4, 4) T_world_obj) for the objects with a pose in the manifest."""
    out = []
    for obj in seq.objects:
        if not isinstance(obj, dict) or obj.get("T_world_obj") is None:
            continue
        T = np.asarray(obj["T_world_obj"], dtype=float)
        if T.shape == (4, 4):
            T = np.broadcast_to(T, (seq.num_frames, 4, 4))
        if T.shape != (seq.num_frames, 4, 4):
            raise VoError(f"object {obj.get('id')}: T_world_obj has shape {T.shape}, expected (4, 4) "
                          f"or ({seq.num_frames}, 4, 4)")
        out.append((obj, T))
    return out


def pose_rows(seq, frames: list[int], cams: list[tuple[int, str]]) -> list[str]:
    rows = [POSE_HEADER]
    objs = object_poses(seq)
    for i, k in enumerate(frames):
        for c, view in cams:
            T_cam_world = invert(seq.T_world_cam(view)[k])
            for obj, T in objs:
                T_w = F_VK_SES @ T[k] @ F_VK_SES          # object axes turned like the world
                T_c = T_cam_world @ T[k] @ F_VK_SES
                ryw, rxw, rzw = euler_yxz(T_w[:3, :3])
                ryc, rxc, rzc = euler_yxz(T_c[:3, :3])
                x, y, z = T_c[:3, 3]
                alpha = (ryc - np.arctan2(x, z) + np.pi) % (2 * np.pi) - np.pi
                dim = list(obj.get("dim") or (0.0, 0.0, 0.0))[:3]
                width, height, length = (float(d) for d in dim + [0.0] * (3 - len(dim)))
                rows.append(_row([i, c, int(obj["id"]) - 1, alpha, width, height, length, *T_w[:3, 3],
                                  ryw, rxw, rzw, x, y, z, ryc, rxc, rzc]))
    return rows


def _rgb_format(opts: ExportOptions) -> str:
    extra = dict(opts.extra)
    fmt = str(extra.pop("rgb", "jpg")).lower()
    if extra:
        raise VoError(f"vkitti2 export: unknown option(s) {', '.join(sorted(extra))} (rgb)")
    if fmt not in ("jpg", "png"):
        raise VoError(f"rgb={fmt!r}: expected jpg (vKITTI 2's own) or png (lossless)")
    return fmt


def export_vkitti2(seq, out: Path, opts: ExportOptions) -> Path:
    fmt = _rgb_format(opts)
    cams = [(0, "left")] + ([(1, "right")] if "right" in seq.views else [])
    frames = list(opts.frames)
    objects = [o for o in seq.objects if isinstance(o, dict)]
    final = sequence_folder(out, opts.sequence)
    with atomic.replacing_folder(final) as root:
        fr = root / "frames"
        with progress_bar(opts, len(frames) * len(cams), "vkitti2") as bar:
            for i, k in enumerate(frames):
                for c, view in cams:
                    cam = f"Camera_{c}"
                    write_image_atomic(fr / "rgb" / cam / f"rgb_{i:05d}.{fmt}",
                                       image_rgb(seq, k, view, opts)[..., ::-1], jpeg_params() if fmt == "jpg" else None)
                    write_image_atomic(fr / "depth" / cam / f"depth_{i:05d}.png", depth_to_cm16(seq.depth(k, view)))
                    ids = seq.ids(k, view)
                    write_image_atomic(fr / "classSegmentation" / cam / f"classgt_{i:05d}.png",
                                       class_image(ids, objects)[..., ::-1])
                    if ids.size and ids.min() < 0:
                        raise VoError(f"vkitti2: frame {k} ({view}) has negative object ids")
                    inst = ids.astype(np.uint8 if ids.max(initial=0) <= 255 else np.uint16)
                    write_image_atomic(fr / "instanceSegmentation" / cam / f"instancegt_{i:05d}.png", inst)
                    if i + 1 < len(frames):
                        f = dense_flow(seq, k, frames[i + 1], view)
                        write_image_atomic(fr / "forwardFlow" / cam / f"flow_{i:05d}.png",
                                           encode_flow(f.flow, f.has_depth)[..., ::-1])
                    if i > 0:
                        f = dense_flow(seq, k, frames[i - 1], view)
                        write_image_atomic(fr / "backwardFlow" / cam / f"backwardFlow_{i:05d}.png",
                                           encode_flow(f.flow, f.has_depth)[..., ::-1])
                    bar.update()
        K = seq.K
        intr = ["frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]"]
        extr = ["frame cameraID r1,1 r1,2 r1,3 t1 r2,1 r2,2 r2,3 t2 r3,1 r3,2 r3,3 t3 0 0 0 1"]
        for i, k in enumerate(frames):
            for c, view in cams:
                intr.append(_row([i, c, K[0, 0], K[1, 1], K[0, 2], K[1, 2]]))
                T_cam_world = invert(F_VK_SES @ seq.T_world_cam(view)[k])
                extr.append(_row([i, c, *T_cam_world.ravel()]))
        atomic.write_text(root / "intrinsic.txt", "\n".join(intr) + "\n")
        atomic.write_text(root / "extrinsic.txt", "\n".join(extr) + "\n")
        atomic.write_text(root / "pose.txt", "\n".join(pose_rows(seq, frames, cams)) + "\n")
        atomic.write_text(root / "colors.txt", "Category r g b\n" + "".join(
            f"{n} {r} {g} {b}\n" for n, (r, g, b) in CATEGORIES.items()))
    return final


export_vkitti2.takes_sequence = True
