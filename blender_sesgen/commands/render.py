"""``python -m blender_sesgen render SCENE.ses --out DIR ...`` (also ``blender -b -P render.py --``).

Exit codes: 0 done; 2 bad input (script, options, or a folder holding another scene's
output: nothing is created or touched); 1 render failure.
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
import time

from ..contract.cli import EXIT_FAILURE, EXIT_INTERRUPTED
from ..contract.progress import Progress, add_progress_argument, progress_mode
from ..contract.timing import FRAMES_HELP
from ..errors import SesgenError
from ..render.interrupt import deferred_interrupts
from ..render.plan import Device, RenderOptions
from ..scene.presets import QUALITIES


def add_arguments(p, forwarded_only: bool = False) -> list[argparse.Action]:
    """The render command's arguments (``forwarded_only``: just the render options a farm
    passes on to every chunk, in the same order); the options' actions are returned."""
    acts = []
    if not forwarded_only:
        p.add_argument("scene", metavar="SCENE.ses", help="the SES script to render")
        p.add_argument("--out", required=True, metavar="DIR", help="output folder (manifest.json, exr/, poses/, scene.ses)")
        p.add_argument("--frames", metavar="A:B", help=f"{FRAMES_HELP}; default all")
    acts.append(p.add_argument("--quality", choices=QUALITIES, default=None,
                               help="render preset: gt (exact ground truth at primary-ray cost, flat-shaded RGB), "
                                    "draft, final (the default) or reference (docs/rendering.md); replaces the "
                                    "script's RENDER quality/samples/denoise"))
    acts.append(p.add_argument("--samples", type=int, metavar="N",
                               help="exactly N samples per pixel, overriding the preset (adaptive sampling off)"))
    acts.append(p.add_argument("--denoise", action=argparse.BooleanOptionalAction, default=None,
                               help="OpenImageDenoise on the beauty pass, overriding the preset (ground truth is "
                                    "never denoised)"))
    acts.append(p.add_argument("--seed", type=int, metavar="S",
                               help="base random seed (per frame/view seeds derive from it)"))
    if not forwarded_only:
        p.add_argument("--resume", action="store_true", help="render only the frames not complete in DIR")
        p.add_argument("--force", action="store_true", help="write into DIR even if it holds another scene's output")
    acts.append(p.add_argument("--resolution-scale", type=float, default=1.0, metavar="S",
                               help="scale the image size and K (e.g. 0.5 for a quick look)"))
    acts.append(p.add_argument("--device", choices=("cpu", "gpu"), default="cpu", help="Cycles device (default cpu)"))
    if not forwarded_only:
        p.add_argument("--threads", type=int, default=0, metavar="N", help="CPU threads (0 = automatic)")
    acts.append(p.add_argument("--plain-pipeline", action="store_true",
                               help="render each view in a fresh Cycles session, without persistent data or "
                                    "multiview (slower, the same pixels: to check the fast path)"))
    acts.append(p.add_argument("--cull", action="store_true",
                               help="build only the objects the frames rendered can see (view volumes, far plane; "
                                    "shadow casters and what is near for shaded presets): a long sequence in chunks "
                                    "(--frames, farm --chunk) loads only its part of a large world; depth and ids "
                                    "stay exact (docs/rendering.md, Culling)"))
    acts.append(p.add_argument("--normal-pass", action="store_true", help="also write the Normal pass"))
    acts.append(p.add_argument("--position-pass", action="store_true", help="also write the Position pass"))
    if not forwarded_only:
        p.add_argument("--contact-sheet", nargs="?", const="contact_sheet.png", metavar="PNG",
                       help="after rendering, write a contact sheet (RGB, disparity, segmentation) into DIR")
    acts.append(p.add_argument("--rate", type=float, metavar="HZ",
                               help="frame rate (overrides TIMING rate; default 25)"))
    acts.append(p.add_argument("--exposure", type=float, metavar="S",
                               help="exposure time in seconds (overrides TIMING exposure)"))
    acts.append(p.add_argument("--readout", type=float, metavar="S",
                               help="rolling-shutter readout time, top to bottom (overrides TIMING readout; 0 = "
                                    "global shutter)"))
    acts.append(p.add_argument("--motion-blur", action=argparse.BooleanOptionalAction, default=None,
                               help="motion blur over the exposure (overrides TIMING blur)"))
    acts.append(p.add_argument("--still", action=argparse.BooleanOptionalAction, default=None,
                               help="a still camera holds its noise: the frames of a still stretch show its first "
                                    "frame's beauty reprojected (overrides TIMING still)"))
    if not forwarded_only:
        p.add_argument("--reuse-exr", metavar="BASE",
                       help="take the EXRs from the render folder BASE and run only the post-render camera chain "
                            "(SENSOR, the lens's optics, NOISE may differ from BASE's script; nothing else)")
        add_progress_argument(p)
        p.add_argument("--verbose", action="store_true", help="show Blender's own render log")
    return acts


def _fmt(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600:d}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60:02d}:{s % 60:02d}"


def one_line(e: BaseException) -> str:
    """An exception as one line, ``Type: what``: Blender's importers put a whole Python
    traceback into their error's text, whose last line says what went wrong."""
    lines = [ln.strip() for ln in str(e).splitlines() if ln.strip()]
    last = lines[-1] if lines else ""
    return last if last.startswith(type(e).__name__) else f"{type(e).__name__}: {last}".rstrip(": ")


