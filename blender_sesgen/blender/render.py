"""Cycles settings, passes, EXR output and the render of one view of one frame.

Ground truth (Depth = planar z, Object Index) comes from Cycles' first sample, which goes
through the exact pixel centre, so it is exact for any sample count, filter or denoiser;
the beauty pass is anti-aliased. Output: multilayer OpenEXR, float32, ZIP (lossless) at
deflate level ``EXR_ZIP_LEVEL``, the scene-linear values; beside it, on request, the
display-referred 8-bit PNG (the same render through the scene's view transform,
``save_display``).
"""
from __future__ import annotations

import os
import re
import time
from pathlib import Path
from typing import Optional

import bpy

from ..errors import SesgenError
from ..scene.presets import Preset
from . import compat
from .runtime import activate, probing_devices, quiet_stdout

# deflate level of the EXRs' ZIP compression (OpenEXR's default: 4). Measured on a 640x480
# gt stereo frame of the paper room (bench/bench_gt_cost.py): level 1 makes the files 1 %
# larger and costs less CPU to write; every level decodes to the same values.
EXR_ZIP_LEVEL = 1

# The ideal camera's pixel filter (and every render's ground truth): Blackman-Harris of width
# 1.5, which Cycles spans over +-1.5 px (its filter table doubles the width): a Gaussian-
# equivalent edge spread of 0.416 px, MTF 0.41 at the Nyquist frequency.
PIXEL_FILTER = ("BLACKMAN_HARRIS", 1.5)
# A sensor's pixel aperture: each pixel integrates the light over its own square (a photosite,
# or the s x s photosites of a render s times smaller than the sensor: a binned pixel), a box
# of one pixel (edge spread 1/sqrt(12) = 0.289 px, MTF 0.64 at Nyquist). The sensor path's
# beauty only (blender/sensor.py: pixel_aperture), whose ground truth is a render of its own:
# sample 0 goes through the pixel centre with either filter, but the two filter tables put it
# there with other float round-off (depth differs in the 6th digit), so the ground truth keeps
# PIXEL_FILTER and its bytes (docs/sensors.md, "Optics, exposure and the raw sensor").
SENSOR_PIXEL_FILTER = ("BOX", 1.0)

_TIME_RE = re.compile(r"Time:\s*(?:(\d+):)?(\d+):(\d+(?:\.\d+)?)")


def gpu_devices(kinds=("OPTIX", "CUDA", "HIP", "METAL", "ONEAPI")) -> tuple[str, list[str]]:
    """(backend, device names) of the first GPU backend with devices; ('', []) if none."""
    prefs = bpy.context.preferences.addons["cycles"].preferences
    for kind in kinds:
        try:
            prefs.compute_device_type = kind
        except TypeError:
            continue
        with probing_devices():
            prefs.get_devices()
        devs = [d for d in prefs.devices if d.type == kind]
        if devs:
            return kind, [d.name for d in devs]
    prefs.compute_device_type = "NONE"
    return "", []


def enable_gpu() -> str:
    backend, names = gpu_devices()
    if not backend:
        raise SesgenError("--device gpu: Cycles found no GPU (OptiX/CUDA/HIP/Metal/oneAPI)")
    prefs = bpy.context.preferences.addons["cycles"].preferences
    for d in prefs.devices:
        d.use = d.type == backend
    return f"{backend}: {', '.join(names)}"


_GUIDES = {"none": "RGB", "albedo": "RGB_ALBEDO", "albedo_normal": "RGB_ALBEDO_NORMAL"}
_PREFILTERS = {"none": "NONE", "fast": "FAST", "accurate": "ACCURATE"}


