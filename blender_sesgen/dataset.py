"""Dataset indexes: ``dataset.json`` (format ``sesgen-dataset/1``, pure: numpy + stdlib).

Two kinds, one format (docs/farm.md):

- ``"kind": "scripts"``, written by ``generate`` beside the scripts it writes: the generator
  (name, file, options), the base seed, and per sequence its script, its own seed, its split
  (train/val/test), frame count and camera path length;
- ``"kind": "renders"``, written by ``farm`` into ROOT: per sequence its render folder, the
  same facts (split and seed carried over from a ``scripts`` index beside its script), the
  render settings and whether it is complete.

Seeds and splits are functions of the base seed only: sequence ``i`` gets the seed drawn
from ``SeedSequence([seed, i])`` (so ``--count 20`` begins with the sequences of
``--count 10``, and neighbouring base seeds share nothing; see :func:`sequence_seeds`), and the split is a seeded
permutation cut at exact counts (:func:`split_counts`).
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Iterable, Optional, Sequence

import numpy as np

from .contract import atomic
from .contract.errors import ContractError
from .contract.inputs import MiB, read_text

FORMAT = "sesgen-dataset/1"
INDEX = "dataset.json"
MAX_INDEX_BYTES = 256 * MiB
SPLITS = ("train", "val", "test")
DEFAULT_FRACTIONS = (0.8, 0.1, 0.1)
_SPLIT_STREAM = 0x5E5_5B17          # a fixed second word: the split's random stream
SEQUENCE_SEEDS = 10_000_000         # sequence seeds lie in 0..9999999: a generator may derive seed * 100 + k
SEED_RULE = ("sequence i: SeedSequence([seed, i]).generate_state(1, uint64)[0] mod 10000000 "
             "(a repeat of an earlier one draws again with [seed, i, 1], [seed, i, 2], ...)")
SPLIT_RULE = ("counts: largest remainders of count * fraction, then one for every split with a fraction > 0 "
              "left empty (taken from the largest); membership: "
              "default_rng(SeedSequence([seed, 0x5E55B17])).permutation(count) cut at the counts "
              "(train, val, test)")


def sequence_seeds(seed: int, count: int) -> list[int]:
    """The seed of each of ``count`` sequences of base ``seed``: distinct, in
    0..SEQUENCE_SEEDS-1, small enough that a generator may derive further seeds from it
    (``seed * 100 + k``) within the scripts' 31-bit seeds. ValueError for more than
    ``SEQUENCE_SEEDS`` sequences (there are not that many distinct seeds)."""
    if not 0 <= int(count) <= SEQUENCE_SEEDS:
        raise ValueError(f"{count} sequences: at most {SEQUENCE_SEEDS} have distinct seeds")
    out, used = [], set()
    for i in range(int(count)):
        extra = 0
        while True:
            words = [int(seed), i] + ([extra] if extra else [])
            s = int(np.random.SeedSequence(words).generate_state(1, np.uint64)[0]) % SEQUENCE_SEEDS
            if s not in used:
                break
            extra += 1
        used.add(s)
        out.append(s)
    return out


def split_counts(count: int, fractions: Sequence[float] = DEFAULT_FRACTIONS) -> tuple[int, int, int]:
    """Sequences per split: ``count * fraction`` rounded by largest remainders (ties go to
    the earlier split), so the counts add up to ``count``; then every split with a fraction
    above zero that got none takes one from the largest split, as long as there are enough
    sequences (10 -> 8/1/1, 5 -> 3/1/1, 3 -> 1/1/1, 2 -> 1/1/0)."""
    f = np.asarray(fractions, dtype=float)
    f = f / f.sum()
    exact = count * f
    n = np.floor(exact).astype(int)
    for j in sorted(range(3), key=lambda j: (-(exact[j] - n[j]), j))[:count - int(n.sum())]:
        n[j] += 1
    for j in range(3):
        big = int(np.argmax(n))
        if f[j] > 0 and n[j] == 0 and n[big] > 1:
            n[j], n[big] = 1, n[big] - 1
    return int(n[0]), int(n[1]), int(n[2])


def assign_splits(count: int, seed: int, fractions: Sequence[float] = DEFAULT_FRACTIONS) -> list[str]:
    """The split of each of ``count`` sequences (see the module docstring)."""
    n_train, n_val, _ = split_counts(count, fractions)
    perm = np.random.default_rng(np.random.SeedSequence([int(seed), _SPLIT_STREAM])).permutation(count)
    out = [""] * count
    for rank, i in enumerate(perm):
        out[int(i)] = "train" if rank < n_train else "val" if rank < n_train + n_val else "test"
    return out


def path_length_m(T_world_cam: np.ndarray) -> float:
    """Length of the camera path (metres: SES units): the sum of the steps between frames."""
    t = np.asarray(T_world_cam, dtype=float)[:, :3, 3]
    return float(np.linalg.norm(np.diff(t, axis=0), axis=1).sum()) if len(t) > 1 else 0.0


def check_fractions(fractions: Sequence[float]) -> tuple[float, float, float]:
    from .errors import SesgenError
    f = tuple(float(x) for x in fractions)
    if len(f) != 3 or any(not np.isfinite(x) or x < 0 for x in f) or sum(f) <= 0:
        raise SesgenError(f"--split needs three non-negative fractions (train val test), got {list(fractions)}")
    total = sum(f)
    return tuple(x / total for x in f)


def scripts_index(generator: dict, seed: int, fractions: Sequence[float], sequences: list[dict]) -> dict:
    """The index ``generate`` writes (``sequences``: name, script, seed, split, frames,
    path_length_m, script_sha256)."""
    return {"format": FORMAT, "kind": "scripts", "generator": generator, "seed": int(seed),
            "count": len(sequences), "seed_rule": SEED_RULE,
            "splits": {"fractions": dict(zip(SPLITS, (round(float(x), 6) for x in fractions))), "rule": SPLIT_RULE},
            "sequences": sequences}


def read_index(folder: Path) -> Optional[dict]:
    """``folder/dataset.json``, checked, if it is an index of ours (``format``
    sesgen-dataset/1); None when there is none or it is another tool's file. An index of ours
    that is damaged -- not JSON, a sequence without a name, a script outside its folder --
    is a SesgenError naming what is wrong: nothing is rendered, generated or rewritten on it."""
    from .errors import SesgenError
    path = Path(folder) / INDEX
    if not path.exists():
        return None
    try:
        text = read_text(path, MAX_INDEX_BYTES, "dataset index")
    except ContractError as e:
        raise SesgenError(str(e)) from None
    try:
        data = json.loads(text)
    except (ValueError, RecursionError):
        if FORMAT not in text:
            return None
        raise SesgenError(f"{path}: a damaged dataset index (not JSON); move it away or write it again") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        return None
    problem = _index_problem(data)
    if problem:
        raise SesgenError(f"{path}: a damaged dataset index ({problem}); move it away or write it again")
    return data


def _index_problem(data: dict) -> str:
    """'' when ``data`` has the shape every reader of an index relies on."""
    kind, sequences = data.get("kind"), data.get("sequences")
    if kind not in ("scripts", "renders"):
        return f"kind {json.dumps(kind)[:40]} is neither scripts nor renders"
    if not isinstance(sequences, list) or not all(isinstance(e, dict) for e in sequences):
        return "'sequences' is not a list of objects"
    for i, e in enumerate(sequences):
        name, script = e.get("name", f"#{i}" if kind == "scripts" else None), e.get("script")
        if not isinstance(name, str) or not name:
            return f"sequence {i} has no name"
        if kind == "scripts" and not (isinstance(script, str) and script and Path(script).name == script
                                      and script not in (".", "..")):
            return f"sequence {name!r}: 'script' must be a file name in the index's folder"
        if "seed" in e and not (isinstance(e["seed"], int) and not isinstance(e["seed"], bool)):
            return f"sequence {name!r}: 'seed' must be a whole number"
        if "split" in e and e["split"] not in SPLITS:
            return f"sequence {name!r}: 'split' must be one of {', '.join(SPLITS)}"
    names = [e["name"] for e in sequences] if kind == "renders" else []
    if len(set(names)) != len(names):
        return "a sequence name is given twice"
    return ""


def render_entry(state) -> dict:
    """One sequence of a ``renders`` index, from a farm scene's state (farm.driver.SceneState)."""
    sc = state.scene
    entry = {"name": sc.name, "folder": sc.name, "script": str(sc.script)}
    for k in ("split", "seed", "generator"):
        if k in sc.meta:
            entry[k] = sc.meta[k]
    if sc.plan is not None:
        s = sc.plan.settings
        entry["frames"] = len(sc.plan.frames)
        entry["path_length_m"] = round(path_length_m(sc.plan.view_poses["left"]), 6)
        entry["render"] = {**s.manifest_block(), "resolution": [s.width, s.height]}
    entry["complete"] = bool(state.complete)
    if state.failed:
        entry["error"] = state.failed
    return entry


def write_render_index(root: Path, states: Iterable) -> Path:
    """``ROOT/dataset.json``: this farm's sequences, plus those of earlier farms into the same
    ROOT that this one did not render (their entries are kept as they were). A scene refused
    before rendering (``scene.error``: its folder holds other settings, say) did not touch
    its folder: an earlier entry for it stays as it was."""
    root = Path(root)
    old = read_index(root)
    old_entries = {e["name"]: e for e in old["sequences"]} if old and old.get("kind") == "renders" else {}
    states = [st for st in states if not (st.scene.error and st.scene.name in old_entries)]
    new = [render_entry(st) for st in states]
    names = {e["name"] for e in new}
    kept = [e for name, e in old_entries.items() if name not in names]
    sequences = sorted(kept + new, key=lambda e: e["name"])
    index = {"format": FORMAT, "kind": "renders", "count": len(sequences),
             "splits": {sp: sum(1 for e in sequences if e.get("split") == sp) for sp in SPLITS},
             "sequences": sequences}
    return atomic.write_json(root / INDEX, index, durable=True)
