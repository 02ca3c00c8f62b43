"""The study file: TOML (read with the standard library's ``tomllib``) -> :class:`Study`.

Every problem is a :class:`StudyError` (exit 2, one line): a TOML syntax error as
``study.toml:LINE:COL: error: ...``, anything else naming the key,
``study.toml: error: factors.exposure_time.levels: expected a list of numbers``. Paths in
the file are relative to its folder. The format is documented in docs/studies.md.
"""
from __future__ import annotations

import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from ..errors import SesgenError
from ..scene.presets import QUALITIES
from .factors import FACTORS, STAGES, UserFactor

POSE_FORMATS = ("tum", "kitti", "euroc")
DESIGNS = ("oat", "grid", "lhs")
METRICS = ("ape_trans_rmse", "ape_rot_rmse_deg", "ape_rot_origin_rmse_deg", "rpe_trans_rmse", "rpe_rot_rmse_deg",
           "rpe_trans_per_m", "kitti_t_err_pct", "tracking_loss")


class StudyError(SesgenError):
    """A study file that cannot be run: one line naming the file and the key (printed as it is)."""
    whole_line = True


@dataclass(frozen=True)
class World:
    script: Optional[Path] = None              # the base world: a script ...
    generator: Optional[str] = None            # ... or a generator (name or .py file) with options
    options: dict = field(default_factory=dict)
    seeds: tuple[int, ...] = (0,)              # world seeds (repeats): a generator's seed; a script's render seed
    frames: Optional[int] = None               # the first N frames only
    resolution: Optional[float] = None         # scale of the image size (and focal length in px)
    quality: Optional[str] = "draft"
    samples: Optional[int] = None
    set: dict = field(default_factory=dict)    # base levels of factors


@dataclass(frozen=True)
class FactorSpec:
    name: str
    levels: tuple
    factor: object                             # Factor or UserFactor
    options: dict = field(default_factory=dict)

    @property
    def unit(self) -> str:
        return self.factor.unit


@dataclass(frozen=True)
class SystemSpec:
    name: str
    cmd: tuple[str, ...]                       # the command template, split like a shell would
    layout: str
    format: str
    timeout_s: float = 600.0
    trials: int = 1
    mono: bool = False
    builtin: Optional[str] = None
    env: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Design:
    kind: str = "oat"
    samples: int = 10
    seed: int = 0


@dataclass(frozen=True)
class Evaluation:
    metric: str = "ape_trans_rmse"             # the error plotted, compared and used for breaking points
    break_multiple: float = 2.0                # broken: error > multiple x the base's, or failed
    min_coverage: float = 0.5                  # a trajectory with poses for fewer frames is a failure
    jump_factor: float = 5.0                   # a step missing the true one by this many mean true steps: lost
    regression_sigmas: float = 1.0             # compare: worse by more than this many spreads
    break_sigmas: float = 1.0                  # broken: above the multiple by more than this many spreads


@dataclass(frozen=True)
class Study:
    path: Path
    name: str
    description: str
    world: World
    factors: tuple[FactorSpec, ...]
    systems: tuple[SystemSpec, ...]
    design: Design
    evaluation: Evaluation
    vo: tuple[str, ...] = ()                   # how to run vo_reference (default: this Python -m vo_reference)

    def factor(self, name: str) -> FactorSpec:
        return next(f for f in self.factors if f.name == name)


_TOML_POS = re.compile(r"\(at line (\d+), column (\d+)\)")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def load(path) -> Study:
    """Read and check a study file (StudyError on any problem)."""
    import tomllib
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise StudyError(f"{path}: error: cannot read the study file ({e.strerror or e})") from None
    try:
        doc = tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise StudyError(f"{path}:1:1: error: the study file is not UTF-8 text") from None
    except tomllib.TOMLDecodeError as e:
        m = _TOML_POS.search(str(e))
        where = f"{path}:{m.group(1)}:{m.group(2)}" if m else str(path)
        raise StudyError(f"{where}: error: {_TOML_POS.sub('', str(e)).strip()}") from None
    return from_dict(doc, path)