def forwarded_options(args: argparse.Namespace) -> RenderOptions:
    """The RenderOptions of the options a farm passes on (``add_arguments(forwarded_only=True)``)."""
    return RenderOptions(
        quality=args.quality, samples=args.samples, denoise=args.denoise, seed=args.seed, device=args.device,
        resolution_scale=args.resolution_scale, normal_pass=args.normal_pass, position_pass=args.position_pass,
        rate_hz=args.rate, exposure_s=args.exposure, readout_s=args.readout, motion_blur=args.motion_blur,
        still=args.still,
        fast_pipeline=not args.plain_pipeline, cull=args.cull,
    )


def render_options(args: argparse.Namespace) -> RenderOptions:
    """The RenderOptions of parsed render arguments."""
    return dataclasses.replace(forwarded_options(args), frames=args.frames, threads=args.threads, verbose=args.verbose,
                               reuse_exr=args.reuse_exr)


def run(args: argparse.Namespace) -> int:
    from ..render.job import RenderJob, frame_progress, have_bpy
    t_start = time.perf_counter()
    args.quiet = progress_mode(args) == "off"   # -q is --progress off: neither says what it renders
    options = render_options(args)
    job = RenderJob.prepare(args.scene, args.out, options, resume=args.resume, force=args.force)  # SesgenError -> 2
    if not have_bpy() and not (options.reuse_exr and job.session_needs_no_bpy()):
        raise SesgenError("rendering needs Blender's Python module 'bpy': pip install 'blender-sesgen[render]' "
                          "(Python 3.11), or run inside Blender: blender -b -P render.py -- SCENE.ses --out DIR")
    todo = job.pending_frames()
    s = job.settings
    views = job.scene.rig.views
    gpu = ""
    if s.device is Device.GPU:  # no GPU: exit 2 before anything is printed or written
        from ..blender.render import enable_gpu
        gpu = f" ({enable_gpu()})"
    if not args.quiet:
        p = s.preset
        sampling = f"adaptive <= {p.samples} samples" if p.adaptive else f"{p.samples} samples"
        how = f"reusing the EXRs of {options.reuse_exr}; " if options.reuse_exr else ""
        print(f"sesgen render: {args.scene} -> {args.out}: {how}{len(todo)} of {len(job.frames)} frames to render, "
              f"{len(views)} view(s), {s.width}x{s.height}, quality {s.quality}: {sampling}"
              f"{' + denoise' if s.denoise else ''}, seed {s.seed}, {s.device.value.upper()}{gpu}", flush=True)
    with deferred_interrupts() as stop:
        try:
            if stop.requested:   # asked while the command started (a farm's render child): no Blender to load
                raise KeyboardInterrupt
            job.build(stop=lambda: stop.requested)
            if job.session.culling is not None and not args.quiet:
                print(f"culling: {job.session.culling.summary()} built for {len(todo)} frame(s)", flush=True)
            if job.session.metering_s is not None and not args.quiet:
                print(f"auto-exposure: metered {sum(v is not None for v in job.session.metering)} frame(s) in "
                      f"{_fmt(job.session.metering_s)}", flush=True)
        except SesgenError:
            raise
        except KeyboardInterrupt:   # the build writes nothing into the folder
            print(f"interrupted{f' ({stop.signal_name})' if stop.signal_name else ''} before frame 0 was rendered: "
                  f"{args.out} is as it was; render again to start", file=sys.stderr)
            return EXIT_INTERRUPTED
        except Exception as e:  # noqa: BLE001 - a Blender failure while building
            print(f"error: building the Blender scene failed: {one_line(e)}", file=sys.stderr)
            return EXIT_FAILURE
        try:
            with Progress(len(todo), "render", mode=progress_mode(args), unit="frame") as bar:
                results = job.run(frame_progress(bar), stop=lambda: stop.requested)
        except SesgenError:
            raise
        except KeyboardInterrupt:
            print(f"interrupted{f' ({stop.signal_name})' if stop.signal_name else ''} after {len(job.timings)} "
                  f"frame(s): {args.out} is consistent; render again with --resume to continue", file=sys.stderr)
            return EXIT_INTERRUPTED
        except Exception as e:  # noqa: BLE001 - Cycles/IO failure (a full disk...): the folder stays consistent
            print(f"error: render failed: {one_line(e)}", file=sys.stderr)
            return EXIT_FAILURE
    if args.contact_sheet:
        from ..files.contact_sheet import write_contact_sheet
        from pathlib import Path
        png = Path(args.contact_sheet)
        if not png.is_absolute():
            png = Path(args.out) / png
        write_contact_sheet(Path(args.out), png)
        if not args.quiet:
            print(f"contact sheet: {png}")
    if not args.quiet:
        wall = time.perf_counter() - t_start
        cyc = [r.cycles_s for r in results]
        tail = ""
        if results and all(c is not None for c in cyc):
            tail = f"; Cycles reported {sum(cyc):.1f} s ({sum(cyc) / wall:.0%} of wall time)"
        print(f"done: {len(results)} frames in {_fmt(wall)}{tail}", flush=True)
    return 0
