"""The camera as a sensor in Blender: sub-frame camera motion, Cycles' shutter (motion blur,
rolling shutter), the distorting lens as a Cycles custom (OSL) camera, the ground-truth
render settings and JPEG writing. Decisions (what to render, with which times) are made
in the pure ``blender_sesgen.render.sensor.render_plan``; this module only applies them.

Measured facts this relies on (bpy 5.0.1, docs/rendering.md):
- Cycles samples the camera at ``2^motion_steps + 1`` instants over the shutter, centred
  on the frame, and interpolates between them (translation linearly, rotation by slerp);
  the camera is keyed exactly at those instants (LINEAR F-curves).
- A rolling shutter (``rolling_shutter_type`` TOP) gives image row r (0 = top) the time
  (r + 1) / H of the shutter (the integer row, no spread within a row), and each row
  integrates over a ``rolling_shutter_duration`` fraction of it; the camera is keyed with poses
  half a line early (:func:`rolling_shift_frames`) so that rows sit symmetrically about the stamp.
- A custom camera's shader gets the raster position in [0, 1] (x from the left, y from
  the bottom) and returns a direction in a frame with x right, y up, z forward; its Depth
  pass is the distance along the ray (not planar z), which the sensor path converts.
"""
from __future__ import annotations

import contextlib
import os
import sys

import bpy
import numpy as np
from mathutils import Matrix

from ..contract.frames import camera_matrix_world
from ..errors import SesgenError
from . import compat, render

MOTION_STEPS = 4          # Cycles' camera motion steps: 2^4 + 1 = 17 instants per shutter


def motion_instants(frame: int, shutter_frames: float, steps: int = MOTION_STEPS) -> np.ndarray:
    """The Blender frame times at which Cycles samples the camera for ``frame`` (float32
    arithmetic, as Cycles computes them)."""
    n = (2 << (steps - 1)) + 1
    rel = np.array([np.float32(2.0 * i / (n - 1) - 1.0) for i in range(n)], dtype=np.float32)
    return (np.float32(frame) + rel * np.float32(shutter_frames) * np.float32(0.5)).astype(np.float64)


# Blender takes a key within 0.01 frame of the time it evaluates as that time's key (measured:
# a camera keyed at Cycles' 17 instants of a 0.125-frame shutter, 0.0078 frame apart, is posed
# at a neighbouring instant at the frame itself; 0.2 frame, 0.0125 apart, is exact)
KEY_GAP_FRAMES = 0.0125


def sparse_instants(frame: float, instants, gap: float = KEY_GAP_FRAMES) -> np.ndarray:
    """The frame and those of ``instants`` at least ``gap`` from every other key, the
    outermost taken first (the whole shutter stays keyed; a short one with fewer keys, between
    which Blender interpolates linearly)."""
    kept = [float(frame)]
    for t in sorted((float(x) for x in instants), key=lambda x: -abs(x - frame)):
        if all(abs(t - k) >= gap for k in kept):
            kept.append(t)
    return np.array(sorted(kept))


def rolling_shift_frames(readout_s: float, height: int, rate_hz: float) -> float:
    """Cycles reads image row r (0 = top) at (r + 1) / H of its rolling shutter (measured:
    the integer pixel row sets the time), half a line later than the symmetric convention
    t_k + (r + 0.5 - H/2) R / H. Keying the camera with the poses of half a line earlier
    restores the convention (in Blender frames: -R / (2 H) * rate)."""
    return -0.5 * float(readout_s) / float(height) * float(rate_hz)


