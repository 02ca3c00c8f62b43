"""SES statements -> the scene model (blender_sesgen.scene.model): the orchestrator.

Owns the whole-script flow (lex, read statements, one-per-script singletons, at least one
object), the object statements (QUAD, CUBOID, SPHERE, CYLINDER, MESH, ASSET: ids and names
unique, materials defined or from the library, semantic classes), BLEND imports, the CAMERA rig, and the assembly of the Scene. Materials and
textures live in ``materials``, START/EGO/POSE/TRAJECTORY/FRAMES in ``motion``, MOVE in
``object_motion``, LIGHT/WORLD/FOG/NOISE/RENDER in ``environment``; all report through one
``checks.Checks``.

All errors of a script are collected (file:line:col); if there is any, the first in
source order is raised as ScriptError and the whole list rides along as its ``errors``
attribute. A script with errors yields no Scene. The only files read are the script
itself, the TRAJECTORY (and MOVE) files it names, the image files it names (decoded:
``blender_sesgen.files.image_check``) and the references inside MESH models (``mesh_files``: they
must stay inside the model's folder), and a BLEND file's signature; mesh geometry and
BLEND contents are read by Blender at render time.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Optional

from ..scene import assets, model
from ..contract.camera import default_principal_point
from . import environment
from .sensor import sensor_models
from .checks import Checks, scalar, vec
from .diagnostics import Diagnostics
from .geometry import quad_problem
from .grammar import OBJECT_KEYWORDS, SINGLETON_KEYWORDS
from .lexer import decode, tokenize
from .materials import library_material, materials, texture
from .mesh_content import content_problems
from .mesh_files import reference_problems
from ..scene.materials import LIBRARY, entry, is_library_name
from ..contract import semantics
from .motion import rig_motion
from .object_motion import object_motions
from .statements import ParsedStatement, TagValue, did_you_mean, read_statement

MAX_ID = 32767                 # Blender's object-index pass clamps above this
MAX_RESOLUTION = 16384
MIN_RESOLUTION = 4      # Blender renders nothing smaller
MIN_NEAR = 1e-6         # Blender's nearest clip distance
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".gltf", ".glb")
MAX_SEED = 2**31 - 1
MAX_BEND_DEG = 90.0


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
    check = Checks(Path(base_dir) if base_dir is not None else Path.cwd(), diags)
    attempted_objects = any(t[0].kind == "word" and t[0].text.upper() in (*OBJECT_KEYWORDS, "BLEND") for t in lines)
    scene = _build(source, statements, attempted_objects, check)
    diags.raise_if_any()
    return scene


def _build(source: str, statements: list[ParsedStatement], attempted_objects: bool,
           check: Checks) -> Optional[model.Scene]:
    """The Scene of the whole script, or None if any error was recorded."""
    seen: dict[str, ParsedStatement] = {}
    for stmt in statements:
        if stmt.keyword in SINGLETON_KEYWORDS:
            if stmt.keyword in seen:
                check.err(stmt.token, f"only one {stmt.keyword} statement is allowed "
                                      f"(the first is on line {seen[stmt.keyword].token.line})")
                continue
            seen[stmt.keyword] = stmt

    named_materials = materials([s for s in statements if s.keyword == "MATERIAL"], check)
    objects = _Objects(check, named_materials).build([s for s in statements if s.keyword in OBJECT_KEYWORDS])
    for o in objects:  # library materials named directly by objects
        for name in (o.material, getattr(o, "ground_material", None)):
            if name is not None and name not in named_materials:
                named_materials[name] = library_material(name)
    objects = [_with_class(o, named_materials) for o in objects]
    imports = [b for b in (_blend(s, check, {o.id: o for o in objects}) for s in statements if s.keyword == "BLEND") if b]
    if not attempted_objects:
        check.diags.error(1, 1, "the script defines no objects: add at least one QUAD, CUBOID, SPHERE, "
                                "CYLINDER, MESH, ASSET or BLEND")
    rig = _rig(seen.get("CAMERA"), check)
    moving = rig_motion(statements, seen.get("START"), check)
    attempted_ids = frozenset(int(s.tags["id"].values[0]) for s in statements
                              if s.keyword in OBJECT_KEYWORDS and "id" in s.tags)
    motions = object_motions([s for s in statements if s.keyword == "MOVE"], objects,
                             len(moving.timeline.T_world_left), check, attempted_ids)
    lights = tuple(light for light in (environment.light(s, check) for s in statements if s.keyword == "LIGHT")
                   if light)
    scene_kwargs = dict(
        world=environment.world(seen.get("WORLD"), check), fog=environment.fog(seen.get("FOG"), check),
        noise=environment.noise(seen.get("NOISE"), check), look=environment.look(seen.get("LOOK"), check),
        render=environment.render(seen.get("RENDER"), check),
        **sensor_models(seen, rig, check, len(moving.timeline.T_world_left)))
    if check.diags:
        return None
    return model.Scene(source=source, objects=tuple(objects), imports=tuple(imports), rig=rig, **moving._asdict(),
                       materials=tuple(named_materials.values()), lights=lights, object_motions=motions,
                       **scene_kwargs)


BLEND_MAGICS = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")   # plain, gzip, zstd
MAX_BLEND_BYTES = 64 << 30                                         # a whole environment, not a disk


def _blend(stmt: ParsedStatement, check: Checks, objects: dict) -> Optional[model.BlendImport]:
    """A BLEND statement (None and an error if it is wrong). The file is checked to be a
    .blend by its signature; its objects and their ids are only known when it is loaded."""
    before = len(check.diags.items)
    id_tv = stmt.tags["id"]
    first = int(id_tv.values[0])
    if not 1 <= first <= MAX_ID:
        check.err(id_tv.tokens[0], f"BLEND 'id' (the first id of its objects) must lie in 1..{MAX_ID}, "
                                   f"got {id_tv.tokens[0].text}")
    check.positive(stmt, "scale")
    tok = stmt.tags["file"].tokens[0]
    path = check.existing_file(stmt, "file")
    if path is not None:
        if path.stat().st_size > MAX_BLEND_BYTES:
            check.err(tok, f"BLEND 'file' '{tok.text}' is larger than {MAX_BLEND_BYTES >> 30} GiB")
        elif path.suffix.lower() != ".blend":
            check.err(tok, f"BLEND 'file' '{tok.text}' is not a .blend file")
        else:
            try:
                with open(path, "rb") as f:
                    head = f.read(7)
            except OSError as e:
                head = b""
                check.err(tok, f"BLEND 'file' '{tok.text}' cannot be read ({e.strerror})")
            if head and not head.startswith(BLEND_MAGICS):
                check.err(tok, f"BLEND 'file' '{tok.text}' is not a Blender file (no BLENDER signature)")
    cls = _Objects(check, {})._class(stmt) if "class" in stmt.tags else semantics.DEFAULT_OBJECT_CLASS
    if len(check.diags.items) != before or path is None:
        return None
    scale = vec(stmt, "scale", (1.0,))
    placement = vec(stmt, "position", (0.0, 0.0, 0.0))
    return model.BlendImport(path=str(path), source=tok.text, first_id=first, collection=stmt.get("collection"),
                             position=placement[:3], rotation_deg=placement[3:] or (0.0, 0.0, 0.0),
                             scale=scale * 3 if len(scale) == 1 else scale, semantic_class=cls or "static",
                             lights=stmt.get("lights", "on") == "on",
                             allow_external="allow_external" in stmt.tags, line=stmt.token.line)


def _with_class(o: model.SceneObject, materials: dict[str, model.Material]) -> model.SceneObject:
    """The object with its semantic class resolved: its ``class``, else (an ASSET) its kind's,
    else its library material's, else ``static`` (contract.semantics)."""
    if isinstance(o, model.Asset):
        return dataclasses.replace(o, semantic_class=semantics.object_class(
            o.semantic_class, assets.KINDS[o.kind].semantic_class))
    m = materials.get(o.material) if o.material else None
    from_material = entry(m.library.name).semantic_class if m and m.library else None
    return dataclasses.replace(o, semantic_class=semantics.object_class(o.semantic_class, from_material))