def configure(bscene, preset: Preset, *, gpu: bool = False, threads: int = 0,
              normal_pass: bool = False, position_pass: bool = False, view_transform: str = "AgX",
              look: str = "None", persistent: bool = False) -> None:
    """Cycles as ``preset`` says (scene/presets.py), the passes, multilayer EXR output and the
    colour management. ``view_transform`` and ``look`` shape the display-referred PNG only
    (the EXR is scene-linear whatever they are). ``persistent``: keep the Cycles session
    (synchronised scene, BVH, importance map) from render to render; switching it off frees
    that session, so it is written only when it changes (configure may run between the
    exposure preview and the frames, which reuse the preview's session)."""
    r = bscene.render
    # writes that would free or resynchronise a persistent session even when the value is
    # unchanged (the engine, the display device) go through _set
    _set(r, "engine", "CYCLES")
    c = bscene.cycles
    c.device = "GPU" if gpu else "CPU"
    c.samples = int(preset.samples)
    c.use_adaptive_sampling = preset.adaptive
    c.adaptive_threshold = float(preset.adaptive_threshold)
    c.adaptive_min_samples = int(preset.adaptive_min_samples)
    c.use_denoising = bool(preset.denoise)
    if preset.denoise:
        with probing_devices():  # the denoiser's choices ask Cycles whether OptiX is there
            c.denoiser = "OPENIMAGEDENOISE"
        c.denoising_input_passes = _GUIDES[preset.denoise_guides]
        c.denoising_prefilter = _PREFILTERS[preset.denoise_prefilter]
        if hasattr(c, "denoising_use_gpu"):  # on a CPU render, do not probe for GPUs to denoise on
            c.denoising_use_gpu = bool(gpu)
    c.use_animated_seed = False
    c.sample_clamp_direct = float(preset.clamp_direct)
    c.sample_clamp_indirect = float(preset.clamp_indirect)
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces = preset.max_bounces, preset.diffuse_bounces, preset.glossy_bounces
    c.transmission_bounces, c.volume_bounces = preset.transmission_bounces, preset.volume_bounces
    c.transparent_max_bounces = preset.transparent_bounces
    c.caustics_reflective = c.caustics_refractive = bool(preset.caustics)
    c.use_light_tree = bool(preset.light_tree)
    c.blur_glossy = float(preset.filter_glossy)
    c.sampling_pattern = preset.sampling_pattern.upper()
    if hasattr(c, "use_guiding"):  # CPU path guiding (Cycles ignores it on a GPU)
        c.use_guiding = bool(preset.path_guiding)
    c.pixel_filter_type, c.filter_width = PIXEL_FILTER
    r.use_motion_blur = False
    r.film_transparent = False
    _set(r, "use_persistent_data", bool(persistent))
    r.use_multiview = False
    r.threads_mode = "FIXED" if threads > 0 else "AUTO"
    if threads > 0:
        r.threads = int(threads)
    r.use_file_extension = False
    r.use_compositing = False
    r.use_sequencer = False
    r.dither_intensity = 0.0
    _set(bscene.display_settings, "display_device", "sRGB")
    _set(bscene.view_settings, "view_transform", view_transform)
    _set(bscene.view_settings, "look", look)
    _set(bscene.view_settings, "exposure", 0.0)
    _set(bscene.view_settings, "gamma", 1.0)
    vl = bscene.view_layers[0]
    vl.name = "ViewLayer"
    vl.use_pass_combined = True
    vl.use_pass_z = True
    vl.use_pass_object_index = True
    vl.use_pass_normal = bool(normal_pass)
    vl.use_pass_position = bool(position_pass)
    compat.set_multilayer_exr(r.image_settings)


class _Stats:
    """Collects the render time Cycles reports (``Time: mm:ss.ss``) through render_stats."""

    def __init__(self):
        self.last = None

    def __call__(self, text, *args):
        text = str(text)
        if "Time:" not in text:  # called for every status line: keep it cheap
            return
        m = _TIME_RE.search(text)
        if m:
            self.last = 3600 * int(m.group(1) or 0) + 60 * int(m.group(2)) + float(m.group(3))


def _render(bscene, quiet: bool) -> tuple[float, Optional[float]]:
    """One render of the scene's camera at its current frame, its file(s) written; (wall s,
    Cycles' own time)."""
    stats = _Stats()
    bpy.app.handlers.render_stats.append(stats)
    t0 = time.perf_counter()
    try:
        # the render takes its frame from the *context* scene: make it ours even where
        # there is no window to activate (blender -b)
        with quiet_stdout(quiet), bpy.context.temp_override(scene=bscene), compat.exr_zip_level(EXR_ZIP_LEVEL):
            result = bpy.ops.render.render(write_still=True, scene=bscene.name)
    finally:
        bpy.app.handlers.render_stats.remove(stats)
    wall = time.perf_counter() - t0
    if "FINISHED" not in result:
        raise RuntimeError(f"Cycles render did not finish ({result}) for frame {bscene.frame_current}")
    return wall, stats.last


