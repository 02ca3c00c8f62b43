"""Dataset exports of a render folder: KITTI odometry, KITTI stereo/flow, TUM RGB-D, EuRoC, PNG.

Each target is a function ``export_X(seq, out, opts) -> None`` registered in
:data:`EXPORTERS` (name -> "module:function", imported when used). Adding a target is one
line there, or :func:`register_exporter` at run time. Layouts: docs/output-format.md.

Common rules: frames are renumbered from 0 in the order of ``opts.frames`` (the source
frame of each output frame is recorded in ``export.json``); every file is written
atomically; 8-bit images carry the noise of ``opts.noise`` (sigma, seed), drawn per source
frame, view and kind so that a frame's noise does not depend on the exported range.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.se3 import invert
from blender_sesgen.contract.timing import frame_range
from blender_sesgen.contract.trajectory_files import format_euroc, format_kitti, format_times

from ..errors import VoError, as_vo_error
from ..io.color import rgb8_to_gray8
from ..io.files import write_png16, write_png_rgb
from .disparity import sequence_disparity, write_disparity_png16
from .noise import add_gaussian_noise
from .progress import Progress

# target name -> ("module:function", one-line help)
EXPORTERS: dict[str, tuple[str | Callable, str]] = {
    "kitti-odometry": ("vo_reference.products.exports:export_kitti_odometry",
                       "image_0/1 grey + image_2/3 colour PNGs, calib.txt (P0..P3), poses.txt, times.txt"),
    "kitti-stereo": ("vo_reference.products.exports:export_kitti_stereo",
                     "KITTI 2015 layout: image_2/3 *_10/_11.png, disp_occ_0/disp_noc_0 PNG16, flow_occ/flow_noc"),
    "tum": ("vo_reference.products.exports:export_tum",
            "TUM RGB-D: rgb/ + depth/ (16-bit, 5000 per metre), rgb.txt, depth.txt, groundtruth.txt"),
    "euroc": ("vo_reference.products.exports:export_euroc",
              "EuRoC MAV/ASL: mav0/cam0 (+cam1) data/<t_ns>.png grey, data.csv, sensor.yaml; "
              "state_groundtruth_estimate0/data.csv (left camera = body)"),
    "png": ("vo_reference.products.exports:export_png",
            "per view: noisy 8-bit RGB, ids PNG16 + colour palette, disparity PNG16 (x256)"),
    "bayer": ("vo_reference.products.bayer_export:export_bayer",
              "GBRG Bayer mosaics + distorted images + undistortion LUT (RobotCar-like)"),
    "cityscapes": ("vo_reference.products.semantic_export:export_cityscapes",
                   "Cityscapes layout: leftImg8bit/ + gtFine/ labelIds, color, instanceIds (+ object ids), "
                   "classes.json; right view in rightImg8bit/ + gtFineRight/"),
}

COLOUR, GREY = 0, 1
VIEW_INDEX = {"left": 0, "right": 1}


@dataclass(frozen=True)
class ExportOptions:
    frames: range                          # source frame indices to export
    noise: tuple[float, int] | None = None  # (sigma in 8-bit grey levels, seed) or None
    progress: bool = True
    extra: dict = field(default_factory=dict)  # target-specific KEY=VALUE options (--opt)


def register_exporter(name: str, fn: Callable | str, help_text: str = "") -> None:
    EXPORTERS[name] = (fn, help_text)


def get_exporter(name: str) -> Callable:
    if name not in EXPORTERS:
        raise VoError(f"unknown export target {name!r} (one of: {', '.join(EXPORTERS)})")
    target = EXPORTERS[name][0]
    if callable(target):
        return target
    mod, _, fn = target.partition(":")
    try:
        module = importlib.import_module(mod)
    except ModuleNotFoundError as e:
        if (e.name or "") == mod or mod.startswith(e.name or "\0"):
            raise VoError(f"export target {name!r} is not available (module {mod} is not present)") from None
        raise
    return getattr(module, fn)


def parse_frames(spec: str | None, n: int) -> range:
    """The source frames ``--frames`` selects (``contract.timing``)."""
    with as_vo_error():
        return frame_range(spec, n)


def export(render_dir, target: str, out, *, frames: str | range | None = None,
           noise="manifest", progress: bool = True, extra: dict | None = None) -> Path:
    """Export a render folder. ``noise``: 'manifest' (the script's NOISE, if any), None
    (clean) or (sigma, seed). Returns the output folder."""
    from ..io.render import RenderSequence
    render_dir, out = Path(render_dir), Path(out)
    seq = RenderSequence(render_dir)
    fn = get_exporter(target)
    if out.resolve() == render_dir.resolve() or (render_dir / "exr").resolve() in (out.resolve(), *out.resolve().parents):
        raise VoError(f"{out}: refusing to export into the render folder itself (choose another OUT)")
    rng = frames if isinstance(frames, range) else parse_frames(frames, seq.num_frames)
    missing = [k for k in rng if not seq.frame_complete(k)]
    if missing:
        shown = ", ".join(map(str, missing[:10])) + (" ..." if len(missing) > 10 else "")
        raise VoError(f"{render_dir}: {len(missing)} frame(s) not rendered completely ({shown}); "
                      "finish the render (--resume) or choose --frames")
    nz = seq.noise if noise == "manifest" else noise
    if nz is not None and float(nz[0]) <= 0:
        nz = None
    opts = ExportOptions(frames=rng, noise=None if nz is None else (float(nz[0]), int(nz[1])),
                         progress=progress, extra=dict(extra or {}))
    out.mkdir(parents=True, exist_ok=True)
    fn(seq, out, opts)
    info = {"target": target, "source": str(render_dir.resolve()), "source_frames": list(rng),
            "noise": None if opts.noise is None else {"sigma": opts.noise[0], "seed": opts.noise[1]},
            "format": seq.manifest.get("format"), "scene_sha256": seq.manifest.get("scene_sha256")}
    atomic.write_json(out / "export.json", info)
    return out


# --- images with noise ------------------------------------------------------------------

def image_rgb(seq, k: int, view: str, opts: ExportOptions) -> np.ndarray:
    rgb = seq.image_rgb(k, view)
    if opts.noise is None:
        return rgb
    return add_gaussian_noise(rgb, opts.noise[0], opts.noise[1], (k, VIEW_INDEX[view], COLOUR))


def image_gray(seq, k: int, view: str, opts: ExportOptions) -> np.ndarray:
    g = rgb8_to_gray8(seq.image_rgb(k, view))
    if opts.noise is None:
        return g
    return add_gaussian_noise(g, opts.noise[0], opts.noise[1], (k, VIEW_INDEX[view], GREY))


def kitti_projections(K: np.ndarray, baseline_m: float) -> dict[str, np.ndarray]:
    """P0 = K[I|0], P1 = K[I|(-B,0,0)]; the colour pair P2/P3 is the same rig here."""
    P0 = np.hstack([K, np.zeros((3, 1))])
    P1 = P0.copy()
    P1[:, 3] = K @ np.array([-baseline_m, 0.0, 0.0])
    return {"P0": P0, "P1": P1, "P2": P0.copy(), "P3": P1.copy()}


def _calib_text(seq) -> str:
    P = kitti_projections(seq.K, seq.baseline_m)
    lines = [f"{n}: " + " ".join(f"{x:.12e}" for x in P[n].ravel()) for n in ("P0", "P1", "P2", "P3")]
    lines.append("Tr: " + " ".join(f"{x:.12e}" for x in np.eye(4)[:3].ravel()))  # no lidar: identity
    return "\n".join(lines) + "\n"


# --- targets ----------------------------------------------------------------------------

def export_kitti_odometry(seq, out: Path, opts: ExportOptions) -> None:
    frames = list(opts.frames)
    stereo = "right" in seq.views
    with Progress(len(frames), "kitti-odometry", enabled=opts.progress) as bar:
        for i, k in enumerate(frames):
            name = f"{i:06d}.png"
            write_png_rgb(out / "image_0" / name, image_gray(seq, k, "left", opts))
            write_png_rgb(out / "image_2" / name, image_rgb(seq, k, "left", opts))
            if stereo:
                write_png_rgb(out / "image_1" / name, image_gray(seq, k, "right", opts))
                write_png_rgb(out / "image_3" / name, image_rgb(seq, k, "right", opts))
            bar.update()
    atomic.write_text(out / "calib.txt", _calib_text(seq))
    T = seq.T_world_cam("left")[frames]
    atomic.write_text(out / "poses.txt", format_kitti(invert(T[0]) @ T))
    t = seq.timestamps_s[frames] - seq.timestamps_s[frames[0]]
    atomic.write_text(out / "times.txt", format_times(t))


def export_kitti_stereo(seq, out: Path, opts: ExportOptions) -> None:
    from .flow import sequence_flow, sequence_stereo_occlusion, write_kitti_flow_png
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError("kitti-stereo needs a stereo render (views left and right)")
    frames = list(opts.frames)
    with Progress(len(frames), "kitti-stereo", enabled=opts.progress) as bar:
        for i, k in enumerate(frames):
            n10 = f"{i:06d}_10.png"
            write_png_rgb(out / "image_2" / n10, image_rgb(seq, k, "left", opts))
            write_png_rgb(out / "image_3" / n10, image_rgb(seq, k, "right", opts))
            d = sequence_disparity(seq, k, "left")
            write_disparity_png16(out / "disp_occ_0" / n10, d)
            d_noc = np.where(sequence_stereo_occlusion(seq, k, "left"), np.nan, d)
            write_disparity_png16(out / "disp_noc_0" / n10, d_noc)
            if k + 1 < seq.num_frames and seq.frame_complete(k + 1):
                n11 = f"{i:06d}_11.png"
                write_png_rgb(out / "image_2" / n11, image_rgb(seq, k + 1, "left", opts))
                write_png_rgb(out / "image_3" / n11, image_rgb(seq, k + 1, "right", opts))
                fl = sequence_flow(seq, k, k + 1, "left")
                write_kitti_flow_png(out / "flow_occ" / n10, fl.flow, fl.valid)
                write_kitti_flow_png(out / "flow_noc" / n10, fl.flow, fl.noc)
            bar.update()
    atomic.write_text(out / "calib.txt", _calib_text(seq))


TUM_DEPTH_SCALE = 5000.0  # 16-bit value per metre (TUM RGB-D)


def depth_to_tum_png16(depth: np.ndarray) -> np.ndarray:
    """uint16 round(z·5000); 0 = no depth (inf, or beyond 65535/5000 = 13.1 m)."""
    z = np.asarray(depth, dtype=np.float64)
    v = np.rint(np.where(np.isfinite(z), z, 0.0) * TUM_DEPTH_SCALE)
    v[(v > 65535) | (v < 0) | ~np.isfinite(z)] = 0
    return v.astype(np.uint16)


def export_tum(seq, out: Path, opts: ExportOptions) -> None:
    from ..io.trajectory import Trajectory, write_tum
    frames = list(opts.frames)
    ts = seq.timestamps_s[frames]
    names = [f"{t:.6f}" for t in ts]
    if len(set(names)) != len(names):
        raise VoError("timestamps are not distinct at 1 µs: cannot name TUM files")
    rgb_lines = ["# color images", f"# file: '{out.name}'", "# timestamp filename"]
    depth_lines = ["# depth maps", f"# file: '{out.name}'", "# timestamp filename"]
    assoc = []
    with Progress(len(frames), "tum", enabled=opts.progress) as bar:
        for k, name in zip(frames, names):
            write_png_rgb(out / "rgb" / f"{name}.png", image_rgb(seq, k, "left", opts))
            write_png16(out / "depth" / f"{name}.png", depth_to_tum_png16(seq.depth(k, "left")))
            rgb_lines.append(f"{name} rgb/{name}.png")
            depth_lines.append(f"{name} depth/{name}.png")
            assoc.append(f"{name} rgb/{name}.png {name} depth/{name}.png")
            bar.update()
    atomic.write_text(out / "rgb.txt", "\n".join(rgb_lines) + "\n")
    atomic.write_text(out / "depth.txt", "\n".join(depth_lines) + "\n")
    atomic.write_text(out / "associations.txt", "\n".join(assoc) + "\n")
    write_tum(out / "groundtruth.txt", Trajectory(seq.T_world_cam("left")[frames], ts))
    K = seq.K
    atomic.write_text(out / "camera.txt", "# fx fy cx cy (pixels, OpenCV convention); depth scale 5000 per metre\n"
                      f"{K[0, 0]:.9g} {K[1, 1]:.9g} {K[0, 2]:.9g} {K[1, 2]:.9g}\n")


def export_png(seq, out: Path, opts: ExportOptions) -> None:
    from .segmentation import write_ids_colour, write_ids_png16
    frames = list(opts.frames)
    stereo = "right" in seq.views and seq.baseline_m > 0
    with Progress(len(frames) * len(seq.views), "png", enabled=opts.progress) as bar:
        for i, k in enumerate(frames):
            name = f"{i:06d}.png"
            for view in seq.views:
                write_png_rgb(out / view / "rgb" / name, image_rgb(seq, k, view, opts))
                ids = seq.ids(k, view)
                write_ids_png16(out / view / "ids" / name, ids)
                write_ids_colour(out / view / "ids_colour" / name, ids)
                if stereo:
                    write_disparity_png16(out / view / "disparity" / name, sequence_disparity(seq, k, view))
                bar.update()


# --- EuRoC MAV / ASL --------------------------------------------------------------------

def _yaml_matrix(T: np.ndarray) -> str:
    rows = [", ".join(f"{x:.17g}" for x in r) for r in T]
    return "  cols: 4\n  rows: 4\n  data: [" + ",\n         ".join(rows) + "]\n"


def _euroc_rate_hz(seq) -> float:
    m = seq.manifest
    fps = m.get("fps") or (m.get("render") or {}).get("fps")
    if fps:
        return float(fps)
    dt = np.diff(seq.timestamps_s)
    return float(1.0 / np.median(dt)) if dt.size and np.median(dt) > 0 else 0.0


def euroc_sensor_yaml(seq, cam: int) -> str:
    """EuRoC ``camN/sensor.yaml``: body = left camera, so T_BS = I (cam0), trans(B,0,0) (cam1)."""
    K = seq.K
    W, H = seq.resolution
    T_BS = np.eye(4)
    T_BS[0, 3] = seq.baseline_m if cam == 1 else 0.0
    return ("# General sensor definitions.\n"
            "sensor_type: camera\n"
            f"comment: sesgen render, {'left' if cam == 0 else 'right'} camera (body frame = left camera)\n\n"
            "# Sensor extrinsics wrt. the body-frame.\n"
            "T_BS:\n" + _yaml_matrix(T_BS) + "\n"
            "# Camera specific definitions.\n"
            f"rate_hz: {_euroc_rate_hz(seq):.9g}\n"
            f"resolution: [{int(W)}, {int(H)}]\n"
            "camera_model: pinhole\n"
            f"intrinsics: [{K[0, 0]:.17g}, {K[1, 1]:.17g}, {K[0, 2]:.17g}, {K[1, 2]:.17g}] #fu, fv, cu, cv\n"
            "distortion_model: radial-tangential\n"
            "distortion_coefficients: [0.0, 0.0, 0.0, 0.0]\n")


def export_euroc(seq, out: Path, opts: ExportOptions) -> None:
    frames = list(opts.frames)
    ts = seq.timestamps_s[frames]
    t_ns = np.rint(ts * 1e9).astype(np.int64)
    if np.any(t_ns < 0):
        raise VoError("euroc: timestamps must be >= 0 to name the files in ns")
    if len(set(t_ns.tolist())) != len(t_ns):
        raise VoError("timestamps are not distinct at 1 ns: cannot name EuRoC files")
    cams = [("cam0", "left")] + ([("cam1", "right")] if "right" in seq.views and seq.baseline_m > 0 else [])
    mav = out / "mav0"
    rows = {cam: ["#timestamp [ns],filename"] for cam, _ in cams}
    with Progress(len(frames) * len(cams), "euroc", enabled=opts.progress) as bar:
        for k, tn in zip(frames, t_ns):
            name = f"{int(tn)}.png"
            for cam, view in cams:
                write_png_rgb(mav / cam / "data" / name, image_gray(seq, k, view, opts))
                rows[cam].append(f"{int(tn)},{name}")
                bar.update()
    for i, (cam, _) in enumerate(cams):
        atomic.write_text(mav / cam / "data.csv", "\n".join(rows[cam]) + "\n")
        atomic.write_text(mav / cam / "sensor.yaml", euroc_sensor_yaml(seq, i))
    gt = mav / "state_groundtruth_estimate0"
    atomic.write_text(gt / "data.csv", format_euroc(t_ns, seq.T_world_cam("left")[frames]))
    atomic.write_text(gt / "sensor.yaml",
                      "# General sensor definitions.\nsensor_type: visual-inertial\n"
                      "comment: sesgen ground truth; body frame = left camera (cam0), R = the SES world\n\n"
                      "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n" + _yaml_matrix(np.eye(4)))
