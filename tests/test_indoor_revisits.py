"""Indoor sequences that come back: the hall's EuRoC-MH-like flight in laps (``flight=laps``)
passes the same places lap after lap, at other heights, through the open middle of the hall
without touching anything; the office's hand-held loop (``walk=loop``) ends where it began,
looking where it looked. The defaults stay the checked-in scripts (test_scene_library)."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.contract.frames import object_pose
from blender_sesgen.scene.model import Asset, Cuboid
from blender_sesgen.ses import parse_string

from test_city_grid import _to_polyline
from test_scene_library import _generator, assert_cameras_see_surfaces


def _boxes(scene, kinds=None, exact=False):
    """(name, lo, hi) world AABBs of the scene's cuboids and assets (size plus the kind's
    overhang; ``exact``: the asset's own mesh)."""
    from blender_sesgen.scene import assets
    out = []
    for o in scene.objects:
        if isinstance(o, Cuboid) and kinds is None:
            lo, hi = -np.asarray(o.size) / 2, np.asarray(o.size) / 2
        elif isinstance(o, Asset) and (kinds is None or o.kind in kinds):
            w, h, d = o.size
            m = assets.KINDS[o.kind].overhang
            lo, hi = np.array([-w / 2 - m, 0.0, -d / 2 - m]), np.array([w / 2 + m, h + m, d / 2 + m])
            if exact:
                lo, hi = assets.generate(o.kind, o.size, o.seed, o.bend, o.offset).bounds
        else:
            continue
        T = object_pose(o.position, o.rotation_deg)
        c = np.array([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        w = c @ T[:3, :3].T + T[:3, 3]
        out.append((o.name, w.min(axis=0), w.max(axis=0)))
    return out


@pytest.fixture(scope="module")
def hall_laps():
    text = _generator("hall").generate(0, flight="laps", laps=3, speed=1.2)
    return parse_string(text, source="hall_laps.ses")


def test_hall_laps_pass_the_same_places_lap_after_lap(hall_laps):
    s = hall_laps
    P = s.timeline.left()[:, :3, 3]
    n = len(P)
    per_lap = (n - 1) / 3
    assert 20.0 * per_lap / 20.0 > 20                      # laps of tens of seconds at 20 Hz
    lap = np.minimum((np.arange(n) / per_lap).astype(int), 2)
    ground = P[:, [0, 2]]
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ground, axis=0), axis=1))])
    L = dist[-1] / 3
    for k in np.flatnonzero(dist > L + 1.0)[::7]:          # every place after the first lap ...
        before = ground[dist <= dist[k] - 0.7 * L]          # ... was passed at least 0.7 laps before
        assert _to_polyline(ground[k:k + 1], before)[0] < 0.8, k
    for k in (1, 2):
        heights = P[lap == k][:, 1], P[lap == k - 1][:, 1]
        assert abs(np.median(heights[0]) - np.median(heights[1])) > 0.02   # ... at another height
    assert 0.9 <= P[:, 1].min() and P[:, 1].max() <= 2.5
    speed = np.linalg.norm(np.diff(P, axis=0), axis=1) * 20.0
    assert 0.6 < np.median(speed) < 1.8 and speed.max() < 2.5


@pytest.mark.parametrize("seed, laps", [(0, 3), (2, 2), (5, 2)])
def test_hall_laps_look_again_where_they_looked(seed, laps):
    """A revisit for place recognition: every pose after the first lap has a pose at least 0.7
    laps earlier within 1.5 m whose optical axis is within 30 deg of its own (before the
    look-around followed the place on the loop, a fifth of the second lap's poses had one
    for some seeds)."""
    s = parse_string(_generator("hall").generate(seed, flight="laps", laps=laps, speed=1.0), source="laps.ses")
    T = s.timeline.left()
    P, axis = T[:, :3, 3], T[:, :3, 2]
    ground = P[:, [0, 2]]
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ground, axis=0), axis=1))])
    L = dist[-1] / laps
    yaw = np.degrees(np.arctan2(axis[:, 0], axis[:, 2]))
    assert np.ptp(yaw[dist < L]) > 300                        # it still looks all around the hall
    for k in np.flatnonzero(dist > L + 1.0)[::5]:
        near = np.flatnonzero((dist <= dist[k] - 0.7 * L) & (np.linalg.norm(P - P[k], axis=1) < 1.5))
        assert len(near), k
        angle = np.degrees(np.arccos(np.clip(axis[near] @ axis[k], -1.0, 1.0))).min()
        assert angle < 30.0, (k, angle)


