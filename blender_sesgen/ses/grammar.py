"""The SES grammar as data: each keyword's tags, their value counts and which are required.

A tag's ``kind`` says how its values are read:
- ``numbers``: finite numbers; ``counts`` lists the allowed counts (``position``: 3 or 6);
- ``int``: one integer;
- ``text``: one token of any kind (bare word, quoted string or number), e.g. a file name;
- ``choice``: one bare word from ``choices``;
- ``flag``: no values (``LIGHT sun``, ``WORLD sky``).
``usage`` is what messages and docs show. This table is the single source of the tag
syntax; docs/ses-language.md documents it (a test checks that every tag appears there).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ..scene.assets import KINDS as ASSET_KINDS
from ..scene.presets import QUALITIES
from ..scene.camera_profiles import PROFILES


@dataclass(frozen=True)
class Tag:
    name: str
    kind: str                    # numbers | int | text | choice | flag
    counts: tuple[int, ...] = (1,)
    required: bool = False
    usage: str = ""
    choices: tuple[str, ...] = ()


@dataclass(frozen=True)
class Statement:
    keyword: str
    tags: dict[str, Tag] = field(default_factory=dict)
    positional: int = 0          # EGO / POSE: a fixed count of numbers and no tags
    positional_usage: str = ""


def _tags(*tags: Tag) -> dict[str, Tag]:
    return {t.name: t for t in tags}


MAX_BENDS = 64  # pieces of a strip asset's centreline


def _num(name, counts=(1,), required=False, usage=""):
    return Tag(name, "numbers", counts, required, usage or f"{name} v")


# Tags every object accepts.
COMMON_OBJECT_TAGS = (
    Tag("id", "int", required=True, usage="id N"),
    Tag("name", "text", usage="name N"),
    Tag("texture", "text", usage="texture T"),
    _num("texture_scale", usage="texture_scale s"),
    _num("colour", (3,), usage="colour r g b"),
    Tag("material", "text", usage="material M"),
    Tag("class", "text", usage="class NAME"),
)
POSITION = _num("position", (3, 6), usage="position x y z [rx ry rz]")
POSITION_REQUIRED = Tag("position", "numbers", (3, 6), True, POSITION.usage)

STATEMENTS: dict[str, Statement] = {s.keyword: s for s in (
    Statement("QUAD", _tags(*COMMON_OBJECT_TAGS,
                            _num("vertices", (12,), True, "vertices x1 y1 z1 x2 y2 z2 x3 y3 z3 x4 y4 z4"))),
    Statement("CUBOID", _tags(*COMMON_OBJECT_TAGS, POSITION_REQUIRED,
                              _num("dim", (3,), True, "dim sx sy sz"), _num("bevel", usage="bevel r"))),
    Statement("SPHERE", _tags(*COMMON_OBJECT_TAGS, POSITION_REQUIRED,
                              _num("dim", (1,), True, "dim r"))),
    Statement("CYLINDER", _tags(*COMMON_OBJECT_TAGS, POSITION_REQUIRED,
                                _num("dim", (2,), True, "dim r h"))),
    Statement("MESH", _tags(*COMMON_OBJECT_TAGS, Tag("file", "text", required=True, usage="file PATH"),
                            POSITION, _num("scale", (1, 3), usage="scale s | scale sx sy sz"),
                            Tag("allow_external", "flag", usage="allow_external"))),
    Statement("ASSET", _tags(*COMMON_OBJECT_TAGS, POSITION_REQUIRED,
                             *(Tag(kind, "flag", usage=kind) for kind in ASSET_KINDS),
                             _num("size", (3,), usage="size sx sy sz"),
                             Tag("seed", "int", usage="seed n"),
                             _num("bend", tuple(range(1, MAX_BENDS + 1)), usage="bend deg [deg ...]"),
                             _num("offset", usage="offset o"),
                             Tag("ground_material", "text", usage="ground_material M"))),
    Statement("BLEND", _tags(Tag("file", "text", required=True, usage="file PATH"),
                             Tag("id", "int", required=True, usage="id N"),
                             Tag("collection", "text", usage="collection NAME"),
                             POSITION, _num("scale", (1, 3), usage="scale s | scale sx sy sz"),
                             Tag("class", "text", usage="class NAME"),
                             Tag("lights", "choice", usage="lights on|off", choices=("on", "off")),
                             Tag("allow_external", "flag", usage="allow_external"))),
    Statement("CAMERA", _tags(_num("resolution", (2,), True, "resolution W H"),
                              _num("focal", (1,), True, "focal F"),
                              _num("principal", (2,), usage="principal cx cy"),
                              _num("baseline", usage="baseline B"),
                              _num("near", usage="near n"),
                              _num("far", usage="far f"))),
    Statement("START", _tags(POSITION_REQUIRED)),
    Statement("EGO", positional=6, positional_usage="EGO U V W alpha beta gamma"),
    Statement("POSE", positional=6, positional_usage="POSE x y z rx ry rz"),
    Statement("FRAMES", positional=1, positional_usage="FRAMES N"),
    Statement("MOVE", _tags(Tag("id", "int", required=True, usage="id N"),
                            Tag("frame", "int", usage="frame F"),
                            POSITION,
                            _num("twist", (6,), usage="twist U V W alpha beta gamma"),
                            Tag("from", "int", usage="from F"),
                            Tag("to", "int", usage="to F"),
                            Tag("file", "text", usage="file PATH"),
                            Tag("format", "choice", usage="format tum|kitti", choices=("tum", "kitti")))),
    Statement("TRAJECTORY", _tags(Tag("file", "text", required=True, usage="file PATH"),
                                  Tag("format", "choice", required=True, usage="format tum|kitti",
                                      choices=("tum", "kitti")))),
    Statement("LIGHT", _tags(Tag("sun", "flag", usage="sun"), Tag("point", "flag", usage="point"),
                             Tag("spot", "flag", usage="spot"), Tag("area", "flag", usage="area"),
                             Tag("portal", "flag", usage="portal"),
                             _num("colour", (3,), usage="colour r g b"),
                             _num("strength", usage="strength s"),
                             _num("position", (3,), usage="position x y z"),
                             _num("direction", (3,), usage="direction dx dy dz"),
                             _num("size", (1, 2), usage="size s | size sx sy"),
                             _num("angle", usage="angle deg"),
                             _num("blend", usage="blend b"))),
    Statement("WORLD", _tags(_num("colour", (3,), usage="colour r g b"), Tag("sky", "flag", usage="sky"),
                             Tag("hdri", "text", usage="hdri NAME|FILE"),
                             _num("strength", usage="strength s"),
                             _num("elevation", usage="elevation deg"),
                             _num("azimuth", usage="azimuth deg"),
                             _num("aerosol", usage="aerosol a"),
                             _num("rotation", usage="rotation deg"))),
    Statement("MATERIAL", _tags(Tag("name", "text", required=True, usage="name N"),
                                _num("colour", (3,), usage="colour r g b"),
                                Tag("texture", "text", usage="texture T"),
                                _num("texture_scale", usage="texture_scale s"),
                                _num("roughness", usage="roughness r"),
                                _num("metallic", usage="metallic m"),
                                _num("specular", usage="specular s"),
                                _num("emission", (3,), usage="emission r g b"),
                                _num("emission_strength", usage="emission_strength s"),
                                Tag("library", "text", usage="library L"),
                                _num("wear", usage="wear w"),
                                _num("bump", usage="bump b"),
                                _num("variation", usage="variation v"),
                                Tag("seed", "int", usage="seed n"),
                                Tag("albedo_map", "text", usage="albedo_map FILE"),
                                Tag("normal_map", "text", usage="normal_map FILE"),
                                Tag("roughness_map", "text", usage="roughness_map FILE"),
                                _num("map_size", usage="map_size s"),
                                Tag("glow", "flag", usage="glow"))),
    Statement("FOG", _tags(_num("start", (1,), True, "start s"), _num("end", (1,), True, "end e"),
                           _num("colour", (3,), usage="colour r g b"))),
    Statement("NOISE", _tags(_num("sigma", (1,), True, "sigma s"), Tag("seed", "int", usage="seed n"))),
    Statement("LOOK", _tags(Tag("view", "choice", usage="view agx|filmic|standard",
                                choices=("agx", "filmic", "standard")),
                            Tag("look", "choice", usage="look base|punchy|...|very_high_contrast",
                                choices=("base", "punchy", "very_low_contrast", "low_contrast", "medium_low_contrast",
                                         "medium_high_contrast", "high_contrast", "very_high_contrast")),
                            Tag("exposure", "text", usage="exposure auto|EV"))),
    Statement("TIMING", _tags(_num("rate", usage="rate HZ"), _num("start", usage="start S"),
                              _num("exposure", usage="exposure S"), _num("readout", usage="readout S"),
                              Tag("blur", "choice", usage="blur on|off", choices=("on", "off")),
                              Tag("still", "choice", usage="still on|off", choices=("on", "off")))),
    Statement("LENS", _tags(_num("brown", (4, 5), usage="brown k1 k2 p1 p2 [k3]"),
                            _num("fisheye", (4,), usage="fisheye k1 k2 k3 k4"),
                            _num("fnumber", usage="fnumber N"), _num("defocus", usage="defocus PX"),
                            _num("vignetting", usage="vignetting V"), _num("chromatic", usage="chromatic PX"))),
    Statement("SENSOR", _tags(Tag("profile", "choice", usage="profile " + "|".join(PROFILES), choices=tuple(PROFILES)),
                              Tag("native", "int", usage="native PX"),
                              _num("fullwell", usage="fullwell E"), _num("readnoise", usage="readnoise E"),
                              _num("dark", usage="dark E_PER_S"), _num("prnu", usage="prnu F"),
                              _num("dsnu", usage="dsnu E"), _num("rownoise", usage="rownoise E"),
                              Tag("cfa", "choice", usage="cfa rggb|bggr|grbg|gbrg",
                                  choices=("rggb", "bggr", "grbg", "gbrg")),
                              Tag("mono", "choice", usage="mono on|off", choices=("on", "off")),
                              _num("nir", usage="nir F"),
                              Tag("bits", "int", usage="bits N"), _num("gain", usage="gain G"),
                              _num("black", usage="black DN"), _num("saturation", usage="saturation L"),
                              Tag("response", "choice", usage="response srgb|linear|gamma",
                                  choices=("srgb", "linear", "gamma")),
                              _num("gamma", usage="gamma G"), _num("pixel", usage="pixel UM"),
                              _num("fill", usage="fill F"), _num("olpf", usage="olpf PX"),
                              Tag("jpeg", "int", usage="jpeg QUALITY"), Tag("seed", "int", usage="seed n"))),
    Statement("AUTOEXPOSURE", _tags(_num("target", usage="target T"), _num("speed", usage="speed PER_S"),
                                    _num("max_exposure", usage="max_exposure S"), _num("max_gain", usage="max_gain G"),
                                    _num("min_exposure", usage="min_exposure S"),
                                    Tag("start", "choice", usage="start converged|nominal",
                                        choices=("converged", "nominal")))),
    Statement("IMU", _tags(_num("rate", usage="rate HZ"), _num("gyro_noise", usage="gyro_noise D"),
                           _num("gyro_walk", usage="gyro_walk D"), _num("accel_noise", usage="accel_noise D"),
                           _num("accel_walk", usage="accel_walk D"), POSITION, _num("offset", usage="offset S"),
                           _num("gravity", usage="gravity G"), Tag("seed", "int", usage="seed n"))),
    Statement("RENDER", _tags(Tag("quality", "choice", usage="quality gt|draft|final|reference", choices=QUALITIES),
                              Tag("samples", "int", usage="samples N"),
                              Tag("denoise", "choice", usage="denoise on|off", choices=("on", "off")),
                              Tag("seed", "int", usage="seed n"))),
)}

OBJECT_KEYWORDS = ("QUAD", "CUBOID", "SPHERE", "CYLINDER", "MESH", "ASSET")
SINGLETON_KEYWORDS = ("CAMERA", "START", "FRAMES", "TRAJECTORY", "WORLD", "FOG", "NOISE", "LOOK", "RENDER",
                      "TIMING", "LENS", "SENSOR", "AUTOEXPOSURE", "IMU")
TAG_SYNONYMS = {"color": "colour"}

# Words people write for what this language says otherwise, and what to write instead: word ->
# (the statement's tag that says it, the hint), tried in order; the first tag the statement
# has gives the hint ({usage}: that tag's usage; {keyword}; {kind}: the statement's first
# kind). "KIND" stands for a statement's kinds, the bare words after its keyword (ASSET car,
# LIGHT sun, WORLD sky).
_KIND = ("KIND", "the kind is a word of its own right after the keyword: '{keyword} {kind} ...'")
_DIM = ("dim", "the size is '{usage}'")
_ROTATION = (("direction", "a light is turned by '{usage}' (the way it shines)"),
             ("position", "the rotation is the last three numbers of '{usage}', in degrees"))
TAG_HINTS: dict[str, tuple[tuple[str, str], ...]] = {
    **{w: (_KIND,) for w in ("kind", "type", "shape", "model")},
    **{w: (("resolution", "write '{usage}'"), _DIM) for w in ("width", "height", "res")},
    **{w: (_DIM,) for w in ("radius", "size", "dims", "dimensions", "extent", "length", "depth", "diameter")},
    **{w: _ROTATION for w in ("rotation", "rot", "orientation", "angles", "euler", "yaw", "heading")},
    **{w: (("position", "write '{usage}'"),) for w in ("pos", "location", "loc", "translation", "origin", "at")},
    **{w: (("strength", "write '{usage}'"),) for w in ("intensity", "power", "energy", "brightness", "watts")},
    **{w: (("focal", "write '{usage}' (pixels)"),) for w in ("f", "fx", "focal_length", "focallength", "fov")},
    **{w: (("principal", "write '{usage}'"),) for w in ("cx", "cy", "pp", "principal_point", "center", "centre")},
    **{w: (("rate", "write '{usage}'"),) for w in ("fps", "framerate", "frame_rate", "hz")},
    **{w: (("colour", "write '{usage}' (0..1 each)"),) for w in ("rgb", "albedo", "diffuse")},
    **{w: (("size", "write '{usage}' (metres)"), _DIM) for w in ("scale", "scaling")},
    **{w: (("file", "write '{usage}'"),) for w in ("path", "filename", "filepath", "src", "source")},
    **{w: (("twist", "a constant motion is '{usage}' (per frame, in the object's own frame)"),)
       for w in ("velocity", "speed", "motion")},
}
