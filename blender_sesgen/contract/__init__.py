"""The on-disk render contract ``sesgen-render/1`` (pure: numpy + stdlib, no bpy).

What a render folder holds (see docs/rendering.md)::

    OUT/manifest.json          everything a reader needs (this module builds it)
    OUT/scene.ses              the script as rendered
    OUT/poses/left.tum.txt     TUM trajectories (timestamp tx ty tz qx qy qz qw), one per view
    OUT/poses/left.kitti.txt   KITTI trajectories (3x4 row-major T_world_cam), one per view
    OUT/poses/ego.txt          the per-step EGO table (U V W alpha beta gamma, deg)
    OUT/exr/left/NNNNNN.exr    one multilayer EXR per frame and view (float32, ZIP)
    OUT/exr/right/NNNNNN.exr

Poses everywhere are ``T_world_cam``: OpenCV camera (x right, y down, z forward) in the
SES world (right-handed, Y up). Frame k's timestamp is ``k / fps`` seconds.

The vo_reference package reads this format without importing blender_sesgen, so the
trajectory writers here are deliberately small and self-contained.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from .. import __version__
from ..model import Scene, TextureRef

FORMAT = "sesgen-render/1"
DEPTH_BACKGROUND = 1e10


def depth_m(z: np.ndarray) -> np.ndarray:
    """Cycles' planar depth with the background (1e10) turned into +inf."""
    z = np.asarray(z, dtype=np.float32)
    return np.where(z >= DEPTH_BACKGROUND * 0.5, np.inf, z)


def disparity_px(depth: np.ndarray, focal_px: float, baseline: float) -> np.ndarray:
    """Rectified disparity d = fx * B / Z in pixels (0 where Z is infinite)."""
    with np.errstate(divide="ignore"):
        return (float(focal_px) * float(baseline) / depth_m(depth)).astype(np.float32)
DEFAULT_FPS = 25.0
MANIFEST = "manifest.json"
SCENE_COPY = "scene.ses"
POSES_DIR = "poses"
EXR_DIR = "exr"
DISPLAY_DIR = "rgb"           # display-referred 8-bit PNGs (the LOOK's view transform)
VIEW_TRANSFORMS = {"agx": "AgX", "filmic": "Filmic", "standard": "Standard"}


# --- render options ---------------------------------------------------------------------

@dataclass(frozen=True)
class RenderOptions:
    """Settings of one render (CLI flags / add-on properties). ``None`` = the script's value.

    ``frames`` is a half-open range (start, stop) of frame indices; ``None`` = all frames.
    ``resolution_scale`` scales the image size and K (square pixels kept).
    """
    samples: Optional[int] = None
    denoise: Optional[bool] = None
    seed: Optional[int] = None
    device: str = "cpu"                  # "cpu" | "gpu"
    resolution_scale: float = 1.0
    frames: Optional[tuple[int, int]] = None
    normal_pass: bool = False
    position_pass: bool = False
    threads: int = 0                     # 0 = Cycles' automatic thread count
    verbose: bool = False                # let Blender print its render log


@dataclass(frozen=True)
class EffectiveSettings:
    """The settings actually used: what the manifest records and resume compares."""
    engine: str
    device: str
    samples: int
    denoise: bool
    seed: int
    resolution_scale: float
    passes: tuple[str, ...]
    width: int
    height: int
    K: tuple[tuple[float, float, float], ...]

    def pixel_affecting(self) -> dict:
        """The subset that changes pixels (device is left out: same output expected)."""
        d = asdict(self)
        d.pop("device")
        d["passes"] = list(self.passes)
        d["K"] = [list(r) for r in self.K]
        return d


def effective_settings(scene: Scene, options: RenderOptions) -> EffectiveSettings:
    rig = scene.rig
    s = float(options.resolution_scale)
    if not (s > 0.0 and np.isfinite(s)):
        from ..errors import SesgenError
        raise SesgenError(f"--resolution-scale must be a positive number, got {options.resolution_scale}")
    W, H = max(1, int(round(rig.width * s))), max(1, int(round(rig.height * s)))
    K = scaled_K(rig.K(), rig.width, rig.height, W, H)
    passes = ["combined", "depth", "object_index"]
    if options.normal_pass:
        passes.append("normal")
    if options.position_pass:
        passes.append("position")
    return EffectiveSettings(
        engine="CYCLES",
        device=options.device.upper(),
        samples=int(options.samples if options.samples is not None else scene.render.samples),
        denoise=bool(options.denoise if options.denoise is not None else scene.render.denoise),
        seed=int(options.seed if options.seed is not None else scene.render.seed),
        resolution_scale=s,
        passes=tuple(passes),
        width=W,
        height=H,
        K=tuple(tuple(float(x) for x in row) for row in K),
    )