# words people use for a class, and the Cityscapes name of it; the classes no object of a
# scene is (the recording car itself, image borders) are never suggested for a misspelling
CLASS_WORDS = {"vehicle": "car", "automobile": "car", "pedestrian": "person", "human": "person", "people": "person",
               "bike": "bicycle", "tree": "vegetation", "plant": "vegetation", "grass": "terrain", "house": "building"}
NOT_OBJECT_CLASSES = ("unlabeled", "ego vehicle", "rectification border", "out of roi", "license plate")


# the asset kinds with a ground floor of their own (ASSET ... ground_material M)
GROUND_FLOOR_KINDS = ("building", "building_shell", "house")


class _Objects:
    """QUAD, CUBOID, SPHERE, CYLINDER, MESH and ASSET statements -> SceneObjects (faulty ones left out)."""

    def __init__(self, check: Checks, defined: dict[str, model.Material]):
        self.check, self.defined = check, defined

    def build(self, statements: list[ParsedStatement]) -> list[model.SceneObject]:
        check, defined = self.check, self.defined
        objects: list[model.SceneObject] = []
        ids: dict[int, ParsedStatement] = {}
        names: dict[str, ParsedStatement] = {}
        for stmt in statements:
            before = len(check.diags.items)
            id_tv: TagValue = stmt.tags["id"]
            obj_id = int(id_tv.values[0])
            if not 1 <= obj_id <= MAX_ID:
                check.err(id_tv.tokens[0], f"{stmt.keyword} 'id' must lie in 1..{MAX_ID} (0 is the background), "
                                           f"got {id_tv.tokens[0].text}")
            elif obj_id in ids:
                other = ids[obj_id]
                check.err(id_tv.tokens[0], f"duplicate id {obj_id}: already used by the {other.keyword} "
                                           f"on line {other.token.line}")
            else:
                ids[obj_id] = stmt
            shape = stmt.keyword.lower()
            name = stmt.get("name") or f"{shape}_{obj_id}"
            if name in names:
                check.err(stmt.tags["name"].tokens[0] if "name" in stmt.tags else stmt.token,
                          f"duplicate object name '{name}': already used on line {names[name].token.line}")
            else:
                names[name] = stmt
            check.unit_range(stmt, "colour")
            material = stmt.get("material")
            if material is not None and material not in defined and not is_library_name(material):
                tok = stmt.tags["material"].tokens[0]
                known = f"defined: {', '.join(defined)}; " if defined else "no MATERIAL is defined; "
                candidates = [*defined, *LIBRARY]
                check.err(tok, f"{stmt.keyword} 'material' '{material}' is not defined and is not a library "
                               f"material{did_you_mean(material, candidates)} "
                               f"({known}library: {', '.join(LIBRARY)})")
            common = dict(id=obj_id, name=name, colour=vec(stmt, "colour", (1.0, 1.0, 1.0)),
                          texture=texture(stmt, check), material=material,
                          semantic_class=self._class(stmt), line=stmt.token.line)
            obj = getattr(self, f"_{shape}")(stmt, common)
            if obj is not None and len(check.diags.items) == before:
                objects.append(obj)
        return objects

    def _class(self, stmt: ParsedStatement) -> Optional[str]:
        tv = stmt.tags.get("class")
        if tv is None:
            return None
        label = semantics.lookup(str(tv.values[0]))
        if label is None:
            names = [lab.name for lab in semantics.LABELS]
            word = semantics.canonical(str(tv.values[0]))
            close = (f"; did you mean '{CLASS_WORDS[word]}'?" if word in CLASS_WORDS
                     else did_you_mean(word, [n for n in names if n not in NOT_OBJECT_CLASSES]))
            self.check.err(tv.tokens[0], f"{stmt.keyword} 'class' '{tv.values[0]}' is not a known class{close} "
                                         f"(classes: {', '.join(names)}; see docs/ses-language.md)")
            return None
        return label.name

    @staticmethod
    def _placement(stmt: ParsedStatement) -> dict:
        values = vec(stmt, "position", (0.0, 0.0, 0.0))
        return dict(position=values[:3], rotation_deg=values[3:] or (0.0, 0.0, 0.0))

    def _quad(self, stmt, common):
        v = vec(stmt, "vertices")
        vertices = (v[0:3], v[3:6], v[6:9], v[9:12])
        problem = quad_problem(vertices)
        if problem:
            self.check.err(stmt.tags["vertices"].tag, problem[1])
            return None
        return model.Quad(vertices=vertices, **common)

    def _cuboid(self, stmt, common):
        self.check.positive(stmt, "dim")
        self.check.positive(stmt, "bevel", allow_zero=True)
        size, bevel = vec(stmt, "dim"), float(scalar(stmt, "bevel", 0.0))
        if bevel > min(size) / 2 and "bevel" in stmt.tags:
            self.check.err(stmt.tags["bevel"].tokens[0], f"CUBOID 'bevel' ({bevel:g}) must be at most half the "
                                                         f"smallest edge ({min(size) / 2:g})")
        return model.Cuboid(size=size, bevel=bevel, **self._placement(stmt), **common)

    def _sphere(self, stmt, common):
        self.check.positive(stmt, "dim")
        return model.Sphere(radius=vec(stmt, "dim")[0], **self._placement(stmt), **common)

    def _cylinder(self, stmt, common):
        self.check.positive(stmt, "dim")
        r, h = vec(stmt, "dim")
        return model.Cylinder(radius=r, height=h, **self._placement(stmt), **common)

    def _mesh(self, stmt, common):
        self.check.positive(stmt, "scale")
        scale = vec(stmt, "scale", (1.0,))
        tok = stmt.tags["file"].tokens[0]
        path = self.check.existing_file(stmt, "file")
        if path is None:
            return None
        if path.suffix.lower() not in MESH_SUFFIXES:
            self.check.err(tok, f"MESH 'file' '{tok.text}' has an unsupported format "
                                f"(use {', '.join(MESH_SUFFIXES)})")
            return None
        problems = reference_problems(path, allow_external="allow_external" in stmt.tags)
        problems = problems or content_problems(path)
        for problem in problems:
            self.check.err(tok, f"MESH 'file' '{tok.text}': {problem}")
        if problems:
            return None
        return model.Mesh(path=str(path), source=tok.text, scale=scale * 3 if len(scale) == 1 else scale,
                          **self._placement(stmt), **common)


    def _asset(self, stmt, common):
        kinds = [k for k in assets.KINDS if k in stmt.tags]
        if len(kinds) != 1:
            at = stmt.tags[kinds[1]].tag if len(kinds) > 1 else stmt.token
            self.check.err(at, f"ASSET needs exactly one kind ({', '.join(assets.KINDS)})")
            return None
        kind = assets.KINDS[kinds[0]]
        self.check.positive(stmt, "size")
        seed = int(scalar(stmt, "seed", common["id"]))
        if not 0 <= seed <= MAX_SEED:
            if "seed" in stmt.tags:
                self.check.err(stmt.tags["seed"].tokens[0], f"ASSET 'seed' must lie in 0..{MAX_SEED}, got {seed}")
            return None  # (a bad id used as the seed is reported as a bad id)
        bend = vec(stmt, "bend", (0.0,))
        strips = ", ".join(k for k, v in assets.KINDS.items() if v.strip)
        for tag in ("bend", "offset"):
            if tag in stmt.tags and not kind.strip:
                self.check.err(stmt.tags[tag].tag, f"ASSET {kind.name} takes no '{tag}' (only {strips} do)")
        if "bend" in stmt.tags:
            for value, tok in zip(bend, stmt.tags["bend"].tokens):
                if abs(value) > MAX_BEND_DEG:
                    self.check.err(tok, f"ASSET 'bend' must lie in -{MAX_BEND_DEG:g}..{MAX_BEND_DEG:g} degrees "
                                        f"per piece, got {tok.text}")
        ground = stmt.get("ground_material")
        if ground is not None:
            tok = stmt.tags["ground_material"].tokens[0]
            if kind.name not in GROUND_FLOOR_KINDS:
                self.check.err(stmt.tags["ground_material"].tag, f"ASSET {kind.name} takes no 'ground_material' "
                                                                 f"(only {', '.join(GROUND_FLOOR_KINDS)} assets have a ground floor)")
            elif ground not in self.defined and not is_library_name(ground):
                self.check.err(tok, f"ASSET 'ground_material' '{ground}' is not defined and is not a library "
                                    f"material{did_you_mean(ground, [*self.defined, *LIBRARY])}")
        size = vec(stmt, "size") or assets.default_size(kind.name, seed)
        return model.Asset(kind=kind.name, size=size, seed=seed, bend=bend,
                           offset=float(scalar(stmt, "offset", 0.0)), ground_material=ground,
                           **self._placement(stmt), **common)


