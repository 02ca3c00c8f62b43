"""Print the hand-held POSE keyframes of scenes/sensors.ses (24 frames at 30 Hz): a pan from
right to left across the room with 1-2 Hz shake in position and angle and a little jitter.

    python scenes/generators/sensors_path.py
"""
from __future__ import annotations

import numpy as np


def main(n: int = 24, rate_hz: float = 30.0, seed: int = 7) -> None:
    rng = np.random.default_rng(seed)
    for k in range(n):
        t = k / rate_hz
        x = -0.6 + 1.2 * k / (n - 1) + 0.02 * np.sin(2 * np.pi * 2.1 * t)
        y = 1.4 + 0.03 * np.sin(2 * np.pi * 1.3 * t + 0.5) + 0.004 * rng.standard_normal()
        z = 3.2 - 0.02 * k + 0.01 * np.sin(2 * np.pi * 1.7 * t)
        rx = -8 + 3.0 * np.sin(2 * np.pi * 1.1 * t) + 0.3 * rng.standard_normal()
        ry = 12 - 24 * k / (n - 1) + 4.0 * np.sin(2 * np.pi * 1.6 * t + 1.0) + 0.3 * rng.standard_normal()
        rz = 2.5 * np.sin(2 * np.pi * 0.9 * t) + 0.3 * rng.standard_normal()
        print(f"POSE {x:.4f} {y:.4f} {z:.4f} {rx:.3f} {ry:.3f} {rz:.3f}")


if __name__ == "__main__":
    main()
