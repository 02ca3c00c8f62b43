"""Test fixture: render folders in the ``sesgen-render/1`` layout, written without Blender.

The EXRs are multi-part, one part per pass, with the channel names Blender 5.0 writes
(``ViewLayer.Combined.R/G/B/A``, ``ViewLayer.Depth.Z``, ``ViewLayer.Object Index.X``),
background depth 1e10, and the manifest is the contract's own (``Manifest.write``). Pass
arrays of your own, or use :func:`plane_scene` for a textured plane whose depth is known in
closed form.
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence as Seq

import numpy as np

from vo_reference.io.exr import render_exr_parts as exr_parts, write_exr_parts

from blender_sesgen.contract.rig import right_from_left
from blender_sesgen.contract.manifest import Manifest, exr_relpath


def write_render(root, *, K: np.ndarray, baseline_m: float, T_world_left: np.ndarray,
                 frames: Seq[dict], noise: tuple[float, int] | None = None,
                 objects: list | None = None, extra: dict | None = None,
                 drop_passes: Seq[str] = ()) -> Path:
    """Write ``root/manifest.json`` and ``root/exr/<view>/NNNNNN.exr``.

    ``frames[k]`` = {"left": (rgb_linear (H,W,3), depth (H,W), ids (H,W)), "right": (...)};
    views are those present in frame 0. ``drop_passes`` (e.g. ``("Depth",)``) leaves
    passes out, to make broken fixtures. Returns root.
    """
    root = Path(root)
    T_left = np.asarray(T_world_left, dtype=float)
    views = tuple(v for v in ("left", "right") if v in frames[0])
    H, W = frames[0]["left"][1].shape
    poses = {"left": T_left}
    if "right" in views:
        poses["right"] = right_from_left(T_left, baseline_m)
    n = len(frames)
    for k, fr in enumerate(frames):
        for v in views:
            rgb, depth, ids = fr[v]
            parts = exr_parts(rgb, depth, ids)
            parts = {name: c for name, c in parts.items() if name.split(".", 1)[1] not in drop_passes}
            write_exr_parts(root / exr_relpath(v, k), parts)
    extra = dict(extra or {})
    timestamps = extra.pop("timestamps", None)
    if timestamps is not None and "fps" not in extra and n > 1:
        extra["fps"] = 1.0 / float(np.median(np.diff(timestamps)))
    fps = float(extra.pop("fps", 1.0))
    timestamps = np.asarray(np.arange(n) / fps if timestamps is None else timestamps, dtype=float)
    if noise is not None:
        extra["noise"] = {"sigma": float(noise[0]), "seed": int(noise[1])}
    Manifest(resolution=(int(W), int(H)), K=np.asarray(K, dtype=float), baseline=float(baseline_m), views=views,
             poses=poses, files={v: [exr_relpath(v, k) for k in range(n)] for v in views},
             timestamps_s=timestamps, fps=fps, frames_complete=[True] * n,
             depth={"kind": "planar_z", "background": 1e10, "channel": "ViewLayer.Depth.Z"},
             segmentation={"kind": "object_index", "background": 0, "channel": "ViewLayer.Object Index.X"},
             channels={"rgb": [f"ViewLayer.Combined.{c}" for c in "RGBA"], "depth": "ViewLayer.Depth.Z",
                       "object_index": "ViewLayer.Object Index.X"},
             objects=objects if objects is not None else [],
             render={"engine": "synthetic", "samples": 0, "denoise": False, "seed": 0},
             generator={"tests/synthetic_render.py": "1"}, scene_sha256="0" * 64, extra=extra).write(root)
    return root


def write_manifest_dict(root, m: dict) -> Path:
    """Write ``m`` as ``root/manifest.json``, sealed as the renderer seals its own (for
    fixtures that change a manifest on purpose; a reader refuses an unsealed edit)."""
    import json
    from blender_sesgen.contract.manifest import SEAL, seal_of
    m = {**m, SEAL: seal_of(m)}
    path = Path(root) / "manifest.json"
    path.write_text(json.dumps(m, indent=1))
    return path


def plane_depth(K: np.ndarray, T_world_cam: np.ndarray, n_world: np.ndarray, d_world: float,
                W: int, H: int) -> np.ndarray:
    """Planar z of the plane {X : n·X = d} seen by a camera (inf where not hit in front)."""
    u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    rays = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)  # z = 1
    R, C = T_world_cam[:3, :3], T_world_cam[:3, 3]
    n_cam = R.T @ n_world
    denom = rays @ n_cam
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (d_world - n_world @ C) / denom
    z[~np.isfinite(z) | (z <= 0)] = np.inf
    return z


def plane_scene(root, *, W: int = 64, H: int = 48, f: float = 50.0, baseline_m: float = 0.2,
                frames: int = 3, step_m: float = 0.1, stereo: bool = True, plane_z: float = 4.0,
                noise: tuple[float, int] | None = None, object_id: int = 7) -> Path:
    """A fronto-parallel textured plane at world z = plane_z, the rig moving along x.

    The plane covers the whole view, so depth = plane_z - camera z everywhere."""
    K = np.array([[f, 0, W / 2 - 0.5], [0, f, H / 2 - 0.5], [0, 0, 1.0]])
    T = np.tile(np.eye(4), (frames, 1, 1))
    T[:, 0, 3] = np.arange(frames) * step_m
    rng = np.random.default_rng(0)
    tex = rng.uniform(0.05, 0.9, (H, W, 3)).astype(np.float32)
    fr = []
    for k in range(frames):
        d = {}
        for v in (("left", "right") if stereo else ("left",)):
            Tv = T[k].copy()
            if v == "right":
                Tv[0, 3] += baseline_m
            z = plane_depth(K, Tv, np.array([0, 0, 1.0]), plane_z, W, H).astype(np.float32)
            d[v] = (np.roll(tex, k, axis=1), z, np.full((H, W), object_id, np.int32))
        fr.append(d)
    return write_render(root, K=K, baseline_m=baseline_m if stereo else 0.0, T_world_left=T, frames=fr,
                        noise=noise, objects=[{"id": object_id, "name": "plane", "shape": "QUAD"}])


COMPLETE_SCRIPT = "CAMERA resolution 64 48 focal 50 baseline 0.2\nSTART position 0 0 0\n"


def complete_render(root, frames: int = 3) -> Path:
    """A synthetic render with what a plain Cycles render holds besides its EXRs: scene.ses,
    display PNGs (display.files), trajectories, an IMU stream, and every file's SHA-256."""
    import hashlib
    import cv2
    from blender_sesgen.contract.colour import linear_to_srgb8
    from blender_sesgen.contract.manifest import display_relpath
    from vo_reference.io.render import RenderSequence
    root = plane_scene(root, frames=frames)
    seq = RenderSequence(root)
    m = Manifest.read(root)
    sums = {}

    def put(rel: str, data: bytes) -> None:
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_bytes(data)
        sums[rel] = hashlib.sha256(data).hexdigest()
    for k in range(frames):
        for v in m.views:
            put(m.files[v][k], (root / m.files[v][k]).read_bytes())
            ok, png = cv2.imencode(".png", linear_to_srgb8(seq.rgb_linear(k, v))[..., ::-1])
            put(display_relpath(v, k), png.tobytes())
    m.extra["display"] = {"kind": "display-referred sRGB, 8-bit PNG", "view_transform": "Standard", "look": "None",
                          "files": {v: [display_relpath(v, k) for k in range(frames)] for v in m.views}}
    for rel in m.static_files():      # the trajectories every manifest lists
        put(rel, b"0 0 0 0 0 0 0 1\n")
    put("imu/data.csv", b"#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n0,0,0,0,0,9.81,0\n")
    m.extra["imu"] = {"files": {"noisy": "imu/data.csv", "ideal": "imu/data.csv", "groundtruth": "imu/data.csv"}}
    put("scene.ses", COMPLETE_SCRIPT.encode())
    m.scene_sha256 = hashlib.sha256(COMPLETE_SCRIPT.encode()).hexdigest()
    m.extra["checksums"] = sums
    m.write(root)
    return root


