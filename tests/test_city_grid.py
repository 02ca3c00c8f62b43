"""The city of blocks (blender_sesgen/generators/builtin/city_grid.py) and its route planner
(road_network.py beside it): the car keeps to the right half of the asphalt, turns
only at junctions, never turns back, respects its speed and acceleration limits, and drives
exactly the loop closures asked for; the generated script parses, is the same for the same
seed, and its camera and its moving cars stay on the streets of the script itself."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from blender_sesgen.generators.builtin import city_grid as city_grid_module
from blender_sesgen.generators.builtin import road_network as rn
from blender_sesgen.model import Cuboid
from blender_sesgen.ses import parse_string

SCENES = Path(__file__).resolve().parents[1] / "scenes"


@pytest.fixture(scope="module")
def city_grid():
    return city_grid_module


def _plan(seed, length=900.0, closures=3, direction="mixed", gap_s=30.0, blocks=4):
    rng = np.random.default_rng(seed)
    g = rn.irregular_grid(rng, blocks, blocks, block=(55.0, 85.0)).graph
    p = rn.DriveParams()
    route = rn.plan_route(g, rng, length, closures, gap_s * p.v_max, direction)
    return g, route, p, rn.drive(g, route, 10.0, p, rng)


def _to_polyline(points, poly):
    """Distance from each point to the polyline through ``poly`` (n, 2)."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    L2 = np.maximum((ab ** 2).sum(axis=1), 1e-12)
    t = np.clip(((points[:, None] - a[None]) * ab[None]).sum(axis=2) / L2, 0.0, 1.0)
    return np.linalg.norm(points[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(axis=1)


def _on_street(g, xz, h):
    """For ground points xz (n, 2) with headings h: inside a junction square, or on a street
    segment's asphalt in the half to the right of its axis (as seen along h)."""
    hr = g.half_road
    ok = np.zeros(len(xz), bool)
    for n in g.nodes:
        ok |= np.all(np.abs(xz - n) <= hr + 1e-9, axis=1)
    for a, b in g.edges:
        u = g.heading(a, b)
        r = rn.right_of(u)
        d = xz - g.nodes[a]
        t, lat = d @ u, d @ r
        on = (t >= hr - 1e-9) & (t <= g.length(a, b) - hr + 1e-9) & (np.abs(lat) <= hr)
        right_half = np.sign(h @ u) * lat > 0            # driving along u: right of the axis
        ok |= on & right_half
    return ok


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_car_keeps_right_and_turns_only_at_junctions(seed):
    g, route, p, d = _plan(seed)
    path = rn.route_path(g, route, p, np.random.default_rng(seed))
    assert _on_street(g, path.xz, path.h).all()
    assert _on_street(g, d.xz, d.h).all()
    # headings change only near a junction (the turn's arc), never on a street's straight part
    turning = np.abs(path.kappa) > 0
    near = np.min(np.linalg.norm(path.xz[:, None, :] - g.nodes[None], axis=2), axis=1)
    assert turning.any() and near[turning].max() <= g.half_road + p.r_left + g.lane * np.sqrt(2)
    dh = np.abs(np.diff(np.unwrap(np.arctan2(path.h[:, 0], path.h[:, 1]))))
    assert dh[~turning[:-1] & ~turning[1:]].max() < 1e-9
    # never back the way it came: no U-turns on the graph
    nodes = route.nodes
    assert all(nodes[i + 2] != nodes[i] for i in range(len(nodes) - 2))
    assert all(g.key(a, b) in set(g.edges) for a, b in route.edges)


@pytest.mark.parametrize("seed", [0, 5])
def test_speed_profile_keeps_its_limits_and_stops(seed):
    g, route, p, d = _plan(seed)
    assert d.v.max() <= p.v_max + 1e-9 and d.v[0] == 0 and d.v[-1] <= p.a_dec * 0.1 + 1e-9   # halts at the end
    assert np.all(np.abs(d.a_lat) <= p.a_lat + 1e-6)
    assert d.a_long.max() <= p.a_acc + 1e-9 and d.a_long.min() >= -p.a_dec - 1e-9
    # positions follow the speeds: the distance driven between frames is the mean speed * dt
    ds = np.diff(d.s)
    assert np.allclose(ds, 0.5 * (d.v[:-1] + d.v[1:]) * 0.1, atol=0.02)
    waiting = np.flatnonzero((d.v[:-1] < 1e-9) & (d.v[1:] < 1e-9))
    assert len(waiting[(waiting > 0) & (waiting < len(d.t) - 2)]), "the car stops at some junctions"
    assert np.array_equal(d.xz[waiting], d.xz[waiting + 1]), "a stopped car stands still"


@pytest.mark.parametrize("closures,direction", [(0, "same"), (1, "same"), (3, "mixed"), (2, "opposite"),
                                                (5, "mixed")])
def test_the_route_drives_exactly_the_requested_loop_closures(closures, direction):
    g, route, p, d = _plan(7 + closures, length=1400.0 if closures > 3 else 900.0, closures=closures,
                           direction=direction)
    ev = rn.closure_events(g, route, d, 30.0)
    assert len(ev) == closures
    assert all(e.gap_s >= 30.0 for e in ev)
    want = [direction == "same" or (direction == "mixed" and i % 2 == 0) for i in range(closures)]
    assert [e.same for e in ev] == want
    assert route.length(g) >= (1400.0 if closures > 3 else 900.0)
    # an independent, geometric check: on the streets' straight parts (away from junctions),
    # the camera comes back within 4 m of where it was >= 30 s before exactly in the closures
    hr = g.half_road
    away = np.min(np.max(np.abs(d.xz[:, None, :] - g.nodes[None]), axis=2), axis=1) > hr + 12.0
    back = np.zeros(len(d.t), bool)
    for k in np.flatnonzero(away):
        old = d.t <= d.t[k] - 30.0
        back[k] = old.any() and np.linalg.norm(d.xz[old] - d.xz[k], axis=1).min() < 4.0
    in_closure = np.zeros(len(d.t), bool)
    for e in ev:
        in_closure |= (d.edge >= e.first) & (d.edge <= e.last)
    assert np.array_equal(back & away, in_closure & away)
    # each closure really passes the same places: same direction on the same lane (< 1 cm),
    # the opposite way on the other lane (2 x 1.75 m apart)
    for e in ev:
        k = np.flatnonzero(away & (d.edge >= e.first) & (d.edge <= e.last))
        old = np.flatnonzero(d.t <= e.t_after - 30.0 + 1e-9)
        dist = _to_polyline(d.xz[k], d.xz[old])
        expect = 0.0 if e.same else 2 * g.lane
        assert np.allclose(dist, expect, atol=0.15), (e, dist.min(), dist.max())


def test_routes_are_deterministic_per_seed():
    g1, r1, _, d1 = _plan(11)
    g2, r2, _, d2 = _plan(11)
    assert r1.nodes == r2.nodes and np.array_equal(d1.xz, d2.xz)
    assert _plan(12)[1].nodes != r1.nodes


def test_a_graph_too_small_for_the_route_is_refused():
    g = rn.irregular_grid(np.random.default_rng(0), 2, 2, block=(55.0, 85.0)).graph
    with pytest.raises(rn.RouteError, match="larger city"):
        rn.plan_route(g, np.random.default_rng(0), 5000.0, 3, 300.0, tries=20)


def test_blocks_tile_the_grid_and_joined_blocks_leave_t_junctions():
    bg = rn.irregular_grid(np.random.default_rng(3), 5, 5, block=(55.0, 85.0), drop_fraction=0.3)
    area = sum((x1 - x0) * (z1 - z0) for x0, x1, z0, z1 in bg.blocks())
    assert np.isclose(area, np.ptp(bg.xs) * np.ptp(bg.zs))
    assert len(bg.blocks()) == 25 - len(bg.dropped) and bg.dropped
    g = bg.graph
    assert min(len(v) for v in g.adjacency.values()) >= 2
    for a, b in bg.dropped:
        assert len(g.adjacency[a]) == 3 and len(g.adjacency[b]) == 3


# --- the generator -------------------------------------------------------------------------

def _streets_of(scene):
    """The asphalt rectangles of a parsed city script: (centre x, z, half x, half z)."""
    out = []
    for o in scene.objects:
        if isinstance(o, Cuboid) and o.name.startswith(("street_", "junction_")):
            out.append((o.position[0], o.position[2], o.size[0] / 2, o.size[2] / 2, o.name.startswith("street_")))
    return np.array(out)


def _in_right_half(rects, xz, h):
    """Points on some asphalt rectangle; on a street (not a junction) in the right half
    for heading h (the street's axis is its rectangle's long centre line)."""
    ok = np.zeros(len(xz), bool)
    for cx, cz, hx, hz, street in rects:
        inside = (np.abs(xz[:, 0] - cx) <= hx + 1e-6) & (np.abs(xz[:, 1] - cz) <= hz + 1e-6)
        if street:
            along_x = hx > hz
            lat = (xz[:, 1] - cz) if along_x else (xz[:, 0] - cx)
            u = h[:, 0] if along_x else h[:, 1]
            # right of a heading u along +x is +z, along +z is -x
            inside &= (np.sign(u) * lat * (1 if along_x else -1)) > 0
        ok |= inside
    return ok


def test_small_city_script_parses_and_keeps_camera_and_traffic_on_its_streets(city_grid):
    text = city_grid.generate(5, route_m=400.0, closures=1, traffic=4)
    assert text == city_grid.generate(5, route_m=400.0, closures=1, traffic=4)
    assert text != city_grid.generate(6, route_m=400.0, closures=1, traffic=4)
    s = parse_string(text, source="city.ses")
    assert (s.rig.width, s.rig.height, s.rig.focal_px, s.rig.baseline) == (1226, 370, 707, 0.54)
    assert s.timing.rate_hz == 10.0 and s.fog is not None and s.rig.far == 250.0
    rects = _streets_of(s)
    T = s.timeline.left()
    cam = T[:, :3, 3]
    assert np.allclose(cam[:, 1], 1.65, atol=0.05)
    assert np.linalg.norm(np.diff(cam[:, [0, 2]], axis=0), axis=1).sum() >= 400.0     # the route asked for
    fwd = T[:, :3, 2][:, [0, 2]]
    fwd /= np.linalg.norm(fwd, axis=1, keepdims=True)
    assert _in_right_half(rects, cam[:, [0, 2]], fwd).all()
    assert len(s.object_motions) >= 2
    for m in s.object_motions:
        P = m.poses()
        xz = P[:, :3, 3][:, [0, 2]]
        h = P[:, :3, 2][:, [0, 2]]                   # a car's nose is its +z
        assert _in_right_half(rects, xz, h).all(), m.id
        assert np.linalg.norm(xz - cam[:, [0, 2]], axis=1).min() >= 8.0
    # the header lists the loop closure, and the camera does come back there
    assert "closure 1: frames" in text
    from test_scene_library import assert_cameras_see_surfaces
    assert_cameras_see_surfaces(s, "city_grid", 0.5, frames=range(0, s.frames, 15))


def test_checked_in_city_loop_is_seed_0(city_grid):
    assert city_grid.generate(0) == (SCENES / "city_loop.ses").read_text()


def test_generate_command_makes_city_scripts(tmp_path, capsys):
    from blender_sesgen.cli import main as sesgen
    out = tmp_path / "scripts"
    assert sesgen(["generate", "city_grid", "--count", "2", "--seed", "4", "--out", str(out), "-o", "route_m=150",
                   "-o", "closures=0", "-o", "traffic=1", "--split", "0.5", "0.5", "0"]) == 0
    scripts = sorted(out.glob("*.ses"))
    assert len(scripts) == 2 and scripts[0].read_text() != scripts[1].read_text()
    assert sesgen(["generate", "city_grid", "--count", "1", "--out", str(tmp_path / "bad"), "-o", "route_m=-5"]) != 0
