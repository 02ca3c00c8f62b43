"""docs/img/imu_allan.png: Allan deviation of our noisy IMU stream (the EuRoC ADIS16448
densities, three hours at rest) next to the real ADIS16448 stream of EuRoC V1_01 (its quietest
3 s, and the whole 145 s), with the datasheet lines N / sqrt(tau) and K sqrt(tau / 3).

    python tools/make_imu_allan.py [--data ../shared/data/euroc/mav0/imu0/data.csv]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
from blender_sesgen.sensor import imu
from vo_reference.evaluate.allan import allan_deviation, fit_noise_densities


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "euroc" / "mav0" / "imu0" / "data.csv"))
    p.add_argument("--out", default=str(REPO / "docs" / "img" / "imu_allan.png"))
    args = p.parse_args()
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    params = imu.ImuParams(seed=1)
    n = int(3 * 3600 * params.rate_hz)
    ours = imu.add_noise(imu.ImuStream(np.arange(n) / params.rate_hz, np.zeros((n, 3)), np.zeros((n, 3))), params)
    real = np.loadtxt(args.data, delimiter=",", skiprows=1)
    rate = 1e9 / np.median(np.diff(real[:, 0]))
    w = int(3 * rate)
    stds = [np.linalg.norm(real[i:i + w, 1:4].std(0)) for i in range(0, len(real) - w, 50)]
    i0 = 50 * int(np.argmin(stds))
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, cols, data_ours, N, K, unit, name in (
            (axes[0], slice(1, 4), ours.gyro, params.gyro_noise, params.gyro_walk, "rad/s", "gyroscope"),
            (axes[1], slice(4, 7), ours.accel, params.accel_noise, params.accel_walk, "m/s²", "accelerometer")):
        t_o, a_o = allan_deviation(data_ours, params.rate_hz, points=50)
        t_q, a_q = allan_deviation(real[i0:i0 + w, cols], rate, points=30)
        t_f, a_f = allan_deviation(real[:, cols], rate, points=40)
        keep = t_o <= 3 * 3600 / 10                     # at least 10 clusters
        Ne, Ke = np.mean([fit_noise_densities(t_o[keep], a_o[keep, c]) for c in range(3)], axis=0)
        ax.loglog(t_o[keep], a_o[keep].mean(axis=1), "C0", lw=2,
                  label=f"ours, 3 h at rest (fit N={Ne:.3g}, K={Ke:.3g})")
        ax.loglog(t_q, a_q.mean(axis=1), "C3", lw=1.5, label=f"EuRoC V1_01 quietest 3 s (t={i0 / rate:.0f} s, in flight)")
        ax.loglog(t_f, a_f.mean(axis=1), "C3:", lw=1, label="EuRoC V1_01, all 145 s (flight)")
        tt = np.logspace(np.log10(t_o[0]), np.log10(t_o[-1]), 50)
        ax.loglog(tt, N / np.sqrt(tt), "k--", lw=0.8, label=f"datasheet N/√τ, N={N:g}")
        ax.loglog(tt, K * np.sqrt(tt / 3), "k-.", lw=0.8, label=f"datasheet K√(τ/3), K={K:g}")
        ax.set_xlabel("τ (s)")
        ax.set_ylabel(f"Allan deviation ({unit})")
        ax.set_title(f"ADIS16448 {name}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
