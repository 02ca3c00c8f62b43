"""Automatic exposure (``LOOK exposure auto``; the default for scripts without emitting LIGHTs).

The default lighting must make any SESGen script "well lit, not black" — but no fixed light
power suits both a 5 m room and a camera 2 m above a 100 m ground, and an HDRI's absolute
level is arbitrary. So, once per sequence, a tiny preview of frame 0 (left view) is rendered and the
film exposure (Cycles' linear ``film_exposure``: scales the beauty pass only; depth and
object index are geometry) is set so that the 90th percentile of its luminance reads
TARGET. The same factor is used for every frame and view, so brightness is constant over
the sequence, as VO assumes; it is recorded in the manifest and reused on --resume, and a
later build of the same scene from the same inputs reads the preview (its value and image) from
the asset cache instead of rendering it (``cached_measure``, ``preview_key``).
Scripts with their own LIGHTs are rendered with exactly the light they ask for (``LOOK
exposure EV`` sets a fixed factor 2^EV).
"""
from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import os
import pickle
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ..contract.exr_format import PASS_COMBINED, PASS_NOISY
from ..render.sensor.autoexposure import METERING_DENOISE, METERING_SAMPLES, METERING_WIDTH_PX, meter
from ..scene.lighting import EXPOSURE_TARGET as TARGET

PREVIEW_WIDTH = 96      # px; the preview keeps the aspect ratio
PREVIEW_SAMPLES = 8


PREVIEW_PREFIX = "sesgen-exposure-"


def remove_stale_previews(folder=None) -> None:
    """Delete preview files of processes that no longer run (a killed render's leftovers)."""
    folder = Path(folder or tempfile.gettempdir())
    for f in folder.glob(f"{PREVIEW_PREFIX}*-*"):   # NAME.exr, or NAME_left while Blender writes it
        try:
            pid = int(f.name[len(PREVIEW_PREFIX):].split("-", 1)[0])
            os.kill(pid, 0)
        except ProcessLookupError:
            f.unlink(missing_ok=True)
        except (ValueError, PermissionError, OSError):
            continue


@contextmanager
def _preview_render(bscene, width_px: int, samples: int, film_exposure: float, denoise: bool = False):
    """The scene set to render small previews (``width_px`` wide, ``samples``, no motion blur,
    film exposure ``film_exposure``; OpenImageDenoise on the CPU with albedo and normal guides
    when ``denoise``, else none) and a temporary EXR path for them; everything restored and the
    file removed afterwards.

    The preview goes to the system's temporary folder under a name with this process's pid,
    so that a later render removes it if this one is killed (``remove_stale_previews``)."""
    from .render import probing_devices
    remove_stale_previews()
    r, c = bscene.render, bscene.cycles
    saved = (r.resolution_percentage, c.samples, c.use_denoising, c.film_exposure, r.use_motion_blur)
    denoiser = None   # the denoiser's own settings, when the preview changes them (a preset's guides, a GPU's)
    r.resolution_percentage = max(1, min(100, int(100 * width_px / max(r.resolution_x, 1))))
    c.samples, c.use_denoising, c.film_exposure, r.use_motion_blur = samples, bool(denoise), film_exposure, False
    if denoise:
        with probing_devices():   # the denoiser's choices ask Cycles whether OptiX is there
            denoiser = (c.denoiser, c.denoising_input_passes, c.denoising_prefilter,
                        getattr(c, "denoising_use_gpu", None))
            c.denoiser = "OPENIMAGEDENOISE"
        c.denoising_input_passes, c.denoising_prefilter = "RGB_ALBEDO_NORMAL", "ACCURATE"
        if denoiser[3] is not None:
            c.denoising_use_gpu = False
    fd, path = tempfile.mkstemp(suffix=".exr", prefix=f"{PREVIEW_PREFIX}{os.getpid()}-")
    os.close(fd)
    try:
        yield path
    finally:
        r.resolution_percentage, c.samples, c.use_denoising, c.film_exposure, r.use_motion_blur = saved
        if denoiser is not None:   # changed values only: each write sets off Blender's updates
            with probing_devices():
                if c.denoiser != denoiser[0]:
                    c.denoiser = denoiser[0]
            for name, value in zip(("denoising_input_passes", "denoising_prefilter", "denoising_use_gpu"),
                                   denoiser[1:]):
                if value is not None and getattr(c, name) != value:
                    setattr(c, name, value)
        if os.path.exists(path):
            os.remove(path)


