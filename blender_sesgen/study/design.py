"""Which variants a study runs (pure): points of the factor space.

- ``oat`` (the default): one factor at a time around the base: the base, then every level
  of every factor with the others at the base's level;
- ``grid``: every combination of the levels of two factors (and the base);
- ``lhs``: a seeded Latin hypercube of ``samples`` points over each factor's [low, high]
  (whole numbers stay whole: a count of cars), and the base.

A point is a dict {factor: level} holding only the factors it sets; the base is ``{}``.
Every point is run on every world seed (``world.seeds``): repeats over worlds.
"""
from __future__ import annotations

import numpy as np

BASE: dict = {}


def points(design, factors) -> list[dict]:
    """The design's points, the base first (see the module docstring)."""
    if design.kind == "oat":
        return [dict(BASE)] + [{f.name: lv} for f in factors for lv in f.levels]
    if design.kind == "grid":
        a, b = factors
        return [dict(BASE)] + [{a.name: x, b.name: y} for x in a.levels for y in b.levels]
    if design.kind == "lhs":
        return [dict(BASE)] + latin_hypercube(factors, design.samples, design.seed)
    raise ValueError(f"unknown design {design.kind!r}")


def latin_hypercube(factors, n: int, seed: int) -> list[dict]:
    """``n`` points, each factor's range cut into n strata, one sample per stratum, the
    strata of different factors paired by seeded permutations (McKay et al. 1979)."""
    rng = np.random.default_rng([int(seed), 0x1A5])
    cols = {}
    for f in factors:
        lo, hi = (float(v) for v in f.levels)
        u = (rng.permutation(n) + rng.uniform(0.0, 1.0, n)) / n
        x = lo + u * (hi - lo)
        whole = all(isinstance(v, int) for v in f.levels)
        cols[f.name] = [int(round(v)) if whole else float(v) for v in x]
    return [{name: cols[name][i] for name in cols} for i in range(n)]


def label(point: dict) -> str:
    """A readable name of a point: ``base``, ``exposure_time=0.008``, ``a=1,b=2``."""
    if not point:
        return "base"
    return ",".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in point.items())
