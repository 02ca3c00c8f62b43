"""Speed (and accuracy where ground truth exists) of the stereo VO methods.

    .venv/bin/python bench/bench_stereo_vo.py [INPUT] [--size 640x480] [--frames A:B]

INPUT: a render folder or KITTI folder (default ../shared/data/kitti/sequence_1). Speed is
measured on images resized to --size (default 640x480, K scaled accordingly; image reading
excluded); accuracy (end-point drift and Sim3 position RMSE in % of the path, per-frame RMSE)
on the native images. Prints one line per method: paper, accurate, opencv-baseline, with the
process CPU time per step (all threads; less sensitive than wall time to other users of the
machine) and the 1-minute load average.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parents[1]

from vo_reference.evaluate.align import umeyama
from vo_reference.io.sequence import open_sequence
from vo_reference.stereo.pipeline import METHODS, parse_frames, run_stereo_vo


class Resized:
    """A sequence with images resized to (W, H) and K scaled; images cached in memory."""

    def __init__(self, seq, W, H, frames):
        self.seq, sx, sy = seq, W / seq.resolution[0], H / seq.resolution[1]
        self.K = np.diag([sx, sy, 1.0]) @ seq.K
        self.K[0, 2] = (seq.K[0, 2] + 0.5) * sx - 0.5
        self.K[1, 2] = (seq.K[1, 2] + 0.5) * sy - 0.5
        self.baseline_m, self.resolution, self.views = seq.baseline_m, (W, H), seq.views
        self.num_frames, self.timestamps_s = seq.num_frames, seq.timestamps_s
        self._img = {(k, v): cv2.resize(seq.image_gray(k, v), (W, H), interpolation=cv2.INTER_AREA)
                     for k in range(frames[0], frames[1] + 1) for v in ("left", "right")}

    def image_gray(self, k, view="left"):
        return self._img[(k, view)]

    def depth(self, k, view="left"):
        return None

    def T_world_cam(self, view="left"):
        return self.seq.T_world_cam(view)


def accuracy(seq, res):
    T = seq.T_world_cam("left")
    if T is None:
        return ""
    gt = T[res.frames[0]:res.frames[1] + 1, :3, 3]
    est = res.trajectory.positions
    L = np.linalg.norm(np.diff(gt, axis=0), axis=1).sum()
    R, t, s = umeyama(est, gt, with_scale=True)      # gt ~ s R est + t, points (n, 3)
    aligned = s * est @ R.T + t
    rmse = np.sqrt(((aligned - gt) ** 2).sum(1).mean())
    e = res.twists - res.gt_twists
    e[:, 3:] = np.degrees(e[:, 3:])
    r = np.sqrt((e ** 2).mean(0))
    return (f"drift {100 * np.linalg.norm(est[-1] - gt[-1]) / L:6.3f} %  sim3 rmse {100 * rmse / L:6.3f} %  "
            f"egomotion rmse U V W {r[0]:.5f} {r[1]:.5f} {r[2]:.5f}  a b g {r[3]:.4f} {r[4]:.4f} {r[5]:.4f} deg")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("input", nargs="?", default=str(REPO.parent / "shared" / "data" / "kitti" / "sequence_1"))
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--frames", default=None)
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--no-accuracy", action="store_true")
    a = ap.parse_args()
    seq = open_sequence(a.input)
    frames = parse_frames(a.frames, seq.num_frames)
    W, H = (int(v) for v in a.size.lower().split("x"))
    small = Resized(seq, W, H, frames)
    print(f"{a.input}: frames {frames[0]}..{frames[1]}, native {seq.resolution[0]}x{seq.resolution[1]}; "
          f"speed at {W}x{H}; cv2 threads {cv2.getNumThreads()}; load average {os.getloadavg()[0]:.2f} "
          f"on {os.cpu_count()} cores")
    for m in a.methods.split(","):
        t0, c0 = time.perf_counter(), time.process_time()
        r = run_stereo_vo(small, m, frames=range(frames[0], frames[1] + 1))
        cpu_ms = 1000 * (time.process_time() - c0) / len(r.seconds)
        line = (f"{m:16s} {r.fps:6.1f} frames/s at {W}x{H} ({len(r.seconds)} steps, {time.perf_counter() - t0:.1f} s; "
                f"CPU {cpu_ms:.0f} ms/step, load {os.getloadavg()[0]:.2f})")
        if not a.no_accuracy and seq.T_world_cam("left") is not None:
            line += "  |  native: " + accuracy(seq, run_stereo_vo(seq, m, frames=range(frames[0], frames[1] + 1)))
        print(line, flush=True)


if __name__ == "__main__":
    main()
