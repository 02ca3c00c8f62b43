"""Export target ``vkitti2``: one Virtual KITTI 2 scene variation (``SceneXX/clone``) as the
dataset ships it (vkitti_2.0.3; layout and file formats from its README on the Naver Labs
Europe page, "Proxy Virtual Worlds -- Virtual KITTI 2")::

    OUT/frames/rgb/Camera_0/rgb_00000.jpg                   colour, left (Camera_1: right), JPEG quality 95,
                                                            4:4:4; --opt rgb=png for lossless PNG
    OUT/frames/depth/Camera_0/depth_00000.png               uint16, planar depth in centimetres
                                                            (65535 = 655.35 m or more, and nothing hit)
    OUT/frames/classSegmentation/Camera_0/classgt_00000.png 8-bit RGB, the class colours of colors.txt
    OUT/frames/instanceSegmentation/Camera_0/instancegt_00000.png   vehicles only (Car, Truck, Van): object id
                                                            (trackID + 1; 0 = anything else), 8-bit grey,
                                                            16-bit when an id is > 255
    OUT/frames/forwardFlow/Camera_0/flow_00000.png          flow k -> k+1 (not for the last frame)
    OUT/frames/backwardFlow/Camera_0/backwardFlow_00001.png flow k -> k-1 (not for the first frame)
    OUT/intrinsic.txt   'frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]'
    OUT/extrinsic.txt   'frame cameraID r1,1 r1,2 r1,3 t1 r2,1 ... t3 0 0 0 1': world -> camera 4x4
    OUT/pose.txt        'frame cameraID trackID alpha width height length world_space_X world_space_Y
                        world_space_Z rotation_world_space_y rotation_world_space_x rotation_world_space_z
                        camera_space_X camera_space_Y camera_space_Z rotation_camera_space_y
                        rotation_camera_space_x rotation_camera_space_z'
    OUT/bbox.txt        'frame cameraID trackID left right top bottom number_pixels truncation_ratio
                        occupancy_ratio isMoving'
    OUT/info.txt        'trackID label model color'
    OUT/colors.txt      'Category r g b' (vKITTI 2's 15 categories)

intrinsic.txt and extrinsic.txt hold one line per frame and camera (camera 0 then 1), pose.txt
and bbox.txt one per frame, camera and vehicle seen in that image, after a header line.

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
``Sky``. As in vKITTI 2, only vehicles (the categories Car, Truck and Van) are tracked: they
alone have instances, and rows in pose.txt, bbox.txt and info.txt (trackID = id − 1).

pose.txt: KITTI's 3-D box label of each vehicle seen in the image. The object's KITTI frame
is x forward (its +Z: SES objects face +Z), y down, z = its +X; width, height, length are the
extents of its object-frame ``box`` along X, Y and Z (the manifest's ``objects[i].box``; 0 when
the manifest has none); the position is the box's bottom centre (the object's origin without
a box), in vKITTI's world (F·T_world_obj) and in the camera; Euler angles with
R = Ry·Rx·Rz (Unity's order, vKITTI's engine); alpha = ry_cam − atan2(X_cam, Z_cam) wrapped
to [−π, π] (KITTI's observation angle). A moving object's pose is its ``T_world_obj`` at the
frame, a static one's its ``T_world_obj_rest``.

bbox.txt: the 2-D box (inclusive pixel bounds) and pixel count of the vehicle's visible
pixels, its truncation ratio (the share of its projected 3-D box outside the image; −1
without a box), occupancy ratio −1 (unknown: a render holds no unoccluded per-object
mask) and isMoving (True/False: it moves between this frame and the next). info.txt: the
vehicle's category, its model (asset kind, else its name) and colour (Unknown).
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
# KITTI's object axes (x forward, y down, z = x cross y) in the SES object frame (forward +Z, Y up)
R_OBJ_KITTI = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
VEHICLES = ("Car", "Truck", "Van")
FLOW_MAX = 2 ** 16 - 1
JPEG_QUALITY = 95
POSE_HEADER = ("frame cameraID trackID alpha width height length world_space_X world_space_Y world_space_Z "
               "rotation_world_space_y rotation_world_space_x rotation_world_space_z camera_space_X "
               "camera_space_Y camera_space_Z rotation_camera_space_y rotation_camera_space_x "
               "rotation_camera_space_z")
BBOX_HEADER = ("frame cameraID trackID left right top bottom number_pixels truncation_ratio occupancy_ratio "
               "isMoving")


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
    return " ".join(str(v) if isinstance(v, (int, np.integer, bool, np.bool_)) else f"{v:.9g}" for v in values)


def vehicles(seq) -> list[dict]:
    """The objects vKITTI 2 tracks: its vehicle categories (Car, Truck, Van), by id."""
    objs = [o for o in seq.objects if isinstance(o, dict) and int(o.get("id", 0)) > 0]
    return sorted((o for o in objs if category_of(o) in VEHICLES), key=lambda o: int(o["id"]))


def object_pose(seq, obj: dict, k: int) -> np.ndarray | None:
    """T_world_obj of ``obj`` at frame k: its per-frame pose if it moves, else its pose as
    placed (``T_world_obj_rest``); None when the manifest has neither (BLEND objects)."""
    T = seq.T_world_obj(int(obj["id"]))
    if T is not None:
        return T[k]
    rest = obj.get("T_world_obj_rest")
    return None if rest is None else np.asarray(rest, dtype=float)


def is_moving(seq, obj: dict, k: int) -> bool:
    """vKITTI 2's isMoving: the object moves between frame k and the next (the previous for
    the last frame of the render)."""
    T = seq.T_world_obj(int(obj["id"]))
    if T is None or len(T) < 2:
        return False
    j = k + 1 if k + 1 < len(T) else k - 1
    return not np.array_equal(T[k], T[j])


def box_label(obj: dict) -> tuple[tuple[float, float, float], np.ndarray]:
    """((width, height, length), bottom centre in the object frame) of the object's box
    (KITTI's dimensions: length along its forward +Z, height along +Y, width along +X);
    zeros and the object's origin without a box."""
    box = obj.get("box")
    if box is None:
        return (0.0, 0.0, 0.0), np.zeros(3)
    lo, hi = np.asarray(box, dtype=float)
    w, h, length = hi - lo
    return (float(w), float(h), float(length)), np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])