class Bake:
    """The throw-away scene of a bake that reads Cycles' own RGB off emitting planes under an
    orthographic camera (the sky's table, the library materials' means): CPU, no denoiser, no
    adaptive sampling, no bounce, the Standard view, ``threads`` CPU threads (0: automatic).
    The caller adds its planes through :meth:`new`; :meth:`close` removes every datablock made."""

    def __init__(self, name: str, width_px: int, height_px: int, samples: int, threads: int,
                 ortho_scale: float, camera_location: tuple):
        self.made: list = []
        self.scene = scene = self.new("scenes", name)
        scene.render.engine = "CYCLES"
        c = scene.cycles
        c.device, c.samples, c.use_denoising, c.use_adaptive_sampling = "CPU", samples, False, False
        c.max_bounces = 0
        r = scene.render
        r.resolution_x, r.resolution_y, r.resolution_percentage = width_px, height_px, 100
        r.threads_mode = "FIXED" if threads > 0 else "AUTO"
        if threads > 0:
            r.threads = int(threads)
        scene.view_settings.view_transform = "Standard"
        scene.view_settings.look = "None"
        scene.world = self.new("worlds", name)
        self.camera = cam = self.new("objects", f"{name}_camera", self.new("cameras", f"{name}_camera"))
        cam.data.type, cam.data.ortho_scale = "ORTHO", float(ortho_scale)
        cam.location = camera_location
        scene.collection.objects.link(cam)
        scene.camera = cam

    def new(self, collection: str, *args, **kw):
        """``bpy.data.<collection>.new(...)``, tagged and removed by :meth:`close`."""
        from .datablocks import tag
        block = tag(getattr(bpy.data, collection).new(*args, **kw))
        self.made.append(block)
        return block

    def render_rgb(self, prefix: str):
        """One quiet render to a temporary 32-bit EXR, removed after: its linear RGB, (H, W, 3)
        float32, row 0 at the top."""
        import tempfile
        import numpy as np
        from ..files.exr import read_exr
        ims = self.scene.render.image_settings
        ims.file_format, ims.color_depth = "OPEN_EXR", "32"
        fd, path = tempfile.mkstemp(suffix=".exr", prefix=f"sesgen-{prefix}-{os.getpid()}-")
        os.close(fd)
        try:
            self.scene.render.filepath = path
            _render(self.scene, quiet=True)
            ch = read_exr(path)
        finally:
            os.remove(path)
        return np.stack([ch[k] for k in "RGB"], axis=-1)

    def close(self) -> None:
        bpy.data.batch_remove(self.made)
        self.made = []


def _set(owner, name: str, value) -> None:
    """Assign only a changed value: every RNA write triggers Blender's update machinery
    (a new camera even rebuilds the dependency graph's relations)."""
    if getattr(owner, name) != value:
        setattr(owner, name, value)


def _prepare(bscene, camera, frame: int, seed: int, fast: bool) -> None:
    """Camera, seed and frame of the next render. ``fast``: set the frame without
    evaluating the scene for it (the render evaluates its own dependency graph at the
    scene's frame; frame_set would evaluate the view layer's too)."""
    activate(bscene)
    if fast:
        _set(bscene, "camera", camera)
        _set(bscene.cycles, "seed", int(seed))
        _set(bscene, "frame_current", int(frame))
    else:
        bscene.camera = camera
        bscene.cycles.seed = int(seed)
        bscene.frame_set(int(frame))


def render_view(bscene, camera, frame: int, seed: int, filepath: str, quiet: bool = True,
                fast: bool = False, display_path: Optional[str] = None) -> dict:
    """Render ``camera`` at Blender frame ``frame`` into the multilayer EXR ``filepath``
    (scene-linear) and, with ``display_path``, the display-referred 8-bit PNG.

    Returns {"wall_s": seconds around the render call, "cycles_s": Cycles' own render time,
    "display_s": seconds writing the PNG}.
    """
    set_multiview(bscene, False)
    _prepare(bscene, camera, frame, seed, fast)
    bscene.render.filepath = filepath
    wall, cycles = _render(bscene, quiet)
    t0 = time.perf_counter()
    if display_path is not None:
        save_display(bscene, display_path)
    return {"wall_s": wall, "cycles_s": cycles, "display_s": time.perf_counter() - t0}