def _beauty(path: str, pass_name: str = PASS_COMBINED[0]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The R, G, B planes of a preview EXR (``pass_name``: ``Combined``, denoised when the
    preview was; ``Noisy Image``, the same render before the denoiser)."""
    from ..files.exr import read_exr
    return _planes(read_exr(path), pass_name)


def _planes(channels: dict, pass_name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return tuple(next(v for k, v in channels.items() if k.endswith(f"{pass_name}.{c}")) for c in "RGB")


def measure_exposure(bscene, camera, frame: int, cameras=None, width_px: int = PREVIEW_WIDTH,
                     samples: int = PREVIEW_SAMPLES, denoise: bool = False) -> tuple[float, np.ndarray]:
    """(film exposure, preview): the film exposure that brings the preview's 90th-percentile
    luminance to TARGET, and the preview's linear RGB at film exposure 1 ((h, w, 3): the
    metering pass's image of ``frame`` before its film exposure, when the metering preview is
    this one, see ``meter_frames``). ``denoise``: render it through the metering preview's
    denoiser too, so that it is that preview; the 90th percentile is still the undenoised
    image's (the EXR's Noisy Image: the same samples), so the film exposure does not change.

    ``cameras`` ({view: camera}, the left one ``camera``): render the preview the fast way
    (``render.render_views``) in the scene's persistent Cycles session, which the frames
    then reuse (the scene is synchronised and its BVH built once, not twice); without it a
    plain render of ``camera``. ``width_px``, ``samples``: another preview's (bench/
    bench_exposure_preview.py)."""
    from .render import render_view, render_views

    with _preview_render(bscene, width_px, samples, 1.0, denoise) as path:
        if cameras is not None:
            render_views(bscene, cameras, ("left",), frame, 0, {"left": path})
        else:
            # the fast way (as the metering pass): evaluating the view layer for the frame too
            # cost the city's build ~1 CPU s, for the same pixels
            render_view(bscene, camera, frame, seed=0, filepath=path, fast=True)
        from ..files.exr import read_exr
        channels = read_exr(path)
        preview = np.stack(_planes(channels, PASS_COMBINED[0]), axis=-1)
        r, g, b = _planes(channels, PASS_NOISY[0] if denoise else PASS_COMBINED[0])
    lum = 0.2126 * r + 0.7152 * g + 0.0722 * b
    p90 = float(np.percentile(lum, 90))
    if not np.isfinite(p90) or p90 <= 1e-6:
        return 1.0, preview  # nothing lit in view: leave the exposure alone
    return float(np.clip(TARGET / p90, 1e-4, 1e4)), preview


# --- the exposure preview kept in the asset cache ---------------------------------------------
# The preview is a deterministic render (seed 0, fixed size and samples) of the built scene: a
# later process that builds the same scene from the same inputs gets the same bits, so its
# value and image are kept in the asset cache (``scene/assets/cache.py: cached_array``, kind
# ``exposure``) under everything the build and the preview depend on (``preview_key``).
CACHE_FORMAT = 1      # bump when what the cache holds, or how it is keyed, changes
EXPOSURES_KEPT = 256  # previews kept (~70 KB each at 96 x 72)
_DTYPES = (np.float32, np.float16, np.float64)


# The code a preview depends on: the package's modules that building the scene and rendering
# the preview import (``PREVIEW_MODULE``'s import closure, read from the sources: every ``import``
# and ``from ... import`` of a module in it, at any depth, function bodies too), the packages'
# ``__init__`` on their way, and every file of the package that is not a module (data). A change
# to another module (the command line, the farm, the studies, the scene generators: the scene
# model they lead to is in the key itself) keeps the previews (tests/test_exposure_cache.py).
PREVIEW_MODULE = "blender.session"   # BlenderSession: builds the scene, renders the preview
_IMPORT = re.compile(r"^[ \t]*(?:from[ \t]+([.\w]+)[ \t]+import[ \t]+(\([^)]*\)|[^\n#;]*)"
                     r"|import[ \t]+([^\n#;]+))", re.M)
_DYNAMIC = re.compile(r"(?:\bimport_module|\b__import__|\bspec_from_file_location|\bexec)[ \t]*\(")


def _imported(text: str, package: list[str], top: str) -> set[str]:
    """The dotted names that ``text`` (a module of the dotted ``package``) imports from ``top``
    (each ``from M import a`` gives M and M.a: ``a`` may be a module)."""
    out = set()
    for m, names, plain in _IMPORT.findall(text):
        if plain:
            out.update(n.split()[0] for n in plain.split(",") if n.strip())
            continue
        dots = len(m) - len(m.lstrip("."))
        if dots:
            base = package[:len(package) - (dots - 1)] if dots > 1 else package
            m = ".".join(base + ([m[dots:]] if m[dots:] else []))
        out.add(m)
        out.update(f"{m}.{n.split()[0]}" for n in names.strip("()").replace("\\", " ").split(",")
                   if n.split())
    return {n for n in out if n == top or n.startswith(top + ".")}


def _dynamic(text: str) -> bool:
    """Whether ``text`` imports by a computed name (``_DYNAMIC``; plain substring tests first)."""
    return any(w in text for w in ("import_module", "__import__", "spec_from_file_location", "exec")) \
        and _DYNAMIC.search(text) is not None


def preview_sources(root: Path, module: str = PREVIEW_MODULE) -> list[Path]:
    """The files of the package at ``root`` whose content the exposure preview depends on
    (``PREVIEW_MODULE``'s import closure and the package's data files), sorted; every file of
    the package where a module of the closure imports by a computed name (``import_module``,
    ``__import__``, ``exec``: what it reaches cannot be read off its text). Pure."""
    top = root.name
    every = sorted(p for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
    modules = {}                                     # dotted name -> its file
    for f in every:
        if f.suffix == ".py":
            rel = f.relative_to(root).with_suffix("").parts
            modules[".".join((top, *(rel[:-1] if rel[-1] == "__init__" else rel)))] = f
    seen, done = set(), set()
    todo = [f"{top}.{module}"]
    while todo:
        name = todo.pop()
        if name in done:
            continue
        done.add(name)
        parts = name.split(".")
        for i in range(1, len(parts) + 1):           # a module's packages run their __init__
            f = modules.get(".".join(parts[:i]))
            if f is None or f in seen:
                continue
            seen.add(f)
            text = f.read_text(encoding="utf-8")
            if _dynamic(text):
                return every
            todo.extend(_imported(text, [top, *f.relative_to(root).parts[:-1]], top))
    return sorted(seen.union(p for p in every if p.suffix not in (".py", ".pyc")))


@functools.lru_cache(maxsize=1)
def code_version() -> Optional[str]:
    """A hash of the package's files the preview depends on (``preview_sources``), numpy's
    version and Blender's (version and build hash); None where the sources cannot be read (a
    package without its .py files): then nothing is cached."""
    import bpy
    from ..scene.assets import cache
    root = Path(__file__).resolve().parents[1]
    if not (root / "blender" / "session.py").is_file():
        return None
    try:
        files = preview_sources(root)
    except (OSError, UnicodeDecodeError):
        return None
    return cache.sources_digest(f"{np.__version__}\0{bpy.app.version_string}\0{bpy.app.build_hash!r}",
                                ((p.relative_to(root).as_posix(), p) for p in files))


@functools.lru_cache(maxsize=1)
def _machine() -> str:
    """The CPU's architecture and instruction set (Cycles' CPU kernels differ by them): a cache
    folder shared by several machines keeps a preview per kind of machine."""
    import platform
    flags = ""
    try:
        with open("/proc/cpuinfo") as f:
            flags = next((line for line in f if line.startswith(("flags", "Features"))), "")
    except OSError:
        pass
    return f"{platform.machine()} {hashlib.sha256(flags.encode()).hexdigest()[:12]}"


def fingerprint(value) -> str:
    """A sha256 (hex) of ``value``'s pickle: every bit of its plain data (dataclasses by type and
    fields, numpy arrays by dtype, shape and bytes, floats exactly), so two values that differ
    anywhere differ here (two equal values may differ too, which costs only a cache miss);
    TypeError/pickle's errors for what does not pickle."""
    return hashlib.sha256(pickle.dumps(value, protocol=4)).hexdigest()


