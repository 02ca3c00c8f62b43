"""Exporting a render to a dataset layout from the add-on (pure: stdlib only, no bpy).

The layouts are written by ``vo_reference`` (OpenCV, OpenEXR, SciPy), which Blender's own
Python does not have; so the add-on runs the ``vo-reference export`` command of a Python
where ``pip install 'blender-sesgen[vo]'`` was done, as a child process, with
``--progress json``, and turns its events into the panel's progress bar and status line.
"""
from __future__ import annotations

import json
import queue
import shlex
import shutil
import signal
import subprocess
import threading
from typing import Optional

from ..errors import SesgenError

# the layouts of vo_reference.products.exports.EXPORTERS (a test keeps the two lists equal)
TARGETS = (
    ("kitti-odometry", "KITTI odometry", "The development kit's tree: dataset/sequences/NN + dataset/poses/NN.txt"),
    ("kitti-folder", "KITTI folder", "One KITTI sequence folder with poses.txt"),
    ("kitti-stereo", "KITTI stereo 2015", "image_2/3, disp_occ_0/disp_noc_0, flow_occ/flow_noc, calib_cam_to_cam"),
    ("kitti-sceneflow", "KITTI scene flow 2015", "image_2/3 _10/_11, disp_occ_0/1, flow_occ, obj_map, instance and motion masks"),
    ("tum", "TUM RGB-D", "rgb/, depth/ (5000 per metre), groundtruth.txt"),
    ("euroc", "EuRoC (ASL)", "mav0/cam0, cam1, state_groundtruth_estimate0"),
    ("png", "PNG", "Noisy RGB, ids, disparity per view"),
    ("bayer", "Bayer (RobotCar)", "Raw Bayer mosaics and an undistortion table"),
    ("tartanair", "TartanAir", "image/depth/seg per view, flow + mask, NED poses"),
    ("vkitti2", "Virtual KITTI 2", "frames/rgb, depth, class/instance segmentation, flow; intrinsic/extrinsic/pose/"
                                   "bbox/info.txt"),
    ("sceneflow", "SceneFlow", "FlyingThings3D tree: PFM disparity, flow, disparity change"),
    ("rosbag", "ROS 2 bag", "mcap: cam0/cam1 Image + CameraInfo, imu0 Imu, tf_static extrinsics, tf + PoseStamped "
                            "ground truth"),
    ("cityscapes", "Cityscapes", "leftImg8bit + gtFine labelIds, labelTrainIds, color, instanceIds, polygons per view; "
                                 "classes.json"),
    ("colmap", "COLMAP", "images + sparse/0 text model with points from the exact depth"),
    ("nerfstudio", "nerfstudio", "transforms.json, images, depths (mm), masks, seed point cloud"),
    ("slam", "SLAM/VIO settings", "ORB-SLAM3, VINS-Fusion, OpenVINS, Kalibr and Basalt settings of the rig"),
    ("tartanair-v2", "TartanAir V2", "ENV/Data_easy/P000: image/depth/seg_lcam_front, rcam_front, flow, NED poses"),
    ("middlebury", "Middlebury 2014", "One folder per frame: im0/im1, disp0/disp1 PFM, mask0nocc, calib.txt"),
    ("eth3d", "ETH3D two-view", "two_view_training + two_view_training_gt per frame"),
    ("sintel", "MPI-Sintel", "training/clean, final, flow (.flo), occlusions, depth (.dpt), camdata_left (.cam)"),
)
TAKES_SEQUENCE = {"kitti-odometry", "tartanair", "tartanair-v2", "vkitti2", "sceneflow", "sintel"}
NOT_FOUND = ("exporting needs the vo_reference tools outside Blender: pip install 'blender-sesgen[vo]' "
             "in a Python 3.11 and put its vo-reference command on PATH, or give the command under VO Command")


class ExportError(SesgenError):
    """The export could not start or failed; the message is one line for the user."""


def tool_command(setting: str, program: str, not_found: str, error=None) -> list[str]:
    """The command line prefix of a tool the add-on runs: the setting split like a shell
    line, else ``program`` on PATH, else ``error(not_found)`` (ExportError by default)."""
    words = shlex.split(setting) if setting and setting.strip() else []
    if words:
        return words
    found = shutil.which(program)
    if found is None:
        raise (error or ExportError)(not_found)
    return [found]


