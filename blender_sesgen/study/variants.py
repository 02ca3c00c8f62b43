"""A study's plan (pure): every variant's script, the distinct renders, and the variants
developed from another render's EXRs.

The base world of seed s is the script (or ``generator(s, **options)``) with the study's
base edits: its file references made absolute (variants live in the study's folder), the
first ``world.frames`` frames, ``world.resolution``, a ``SENSOR`` when a factor acts
through the camera chain, a script world's render and sensor seeds set to s, and the
``world.set`` levels. A variant is the base with its point's factors applied in registry
order (``factors.ordered``).

Controlled variants: the *render script* of a variant is its script without its
``sensor``-stage factors. When the two differ, the variant is not rendered: it is developed
from the render of its render script (``render --reuse-exr``: the EXRs copied, only the
camera chain run) -- unless it has AUTOEXPOSURE, whose exposures (and so its motion blur)
depend on the sensor's images: then it is rendered. Renders are content-addressed (the SHA-256 of the script and the render
options): two variants with the same script -- a level equal to the base's -- are one
render, and a study costs its distinct renders.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ScriptError, SesgenError
from . import design as design_mod
from .factors import CONTROLLED_STAGES, FACTORS, STAGES, Edit, UserFactor, ordered
from .paths import MOTION_KEYWORDS, rewrite_object_motions
from .script import Script, statement_line
from .spec import Study, StudyError

FILE_TAGS = {"QUAD": ("texture",), "CUBOID": ("texture",), "SPHERE": ("texture",), "CYLINDER": ("texture",),
             "MESH": ("texture", "file"), "ASSET": ("texture",), "BLEND": ("file",), "TRAJECTORY": ("file",),
             "MOVE": ("file",), "WORLD": ("hdri",),
             "MATERIAL": ("texture", "albedo_map", "normal_map", "roughness_map")}


@dataclass
class Variant:
    point: dict                       # the factors it sets (the base: {})
    seed: int                         # its world seed
    script: str                       # its script
    render_script: str                # the script whose EXRs it uses (its own unless only sensor factors differ)
    stage: str                        # the highest stage of its factors ("base" for the base)
    options_key: str = ""             # the render options, in every key

    @property
    def label(self) -> str:
        return design_mod.label(self.point)

    @property
    def name(self) -> str:
        return f"{self.label}@s{self.seed}"

    @property
    def key(self) -> str:
        return content_key(self.script, self.options_key)

    @property
    def render_key(self) -> str:
        return content_key(self.render_script, self.options_key)

    @property
    def developed(self) -> bool:
        return self.script != self.render_script

    @property
    def controlled(self) -> bool:
        """Its ground truth must equal its seed's base's (only image/sensor factors)."""
        return self.stage in CONTROLLED_STAGES


def content_key(script: str, options_key: str) -> str:
    return "r" + hashlib.sha256((options_key + "\n" + script).encode("utf-8")).hexdigest()[:15]


@dataclass
class Plan:
    study: Study
    variants: list[Variant]
    render_args: list[str]            # render options of every render (quality, samples)
    renders: dict = field(default_factory=dict)    # key -> script: rendered by Cycles
    develops: dict = field(default_factory=dict)   # key -> (script, key of the render whose EXRs it reuses)

    def base_of(self, seed: int) -> Variant:
        return next(v for v in self.variants if not v.point and v.seed == seed)

    def to_json(self) -> dict:
        return {"renders": sorted(self.renders), "developed": {k: b for k, (_, b) in sorted(self.develops.items())},
                "variants": [{"name": v.name, "point": v.point, "world_seed": v.seed, "key": v.key,
                              "render_key": v.render_key, "stage": v.stage} for v in self.variants],
                "render_args": self.render_args}


def render_options(study: Study):
    """What every render of the study renders with: the world's quality and samples."""
    from ..render.plan import RenderOptions
    return RenderOptions(quality=study.world.quality, samples=study.world.samples)


def render_args(study: Study) -> list[str]:
    """:func:`render_options` as the render command's arguments (a farm task's)."""
    from ..render.plan import render_argv
    return render_argv(render_options(study))


def make_plan(study: Study, scripts_dir: Path) -> Plan:
    """Every variant of the study (design points x world seeds), checked (StudyError naming
    the factor and level of a variant that does not make a valid script)."""
    args = render_args(study)
    options_key = json.dumps(args)
    variants = []
    for seed in study.world.seeds:
        for point in design_mod.points(study.design, study.factors):
            variants.append(make_variant(study, point, seed, scripts_dir, options_key))
    plan = Plan(study, variants, args)
    for v in variants:
        plan.renders.setdefault(v.render_key, v.render_script)
    for v in variants:
        if v.developed and v.key not in plan.renders:
            plan.develops.setdefault(v.key, (v.script, v.render_key))
    return plan


class _Parser:
    """Parses a script text as a Scene (cached), with the study's base folder."""

    def __init__(self, base_dir: Path, source: str):
        self.base_dir, self.source, self.cache = base_dir, source, {}

    def __call__(self, script) -> object:
        text = script.text if isinstance(script, Script) else script
        if text not in self.cache:
            from ..ses.parser import parse_text
            self.cache[text] = parse_text(text, self.source, str(self.base_dir))
        return self.cache[text]


