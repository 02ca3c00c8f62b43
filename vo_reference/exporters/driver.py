"""Dataset exports of a render folder: KITTI odometry, KITTI stereo/flow, TUM RGB-D, EuRoC,
PNG, Bayer, TartanAir (V1, V2), Virtual KITTI 2, SceneFlow, COLMAP, nerfstudio, SLAM/VIO
settings, Middlebury 2014, ETH3D, MPI-Sintel.

Each target is a function ``export_X(seq, out, opts)`` registered in :data:`EXPORTERS`
(name -> "module:function", imported when used). Adding a target is one line there, or
:func:`register_exporter` at run time. Layouts: docs/output-format.md. A target whose
layout is a tree of several sequences sets ``export_X.takes_sequence = True``, reads its
slot from ``opts.sequence`` (``--sequence``) and returns the sequence's folder, where
``export.json`` then goes (otherwise it goes into ``out``).

Common rules: frames are renumbered from 0 in the order of ``opts.frames`` (the source
frame of each output frame is recorded in ``export.json``); 8-bit images carry the noise of
``opts.noise`` (sigma, seed), drawn per source frame, view and kind so that a frame's noise
does not depend on the exported range.

Every export is a transaction (``contract.atomic.Transaction``), here for every layout: the
exporter writes into a stage that mirrors OUT, never into OUT; then what it staged becomes
visible at once -- OUT whole for a one-folder layout; in a tree, its *units*, every staged
folder at the slot's depth and every file above it (:func:`staged_units`: kitti-odometry's
``sequences/NN`` with ``poses/NN.txt``, SceneFlow's four ``<kind>/<slot>`` folders). A
failure or Ctrl-C leaves the earlier export or nothing, never a mix or a temporary folder
(a ``kill -9`` leaves one that the next export into OUT completes or removes). A place is
replaced only if it is empty or holds what an earlier export listed in its ``export.json``
(``owns``: slot, units, files): an export never deletes anything that is not its own. A
full disk is one line (exit 1), the stage removed.
"""
from __future__ import annotations

import importlib
import json
import os
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract import rig
from blender_sesgen.contract.cli import SYSTEM_ERRNOS
from blender_sesgen.contract.timing import frame_range
from blender_sesgen.contract.progress import MODES as PROGRESS_MODES
from blender_sesgen.contract.progress import Progress

from ..errors import VoError, as_vo_error
from ..io.color import rgb8_to_gray8
from ..io.sequence import require_complete
from ..groundtruth.noise import add_gaussian_noise
from ..groundtruth.options import pop_number

__all__ = ["EXPORTERS", "ExportOptions", "export", "register_exporter", "get_exporter", "parse_frames",
           "sequence_folder", "check_replaceable", "progress_bar", "refuse_options", "image_rgb", "image_gray",
           "pop_number"]