def from_dict(doc: dict, path: Path) -> Study:
    """A study from its parsed TOML (``path``: where relative paths start, and the name in messages)."""
    c = _Checker(Path(path))
    c.keys(doc, "", ("study", "world", "design", "factors", "systems", "evaluation"), required=("world", "systems"))
    top = c.table(doc, "study", optional=True)
    c.keys(top, "study", ("name", "description", "vo"))
    world = _world(c, c.table(doc, "world"))
    factors = _factors(c, c.table(doc, "factors", optional=True), world)
    design = _design(c, c.table(doc, "design", optional=True), factors)
    systems = _systems(c, doc.get("systems"))
    ev = _evaluation(c, c.table(doc, "evaluation", optional=True))
    vo = top.get("vo", ())
    vo = tuple(shlex.split(c.text(vo, "study.vo"))) if vo else ()
    return Study(path=Path(path).resolve(), name=c.text(top.get("name", Path(path).stem), "study.name"),
                 description=c.text(top.get("description", ""), "study.description"), world=world,
                 factors=factors, systems=systems, design=design, evaluation=ev, vo=vo)


class _Checker:
    def __init__(self, path: Path):
        self.path = path
        self.base = path.resolve().parent

    def fail(self, key: str, message: str):
        raise StudyError(f"{self.path}: error: {key + ': ' if key else ''}{message}")

    def keys(self, table: dict, where: str, allowed, required=()) -> None:
        for k in table:
            if k not in allowed:
                import difflib
                close = difflib.get_close_matches(k, allowed, n=1)
                self.fail(f"{where + '.' if where else ''}{k}",
                          f"unknown key{f' (did you mean {close[0]!r}?)' if close else ''}; "
                          f"expected one of: {', '.join(allowed)}")
        for k in required:
            if k not in table:
                self.fail(f"{where + '.' if where else ''}{k}", "missing (required)")

    def table(self, doc: dict, key: str, optional: bool = False) -> dict:
        v = doc.get(key)
        if v is None:
            if optional:
                return {}
            self.fail(key, "missing (required)")
        if not isinstance(v, dict):
            self.fail(key, f"expected a table, got {type(v).__name__}")
        return v

    def text(self, v, key: str) -> str:
        if not isinstance(v, str):
            self.fail(key, f"expected a string, got {v!r}")
        return v

    def number(self, v, key: str, lo: Optional[float] = None, integer: bool = False, positive: bool = False):
        ok = isinstance(v, int) if integer else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok:
            self.fail(key, f"expected {'a whole number' if integer else 'a number'}, got {v!r}")
        if v != v or v in (float("inf"), float("-inf")):
            self.fail(key, f"expected a finite number, got {v!r}")
        if positive and not v > 0:
            self.fail(key, f"must be > 0, got {v!r}")
        if lo is not None and v < lo:
            self.fail(key, f"must be >= {lo}, got {v!r}")
        return v

    def file(self, v, key: str) -> Path:
        p = Path(self.text(v, key))
        p = p if p.is_absolute() else self.base / p
        if not p.is_file():
            self.fail(key, f"no such file: {p}")
        return p