_FIELDS: dict = {}


def reads_files(scene) -> bool:
    """Whether building ``scene`` reads a file besides the script (an image, a mesh, a .blend,
    an HDRI, a trajectory): any absolute path in its fields (the script's own ``source`` aside).
    Their content is not in ``preview_key``: such a scene's preview is never cached."""
    stack = [getattr(scene, f.name) for f in dataclasses.fields(scene) if f.name != "source"]
    plain = (int, float, bool, type(None), np.ndarray)
    while stack:
        v = stack.pop()
        t = type(v)
        if t is str:
            if os.path.isabs(v):
                return True
        elif t in plain or isinstance(v, (enum.Enum, np.generic)):
            continue
        elif t is tuple or t is list or t is set or t is frozenset:
            stack.extend(x for x in v if type(x) is not float)
        elif t is dict:
            stack.extend(v.keys())
            stack.extend(v.values())
        else:
            names = _FIELDS.get(t)
            if names is None:
                if not dataclasses.is_dataclass(v):
                    return True       # something unknown: not cached
                names = _FIELDS[t] = tuple(f.name for f in dataclasses.fields(v))
            stack.extend(getattr(v, n) for n in names)
    return False


def preview_key(parts) -> Optional[list]:
    """The asset cache's key of an exposure preview: the code (``code_version``), the machine,
    and ``parts`` (what the session built and how it renders the preview: the scene model, the
    sizes, poses and options, fingerprinted); None where nothing may be cached."""
    code = code_version()
    if code is None:
        return None
    try:
        return ["exposure preview", CACHE_FORMAT, code, _machine(), fingerprint(parts)]
    except (TypeError, AttributeError, pickle.PicklingError):
        return None


