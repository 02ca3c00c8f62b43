"""Cycles settings, passes, EXR output and the render of one view of one frame.

Ground truth (Depth = planar z, Object Index) comes from Cycles' first sample, which goes
through the exact pixel centre, so it is exact for any sample count, filter or denoiser;
the beauty pass is anti-aliased. Output: multilayer OpenEXR, float32, ZIP (lossless).
"""
from __future__ import annotations

import re
import time

import bpy

from ..errors import SesgenError
from . import compat
from .runtime import activate, quiet_stdout

_TIME_RE = re.compile(r"Time:\s*(?:(\d+):)?(\d+):(\d+(?:\.\d+)?)")


def gpu_devices(kinds=("OPTIX", "CUDA", "HIP", "METAL", "ONEAPI")) -> tuple[str, list[str]]:
    """(backend, device names) of the first GPU backend with devices; ('', []) if none."""
    prefs = bpy.context.preferences.addons["cycles"].preferences
    for kind in kinds:
        try:
            prefs.compute_device_type = kind
        except TypeError:
            continue
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


def configure(bscene, *, samples: int, denoise: bool, gpu: bool = False, threads: int = 0,
              normal_pass: bool = False, position_pass: bool = False, view_transform: str = "AgX",
              look: str = "None") -> None:
    """Cycles, passes and colour management. ``view_transform`` shapes the display-referred
    PNG only (the EXR is scene-linear whatever it is)."""
    r = bscene.render
    r.engine = "CYCLES"
    c = bscene.cycles
    c.device = "GPU" if gpu else "CPU"
    c.samples = int(samples)
    c.use_adaptive_sampling = False
    c.use_denoising = bool(denoise)
    if denoise:
        c.denoiser = "OPENIMAGEDENOISE"
        c.denoising_input_passes = "RGB_ALBEDO_NORMAL"   # guided by albedo and normal
        c.denoising_prefilter = "ACCURATE"
    c.use_animated_seed = False
    c.sample_clamp_indirect = 10.0
    # enough bounces for indirect light in a closed room, fewer than Cycles' 12 (speed)
    c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 6, 3, 3
    c.transmission_bounces, c.volume_bounces, c.transparent_max_bounces = 6, 0, 8
    c.caustics_reflective = c.caustics_refractive = False
    r.use_motion_blur = False
    r.film_transparent = False
    r.use_persistent_data = False
    r.use_multiview = False
    r.threads_mode = "FIXED" if threads > 0 else "AUTO"
    if threads > 0:
        r.threads = int(threads)
    r.use_file_extension = False
    r.use_compositing = False
    r.use_sequencer = False
    r.dither_intensity = 0.0
    bscene.display_settings.display_device = "sRGB"
    bscene.view_settings.view_transform = view_transform
    bscene.view_settings.look = look
    bscene.view_settings.exposure = 0.0
    bscene.view_settings.gamma = 1.0
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
        m = _TIME_RE.search(str(text))
        if m:
            self.last = 3600 * int(m.group(1) or 0) + 60 * int(m.group(2)) + float(m.group(3))


def render_view(bscene, camera, frame: int, seed: int, filepath: str, quiet: bool = True,
                display_path: str | None = None) -> dict:
    """Render ``camera`` at Blender frame ``frame`` into the multilayer EXR ``filepath``
    (scene-linear) and, with ``display_path``, the display-referred 8-bit PNG (the same
    render through the scene's view transform).

    Returns {"wall_s": seconds around the render call, "cycles_s": Cycles' own render time}.
    """
    activate(bscene)
    bscene.camera = camera
    bscene.cycles.seed = int(seed)
    bscene.frame_set(int(frame))
    bscene.render.filepath = filepath
    stats = _Stats()
    bpy.app.handlers.render_stats.append(stats)
    t0 = time.perf_counter()
    try:
        # the render takes its frame from the *context* scene: make it ours even where
        # there is no window to activate (blender -b)
        with quiet_stdout(quiet), bpy.context.temp_override(scene=bscene):
            result = bpy.ops.render.render(write_still=True, scene=bscene.name)
    finally:
        bpy.app.handlers.render_stats.remove(stats)
    wall = time.perf_counter() - t0
    if "FINISHED" not in result:
        raise RuntimeError(f"Cycles render did not finish ({result}) for frame {frame}")
    if display_path is not None:
        save_display(bscene, display_path)
    return {"wall_s": wall, "cycles_s": stats.last}


def save_display(bscene, path: str) -> None:
    """The last render result as an 8-bit sRGB PNG through the scene's view transform
    (``Image.save_render`` applies the scene's colour management to non-float formats)."""
    ims = bscene.render.image_settings
    try:
        compat.set_png(ims)
        bpy.data.images["Render Result"].save_render(filepath=path, scene=bscene)
    finally:
        compat.set_multilayer_exr(ims)