def save_display(bscene, path: str, views=None) -> None:
    """The last render result as an 8-bit sRGB PNG through the scene's view transform
    (``Image.save_render`` applies the scene's colour management to non-float formats).
    ``views``: {view: path} of a multiview render (Blender writes each view with its file
    suffix, as ``multiview_paths`` says; the files are moved to their paths)."""
    ims = bscene.render.image_settings
    written = multiview_paths(Path(path), tuple(views)) if views else {}
    try:
        compat.set_png(ims)
        bpy.data.images["Render Result"].save_render(filepath=path, scene=bscene)
    except RuntimeError:
        # Blender 5.0 writes every view of a multiview result (with its suffix) and then
        # reports that the unsuffixed path could not be saved; the files are checked
        # (decoded) when the frame is sealed
        if not written or not all(p.exists() for p in written.values()):
            raise
    finally:
        compat.set_multilayer_exr(ims)
    for v, target in (views or {}).items():
        os.replace(written[v], target)


# --- the fast path: one camera for Blender, views chosen per render ---------------------
# Switching ``scene.camera`` rebuilds Blender's dependency-graph relations, and Cycles then
# synchronises the whole scene again and rebuilds its BVH (measured: 11 s per view for a
# street of a few hundred assets, ~all of a ground-truth frame's time). So the fast path
# never switches it: the scene renders in multiview mode (views_format MULTIVIEW) with the
# left camera active, and each enabled view takes the camera named like the active one
# with the view's suffix (SESGen_left -> SESGen_right), i.e. exactly the camera a per-view
# render uses. A render enables the views it draws: one view (with that view's own seed),
# or both at once when the beauty pass uses no random numbers
# (``presets.Preset.deterministic_rgb``: the views of one render share a seed). The scene
# is then synchronised once for the sequence (``use_persistent_data``); per frame only the
# cameras move. Files: Blender inserts the view's suffix before the path's last dot.

def can_render_multiview(cameras: dict) -> bool:
    """The cameras are named for the suffix lookup (``<name>_<view>``, one name)."""
    stems = {cam.name[:-len(v) - 1] for v, cam in cameras.items() if cam.name.endswith(f"_{v}")}
    return len(stems) == 1 and len(cameras) == sum(cam.name.endswith(f"_{v}") for v, cam in cameras.items())


def set_multiview(bscene, on: bool, views=("left", "right")) -> None:
    """Multiview rendering of exactly ``views`` (each view's camera and file suffix
    ``_<view>``), or off."""
    r = bscene.render
    if not on:
        _set(r, "use_multiview", False)
        return
    _set(r, "use_multiview", True)
    _set(r, "views_format", "MULTIVIEW")
    _set(r.image_settings, "views_format", "INDIVIDUAL")
    for name in views:
        if r.views.get(name) is None:
            r.views.new(name)
    for rv in r.views:
        _set(rv, "use", rv.name in views)
        if rv.name in views:
            _set(rv, "camera_suffix", f"_{rv.name}")
            _set(rv, "file_suffix", f"_{rv.name}")


def multiview_paths(base: Path, views) -> dict:
    """Where Blender writes each view of a multiview render to ``base`` (suffix before the
    name's last dot)."""
    stem, dot, ext = base.name.rpartition(".")
    return {v: base.with_name(f"{stem}_{v}.{ext}" if dot and stem else f"{base.name}_{v}") for v in views}


def render_views(bscene, cameras: dict, views, frame: int, seed: int, paths: dict, quiet: bool = True,
                 display_paths: Optional[dict] = None) -> dict:
    """``views`` (a subset of ``cameras``) at ``frame`` in one multiview render with Cycles
    seed ``seed``, view v into ``paths[v]`` (and its display-referred PNG into
    ``display_paths[v]``); {view: stats} (the render's wall and Cycles time, and the time
    spent writing the display PNGs, split evenly between its views)."""
    views = tuple(views)
    set_multiview(bscene, True, views)
    _prepare(bscene, cameras["left"], frame, seed, fast=True)
    first = Path(paths[views[0]])                  # e.g. exr/left/.000003.tmp-PID.exr
    base = first.with_name(first.name.removesuffix(".exr"))  # Blender writes .000003_<view>.tmp-PID
    written = multiview_paths(base, views)
    bscene.render.filepath = str(base)
    try:
        wall, cycles = _render(bscene, quiet)
        for v in views:
            os.replace(written[v], paths[v])
        t0 = time.perf_counter()
        if display_paths:
            save_display(bscene, str(display_paths[views[0]]), {v: display_paths[v] for v in views})
        display = time.perf_counter() - t0
    finally:
        for p in written.values():
            if p.exists():
                p.unlink()
    n = len(views)
    return {v: {"wall_s": wall / n, "cycles_s": None if cycles is None else cycles / n, "views_per_render": n,
                "display_s": display / n} for v in views}