def scaled_K(K: np.ndarray, W: int, H: int, W2: int, H2: int) -> np.ndarray:
    """K of the same camera rendered at W2 x H2 (square pixels: one scale W2/W).

    Pixel centres at integers: a point at pixel x maps to (x + 0.5) * s - 0.5.
    """
    s = W2 / W
    K2 = np.array(K, dtype=float)
    K2[0, 0] *= s
    K2[1, 1] *= s
    K2[0, 2] = (K[0, 2] + 0.5) * s - 0.5
    K2[1, 2] = (K[1, 2] + 0.5) * (H2 / H) - 0.5
    return K2


def render_seed(seed: int, frame: int, view_index: int) -> int:
    """Cycles seed of one (frame, view): deterministic, different for every frame and view
    (a fixed noise pattern shared by both views would look like zero-disparity texture)."""
    return (int(seed) * 1_000_003 + 2 * int(frame) + int(view_index)) % (2**31 - 1)


# --- file names -------------------------------------------------------------------------

def exr_relpath(view: str, frame: int) -> str:
    return f"{EXR_DIR}/{view}/{frame:06d}.exr"


def display_relpath(view: str, frame: int) -> str:
    return f"{DISPLAY_DIR}/{view}/{frame:06d}.png"


def trajectory_relpaths(views: Sequence[str]) -> dict:
    return {
        "tum": {v: f"{POSES_DIR}/{v}.tum.txt" for v in views},
        "kitti": {v: f"{POSES_DIR}/{v}.kitti.txt" for v in views},
        "ego": f"{POSES_DIR}/ego.txt",
    }


# --- hashing ----------------------------------------------------------------------------

