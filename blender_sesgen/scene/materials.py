"""The named material library: procedural PBR materials built for realism (pure data).

A script selects one by name (``material asphalt`` where no MATERIAL of that name is
defined) or derives its own from one (``MATERIAL name old_road library asphalt wear 0.6
colour 0.12 0.12 0.12``). This module is the single source of the names, their documented
defaults and the per-object variation rule; the Blender node setups live in
``blender/library/`` (one recipe per name), pictures in docs/rendering.md (Material library).

Conventions every entry follows:
- **Units**: patterns are laid out in metres on the object's own coordinates (object-local,
  times the object's scale), so a brick is 24 cm long on every object and patterns stick to
  the surface. ``scale_m`` is the size of the entry's main element (a brick's length, a
  tile's edge, a plank's width, a stone's diameter); ``texture_scale s`` divides it.
- **Colours** are linear albedos (what a spectrophotometer would give, not sRGB): real
  surfaces lie between ~0.03 (fresh asphalt, rubber) and ~0.85 (fresh white paint).
- **Relief** is shading only (Cycles' Bump node: the normal changes, the geometry never
  does, so depth and ids are untouched); ``bump_m`` is its depth in metres at ``bump 1``.
- **Variation**: every object gets its own pattern offset and a small colour/roughness
  shift from :func:`object_variation` (a pure function of the material seed and the
  object id), so two walls of the same brick never repeat each other.
- **Wear** (0..1) adds dirt, stains and the entry's own ageing (rust, worn paint, moss).
- **Statistics**: variation at every scale a camera resolves, with the contrasts of the
  real surface at each (asphalt's light stones in near-black binder at millimetres, its
  ravelling at centimetres, stains at decimetres; concrete's sand speckle), not one
  high-contrast noise everywhere (what made the old renders look synthetic) and not flat
  paint either (what made the first library's roads and floors smoother than a camera
  sees them: docs/rendering.md, "Side by side with real camera images").
"""
from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass
from typing import Optional

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class LibraryEntry:
    """One named material: its documented defaults (override them with MATERIAL tags)."""
    name: str
    description: str
    colour: Vec3                   # main linear albedo (``colour`` replaces it)
    roughness: float               # mean roughness (``roughness`` replaces it)
    metallic: float = 0.0          # 0 dielectric, 1 metal (``metallic`` replaces it)
    scale_m: float = 1.0           # size of the main element, metres
    bump_m: float = 0.001          # relief depth at ``bump 1``, metres
    variation: float = 0.3         # per-object colour variation (0..1)
    wear: float = 0.2              # default wear/dirt (0..1)
    semantic_class: Optional[str] = None  # default ``class`` of objects using it
    nir: Optional[float] = None    # reflectance at 700-1000 nm (None: as in the visible); see band_colour
    transmittance: float = 0.0     # share of light passed, scattered evenly (diffusing glazing, leaves); 0: opaque


def _entries(*entries: LibraryEntry) -> dict[str, LibraryEntry]:
    return {e.name: e for e in entries}