def cached_measure(key: Callable[[], Optional[list]],
                   measure: Callable[[], tuple[float, np.ndarray]]) -> tuple[float, np.ndarray]:
    """``measure()`` (``measure_exposure``'s (film exposure, preview)), read from the asset cache
    when an earlier process measured it under ``key()`` (the same bits), measured and kept there
    otherwise; measured whenever the cache is off or ``key()`` is None."""
    from ..scene.assets import cache
    if cache.folder() is None:
        return measure()
    k = key()
    if k is None:
        return measure()

    def make() -> np.ndarray:
        value, preview = measure()
        preview = np.asarray(preview)
        code = next(i for i, t in enumerate(_DTYPES) if preview.dtype == t)
        head = np.array([value, preview.shape[0], preview.shape[1], code], dtype=np.float64)
        return np.concatenate([head, preview.astype(np.float64).ravel()])

    def valid(a: np.ndarray) -> bool:
        if a.ndim != 1 or a.dtype != np.float64 or len(a) < 4 or not np.isfinite(a).all():
            return False
        h, w, code = a[1], a[2], a[3]
        return h == int(h) > 0 and w == int(w) > 0 and code in range(len(_DTYPES)) and len(a) == 4 + int(h) * int(w) * 3

    a = cache.cached_array("exposure", k, make, valid, keep=EXPOSURES_KEPT)
    h, w, code = (int(x) for x in a[1:4])
    return float(a[0]), a[4:].reshape(h, w, 3).astype(_DTYPES[code])


# The exposure preview is the metering preview of its frame (same size, samples, seed, no
# motion blur, film exposure 1; rendered through the metering preview's denoiser when it serves
# as one): the metering pass takes that frame's image from it.
PREVIEW_IS_METERING = (PREVIEW_WIDTH, PREVIEW_SAMPLES) == (METERING_WIDTH_PX, METERING_SAMPLES)


def _plain_meter(linear_rgb: np.ndarray, metered_before: list) -> float:
    return meter(linear_rgb)


def meter_frames(bscene, camera, frames, film_exposure: float, progress=None,
                 first: Optional[np.ndarray] = None, metering: Callable = _plain_meter) -> list[float]:
    """The sensor auto-exposure's metering pass: ``metering(image, values so far)`` of a small
    preview of each of ``frames`` through ``camera`` (the left view), rendered in order in one
    persistent Cycles session at film exposure 1, the image times the film exposure of the
    frames (the frames' linear beauty). ``metering``: the camera's rule
    (``SensorPlan.meter``: what the sensor receives, clipped at full scale at the frame's own
    exposure, which the values of the frames before it decide: hence in order); default the
    plain mean linear luminance. Deterministic: seed 0, ``METERING_WIDTH_PX`` wide,
    ``METERING_SAMPLES`` samples, ``METERING_DENOISE``, no motion blur; whoever runs it (one render, a
    chunk of a farm) gets the same numbers. ``first``: the preview of ``frames[0]`` already
    rendered (the exposure preview, ``measure_exposure``, when ``PREVIEW_IS_METERING``: not
    while the metering preview is denoised and the exposure preview not), not rendered again.
    ``progress(i, n)`` after each frame."""
    from .render import render_view

    r = bscene.render
    persistent = r.use_persistent_data
    r.use_persistent_data = True       # one synchronisation and BVH for the whole pass
    frames = list(frames)
    out = [] if first is None else [metering(film_exposure * np.asarray(first), [])]
    try:
        with _preview_render(bscene, METERING_WIDTH_PX, METERING_SAMPLES, 1.0, METERING_DENOISE) as path:
            for i, frame in enumerate(frames[len(out):], start=len(out)):
                # the fast way: the frame set, not the view layer evaluated for it (the render
                # evaluates its own dependency graph), the camera not re-assigned: the same
                # pixels, ~0.45 CPU s less a preview in the city (bench/profile_scenes.py)
                render_view(bscene, camera, frame, seed=0, filepath=path, fast=True)
                out.append(metering(film_exposure * np.stack(_beauty(path), axis=-1), list(out)))
                if progress is not None:
                    progress(i + 1, len(frames))
    finally:
        r.use_persistent_data = persistent
    return out


def set_exposure(bscene, exposure: float) -> None:
    bscene.cycles.film_exposure = float(exposure)