def make_variant(study: Study, point: dict, seed: int, scripts_dir: Path, options_key: str = "") -> Variant:
    levels = {**study.world.set, **point}
    where = f"variant {design_mod.label(point)} (world seed {seed})"
    if len(point) == 1:
        (name, lv), = point.items()
        where = f"factors.{name}: level {lv!r} (world seed {seed})"
    parse = _Parser(Path(scripts_dir), f"{study.name}/{design_mod.label(point)}@s{seed}.ses")
    try:
        s = base_script(study, seed, levels, parse)
        stages = []
        render_text = None
        names = ordered(levels)
        names = [n for n in names if _factor(study, n).stage != "sensor"] + \
                [n for n in names if _factor(study, n).stage == "sensor"]
        for name in names:
            f = _factor(study, name)
            if f.stage == "sensor" and render_text is None:
                render_text = s.text
            spec_opts = study.factor(name).options if any(x.name == name for x in study.factors) else {}
            edit = Edit(levels=levels, options={**getattr(f, "options", {}), **spec_opts}, seed=seed, parse=parse)
            if name in point:
                stages.append(f.stage)
            try:
                if _same_level(f.base_level(parse(s)), levels[name]):
                    continue                     # the script has that level already: the same text
                f.apply(s, levels[name], edit)
            except ScriptError as e:
                raise StudyError(f"{study.path}: error: factors.{name}: level {levels[name]!r}: the script before "
                                 f"it does not check: {e}") from None
            except SesgenError as e:
                raise StudyError(f"{study.path}: error: factors.{name}: level {levels[name]!r}: {e}") from None
        text = s.text
        if render_text is None or parse(text).autoexposure is not None:
            render_text = text   # AUTOEXPOSURE meters the developed images: its exposures, so its blur, follow them
        parse(render_text)
    except ScriptError as e:
        raise StudyError(f"{study.path}: error: {where}: the variant's script does not check: {e}") from None
    stage = max(stages, key=STAGES.index) if stages else "base"
    return Variant(point=dict(point), seed=seed, script=text, render_script=render_text, stage=stage,
                   options_key=options_key)


def _same_level(base, level) -> bool:
    if base is None or isinstance(base, bool) or isinstance(level, bool):
        return False
    if isinstance(base, (int, float)) and isinstance(level, (int, float)):
        return float(base) == float(level)
    return base == level


def _factor(study: Study, name: str):
    for f in study.factors:
        if f.name == name:
            return f.factor
    return FACTORS[name]


def base_script(study: Study, seed: int, levels: dict, parse) -> Script:
    """The base world of ``seed`` with the study's base edits (module docstring)."""
    w = study.world
    if w.generator is not None:
        from ..generators import find
        try:
            gen = find(w.generator)
            options = {**w.options, **{f.factor.option: levels[f.name] for f in study.factors
                                       if isinstance(f.factor, UserFactor) and f.factor.option and f.name in levels}}
            gen.check_options(options)
            text = gen(seed, **options)
        except SesgenError as e:
            raise StudyError(f"{study.path}: error: world.generator: {e}") from None
        except Exception as e:  # noqa: BLE001 - the generator's own failure, as one line
            raise StudyError(f"{study.path}: error: world.generator: {w.generator}({seed}) failed: "
                             f"{type(e).__name__}: {e}") from None
        s = Script(text, f"{w.generator}-s{seed}")
        source_dir = parse.base_dir
    else:
        try:
            text = w.script.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise StudyError(f"{study.path}: error: world.script: cannot read {w.script} ({e})") from None
        s = Script(text, str(w.script))
        source_dir = w.script.parent
        absolute_files(s, source_dir)
        s.set_tag("RENDER", "seed", seed)
    if w.frames is not None:
        truncate(s, parse(s), w.frames, study)
    if w.resolution is not None:
        scene = parse(s)
        kind, *vals = w.resolution
        scale = vals[0] if kind == "scale" else vals[0] / scene.rig.width
        if kind == "size" and abs(round(scene.rig.height * scale) - vals[1]) > 1:
            raise StudyError(f"{study.path}: error: world.resolution: {vals[0]}x{vals[1]} does not keep the "
                             f"script's aspect ({scene.rig.width}x{scene.rig.height}); give a scale instead")
        FACTORS["resolution"].apply(s, scale, Edit({}, {}, seed, parse))
    names = list(levels) + [f.name for f in study.factors]
    if any(getattr(_factor(study, n), "needs_sensor", False) for n in names) and not s.has("SENSOR"):
        s.set_tags("SENSOR", {"seed": (seed,)})
    elif s.has("SENSOR") and w.generator is None:
        s.set_tag("SENSOR", "seed", seed)
    return s


def absolute_files(s: Script, folder: Path) -> None:
    """Every file a statement names, made absolute (the variants are written elsewhere)."""
    for st in s.statements(*FILE_TAGS):
        new = {}
        for tag in FILE_TAGS[st.keyword]:
            v = st.get(tag)
            if isinstance(v, str) and v and not Path(v).is_absolute() and (folder / v).is_file():
                new[tag] = (str((folder / v).resolve()),)
        if new:
            s.edit(st, new)


def truncate(s: Script, scene, n: int, study: Study) -> None:
    """Keep the first ``n`` frames of the script's motion (and of its moving objects)."""
    if n > scene.frames:
        raise StudyError(f"{study.path}: error: world.frames: the base world has {scene.frames} frame(s), "
                         f"fewer than {n}")
    if n == scene.frames:
        return
    kind = scene.motion.kind
    if kind == "ego":
        for st in s.statements("EGO")[n - 1:][::-1]:
            del s.lines[st.index]
    elif kind == "pose":
        for st in s.statements("POSE")[n:][::-1]:
            del s.lines[st.index]
    elif kind == "trajectory":
        from .paths import pose_line
        s.drop(*MOTION_KEYWORDS)
        s.append("", "// the trajectory's first frames (study)", *(pose_line(T) for T in scene.timeline.left()[:n]))
    else:
        s.drop("FRAMES")
        s.insert_head(statement_line("FRAMES", numbers=(n,)))
    if scene.object_motions:
        import numpy as np
        rewrite_object_motions(s, scene, np.arange(n, dtype=float))
