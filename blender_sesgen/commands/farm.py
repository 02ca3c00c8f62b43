"""``python -m blender_sesgen farm SCENE... --out ROOT``: render many scenes, in chunks of
frames, as Ray tasks (docs/farm.md).

Exit codes: 0 every scene complete (verified against its checksums); 1 a scene could not be
rendered (its chunks lost more often than ``--retries``); 2 bad input (options, a script,
a folder holding something else: if every scene that failed failed for such a reason);
130 interrupted (run the same command again: it resumes).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..contract.cli import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_OK, EXIT_USER_ERROR
from ..contract.progress import add_progress_argument, progress_mode
from ..errors import SesgenError

# render options the farm sets itself (per chunk) or that make no sense for a farm
CONTROLLED = {"scene", "out", "frames", "resume", "force", "contact_sheet", "progress", "quiet", "verbose",
              "threads", "reuse_exr", "help"}
DEFAULT_CHUNK = 10
DEFAULT_RETRIES = 3


def render_actions() -> list[argparse.Action]:
    """The render command's options a farm passes on to every chunk (``--quality``,
    ``--samples``, ``--denoise``, ``--seed``, ``--resolution-scale``, ``--device``, ...):
    declared once, by the render command (``render.add_arguments``), so that a new render
    option is a farm option too."""
    from . import render
    return render.add_arguments(argparse.ArgumentParser(add_help=False), forwarded_only=True)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenes", nargs="+", metavar="SCENE",
                   help="SES scripts, or folders of them (a folder written by `generate`: in its index's order)")
    p.add_argument("--out", required=True, metavar="ROOT",
                   help="each scene renders into ROOT/NAME, NAME being its file name without .ses (names given "
                        "twice get -2, -3, ... in order); ROOT/dataset.json indexes them")
    p.add_argument("--address", metavar="auto|HOST:PORT",
                   help="join this Ray cluster (the head's address; ROOT and the scripts must be on a filesystem "
                        "every node shares); default: start a local Ray on this machine")
    p.add_argument("--chunk", type=int, default=DEFAULT_CHUNK, metavar="N",
                   help=f"frames per task (default {DEFAULT_CHUNK})")
    p.add_argument("--retries", type=int, default=DEFAULT_RETRIES, metavar="K",
                   help=f"times a lost task (exit 1, killed, worker or node gone) is run again (default "
                        f"{DEFAULT_RETRIES}); user errors are not retried")
    p.add_argument("--cpus-per-task", type=float, metavar="C",
                   help="CPUs each task reserves, also its Cycles threads (default: the cluster's CPUs shared "
                        "among the chunks, at least 1, so that one machine is never idle)")
    p.add_argument("--gpus-per-task", type=float, default=0.0, metavar="G",
                   help="GPUs each task reserves (fractions share a GPU); > 0 renders with --device gpu")
    p.add_argument("--num-cpus", type=int, metavar="N", help="local Ray only: the CPUs it may use (default all)")
    add_progress_argument(p)
    from . import render
    render.add_arguments(p.add_argument_group("render options", "as for `render`, for every scene"),
                             forwarded_only=True)


def forwarded_argv(args: argparse.Namespace) -> list[str]:
    """The render options given on the farm's command line, as render arguments."""
    from ..render.plan import render_argv
    return render_argv(render_options(args))


def render_options(args: argparse.Namespace):
    """The RenderOptions every chunk renders with (the render command's reading of them)."""
    from . import render
    return render.forwarded_options(args)


def prepare(args: argparse.Namespace) -> tuple[Path, list]:
    """ROOT and the farm's scenes, each with its plan and pending frames or its user error."""
    from ..farm.work import FarmScene, find_scripts, prepare_scene, unique_names
    root = Path(args.out).absolute()
    if root.exists() and not root.is_dir():
        raise SesgenError(f"--out {args.out}: exists and is not a folder")
    from ..files.dataset import read_index
    index = read_index(root)       # a damaged index: refused now, not after the renders
    if index is not None and index.get("kind") != "renders":
        raise SesgenError(f"--out {args.out}: holds the scripts index of `generate`; render into another folder")
    options = render_options(args)
    found = find_scripts(args.scenes)
    scenes = [prepare_scene(FarmScene(name=name, script=script, out=root / name, meta=meta), options)
              for (script, meta), name in zip(found, unique_names(s for s, _ in found))]
    return root, scenes