def _world(c: _Checker, w: dict) -> World:
    c.keys(w, "world", ("script", "generator", "options", "seed", "seeds", "frames", "resolution", "quality",
                        "samples", "set"))
    if ("script" in w) == ("generator" in w):
        c.fail("world", "give exactly one of 'script' (an SES file) or 'generator' (a name or a .py file)")
    script = c.file(w["script"], "world.script") if "script" in w else None
    generator = None
    if "generator" in w:
        generator = c.text(w["generator"], "world.generator")
        if generator.endswith(".py"):
            generator = str(c.file(generator, "world.generator"))
    options = w.get("options", {})
    if not isinstance(options, dict):
        c.fail("world.options", "expected a table of generator options")
    if options and script is not None:
        c.fail("world.options", "options are a generator's; a script world has none")
    if "seed" in w and "seeds" in w:
        c.fail("world.seeds", "give 'seed' or 'seeds', not both")
    seeds = w.get("seeds", [w.get("seed", 0)])
    if not isinstance(seeds, list) or not seeds:
        c.fail("world.seeds", "expected a non-empty list of whole numbers")
    seeds = tuple(int(c.number(s, "world.seeds", lo=0, integer=True)) for s in seeds)
    if len(set(seeds)) != len(seeds):
        c.fail("world.seeds", "a seed is listed twice")
    frames = w.get("frames")
    if frames is not None:
        frames = int(c.number(frames, "world.frames", lo=2, integer=True))
    res = w.get("resolution")
    if res is not None:
        if isinstance(res, list):
            if len(res) != 2:
                c.fail("world.resolution", "expected a scale (0.25) or [W, H]")
            res = ("size", int(c.number(res[0], "world.resolution", lo=4, integer=True)),
                   int(c.number(res[1], "world.resolution", lo=4, integer=True)))
        else:
            res = ("scale", float(c.number(res, "world.resolution", positive=True)))
    quality = w.get("quality", "draft")
    if quality not in QUALITIES:
        c.fail("world.quality", f"expected one of {', '.join(QUALITIES)}, got {quality!r}")
    samples = w.get("samples")
    if samples is not None:
        samples = int(c.number(samples, "world.samples", lo=1, integer=True))
    sets = w.get("set", {})
    if not isinstance(sets, dict):
        c.fail("world.set", "expected a table: factor = level")
    for k, v in sets.items():
        if k not in FACTORS:
            c.fail(f"world.set.{k}", f"unknown factor (factors: {', '.join(FACTORS)})")
        try:
            FACTORS[k].check_level(v)
        except SesgenError as e:
            c.fail(f"world.set.{k}", str(e))
    return World(script=script, generator=generator, options=dict(options), seeds=seeds, frames=frames,
                 resolution=res, quality=quality, samples=samples, set=dict(sets))


USER_KEYS = ("levels", "statement", "tag", "match", "option", "unit", "doc", "stage")


def _factors(c: _Checker, table: dict, world: World) -> tuple[FactorSpec, ...]:
    out = []
    for name, spec in table.items():
        key = f"factors.{name}"
        if not _NAME.match(name):
            c.fail(key, "a factor name is letters, digits, '_', '-' or '.'")
        if not isinstance(spec, dict):
            spec = {"levels": spec}
        levels = spec.get("levels")
        if not isinstance(levels, list) or not levels:
            c.fail(f"{key}.levels", "expected a non-empty list of levels")
        if name in FACTORS:
            f: object = FACTORS[name]
            c.keys(spec, key, ("levels", *f.options))
            options = {**f.options, **{k: v for k, v in spec.items() if k != "levels"}}
            for k, v in options.items():
                if isinstance(f.options[k], (int, float)):
                    c.number(v, f"{key}.{k}")
        else:
            c.keys(spec, key, USER_KEYS)
            f = _user_factor(c, name, spec, world)
            options = {}
        for i, lv in enumerate(levels):
            try:
                f.check_level(lv)
            except SesgenError as e:
                c.fail(f"{key}.levels[{i}]", str(e))
        if len({repr(v) for v in levels}) != len(levels):
            c.fail(f"{key}.levels", "a level is listed twice")
        out.append(FactorSpec(name, tuple(levels), f, options))
    return tuple(out)