def truncation(obj: dict, T_cam_obj: np.ndarray, K: np.ndarray, width: int, height: int) -> float:
    """vKITTI 2's truncation ratio: the share of the object's 2-D box (its 3-D box projected,
    clipped to the front of the camera) that lies outside the image; -1 without a box."""
    box = obj.get("box")
    if box is None:
        return -1.0
    lo, hi = np.asarray(box, dtype=float)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    X = corners @ T_cam_obj[:3, :3].T + T_cam_obj[:3, 3]
    near = 1e-3
    pts = [x for x in X if x[2] >= near]
    for i in range(8):               # the box's edges (corners differing in one coordinate) cut at z = near
        for j in range(i + 1, 8):
            a, b = X[i], X[j]
            if bin(i ^ j).count("1") == 1 and (a[2] - near) * (b[2] - near) < 0:
                t = (near - a[2]) / (b[2] - a[2])
                pts.append(a + t * (b - a))
    if not pts:
        return 1.0
    P = np.array(pts)
    u = K[0, 0] * P[:, 0] / P[:, 2] + K[0, 2]
    v = K[1, 1] * P[:, 1] / P[:, 2] + K[1, 2]
    x0, x1, y0, y1 = u.min(), u.max(), v.min(), v.max()
    area = (x1 - x0) * (y1 - y0)
    if area <= 0:
        return 0.0
    inside = max(0.0, min(x1, width - 0.5) - max(x0, -0.5)) * max(0.0, min(y1, height - 0.5) - max(y0, -0.5))
    return float(np.clip(1.0 - inside / area, 0.0, 1.0))


def object_rows(seq, frames: list[int], cams: list[tuple[int, str]]) -> tuple[list[str], list[str]]:
    """The rows of pose.txt and bbox.txt: one per frame, camera and vehicle seen in that
    image (at least one pixel), in that order (module docstring)."""
    poses, boxes = [POSE_HEADER], [BBOX_HEADER]
    objs = vehicles(seq)
    W, H = seq.resolution
    K = np.asarray(seq.K, dtype=float)
    for i, k in enumerate(frames):
        for c, view in cams:
            ids = seq.ids(k, view)
            T_cam_world = invert(seq.T_world_cam(view)[k])
            for obj in objs:
                on = ids == int(obj["id"])
                T = object_pose(seq, obj, k)
                if not on.any() or T is None:
                    continue
                (width, height, length), bottom = box_label(obj)
                T_obj_kitti = T @ R_OBJ_KITTI
                T_w = F_VK_SES @ T_obj_kitti                  # in vKITTI's world (y down)
                T_c = T_cam_world @ T_obj_kitti
                p_w = (F_VK_SES @ T @ np.append(bottom, 1.0))[:3]
                p_c = (T_cam_world @ T @ np.append(bottom, 1.0))[:3]
                ryw, rxw, rzw = euler_yxz(T_w[:3, :3])
                ryc, rxc, rzc = euler_yxz(T_c[:3, :3])
                alpha = (ryc - np.arctan2(p_c[0], p_c[2]) + np.pi) % (2 * np.pi) - np.pi
                track = int(obj["id"]) - 1
                poses.append(_row([i, c, track, alpha, width, height, length, *p_w, ryw, rxw, rzw, *p_c,
                                   ryc, rxc, rzc]))
                ys, xs = np.nonzero(on)
                boxes.append(_row([i, c, track, int(xs.min()), int(xs.max()), int(ys.min()), int(ys.max()),
                                   int(on.sum()), truncation(obj, T_cam_world @ T, K, W, H), -1.0,
                                   is_moving(seq, obj, k)]))
    return poses, boxes


def info_rows(seq) -> list[str]:
    """info.txt: 'trackID label model color' per vehicle (model: the asset kind, else the
    object's name; color: unknown, the manifest does not hold it)."""
    rows = ["trackID label model color"]
    for obj in vehicles(seq):
        model = obj.get("kind") if obj.get("shape") == "asset" else obj.get("name")
        model = "_".join(str(model or obj.get("shape") or "object").split())
        rows.append(f"{int(obj['id']) - 1} {category_of(obj)} {model} Unknown")
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
    vehicle_ids = [int(o["id"]) for o in vehicles(seq)]
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
                    inst = np.where(np.isin(ids, vehicle_ids), ids, 0)       # vKITTI 2: vehicles only
                    inst = inst.astype(np.uint8 if max(vehicle_ids, default=0) <= 255 else np.uint16)
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
        pose, bbox = object_rows(seq, frames, cams)
        atomic.write_text(root / "pose.txt", "\n".join(pose) + "\n")
        atomic.write_text(root / "bbox.txt", "\n".join(bbox) + "\n")
        atomic.write_text(root / "info.txt", "\n".join(info_rows(seq)) + "\n")
        atomic.write_text(root / "colors.txt", "Category r g b\n" + "".join(
            f"{n} {r} {g} {b}\n" for n, (r, g, b) in CATEGORIES.items()))
    return final


export_vkitti2.takes_sequence = True
