"""``python -m blender_sesgen generate GENERATOR --count N --seed S --out DIR``: N scene scripts
from a scene generator, and their dataset index (docs/farm.md).

Sequence ``i`` is ``GENERATOR(seed_i, **options)`` with ``seed_i`` drawn from (S, i)
(``dataset.sequence_seeds``), written as ``DIR/<generator>-s<S>-<i>.ses``; every script is
parsed and validated before anything is written, and the folder appears whole (or not at
all). ``DIR/dataset.json`` lists every script with its seed, split (train/val/test, from S),
frame count and camera path length; ``farm DIR --out ROOT`` renders them.

Exit codes: 0 written; 2 bad input (unknown generator or option, a folder holding other
files); 1 the generator failed or wrote a script that does not check.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

from .contract.cli import EXIT_FAILURE, EXIT_OK
from .contract.progress import Progress, add_progress_argument, progress_mode
from .errors import ScriptError, SesgenError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("generator", nargs="?", metavar="GENERATOR",
                   help="a generator's name (see --list) or a Python file defining generate(seed, **options)")
    p.add_argument("--count", type=int, metavar="N", help="how many scripts")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="base seed: the same seed gives the same scripts "
                   "(default 0)")
    p.add_argument("--out", metavar="DIR", help="folder for the scripts and dataset.json (new, or written by generate)")
    p.add_argument("--option", "-o", action="append", default=[], metavar="KEY=VALUE",
                   help="an option of the generator (VALUE read as JSON, else text); repeatable")
    p.add_argument("--split", nargs=3, type=float, default=None, metavar=("TRAIN", "VAL", "TEST"),
                   help="fractions of the sequences in each split (default 0.8 0.1 0.1)")
    p.add_argument("--list", action="store_true", help="list the generators found and exit")
    add_progress_argument(p)


MAX_COUNT = 1_000_000   # scripts per folder (distinct seeds run out at dataset.SEQUENCE_SEEDS)


class GeneratorFailed(RuntimeError):
    """The generator raised or wrote a script that does not check: exit 1."""


def parse_options(items: list[str]) -> dict:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.isidentifier():
            raise SesgenError(f"--option {item!r}: expected KEY=VALUE")
        try:
            out[key] = json.loads(value)
        except ValueError:
            out[key] = value
    return out


def run(args: argparse.Namespace) -> int:
    from . import generators
    if args.list:
        for name, where in generators.available().items():
            print(f"{name:14s} {where}")
        return EXIT_OK
    if not args.generator or args.count is None or not args.out:
        raise SesgenError("generate needs GENERATOR, --count N and --out DIR (or --list)")
    from .dataset import DEFAULT_FRACTIONS, assign_splits, check_fractions, sequence_seeds
    if not 1 <= args.count <= MAX_COUNT:
        raise SesgenError(f"--count must lie in 1..{MAX_COUNT}, got {args.count}")
    if not 0 <= args.seed <= 2**31 - 1:
        raise SesgenError(f"--seed must be in 0..2147483647, got {args.seed}")
    fractions = check_fractions(args.split or DEFAULT_FRACTIONS)
    options = parse_options(args.option)
    gen = generators.find(args.generator)
    gen.check_options(options)
    out = Path(args.out).absolute()
    _check_folder(out)
    seeds = sequence_seeds(args.seed, args.count)
    splits = assign_splits(args.count, args.seed, fractions)
    width = max(4, len(str(args.count - 1)))
    names = [f"{gen.name}-s{args.seed}-{i:0{width}d}" for i in range(args.count)]
    try:
        n = _write(out, gen, options, args, seeds, splits, names, fractions)
    except GeneratorFailed as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_FAILURE
    counts = {sp: splits.count(sp) for sp in ("train", "val", "test")}
    if progress_mode(args) != "off":
        print(f"generate {gen.name}: {n} script(s), seed {args.seed} -> {out} "
              f"(train {counts['train']}, val {counts['val']}, test {counts['test']}); "
              f"render them with: sesgen farm {out} --out ROOT")
    return EXIT_OK


def _check_folder(out: Path) -> None:
    """DIR must be new, empty, or hold only what an earlier ``generate`` wrote."""
    from .dataset import INDEX, read_index
    if out.exists() and not out.is_dir():
        raise SesgenError(f"--out {out}: exists and is not a folder")
    if not out.is_dir() or not any(out.iterdir()):
        return
    index = read_index(out)
    if index is None or index.get("kind") != "scripts":
        raise SesgenError(f"--out {out}: folder is not empty and was not written by generate; choose a new folder")
    ours = {INDEX} | {s.get("script") for s in index.get("sequences", [])}
    foreign = sorted(p.name for p in out.iterdir() if p.name not in ours)
    if foreign:
        raise SesgenError(f"--out {out}: holds files generate did not write ({', '.join(foreign[:3])}); "
                          "choose a new folder")


def _write(out: Path, gen, options: dict, args, seeds, splits, names, fractions) -> int:
    from .contract.atomic import replacing_folder, write_json
    from .dataset import INDEX, path_length_m, scripts_index
    from .plan import validate_scene
    from .ses import parse_string
    sequences = []
    with Progress(len(names), f"generate {gen.name}", mode=progress_mode(args), unit="script") as bar, \
            replacing_folder(out) as tmp:
        for name, seed, split in zip(names, seeds, splits):
            try:
                text = gen(seed, **options)
            except SesgenError:
                raise
            except SystemExit as e:   # the generator's exit is not generate's
                raise GeneratorFailed(f"generator {gen.name} called sys.exit({e.code!r}) for seed {seed}") from None
            except Exception as e:  # noqa: BLE001 - the generator's own failure
                raise GeneratorFailed(f"generator {gen.name} failed for seed {seed}: {type(e).__name__}: {e}") \
                    from None
            if not isinstance(text, str):
                raise GeneratorFailed(f"generator {gen.name} returned {type(text).__name__}, not a script (str)")
            script = out / f"{name}.ses"
            try:
                scene = parse_string(text, source=str(script), base_dir=str(out))
                validate_scene(scene)
            except ScriptError as e:
                raise GeneratorFailed(f"generator {gen.name} (seed {seed}) wrote a script that does not check: {e}") \
                    from None
            except SesgenError as e:
                raise GeneratorFailed(f"generator {gen.name} (seed {seed}) wrote a script that does not check: "
                                      f"{script}: {e}") from None
            (tmp / script.name).write_text(text, encoding="utf-8")
            sequences.append({"name": name, "script": script.name, "seed": seed, "split": split,
                              "frames": int(scene.frames),
                              "path_length_m": round(path_length_m(scene.timeline.left()), 6),
                              "script_sha256": hashlib.sha256(text.encode("utf-8")).hexdigest()})
            bar.update(detail=f"{name} ({split}, {scene.frames} frames)")
        generator = {"name": gen.name, "origin": gen.origin, "location": gen.location,
                     "source_sha256": gen.source_sha256, "options": options}
        write_json(tmp / INDEX, scripts_index(generator, args.seed, fractions, sequences))
    return len(sequences)
