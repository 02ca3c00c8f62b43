"""SES statements -> the scene model (blender_sesgen.model), with every semantic check.

All errors of a script are collected (file:line:col); if there is any, the first in
source order is raised as ScriptError and the whole list rides along as its ``errors``
attribute. A script with errors yields no Scene. The only files read are the script
itself and the TRAJECTORY file it names; texture and mesh files are only checked to exist.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Optional

import numpy as np

from .. import model, poses
from ..intrinsics import default_principal_point
from ..textures import BUILTIN_TEXTURES, NAME_TO_NUMBER
from .diagnostics import Diagnostics
from .geometry import quad_problem
from .grammar import OBJECT_KEYWORDS, SINGLETON_KEYWORDS
from .lexer import Token, decode, tokenize
from .statements import ParsedStatement, TagValue, did_you_mean, read_statement
from .trajectory_files import TrajectoryFileError, read_trajectory

MAX_ID = 32767                 # Blender's object-index pass clamps above this
MAX_RESOLUTION = 16384
MAX_SEED = 2**31 - 1           # Cycles seeds are 32-bit signed
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tga", ".tif", ".tiff", ".exr", ".hdr", ".webp")
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".gltf", ".glb")
LIGHT_DEFAULTS = {  # per kind: strength (sun W/m^2, others W) and size (point radius, area edge)
    "sun": (3.0, 0.0), "point": (500.0, 0.1), "area": (500.0, 1.0)}


def parse_bytes(data: bytes, source: str = "<string>", base_dir: Optional[str] = None) -> model.Scene:
    diags = Diagnostics(source)
    text = decode(data, diags)
    diags.raise_if_any()
    return parse_text(text, source, base_dir, diags)


def parse_text(text: str, source: str = "<string>", base_dir: Optional[str] = None,
               diags: Optional[Diagnostics] = None) -> model.Scene:
    diags = diags if diags is not None else Diagnostics(source)
    lines = tokenize(text, diags)
    statements = [s for s in (read_statement(tokens, diags) for tokens in lines) if s is not None]
    builder = _Builder(source, Path(base_dir) if base_dir is not None else Path.cwd(), diags)
    attempted_objects = any(t[0].kind == "word" and t[0].text.upper() in OBJECT_KEYWORDS for t in lines)
    scene = builder.build(statements, attempted_objects)
    diags.raise_if_any()
    return scene


class _Builder:
    def __init__(self, source: str, base_dir: Path, diags: Diagnostics):
        self.source, self.base_dir, self.diags = source, base_dir, diags

    # --- helpers ------------------------------------------------------------------------
    def err(self, token: Token, message: str) -> None:
        self.diags.at(token, message)

    def _positive(self, stmt: ParsedStatement, name: str, allow_zero: bool = False) -> None:
        tv = stmt.tags.get(name)
        if tv is None:
            return
        for value, tok in zip(tv.values, tv.tokens):
            if value < 0 or (value == 0 and not allow_zero):
                need = "zero or positive" if allow_zero else "positive"
                self.err(tok, f"{stmt.keyword} '{name}' must be {need}, got {tok.text}")

    def _unit_range(self, stmt: ParsedStatement, name: str) -> None:
        tv = stmt.tags.get(name)
        if tv is None:
            return
        for value, tok in zip(tv.values, tv.tokens):
            if not 0.0 <= value <= 1.0:
                self.err(tok, f"{stmt.keyword} '{name}' values must lie in 0..1, got {tok.text}")

    def _vec(self, stmt: ParsedStatement, name: str, default=None):
        tv = stmt.tags.get(name)
        return tuple(float(v) for v in tv.values) if tv is not None else default

    def _scalar(self, stmt: ParsedStatement, name: str, default=None):
        tv = stmt.tags.get(name)
        return tv.values[0] if tv is not None else default

    def _existing_file(self, stmt: ParsedStatement, tag: str, what: str = "") -> Optional[Path]:
        """The absolute path of a file tag's value (relative to the script), or None and an error."""
        tok = stmt.tags[tag].tokens[0]
        try:
            path = Path(os.path.abspath(self.base_dir / tok.text))
            found = path.is_file()
        except (ValueError, OSError):  # embedded NUL, unencodable name, ...
            self.err(tok, f"{stmt.keyword} '{tag}' is not a valid file name: {tok.shown()}")
            return None
        if not found:
            self.err(tok, what or f"{stmt.keyword} '{tag}' file '{tok.text}' not found (looked for {path})")
            return None
        return path

    def _seed(self, stmt: ParsedStatement, name: str = "seed") -> int:
        tv = stmt.tags.get(name)
        if tv is None:
            return 0
        if not 0 <= tv.values[0] <= MAX_SEED:
            self.err(tv.tokens[0], f"{stmt.keyword} '{name}' must lie in 0..{MAX_SEED}, got {tv.tokens[0].text}")
        return int(tv.values[0])

    # --- the whole script ---------------------------------------------------------------
    def build(self, statements: list[ParsedStatement], attempted_objects: bool) -> Optional[model.Scene]:
        seen: dict[str, ParsedStatement] = {}
        for stmt in statements:
            if stmt.keyword in SINGLETON_KEYWORDS:
                if stmt.keyword in seen:
                    self.err(stmt.token, f"only one {stmt.keyword} statement is allowed "
                                         f"(the first is on line {seen[stmt.keyword].token.line})")
                    continue
                seen[stmt.keyword] = stmt

        materials = self._materials([s for s in statements if s.keyword == "MATERIAL"])
        objects = self._objects([s for s in statements if s.keyword in OBJECT_KEYWORDS], materials)
        if not attempted_objects:
            self.diags.error(1, 1, "the script defines no objects: add at least one QUAD, CUBOID, SPHERE, "
                                   "CYLINDER or MESH")
        rig = self._rig(seen.get("CAMERA"))
        start = seen.get("START")
        start_position = self._vec(start, "position", (0.0, 0.0, 0.0))[:3] if start else (0.0, 0.0, 0.0)
        start_rotation = (self._vec(start, "position")[3:] or (0.0, 0.0, 0.0)) if start else (0.0, 0.0, 0.0)
        motion, T_world_left = self._motion(statements, seen, start_position, start_rotation)
        if motion.kind == "pose" and motion.keyframes:
            start_position, start_rotation = motion.keyframes[0][:3], motion.keyframes[0][3:]
        lights = tuple(light for light in (self._light(s) for s in statements if s.keyword == "LIGHT") if light)
        scene_kwargs = dict(
            world=self._world(seen.get("WORLD")), fog=self._fog(seen.get("FOG")),
            noise=self._noise(seen.get("NOISE")), render=self._render(seen.get("RENDER")))
        if self.diags:
            return None
        return model.Scene(
            source=self.source, objects=tuple(objects), rig=rig,
            start_position=tuple(start_position), start_rotation_deg=tuple(start_rotation),
            motion=motion, timeline=model.Timeline(T_world_left=tuple(model.mat4(T) for T in T_world_left)),
            materials=tuple(materials.values()), lights=lights, **scene_kwargs)

    # --- textures and materials ---------------------------------------------------------
    def _texture(self, stmt: ParsedStatement) -> Optional[model.TextureRef]:
        tv = stmt.tags.get("texture")
        scale_tv = stmt.tags.get("texture_scale")
        self._positive(stmt, "texture_scale")
        scale = float(scale_tv.values[0]) if scale_tv else 1.0
        if tv is None:
            if scale_tv is not None:
                self.err(scale_tv.tag, f"{stmt.keyword} 'texture_scale' needs a 'texture'")
            return None
        tok: Token = tv.tokens[0]
        text = tv.values[0]
        if tok.kind == "number":
            value = float(text)
            if not value.is_integer():
                self.err(tok, f"{stmt.keyword} 'texture' number must be an integer, got {text}")
                return None
            number = int(value)
            if number == 0:
                return None
            if number not in BUILTIN_TEXTURES:
                self.err(tok, f"{stmt.keyword} 'texture' {number} is not a built-in texture "
                              f"(0 = none, 1..{max(BUILTIN_TEXTURES)}: see docs/ses-language.md)")
                return None
            return model.TextureRef(kind="builtin", name=BUILTIN_TEXTURES[number][0], number=number, scale=scale)
        if tok.lower in NAME_TO_NUMBER:  # bare or quoted: a name ("./noise" names a file)
            number = NAME_TO_NUMBER[tok.lower]
            return model.TextureRef(kind="builtin", name=tok.lower, number=number, scale=scale)
        hint = did_you_mean(text, NAME_TO_NUMBER)
        path = self._existing_file(stmt, "texture", f"{stmt.keyword} 'texture' '{text}' is neither a built-in "
                                   f"texture name nor an existing image file (looked for "
                                   f"{os.path.join(self.base_dir, text)}){hint}")
        if path is None:
            return None
        if path.suffix.lower() not in IMAGE_SUFFIXES:
            self.err(tok, f"{stmt.keyword} 'texture' file '{text}' is not an image "
                          f"({', '.join(IMAGE_SUFFIXES)})")
            return None
        return model.TextureRef(kind="image", name=path.stem, path=str(path), source=text, scale=scale)

    def _materials(self, statements: list[ParsedStatement]) -> dict[str, model.Material]:
        materials: dict[str, model.Material] = {}
        first_line: dict[str, int] = {}
        for stmt in statements:
            name = stmt.get("name")
            if name in materials or name in first_line:
                self.err(stmt.tags["name"].tokens[0],
                         f"MATERIAL '{name}' is defined twice (first on line {first_line[name]})")
                continue
            first_line[name] = stmt.token.line
            for tag in ("colour", "emission", "roughness", "metallic", "specular"):
                self._unit_range(stmt, tag)
            self._positive(stmt, "emission_strength", allow_zero=True)
            before = len(self.diags.items)
            texture = self._texture(stmt)
            if len(self.diags.items) != before:
                continue
            materials[name] = model.Material(
                name=name, colour=self._vec(stmt, "colour", (0.8, 0.8, 0.8)), texture=texture,
                roughness=float(self._scalar(stmt, "roughness", 0.5)),
                metallic=float(self._scalar(stmt, "metallic", 0.0)),
                specular=float(self._scalar(stmt, "specular", 0.5)),
                emission=self._vec(stmt, "emission", (0.0, 0.0, 0.0)),
                emission_strength=float(self._scalar(stmt, "emission_strength", 0.0)))
        return materials

    # --- objects ------------------------------------------------------------------------
    def _objects(self, statements: list[ParsedStatement], materials: dict) -> list[model.SceneObject]:
        objects: list[model.SceneObject] = []
        ids: dict[int, ParsedStatement] = {}
        names: dict[str, ParsedStatement] = {}
        for stmt in statements:
            before = len(self.diags.items)
            id_tv: TagValue = stmt.tags["id"]
            obj_id = int(id_tv.values[0])
            if not 1 <= obj_id <= MAX_ID:
                self.err(id_tv.tokens[0], f"{stmt.keyword} 'id' must lie in 1..{MAX_ID} (0 is the background), "
                                          f"got {id_tv.tokens[0].text}")
            elif obj_id in ids:
                other = ids[obj_id]
                self.err(id_tv.tokens[0], f"duplicate id {obj_id}: already used by the {other.keyword} "
                                          f"on line {other.token.line}")
            else:
                ids[obj_id] = stmt
            shape = stmt.keyword.lower()
            name = stmt.get("name") or f"{shape}_{obj_id}"
            if name in names:
                self.err(stmt.tags["name"].tokens[0] if "name" in stmt.tags else stmt.token,
                         f"duplicate object name '{name}': already used on line {names[name].token.line}")
            else:
                names[name] = stmt
            self._unit_range(stmt, "colour")
            material = stmt.get("material")
            if material is not None and material not in materials:
                tok = stmt.tags["material"].tokens[0]
                known = f" (defined: {', '.join(materials)})" if materials else " (no MATERIAL is defined)"
                self.err(tok, f"{stmt.keyword} 'material' '{material}' is not defined{known}"
                              f"{did_you_mean(material, materials) if materials else ''}")
            texture = self._texture(stmt)
            common = dict(id=obj_id, name=name, colour=self._vec(stmt, "colour", (1.0, 1.0, 1.0)),
                          texture=texture, material=material, line=stmt.token.line)
            obj = getattr(self, f"_{shape}")(stmt, common)
            if obj is not None and len(self.diags.items) == before:
                objects.append(obj)
        return objects

    def _placement(self, stmt: ParsedStatement) -> dict:
        values = self._vec(stmt, "position", (0.0, 0.0, 0.0))
        return dict(position=values[:3], rotation_deg=values[3:] or (0.0, 0.0, 0.0))

    def _quad(self, stmt, common):
        v = self._vec(stmt, "vertices")
        vertices = (v[0:3], v[3:6], v[6:9], v[9:12])
        problem = quad_problem(vertices)
        if problem:
            self.err(stmt.tags["vertices"].tag, problem[1])
            return None
        return model.Quad(vertices=vertices, **common)

    def _cuboid(self, stmt, common):
        self._positive(stmt, "dim")
        return model.Cuboid(size=self._vec(stmt, "dim"), **self._placement(stmt), **common)

    def _sphere(self, stmt, common):
        self._positive(stmt, "dim")
        return model.Sphere(radius=self._vec(stmt, "dim")[0], **self._placement(stmt), **common)

    def _cylinder(self, stmt, common):
        self._positive(stmt, "dim")
        r, h = self._vec(stmt, "dim")
        return model.Cylinder(radius=r, height=h, **self._placement(stmt), **common)

    def _mesh(self, stmt, common):
        self._positive(stmt, "scale")
        scale = self._vec(stmt, "scale", (1.0,))
        tok = stmt.tags["file"].tokens[0]
        path = self._existing_file(stmt, "file")
        if path is None:
            return None
        if path.suffix.lower() not in MESH_SUFFIXES:
            self.err(tok, f"MESH 'file' '{tok.text}' has an unsupported format (use {', '.join(MESH_SUFFIXES)})")
            return None
        return model.Mesh(path=str(path), source=tok.text, scale=scale * 3 if len(scale) == 1 else scale,
                          **self._placement(stmt), **common)

    # --- rig and motion -----------------------------------------------------------------
    def _rig(self, stmt: Optional[ParsedStatement]) -> model.Rig:
        if stmt is None:
            return model.Rig()
        res = stmt.tags["resolution"]
        for value, tok in zip(res.values, res.tokens):
            if not float(value).is_integer() or not 1 <= value <= MAX_RESOLUTION:
                self.err(tok, f"CAMERA 'resolution' must be whole numbers in 1..{MAX_RESOLUTION}, got {tok.text}")
        self._positive(stmt, "focal")
        self._positive(stmt, "baseline", allow_zero=True)
        self._positive(stmt, "near")
        self._positive(stmt, "far")
        width, height = (int(v) for v in res.values)
        cx, cy = self._vec(stmt, "principal", default_principal_point(width, height))
        near = float(self._scalar(stmt, "near", model.Rig.near))
        far = float(self._scalar(stmt, "far", model.Rig.far))
        if near >= far:
            tv = stmt.tags.get("far") or stmt.tags["near"]
            self.err(tv.tokens[0], f"CAMERA 'near' ({near:g}) must be less than 'far' ({far:g})")
        return model.Rig(width=width, height=height, focal_px=float(self._scalar(stmt, "focal")),
                         cx=float(cx), cy=float(cy), baseline=float(self._scalar(stmt, "baseline", 0.0)),
                         near=near, far=far)

    def _motion(self, statements, seen, start_position, start_rotation):
        """(Motion, list of T_world_left) from EGO / POSE / TRAJECTORY (or START alone)."""
        kinds = {"EGO": "ego", "POSE": "pose", "TRAJECTORY": "trajectory"}
        first: dict[str, ParsedStatement] = {}
        for stmt in statements:
            if stmt.keyword not in kinds:
                continue
            for other, other_stmt in first.items():
                if other != stmt.keyword and stmt.keyword not in first:
                    self.err(stmt.token, f"{stmt.keyword} cannot be mixed with {other} (first {other} on line "
                                         f"{other_stmt.token.line}): describe the motion one way only")
                    break
            first.setdefault(stmt.keyword, stmt)
        T_start = poses.start_pose(start_position, start_rotation)
        if not first:
            return model.Motion(), [T_start]
        keyword = min(first, key=lambda k: first[k].token.line)
        if keyword == "EGO":
            ego = tuple(s.numbers for s in statements if s.keyword == "EGO")
            return model.Motion(kind="ego", ego=ego), list(poses.integrate_ego(T_start, ego))
        if keyword == "POSE":
            if "START" in seen:
                self.err(seen["START"].token, "START cannot be used with POSE: the first POSE line is frame 0")
            keyframes = tuple(s.numbers for s in statements if s.keyword == "POSE")
            return (model.Motion(kind="pose", keyframes=keyframes),
                    [poses.start_pose(k[:3], k[3:]) for k in keyframes])
        stmt = first["TRAJECTORY"]
        tok = stmt.tags["file"].tokens[0]
        fmt = stmt.get("format")
        path = self._existing_file(stmt, "file")
        motion = model.Motion(kind="trajectory", trajectory_path=str(path), trajectory_format=fmt)
        if path is None:
            return motion, [T_start]
        try:
            T_file = read_trajectory(str(path), fmt)
        except TrajectoryFileError as e:
            self.err(tok, f"TRAJECTORY file '{tok.text}' {e}")
            return motion, [T_start]
        # replayed relative to START: T_world_cam(k) = T_start . inv(T_file(0)) . T_file(k)
        T_start_file0 = T_start @ poses.invert(T_file[0])
        return motion, [T_start_file0 @ T for T in T_file]

    # --- environment --------------------------------------------------------------------
    def _light(self, stmt: ParsedStatement) -> Optional[model.Light]:
        kinds = [k for k in ("sun", "point", "area") if k in stmt.tags]
        if len(kinds) != 1:
            at = stmt.tags[kinds[1]].tag if len(kinds) > 1 else stmt.token
            self.err(at, "LIGHT needs exactly one of sun, point, area")
            return None
        kind = kinds[0]
        needs = {"sun": ("direction",), "point": ("position",), "area": ("position", "direction")}[kind]
        unused = {"sun": ("position", "size"), "point": ("direction",), "area": ()}[kind]
        for tag in needs:
            if tag not in stmt.tags:
                self.err(stmt.token, f"LIGHT {kind} needs the tag '{tag}'")
        for tag in unused:
            if tag in stmt.tags:
                self.err(stmt.tags[tag].tag, f"LIGHT {kind} takes no '{tag}'")
        self._unit_range(stmt, "colour")
        self._positive(stmt, "strength", allow_zero=True)
        self._positive(stmt, "size", allow_zero=(kind != "area"))
        direction = self._vec(stmt, "direction")
        if direction is not None:
            norm = float(np.linalg.norm(direction))
            if norm == 0.0:
                self.err(stmt.tags["direction"].tag, "LIGHT 'direction' must not be the zero vector")
                return None
            direction = tuple(float(x) / norm for x in direction)
        strength, size = LIGHT_DEFAULTS[kind]
        return model.Light(kind=kind, colour=self._vec(stmt, "colour", (1.0, 1.0, 1.0)),
                           strength=float(self._scalar(stmt, "strength", strength)),
                           position=self._vec(stmt, "position"), direction=direction,
                           size=float(self._scalar(stmt, "size", size)))

    def _world(self, stmt: Optional[ParsedStatement]) -> Optional[model.World]:
        if stmt is None:
            return None
        has_colour, has_sky = "colour" in stmt.tags, "sky" in stmt.tags
        if has_colour == has_sky:
            self.err(stmt.token, "WORLD needs either 'colour r g b' or 'sky' (one of them)")
            return None
        if has_colour:
            for tag in ("elevation", "azimuth"):
                if tag in stmt.tags:
                    self.err(stmt.tags[tag].tag, f"WORLD '{tag}' is only for 'WORLD sky'")
        self._unit_range(stmt, "colour")
        self._positive(stmt, "strength", allow_zero=True)
        elevation = self._scalar(stmt, "elevation", model.World.sun_elevation_deg)
        if not -90.0 <= elevation <= 90.0:
            self.err(stmt.tags["elevation"].tokens[0], f"WORLD 'elevation' must lie in -90..90 degrees, got {elevation:g}")
        return model.World(kind="sky" if has_sky else "colour",
                           colour=self._vec(stmt, "colour", model.World.colour),
                           strength=float(self._scalar(stmt, "strength", 1.0)),
                           sun_elevation_deg=float(elevation),
                           sun_azimuth_deg=float(self._scalar(stmt, "azimuth", 0.0)))

    def _fog(self, stmt: Optional[ParsedStatement]) -> Optional[model.Fog]:
        if stmt is None:
            return None
        self._positive(stmt, "start", allow_zero=True)
        self._unit_range(stmt, "colour")
        start, end = float(stmt.get("start")), float(stmt.get("end"))
        if end <= start:
            self.err(stmt.tags["end"].tokens[0], f"FOG 'end' ({end:g}) must be greater than 'start' ({start:g})")
        return model.Fog(start=start, end=end, colour=self._vec(stmt, "colour", (0.7, 0.7, 0.7)))

    def _noise(self, stmt: Optional[ParsedStatement]) -> Optional[model.Noise]:
        if stmt is None:
            return None
        self._positive(stmt, "sigma", allow_zero=True)
        return model.Noise(sigma=float(stmt.get("sigma")), seed=self._seed(stmt))

    def _render(self, stmt: Optional[ParsedStatement]) -> model.RenderSettings:
        if stmt is None:
            return model.RenderSettings()
        samples = stmt.tags["samples"]
        if not 1 <= samples.values[0] <= 1_000_000:
            self.err(samples.tokens[0], f"RENDER 'samples' must lie in 1..1000000, got {samples.tokens[0].text}")
        return model.RenderSettings(samples=int(samples.values[0]), denoise=stmt.get("denoise", "off") == "on",
                                    seed=self._seed(stmt))
