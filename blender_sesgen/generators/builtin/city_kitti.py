"""Writes scenes/city_kitti.ses: an urban street seen by the KITTI odometry rig.

A two-lane street of gentle curves (a chain of arcs) with kerbs, a tree lawn and sidewalks;
each side a residential cross-section (``FRONTAGES``: blocks behind front yards, houses
behind hedged yards, or an open lawn before low houses) of buildings (real window openings,
balconies, gable or flat roofs) alternating with green strips; street trees, hedges and bushes; parked cars along
the kerbs; street lights, signs on poles, bins and bollards; near-field detail (scaffolding and
site fences at buildings under works, bike racks, young trees in stakes); a sun and a physical sky.
Trees, bushes, cars, street lights and bins are a few variants per kind (``POOLS``), so
that Blender shares their meshes and Cycles instances them (docs/rendering.md#speed).
The rig is KITTI's (1226 x 370 px, f = 707 px, baseline 0.54 m, camera 1.65 m above the
road) and drives in the right lane at ~1.2 m per frame (KITTI's 10 Hz at ~43 km/h),
keeping its lane with small steering, speed, pitch and roll variations. Moving traffic
(``traffic`` cars, MOVE keyframes along the street's curves): cars ahead in the rig's lane
driving on at about its speed and oncoming cars in the other lane, never within 10 m of the
rig's car or 8 m of each other; the camera's auto-exposure follows the scene (AUTOEXPOSURE).
Seed 0 scripts its near field after KITTI sequence_1's frames (``KITTI_S1_NEAR``): a 4 m
carriageway driven near its middle, the lawn from the left kerb, a parking bay on the right
with the two cars where sequence_1 shows them, its right front row 7-10 m right of the camera
to 37 m ahead behind front gardens (a hedge or shrubs along their edge, bikes, planters, bins,
young garden trees every 10-13.5 m and between the houses, which have no balconies; no trees on
its grass strip), beyond a gap a deep block under
scaffolding whose end wall faces the camera 60 m ahead, on the left a loose row of young trees
10-16 m out on the lawn and the houses facing the street 23-24 m left, and its traffic 100-130 m
ahead, none oncoming.

    python -m blender_sesgen.generators.builtin.city_kitti [--seed N] [--frames N] > scenes/city_kitti.ses

``generate(seed, **options)`` returns the script (the checked-in file is seed 0). Every seed
lays out its own street (curves, widths, buildings, trees, cars); a seed other than 0 also
varies (:class:`Variation`) the time of day (sun elevation 12-65 deg, any azimuth) or, one
time in three, a bundled daylight HDRI (city, courtyard, forest, sunrise, sunset) at a random
strength and rotation, haze one time in four, the asphalt (tone, wear) and the paving, and
the drive: 0.8-1.5 m per frame, 1-3 curves of 5-18 deg, the lane position and weave, and
each side's cross-section and how full its kerb is parked (seed 0: KITTI sequence_1's, an
open lawn left and blocks right, two cars parked 15 and 40 m ahead, the right kerb parked at
0.24 of its slots from 100 m on, none on the left).
``frames`` sets the sequence length; ``step_m``, ``sun_elevation``, ``sun_azimuth`` override
the seed's (a sun given replaces an HDRI); ``traffic`` the number of moving cars (0: a
static street).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from ...scene.assets import default_size, generate as asset_mesh
from ...scene.assets.street import arc_frame
from .city_grid import _keyframes as keyframes
from .sesgen_layout import (KITTI_CAMERA_HEIGHT, Frontage, Ids, Lighting, asset, command_line, derived_material, draw_lighting,
                           draw_street_surfaces, kerb_cars, kitti_rig, line_street_side, num, nums,
                           script_with_poses, SeededVariation, smooth_noise, street_lights, variation_rng, VariantPool)

KITTI_RIG = kitti_rig(far=600)
CAMERA_HEIGHT = KITTI_CAMERA_HEIGHT
PIECE = 20.0                 # centreline pieces (m)
# the sky's haze (WORLD sky aerosol) in the KITTI camera's band: it sees 400-1000 nm (``nir 0.2``),
# where the sky is far darker than in the visible (Rayleigh ~ lambda^-4), so its sun-to-sky
# ratio is ~1.15x the RGB sky model's; at 2.5 the model's sun lights open ground 5.2x as much as
# the sky at a 40 deg sun (bench/calibrate_sky_sun.py's table; 4.5 at 4, 6.8 at the default 1).
# KITTI sequence_1's sunlit over shadowed asphalt is 4.6-6.3, median 5.5 (frames 0-40, car and
# tree shadows); the render's like shadows gave 4.8 at 4 and about the same at 2.5: their light
# is more the surroundings' than the sky's (docs/sensors.md, Camera twins)
HAZE_AEROSOL = 2.5
# KITTI sequence_1's sun, measured from its shadows on the road (frame 40: a street tree's crown
# shadow lies 4.4 m from its trunk, 76 deg right of straight ahead and slightly away; frame 0: the
# car ahead throws its shadow to the right): the sun stands left of the drive and a little behind
# (azimuth -104 deg from the rig's first heading, elevation ~40 deg), so the camera sees the lit
# sides of trees, lawns and right-hand facades, not their shaded ones against the light
# (docs/sensors.md, Camera twins)
KITTI_S1_SUN = (40.0, -104.0)
LANE_M = 1.75                # moving cars' centre from the centreline (parked ones stand further out)
TRAFFIC_GAP_M = (10.0, 8.0)  # least distance along the street to the rig's car, and between two cars of a lane
# asset variants per kind (VariantPool: identical assets share one mesh, Cycles instances it);
# buildings, hedges, fences, poles and signs keep their own sizes (they follow the lots)
POOLS = {"tree": 6, "lawn_tree": 5, "young_tree": 4, "conifer": 3, "bush": 6, "car": 8, "streetlight": 2, "bin": 3}
POOL_SIZES = {   # the street trees' sizes (m: crown width, height, crown depth)
    "lawn_tree": lambda r: (round(float(r.uniform(3.0, 5.5)), 2), round(float(r.uniform(6, 11)), 2),
                            round(float(r.uniform(3.0, 5.5)), 2)),
    "young_tree": lambda r: (round(float(r.uniform(2.5, 4.0)), 2), round(float(r.uniform(5, 8)), 2),
                             round(float(r.uniform(2.5, 4.0)), 2))}
# the cross-sections of residential streets, per side (what lies between the sidewalk and the
# facades decides whether the sun reaches the road): ``block`` - 3-6 storeys behind front yards
# of 4-12 m; ``yards`` - 2-4 storey houses behind hedged front yards of 5-12 m; ``open`` - a
# public lawn of 14-28 m before low houses (KITTI sequence_1's left side: its frames 0-45)
FRONTAGES = {
    "block": Frontage(),
    "yards": Frontage(p_green=0.25, width=(10.0, 18.0), depth=(9.0, 13.0), height_low=(6.0, 9.5),
                      height_high=(9.5, 13.0), p_high=0.35, setback=(5.0, 12.0), p_second_row=0.4, p_yard_edge=0.9),
    "open": Frontage(p_green=0.3, green_depth=(8.0, 26.0), width=(10.0, 16.0), depth=(9.0, 12.0),
                     height_low=(6.0, 9.0), height_high=(9.0, 11.0), p_high=0.15, setback=(14.0, 28.0),
                     gap=(3.0, 10.0), p_second_row=0.2, p_yard_edge=0.0)}
FRONTAGE_ODDS = {"block": 0.35, "yards": 0.45, "open": 0.2}
SPEED_RMS = 0.06   # a drive's speed wander, RMS over its mean step (cycles per 100 frames)


@dataclass(frozen=True)
class NearField:
    """A street's carriageway, kerbs and what stands and drives near the camera, scripted from
    a real sequence's frames (seed 0: KITTI sequence_1's) where other seeds draw theirs (two
    lanes of 4.7-5 m, cars parked at the road's edges, traffic both ways). Distances in metres
    from the street's centreline (+ right) or ahead of the first camera along the street."""
    half_road: float        # half the carriageway
    bay: float              # a paved parking bay, flush with the road, right of the carriageway
    walk_left: float        # the left sidewalk's width (0: the lawn starts at the kerb)
    car_offset: float       # the parked cars' centres in the bay
    parked_ahead: tuple     # the right kerb's parked cars (their centres) ahead of the first camera ...
    parked_clear: float     # ... and none other up to this far ahead
    traffic_lane: float     # the moving cars' centre off the centreline
    traffic_ahead: tuple    # the nearest car ahead in the rig's lane at frame 0 (range drawn)
    oncoming: bool          # whether cars come the other way
    white_right: float = 0.0    # the right-hand buildings up to this far ahead have a white render (0: drawn)
    works_right: tuple = ()     # (from, to) ahead: a deep block under scaffolding on the right, its end wall facing the camera ...
    works_depth: float = 0.0    # ... this deep (m) ...
    works_front: float = 0.0    # ... its street scaffold's front this far right of the centreline, a site fence before it (0: the setback's)
    open_right: float = 0.0     # ... and no front-row building from this far ahead to it (a side street's mouth)
    bikes_right: tuple = ()     # bike racks on the right sidewalk this far ahead
    lawn_right: float = 0.0     # the right tree lawn's and sidewalk's widths (0: drawn) ...
    walk_right: float = 0.0
    setback_right: tuple = ()   # ... and the right front row's setback range behind the sidewalk (empty: drawn)
    gutter_right: float = 0.0   # a light concrete gutter this wide between the carriageway and the bay
    trees_left: tuple = ()      # (from, to) ahead, (near, far) left of the centreline: a loose row of young trees on the lawn
    setback_left: tuple = ()    # the left front row's setback range behind the left kerb up to LEFT_ROW_M ahead (empty: drawn)
    gardens_right: tuple = ()   # (from, to) ahead: front gardens before the right front row (``GARDEN``), the tree lawn treeless
    speed_rms: float = SPEED_RMS  # the drive's speed wander, RMS over the mean step


# KITTI sequence_1's street, measured in its frames (ground plane 1.65 m under the camera, f 707
# px; SGBM for the cars; docs/sensors.md, Camera twins): the left kerb 1.84 m left of the left
# camera and the edge of a cobbled parking bay 2.17 m right of it (frame 12, row 360: a 4.0 m
# carriageway without markings, the camera 0.17 m left of its middle); the lawn starts at the
# left kerb (no sidewalk), its young trees ~4 m left of the camera (frame 12); two cars parked
# in the bay, 3.3 m right of the camera, their rears 13.3 m and 38.0 m ahead in frame 0 (passed
# at frames ~10 and ~28), and no other at the right kerb through frame 50 (~60 m further); no
# moving car in its 51 frames: none ahead in the lane in the ~100 m its frames see, none
# oncoming (a street too narrow for two cars to pass at speed); the cars far ahead drive its middle
# as the rig does (its car's centre ~0.27 m right of the left camera); the blocks on the right
# through frame 45 (~55 m) have white renders: the sunlit one of frames 0-15 holds almost all of
# the sequence's burnt-out pixels; the one being built is white behind its scaffold where its street
# facade shows (frame 44, burnt out) and grey where its walls face the camera in frames 20-38
# (0.33-0.49 x the frame mean: grazing sun; bare concrete walls there made the bench's KLT, clipped
# share and slope worse, docs/sensors.md);
# that right front row stands 7-10 m right of the camera (SGBM, frames 0-40: the peak of the lateral
# positions of the points above the horizon right of the image centre: 9, 9, 8, 7, 7 m), behind a
# grass strip ~1.5 m wide from ~4 m (frame 0, rows 300-340 on the ground plane) and paving to the
# facades, and ends ~37 m ahead; beyond a side street's mouth (its kerb's return, frame 28) the
# block under works is deep: a map of all frames' SGBM points 2-10 m above the road (frames 0-45,
# in frame 0's camera frame) shows its end wall across the view 60-62 m ahead, 5-28 m right, and
# its street facade from there on past 85 m; frames 0-27 see that end wall, scaffolded, through
# the gap (frame 24: 66-79 % of the points right of the centre 30-32 m away face the camera), so
# half of KITTI's wall points there face the camera where a row of facades along the street gave
# a quarter (docs/sensors.md); between its carriageway and the bay a light concrete gutter (frame
# 12, rows 300-360: 0.38-0.44 m wide, 2.3-2.8 m right of the camera; 2.3 x the sunlit asphalt)
KITTI_S1_NEAR = NearField(half_road=2.0, bay=2.5, walk_left=0.0, car_offset=3.13, parked_ahead=(15.4, 40.1),
                          parked_clear=100.0, traffic_lane=0.1, traffic_ahead=(100.0, 130.0), oncoming=False,
                          white_right=65.0, works_right=(60.0, 100.0), works_depth=22.0, works_front=6.4, open_right=37.0,
                          lawn_right=1.3,
                          walk_right=2.2, setback_right=(0.6, 1.2), gutter_right=0.4, setback_left=(20.5, 22.5),
                          trees_left=((18.0, 80.0), (10.5, 15.5)), gardens_right=(0.0, 37.0), speed_rms=0.005)
# KITTI sequence_1 cruises: its 50 steps are 1.186-1.208 m (poses.txt; mean 1.197, RMS 0.4 % of
# it), where other seeds' drives wander 6 % (a 45-frame stretch of seed 0 at 6 % drove 1.07-1.23 m a
# frame, 6 % slower than KITTI's over the twin bench's frames: less image motion, smaller KLT errors)
# KITTI sequence_1's left houses (beyond its public lawn) face the street 25-27 m left of the camera
# (SGBM, frames 20-36); the open frontage's drawn 14-28 m put seed 0's at 18.5-21 m, large smooth
# walls where KITTI's upper left holds ~1.7x the corners (session 14: 76-88 vs 43-49 a frame);
# between them and the kerb's young trees its lawn holds a loose row of young trees 10-16 m left
# (SGBM, frames 0-30: crowns 2-7 m above the road, 20-80 m ahead of frame 0), where seed 0 had none
LEFT_ROW_M = 100.0
# a white silicate render (light reflectance value ~80: palette.PLASTER's whitest but one)
WHITE_RENDER = (0.80, 0.79, 0.76)
# the film factor (LOOK exposure, EV): fixed, as a camera's sensitivity is, so the sensor's input
# is the calibrated sky's and sun's light at every seed and the camera's AUTOEXPOSURE does the
# adapting; 2^1.59 = 3.01 is what ``LOOK exposure auto`` chose for seed 0 up to session 18 (the
# 90th percentile of frame 0's 96 px preview at 0.6). The automatic factor sat on a cliff there:
# a re-drawn garden tree showed more sunlit white wall and halved it (3.01 -> 1.67), darkening the
# whole sequence's sensor input and its first frames while the camera's exposure caught up
FILM_EV = 1.59
FRONT_ROW_M = 30.0   # a block's centre within this of the centreline: the front row (second rows stand further back)
# near-field street detail (docs/sensors.md, Camera twins: what KITTI sequence_1 shows at 5-30 m
# that carries its corners): KITTI sequence_1's deep block beyond the side street is under
# scaffolding with fence panels at its end wall and along its yard, its lawn's young trees all stand
# in three stakes, bikes in its front gardens (``GARDEN``); residential streets elsewhere: a building in
# ~8 under works, a bike rack before one front-row building in ~4, young trees staked
P_WORKS = 0.12            # the chance that a front-row building (seed != 0) is under scaffolding
P_BIKES = 0.25            # ... that a bike rack stands in its front yard
SCAFFOLD_DEPTH_M = 0.9    # a facade scaffold's width (EN 12811 class 4: 0.9 m decks) ...
SCAFFOLD_GAP_M = 0.15     # ... and its gap to the facade's foremost part below its top
SITE_FENCE_GAP_M = 0.1    # a site fence's feet this far before a scaffold on a sidewalk (KITTI s1's)
# KITTI sequence_1's near right (frames 0-36, full-size SGBM in each frame's camera frame, 6-16 m
# from the camera): points 0.6-1.4 m above the road peak 7.0-7.5 m right of the camera in every 4 m
# of the ~40 m before its side street (a front gardens' boundary: clipped hedges, shrubs, bikes;
# its images: a hedge, flowering shrubs, planters, bikes on their stands, wheelie bins), points
# 2.6-6 m up stand 7.5-9.5 m right every ~12 m (young garden trees) and none 4.5-6.5 m right (its
# grass strip has no trees); the facades ~8.5-9.5 m right: gardens ~1-1.5 m deep
GARDEN = {"line": 7.1,          # the boundary's middle, metres right of the centreline ...
          "thick": 0.5,         # ... its thickness (a hedge's), the hedge modules' length and heights
          "module": 1.2, "heights": (1.2, 1.4, 1.6),   # its tops where high (KITTI's p50 1.52 m, below)
          "p_hedge": 0.65,      # a garden's boundary a clipped hedge (else a row of shrubs)
          "gap": (1.2, 1.6),    # its entrance's width
          "p_bikes": 1.0,       # bikes in every garden (KITTI's frames 0, 16 and 24 each pass one), ...
          "p_pots": 0.6, "p_bin": 0.4, "shrubs_per_m": 0.25,    # ... planters, a wheelie bin, shrubs ...
          "p_bin_store": 0.35, "p_board": 0.3,   # ... a bin enclosure beside the path, a notice board (KITTI's frames 12-18)
          "shrub_h": (1.0, 1.7),    # ... as high as KITTI's between its garden trees (SGBM p50-p90 1.0-1.8 m)
          # KITTI sequence_1's boundary is broken (full-size SGBM, frames 0-30 every 3rd, points 6-16 m
          # away 6.6-7.8 m right, the top (p95) of each 1 m along the view: p10/50/90 0.55/1.52/2.34 m,
          # 21 % of them under 0.9 m and 31 % under 1.2 m; of the points 0.2-1.2 m up 5.5-12 m right 21 %
          # lie behind it, beyond 7.8 m): stretches of hedge or shrubs broken by paths and drives, low
          # walls, fences and low planting, the gardens' bikes, bins and planters seen over them (session
          # 18's unbroken 1.3-1.5 m shrubs: no top under 0.9 m, 5 % under 1.2 m, 8 % behind). Each
          # stretch 2.5-6 m (a gap 0.9-2.4 m), of a kind by these shares of the boundary's length:
          "stretch": (2.5, 6.0), "gap_len": (0.9, 2.4),
          "stretches": {"high": 0.5, "low_plants": 0.15, "wall": 0.1, "fence": 0.1, "gap": 0.15},
          "low_h": (0.4, 0.7), "wall_h": (0.5, 0.75), "fence_h": (0.8, 1.0)}   # perennials; a coping's top; pickets or bars
# KITTI sequence_1's front gardens hold a young tree every ~12 m (full-size SGBM, frames 0-18, points
# 7.3-9 m right of the camera 8-30 m ahead: clusters 4.5-6 m high (p99 of the points' height 4.5-6.1
# m), their crowns from ~1.5-2.5 m up, ~3-4 m along the street, at 12, 23.5, 36 and 47 m ahead of
# frame 0; between them the boundary's shrubs and bikes 1-1.8 m high (p90 1.2-1.8 m)); those crowns
# hold half of its upper-right ORB inliers (96 a step at 21 m where the render's facades held 41;
# bench/twin.py, 24 frames): young garden trees (``garden_tree``: a slim stem, laterals all the way
# up, small leaves) in every garden, their crowns clear of the facade's foremost parts
GARDEN_TREES = {"every": (10.0, 13.5),     # along the street (m) ...
                "first": (1.5, 4.5),        # ... the first this far into a garden
                "size": ((2.2, 3.0), (4.5, 6.0), (1.4, 1.7)),   # crown width, height, crown depth (m)
                "variants": 3, "trunk": 0.2,   # variants (instanced); the trunk this far inside the boundary ...
                "apart": 5.0}   # ... and this far from another tree's (crowns apart)


@dataclass(frozen=True)
class Variation(SeededVariation, salt=0xC17):
    """What a seed changes besides the layout; the defaults are city_kitti.ses's (seed 0)."""
    lighting: Lighting = Lighting(sun=KITTI_S1_SUN)
    step_m: float = 1.2                  # metres per frame (KITTI: ~1.2)
    curves: int = 2                      # gentle curves along the street
    curve_deg: tuple = (6.0, 14.0)       # the range of each curve's total turn
    lane: float = -0.17                  # the left camera right of the centreline (m; KITTI sequence_1: left of its middle)
    weave: float = 0.1                   # lane keeping: amplitude of the lateral wander (m)
    road: Optional[tuple] = None         # (colour, wear) of the asphalt; None: as the road asset picks it
    paving: Optional[tuple] = None       # (colour, wear) of the sidewalks' concrete
    frontage: tuple = ("open", "block")  # the left and right side's cross-section (FRONTAGES): KITTI sequence_1's
    # the chance that a kerb slot holds a parked car, right and left side: KITTI sequence_1's are
    # sparse (2-3 cars at the right kerb over the ~90 m its frames 0-45 see, one per ~35 m; none
    # along the lawn on the left); residential streets range from that to kerbs parked full
    parking: tuple = (0.24, 0.0)
    # seed 0's carriageway, parking bay and near traffic as KITTI sequence_1's (KITTI_S1_NEAR);
    # None: drawn (two lanes, cars at the road's edges, traffic both ways)
    near: Optional[NearField] = KITTI_S1_NEAR
    grass_m: float = 0.08                # the lawns' blades (their tallest; m): KITTI sequence_1's public lawn is mown
    # the share of young trees (left) and tree-lawn trees (right) standing in stakes: all of KITTI
    # sequence_1's lawn trees are newly planted and staked (frames 0-45)
    staked: tuple = (1.0, 0.0)
    # the car body's pitch and roll about the drive (RMS, deg) and its heave (RMS, m): KITTI
    # sequence_1's poses turn 0.019 deg (pitch) and 0.034 deg (roll) a frame and their vertical step
    # changes 0.7 mm from frame to frame (medians); 0.3 deg / 0.2 deg / 1 cm moved the rig 8x / 3x /
    # 6x that, and the rotation's change from frame to frame (0.26 vs 0.036 deg) broke
    # constant-velocity predictions
    body: tuple = (0.03, 0.05, 0.0015)

    @classmethod
    def draw(cls, rng: np.random.Generator) -> "Variation":
        tone = float(rng.uniform(0.8, 1.35))
        return cls(lighting=draw_lighting(rng, p_hdri=1 / 3, p_fog=0.25, fog_start=(25.0, 80.0),
                                          fog_depth=(150.0, 450.0)),
                   step_m=round(float(rng.uniform(0.8, 1.5)), 3), curves=int(rng.integers(1, 4)),
                   curve_deg=(5.0, 18.0), lane=round(float(rng.uniform(1.35, 1.9)), 2),
                   weave=round(float(rng.uniform(0.04, 0.15)), 3),
                   **draw_street_surfaces(rng, tone),
                   frontage=tuple(str(k) for k in rng.choice(list(FRONTAGE_ODDS), 2, p=list(FRONTAGE_ODDS.values()))),
                   parking=(round(float(rng.uniform(0.15, 0.75)), 2), round(float(rng.uniform(0.0, 0.5)), 2)),
                   near=None, grass_m=0.16,
                   # up to KITTI sequence 00's ground truth (0.11 / 0.10 deg a frame, 2.3 mm, its OXTS noise included)
                   body=tuple(round(float(np.exp(rng.uniform(np.log(lo), np.log(hi)))), 4)
                              for lo, hi in ((0.03, 0.17), (0.05, 0.15), (0.0015, 0.005))),
                   staked=(round(float(rng.uniform(0.4, 1.0)), 2), round(float(rng.uniform(0.0, 0.5)), 2)))


def _centre(street_pos, street_yaw, s, L, bends):
    """World points and headings (deg) of the centreline at arc lengths s."""
    c, n, h = arc_frame(s, L, bends)
    a = np.radians(street_yaw)
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    return (c @ R.T + street_pos, n @ R.T, np.degrees(h) + street_yaw)


class _Centreline:
    """The street's centreline sampled every 0.5 m (``centre``: arc length -> world position):
    the arc length and distance of the point nearest a ground position, for the placements that
    read a drawn side back (one sampling for all of them)."""

    def __init__(self, centre, length: float):
        self.s = np.arange(0.0, length, 0.5)
        self.xz = centre(self.s)[:, [0, 2]]

    def nearest(self, xz) -> tuple[float, float]:
        d = np.linalg.norm(self.xz - xz, axis=1)
        k = int(np.argmin(d))
        return float(self.s[k]), float(d[k])


def _ground_xz(w: list[str]) -> np.ndarray:
    """The (x, z) of an ASSET line's words ``w``."""
    i = w.index("position")
    return np.array([float(w[i + 1]), float(w[i + 3])])


def _white_near(lines: list[str], centreline: _Centreline, s0: float, s1: float) -> list[str]:
    """``lines`` with the front row's buildings (centres within ``FRONT_ROW_M`` of the
    centreline) whose nearest centreline point lies between arc lengths ``s0`` and ``s1``
    given the ``white_render`` material (their walls; a scripted near field's), and the block
    under works (``works_blocks``) its white insulated ground floor under the bare blocks
    (KITTI sequence_1's, frames 30-45)."""
    out = []
    for ln in lines:
        if ln.startswith("ASSET building") and " material " not in ln:    # the block under works: its blocks
            s, d = centreline.nearest(_ground_xz(ln.split()))
            if s0 <= s <= s1 and d <= FRONT_ROW_M:
                ln += " material white_render"
        elif ln.startswith("ASSET building") and ln.endswith(" material works_blocks"):
            ln += " ground_material white_render"
        out.append(ln)
    return out


BUILDING_KINDS = ("building", "building_shell", "house")   # the asset kinds a street's blocks are drawn with


def _has_front_balconies(size, seed: int) -> bool:
    """Whether the building asset of ``size`` and ``seed`` has balconies on its front: parts above
    its ground floor more than 0.5 m before its front wall (sills, frames and shutters stand out
    under 0.1 m; a balcony 1.1-1.5 m)."""
    V = asset_mesh("building", size, seed).vertices
    return bool(np.any((V[:, 1] > 2.0) & (V[:, 2] > size[2] / 2 + 0.5)))


def _plain_fronts(lines: list[str], centreline: _Centreline, s0: float, s1: float) -> list[str]:
    """``lines`` with each front-row building whose nearest centreline point lies between arc
    lengths ``s0`` and ``s1`` and that has balconies on its front (``_has_front_balconies``)
    drawn again (its seed + 7919 k, the first k >= 1 without; size, place and material kept): a
    scripted near field's gardens, KITTI sequence_1's near right houses (frames 0-24 at full size:
    plain rendered walls, small windows with shutters, young trees before them; no balcony), where
    a balcony 1.1-1.5 m deep over a garden 1-1.5 m deep left no room for a tree's crown. Each is a
    ``house``: its ground floor recessed under the storeys above over most of its front, the front
    door in the recess (KITTI's near houses: dark timber-clad recesses ~2-2.5 m behind the
    facade along nearly all of them; ``building.PORCH``)."""
    out = []
    for ln in lines:
        b = _front_row_building(ln, centreline)
        if b is not None and b["kind"] == "building" and s0 <= b["s"] <= s1:
            if _has_front_balconies(b["size"], b["seed"]):
                seed_ = next(b["seed"] + 7919 * k for k in range(1, 100)
                             if not _has_front_balconies(b["size"], b["seed"] + 7919 * k))
                ln = ln.replace(f" seed {b['seed']} ", f" seed {seed_} ", 1)
            ln = ln.replace("ASSET building ", "ASSET house ", 1)
        out.append(ln)
    return out


def _front_row_building(ln: str, centreline: _Centreline) -> Optional[dict]:
    """A front-row building's line ``ln`` (centre within ``FRONT_ROW_M`` of the centreline) as
    its position, yaw (deg), size, seed, arc length ``s`` of the nearest centreline point and
    distance ``dist`` from it; None for any other line."""
    w = ln.split()
    if len(w) < 2 or w[0] != "ASSET" or w[1] not in BUILDING_KINDS:
        return None
    i, j = w.index("position"), w.index("size")
    p = np.array([float(x) for x in w[i + 1:i + 4]])
    s, dist = centreline.nearest(p[[0, 2]])
    if dist > FRONT_ROW_M:
        return None
    return {"p": p, "yaw": float(w[i + 5]) if j - i == 7 else 0.0, "size": tuple(float(x) for x in w[j + 1:j + 4]),
            "seed": int(w[w.index("seed") + 1]), "s": s, "dist": dist, "kind": w[1]}


def _lawn_trees(rng: np.random.Generator, place, behind: float, spec: tuple, lines: list[str], pool, ids: Ids) -> list[str]:
    """A loose row of young trees on the left lawn (a scripted near field's ``trees_left``: from,
    to ahead; near, far left of the centreline), every 7-13 m, none within 3.5 m of a tree, bush
    or building of ``lines`` (crowns apart) nor inside a building's footprint; variants of the
    young-tree pool picked from ``rng`` (the pool's own stream stays as it was)."""
    (a0, a1), (d0, d1) = spec
    taken = []
    for ln in lines:
        w = ln.split()
        if len(w) > 2 and w[0] == "ASSET" and w[1] in ("tree", "bush", *BUILDING_KINDS):
            r = 3.5
            if w[1] in BUILDING_KINDS and "size" in w:
                i = w.index("size")
                r = 0.5 * float(np.hypot(float(w[i + 1]), float(w[i + 3]))) + 3.0
            taken.append((_ground_xz(w), r))
    seeds, sizes = pool.seeds["young_tree"], pool.sizes["young_tree"]
    out = []
    a = a0 + float(rng.uniform(0, 5))
    while a < a1:
        p, _ = place(behind + a, -float(rng.uniform(d0, d1)))
        k = int(rng.integers(len(seeds)))
        yaw = float(rng.uniform(0, 360))
        if all(np.linalg.norm(p[[0, 2]] - xz) > r for xz, r in taken):
            out.append(asset("tree", ids("tree"), p, yaw, sizes[k], seed=seeds[k]))
            taken.append((p[[0, 2]], 3.5))
        a += float(rng.uniform(7, 13))
    return out


def _front_row(lines: list[str], centreline: _Centreline) -> list[dict]:
    """The front row's buildings of ``lines`` (:func:`_front_row_building`)."""
    return [b for ln in lines if (b := _front_row_building(ln, centreline)) is not None]


def _pull_front_row(lines: list[str], centreline: _Centreline, s_end: float, edge: float, setback: tuple,
                    rng: np.random.Generator, clear_yards: bool = True) -> list[str]:
    """``lines`` (one side's) with the front row's buildings up to arc length ``s_end`` moved
    towards the street to a ``setback`` drawn in that range behind ``edge`` (a scripted near
    field's; their front yards' hedges, fences, bushes and bins left out unless not
    ``clear_yards``, for a row moved back): done after the side
    is drawn, so the layout's stream, and all drawn after it, stays as it was."""
    moved = []                       # (arc length range, distance range) of the yards given up
    out = []
    for ln in lines:
        b = _front_row_building(ln, centreline)
        if b is None or b["s"] - b["size"][0] / 2 >= s_end:
            out.append(ln)
            continue
        W, _, D = b["size"]
        a = np.radians(b["yaw"])
        front = np.array([np.sin(a), 0.0, np.cos(a)])
        new = edge + float(rng.uniform(*setback)) + D / 2
        p = b["p"] + front * (b["dist"] - new)
        w = ln.split()
        i = w.index("position")
        w[i + 1:i + 4] = nums(p).split()
        out.append(" ".join(w))
        if clear_yards:
            moved.append((b["s"] - W / 2 - 1.0, b["s"] + W / 2 + 1.0, b["dist"] - D / 2))
    keep = []
    for ln in out:
        w = ln.split()
        if w[1] in ("hedge", "fence", "bush", "bin"):
            s_, d = centreline.nearest(_ground_xz(w))
            if any(s0 <= s_ <= s1 and d < front_d for s0, s1, front_d in moved):
                continue
        keep.append(ln)
    return keep


def _works_row(lines: list[str], centreline: _Centreline, place, s_open: float, span: tuple, depth: float,
               edge: float, setback: tuple, ids: Ids, rng: np.random.Generator, front: float = 0.0) -> list[str]:
    """``lines`` (one side's, right) with a deep block being built from arc length ``span[0]``
    to ``span[1]``, ``depth`` deep, its front ``setback`` (drawn in that range) behind ``edge``
    (``front`` > 0: its wall a scaffold's depth and gap behind ``front``: the works site takes the
    verge and sidewalk, KITTI sequence_1's frames 34-44),
    and no front-row building from ``s_open`` to it (KITTI sequence_1's right side: a side
    street's mouth, then a block under scaffolding whose end wall faces the camera across it).
    A front-row building reaching past ``s_open`` is cut back to end there (left out if that
    leaves less than 6 m); any building, tree or bush on the block's footprint is left out."""
    s0, s1 = span
    near = edge + float(rng.uniform(*setback))
    if front > 0:       # (drawn all the same: the stream stays)
        near = front + SCAFFOLD_DEPTH_M + SCAFFOLD_GAP_M
    out = []
    for ln in lines:
        w = ln.split()
        if w[1] == "building":
            i, j = w.index("position"), w.index("size")
            s, d = centreline.nearest(_ground_xz(w))
            W, D = float(w[j + 1]), float(w[j + 3])
            if s - W / 2 < s1 + 2.0 and s + W / 2 > s0 - 2.0 and d - D / 2 < near + depth + 2.0:
                continue                                        # on the block's footprint
            b = _front_row_building(ln, centreline)
            if b is not None and s + W / 2 > s_open and s - W / 2 < s0:
                if s_open - (s - W / 2) < 6.0:
                    continue
                W_new = s_open - (s - W / 2)                    # cut back to the side street
                p, _ = place(s - W / 2 + W_new / 2, d)
                w[i + 1:i + 4] = nums(p).split()
                w[j + 1] = num(round(W_new, 2))
                ln = " ".join(w)
        elif w[1] in ("tree", "conifer", "bush"):
            s, d = centreline.nearest(_ground_xz(w))
            if s0 - 2.0 <= s <= s1 + 2.0 and d < near + depth + 2.0:
                continue
        out.append(ln)
    p, h = place((s0 + s1) / 2, near + depth / 2)
    out.append(asset("building_shell", ids("building"), p, h - 90, (round(s1 - s0, 2), round(float(rng.uniform(14.0, 16.0)), 2),
                                                              round(depth, 2)), seed=int(rng.integers(1e6)),
                     extra="material works_blocks"))
    return out


def _reach(w: list[str]) -> float:
    """How far a bush of an ASSET line's words ``w`` reaches from its centre (half its larger
    footprint side: its size, or the seeded one a line without size gets); 0 for the rest."""
    if w[1] != "bush":
        return 0.0
    if "size" in w:
        j = w.index("size")
        return max(float(w[j + 1]), float(w[j + 3])) / 2
    size = default_size("bush", int(w[w.index("seed") + 1]))
    return max(size[0], size[2]) / 2


def _clear_footprints(lines: list[str], works: list[str], margin: float = 0.3) -> list[str]:
    """``lines`` without the small street furniture (bins, poles, signs, bollards, bushes,
    hedges, fences) that stands within ``margin`` of a footprint of ``works`` (scaffolds and
    site fences stand where the sidewalk's bins and signs were: a works site clears them) -
    a bush within its reach (``_reach``: a yard's bush centred 0.4 m before a scaffold grew into it)."""
    boxes = []
    for ln in works:
        w = ln.split()
        i, j = w.index("position"), w.index("size")
        yaw = np.radians(float(w[i + 5]) if j - i == 7 else 0.0)
        boxes.append((np.array([float(w[i + 1]), float(w[i + 3])]), yaw, float(w[j + 1]) / 2 + margin,
                      float(w[j + 3]) / 2 + margin))
    out = []
    for ln in lines:
        w = ln.split()
        if len(w) > 1 and w[0] == "ASSET" and w[1] in ("bin", "pole", "sign", "bollard", "bush", "hedge", "fence"):
            q, r = _ground_xz(w), _reach(w)
            inside = False
            for c, yaw, hx, hz in boxes:     # the asset frame's x = (cos, -sin), z = (sin, cos) in world (x, z)
                d = q - c
                inside |= abs(d[0] * np.cos(yaw) - d[1] * np.sin(yaw)) < hx + r and \
                    abs(d[0] * np.sin(yaw) + d[1] * np.cos(yaw)) < hz + r
            if inside:
                continue
        out.append(ln)
    return out


def _street_detail(rng, side_lines: dict, place, centreline: _Centreline, behind: float, edges: dict,
                   near: Optional[NearField], staked: tuple, trees_at: dict, ids: Ids) -> list[str]:
    """Scaffolds on front-row buildings under works (seed 0: the right ones ``near.works_right``
    ahead; else each with ``P_WORKS``) and a site fence along their yard, bike racks (seed 0:
    at ``near.bikes_right``; else before a front-row building with ``P_BIKES``), stakes round
    the young (left) and tree-lawn (right) trees with the shares ``staked``. Stakes and racks
    are a few variants each (instanced)."""
    stakes = [int(x) for x in rng.integers(1, 10 ** 6, 4)]
    racks = [(int(x), (round(float(rng.uniform(2.7, 4.5)), 2), 0.85, 1.8)) for x in rng.integers(1, 10 ** 6, 3)]
    out = []
    for side, lines in side_lines.items():
        for b in _front_row(lines, centreline):
            W, H, D = b["size"]
            a = np.radians(b["yaw"])
            front, along = np.array([np.sin(a), 0.0, np.cos(a)]), np.array([np.cos(a), 0.0, -np.sin(a)])
            yard = b["dist"] - D / 2 - edges[side]          # the front yard's depth
            if near is not None:
                works = side > 0 and bool(near.works_right) and \
                    near.works_right[0] <= b["s"] - behind <= near.works_right[1]
            else:
                works = rng.random() < P_WORKS
            if works:   # to the eaves (a gable's ridge is ~1/4 of the height above them), clear of
                # what the facade carries below them (balconies, sills, steps: the building's own mesh)
                h_s = round(max(0.75 * H, 4.5), 2)
                V = asset_mesh(b["kind"], (W, H, D), b["seed"]).vertices
                face = float(V[V[:, 1] < h_s, 2].max()) + SCAFFOLD_GAP_M
                p = b["p"] + front * (face + SCAFFOLD_DEPTH_M / 2)
                out.append(asset("scaffold", ids("furniture"), p, b["yaw"], (round(W + 1.0, 2), h_s, SCAFFOLD_DEPTH_M),
                                 seed=int(rng.integers(1e6))))
                if near is not None:    # KITTI's deep block: its end wall facing the camera scaffolded too
                    end = 1.0 if centreline.nearest((b["p"] + along * W / 2)[[0, 2]])[0] < b["s"] else -1.0
                    face_x = float((end * V[V[:, 1] < h_s, 0]).max()) + SCAFFOLD_GAP_M
                    out.append(asset("scaffold", ids("furniture"), b["p"] + end * along * (face_x + SCAFFOLD_DEPTH_M / 2),
                                     b["yaw"] + 90 * end, (round(D + 1.0, 2), h_s, SCAFFOLD_DEPTH_M),
                                     seed=int(rng.integers(1e6))))
                    # ... behind fence panels across the gap (KITTI's frames 24-36: panels and stacked
                    # materials at the foot of that wall)
                    out.append(asset("site_fence", ids("furniture"), b["p"] + end * along * (face_x + SCAFFOLD_DEPTH_M + 1.5),
                                     b["yaw"] + 90 * end, (round(D + 0.5, 2), 2.0, 0.65), seed=int(rng.integers(1e6))))
                site = face + SCAFFOLD_DEPTH_M + 1.5            # the site fence 1.5 m before the scaffold
                if near is not None and near.works_front:       # KITTI's: the site takes the sidewalk, its
                    # fence panels' feet (0.65 m) just before the scaffold (frames 36-44), a stream of its own
                    p = b["p"] + front * (face + SCAFFOLD_DEPTH_M + SITE_FENCE_GAP_M + 0.325)
                    out.append(asset("site_fence", ids("furniture"), p, b["yaw"], (round(W + 0.5, 2), 2.0, 0.65),
                                     seed=int(np.random.default_rng([b["seed"], 0x5F1]).integers(1e6))))
                elif b["dist"] - site > edges[side] + 0.3:
                    p = b["p"] + front * site
                    out.append(asset("site_fence", ids("furniture"), p, b["yaw"], (round(W + 0.5, 2), 2.0, 0.65),
                                     seed=int(rng.integers(1e6))))
            if near is None and rng.random() < P_BIKES and yard > 3.0:
                seed_, size = racks[int(rng.integers(len(racks)))]
                p = b["p"] + front * (D / 2 + 1.6) + along * float(rng.uniform(-W / 3, W / 3))
                i = ids("furniture")    # drawn all the same: the ids after it stay
                if not works:           # a site's entrance has no bike rack (it stood in the scaffold)
                    out.append(asset("bike_rack", i, p, b["yaw"], size, seed=seed_))
    for a in (near.bikes_right if near is not None else ()):
        p, h = place(behind + a, edges[1] - 0.95)
        seed_, size = racks[0]
        out.append(asset("bike_rack", ids("furniture"), p, h - 90, size, seed=seed_))
    for share, where in zip(staked, ("young", "lawn")):
        for p in trees_at[where]:
            if rng.random() < share:
                i = int(rng.integers(len(stakes)))
                out.append(asset("tree_stakes", ids("furniture"), p, 0.0, (0.7, 2.2, 0.7), seed=stakes[i]))
    return out


def _gardens(rng, lines: list[str], side_lines: list[str], place, centreline: _Centreline, span: tuple, pool,
             ids: Ids, kerb_h: float, tree_rng=None) -> list[str]:
    """Front gardens before the right front row's buildings whose front lies between arc lengths
    ``span`` (a scripted near field's ``gardens_right``, KITTI sequence_1's: ``GARDEN``): along
    each facade a boundary ``GARDEN['line']`` right of the centreline - modules of a clipped
    hedge of one height, or a row of shrubs - broken by an entrance; between it and the facade's
    foremost part (its steps and balconies) bicycles, planters, a wheelie bin at the entrance and
    shrubs; in a gap of 2 m or more between two buildings a young tree (its crown clear of the
    walls). Hedge, shrub, planter and bike variants are a few each (instanced); nothing within
    reach of an asset of ``lines`` (poles, signs, bins, trees, lights). With ``tree_rng`` (a stream
    of its own: everything else stays as drawn without it) young garden trees (``GARDEN_TREES``)
    every 10-13.5 m of each garden, ``_garden_trees``."""
    g = GARDEN
    hedges = [(int(x), (g["module"], h, g["thick"])) for x, h in zip(rng.integers(1, 10 ** 6, 3), g["heights"])]
    shrubs = [(int(x), (round(float(rng.uniform(0.7, 1.0)), 2), round(float(rng.uniform(*g["shrub_h"])), 2),
                        round(float(rng.uniform(0.55, 0.75)), 2))) for x in rng.integers(1, 10 ** 6, 3)]
    pots = [(int(x), (0.5, round(float(rng.uniform(0.7, 1.1)), 2), 0.5)) for x in rng.integers(1, 10 ** 6, 2)]
    bikes = [(int(x), (n * 0.6, 1.0, 1.8)) for x, n in zip(rng.integers(1, 10 ** 6, 2), (1, 2))]
    lows = [(int(x), (round(float(rng.uniform(0.8, 1.1)), 2), round(float(rng.uniform(*g["low_h"])), 2),
                      round(float(rng.uniform(0.5, 0.7)), 2))) for x in rng.integers(1, 10 ** 6, 2)]
    fences = {"wall": _fence_seeds(rng, 2, 2), "fence": _fence_seeds(rng, 0, 1) + _fence_seeds(rng, 1, 1)}
    stores = [(int(x), (round(float(rng.uniform(1.4, 2.2)), 2), round(float(rng.uniform(1.2, 1.35)), 2), 0.8))
              for x in rng.integers(1, 10 ** 6, 2)]
    board = (int(rng.integers(1, 10 ** 6)), (round(float(rng.uniform(1.0, 1.5)), 2), 2.0, 0.12))
    taken = []
    for ln in lines:
        w = ln.split()
        if len(w) > 2 and w[0] == "ASSET" and w[1] in ("pole", "sign", "bin", "bollard", "tree", "streetlight",
                                                       "bike_rack", "tree_stakes", "bush", "hedge", "fence"):
            taken.append(_ground_xz(w))

    def clear(p, r):
        return all(np.linalg.norm(p[[0, 2]] - xz) > r + 0.3 for xz in taken)

    out = []

    def put(kind, a, d, yaw_off, variant, r, group="furniture"):
        p, h = place(a, d)
        p = p + np.array([0.0, kerb_h, 0.0])
        if clear(p, r):
            out.append(asset(kind, ids(group), p, h + yaw_off, variant[1], seed=variant[0]))

    row = sorted((b for ln in side_lines if (b := _front_row_building(ln, centreline)) is not None),
                 key=lambda b: b["s"])
    ends = [(b["s"] - b["size"][0] / 2, b["s"] + b["size"][0] / 2) for b in row]
    gardens = []
    used = dict.fromkeys(g["stretches"], 0.0)          # metres of each kind of boundary stretch so far
    for i, b in enumerate(row):
        s0, s1 = max(ends[i][0], span[0]), min(ends[i][1], span[1])
        if s1 - s0 < 2.0:
            continue
        # the boundary runs on to the middle of a gap under 6 m to the next house (KITTI's is unbroken)
        e0 = (ends[i - 1][1] + ends[i][0]) / 2 if i > 0 and 0.0 < ends[i][0] - ends[i - 1][1] < 6.0 else ends[i][0]
        e1 = (ends[i][1] + ends[i + 1][0]) / 2 if i + 1 < len(row) and 0.0 < ends[i + 1][0] - ends[i][1] < 6.0 \
            else ends[i][1]
        e0, e1 = max(e0, span[0]), min(e1, span[1])
        V = asset_mesh(b["kind"], b["size"], b["seed"]).vertices
        front = b["dist"] - float(V[V[:, 1] < 1.5, 2].max())     # the facade's foremost part, from the centreline
        inner = (g["line"] + g["thick"] / 2 + 0.1, front - 0.15)
        gap = float(rng.uniform(*g["gap"]))
        entrance = float(rng.uniform(s0 + 1.5, max(s1 - 1.5 - gap, s0 + 1.5)))
        hedge = rng.random() < g["p_hedge"]
        k = int(rng.integers(len(hedges)))
        open_ = [(entrance, entrance + gap)]           # where the boundary is low or open: the gardens seen
        for a0, a1 in ((e0 + 0.1, entrance), (entrance + gap, e1 - 0.1)):
            for c0, c1, kind in _boundary_stretches(rng, a0, a1, used):
                if kind != "high":
                    open_.append((c0, c1))
                if kind == "gap":
                    continue
                if kind == "wall" or kind == "fence":
                    h = float(rng.uniform(*g[kind + "_h"]))
                    put("fence", (c0 + c1) / 2, g["line"], -90.0, (fences[kind][int(rng.integers(2))],
                        (round(c1 - c0, 2), round(h, 2), 0.22 if kind == "wall" else 0.1)), 0.0)
                    continue
                step = g["module"] if hedge and kind == "high" else 0.8
                n = max(int(np.ceil((c1 - c0) / step)), 1)    # modules overlapping a little: the stretch unbroken
                plants = lows if kind == "low_plants" else shrubs
                for a in np.linspace(c0 + step / 2, c1 - step / 2, n) if n > 1 else [(c0 + c1) / 2]:
                    if hedge and kind == "high":
                        put("hedge", a, g["line"], -90.0 + 180.0 * int(rng.integers(2)), hedges[k], 0.0, "veg")
                    else:
                        put("bush", a + float(rng.uniform(-0.1, 0.1)), g["line"], float(rng.uniform(0, 360)),
                            plants[int(rng.integers(len(plants)))], 0.0, "veg")
        gardens.append((b, s0, s1, entrance, gap, inner[0]))
        depth = inner[1] - inner[0]
        if depth < 0.5:
            continue
        mid = (inner[0] + inner[1]) / 2
        # the garden's things, each in a 1.5 m slot of its own along the facade, the entrance's kept free;
        # first the slots behind a low or open stretch of the boundary (where the street sees them)
        slots = [a for a in np.arange(s0 + 0.9, s1 - 0.6, 1.5) if not entrance - 0.8 < a < entrance + gap + 0.8]
        rng.shuffle(slots)
        slots.sort(key=lambda a: any(c0 - 0.5 < a < c1 + 0.5 for c0, c1 in open_))   # seen ones last: pop() takes them
        store = stores[int(rng.integers(len(stores)))]
        stored = rng.random() < g["p_bin_store"] and depth >= store[1][2] + 0.1 and entrance - store[1][0] - 0.3 > s0
        if stored:      # a bin enclosure beside the path, its doors facing the street (KITTI's frame 12)
            a = entrance - 0.15 - store[1][0] / 2
            put("bin_store", a, inner[0] + store[1][2] / 2 + 0.05, -90.0, store, 0.0)
            slots = [x for x in slots if abs(x - a) > store[1][0] / 2 + 0.6]
        lows_ = [(c0, c1) for c0, c1 in open_[1:] if c1 - c0 >= board[1][0] + 0.4
                 and not (stored and c0 - 0.2 < entrance and c0 + board[1][0] + 0.4 > entrance - 0.3 - store[1][0])]
        if rng.random() < g["p_board"] and lows_:
            # a notice board just behind a low or open stretch of the boundary, facing the street
            c0, c1 = lows_[int(rng.integers(len(lows_)))]
            a = c0 + 0.2 + board[1][0] / 2
            put("notice_board", a, g["line"] + g["thick"] / 2 + 0.15, -90.0, board, 0.0)
            slots = [x for x in slots if abs(x - a) > board[1][0] / 2 + 0.6]
        if rng.random() < g["p_bikes"] and slots:
            v = bikes[1 if depth >= 1.3 and rng.random() < 0.5 else 0]
            put("bicycles", slots.pop(), mid, 0.0, v, 0.0)
        if not stored and rng.random() < g["p_bin"]:
            put("bin", entrance + gap + 0.5, inner[0] + 0.35, -90.0, (pool.seeds["bin"][int(rng.integers(POOLS["bin"]))], None), 0.0)
        if rng.random() < g["p_pots"]:
            for _ in range(int(rng.integers(1, 3))):
                if slots:
                    put("plant", slots.pop(), inner[1] - 0.3, float(rng.uniform(0, 360)), pots[int(rng.integers(len(pots)))], 0.0)
        for _ in range(int(rng.poisson(g["shrubs_per_m"] * (s1 - s0)))):
            if slots and depth >= 0.8:
                put("bush", slots.pop(), mid, float(rng.uniform(0, 360)), shrubs[int(rng.integers(len(shrubs)))], 0.0, "veg")
    for (_, e0), (e1, _) in zip(ends[:-1], ends[1:]):          # young trees between the houses
        if e1 - e0 >= 2.0 and span[0] <= (e0 + e1) / 2 <= span[1]:
            seed_, size = pool.seeds["young_tree"], pool.sizes["young_tree"]
            k = int(rng.integers(len(seed_)))
            p, h = place((e0 + e1) / 2, g["line"] + 0.9)
            if clear(p, 0.5):
                out.append(asset("tree", ids("tree"), p + np.array([0.0, kerb_h, 0.0]), float(rng.uniform(0, 360)),
                                 size[k], seed=seed_[k]))
    if tree_rng is not None:
        out += _garden_trees(tree_rng, gardens, out, lambda p, r: clear(p, r - 0.3), place, ids, kerb_h)
    return out


def _fence_seeds(rng, style: int, n: int) -> list[int]:
    """``n`` seeds of ``fence`` assets of ``style`` (street.fence: 0 wooden pickets, 1 steel bars,
    2 a low wall with a coping: its first draw of its own stream)."""
    out = []
    while len(out) < n:
        x = int(rng.integers(1, 10 ** 6))
        if int(np.random.default_rng(x).integers(3)) == style:
            out.append(x)
    return out


def _boundary_stretches(rng, a0: float, a1: float, used: dict) -> list[tuple]:
    """A front garden's boundary between arc lengths ``a0`` and ``a1`` as stretches (c0, c1, kind)
    one after another: ``high`` (the garden's hedge or shrubs), ``low_plants``, ``wall``, ``fence``
    or ``gap`` (a path or drive), each 2.5-6 m (a gap 0.9-2.4 m); each the kind furthest below its
    share of the boundary's length so far (``GARDEN['stretches']``, KITTI sequence_1's broken
    boundary; ``used``: metres of each kind drawn so far along the street, updated), give or take
    a random metre; no gap first or after a gap, a rest under 1.5 m joins the stretch before it."""
    g = GARDEN
    out, a = [], a0
    while a1 - a > 0.6:
        total = sum(used.values()) + float(np.mean(g["stretch"]))
        behind = {k: share * total - used[k] + float(rng.uniform(0.0, 1.0)) for k, share in g["stretches"].items()}
        if not out or out[-1][2] == "gap":
            behind.pop("gap")
        kind = max(behind, key=behind.get)
        L = float(rng.uniform(*(g["gap_len"] if kind == "gap" else g["stretch"])))
        c1 = a1 if a1 - (a + L) < 1.5 else a + L
        if kind == "gap" and a1 - c1 < 0.6:
            kind = "high"
        out.append((a, c1, kind))
        used[kind] += c1 - a
        a = c1
    return out


def _garden_trees(rng, gardens: list, garden_lines: list[str], clear, place, ids: Ids, kerb_h: float) -> list[str]:
    """Young garden trees (``garden_tree``, ``GARDEN_TREES``: a few variants) in ``gardens`` ((the
    front-row building, its garden's arc lengths s0, s1, its entrance and width, the inner edge of
    its boundary) of ``_gardens``): the first 1.5-4.5 m into each garden or at the next place
    free, then every 10-13.5 m on, none in the entrance; the trunk ``GARDEN_TREES['trunk']`` inside the boundary, the crown's
    width along the street and its depth towards the facade, where no part of the building
    (balconies, sills, steps) within the crown's reach along the street and height stands nearer
    than 0.1 m to it, nor a garden thing of ``garden_lines`` (bikes, planters, bins, shrubs)
    within 0.5 m of its trunk, nor a tree (the young trees between the houses) within 5 m (places tried every 0.25 m along the
    garden; a balcony over the garden leaves it fewer trees)."""
    t = GARDEN_TREES
    variants = [(int(x), tuple(round(float(rng.uniform(*r)), 2) for r in t["size"]))
                for x in rng.integers(1, 10 ** 6, t["variants"])]
    things = [_ground_xz(ln.split()) for ln in garden_lines if ln.startswith("ASSET") and not ln.startswith("ASSET hedge")]
    trees = [_ground_xz(ln.split()) for ln in garden_lines if ln.startswith("ASSET tree")]
    out = []
    for b, s0, s1, entrance, gap, inner0 in gardens:
        V = asset_mesh(b["kind"], b["size"], b["seed"]).vertices
        yaw = np.radians(b["yaw"])
        R = np.array([[np.cos(yaw), 0.0, np.sin(yaw)], [0.0, 1.0, 0.0], [-np.sin(yaw), 0.0, np.cos(yaw)]])
        a = s0 + float(rng.uniform(*t["first"]))
        for s_ in np.arange(s0 + 0.8, s1 - 0.8, 0.25):
            if s_ < a or entrance - 1.2 < s_ < entrance + gap + 1.2:
                continue
            k = int(rng.integers(len(variants)))
            seed_, (w, h, d) = variants[k]
            p, heading = place(s_, inner0 + t["trunk"])
            p = p + np.array([0.0, kerb_h, 0.0])
            q = R.T @ (p - b["p"])                       # the trunk in the building's frame (its front +z)
            near_ = (np.abs(V[:, 0] - q[0]) < w / 2 + 0.3) & (V[:, 1] > 1.0) & (V[:, 1] < h + 0.3)
            if near_.any() and float(V[near_, 2].max()) > q[2] - d / 2 - 0.25:
                continue
            if any(np.linalg.norm(p[[0, 2]] - xz) < 0.5 for xz in things) or not clear(p, 0.5) \
                    or any(np.linalg.norm(p[[0, 2]] - xz) < t["apart"] for xz in trees):
                continue
            trees.append(p[[0, 2]])
            out.append(asset("garden_tree", ids("tree"), p, heading + 90.0 * int(rng.choice([-1, 1])), (w, h, d),
                             seed=seed_))
            a = s_ + float(rng.uniform(*t["every"]))
    return out


def _traffic(rng, centre, s_cam: np.ndarray, step_m: float, L: float, n_cars: int, ids: Ids, seed_of,
             lane_m: float = LANE_M, ahead_m: tuple = (15.0, 70.0), oncoming: bool = True) -> list[str]:
    """Moving cars (ASSET car + MOVE keyframes): alternately one ahead in the rig's lane,
    starting ``ahead_m`` ahead of the rig (15-70 m: a headway of 1.3-6 s at KITTI's 12 m/s) and
    driving on at 0.95-1.15x the rig's speed, and one oncoming in the other lane at 0.7-1.2x
    (without ``oncoming`` all drive ahead); ``lane_m`` off the centreline, each on the street
    for the whole sequence, at least TRAFFIC_GAP_M from the rig's car and from the other cars of
    its lane (a car that finds no such place after 40 tries is left out). ``centre(s)``: the
    centreline's points, right normals and headings; ``seed_of`` the car variants (the parked
    cars' pool: moving cars share their meshes too)."""
    k = np.arange(len(s_cam))
    lanes = {1: [(s_cam, TRAFFIC_GAP_M[0])], -1: []}          # (positions along the street, least gap)
    out = ["", "// moving traffic: cars ahead in the rig's lane and oncoming ones (keyframes along the curves)"]
    for j in range(n_cars):
        side = 1 if j % 2 == 0 or not oncoming else -1
        for _try in range(40):
            if side > 0:
                s_k = s_cam[0] + rng.uniform(*ahead_m) + step_m * rng.uniform(0.95, 1.15) * k
            else:
                s_k = rng.uniform(s_cam[0] + 20.0, L - 5.0) - step_m * rng.uniform(0.7, 1.2) * k
            if s_k.min() > 3.0 and s_k.max() < L - 3.0 and all(np.abs(s_k - o).min() >= g for o, g in lanes[side]):
                break
        else:
            continue
        lanes[side].append((s_k, TRAFFIC_GAP_M[1]))
        c, n, h = centre(s_k)
        xz = (c + side * lane_m * n)[:, [0, 2]]
        yaw = np.round(h + (180.0 if side > 0 else 0.0), 3)    # the car's nose (+z) along its way
        i = ids("car")
        out.append(asset("car", i, (xz[0, 0], 0.0, xz[0, 1]), yaw[0], seed=seed_of("car")))
        for f in keyframes(xz, yaw)[1:]:
            out.append(f"MOVE id {i} frame {f} position {nums((xz[f, 0], 0.0, xz[f, 1]))} 0 {num(yaw[f], 3)} 0")
    return out


def generate(seed: int = 0, frames: int = 101, step_m: Optional[float] = None, sun_elevation: Optional[float] = None,
             sun_azimuth: Optional[float] = None, traffic: int = 8) -> str:
    """The SES script of the city street for ``seed`` (layout, buildings, trees, cars and
    drive all follow from it; see the module docstring)."""
    if int(seed) < 0 or int(frames) < 2 or int(traffic) < 0:
        raise ValueError(f"seed must be >= 0, frames >= 2 and traffic >= 0, got seed {seed}, frames {frames}, "
                         f"traffic {traffic}")
    v = Variation.of(int(seed))
    step_m = v.step_m if step_m is None else float(step_m)
    lighting = replace(v.lighting, aerosol=HAZE_AEROSOL)
    if sun_elevation is not None or sun_azimuth is not None:
        lighting = replace(lighting, sun=(lighting.sun[0] if sun_elevation is None else float(sun_elevation),
                                          lighting.sun[1] if sun_azimuth is None else float(sun_azimuth)))
    rng = np.random.default_rng(seed)
    behind, ahead = 40.0, 130.0
    L = behind + step_m * (frames - 1) * 1.1 + ahead
    n_pieces = int(np.ceil(L / PIECE))
    L = n_pieces * PIECE
    bends = np.zeros(n_pieces)
    for _ in range(v.curves):    # gentle curves somewhere along the drive
        i = int(rng.integers(2, n_pieces - 3))
        turn = rng.choice([-1, 1]) * rng.uniform(*v.curve_deg)
        bends[i:i + 3] += turn * np.array([0.3, 0.4, 0.3])
    bends = np.round(bends, 3)
    street_pos = np.array([0.0, 0.0, behind])
    street_yaw = 0.0
    half_road = round(float(rng.uniform(4.7, 5.0)), 2)       # two lanes, cars parked at the edges
    kerb_w, kerb_h = 0.2, 0.13
    lawn_w = round(float(rng.uniform(1.8, 3.0)), 2)          # tree lawn, right side
    walk_r = round(float(rng.uniform(2.2, 3.0)), 2)
    walk_l = round(float(rng.uniform(2.0, 3.0)), 2)
    near = v.near
    bay = 0.0
    if near is not None:       # a scripted near field (drawn above all the same: the layout's stream stays)
        half_road, bay, walk_l = near.half_road, near.bay, near.walk_left
        lawn_w, walk_r = near.lawn_right or lawn_w, near.walk_right or walk_r
    yard = 60.0
    ids = Ids({"street": 1, "building": 100, "car": 400, "tree": 600, "veg": 900, "furniture": 1200,
               "grass": 2000})
    pool = VariantPool(rng, POOLS, POOL_SIZES, variants_rng=variation_rng(seed, 0x7EE))

    out = ["// city_kitti.ses - an urban street seen by the KITTI odometry rig (1226x370, f 707 px,",
           "// baseline 0.54 m), ~1.2 m per frame, lane keeping along gentle curves.",
           f"// Generated by blender_sesgen/generators/builtin/city_kitti.py --seed {seed} --frames {frames} "
           "(edit that, not this file). Y up, metres.",
           KITTI_RIG,
           *lighting.lines(),
           "RENDER samples 16 denoise on",
           "SENSOR profile kitti        // KITTI's camera, measured (docs/sensors.md): its noise, blur, clipping",
           "AUTOEXPOSURE                // its exposure follows the scene (metered before the frames render)",
           f"LOOK exposure {num(FILM_EV)}          // a fixed film factor: the sky and sun are calibrated, the camera adapts"]
    road_mat = paving_mat = ""
    if v.road is not None:
        out += ["", "// this seed's asphalt and paving (library materials with its own tone and wear)",
                derived_material("road_asphalt", "asphalt", v.road[0], v.road[1], seed=seed),
                derived_material("paving", "concrete", v.paving[0], v.paving[1], seed=seed)]
        road_mat, paving_mat = " material road_asphalt", " material paving"
    out += ["", "// the street: one centreline (arcs of 20 m), strips side by side"]
    bend_s = nums(bends)
    rot = f"position {nums(street_pos)} 0 {num(street_yaw)} 0"

    def strip(kind, width, height, offset, seed_, material=""):
        return (f"ASSET {kind} id {ids('street')} seed {seed_} {rot} size {nums((width, height, L))} "
                f"bend {bend_s} offset {num(offset, 3)}{material}")

    r_kerb = half_road + kerb_w / 2 - 0.05            # kerbs overlap the road edge by 5 cm
    out.append(strip("road", 2 * half_road, 0.3, 0.0, seed * 10 + 1, road_mat))
    if bay:                                           # setts, flush with the road (1 cm up), as KITTI s1's bay
        g = near.gutter_right if near is not None else 0.0   # ... its first decimetres a gutter (seed 0)
        out.append(strip("sidewalk", bay - g, 0.01, half_road + g + (bay - g) / 2, seed * 10 + 9, " material setts"))
    out.append(strip("kerb", kerb_w, kerb_h, r_kerb + bay, seed * 10 + 2))
    out.append(strip("kerb", kerb_w, kerb_h, -r_kerb, seed * 10 + 3))
    o = r_kerb + bay + kerb_w / 2
    lawn = (o, o + lawn_w)
    out.append(strip("verge", lawn_w, kerb_h, o + lawn_w / 2, seed * 10 + 4))
    o += lawn_w
    walk_r_span = (o, o + walk_r)
    out.append(strip("sidewalk", walk_r, kerb_h, o + walk_r / 2, seed * 10 + 5, paving_mat))
    o += walk_r
    right_edge = o
    out.append(strip("verge", yard, kerb_h, o + yard / 2, seed * 10 + 6))
    o = r_kerb + kerb_w / 2
    walk_l_span = (-(o + walk_l), -o)
    if walk_l:
        out.append(strip("sidewalk", walk_l, kerb_h, -(o + walk_l / 2), seed * 10 + 7, paving_mat))
    o += walk_l
    left_edge = -o
    out.append(strip("verge", yard, kerb_h, -(o + yard / 2), seed * 10 + 8))
    if bay and g:                                     # the gutter last: the other strips keep their ids
        out.append(strip("gutter", g, 0.01, half_road + g / 2, seed * 10 + 10))

    def place(s, offset):
        p, n, h = _centre(street_pos, street_yaw, np.atleast_1d(s), L, bends)
        return p[0] + offset * n[0], float(h[0])

    # --- buildings and green blocks on both sides -------------------------------------
    out += ["", "// buildings (front facades towards the street) and green blocks"]
    side_lines = {}
    centreline = _Centreline(lambda s_: _centre(street_pos, street_yaw, s_, L, bends)[0], L + 40.0)
    for side in (1, -1):
        lines = line_street_side(rng, place, L - 12, side, right_edge if side > 0 else -left_edge, ids,
                                 FRONTAGES[v.frontage[0 if side < 0 else 1]], seed_of=pool)
        if side > 0 and near is not None and near.setback_right:
            lines = _pull_front_row(lines, centreline, behind + near.white_right + 15.0, right_edge, near.setback_right,
                                    np.random.default_rng([seed, 0x5E7]))
        if side < 0 and near is not None and near.setback_left:
            lines = _pull_front_row(lines, centreline, behind + LEFT_ROW_M, -left_edge, near.setback_left,
                                    np.random.default_rng([seed, 0x5E8]), clear_yards=False)
        if side > 0 and near is not None and near.works_right:
            lines = _works_row(lines, centreline, place, behind + near.open_right,
                               (behind + near.works_right[0], behind + near.works_right[1]), near.works_depth,
                               right_edge, near.setback_right, ids, np.random.default_rng([seed, 0x5CA]),
                               front=near.works_front)
        if side > 0 and near is not None and near.white_right > 0:    # the block under works white too (KITTI's)
            lines = _white_near(lines, centreline, behind, behind + max(near.white_right, *near.works_right))
            out.append(derived_material("white_render", "plaster", WHITE_RENDER, seed=seed))
        if side > 0 and near is not None and near.works_right:
            out.append(derived_material("works_blocks", "blockwork", seed=seed))
        if side > 0 and near is not None and near.gardens_right:   # the gardens' houses without balconies (KITTI's)
            lines = _plain_fronts(lines, centreline, behind + near.gardens_right[0] - 8.0,
                                  behind + near.gardens_right[1] + 8.0)
        out += lines
        side_lines[side] = lines

    # a building across the far end of the street closes the view
    p_end, h_end = place(L + 12.0, 0.0)
    out.append(asset("building", ids("building"), p_end, h_end, (2 * (right_edge + 10), 16.0, 12.0), seed=seed + 77))

    # --- street trees in the tree lawn, lights, signs, bollards --------------------------
    out += ["", "// street trees (tree lawn, right), street lights, signs (trees, cars, lights: a few variants, instanced)"]
    trees_at = {"lawn": [], "young": []}      # where the street trees stand (their stakes come below)
    s = float(rng.uniform(3, 8))
    treeless = (behind + near.gardens_right[0] - 3.0, behind + near.gardens_right[1] + 8.0) \
        if near is not None and near.gardens_right else (0.0, 0.0)
    if near is not None and near.works_right:   # and along the block being built: KITTI's frames 25-50 show
        # no street tree from the side street's mouth past its end (site fences and materials stand there)
        treeless = (treeless[0] if near.gardens_right else behind + near.open_right,
                    max(treeless[1], behind + near.works_right[1] + 2.0))
    while s < L - 5:
        p, _ = place(s, 0.5 * (lawn[0] + lawn[1]))
        seed_, size = pool.pick("lawn_tree")
        line = asset("tree", ids("tree"), p, rng.uniform(0, 360), size, seed=seed_)   # drawn all the same: the ids stay
        if not treeless[0] <= s <= treeless[1]:     # a scripted near field's gardens: a treeless strip past the side street
            out.append(line)
            trees_at["lawn"].append(p)
        s += float(rng.uniform(8, 13))
    s = float(rng.uniform(3, 8))
    while s < L - 5:                       # young trees along the left sidewalk's outer edge
        p, _ = place(s, left_edge - 1.2)
        seed_, size = pool.pick("young_tree")
        out.append(asset("tree", ids("tree"), p + np.array([0.0, kerb_h, 0.0]), rng.uniform(0, 360), size, seed=seed_))
        trees_at["young"].append(p + np.array([0.0, kerb_h, 0.0]))
        s += float(rng.uniform(9, 15))
    if near is not None and near.trees_left:
        out += _lawn_trees(np.random.default_rng([seed, 0x7E5]), place, behind, near.trees_left, out, pool, ids)
    for side in (1, -1):
        s = float(rng.uniform(5, 25)) + (0 if side > 0 else 14)
        kerb_out = r_kerb + kerb_w / 2
        out += street_lights(rng, place, s, L - 5, side, kerb_out + (lawn_w * 0.5 + 0.8 if side > 0 else 0.5), ids, seed_of=pool)
    for _ in range(int(L / 45)):
        side = int(rng.choice([1, -1]))
        s = float(rng.uniform(10, L - 10))
        o_sign = side * ((walk_r_span[0] + 0.4) if side > 0 else (-walk_l_span[1] + 0.4))
        p, h = place(s, o_sign)
        height = float(rng.uniform(2.2, 2.7))
        out.append(asset("pole", ids("furniture"), p, 0.0, (0.076, round(height + 0.35, 2), 0.076),
                         seed=int(rng.integers(1e6))))
        yaw_sign = h if side > 0 else h + 180
        front = np.array([np.sin(np.radians(yaw_sign)), 0.0, np.cos(np.radians(yaw_sign))])
        out.append(asset("sign", ids("furniture"), p + 0.07 * front, yaw_sign,
                         (round(float(rng.uniform(0.6, 0.8)), 2), round(height, 2), 0.025),
                         seed=int(rng.integers(1e6))))

    # public litter bins at the sidewalks' outer edge, every 40-80 m on either side (a stream of
    # their own: the layout drawn before and after them stays as it is)
    rng_bins = np.random.default_rng([seed, 0xB17])
    s = float(rng_bins.uniform(10, 40))
    while s < L - 10:
        side = 1 if rng_bins.random() < 0.5 else -1
        p, h = place(s, walk_r_span[1] - 0.4 if side > 0 else (walk_l_span[0] + 0.4 if walk_l else left_edge - 0.6))
        out.append(asset("bin", ids("furniture"), p + np.array([0.0, kerb_h, 0.0]), h - 90 if side > 0 else h + 90,
                         seed=pool.seeds["bin"][int(rng_bins.integers(POOLS["bin"]))]))
        s += float(rng_bins.uniform(40, 80))

    # --- near-field detail: works (scaffold, site fence), bike racks, the young trees' stakes --
    # (a stream of its own, ids after the furniture's: the layout and ids drawn before stay)
    out += ["", "// near-field detail: facade scaffolding and site fences at works, bike racks, tree stakes"]
    detail = _street_detail(np.random.default_rng([seed, 0xDE7]), side_lines, place, centreline, behind,
                            {1: right_edge, -1: -left_edge}, near, v.staked, trees_at, ids)
    out = _clear_footprints(out, [ln for ln in detail if ln.split()[1] in ("scaffold", "site_fence")]) + detail
    if near is not None and near.gardens_right:
        out += ["", "// front gardens before the right front row: hedges or shrubs, bikes, planters, bins, young trees"]
        out += _gardens(np.random.default_rng([seed, 0x6A7]), out, side_lines[1], place, centreline,
                        (behind + near.gardens_right[0], behind + near.gardens_right[1]), pool, ids, kerb_h,
                        tree_rng=np.random.default_rng([seed, 0x6A7, 0x7EE]))

    # --- grass (real blades) on the tree lawn and the first metres of the yards and fields --
    out += ["", "// grass: patches of blades on the lawns near the road (a few variants, instanced)"]
    tufts = [int(rng.integers(1e6)) for _ in range(6)]
    patch = 2.5
    bands = [(lawn[0] + 0.1, lawn[1] - 0.1), (right_edge + 0.2, right_edge + 14.0), (left_edge - 14.0, left_edge - 0.2)]
    for o0, o1 in bands:
        n_o = max(int(round((o1 - o0) / patch)), 1)
        for s_ in np.arange(patch / 2, L - patch / 2, patch):
            for j in range(n_o):
                off = o0 + (j + 0.5) * (o1 - o0) / n_o
                p, h = place(s_ + rng.uniform(-0.3, 0.3), off + rng.uniform(-0.2, 0.2))
                out.append(asset("grass_tuft", ids("grass"), p + np.array([0.0, kerb_h - 0.02, 0.0]),
                                 float(rng.choice([0, 90, 180, 270])), (patch * 1.15, v.grass_m, patch * 1.15),
                                 seed=tufts[rng.integers(len(tufts))]))

    # --- parked cars along both kerbs (none beside the start: the rig needs a clear view) --
    out += ["", "// parked cars along the kerbs (right side facing the drive)"]
    for side in (1, -1):
        s = behind + float(rng.uniform(12, 20)) if side > 0 else float(rng.uniform(5, 15))
        offset = half_road - 0.95
        if near is not None and side > 0:   # the real sequence's cars where its frames show them, then drawn on
            offset = near.car_offset
            for a in near.parked_ahead:
                p, h = place(behind + a, offset)
                out.append(asset("car", ids("car"), p, h + 180 + rng.uniform(-2, 2), seed=pool("car")))
            s = behind + near.parked_clear
        out += kerb_cars(rng, place, s, L - 8, side, offset, v.parking[0 if side > 0 else 1], ids, pool)

    # --- the drive: right lane, ~1.2 m per frame -----------------------------------------
    # the drive's wander, speed and body motion: cycles per 100 frames (~120 m), so a short sequence
    # is a stretch of the same drive; cycles per sequence gave 10 frames yaw steps of 3-9 deg (the
    # studies' fragile frame 5->6 step: docs/studies.md), where KITTI's are below 1 deg
    per_100 = (frames - 1) / 100.0

    def noise(cycles):
        return smooth_noise(rng, frames, 1.0, tuple(c * per_100 for c in cycles))

    speed = step_m * (1 + (SPEED_RMS if near is None else near.speed_rms) * noise((0.7, 1.6)))
    s_cam = behind + np.concatenate([[0.0], np.cumsum(speed[:-1])])
    lane = v.lane + v.weave * noise((0.8, 1.7, 3.1))
    c, n, h = _centre(street_pos, street_yaw, s_cam, L, bends)
    pos = c + lane[:, None] * n + [0.0, CAMERA_HEIGHT, 0.0]
    pos[:, 1] += v.body[2] * noise((9.0, 17.0))       # suspension
    drift = np.gradient(lane, s_cam)                                          # steering follows lane changes
    yaw = h - np.degrees(drift) + 0.25 * noise((3.0, 7.0))
    pitch = v.body[0] * noise((5.0, 11.0, 23.0))
    roll = v.body[1] * noise((4.0, 9.0, 19.0))
    traffic_kw = {} if near is None else {"lane_m": near.traffic_lane, "ahead_m": near.traffic_ahead,
                                          "oncoming": near.oncoming}
    out += _traffic(np.random.default_rng([seed, 0x7AF]), lambda s_: _centre(street_pos, street_yaw, s_, L, bends),
                    s_cam, step_m, L, int(traffic), ids, pool, **traffic_kw)
    return script_with_poses(out, f"the drive: {frames} poses of the left camera (KITTI: 1.65 m above the road, right lane)",
                             pos, yaw, pitch, roll)


if __name__ == "__main__":
    command_line(generate, __doc__, 101)
