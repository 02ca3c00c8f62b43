"""Procedural assets: the kinds an ``ASSET`` statement can name, and their mesh generators.

Pure numpy (no bpy): ``generate(kind, size, seed, bend)`` returns a
:class:`~blender_sesgen.scene.assets.mesh.MeshData` in the asset's own frame (SES axes, Y up,
metres); the Blender layer only turns it into one object. The same kind, size, seed and
bend always give the same mesh (bit for bit), so a script fully determines its geometry.

Frame conventions (docs/ses-language.md, *Assets*): the origin is the middle of the
asset's footprint on the ground (y = 0); ``size`` = (x, y, z) extents; its front faces
+z. Strips (road, kerb, gutter, sidewalk, verge) follow a centreline that starts at the origin,
runs along -z and turns by ``bend`` degrees per equal piece (positive = left), lying
``offset`` to its right (see ``street``), so the strips of one street fit exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..model import Material
from .mesh import MeshData, Surface  # noqa: F401  (re-exported)

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Kind:
    name: str
    family: str                    # outdoor | street | indoor | industrial | nature
    semantic_class: str            # default class (Cityscapes names + indoor classes)
    summary: str                   # one line for the docs
    size_ranges: tuple             # ((lo, hi) for x, y, z): a seeded default size
    size_meaning: str              # what x, y, z mean for this kind
    generator: Callable            # (size, seed) or (size, seed, bend) -> MeshData
    strip: bool = False            # takes ``bend`` and ``offset``
    closed: bool = True            # every part is a closed surface (tests check)
    overhang: float = 0.5          # how far parts may reach beyond ``size`` (balconies, arms, branches), m


def _kinds() -> dict[str, Kind]:
    from . import building, indoor, industrial, nature, street, street_detail, flight_arena, vegetation, vehicle
    table = [
        Kind("building", "outdoor", "building",
             "block with real window/door openings, frames, sills, roller shutters (6 in 10 buildings; some "
             "lowered), balconies, cornice, flat or gable roof; downpipes at the corners, eaves gutters, attic "
             "windows in the gables, roof windows in some slopes",
             ((12, 26), (9, 20), (9, 16)), "width, height (to the ridge), depth", building.generate, overhang=3.0),
        Kind("building_shell", "outdoor", "building",
             "block under construction: bare walls, unglazed openings into dark rooms, slab edges, flat roof",
             ((12, 40), (9, 20), (9, 22)), "width, height, depth", building.shell, overhang=0.1),
        Kind("car", "street", "car", "hatchback, saloon or estate: lofted body, glass showing the cabin's "
             "headrests, alloy wheels in arches, faceted lamps, plates with characters, mirrors, door and lid "
             "shut lines, bumper ledge, third brake lamp, wiper",
             ((1.72, 1.85), (1.42, 1.55), (3.9, 4.8)), "width, height, length (nose towards +z)",
             vehicle.generate),
        Kind("tree", "nature", "vegetation", "broadleaf tree: trunk, three levels of branches, ~20-60k leaves",
             ((3.5, 8), (5, 14), (3.5, 8)), "crown width, total height, crown depth", vegetation.tree,
             closed=False, overhang=2.0),
        Kind("garden_tree", "nature", "vegetation", "young garden tree: slim stem, laterals all up the leader, "
             "twigs, ~3-20k small leaves (5-8 cm) in open sprays", ((1.6, 3.2), (3.5, 6.5), (1.2, 3.2)),
             "crown width, total height, crown depth", vegetation.garden_tree, closed=False, overhang=0.3),
        Kind("conifer", "nature", "vegetation", "spruce-like conifer: whorls of drooping branches with needle sprays",
             ((2.5, 5), (6, 18), (2.5, 5)), "crown width, total height, crown depth", vegetation.conifer,
             closed=False, overhang=0.7),
        Kind("bush", "nature", "vegetation", "shrub: stems and dense leaf clusters in an ellipsoid",
             ((0.8, 2.2), (0.6, 1.8), (0.8, 2.2)), "width, height, depth", vegetation.bush, closed=False),
        Kind("hedge", "nature", "vegetation", "clipped hedge: leafy core box wrapped in leaves",
             ((2, 8), (0.8, 1.8), (0.6, 1.2)), "length (x), height, thickness", vegetation.hedge, closed=False),
        Kind("house", "outdoor", "building",
             "building whose ground floor is set back 1.4-2.0 m under the storeys above over most of its front "
             "(its front door, windows, letterboxes and a lamp in the recess)", ((12, 26), (9, 20), (9, 16)),
             "width, height (to the ridge), depth", building.house, overhang=3.0),
    ]
    table += [
        Kind("road", "street", "road", "asphalt slab with camber, dashed centre / edge lines, patches, covers",
             ((6, 8), (0.3, 0.3), (20, 20)), "width, slab depth, length", street.road, strip=True),
        Kind("kerb", "street", "sidewalk", "kerb stones (road side at -x), chamfered edge",
             ((0.15, 0.25), (0.12, 0.15), (20, 20)), "width, height above the road, length", street.kerb,
             strip=True),
        Kind("gutter", "street", "road", "flush gutter of light concrete blocks (road side at -x), falling to the road",
             ((0.3, 0.5), (0.0, 0.03), (20, 20)), "width, height above the road, length", street.gutter, strip=True),
        Kind("sidewalk", "street", "sidewalk", "concrete pavers (paving) in slabs of per-slab tone, slight cross fall",
             ((2.0, 3.5), (0.12, 0.15), (20, 20)), "width, height, length", street.sidewalk, strip=True),
        Kind("verge", "street", "terrain", "grass strip with a gentle relief and worn patches",
             ((2, 5), (0.1, 0.14), (20, 20)), "width, height, length", street.verge, strip=True),
        Kind("pole", "street", "pole", "round post with a cap (for signs)",
             ((0.06, 0.09), (2.4, 3.2), (0.06, 0.09)), "diameter, height, diameter", street.pole),
        Kind("streetlight", "street", "pole", "tapered mast, curved arm reaching towards -x, luminaire",
             ((1.0, 2.0), (6, 9), (0.16, 0.22)), "arm reach, mast height, base diameter", street.streetlight, overhang=2.7),
        Kind("sign", "street", "traffic sign", "sign plate facing +z (triangle, disc or rectangle) with clamps",
             ((0.6, 0.9), (2.2, 2.8), (0.02, 0.03)), "plate width, height of its centre, thickness", street.sign),
        Kind("traffic_light", "street", "traffic light", "post with a three-lamp head facing +z",
             ((0.3, 0.35), (3.2, 4.0), (0.1, 0.14)), "head width, height, post diameter", street.traffic_light),
        Kind("bin", "street", "static", "wheelie bin or litter bin on a post",
             ((0.55, 0.7), (0.95, 1.1), (0.6, 0.75)), "width, height, depth", street.bin_, overhang=0.8),
        Kind("bollard", "street", "pole", "bollard with a reflective band and a domed cap",
             ((0.1, 0.16), (0.8, 1.0), (0.1, 0.16)), "diameter, height, diameter", street.bollard),
        Kind("fence", "street", "fence", "garden fence along x: wooden pickets, steel bars or a low wall, posts",
             ((3, 12), (0.8, 1.3), (0.1, 0.3)), "length, height, thickness", street.fence),
        Kind("bench", "street", "static", "park bench: metal frame, wooden slats",
             ((1.6, 2.0), (0.8, 0.9), (0.55, 0.65)), "width, height, depth", street.bench),
        Kind("scaffold", "street", "building", "facade scaffolding: tube standards, ledgers, transoms, braces, "
             "boarded lifts every 2 m, guard rails and toe boards (wall side -z)",
             ((6, 20), (6, 15), (0.7, 1.1)), "length, height, depth", street_detail.scaffold, overhang=0.2),
        Kind("site_fence", "street", "fence", "mobile construction fence along x: welded-mesh panels in "
             "concrete feet, a few with banners", ((3.5, 14), (1.9, 2.1), (0.6, 0.7)),
             "length, height, depth of the feet", street_detail.site_fence, overhang=0.1),
        Kind("tree_stakes", "street", "pole", "a young tree's stakes: 2-4 round posts around the trunk, "
             "battens, ties (the tree not included)", ((0.6, 0.9), (1.8, 2.6), (0.6, 0.9)),
             "spread, height, spread", street_detail.tree_stakes, overhang=0.2),
        Kind("bike_rack", "street", "bicycle", "row of Sheffield stands along x with bicycles (wheels, spokes, "
             "frame, bars, saddle) parked at some", ((1.8, 5.4), (0.8, 0.9), (1.7, 1.9)),
             "row length, stand height, bicycle length", street_detail.bike_rack, overhang=0.4),
        Kind("bicycles", "street", "bicycle", "bicycles on their kickstands side by side along x, each along z "
             "(wheels, spokes, frame, bars, saddle), about half turned round", ((0.6, 3.0), (0.95, 1.1), (1.7, 1.9)),
             "row length, handlebar height, bicycle length", street_detail.bicycles, overhang=0.45),
        Kind("bin_store", "street", "static", "a front garden's bin enclosure: timber posts, walls and doors of "
             "slats with gaps into its dark inside, bins in it, a lid of boards", ((1.3, 2.3), (1.15, 1.4), (0.75, 0.9)),
             "length, height, depth (doors towards +z)", street_detail.bin_store, overhang=0.1),
        Kind("notice_board", "street", "static", "notice board on two posts: a framed board of notices with lines "
             "of print, a small roof (face towards +z)", ((0.9, 1.6), (1.8, 2.2), (0.1, 0.15)),
             "width, height of the posts, depth of its roof", street_detail.notice_board, overhang=0.1),
    ]
    table += [
        Kind("table", "indoor", "table", "table: top on four legs with an apron",
             ((0.8, 1.8), (0.72, 0.76), (0.7, 1.0)), "width, height, depth", indoor.table),
        Kind("desk", "indoor", "table", "office desk: top, side panel, drawer block, modesty panel",
             ((1.2, 1.8), (0.72, 0.76), (0.7, 0.85)), "width, height, depth", indoor.desk),
        Kind("chair", "indoor", "chair", "four-legged chair or office chair (five-star base)",
             ((0.42, 0.5), (0.85, 1.0), (0.45, 0.52)), "width, height, depth (seat faces +z)", indoor.chair),
        Kind("shelf", "indoor", "shelf", "bookcase open towards +z, filled with books, boxes, stacks",
             ((0.8, 1.2), (1.8, 2.2), (0.3, 0.38)), "width, height, depth", indoor.shelf),
        Kind("cabinet", "indoor", "cabinet", "cabinet with doors or drawers and handles",
             ((0.8, 1.2), (0.75, 1.2), (0.4, 0.5)), "width, height, depth", indoor.cabinet),
        Kind("sofa", "indoor", "sofa", "sofa: soft arms, back and cushions on wooden feet",
             ((1.6, 2.4), (0.8, 0.9), (0.85, 0.95)), "width, height, depth (seat faces +z)", indoor.sofa),
        Kind("door", "indoor", "door", "door leaf in a frame with architraves and handles",
             ((0.8, 1.0), (2.0, 2.1), (0.12, 0.2)), "opening width, opening height, wall thickness", indoor.door),
        Kind("picture", "indoor", "picture", "framed print facing +z, its back at z = 0",
             ((0.4, 1.0), (1.5, 1.7), (0.02, 0.04)), "width, height of its centre, depth", indoor.picture, overhang=0.6),
        Kind("ceiling_light", "indoor", "lamp", "light panel (emissive light_panel diffuser facing down), "
             "flush or on wires; top at y = 0", ((0.6, 1.2), (0.05, 0.8), (0.2, 0.6)),
             "width, hanging length (< 0.1: flush), depth", indoor.ceiling_light, overhang=0.8),
        Kind("window_frame", "indoor", "window", "open window frame with bars and a sill board, for a wall "
             "opening (room side +z)", ((1.0, 2.0), (1.2, 1.6), (0.2, 0.35)),
             "opening width, opening height, wall thickness", indoor.window_frame),
        Kind("plant", "indoor", "vegetation", "pot plant: pot, soil, stems with leaves",
             ((0.4, 0.8), (0.6, 1.4), (0.4, 0.8)), "width, height, depth", indoor.plant, closed=False, overhang=0.6),
        Kind("monitor", "indoor", "screen", "computer monitor on a stand, screen facing +z",
             ((0.5, 0.65), (0.45, 0.55), (0.18, 0.22)), "width, height, depth", indoor.monitor),
        Kind("radiator", "indoor", "static", "panel radiator on brackets with a valve, back at z = 0",
             ((0.8, 1.6), (0.7, 0.8), (0.1, 0.12)), "width, height of its top, depth", indoor.radiator),
        Kind("whiteboard", "indoor", "picture", "whiteboard with frame, marker tray and writing, back at z = 0",
             ((1.2, 2.0), (1.4, 1.6), (0.03, 0.03)), "width, height of its centre, depth", indoor.whiteboard,
             overhang=0.6),
        Kind("rug", "indoor", "floor", "rug with a border", ((1.4, 3.0), (0.006, 0.012), (1.0, 2.2)),
             "width, thickness, depth", indoor.rug),
        Kind("crash_mat", "indoor", "static", "gym landing mat lying flat: foam in a vinyl cover quilted in "
             "channels across x, rounded edges, webbing handles, a label", ((1.5, 3.0), (0.2, 0.4), (1.0, 2.0)),
             "length, thickness, width", flight_arena.crash_mat, overhang=0.1),
        Kind("play_mat", "indoor", "floor", "printed vinyl play mat: roads with dashed lines, blocks of colour, "
             "a roundabout", ((1.0, 2.0), (0.003, 0.005), (1.5, 2.5)), "width, thickness, depth", flight_arena.play_mat),
        Kind("cable", "indoor", "static", "cable lying on the floor, wandering along x, a plug at one end",
             ((1.5, 5.0), (0.008, 0.015), (0.2, 1.0)), "length, diameter, wander", flight_arena.cable, overhang=0.1),
        Kind("column", "industrial", "building", "steel H column on a base plate (stripes) or concrete column",
             ((0.3, 0.45), (6, 12), (0.3, 0.45)), "width, height, depth", industrial.column),
        Kind("girder", "industrial", "building", "I-beam along x with stiffeners; origin mid bottom flange",
             ((8, 20), (0.5, 0.9), (0.25, 0.35)), "length, depth, flange width", industrial.girder),
        Kind("rack", "industrial", "shelf", "pallet rack with beam levels, pallets and cardboard loads",
             ((5, 11), (4, 7), (1.0, 1.2)), "length, height, depth", industrial.rack),
        Kind("machine", "industrial", "static", "industrial machine: housing, panels, control cabinet, duct",
             ((2.5, 5), (1.8, 3.2), (1.5, 3)), "width, height, depth", industrial.machine, overhang=1.2),
        Kind("tank", "industrial", "static", "vertical tank on legs with a domed top and a ladder",
             ((1.5, 3), (3, 6), (1.5, 3)), "diameter, height, diameter", industrial.tank),
        Kind("crate", "industrial", "static", "wooden crate with battens", ((0.8, 1.6), (0.6, 1.2), (0.8, 1.4)),
             "width, height, depth", industrial.crate),
        Kind("pallet", "industrial", "static", "wooden pallet", ((1.2, 1.2), (0.14, 0.14), (0.8, 1.0)),
             "width, height, depth", industrial.pallet),
        Kind("barrel", "industrial", "static", "steel drum with rolling hoops", ((0.58, 0.6), (0.85, 0.9), (0.58, 0.6)),
             "diameter, height, diameter", industrial.barrel),
        Kind("stairs", "industrial", "stairs", "steel stair rising towards -z with handrails",
             ((0.9, 1.4), (2.5, 4.5), (3, 6)), "width, rise, run", industrial.stairs, overhang=1.1),
        Kind("railing", "industrial", "fence", "guard railing along x with a kick plate",
             ((3, 10), (1.0, 1.1), (0.05, 0.05)), "length, height, thickness", industrial.railing),
        Kind("pipe", "industrial", "static", "pipe run along x with flanges and supports",
             ((6, 20), (1.5, 4), (0.15, 0.4)), "length, axis height, diameter", industrial.pipe),
        Kind("terrain", "nature", "terrain", "rolling ground (0.5 m grid following the trail's meander along z): "
             "bare trail, grassy margins, leaf-litter floor",
             ((60, 120), (2, 6), (100, 200)), "width, relief amplitude, depth", nature.terrain, closed=False,
             overhang=18.0),
        Kind("rock", "nature", "terrain", "boulder: displaced icosphere, moss on top",
             ((0.4, 2.5), (0.3, 1.5), (0.4, 2.5)), "width, height, depth", nature.rock),
        Kind("litter", "nature", "terrain", "fallen leaves and twigs lying on the ground over a patch",
             ((2, 4), (0.05, 0.05), (2, 4)), "width, -, depth", nature.litter, closed=False),
        Kind("log", "nature", "vegetation", "fallen log along x with branch stubs",
             ((3, 8), (0.25, 0.6), (0.25, 0.6)), "length, diameter, diameter", nature.log, overhang=1.0),
        Kind("stump", "nature", "vegetation", "tree stump with root flares", ((0.4, 0.8), (0.3, 0.8), (0.4, 0.8)),
             "width, height, depth", nature.stump, overhang=0.7),
        Kind("fern", "nature", "vegetation", "arching fronds of leaflets", ((0.6, 1.4), (0.3, 0.7), (0.6, 1.4)),
             "width, height, depth", nature.fern, closed=False),
        Kind("grass_tuft", "nature", "terrain", "clump of grass blades (800 per m² at 35 cm and above; shorter ones as a "
             "mown sward: denser, at the same leaf area, in 6 cm clumps)", ((0.3, 0.8), (0.2, 0.5), (0.3, 0.8)),
             "width, height, depth", nature.grass_tuft, closed=False),
    ]
    return {k.name: k for k in table}


KINDS: dict[str, Kind] = _kinds()

# Materials some assets need that the library has not (a script's MATERIAL of the same
# name replaces them): the diffuser of ceiling_light, which glows.
ASSET_MATERIALS: dict[str, Material] = {
    "light_panel": Material(name="light_panel", colour=(0.85, 0.85, 0.83), roughness=0.3,
                            emission=(1.0, 0.97, 0.92), emission_strength=15.0),
}


def default_size(kind: str, seed: int) -> Vec3:
    """The seeded size an asset gets when the script gives none."""
    rng = np.random.default_rng([seed, 7919])
    return tuple(round(float(rng.uniform(lo, hi)), 3) for lo, hi in KINDS[kind].size_ranges)


def mesh_key(obj) -> tuple:
    """What makes two ASSET objects share one mesh in Blender (their geometry and the material
    tags of their main surface): equal keys, one mesh."""
    return (obj.kind, tuple(obj.size), obj.seed, tuple(obj.bend), obj.offset, obj.material, tuple(obj.colour),
            obj.texture, getattr(obj, "ground_material", None))


def generate(kind: str, size, seed: int, bend=(0.0,), offset: float = 0.0) -> MeshData:
    """The mesh of one asset (asset frame, SES axes, metres)."""
    k = KINDS[kind]
    if k.strip:
        return k.generator(tuple(map(float, size)), int(seed), tuple(map(float, np.atleast_1d(bend))),
                           float(offset))
    return k.generator(tuple(map(float, size)), int(seed))