def add_imu(root, T_cam_imu, rate_hz: float = 200.0, time_offset_s: float = 0.0, yaml_text: str | None = None) -> dict:
    """Give a render folder an IMU: the manifest's ``imu`` entry (ADIS16448-like densities)
    and its files, samples at rest over the frames' span (gyro 0, accel +9.81 along y),
    ground truth at the origin; ``yaml_text`` replaces the render's imu/sensor.yaml (an old
    render's file, say). Returns the entry."""
    import json
    from blender_sesgen.contract.manifest import LIMIT, MANIFEST
    from blender_sesgen.contract.manifest_sections import ImuSection
    from blender_sesgen.contract.sensor_yaml import imu_sensor_yaml
    from blender_sesgen.contract.timing import to_ns
    root = Path(root)
    m = json.loads((root / "manifest.json").read_text())
    imu = {"rate_hz": float(rate_hz), "gyroscope_noise_density": 1.7e-4, "gyroscope_random_walk": 1.9e-5,
           "accelerometer_noise_density": 2.0e-3, "accelerometer_random_walk": 3.0e-3,
           "T_cam_imu": np.asarray(T_cam_imu, dtype=float).tolist(), "time_offset_s": float(time_offset_s),
           "gravity_world": [0.0, -9.81, 0.0], "seed": 0,
           "files": {"noisy": "imu/data.csv", "ideal": "imu/data_ideal.csv", "groundtruth": "imu/groundtruth.csv",
                     "yaml": "imu/sensor.yaml"}}
    m["imu"] = imu
    write_manifest_dict(root, m)
    (root / "imu").mkdir(exist_ok=True)
    t = np.asarray(m["timestamps"], dtype=float)
    t_ns = to_ns(np.arange(t[0], t[-1] + 0.5 / rate_hz, 1.0 / rate_hz) + time_offset_s)
    rows = "".join(f"{int(tn)},0,0,0,0,9.81,0\n" for tn in t_ns)
    for name in ("data.csv", "data_ideal.csv"):
        (root / "imu" / name).write_text("#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n" + rows)
    (root / "imu" / "groundtruth.csv").write_text("#timestamp, p, q_wxyz, v, b_w, b_a\n" + "".join(
        f"{int(tn - round(time_offset_s * 1e9))},0,0,0,1,0,0,0,0,0,0,0,0,0,0,0,0\n" for tn in t_ns))
    (root / "imu" / "sensor.yaml").write_text(imu_sensor_yaml(ImuSection.from_json(imu, MANIFEST, LIMIT))
                                                if yaml_text is None else yaml_text)
    return imu
