"""A small analytic scene with moving objects, ray-cast exactly (tests/raycast.py), written
as a render folder without Blender (tests/synthetic_render.py).

Ground (id 1) and back wall (id 2) are static; a rotated cuboid (id 3) drives and turns, a
sphere (id 4) moves and spins, passing in front of the cuboid; the stereo rig moves too.
Object poses: T_world_obj(k) = M(k) @ T_rest with M(k) the accumulated rigid motion (built
here with scipy, independently of blender_sesgen); the manifest carries them exactly as the
renderer writes them (``objects[i].moving`` / ``T_world_obj``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

import raycast

W, H = 64, 48
K = np.array([[60.0, 0.0, 31.5], [0.0, 60.0, 23.5], [0.0, 0.0, 1.0]])
BASELINE = 0.3
FRAMES = 3


def pose(p, euler_deg=(0, 0, 0)):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", euler_deg, degrees=True).as_matrix()
    T[:3, 3] = p
    return T


def camera(p, yaw_deg=0.0):
    """OpenCV camera at p looking along world -Z (turned by yaw about world +Y)."""
    T = pose(p, (0, yaw_deg, 0))
    T[:3, :3] = T[:3, :3] @ np.diag([1.0, -1.0, -1.0])
    return T


GROUND = raycast.QuadP(1, np.array([[-30, 0, -40], [30, 0, -40], [30, 0, 15], [-30, 0, 15]], float))
WALL = raycast.QuadP(2, np.array([[-30, 0, -15], [30, 0, -15], [30, 20, -15], [-30, 20, -15]], float))
BOX = raycast.BoxP(3, np.array([-1.0, 0.8, 0.0]), (10, 30, 0), np.array([2.0, 1.2, 1.0]))
BALL = raycast.SphereP(4, np.array([1.2, 0.7, 1.0]), 0.6)
REST = {3: pose(BOX.centre, BOX.rotation_deg), 4: pose(BALL.centre)}
# per-step world motions of the movers: a turn about the object's own centre plus a move
STEP = {3: (np.array([0.35, 0.0, 0.25]), (0, 8, 0)), 4: (np.array([-0.45, 0.08, -0.3]), (20, -15, 30))}


def step_motion(obj_id: int, T_world_obj: np.ndarray) -> np.ndarray:
    """World-to-world motion of one step: rotate about the object's centre, then translate."""
    dt, euler = STEP[obj_id]
    R = Rotation.from_euler("xyz", euler, degrees=True).as_matrix()
    c = T_world_obj[:3, 3]
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = c - R @ c + dt
    return M


@dataclass
class DynamicScene:
    T_left: np.ndarray                 # (N, 4, 4)
    M: dict                            # id -> (N, 4, 4) accumulated world motion of each mover
    T_world_obj: dict                  # id -> (N, 4, 4)

    def prims(self, k: int) -> list:
        return [GROUND, WALL, raycast.Moved(BOX, self.M[3][k]), raycast.Moved(BALL, self.M[4][k])]

    def T_right(self) -> np.ndarray:
        T = self.T_left.copy()
        T[:, :3, 3] += BASELINE * T[:, :3, 0]
        return T


def make_scene(frames: int = FRAMES, static: bool = False) -> DynamicScene:
    """The scene over ``frames`` frames (``static``: the cuboid and sphere stay put)."""
    T_left = np.stack([camera((0.05 * k, 1.5, 6.0 - 0.15 * k), yaw_deg=1.5 * k) for k in range(frames)])
    M, T_obj = {}, {}
    for obj_id in (3, 4):
        Ms, Ts = [np.eye(4)], [REST[obj_id]]
        for _ in range(frames - 1):
            step = np.eye(4) if static else step_motion(obj_id, Ts[-1])
            Ms.append(step @ Ms[-1])
            Ts.append(step @ Ts[-1])
        M[obj_id], T_obj[obj_id] = np.stack(Ms), np.stack(Ts)
    return DynamicScene(T_left, M, T_obj)


def truth(scene: DynamicScene, k: int, view: str = "left"):
    """Depth (H, W) and ids (H, W) at every pixel centre of frame k."""
    T = scene.T_left[k] if view == "left" else scene.T_right()[k]
    vv, uu = np.mgrid[0:H, 0:W].astype(float)
    depth, ids = raycast.cast(scene.prims(k), K, T, uu, vv)
    return depth.reshape(H, W), ids.reshape(H, W)


def write(root, scene: DynamicScene, moving: bool = True):
    """The render folder of the scene (rgb: a fixed random texture; it is not used here)."""
    from synthetic_render import write_render
    rng = np.random.default_rng(5)
    frames = []
    for k in range(len(scene.T_left)):
        fr = {}
        for view in ("left", "right"):
            z, ids = truth(scene, k, view)
            fr[view] = (rng.uniform(0.05, 0.9, (H, W, 3)).astype(np.float32), z.astype(np.float32), ids)
        frames.append(fr)
    objects = []
    for obj_id, name, shape in ((1, "ground", "quad"), (2, "wall", "quad"), (3, "car", "cuboid"), (4, "ball", "sphere")):
        o = {"id": obj_id, "name": name, "shape": shape, "moving": False}
        if moving and obj_id in scene.T_world_obj:
            o.update(moving=True, motion="twist", T_world_obj=scene.T_world_obj[obj_id].tolist())
        objects.append(o)
    return write_render(root, K=K, baseline_m=BASELINE, T_world_left=scene.T_left, frames=frames, objects=objects)
