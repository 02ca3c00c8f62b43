"""Dataset exports of a render folder: KITTI odometry, KITTI stereo/flow, TUM RGB-D, EuRoC,
PNG, Bayer, TartanAir, Virtual KITTI 2, SceneFlow.

Each target is a function ``export_X(seq, out, opts)`` registered in :data:`EXPORTERS`
(name -> "module:function", imported when used). Adding a target is one line there, or
:func:`register_exporter` at run time. Layouts: docs/output-format.md. A target whose
layout is a tree of several sequences sets ``export_X.takes_sequence = True``, reads its
slot from ``opts.sequence`` (``--sequence``) and returns the sequence's folder, where
``export.json`` then goes (otherwise it goes into ``out``).

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
from blender_sesgen.contract.timing import frame_range
from blender_sesgen.contract.progress import MODES as PROGRESS_MODES
from blender_sesgen.contract.progress import Progress
from blender_sesgen.contract.trajectory_files import format_euroc
from blender_sesgen.contract.se3 import invert

from ..errors import VoError, as_vo_error
from ..io.color import rgb8_to_gray8
from ..io.files import write_png16, write_png_rgb
from .disparity import sequence_disparity, write_disparity_png16
from .noise import add_gaussian_noise

__all__ = ["EXPORTERS", "ExportOptions", "export", "register_exporter", "get_exporter", "parse_frames",
           "sequence_folder", "check_replaceable", "progress_bar", "image_rgb", "image_gray"]

# target name -> ("module:function", one-line help)
EXPORTERS: dict[str, tuple[str | Callable, str]] = {
    "kitti-odometry": ("vo_reference.products.kitti_odometry:export_kitti_odometry",
                       "KITTI odometry devkit tree: dataset/sequences/NN/image_0..3, calib.txt, times.txt + "
                       "dataset/poses/NN.txt (--sequence NN, default 00)"),
    "kitti-folder": ("vo_reference.products.kitti_odometry:export_kitti_folder",
                     "one KITTI sequence folder: image_0..3/, calib.txt, times.txt, poses.txt"),
    "kitti-stereo": ("vo_reference.products.exports:export_kitti_stereo",
                     "KITTI 2015 layout: image_2/3 *_10/_11.png, disp_occ_0/disp_noc_0 PNG16, flow_occ/flow_noc"),
    "tum": ("vo_reference.products.exports:export_tum",
            "TUM RGB-D: rgb/ + depth/ (16-bit, 5000 per metre), rgb.txt, depth.txt, groundtruth.txt"),
    "euroc": ("vo_reference.products.exports:export_euroc",
              "EuRoC MAV/ASL: mav0/cam0 (+cam1) data/<t_ns>.png grey, data.csv, sensor.yaml; "
              "state_groundtruth_estimate0/data.csv (body = left camera, or the IMU + imu0/ with an IMU)"),
    "png": ("vo_reference.products.exports:export_png",
            "per view: noisy 8-bit RGB, ids PNG16 + colour palette, disparity PNG16 (x256)"),
    "bayer": ("vo_reference.products.bayer_export:export_bayer",
              "GBRG Bayer mosaics + distorted images + undistortion LUT (RobotCar-like)"),
    "tartanair": ("vo_reference.products.tartanair:export_tartanair",
                  "TartanAir: image_left/right PNG, depth_left/right .npy (m), seg_left/right .npy, "
                  "flow/ *_flow.npy + *_mask.npy, pose_left/right.txt (NED)"),
    "vkitti2": ("vo_reference.products.vkitti2:export_vkitti2",
                "Virtual KITTI 2: frames/{rgb,depth,classSegmentation,instanceSegmentation,forwardFlow,"
                "backwardFlow}/Camera_0|1, intrinsic.txt, extrinsic.txt, pose.txt, colors.txt"),
    "sceneflow": ("vo_reference.products.sceneflow:export_sceneflow",
                  "SceneFlow / FlyingThings3D: frames_cleanpass, disparity (PFM, both views), "
                  "optical_flow and disparity_change into_future/into_past (--sequence TRAIN/A/0000)"),
    "rosbag": ("vo_reference.products.rosbag_export:export_rosbag",
               "ROS 2 bag (mcap): cam0/cam1 Image + CameraInfo, imu0 Imu, tf + PoseStamped ground truth"),
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
    progress: str = "auto"                 # progress mode (blender_sesgen.contract.progress.MODES)
    extra: dict = field(default_factory=dict)  # target-specific KEY=VALUE options (--opt)
    sequence: str | None = None            # the render's slot in a multi-sequence dataset tree (--sequence)
    progress_callback: Callable | None = None  # receives every progress event (a dict)


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
           noise="manifest", progress: bool | str = "auto", extra: dict | None = None,
           sequence: str | None = None, progress_callback: Callable | None = None) -> Path:
    """Export a render folder. ``noise``: 'manifest' (the script's NOISE, if any), None
    (clean) or (sigma, seed); ``sequence``: the slot in a dataset tree, for the targets that
    have one (kitti-odometry, tartanair, vkitti2, sceneflow); ``progress``: a mode of
    :mod:`blender_sesgen.contract.progress` (True = 'auto', False = 'off') and
    ``progress_callback(event)`` a hook for every progress event. Returns the folder that
    holds the export (``out``, or the sequence's folder inside it) with its ``export.json``."""
    from ..io.render import RenderSequence
    render_dir, out = Path(render_dir), Path(out)
    seq = RenderSequence(render_dir)
    fn = get_exporter(target)
    if sequence is not None and not getattr(fn, "takes_sequence", False):
        raise VoError(f"--sequence does not apply to the {target} layout")
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
    mode = ("auto" if progress else "off") if isinstance(progress, bool) else str(progress)
    if mode not in PROGRESS_MODES:
        raise VoError(f"progress {progress!r}: expected one of {', '.join(PROGRESS_MODES)}")
    opts = ExportOptions(frames=rng, noise=None if nz is None else (float(nz[0]), int(nz[1])),
                         progress=mode, extra=dict(extra or {}), sequence=sequence,
                         progress_callback=progress_callback)
    out.mkdir(parents=True, exist_ok=True)
    where = Path(fn(seq, out, opts) or out)
    info = {"target": target, "source": str(render_dir.resolve()), "source_frames": list(rng),
            "sequence": sequence,
            "noise": None if opts.noise is None else {"sigma": opts.noise[0], "seed": opts.noise[1]},
            "format": seq.manifest.get("format"), "scene_sha256": seq.manifest.get("scene_sha256")}
    atomic.write_json(where / "export.json", info)
    return where


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


def check_replaceable(folder: Path) -> None:
    """A sequence folder an export may replace: absent, empty, or written by an export
    (it has ``export.json``). Anything else -- real data, say -- is never replaced."""
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir()
                            or (any(folder.iterdir()) and not (folder / "export.json").is_file())):
        raise VoError(f"{folder}: exists and is not an export of ours (no export.json); "
                      "choose another --sequence or OUT")


def sequence_folder(out: Path, sequence: str | None, default: str | None = None, check: bool = True) -> Path:
    """``OUT/<sequence>`` (``--sequence``: a relative path without '..'; ``default`` when not
    given; ``OUT`` itself when both are None), checked with :func:`check_replaceable`."""
    rel = sequence if sequence is not None else default
    folder = Path(out).resolve()
    if rel is not None:
        parts = Path(str(rel).strip()).parts
        if not parts or Path(str(rel)).is_absolute() or any(p in ("..", ".") for p in parts):
            raise VoError(f"--sequence {rel!r}: expected a relative path inside OUT (no '..')")
        folder = folder.joinpath(*parts)
    if check:
        check_replaceable(folder)
    return folder


def progress_bar(opts: ExportOptions, total: int, label: str) -> Progress:
    """The progress reporter of one export (a context manager with ``update()``)."""
    return Progress(total, f"export {label}", mode=opts.progress, callback=opts.progress_callback)


def kitti_projections(K: np.ndarray, baseline_m: float) -> dict[str, np.ndarray]:
    """P0 = K[I|0], P1 = K[I|(-B,0,0)]; the colour pair P2/P3 is the same rig here."""
    P0 = np.hstack([K, np.zeros((3, 1))])
    P1 = P0.copy()
    P1[:, 3] = K @ np.array([-baseline_m, 0.0, 0.0])
    return {"P0": P0, "P1": P1, "P2": P0.copy(), "P3": P1.copy()}


def calib_text(seq) -> str:
    P = kitti_projections(seq.K, seq.baseline_m)
    lines = [f"{n}: " + " ".join(f"{x:.12e}" for x in P[n].ravel()) for n in ("P0", "P1", "P2", "P3")]
    lines.append("Tr: " + " ".join(f"{x:.12e}" for x in np.eye(4)[:3].ravel()))  # no lidar: identity
    return "\n".join(lines) + "\n"


# --- targets ----------------------------------------------------------------------------

def export_kitti_stereo(seq, out: Path, opts: ExportOptions) -> None:
    from .flow import sequence_flow, sequence_stereo_occlusion, write_kitti_flow_png
    if "right" not in seq.views or seq.baseline_m <= 0:
        raise VoError("kitti-stereo needs a stereo render (views left and right)")
    frames = list(opts.frames)
    with progress_bar(opts, len(frames), "kitti-stereo") as bar:
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
    atomic.write_text(out / "calib.txt", calib_text(seq))


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
    with progress_bar(opts, len(frames), "tum") as bar:
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
    with progress_bar(opts, len(frames) * len(seq.views), "png") as bar:
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


def euroc_T_body_cam(seq, cam: int) -> np.ndarray:
    """Camera ``cam``'s pose in the EuRoC body frame: the IMU where the render has one
    (T_imu_cam = inv(T_cam_imu), right camera trans(B, 0, 0) further), else the left camera."""
    T_cam_left = np.eye(4)
    T_cam_left[0, 3] = seq.baseline_m if cam == 1 else 0.0
    imu = seq.manifest.get("imu") if hasattr(seq, "manifest") else None
    if not imu:
        return T_cam_left
    return invert(np.array(imu["T_cam_imu"], dtype=float)) @ T_cam_left


def _euroc_distortion(seq) -> tuple[str, list]:
    lens = getattr(seq, "lens", None)
    if lens is None:
        return "radial-tangential", [0.0, 0.0, 0.0, 0.0]
    if lens.model == "kannala_brandt":
        return "equidistant", list(lens.coeffs)
    k1, k2, p1, p2, k3 = lens.coeffs
    if k3:
        raise VoError("euroc: the EuRoC/Kalibr radial-tangential model has k1 k2 p1 p2 only; this lens has k3 != 0")
    return "radial-tangential", [k1, k2, p1, p2]


def euroc_sensor_yaml(seq, cam: int) -> str:
    """EuRoC ``camN/sensor.yaml``: T_BS (camera in the body frame), intrinsics, distortion,
    and for a rolling shutter its readout time (the per-row offsets are in row_offsets.csv)."""
    K = seq.K
    W, H = seq.resolution
    model, coeffs = _euroc_distortion(seq)
    body = "the IMU" if (getattr(seq, "manifest", None) or {}).get("imu") else "the left camera"
    readout = float(getattr(seq, "readout_s", 0.0) or 0.0)
    rs = (f"rolling_shutter_readout_s: {readout:.9g}   # rows read top to bottom, see row_offsets.csv\n"
          if readout > 0 else "")
    return ("# General sensor definitions.\n"
            "sensor_type: camera\n"
            f"comment: sesgen render, {'left' if cam == 0 else 'right'} camera (body frame = {body})\n\n"
            "# Sensor extrinsics wrt. the body-frame.\n"
            "T_BS:\n" + _yaml_matrix(euroc_T_body_cam(seq, cam)) + "\n"
            "# Camera specific definitions.\n"
            f"rate_hz: {_euroc_rate_hz(seq):.9g}\n"
            f"resolution: [{int(W)}, {int(H)}]\n"
            "camera_model: pinhole\n"
            f"intrinsics: [{K[0, 0]:.17g}, {K[1, 1]:.17g}, {K[0, 2]:.17g}, {K[1, 2]:.17g}] #fu, fv, cu, cv\n"
            f"distortion_model: {model}\n"
            f"distortion_coefficients: [{', '.join(f'{c:.17g}' for c in coeffs)}]\n" + rs)


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
    with progress_bar(opts, len(frames) * len(cams), "euroc") as bar:
        for k, tn in zip(frames, t_ns):
            name = f"{int(tn)}.png"
            for cam, view in cams:
                write_png_rgb(mav / cam / "data" / name, image_gray(seq, k, view, opts))
                rows[cam].append(f"{int(tn)},{name}")
                bar.update()
    for i, (cam, _) in enumerate(cams):
        atomic.write_text(mav / cam / "data.csv", "\n".join(rows[cam]) + "\n")
        atomic.write_text(mav / cam / "sensor.yaml", euroc_sensor_yaml(seq, i))
        readout = float(getattr(seq, "readout_s", 0.0) or 0.0)
        if readout > 0:
            from blender_sesgen.contract.timing import row_offsets_s, to_ns
            off = to_ns(row_offsets_s(seq.resolution[1], readout))
            atomic.write_text(mav / cam / "row_offsets.csv", "#row,offset [ns] (capture time of the row - frame stamp)\n"
                              + "".join(f"{r},{int(o)}\n" for r, o in enumerate(off)))
    gt = mav / "state_groundtruth_estimate0"
    imu = (getattr(seq, "manifest", None) or {}).get("imu")
    if imu:
        _export_euroc_imu(seq, mav, ts)
        body = "the IMU (imu0)"
    else:
        atomic.write_text(gt / "data.csv", format_euroc(t_ns, seq.T_world_cam("left")[frames]))
        body = "left camera (cam0)"
    atomic.write_text(gt / "sensor.yaml",
                      "# General sensor definitions.\nsensor_type: visual-inertial\n"
                      f"comment: sesgen ground truth; body frame = {body}, R = the SES world\n\n"
                      "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n" + _yaml_matrix(np.eye(4)))


def _export_euroc_imu(seq, mav: Path, ts: np.ndarray) -> None:
    """imu0/data.csv + sensor.yaml (the noisy stream) and the body ground truth at the IMU's
    instants, both cut to the exported frames' time span."""
    entry = seq.manifest["imu"]
    t0, t1 = float(ts[0]), float(ts[-1])
    off = float(entry.get("time_offset_s", 0.0))

    def cut(rel: str, shift: float) -> str:
        lines = (seq.root / rel).read_text(encoding="utf-8").splitlines()
        keep = [ln for ln in lines[1:] if ln and t0 - 1e-9 <= int(ln.split(",")[0]) * 1e-9 - shift <= t1 + 1e-9]
        return "\n".join([lines[0]] + keep) + "\n"
    atomic.write_text(mav / "imu0" / "data.csv", cut(entry["files"]["noisy"], off))
    atomic.write_text(mav / "imu0" / "sensor.yaml", (seq.root / entry["files"]["yaml"]).read_text(encoding="utf-8"))
    atomic.write_text(mav / "state_groundtruth_estimate0" / "data.csv", cut(entry["files"]["groundtruth"], 0.0))