def key_camera_instants(obj, frame_times: np.ndarray, T_world_cam_cv: np.ndarray) -> None:
    """Replace the camera's keys by poses at (fractional) Blender frames, LINEAR F-curves."""
    order = np.argsort(frame_times, kind="stable")
    frame_times = np.asarray(frame_times, dtype=float)[order]
    T_world_cam_cv = np.asarray(T_world_cam_cv, dtype=float)[order]
    keep = np.concatenate([[True], np.diff(frame_times) > 1e-9])
    frame_times, T_world_cam_cv = frame_times[keep], T_world_cam_cv[keep]
    locs, quats = [], []
    for T in T_world_cam_cv:
        loc, rot, _ = Matrix(camera_matrix_world(T).tolist()).decompose()
        q = tuple(rot)
        if quats and np.dot(q, quats[-1]) < 0:
            q = tuple(-x for x in q)
        locs.append(tuple(loc))
        quats.append(q)
    values = {("location", i): [v[i] for v in locs] for i in range(3)}
    values.update({("rotation_quaternion", i): [q[i] for q in quats] for i in range(4)})
    N = len(frame_times)
    for fc in compat.object_fcurves(obj):
        kp = fc.keyframe_points
        kp.clear()
        kp.add(N)
        co = np.empty(2 * N, dtype=np.float32)
        co[0::2] = frame_times
        co[1::2] = values[(fc.data_path, fc.array_index)]
        kp.foreach_set("co", co)
        for p in kp:
            p.interpolation = "LINEAR"
        fc.update()
    obj.cycles.use_motion_blur = True
    obj.cycles.motion_steps = MOTION_STEPS


def set_shutter(bscene, shutter_frames: float, rolling: bool, duration: float) -> None:
    """Motion blur over ``shutter_frames`` centred on the frame (0: off)."""
    r = bscene.render
    r.use_motion_blur = shutter_frames > 0
    if shutter_frames > 0:
        r.motion_blur_shutter = float(shutter_frames)
        r.motion_blur_position = "CENTER"
    bscene.cycles.rolling_shutter_type = "TOP" if rolling else "NONE"
    bscene.cycles.rolling_shutter_duration = float(duration) if rolling else 0.0


@contextlib.contextmanager
def pixel_aperture(bscene):
    """The beauty render through the sensor's pixel aperture (render.SENSOR_PIXEL_FILTER, a box
    of one pixel) instead of the ideal camera's filter; the ground truth is rendered apart."""
    c = bscene.cycles
    saved = (c.pixel_filter_type, c.filter_width)
    try:
        c.pixel_filter_type, c.filter_width = render.SENSOR_PIXEL_FILTER
        yield
    finally:
        c.pixel_filter_type, c.filter_width = saved


@contextlib.contextmanager
def ground_truth_settings(bscene, shutter_frames: float, rolling: bool):
    """Settings of the sharp ground-truth render: 1 sample (the ground-truth passes come from
    sample 0 through the pixel centre), no denoiser, no bounces; the shutter only for a
    rolling shutter with instantaneous rows (each row at its own capture time)."""
    r, c = bscene.render, bscene.cycles
    saved = (c.samples, c.use_denoising, c.max_bounces, r.use_motion_blur, r.motion_blur_shutter,
             c.rolling_shutter_type, c.rolling_shutter_duration)
    try:
        c.samples, c.use_denoising, c.max_bounces = 1, False, 0
        set_shutter(bscene, shutter_frames if rolling else 0.0, rolling, 0.0)
        yield
    finally:
        (c.samples, c.use_denoising, c.max_bounces, r.use_motion_blur, r.motion_blur_shutter,
         c.rolling_shutter_type, c.rolling_shutter_duration) = saved


# --- the distorting lens as a custom camera ----------------------------------------------------

_UNDISTORT = {
    "brown": """
    float x = xd, y = yd;
    for (int i = 0; i < 30; i++) {
        float r2 = x * x + y * y;
        float radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
        float dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
        float fx_ = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd;
        float fy_ = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd;
        float a = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x;
        float b = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y;
        float d = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x;
        float det = a * d - b * b;
        x -= (d * fx_ - b * fy_) / det;
        y -= (-b * fx_ + a * fy_) / det;
    }
    vector ray = vector(x, y, 1.0);""",
    "kannala_brandt": """
    float td = hypot(xd, yd);
    float t = td;
    for (int i = 0; i < 30; i++) {
        float t2 = t * t;
        float f = t * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - td;
        float df = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
        t -= f / df;
    }
    float s = (td > 0.0) ? sin(t) / td : 1.0;
    vector ray = vector(xd * s, yd * s, cos(t));""",
}