def _user_factor(c: _Checker, name: str, spec: dict, world: World) -> UserFactor:
    key = f"factors.{name}"
    stage = spec.get("stage", "world")
    if stage not in STAGES:
        c.fail(f"{key}.stage", f"expected one of {', '.join(STAGES)}")
    unit = c.text(spec.get("unit", ""), f"{key}.unit")
    doc = c.text(spec.get("doc", ""), f"{key}.doc")
    if "option" in spec:
        if "statement" in spec or "tag" in spec:
            c.fail(key, "a user factor is either a generator 'option' or a 'statement' with a 'tag'")
        if world.generator is None:
            c.fail(f"{key}.option", "generator options need a generator world (world.generator)")
        return UserFactor(name, unit, doc, option=c.text(spec["option"], f"{key}.option"), stage=stage)
    if "statement" not in spec or "tag" not in spec:
        import difflib
        close = difflib.get_close_matches(name, FACTORS, n=1)
        c.fail(key, "unknown factor" + (f" (did you mean {close[0]!r}?)" if close else "")
               + f"; a user factor needs 'statement' and 'tag' (or 'option'); registry: {', '.join(FACTORS)}")
    from ..ses.grammar import STATEMENTS
    kw = c.text(spec["statement"], f"{key}.statement").upper()
    if kw not in STATEMENTS or STATEMENTS[kw].positional:
        c.fail(f"{key}.statement", f"no statement {kw!r} with tags")
    tag = c.text(spec["tag"], f"{key}.tag").lower()
    if tag not in STATEMENTS[kw].tags:
        c.fail(f"{key}.tag", f"{kw} has no tag {tag!r} (tags: {', '.join(STATEMENTS[kw].tags)})")
    match = spec.get("match", {})
    if not isinstance(match, dict):
        c.fail(f"{key}.match", "expected a table: tag = value")
    for k in match:
        if k not in STATEMENTS[kw].tags:
            c.fail(f"{key}.match.{k}", f"{kw} has no tag {k!r}")
    from ..ses.grammar import SINGLETON_KEYWORDS
    if kw not in SINGLETON_KEYWORDS and not match:
        c.fail(f"{key}.match", f"{kw} may appear several times: say which with match = {{ id = N }} or "
                               "{ name = \"...\" }")
    return UserFactor(name, unit, doc, statement=kw, tag=tag, match=tuple(match.items()), stage=stage)


def _design(c: _Checker, d: dict, factors: tuple) -> Design:
    c.keys(d, "design", ("kind", "samples", "seed"))
    kind = d.get("kind", "oat")
    if kind not in DESIGNS:
        c.fail("design.kind", f"expected one of {', '.join(DESIGNS)} (oat: one factor at a time around the base; "
                              "grid: every combination of two factors; lhs: a seeded Latin hypercube)")
    if kind == "grid" and len(factors) != 2:
        c.fail("design.kind", f"a grid crosses exactly two factors; the study has {len(factors)}")
    if kind == "lhs" and not factors:
        c.fail("design.kind", "a Latin hypercube needs factors")
    samples = int(c.number(d.get("samples", 10), "design.samples", lo=1, integer=True))
    seed = int(c.number(d.get("seed", 0), "design.seed", lo=0, integer=True))
    if kind == "lhs":
        for f in factors:
            if f.factor.kind != "number" or len(f.levels) != 2:
                c.fail(f"factors.{f.name}.levels", "a Latin hypercube samples numeric ranges: give [low, high]")
    return Design(kind, samples, seed)


