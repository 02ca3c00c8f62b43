"""bench/hall_klt.py's readings against noise and corners of known size (issue 28, session 20)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
import hall_klt  # noqa: E402


def _flat_pairs(sigma: float, smooth: bool, seed: int = 0):
    """Pairs of a flat 130 DN frame with white noise of ``sigma`` DN (float, no rounding), or the
    noise averaged with its right neighbour (a resampling's correlation: lag-1 across 0.5, the
    variance halved)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(3):
        f = []
        for _ in range(2):
            n = rng.normal(0, sigma, (240, 377))
            n = (n[:, 1:] + n[:, :-1]) / 2 if smooth else n[:, 1:]
            f.append(130.0 + n)
        out.append(tuple(f))
    return out


def test_noise_by_level_reads_a_known_variance_and_its_correlation():
    """White noise of 0.8 DN reads 0.64 DN^2 at 132 DN with no lag-1 correlation; averaged with
    its right neighbour 0.32 DN^2 and +0.5 across, 0 down (a mutant without the half, or with
    the lag taken down, reads otherwise)."""
    line = hall_klt.noise_by_level(_flat_pairs(0.8, False), levels=(132,))
    assert abs(float(line.split("132: ")[1].split(";")[0]) - 0.64) < 0.03, line
    assert abs(float(line.split("across ")[1].split(",")[0])) < 0.03
    line = hall_klt.noise_by_level(_flat_pairs(0.8, True), levels=(132,))
    assert abs(float(line.split("132: ")[1].split(";")[0]) - 0.32) < 0.02, line
    assert abs(float(line.split("across ")[1].split(",")[0]) - 0.5) < 0.03, line
    assert abs(float(line.split("down ")[1])) < 0.03, line


def test_floor_figures_count_corners_on_the_floor_only():
    """A flat frame with four bright squares inside the mask and none outside: 16 corners on the
    mask's pixels, a plain floor's pixel-scale deviation 0."""
    img = np.full((240, 376), 100, np.uint8)
    for x0 in (40, 80, 120, 160):
        img[150:160, x0:x0 + 10] = 200
    mask = np.zeros(img.shape, bool)
    mask[120:240] = True
    pix, band, per_k = hall_klt.floor_figures(img, mask)
    assert pix == 0 and abs(per_k - 1000 * 16 / mask.sum()) < 1e-9, (pix, per_k)


def test_a_folder_without_the_frame_exits_2(tmp_path, capsys):
    assert hall_klt.main([str(tmp_path), "--frame", "30"]) == 2
    assert "not a hall render folder" in capsys.readouterr().err