def _rig(stmt: Optional[ParsedStatement], check: Checks) -> model.Rig:
    """The stereo rig of the CAMERA statement (the model's default rig without one)."""
    if stmt is None:
        return model.Rig()
    res = stmt.tags["resolution"]
    for value, tok in zip(res.values, res.tokens):
        if not float(value).is_integer() or not MIN_RESOLUTION <= value <= MAX_RESOLUTION:
            check.err(tok, f"CAMERA 'resolution' must be whole numbers in {MIN_RESOLUTION}..{MAX_RESOLUTION}, "
                           f"got {tok.text}")
    check.positive(stmt, "focal")
    check.positive(stmt, "baseline", allow_zero=True)
    check.positive(stmt, "near")
    check.positive(stmt, "far")
    width, height = (int(v) for v in res.values)
    cx, cy = vec(stmt, "principal", default_principal_point(width, height))
    near = float(scalar(stmt, "near", model.Rig.near))
    far = float(scalar(stmt, "far", model.Rig.far))
    if 0 < near < MIN_NEAR:
        check.err(stmt.tags["near"].tokens[0], f"CAMERA 'near' must be at least {MIN_NEAR:g} (Blender clips "
                                               f"nearer), got {stmt.tags['near'].tokens[0].text}")
    if near >= far:
        tv = stmt.tags.get("far") or stmt.tags["near"]
        check.err(tv.tokens[0], f"CAMERA 'near' ({near:g}) must be less than 'far' ({far:g})")
    return model.Rig(width=width, height=height, focal_px=float(scalar(stmt, "focal")),
                     cx=float(cx), cy=float(cy), baseline=float(scalar(stmt, "baseline", 0.0)),
                     near=near, far=far)