LIBRARY: dict[str, LibraryEntry] = _entries(
    # --- streets --------------------------------------------------------------------------
    LibraryEntry("asphalt", "road asphalt: light AC 11 stones in dark binder, ravelling, oil stains, tonal "
                            "patches, sealed cracks",
                 (0.085, 0.085, 0.082), 0.88, scale_m=2.0, bump_m=0.0015, variation=0.25, wear=0.3,
                 semantic_class="road", nir=0.12),
    LibraryEntry("lane_marking", "white road paint, worn where tyres pass (colour for yellow lines)",
                 (0.72, 0.72, 0.70), 0.55, scale_m=0.5, bump_m=0.0008, variation=0.1, wear=0.3,
                 semantic_class="road", nir=0.75),
    LibraryEntry("concrete", "cast concrete: sand speckle, stains, pores; scuffs and dirt with wear",
                 (0.38, 0.37, 0.35), 0.85, scale_m=1.0, bump_m=0.0015, variation=0.3, wear=0.3,
                 semantic_class="wall", nir=0.4),
    LibraryEntry("paving", "concrete pavers of a sidewalk (20 x 10 cm, running bond) with 4 mm sand joints, "
                           "per-paver tone, sand speckle, chipped edges, dirt in the joints with wear",
                 (0.30, 0.29, 0.27), 0.85, scale_m=0.2, bump_m=0.003, variation=0.25, wear=0.3,
                 semantic_class="sidewalk", nir=0.35),
    # KITTI sequence_1's parking bay: dark grey concrete blocks (weathered, ~0.15) in straight
    # rows with light sand joints, 1.2-1.45 x the sunlit asphalt beside it (docs/sensors.md, Camera twins)
    LibraryEntry("setts", "block paving of a parking bay or square: 20 cm blocks in straight rows, 6 mm light "
                          "sand joints, per-block tone, oil stains and litter with wear",
                 (0.15, 0.145, 0.14), 0.8, scale_m=0.2, bump_m=0.003, variation=0.2, wear=0.3,
                 semantic_class="sidewalk", nir=0.15),
    # grey granite kerbs: albedo 0.2-0.35 (light grey granite ~0.35, weathered and dirty ~0.2; the
    # sunlit kerb tops of KITTI sequence_1 are 2.4 x its asphalt, whose albedo is ~0.085-0.1)
    LibraryEntry("granite", "grey granite (kerb stones, setts, steps): 2-6 mm grains of black mica, grey quartz "
                            "and white feldspar, stains, tyre scuffs with wear",
                 (0.26, 0.26, 0.25), 0.7, scale_m=0.004, bump_m=0.001, variation=0.2, wear=0.3,
                 semantic_class="sidewalk", nir=0.3),
    LibraryEntry("brick", "brick wall, stretcher bond: 24 x 7.1 cm bricks with 1 cm recessed mortar, "
                          "per-brick colour, chipped faces", (0.26, 0.10, 0.06), 0.85, scale_m=0.24,
                 bump_m=0.004, variation=0.35, wear=0.2, semantic_class="building", nir=0.45),
    # a building site's bare masonry: sand-lime blocks (KS-Planstein 498 x 248 mm, thin-bed mortar) as
    # KITTI sequence_1's scaffolded building shows them above its insulated ground floor (frames
    # 15-45): a light grey grid of per-block tone and dark joint lines a pixel resolves 10-30 m away
    LibraryEntry("blockwork", "bare masonry of sand-lime blocks (50 x 25 cm, running bond): 2 mm thin-bed joints "
                              "between bevelled arrises, per-block tone, a few damp blocks, mortar smears and dust",
                 (0.50, 0.49, 0.46), 0.9, scale_m=0.5, bump_m=0.003, variation=0.2, wear=0.3,
                 semantic_class="building", nir=0.55),
    LibraryEntry("plaster", "painted render/plaster wall: orange-peel relief, faint patches, grime streaks",
                 (0.62, 0.58, 0.52), 0.8, scale_m=1.0, bump_m=0.0008, variation=0.25, wear=0.2,
                 semantic_class="building", nir=0.65),
    LibraryEntry("roof_tiles", "clay roof tiles in overlapping rows (33 x 20 cm), per-tile colour, moss with wear",
                 (0.28, 0.085, 0.045), 0.75, scale_m=0.33, bump_m=0.012, variation=0.3, wear=0.3,
                 semantic_class="building", nir=0.45),
    # --- indoor / built ---------------------------------------------------------------------
    LibraryEntry("wood_planks", "varnished wooden planks (14 cm x 1.2-2 m), grain and per-plank tone",
                 (0.33, 0.19, 0.09), 0.45, scale_m=0.14, bump_m=0.002, variation=0.35, wear=0.15,
                 semantic_class="floor", nir=0.5),
    LibraryEntry("ceramic_tiles", "glazed ceramic tiles (30 cm) with 3 mm grout, per-tile tint",
                 (0.62, 0.62, 0.60), 0.12, scale_m=0.30, bump_m=0.0015, variation=0.15, wear=0.15,
                 semantic_class="floor", nir=0.65),
    LibraryEntry("fabric", "woven upholstery fabric: sheen, soft folds in tone, faint weave",
                 (0.18, 0.20, 0.26), 0.9, scale_m=0.004, bump_m=0.0003, variation=0.3, wear=0.1,
                 semantic_class="furniture"),
    LibraryEntry("plastic", "moulded plastic: glossy with faint texture, smudges with wear",
                 (0.55, 0.55, 0.55), 0.35, scale_m=0.05, bump_m=0.00005, variation=0.2, wear=0.1),
    LibraryEntry("rubber", "black rubber (tyres, seals): matte, dusty with wear",
                 (0.035, 0.035, 0.035), 0.85, scale_m=0.02, bump_m=0.0002, variation=0.1, wear=0.3, nir=0.04),
    # --- metals and glass -------------------------------------------------------------------
    LibraryEntry("metal_painted", "painted steel: orange-peel paint, chips showing primer and steel with wear",
                 (0.12, 0.22, 0.16), 0.4, scale_m=0.5, bump_m=0.0002, variation=0.2, wear=0.2,
                 semantic_class="pole"),
    LibraryEntry("metal_brushed", "brushed stainless steel: fine directional streaks along the object's x axis",
                 (0.58, 0.58, 0.58), 0.3, metallic=1.0, scale_m=0.2, bump_m=0.00005, variation=0.1, wear=0.1),
    LibraryEntry("metal_rusty", "weathered steel: paint and steel giving way to rust (more with wear)",
                 (0.30, 0.30, 0.29), 0.5, metallic=1.0, scale_m=0.5, bump_m=0.001, variation=0.3, wear=0.5,
                 semantic_class="pole"),
    # hot-dip galvanised steel a few years out (scaffold tubes, fences, lamp posts): the zinc's
    # bright spangle turns to a dull, light grey patina (zinc carbonate) that scatters rather than
    # mirrors, albedo ~0.35-0.5; KITTI sequence_1's scaffold tubes read light grey against the wall
    # behind them, where a mirror-like metal reflects the dark street and reads near black
    LibraryEntry("galvanised", "weathered hot-dip galvanised steel (scaffold tubes, fences): a dull light grey "
                               "zinc patina over spangle crystals of 1-3 cm, bright zinc where worn, white rust "
                               "and dirt with wear",
                 (0.40, 0.40, 0.38), 0.6, metallic=0.0, scale_m=0.02, bump_m=0.0002, variation=0.2, wear=0.3,
                 semantic_class="pole", nir=0.4),
    LibraryEntry("chrome", "polished chrome: a near-perfect mirror with faint smudges",
                 (0.55, 0.56, 0.55), 0.05, metallic=1.0, scale_m=0.1, bump_m=0.0001, variation=0.05, wear=0.1),
    LibraryEntry("vehicle_lamp", "vehicle lamp: a metallised reflector behind a lens of the colour (red, amber, clear) "
                                 "whose pillow optics spread what it returns; the lens's gloss on top; its dyes pass "
                                 "the near infrared", (0.7, 0.05, 0.04), 0.4, metallic=1.0, scale_m=0.04,
                 bump_m=0.0001, variation=0.05, wear=0.1, nir=0.7),
    LibraryEntry("car_paint", "car paint: metallic base coat under a glossy clear coat (colour for the car's)",
                 (0.05, 0.09, 0.20), 0.35, metallic=0.5, scale_m=0.5, bump_m=0.00003, variation=0.5, wear=0.15,
                 semantic_class="car"),
    LibraryEntry("glass_window", "window glass: mirror-like reflections over a dark interior (curtains, rooms); "
                                 "opaque, so depth is the glass", (0.035, 0.038, 0.04), 0.03, scale_m=1.5,
                 bump_m=0.0003, variation=0.5, wear=0.1, semantic_class="window"),
    # opal (diffusing) glazing: 3 mm opal acrylic/polycarbonate or a white sheer curtain passes
    # 40-60 % of daylight and reflects 30-45 %, both nearly Lambertian; 0.40 + 0.45 leaves 15 %
    # absorbed. Light passes, the view does not: lit from behind it glows evenly, and a camera
    # exposed for the room sees it burnt out (EuRoC V1_01's curtained window, docs/sensors.md)
    LibraryEntry("frosted_glass", "diffusing glazing (opal glass or polycarbonate, a white curtain): reflects "
                                  "and transmits diffusely, light passes, the view does not; depth is the pane",
                 (0.40, 0.40, 0.39), 0.6, scale_m=0.5, bump_m=0.0002, variation=0.1, wear=0.1,
                 semantic_class="window", transmittance=0.45),
    # --- nature -----------------------------------------------------------------------------
    LibraryEntry("grass", "lawn seen from a few metres: clumps, dry and lush patches, lit blade tips over shaded "
                          "thatch, dead blades, clover, bare earth with wear; its blades pass about what they "
                          "reflect (as leaves)",
                 (0.06, 0.10, 0.03), 0.9, scale_m=0.3, bump_m=0.006, variation=0.3, wear=0.2,
                 semantic_class="terrain", nir=0.45, transmittance=0.0864),
    # a green leaf passes about as much light as it reflects, band by band (PROSPECT; Jacquemoud
    # & Baret 1990: ~0.05-0.1 in the visible, ~0.45 in the near infrared): transmittance = the
    # colour's luminance (gain 1), so a sensor's band colour (band_colour, NIR included) is
    # passed too and the crowns' and hedges' inner leaves glow as real ones do
    # a leaf's surface: the crowns are real leaves (scene/assets/vegetation.py), each a flat lamina
    # folded along its mid-rib by the mesh; the shade between them is geometry (session 18)
    LibraryEntry("leaves", "leaves: each leaf its own tone (age, sun and shade leaves), a flat lamina with veins, "
                           "yellowed leaves with wear; passes about what it reflects",
                 (0.05, 0.09, 0.025), 0.6, scale_m=0.08, bump_m=0.0005, variation=0.35, wear=0.15,
                 semantic_class="vegetation", nir=0.45, transmittance=0.0768),
    LibraryEntry("bark", "tree bark: vertical ridges along the object's y axis, lichen with wear",
                 (0.13, 0.10, 0.08), 0.9, scale_m=0.05, bump_m=0.01, variation=0.3, wear=0.3,
                 semantic_class="vegetation", nir=0.3),
    LibraryEntry("soil", "bare earth: clods, small stones, damp patches", (0.14, 0.10, 0.07), 0.95,
                 scale_m=0.1, bump_m=0.004, variation=0.3, wear=0.3, semantic_class="terrain", nir=0.3),
    LibraryEntry("gravel", "loose gravel: rounded 2-4 cm stones of varied tone with dark gaps",
                 (0.30, 0.28, 0.25), 0.85, scale_m=0.03, bump_m=0.008, variation=0.25, wear=0.2,
                 semantic_class="terrain", nir=0.35),
)

