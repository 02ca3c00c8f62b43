"""The manifest's object rows carry each object's rest pose and its object-frame bounding
box (blender_sesgen.bounds), against the geometry the script states and, for assets and
OBJ meshes, the vertices themselves."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from blender_sesgen.contract.errors import ContractError
from blender_sesgen.contract.manifest_schema import check_types
from blender_sesgen.plan import object_table
from blender_sesgen.ses import parse_string

REPO = Path(__file__).resolve().parents[1]


def rows_of(text: str, **kw) -> dict:
    return {r["id"]: r for r in object_table(parse_string(text, **kw))}


def test_boxes_of_the_primitives_and_their_rest_poses():
    rows = rows_of("CAMERA resolution 64 48 focal 50\nSTART position 0 1 5 0 0 0\n"
                   "QUAD id 1 vertices -2 0 -1  4 0 -1  4 0 3  -2 0 3\n"
                   "CUBOID id 2 position 1 0.5 -2 0 30 0 dim 1.2 1.0 0.5\n"
                   "SPHERE id 3 position 0 1 -3 dim 0.4\n"
                   "CYLINDER id 4 position 2 1 -4 90 0 0 dim 0.25 1.5\n"
                   "ASSET car id 5 position 3 0 -6 size 1.8 1.4 4.2 seed 2\n"
                   "ASSET road id 6 position 0 0 0 size 7 0.3 20 seed 1\n")
    assert np.allclose(rows[1]["box"], [[-3, 0, -2], [3, 0, 2]])            # about the vertices' centroid
    assert np.allclose(np.array(rows[1]["T_world_obj_rest"])[:3, 3], [1, 0, 1])
    assert np.allclose(rows[2]["box"], [[-0.6, -0.5, -0.25], [0.6, 0.5, 0.25]])
    T2 = np.array(rows[2]["T_world_obj_rest"])
    assert np.allclose(T2[:3, 3], [1, 0.5, -2]) and T2[0, 2] == pytest.approx(np.sin(np.radians(30)))
    assert np.allclose(rows[3]["box"], [[-0.4] * 3, [0.4] * 3])
    assert np.allclose(rows[4]["box"], [[-0.25, -0.75, -0.25], [0.25, 0.75, 0.25]])
    from blender_sesgen import assets
    V = assets.generate("car", (1.8, 1.4, 4.2), 2).vertices
    assert np.allclose(rows[5]["box"], [V.min(0), V.max(0)])
    assert "box" not in rows[6]                                             # stuff: no box label
    assert all(not r["moving"] and "T_world_obj" not in r for r in rows.values())


def test_obj_mesh_box_is_its_vertices_times_scale(tmp_path):
    (tmp_path / "m.obj").write_text("# a wedge\nv -1 0 -2\nv 1 0 -2\nv 0 2 3\nvn 0 1 0\nf 1 2 3\n")
    rows = rows_of("CAMERA resolution 64 48 focal 50\nSTART position 0 1 5 0 0 0\n"
                   "MESH id 7 file m.obj position 0 0 -5 scale 2 1 0.5\n", base_dir=tmp_path)
    assert np.allclose(rows[7]["box"], [[-2, 0, -1], [2, 2, 1.5]])


def test_traffic_cars_have_the_car_mesh_box():
    from blender_sesgen.ses import parse_file
    rows = [r for r in object_table(parse_file(REPO / "scenes" / "street_kitti_traffic.ses")) if r["class"] == "car"]
    assert len(rows) == 6
    for r in rows:    # scenes/generators/traffic.py: a 1.8 m wide, 4.3 m long car on the ground, nose +z
        assert np.allclose(r["box"], [[-0.91, 0.0162, -2.15], [0.91, 1.375, 2.15]])


@pytest.mark.parametrize("row", [{"id": 1, "box": [[0, 0, 0], [1, 1]]}, {"id": 1, "box": [[1, 0, 0], [0, 1, 1]]},
                                 {"id": 1, "T_world_obj_rest": [[1, 0, 0, 0]]}])
def test_a_malformed_box_or_rest_pose_names_the_key(row):
    m = {"resolution": [4, 4], "frames": 1, "views": ["left"], "poses": {}, "objects": [row]}
    with pytest.raises(ContractError, match="objects"):
        check_types(m, "manifest.json", 1e9)