def lens_shader_source(model: str) -> str:
    """OSL camera shader: OpenCV pixel of the raster position -> unprojected ray."""
    params = ", ".join(f"float {n} = 0.0" for n in ("k1", "k2", "k3", "k4", "p1", "p2"))
    return f"""// blender-sesgen lens: {model} (generated; see blender_sesgen/blender/sensor.py)
shader sesgen_lens(float fx = 1.0, float fy = 1.0, float cx = 0.0, float cy = 0.0,
                   float width = 1.0, float height = 1.0, {params},
                   output point position = 0, output vector direction = 0, output color throughput = 1)
{{
    point r = camera_shader_raster_position();
    float px = r[0] * width - 0.5;           // OpenCV pixel (u, v are OSL globals)
    float py = (1.0 - r[1]) * height - 0.5;
    float xd = (px - cx) / fx;
    float yd = (py - cy) / fy;
{_UNDISTORT[model]}
    position = point(0, 0, 0);
    direction = normalize(vector(ray[0], -ray[1], ray[2]));
    throughput = color(1);
}}
"""


BUNDLED_FOR_OSL = ("oslquery", "OpenImageIO")   # what Cycles' OSL query imports by name


class _BundledModules:
    """A finder for the named top-level modules only, in Blender's bundled site-packages."""

    def __init__(self, folder: str, names: tuple):
        self.folder, self.names = folder, names

    def find_spec(self, name, path=None, target=None):
        if path is None and name in self.names:
            import importlib.machinery
            return importlib.machinery.PathFinder.find_spec(name, [self.folder])
        return None


def _ensure_oslquery() -> None:
    """The bpy wheel keeps Blender's bundled modules out of the import path; Cycles imports
    ``oslquery`` (which imports ``OpenImageIO``) to read a custom camera's parameters: those
    two, and nothing else of Blender's bundled site-packages, become importable."""
    import importlib.util
    if importlib.util.find_spec("oslquery") is not None:   # Blender's own Python has it
        return
    base = os.path.join(bpy.utils.resource_path("LOCAL"), "python", "lib")
    d = os.path.join(base, f"python{sys.version_info[0]}.{sys.version_info[1]}", "site-packages")
    if os.path.isdir(d) and not any(isinstance(f, _BundledModules) for f in sys.meta_path):
        sys.meta_path.append(_BundledModules(d, BUNDLED_FOR_OSL))


def apply_lens(cam_data, lens, width: int, height: int) -> None:
    """Make ``cam_data`` a Cycles custom camera that renders through ``lens``
    (a ``contract.lens.Lens`` on the render's K)."""
    if "CUSTOM" not in [e.identifier for e in bpy.types.Camera.bl_rna.properties["type"].enum_items]:
        raise SesgenError(f"LENS distortion needs Cycles' custom cameras (Blender 4.5 or newer); this is "
                          f"Blender {compat.version_string()}")
    _ensure_oslquery()
    name = f"sesgen_lens_{lens.model}.osl"
    text = bpy.data.texts.get(name) or bpy.data.texts.new(name)
    text.from_string(lens_shader_source(lens.model))
    cam_data.type = "CUSTOM"
    cam_data.shift_x = cam_data.shift_y = 0.0     # the shader places the principal point (cx, cy) itself
    cam_data.custom_mode = "INTERNAL"
    cam_data.custom_shader = text                 # compiles the shader and creates its parameters
    props = cam_data.cycles_custom
    if "fx" not in props.keys():
        raise SesgenError("LENS: Cycles could not compile the lens shader (is OSL available in this Blender?)")
    c = dict(zip(("k1", "k2", "p1", "p2", "k3"), lens.coeffs)) if lens.model == "brown" else \
        dict(zip(("k1", "k2", "k3", "k4"), lens.coeffs))
    values = dict(fx=lens.fx, fy=lens.fy, cx=lens.cx, cy=lens.cy, width=float(width), height=float(height), **c)
    for k, v in values.items():
        props[k] = float(v)


def save_jpeg(path: str, rgb8: np.ndarray, quality: int) -> None:
    """Write an 8-bit RGB image as JPEG with Blender's image writer (no colour transform)."""
    H, W = rgb8.shape[:2]
    img = bpy.data.images.new("sesgen_jpeg", W, H, alpha=False, float_buffer=False)
    try:
        img.colorspace_settings.name = "Non-Color"
        px = np.ones((H, W, 4), dtype=np.float32)
        px[..., :3] = rgb8[::-1].astype(np.float32) / 255.0     # Blender rows start at the bottom
        img.pixels.foreach_set(px.ravel())
        img.file_format = "JPEG"
        img.filepath_raw = path
        img.save(filepath=path, quality=int(quality))
    finally:
        bpy.data.images.remove(img)