def _systems(c: _Checker, systems) -> tuple[SystemSpec, ...]:
    from .systems import BUILTIN, check_template
    if not isinstance(systems, list) or not systems:
        c.fail("systems", "expected at least one [[systems]] table")
    out, names = [], set()
    for i, s in enumerate(systems):
        key = f"systems[{i}]"
        if not isinstance(s, dict):
            c.fail(key, "expected a table")
        c.keys(s, key, ("name", "builtin", "cmd", "layout", "format", "timeout_s", "trials", "mono", "env"))
        if ("builtin" in s) == ("cmd" in s):
            c.fail(key, f"give exactly one of 'builtin' ({', '.join(BUILTIN)}) or 'cmd' (a command template)")
        if "builtin" in s:
            b = s["builtin"]
            if b not in BUILTIN:
                c.fail(f"{key}.builtin", f"unknown built-in system {b!r} (one of: {', '.join(BUILTIN)})")
            base = BUILTIN[b]
            for k in ("cmd", "layout", "format", "mono"):
                if k in s:
                    c.fail(f"{key}.{k}", f"a built-in system fixes its {k}")
            cmd, layout, fmt, mono = base.cmd, base.layout, base.format, base.mono
        else:
            text = c.text(s["cmd"], f"{key}.cmd")
            try:
                cmd = tuple(shlex.split(text))
            except ValueError as e:
                c.fail(f"{key}.cmd", f"cannot split the command ({e})")
            if not cmd:
                c.fail(f"{key}.cmd", "empty command")
            try:
                check_template(cmd)
            except SesgenError as e:
                c.fail(f"{key}.cmd", str(e))
            if not any("{out}" in w for w in cmd):
                c.fail(f"{key}.cmd", "the command must name where it writes its trajectory: {out}")
            layout = c.text(s.get("layout", ""), f"{key}.layout")
            if not layout:
                c.fail(f"{key}.layout", "expected the export layout it reads (python -m vo_reference export --help)")
            fmt = s.get("format")
            if fmt not in POSE_FORMATS:
                c.fail(f"{key}.format", f"expected the pose format it writes: {', '.join(POSE_FORMATS)}")
            mono = s.get("mono", False)
            if not isinstance(mono, bool):
                c.fail(f"{key}.mono", "expected true or false")
            b = None
        name = c.text(s.get("name", b or f"system{i + 1}"), f"{key}.name")
        if not _NAME.match(name):
            c.fail(f"{key}.name", "a system name is letters, digits, '_', '-' or '.'")
        if name in names:
            c.fail(f"{key}.name", f"two systems are named {name!r}")
        names.add(name)
        env = s.get("env", {})
        if not isinstance(env, dict) or not all(isinstance(v, str) for v in env.values()):
            c.fail(f"{key}.env", "expected a table of strings")
        out.append(SystemSpec(name=name, cmd=tuple(cmd), layout=layout, format=fmt,
                              timeout_s=float(c.number(s.get("timeout_s", 600.0), f"{key}.timeout_s", positive=True)),
                              trials=int(c.number(s.get("trials", 1), f"{key}.trials", lo=1, integer=True)),
                              mono=bool(mono), builtin=b, env=dict(env)))
    return tuple(out)


def _evaluation(c: _Checker, e: dict) -> Evaluation:
    c.keys(e, "evaluation", ("metric", "break_multiple", "min_coverage", "jump_factor", "regression_sigmas",
                             "break_sigmas"))
    metric = e.get("metric", "ape_trans_rmse")
    if metric not in METRICS:
        c.fail("evaluation.metric", f"expected one of {', '.join(METRICS)}")
    mult = float(c.number(e.get("break_multiple", 2.0), "evaluation.break_multiple", positive=True))
    if mult <= 1:
        c.fail("evaluation.break_multiple", f"must be > 1 (a multiple of the base's error), got {mult}")
    cov = float(c.number(e.get("min_coverage", 0.5), "evaluation.min_coverage", lo=0))
    if cov > 1:
        c.fail("evaluation.min_coverage", "a fraction of the frames, 0..1")
    jump = float(c.number(e.get("jump_factor", 5.0), "evaluation.jump_factor", positive=True))
    sig = float(c.number(e.get("regression_sigmas", 1.0), "evaluation.regression_sigmas", lo=0))
    brk = float(c.number(e.get("break_sigmas", 1.0), "evaluation.break_sigmas", lo=0))
    return Evaluation(metric, mult, cov, jump, sig, brk)