# the tags of ``MATERIAL ... library L`` and what they change (docs/ses-language.md)
OVERRIDES = ("colour", "roughness", "metallic", "texture_scale", "wear", "bump", "variation", "seed")


def entry(name: str) -> LibraryEntry:
    """The library entry ``name`` (case-insensitive); KeyError if there is none."""
    return LIBRARY[name.lower()]


def is_library_name(name: str) -> bool:
    return name.lower() in LIBRARY


def _luminance(c) -> float:
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


def transmission_gain(e: LibraryEntry) -> float:
    """Passed over reflected light of entry ``e`` at its own colour (0 for opaque entries)."""
    return e.transmittance / max(_luminance(e.colour), 1e-6)


def transmitted_colour(colour: Vec3, e: LibraryEntry) -> Vec3:
    """What a pane of entry ``e`` in reflected ``colour`` passes to its other side, per
    channel: ``transmittance`` scaled with the colour's luminance over the entry's own (a
    darker, dirtier pane passes less) and at most 1 - colour (reflected plus passed never
    exceed what falls on it). The recipe builds the same in nodes (blender/library)."""
    k = transmission_gain(e)
    return tuple(min(k * float(c), 1.0 - float(c)) for c in colour)


def band_colour(colour: Vec3, name: str, nir_share: float) -> Vec3:
    """The albedo of library material ``name`` in ``colour`` as a sensor sees it that takes
    ``nir_share`` of a spectrally flat surface's signal from 700-1000 nm (a camera without an
    IR-cut filter, docs/sensors.md "Near infrared"): (1 - s) colour + s NIR, per channel, the
    entry's NIR reflectance scaled with the colour's luminance over the entry's own (a darker
    variant is darker in the NIR too). Unchanged for s = 0 and for entries without ``nir``."""
    e = LIBRARY.get(name.lower())
    if nir_share <= 0 or e is None or e.nir is None:
        return tuple(colour)
    nir = min(e.nir * _luminance(colour) / max(_luminance(e.colour), 1e-6), 0.95)
    return tuple((1.0 - nir_share) * float(c) + nir_share * nir for c in colour)


@dataclass(frozen=True)
class ObjectVariation:
    """What makes one object's copy of a library material its own.

    ``offset_m``: added to the object's coordinates before the pattern (metres, each
    component in -500..500); ``rand``: three numbers in 0..1 the recipes use for the
    object's colour, roughness and wear shifts.
    """
    offset_m: Vec3
    rand: Vec3


def object_variation(seed: int, object_id: int) -> ObjectVariation:
    """A pure, platform-independent function of (material seed, object id): SHA-256 of
    the two integers, its first 24 bytes read as six little-endian uint32 in 0..1."""
    digest = hashlib.sha256(struct.pack("<qq", int(seed), int(object_id))).digest()
    u = [x / 2**32 for x in struct.unpack("<6I", digest[:24])]
    return ObjectVariation(offset_m=tuple(1000.0 * (v - 0.5) for v in u[:3]), rand=tuple(u[3:]))