def run(args: argparse.Namespace) -> int:
    for flag, value, least in (("--chunk", args.chunk, 1), ("--retries", args.retries, 0),
                               ("--gpus-per-task", args.gpus_per_task, 0)):
        if value < least:
            raise SesgenError(f"{flag} must be >= {least}, got {value}")
    if args.cpus_per_task is not None and not args.cpus_per_task > 0:
        raise SesgenError(f"--cpus-per-task must be > 0, got {args.cpus_per_task}")
    if getattr(args, "device", "cpu") == "gpu" and args.gpus_per_task == 0:
        args.gpus_per_task = 1.0
    if args.gpus_per_task > 0:
        args.device = "gpu"
    if args.address is not None and args.num_cpus is not None:
        raise SesgenError("--num-cpus is for the local Ray only (a cluster has the CPUs its nodes have)")
    root, scenes = prepare(args)
    quiet = progress_mode(args) == "off"
    good = [s for s in scenes if s.error is None]
    if not good:
        for s in scenes:
            print(s.error, file=sys.stderr)
        return EXIT_USER_ERROR

    from ..files.dataset import write_render_index
    from ..farm.cluster import Cluster, ClusterStartError
    from ..farm.driver import Farm
    from ..farm.work import auto_cpus_per_task, frame_ranges
    from ..render.interrupt import sigterm_as_interrupt
    try:
        cluster = Cluster(args.address, num_cpus=args.num_cpus).start()
    except ClusterStartError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_FAILURE
    try:
        if args.address is not None:
            cluster.check_shared(root, [s.script for s in good])
        cpus, gpus = cluster.totals()
        big_cpus, big_gpus = cluster.largest_node()
        if args.gpus_per_task > big_gpus:
            raise SesgenError(f"--gpus-per-task {args.gpus_per_task:g}: no node has that many GPUs "
                              f"(the largest has {big_gpus:g})")
        n_chunks = sum(len(frame_ranges(s.pending, args.chunk)) for s in good)
        cpt = args.cpus_per_task or auto_cpus_per_task(cpus, n_chunks)
        cpt = min(cpt, big_cpus) if big_cpus > 0 else cpt
        threads = max(1, int(cpt))
        if not quiet:
            frames = sum(len(s.pending) for s in good)
            print(f"sesgen farm: {len(scenes)} scene(s), {frames} frame(s) to render in {n_chunks} task(s) of "
                  f"<= {args.chunk} frames -> {root}; {cluster.describe()}; {cpt:g} CPU(s) per task (Cycles "
                  f"threads {threads})" + (f", {args.gpus_per_task:g} GPU(s) per task" if args.gpus_per_task else ""),
                  flush=True)
            for s in scenes:
                if s.error:
                    print(f"farm: {s.name} failed: {s.error}", file=sys.stderr)
        root.mkdir(parents=True, exist_ok=True)
        farm = Farm(cluster, scenes, chunk=args.chunk, retries=args.retries, cpus_per_task=cpt,
                    gpus_per_task=args.gpus_per_task, threads=threads, forwarded=forwarded_argv(args),
                    progress_mode=progress_mode(args))
        with sigterm_as_interrupt():
            result = farm.run()
    finally:
        cluster.stop()
    write_render_index(root, result.states)
    return report(root, result, quiet)


def report(root: Path, result, quiet: bool) -> int:
    """The summary (stdout: one line per scene; stderr: every failure) and the exit code."""
    done, failed = result.complete, result.failed
    if not quiet:
        for st in done:
            print(f"  {st.scene.name}: complete, {st.scene.frames} frame(s) -> {st.scene.out}")
    for st in failed:
        why = st.failed or ("interrupted" if result.interrupted else "not finished")
        print(f"  {st.scene.name}: FAILED: {why}", file=sys.stderr)
    tail = f"; {result.retried} task(s) retried" if result.retried else ""
    line = (f"farm {root}: {len(done)} of {len(result.states)} scene(s) complete, {result.frames_rendered} frame(s) "
            f"rendered in {result.wall_s:.1f} s{tail}")
    if result.interrupted:
        print(f"{line}; interrupted: the folders are consistent, run the same command again to continue",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    print(line, file=sys.stderr if failed else sys.stdout)
    if not failed:
        return EXIT_OK
    return EXIT_USER_ERROR if all(st.user_error for st in failed) else EXIT_FAILURE