def test_hall_laps_touch_nothing_and_see_surfaces(hall_laps):
    s = hall_laps
    P = s.timeline.left()[:, :3, 3]
    for name, lo, hi in _boxes(s):
        if name in ("floor", "roof") or hi[1] - lo[1] > 9:   # the shell and columns are around, not in the way
            continue
        inside = np.all((P > lo - 0.3) & (P < hi + 0.3), axis=1)
        assert not inside.any(), name
    assert_cameras_see_surfaces(s, "hall", 0.75, frames=range(0, s.frames, 25))


def test_the_default_hall_and_office_are_unchanged_by_the_new_options():
    hall, office = _generator("hall"), _generator("office")
    assert hall.generate(0) == hall.generate(0, flight="sweep")
    assert office.generate(0) == office.generate(0, walk="aisle")
    with pytest.raises(ValueError):
        hall.generate(0, flight="circles")
    with pytest.raises(ValueError):
        office.generate(0, walk="run")


@pytest.mark.parametrize("seed", [0, 4])
def test_office_loop_ends_where_it_began_looking_the_same_way(seed):
    text = _generator("office").generate(seed, walk="loop")
    s = parse_string(text, source="office_loop.ses")
    T = s.timeline.left()
    P = T[:, :3, 3]
    assert s.frames > 600                                    # ~ 30 s at 30 Hz
    assert np.linalg.norm(P[-1, [0, 2]] - P[0, [0, 2]]) < 0.05
    assert abs(P[-1, 1] - P[0, 1]) < 0.12                     # the eye height wanders a little
    cos = float(T[0][:3, 2] @ T[-1][:3, 2])
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))) < 15.0  # hand shake apart, the same view
    far = np.linalg.norm(P[:, [0, 2]] - P[0, [0, 2]], axis=1).max()
    assert far > 4.0                                          # it went around the room first
    # inside the room (7 x 9 m), clear of the walls and the bookcases along the east wall
    assert np.all(np.abs(P[:, 0]) < 3.5 - 0.3) and np.all(np.abs(P[:, 2]) < 4.5 - 0.3)
    for name, lo, hi in _boxes(s, kinds=("shelf",), exact=True):
        assert not np.any(np.all((P > lo - 0.1) & (P < hi + 0.1), axis=1)), name
    assert_cameras_see_surfaces(s, "office", 0.8, frames=range(0, s.frames, 40))


@pytest.mark.parametrize("name, kwargs", [
    ("hall", {"flight": "laps", "laps": 1, "speed": 1.5}),
    ("office", {"walk": "loop", "frames": 120}),
    ("city_grid", {"route_m": 150.0, "closures": 1, "gap_s": 6.0, "blocks": 2, "traffic": 3, "haze": False}),
])
def test_the_header_names_the_command_that_writes_the_script(name, kwargs, capsys):
    """The script's ``// Generated by FILE --flags`` line, run as the generator's command
    line, writes the same script as ``generate`` with those options."""
    import shlex
    from blender_sesgen.generators.builtin.sesgen_layout import command_line
    module = _generator(name)
    text = module.generate(0, **kwargs)
    header = next(line for line in text.splitlines() if line.startswith("// Generated by "))
    argv = shlex.split(header.split(" (edit that")[0])[4:]
    assert argv[:2] == ["--seed", "0"]
    command_line(module.generate, module.__doc__, None, argv)
    assert capsys.readouterr().out == text