def sha256_text(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def scene_text_for(scene: Scene) -> str:
    """Stand-in for the script text of a Scene built in Python (no .ses file): its JSON."""
    return "// scene built in Python; its model as JSON:\n// " + json.dumps(scene.to_json(), sort_keys=True) + "\n"


# --- manifest ---------------------------------------------------------------------------

def texture_label(tex: Optional[TextureRef]) -> Optional[str]:
    if tex is None:
        return None
    if tex.kind == "builtin":
        return tex.name
    return tex.source or tex.path


def object_table(scene: Scene) -> list[dict]:
    """One row per object: id, name, shape, texture, material, semantic ``class`` and its
    Cityscapes ``label_id`` (contract.semantics)."""
    from .semantics import BY_NAME, canonical
    out = []
    for o in scene.objects:
        tex = o.texture
        if tex is None and o.material:
            try:
                tex = scene.material(o.material).texture
            except KeyError:
                tex = None
        cls = canonical(o.semantic_class)
        out.append({"id": int(o.id), "name": o.name, "shape": o.shape,
                    "texture": texture_label(tex), "material": o.material,
                    "class": cls, "label_id": BY_NAME[cls].id})
    return out


def view_poses(scene: Scene) -> dict[str, np.ndarray]:
    """``{view: (N, 4, 4) T_world_cam}`` (OpenCV camera, SES world)."""
    poses = {"left": scene.timeline.left()}
    if scene.rig.stereo:
        poses["right"] = scene.timeline.right(scene.rig.baseline)
    return poses


def build_manifest(scene: Scene, scene_sha256: str, settings: EffectiveSettings,
                   generator: dict, fps: float = DEFAULT_FPS) -> dict:
    """The full manifest with no frame complete yet."""
    rig = scene.rig
    views = list(rig.views)
    N = scene.frames
    poses = view_poses(scene)
    m = {
        "format": FORMAT,
        "generator": generator,
        "scene": SCENE_COPY,
        "scene_source": scene.source,
        "scene_sha256": scene_sha256,
        "resolution": [settings.width, settings.height],
        "K": [list(r) for r in settings.K],
        "baseline": float(rig.baseline),
        "near": float(rig.near),
        "far": float(rig.far),
        "frames": N,
        "fps": float(fps),
        "timestamps": [k / fps for k in range(N)],
        "views": views,
        "depth": {"kind": "planar_z", "background": DEPTH_BACKGROUND, "channel": None},
        "segmentation": {"kind": "object_index", "background": 0, "channel": None},
        "channels": {},
        "objects": object_table(scene),
        "poses_convention": "T_world_cam: OpenCV camera (x right, y down, z forward) in the SES world (Y up)",
        "poses": {v: [np.asarray(T, dtype=float).tolist() for T in poses[v]] for v in views},
        "trajectories": trajectory_relpaths(views),
        "files": {v: [exr_relpath(v, k) for k in range(N)] for v in views},
        "display": {
            "kind": "display-referred sRGB, 8-bit PNG (the EXR's Combined pass through the view transform)",
            "view_transform": VIEW_TRANSFORMS[scene.look.view],
            "files": {v: [display_relpath(v, k) for k in range(N)] for v in views},
        },
        "frames_complete": [False] * N,
        "render": {
            "engine": settings.engine,
            "device": settings.device,
            "samples": settings.samples,
            "denoise": settings.denoise,
            "seed": settings.seed,
            "seed_rule": "cycles seed = (seed * 1000003 + 2 * frame + view_index) mod (2^31 - 1)",
            "resolution_scale": settings.resolution_scale,
            "passes": list(settings.passes),
            "exr": {"codec": "ZIP", "bits": 32, "layout": "multilayer, one part per pass"},
        },
    }
    if scene.noise is not None:
        m["noise"] = {"sigma": float(scene.noise.sigma), "seed": int(scene.noise.seed)}
    if scene.fog is not None:
        m["fog"] = {"start": scene.fog.start, "end": scene.fog.end, "colour": list(scene.fog.colour),
                    "applies_to": "rgb only"}
    return m


def generator_info(blender_version: Optional[str] = None) -> dict:
    import platform
    return {"name": "blender-sesgen", "version": __version__, "blender": blender_version,
            "python": platform.python_version()}


def load_manifest(out_dir: Path) -> Optional[dict]:
    p = Path(out_dir) / MANIFEST
    if not p.is_file():
        return None
    with open(p, encoding="utf-8") as f:
        return json.load(f)


def complete_frames(manifest: dict) -> list[int]:
    return [k for k, done in enumerate(manifest.get("frames_complete", [])) if done]


# --- atomic writes ----------------------------------------------------------------------

def atomic_write_bytes(path: Path, data: bytes) -> None:
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def atomic_write_text(path: Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: Path, obj: dict) -> None:
    atomic_write_text(path, json.dumps(obj, indent=1) + "\n")


# --- trajectory writers -----------------------------------------------------------------

def R_to_quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (qx, qy, qz, qw), qw >= 0, of a rotation matrix (Shepperd's method)."""
    R = np.asarray(R, dtype=float)
    tr = np.trace(R)
    cands = np.array([tr, R[0, 0], R[1, 1], R[2, 2]])
    i = int(np.argmax(cands))
    if i == 0:
        w = np.sqrt(1.0 + tr) / 2.0
        q = np.array([(R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w), w])
    elif i == 1:
        x = np.sqrt(1.0 + 2 * R[0, 0] - tr) / 2.0
        q = np.array([x, (R[0, 1] + R[1, 0]) / (4 * x), (R[0, 2] + R[2, 0]) / (4 * x), (R[2, 1] - R[1, 2]) / (4 * x)])
    elif i == 2:
        y = np.sqrt(1.0 + 2 * R[1, 1] - tr) / 2.0
        q = np.array([(R[0, 1] + R[1, 0]) / (4 * y), y, (R[1, 2] + R[2, 1]) / (4 * y), (R[0, 2] - R[2, 0]) / (4 * y)])
    else:
        z = np.sqrt(1.0 + 2 * R[2, 2] - tr) / 2.0
        q = np.array([(R[0, 2] + R[2, 0]) / (4 * z), (R[1, 2] + R[2, 1]) / (4 * z), z, (R[1, 0] - R[0, 1]) / (4 * z)])
    q /= np.linalg.norm(q)
    return -q if q[3] < 0 else q


def format_tum(timestamps: Sequence[float], T_world_cam: np.ndarray) -> str:
    """TUM RGB-D format: ``timestamp tx ty tz qx qy qz qw`` per line."""
    lines = ["# timestamp tx ty tz qx qy qz qw  (T_world_cam: OpenCV camera, SES world)"]
    for t, T in zip(timestamps, np.asarray(T_world_cam, dtype=float)):
        q = R_to_quaternion_xyzw(T[:3, :3])
        lines.append(" ".join(f"{x:.9g}" for x in (t, *T[:3, 3], *q)))
    return "\n".join(lines) + "\n"


def format_kitti(T_world_cam: np.ndarray) -> str:
    """KITTI odometry format: the 3x4 top of T_world_cam, row-major, 12 numbers per line."""
    return "".join(" ".join(f"{x:.12e}" for x in T[:3, :4].reshape(-1)) + "\n"
                   for T in np.asarray(T_world_cam, dtype=float))


def format_ego_table(ego: np.ndarray) -> str:
    """One line per frame step k -> k+1: ``k U V W alpha beta gamma`` (camera frame at k, deg)."""
    lines = ["# step U V W alpha_deg beta_deg gamma_deg  (motion from frame k to k+1 in the left camera frame at k)"]
    for k, row in enumerate(np.asarray(ego, dtype=float).reshape(-1, 6)):
        lines.append(f"{k} " + " ".join(f"{x:.12g}" for x in row))
    return "\n".join(lines) + "\n"


def write_pose_files(out_dir: Path, scene: Scene, timestamps: Sequence[float]) -> None:
    out_dir = Path(out_dir)
    (out_dir / POSES_DIR).mkdir(parents=True, exist_ok=True)
    poses = view_poses(scene)
    rel = trajectory_relpaths(list(poses))
    for view, T in poses.items():
        atomic_write_text(out_dir / rel["tum"][view], format_tum(timestamps, T))
        atomic_write_text(out_dir / rel["kitti"][view], format_kitti(T))
    atomic_write_text(out_dir / rel["ego"], format_ego_table(scene.timeline.ego_table()))
