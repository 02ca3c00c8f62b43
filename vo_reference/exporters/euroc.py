"""EuRoC MAV / ASL layout of a render: ``mav0/cam0`` (+ ``cam1``) ``data/<t_ns>.png`` grey with
``data.csv`` and ``sensor.yaml``, ``state_groundtruth_estimate0``, and ``imu0`` when the render
has an IMU (docs/output-format.md)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.sensor_yaml import YAML_HEADER, imu_sensor_yaml, yaml_matrix
from blender_sesgen.contract.trajectory_files import format_euroc

from ..errors import VoError
from ..io.files import write_png_rgb
from .driver import ExportOptions, image_gray, progress_bar, refuse_options
from .slam_config import T_body_cam, write_slam_configs


def _euroc_distortion(seq) -> tuple[str, list]:
    lens = seq.lens
    if lens is None:
        return "radial-tangential", [0.0, 0.0, 0.0, 0.0]
    if lens.model == "kannala_brandt":
        return "equidistant", list(lens.coeffs)
    k1, k2, p1, p2, k3 = lens.coeffs
    if k3:
        raise VoError("euroc: the EuRoC/Kalibr radial-tangential model has k1 k2 p1 p2 only and this lens has "
                      "k3 != 0: add --undistort to write pinhole images")
    return "radial-tangential", [k1, k2, p1, p2]


def euroc_sensor_yaml(seq, cam: int) -> str:
    """EuRoC ``camN/sensor.yaml``: T_BS (camera in the body frame), intrinsics, distortion,
    and for a rolling shutter its readout time (the per-row offsets are in row_offsets.csv)."""
    K = seq.K
    W, H = seq.resolution
    model, coeffs = _euroc_distortion(seq)
    body = "the IMU" if seq.imu_calibration() is not None else "the left camera"
    readout = float(seq.readout_s)
    rs = (f"rolling_shutter_readout_s: {readout:.9g}   # rows read top to bottom, see row_offsets.csv\n"
          if readout > 0 else "")
    return (YAML_HEADER + "# General sensor definitions.\n"
            "sensor_type: camera\n"
            f"comment: sesgen render, {'left' if cam == 0 else 'right'} camera (body frame = {body})\n\n"
            "# Sensor extrinsics wrt. the body-frame.\n"
            "T_BS:\n" + yaml_matrix(T_body_cam(seq, cam)) + "\n"
            "# Camera specific definitions.\n"
            f"rate_hz: {seq.rate_hz:.9g}\n"
            f"resolution: [{int(W)}, {int(H)}]\n"
            "camera_model: pinhole\n"
            f"intrinsics: [{K[0, 0]:.17g}, {K[1, 1]:.17g}, {K[0, 2]:.17g}, {K[1, 2]:.17g}] #fu, fv, cu, cv\n"
            f"distortion_model: {model}\n"
            f"distortion_coefficients: [{', '.join(f'{c:.17g}' for c in coeffs)}]\n" + rs)


def export_euroc(seq, out: Path, opts: ExportOptions) -> None:
    refuse_options(opts, "euroc")
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
        readout = float(seq.readout_s)
        if readout > 0:
            from blender_sesgen.contract.timing import row_offsets_s, to_ns
            off = to_ns(row_offsets_s(seq.resolution[1], readout))
            atomic.write_text(mav / cam / "row_offsets.csv", "#row,offset [ns] (capture time of the row - frame stamp)\n"
                              + "".join(f"{r},{int(o)}\n" for r, o in enumerate(off)))
    gt = mav / "state_groundtruth_estimate0"
    if seq.imu_calibration() is not None:
        _export_euroc_imu(seq, mav, ts)
        body = "the IMU (imu0)"
    else:
        atomic.write_text(gt / "data.csv", format_euroc(t_ns, seq.T_world_cam("left")[frames]))
        body = "left camera (cam0)"
    atomic.write_text(gt / "sensor.yaml",
                      YAML_HEADER + "# General sensor definitions.\nsensor_type: visual-inertial\n"
                      f"comment: sesgen ground truth; body frame = {body}, R = the SES world\n\n"
                      "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n" + yaml_matrix(np.eye(4)))
    write_slam_configs(seq, out / "slam", t_ns)   # the rig's SLAM/VIO settings beside mav0


def _export_euroc_imu(seq, mav: Path, ts: np.ndarray) -> None:
    """imu0/data.csv + sensor.yaml (the noisy stream) and the body ground truth at the IMU's
    instants, both cut to the exported frames' time span."""
    entry = seq.imu_calibration()
    t0, t1 = float(ts[0]), float(ts[-1])
    off = entry.time_offset_s

    def cut(rel: str, shift: float) -> str:
        lines = (seq.root / rel).read_text(encoding="utf-8").splitlines()
        keep = [ln for ln in lines[1:] if ln and t0 - 1e-9 <= int(ln.split(",")[0]) * 1e-9 - shift <= t1 + 1e-9]
        return "\n".join([lines[0]] + keep) + "\n"
    atomic.write_text(mav / "imu0" / "data.csv", cut(entry.files["noisy"], off))
    # written from the manifest (not copied: renders made before the YAML header was fixed
    # hold a file PyYAML cannot read)
    atomic.write_text(mav / "imu0" / "sensor.yaml", imu_sensor_yaml(entry))
    atomic.write_text(mav / "state_groundtruth_estimate0" / "data.csv", cut(entry.files["groundtruth"], 0.0))


export_euroc.keeps_lens = True   # a distorted render is written as it is, with its lens (docs/output-format.md)