# target name -> ("module:function", one-line help)
EXPORTERS: dict[str, tuple[str | Callable, str]] = {
    "kitti-odometry": ("vo_reference.exporters.kitti_odometry:export_kitti_odometry",
                       "KITTI odometry devkit tree: dataset/sequences/NN/image_0..3, calib.txt, times.txt + "
                       "dataset/poses/NN.txt (--sequence NN, default 00)"),
    "kitti-folder": ("vo_reference.exporters.kitti_odometry:export_kitti_folder",
                     "one KITTI sequence folder: image_0..3/, calib.txt, times.txt, poses.txt"),
    "kitti-stereo": ("vo_reference.exporters.kitti_stereo:export_kitti_stereo",
                     "KITTI 2015 layout: image_2/3 *_10/_11.png, disp_occ_0/disp_noc_0 PNG16, flow_occ/flow_noc"),
    "kitti-sceneflow": ("vo_reference.exporters.kitti_sceneflow:export_kitti_sceneflow",
                        "KITTI scene flow 2015: image_2/3 *_10/_11, disp_occ/noc_0/1, flow_occ/noc, obj_map, "
                        "+ instance_map, motion_mask (moving objects exact)"),
    "tum": ("vo_reference.exporters.tum:export_tum",
            "TUM RGB-D: rgb/ + depth/ (16-bit, 5000 per metre), rgb.txt, depth.txt, groundtruth.txt"),
    "euroc": ("vo_reference.exporters.euroc:export_euroc",
              "EuRoC MAV/ASL: mav0/cam0 (+cam1) data/<t_ns>.png grey, data.csv, sensor.yaml; "
              "state_groundtruth_estimate0/data.csv (body = left camera, or the IMU + imu0/ with an IMU)"),
    "png": ("vo_reference.exporters.png:export_png",
            "per view: noisy 8-bit RGB, ids PNG16 + colour palette, disparity PNG16 (x256)"),
    "bayer": ("vo_reference.exporters.bayer:export_bayer",
              "GBRG Bayer mosaics + distorted images + undistortion LUT (RobotCar-like)"),
    "tartanair": ("vo_reference.exporters.tartanair:export_tartanair",
                  "TartanAir: image_left/right PNG, depth_left/right .npy (m), seg_left/right .npy, "
                  "flow/ *_flow.npy + *_mask.npy, pose_left/right.txt (NED)"),
    "vkitti2": ("vo_reference.exporters.vkitti2:export_vkitti2",
                "Virtual KITTI 2: frames/{rgb,depth,classSegmentation,instanceSegmentation,forwardFlow,"
                "backwardFlow}/Camera_0|1, intrinsic.txt, extrinsic.txt, pose.txt, colors.txt"),
    "sceneflow": ("vo_reference.exporters.sceneflow_datasets:export_sceneflow",
                  "SceneFlow / FlyingThings3D: frames_cleanpass, disparity (PFM, both views), "
                  "optical_flow and disparity_change into_future/into_past (--sequence TRAIN/A/0000)"),
    "rosbag": ("vo_reference.exporters.rosbag:export_rosbag",
               "ROS 2 bag (mcap): cam0/cam1 Image + CameraInfo, imu0 Imu, tf + PoseStamped ground truth"),
    "cityscapes": ("vo_reference.exporters.cityscapes:export_cityscapes",
                   "Cityscapes layout: leftImg8bit/ + gtFine/ labelIds, color, instanceIds (+ object ids), "
                   "classes.json; right view in rightImg8bit/ + gtFineRight/"),
    "colmap": ("vo_reference.exporters.colmap:export_colmap",
               "COLMAP text model: images/ + sparse/0/{cameras,images,points3D,rigs,frames}.txt, points from "
               "the exact depth with their observations in every image that sees them"),
    "nerfstudio": ("vo_reference.exporters.nerfstudio:export_nerfstudio",
                   "nerfstudio / 3D Gaussian Splatting: transforms.json (OpenGL camera-to-world), images/, "
                   "depths/ (16-bit mm), masks/, sparse_pc.ply"),
    "slam": ("vo_reference.exporters.slam_config:export_slam_config",
             "SLAM/VIO settings of the rig: ORB-SLAM3, VINS-Fusion, OpenVINS, Kalibr, Basalt (also written "
             "beside the euroc and rosbag exports, in slam/)"),
    "tartanair-v2": ("vo_reference.exporters.tartanair_v2:export_tartanair_v2",
                     "TartanAir V2: ENV/Data_easy/P000/image_lcam_front, depth_* (RGBA-packed float PNG), "
                     "seg_*, flow_lcam_front, pose_*.txt (NED) (--sequence ENV/Data_DIFF/PNNN)"),
    "middlebury": ("vo_reference.exporters.middlebury:export_middlebury",
                   "Middlebury 2014 stereo: one folder per frame with im0.png, im1.png, disp0.pfm, disp1.pfm, "
                   "mask0nocc.png, calib.txt"),
    "eth3d": ("vo_reference.exporters.middlebury:export_eth3d",
              "ETH3D two-view stereo: two_view_training/NAME/{im0,im1}.png, calib.txt, cameras.txt, images.txt "
              "+ two_view_training_gt/NAME/disp0GT.pfm, mask0nocc.png"),
    "sintel": ("vo_reference.exporters.sintel:export_sintel",
               "MPI-Sintel: training/{clean,final}/SCENE/frame_NNNN.png, flow/ .flo, occlusions/, invalid/, "
               "depth/ .dpt, camdata_left/ .cam (--sequence SCENE)"),
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
    undistort: bool = False                # a lens render is exported through a pinhole camera (--undistort)


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


def _require_neighbours(seq, rng: range, target: str, fn) -> None:
    """VoError naming the frames a layout reads beside the selected ones (``fn.reads_neighbours``:
    offsets, e.g. (1,) for frame k's pair or flow to frame k+1) that a render is writing now
    (not complete, within a live writer's lock: ``contract.writers``). A neighbour the render
    did not render (a shorter ``--frames`` range, a render stopped) is the sequence's end for
    the layout (no pair, NaN flow: docs/output-format.md); one being written would come out so
    too, and the export would differ from the one made minutes later, silently."""
    from blender_sesgen.contract.writers import live_locks
    chosen = set(rng)
    near = sorted({k + d for k in rng for d in getattr(fn, "reads_neighbours", ())} - chosen)
    missing = [j for j in near if 0 <= j < seq.num_frames and not seq.frame_complete(j)]
    if not missing or seq.root is None:
        return
    for lock in live_locks(seq.root):
        first, last = lock["frames"]
        held = [j for j in missing if first <= j <= last]
        if held:
            raise VoError(f"{seq.root}: frame(s) {', '.join(map(str, held[:10]))} beside the selected ones are being "
                          f"rendered (pid {lock.get('pid')} on {lock.get('host')}, frames {first}..{last}); the "
                          f"{target} layout reads them (pairs and flow across the selection's ends): wait for the "
                          "render to finish, or choose --frames whose neighbours are rendered")


def export(render_dir, target: str, out, *, frames: str | range | None = None,
           noise="manifest", progress: bool | str = "auto", extra: dict | None = None,
           sequence: str | None = None, progress_callback: Callable | None = None,
           undistort: bool = False) -> Path:
    """Export a render folder. ``noise``: 'manifest' (the script's NOISE, if any), None
    (clean) or (sigma, seed); ``sequence``: the slot in a dataset tree, for the targets that
    have one (kitti-odometry, tartanair, tartanair-v2, vkitti2, sceneflow, sintel); ``progress``: a mode of
    :mod:`blender_sesgen.contract.progress` (True = 'auto', False = 'off') and
    ``progress_callback(event)`` a hook for every progress event; ``undistort``: a render
    with a distorting lens is written through a pinhole camera (:mod:`.undistorted`) —
    without it, a layout that has no lens model (``fn.keeps_lens`` unset) refuses such a
    render. Returns the folder that holds the export (``out``, or the sequence's folder
    inside it) with its ``export.json``."""
    from ..io.render import RenderSequence
    render_dir, out = Path(render_dir), Path(out)
    seq = RenderSequence(render_dir)
    fn = get_exporter(target)
    if sequence is not None and not getattr(fn, "takes_sequence", False):
        raise VoError(f"--sequence does not apply to the {target} layout")
    rng = frames if isinstance(frames, range) else parse_frames(frames, seq.num_frames)
    require_complete(seq, rng)
    _require_neighbours(seq, rng, target, fn)
    lens = seq.lens
    seq = _camera_of_the_layout(seq, target, fn, undistort)
    nz = seq.noise if noise == "manifest" else noise
    if nz is not None and float(nz[0]) <= 0:
        nz = None
    mode = ("auto" if progress else "off") if isinstance(progress, bool) else str(progress)
    if mode not in PROGRESS_MODES:
        raise VoError(f"progress {progress!r}: expected one of {', '.join(PROGRESS_MODES)}")
    opts = ExportOptions(frames=rng, noise=None if nz is None else (float(nz[0]), int(nz[1])),
                         progress=mode, extra=dict(extra or {}), sequence=sequence,
                         progress_callback=progress_callback, undistort=seq.lens is None and lens is not None)
    info = {"target": target, "source": str(render_dir.resolve()), "source_frames": list(rng),
            "sequence": sequence,
            "noise": None if opts.noise is None else {"sigma": opts.noise[0], "seed": opts.noise[1]},
            **{"format": None, "scene_sha256": None, **seq.provenance()}}
    if opts.undistort:   # what the pinhole camera of the export is
        info["undistorted"] = {"K": np.asarray(seq.K).tolist(), "lens": lens.to_json()}
    tree = bool(getattr(fn, "takes_sequence", False))
    _refuse_overlap(render_dir, out, tree)
    # the export is staged in a transaction (contract.atomic) and made visible at once
    with _disk_errors(out), atomic.transaction(out) as tx:
        if not tree:   # OUT is replaced whole: say so before the work, not after it
            _check_ours(out, ".", ".", out, render_dir)
        where = Path(fn(seq, tx.stage, opts) or tx.stage) if tree else (fn(seq, tx.stage, opts), tx.stage)[1]
        slot = _relative(where, tx.stage)
        units = staged_units(tx.stage, slot)
        files = {_relative(p, tx.stage) for u in units for p in _files_under(atomic.unit_path(tx.stage, u))}
        files.add(_relative(where / EXPORT_JSON, tx.stage))
        info["owns"] = {"slot": slot, "units": units, "files": sorted(files)}
        atomic.write_json(where / EXPORT_JSON, info)
        tx.commit(units, last=slot, check=lambda unit, dest: _check_ours(out, slot, unit, dest, render_dir))
    return atomic.unit_path(out, slot)


EXPORT_JSON = "export.json"


def _relative(path: Path, root: Path) -> str:
    rel = Path(os.path.abspath(path)).relative_to(os.path.abspath(root)).as_posix()
    return rel if rel not in ("", ".") else "."


def _files_under(path: Path):
    """Every file (or symbolic link) at or under ``path``."""
    if path.is_symlink() or not path.is_dir():
        yield path
        return
    for dirpath, dirnames, filenames in os.walk(path):
        for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
            yield Path(dirpath) / name


def staged_units(stage: Path, slot: str) -> list[str]:
    """What an export replaces whole, relative to OUT: OUT itself for a one-folder layout
    (slot ``.``); in a tree, every staged folder at the slot's depth and every staged file
    above it -- ``dataset/sequences/00`` and ``dataset/poses/00.txt`` for kitti-odometry,
    ``<kind>/TRAIN/A/0000`` for each of SceneFlow's four kinds -- so that the folders they
    share with other sequences (``dataset/``, ``poses/``) are never replaced."""
    depth = 0 if slot == "." else len(slot.split("/"))
    if depth == 0:
        return ["."]
    units, level = [], [(stage, "")]
    for d in range(1, depth + 1):
        deeper = []
        for folder, rel in level:
            for entry in sorted(os.scandir(folder), key=lambda e: e.name):
                name = f"{rel}/{entry.name}" if rel else entry.name
                if entry.is_dir(follow_symlinks=False) and d < depth:
                    deeper.append((Path(entry.path), name))
                else:
                    units.append(name)
        level = deeper
    return units


def _refuse_overlap(render_dir: Path, out: Path, tree: bool) -> None:
    """OUT may not lie in the render folder; a one-folder export (OUT replaced whole) may not
    hold the render either (a tree export may: only its slot is replaced)."""
    src, dst = render_dir.resolve(), out.resolve()
    if dst == src or src in dst.parents:
        raise VoError(f"{out}: refusing to export into the render folder itself (choose another OUT)")
    if not tree and dst in src.parents:
        raise VoError(f"{out}: holds the render folder {render_dir}, and an export replaces OUT whole; "
                      "choose another OUT")


def _check_ours(out: Path, slot: str, unit: str, dest: Path, render_dir: Path) -> None:
    """Refuse to replace ``dest`` (the place of ``unit``) unless it is empty or an earlier
    export of ours wrote every file in it (the ``owns`` of its ``export.json``, at the same
    slot); an export never deletes anything else -- real data, the user's notes, a render.
    (An ``export.json`` written before exports listed their files vouches for its slot,
    unless a render folder lies inside.)"""
    if not os.path.lexists(dest):
        return
    src = render_dir.resolve()
    if not dest.is_symlink() and dest.resolve() in (src, *src.parents):
        raise VoError(f"{dest}: holds the render folder {render_dir}, and the export would replace it; "
                      "choose another OUT")
    if dest.is_dir() and not dest.is_symlink() and not any(dest.iterdir()):
        return
    record = atomic.unit_path(out, slot) / EXPORT_JSON
    fix = "move it away, or choose another OUT or --sequence"
    try:
        info = json.loads(record.read_text(encoding="utf-8")) if record.is_file() else None
    except (OSError, ValueError):
        info = None
    if not isinstance(info, dict):
        raise VoError(f"{dest}: exists and is not an export of ours (no readable {EXPORT_JSON} in "
                      f"{record.parent}); {fix}")
    owns = info.get("owns")
    listed = set(owns.get("files") or []) | {_relative(record, out)} if isinstance(owns, dict) else None
    if listed is not None and unit not in (owns.get("units") or []):
        raise VoError(f"{dest}: not written by the export recorded in {record}; {fix}")
    for path in _files_under(dest):
        rel = _relative(path, out)
        if (rel not in listed) if listed is not None else path.name == "manifest.json":
            raise VoError(f"{out}: holds {rel}, which no export of ours wrote (an export never deletes what "
                          f"is not its own); {fix}")


@contextmanager
def _disk_errors(out: Path):
    """A write that fails for want of space (or rights) is one line naming the file: the
    transaction has removed what it had staged, OUT is as it was."""
    try:
        yield
    except OSError as e:
        if e.errno not in SYSTEM_ERRNOS:
            raise
        where = f" ({e.filename})" if e.filename else ""
        raise OSError(e.errno, f"{e.strerror}{where}; the export was abandoned, {out} is as it was",
                      f"export to {out}") from None


def _camera_of_the_layout(seq, target: str, fn: Callable, undistort: bool):
    """The sequence a layout is written from: a pinhole render as it is; a render with a
    distorting lens as it is when the layout keeps the lens (``fn.keeps_lens``), through a
    pinhole camera with ``undistort``, else refused (VoError: exit 2 at the CLI)."""
    lens = seq.lens
    if lens is None or lens.is_pinhole:
        return seq
    if undistort:
        from .undistorted import UndistortedSequence
        return UndistortedSequence(seq)
    if not getattr(fn, "keeps_lens", False):
        raise VoError(f"{target}: the render has a {lens.model} lens and the {target} layout has no lens model; "
                      "export with --undistort (pinhole images and ground truth)")
    return seq


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
    """VoError unless ``folder`` is absent, empty, or holds an ``export.json``. Exporters
    write into the driver's stage, where this always holds; what decides whether the real
    place may be replaced is the driver's check at commit (:func:`export`)."""
    folder = Path(folder)
    if folder.exists() and (not folder.is_dir()
                            or (any(folder.iterdir()) and not (folder / "export.json").is_file())):
        raise VoError(f"{folder}: exists and is not an export of ours (no export.json); "
                      "choose another --sequence or OUT")


def sequence_folder(out: Path, sequence: str | None, default: str | None = None, check: bool = True) -> Path:
    """``OUT/<sequence>`` (``--sequence``: a relative path without '..'; ``default`` when not
    given; ``OUT`` itself when both are None), checked with :func:`check_replaceable` (within
    the stage: see there)."""
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


def refuse_options(opts: ExportOptions, target: str) -> None:
    """VoError for a layout that takes no ``--opt``: an option it would ignore (a typo, an
    option of another layout) must not give an export other than the one asked for."""
    if opts.extra:
        raise VoError(f"{target} export: unknown option(s) {', '.join(sorted(opts.extra))} (it takes none)")


def progress_bar(opts: ExportOptions, total: int, label: str) -> Progress:
    """The progress reporter of one export (a context manager with ``update()``)."""
    return Progress(total, f"export {label}", mode=opts.progress, callback=opts.progress_callback)


def kitti_projections(K: np.ndarray, baseline_m: float) -> dict[str, np.ndarray]:
    """P0 = K[I|0], P1 = K[I|(-B,0,0)]; the colour pair P2/P3 is the same rig here."""
    P0, P1 = (rig.projection_matrix(K, view, baseline_m) for view in ("left", "right"))
    return {"P0": P0, "P1": P1, "P2": P0.copy(), "P3": P1.copy()}


def calib_text(seq) -> str:
    P = kitti_projections(seq.K, seq.baseline_m)
    lines = [f"{n}: " + " ".join(f"{x:.12e}" for x in P[n].ravel()) for n in ("P0", "P1", "P2", "P3")]
    lines.append("Tr: " + " ".join(f"{x:.12e}" for x in np.eye(4)[:3].ravel()))  # no lidar: identity
    return "\n".join(lines) + "\n"


def calib_cam_to_cam_text(seq) -> str:
    """KITTI 2015's ``calib_cam_to_cam/NNNNNN.txt`` (the raw data's camera calibration) of the
    rig: per camera xx = 00..03 (00/01 grey, 02/03 colour: here one rectified pair, 00 = 02
    the left camera, 01 = 03 the right) ``S_xx`` (W H), ``K_xx``, ``D_xx`` (no distortion),
    ``R_xx``/``T_xx`` (camera 0 -> xx: X_xx = R·X_0 + T, T = (-B, 0, 0) for the right
    camera), ``S_rect_xx``, ``R_rect_xx`` (identity) and ``P_rect_xx`` (as ``calib.txt``'s P)."""
    P = kitti_projections(seq.K, seq.baseline_m)
    W, H = seq.resolution

    def row(name, values) -> str:
        return f"{name}: " + " ".join(f"{float(x):.12e}" for x in np.ravel(values)) + "\n"
    out = []
    for xx, view in enumerate(("left", "right", "left", "right")):
        T_xx_0 = rig.T_view_left(view, seq.baseline_m)
        out += [row(f"S_{xx:02d}", (W, H)), row(f"K_{xx:02d}", seq.K), row(f"D_{xx:02d}", np.zeros(5)),
                row(f"R_{xx:02d}", T_xx_0[:3, :3]), row(f"T_{xx:02d}", T_xx_0[:3, 3]), row(f"S_rect_{xx:02d}", (W, H)),
                row(f"R_rect_{xx:02d}", np.eye(3)), row(f"P_rect_{xx:02d}", P[f"P{xx}"])]
    return "".join(out)
