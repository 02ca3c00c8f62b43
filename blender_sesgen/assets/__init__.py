"""Procedural assets: the kinds an ``ASSET`` statement can name, and their mesh generators.

Pure numpy (no bpy): ``generate(kind, size, seed, bend)`` returns a
:class:`~blender_sesgen.assets.mesh.MeshData` in the asset's own frame (SES axes, Y up,
metres); the Blender layer only turns it into one object. The same kind, size, seed and
bend always give the same mesh (bit for bit), so a script fully determines its geometry.

Frame conventions (docs/ses-language.md, *Assets*): the origin is the middle of the
asset's footprint on the ground (y = 0); ``size`` = (x, y, z) extents; its front faces
+z. Strips (road, kerb, sidewalk, verge) start at the origin and run along -z for their
length, curving by ``bend`` degrees (positive = to the left, i.e. counter-clockwise
seen from above), so that consecutive strips join exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

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
    strip: bool = False            # takes ``bend``
    closed: bool = True            # every part is a closed surface (tests check)


def _kinds() -> dict[str, Kind]:
    from . import building, street, vegetation, vehicle
    table = [
        Kind("building", "outdoor", "building",
             "block with real window/door openings, frames, sills, balconies, cornice, flat or gable roof",
             ((12, 26), (9, 20), (9, 16)), "width, height (to the ridge), depth", building.generate),
        Kind("car", "street", "car", "hatchback, saloon or estate: lofted body, glass, wheels, lamps, plates, cabin",
             ((1.72, 1.85), (1.42, 1.55), (3.9, 4.8)), "width, height, length (nose towards +z)",
             vehicle.generate),
        Kind("tree", "nature", "vegetation", "broadleaf tree: trunk, three levels of branches, ~20-60k leaves",
             ((3.5, 8), (5, 14), (3.5, 8)), "crown width, total height, crown depth", vegetation.tree,
             closed=False),
        Kind("conifer", "nature", "vegetation", "spruce-like conifer: whorls of drooping branches with needle sprays",
             ((2.5, 5), (6, 18), (2.5, 5)), "crown width, total height, crown depth", vegetation.conifer,
             closed=False),
        Kind("bush", "nature", "vegetation", "shrub: stems and dense leaf clusters in an ellipsoid",
             ((0.8, 2.2), (0.6, 1.8), (0.8, 2.2)), "width, height, depth", vegetation.bush, closed=False),
        Kind("hedge", "nature", "vegetation", "clipped hedge: leafy core box wrapped in leaves",
             ((2, 8), (0.8, 1.8), (0.6, 1.2)), "length (x), height, thickness", vegetation.hedge, closed=False),
    ]
    table += [
        Kind("road", "street", "road", "asphalt slab with camber, dashed centre / edge lines, patches, covers",
             ((6, 8), (0.3, 0.3), (20, 20)), "width, slab depth, length", street.road, strip=True),
        Kind("kerb", "street", "sidewalk", "kerb stones (road side at -x), chamfered edge",
             ((0.15, 0.25), (0.12, 0.15), (20, 20)), "width, height above the road, length", street.kerb,
             strip=True),
        Kind("sidewalk", "street", "sidewalk", "paving slabs with per-slab tone, slight cross fall",
             ((2.0, 3.5), (0.12, 0.15), (20, 20)), "width, height, length", street.sidewalk, strip=True),
        Kind("verge", "street", "terrain", "grass strip with a gentle relief and worn patches",
             ((2, 5), (0.1, 0.14), (20, 20)), "width, height, length", street.verge, strip=True),
        Kind("pole", "street", "pole", "round post with a cap (for signs)",
             ((0.06, 0.09), (2.4, 3.2), (0.06, 0.09)), "diameter, height, diameter", street.pole),
        Kind("streetlight", "street", "pole", "tapered mast, curved arm reaching towards -x, luminaire",
             ((1.0, 2.0), (6, 9), (0.16, 0.22)), "arm reach, mast height, base diameter", street.streetlight),
        Kind("sign", "street", "traffic sign", "sign plate facing +z (triangle, disc or rectangle) with clamps",
             ((0.6, 0.9), (2.2, 2.8), (0.02, 0.03)), "plate width, height of its centre, thickness", street.sign),
        Kind("traffic_light", "street", "traffic light", "post with a three-lamp head facing +z",
             ((0.3, 0.35), (3.2, 4.0), (0.1, 0.14)), "head width, height, post diameter", street.traffic_light),
        Kind("bin", "street", "static", "wheelie bin or litter bin on a post",
             ((0.55, 0.7), (0.95, 1.1), (0.6, 0.75)), "width, height, depth", street.bin_),
        Kind("bollard", "street", "pole", "bollard with a reflective band and a domed cap",
             ((0.1, 0.16), (0.8, 1.0), (0.1, 0.16)), "diameter, height, diameter", street.bollard),
        Kind("bench", "street", "static", "park bench: metal frame, wooden slats",
             ((1.6, 2.0), (0.8, 0.9), (0.55, 0.65)), "width, height, depth", street.bench),
    ]
    return {k.name: k for k in table}


KINDS: dict[str, Kind] = _kinds()


def default_size(kind: str, seed: int) -> Vec3:
    """The seeded size an asset gets when the script gives none."""
    rng = np.random.default_rng([seed, 7919])
    return tuple(round(float(rng.uniform(lo, hi)), 3) for lo, hi in KINDS[kind].size_ranges)


def generate(kind: str, size, seed: int, bend: float = 0.0) -> MeshData:
    """The mesh of one asset (asset frame, SES axes, metres)."""
    k = KINDS[kind]
    if k.strip:
        return k.generator(tuple(map(float, size)), int(seed), float(bend))
    return k.generator(tuple(map(float, size)), int(seed))