def vo_command(setting: str = "") -> list[str]:
    """The command line prefix that runs ``vo-reference``: the setting (e.g.
    ``/opt/venv/bin/vo-reference`` or ``python3 -m vo_reference``), else ``vo-reference`` on PATH."""
    return tool_command(setting, "vo-reference", NOT_FOUND)


def export_command(prefix: list[str], render_dir: str, out_dir: str, target: str,
                   sequence: str = "", frames: str = "", undistort: bool = False) -> list[str]:
    """``vo-reference export RENDER OUT --to TARGET --progress json [--sequence S] [--frames A:B]
    [--undistort]``."""
    if target not in {t[0] for t in TARGETS}:
        raise ExportError(f"unknown layout {target!r}")
    if not render_dir:
        raise ExportError("choose the render's output folder first")
    if not out_dir:
        raise ExportError("choose an export folder first")
    cmd = [*prefix, "export", render_dir, out_dir, "--to", target, "--progress", "json"]
    if sequence.strip():
        if target not in TAKES_SEQUENCE:
            raise ExportError(f"the {target} layout has no sequence slot (leave Sequence empty)")
        cmd += ["--sequence", sequence.strip()]
    if frames.strip():
        cmd += ["--frames", frames.strip()]
    if undistort:
        cmd.append("--undistort")
    return cmd


class ExportProcess:
    """A running export: ``poll()`` returns the progress events read so far (dicts); when
    ``finished``, ``returncode``, ``error`` (the tool's one-line message) and ``where``."""

    def __init__(self, cmd: list[str]):
        self.cmd = cmd
        try:
            self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                         stdin=subprocess.DEVNULL)
        except OSError as e:
            raise ExportError(f"cannot run {cmd[0]}: {e.strerror or e} ({NOT_FOUND})") from None
        self._events: queue.Queue = queue.Queue()
        self._other: list[str] = []
        self._stdout: list[str] = []
        self._threads = [threading.Thread(target=self._read_stderr, daemon=True),
                         threading.Thread(target=self._read_stdout, daemon=True)]
        for t in self._threads:
            t.start()
        self.done, self.total = 0, 0
        self.returncode: Optional[int] = None

    def _read_stderr(self) -> None:
        for line in self.proc.stderr:
            try:
                event = json.loads(line)
            except ValueError:
                event = None
            if isinstance(event, dict) and "event" in event:
                self._events.put(event)
            elif line.strip():
                self._other.append(line.rstrip("\n"))

    def _read_stdout(self) -> None:
        for line in self.proc.stdout:
            self._stdout.append(line.rstrip("\n"))

    def poll(self) -> list[dict]:
        events = []
        while True:
            try:
                events.append(self._events.get_nowait())
            except queue.Empty:
                break
        for e in events:
            if "total" in e:
                self.total = int(e["total"])
            if "done" in e:
                self.done = int(e["done"])
        if self.returncode is None and self.proc.poll() is not None:
            for t in self._threads:
                t.join(timeout=5)
            self.returncode = self.proc.returncode
            events += self.poll()
        return events

    @property
    def finished(self) -> bool:
        return self.returncode is not None

    @property
    def fraction(self) -> float:
        return min(self.done / self.total, 1.0) if self.total else 0.0

    @property
    def error(self) -> str:
        """The tool's own message (``error: ...``), else its last line, else the exit code."""
        msgs = [l for l in self._other if l.startswith("error:")]
        if msgs:
            return msgs[-1][len("error:"):].strip()
        return self._other[-1] if self._other else f"the export command exited with code {self.returncode}"

    @property
    def summary(self) -> str:
        """The tool's result line (``exported RENDER -> OUT (layout)``)."""
        return self._stdout[-1] if self._stdout else ""

    def wait(self, timeout: Optional[float] = None) -> int:
        self.proc.wait(timeout)
        self.poll()
        return self.returncode

    def cancel(self) -> None:
        """Interrupt the export as Ctrl-C would (its half-built sequence folder is removed)."""
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGINT)
            except (ValueError, OSError):
                self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.poll()
