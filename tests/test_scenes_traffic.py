"""scenes/street_kitti_traffic.ses: in sync with its generator, traffic in view, and nothing
driving through the camera, a parked box, a pole or another road user (pure: the model's
per-frame object poses against footprints on the ground)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from blender_sesgen.model import Cuboid, Cylinder, Mesh
from blender_sesgen.ses import parse_file

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "scenes" / "street_kitti_traffic.ses"
FOOTPRINT = {"car.obj": (1.8, 4.3), "person.obj": (0.64, 0.26)}   # width (local x), length (local z), m


@pytest.fixture(scope="module")
def scene():
    return parse_file(SCENE)


def test_in_sync_with_its_generator(tmp_path):
    gen = REPO / "scenes" / "generators" / "traffic.py"
    r = subprocess.run([sys.executable, str(gen), "--assets", str(tmp_path)], capture_output=True, text=True,
                       env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    assert r.stdout == SCENE.read_text(), "street_kitti_traffic.ses differs from `generators/traffic.py`"
    for f in tmp_path.iterdir():
        assert f.read_text() == (REPO / "scenes" / "traffic" / f.name).read_text(), f.name


def _corners(T, width, length, grow=0.0):
    """(4, 2) ground (x, z) corners of a footprint centred on the object frame's origin."""
    hw, hl = width / 2 + grow, length / 2 + grow
    local = np.array([[-hw, 0, -hl], [hw, 0, -hl], [hw, 0, hl], [-hw, 0, hl]])
    return (local @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3])[:, [0, 2]]


def _overlap(a, b) -> bool:
    """Separating-axis test of two convex polygons (corners in order)."""
    for poly in (a, b):
        for i in range(len(poly)):
            e = poly[(i + 1) % len(poly)] - poly[i]
            n = np.array([-e[1], e[0]])
            pa, pb = a @ n, b @ n
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def _movers(scene):
    out = []
    for m in scene.object_motions:
        obj = next(o for o in scene.objects if o.id == m.id)
        assert isinstance(obj, Mesh)
        out.append((obj.name, FOOTPRINT[Path(obj.path).name], m.poses()))
    return out


def test_traffic_moves_with_kittis_rig(scene):
    assert scene.frames == 51 and scene.rig.width == 1226 and scene.rig.focal_px == 707
    assert scene.timing is not None and scene.timing.rate_hz == 10   # KITTI's frame rate
    kinds = sorted(m.kind for m in scene.object_motions)
    assert kinds.count("trajectory") == 4 and kinds.count("twist") >= 8
    names = [n for n, _, _ in _movers(scene)]
    assert sum(n.startswith("oncoming") for n in names) == 3 and sum("walker" in n for n in names) == 8


def test_nothing_drives_through_the_camera_the_street_furniture_or_each_other(scene):
    movers = _movers(scene)
    cams = [scene.timeline.left()[:, :3, 3][:, [0, 2]], scene.timeline.right(scene.rig.baseline)[:, :3, 3][:, [0, 2]]]
    still = []
    for o in scene.objects:
        if isinstance(o, Cuboid) and o.id >= 1000:   # parked boxes
            T = np.eye(4)
            a = np.radians(o.rotation_deg[1])
            T[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
            T[:3, 3] = o.position
            still.append((o.name, _corners(T, o.size[0], o.size[2])))
        elif isinstance(o, Cylinder):                 # lamp poles
            T = np.eye(4)
            T[:3, 3] = o.position
            still.append((o.name, _corners(T, 2 * o.radius, 2 * o.radius)))
    for k in range(scene.frames):
        boxes = [(n, _corners(P[k], *wl)) for n, wl, P in movers]
        for n, b in boxes:
            for cam in cams:
                grown = _corners(movers[[m[0] for m in movers].index(n)][2][k], *FOOTPRINT["car.obj" if "walker" not in n else "person.obj"], grow=0.3)
                c = cam[k]
                assert not _overlap(grown, np.array([c, c + [1e-3, 0], c + [1e-3, 1e-3]])), f"frame {k}: {n} hits the camera"
            for sn, sb in still:
                assert not _overlap(b, sb), f"frame {k}: {n} drives through {sn}"
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                assert not _overlap(boxes[i][1], boxes[j][1]), f"frame {k}: {boxes[i][0]} and {boxes[j][0]} collide"


def test_traffic_is_in_view(scene):
    K = scene.rig.K()
    T = scene.timeline.left()
    W, H = scene.rig.width, scene.rig.height
    seen = {}
    for name, _, P in _movers(scene):
        c = P[:, :3, 3] + [0, 0.8, 0]
        Xc = np.einsum("kji,kj->ki", T[:, :3, :3], c - T[:, :3, 3])      # R^T (c - t)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = K[0, 0] * Xc[:, 0] / Xc[:, 2] + K[0, 2]
            v = K[1, 1] * Xc[:, 1] / Xc[:, 2] + K[1, 2]
        seen[name] = (Xc[:, 2] > 1) & (Xc[:, 2] < 80) & (u >= 0) & (u < W) & (v >= 0) & (v < H)
        seen[name + ":u"] = u
    per_frame = sum(v.astype(int) for k, v in seen.items() if not k.endswith(":u"))
    assert per_frame.min() >= 3, per_frame
    # the crossing cars cross the image, left to right and right to left
    for name, sign in (("crossing_1", 1), ("crossing_2", -1)):
        u = seen[name + ":u"][seen[name]]
        assert len(u) >= 5 and sign * (u[-1] - u[0]) > W / 3, (name, u)


def test_cars_and_people_carry_their_class(scene):
    """So that the cityscapes export labels them car / person (instances) and vkitti2 Car."""
    from blender_sesgen.plan import object_table
    rows = {r["id"]: r for r in object_table(scene)}
    meshes = [o for o in scene.objects if isinstance(o, Mesh)]
    assert len(meshes) >= 10
    for o in meshes:
        want = {"car.obj": "car", "person.obj": "person"}[Path(o.path).name]
        assert o.semantic_class == want and rows[o.id]["class"] == want, o.name
