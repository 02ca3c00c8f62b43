"""Colours of asset surfaces: linear albedos (what a spectrophotometer would give, not
sRGB), chosen from short lists so that a scene uses a bounded number of materials.

Real surfaces lie between ~0.03 (fresh asphalt, rubber, black paint) and ~0.85 (fresh
white paint); a colour given for a library material replaces the library's main colour.
"""
from __future__ import annotations

import numpy as np

# facade renders: a third white or cream, as on Central European streets (white silicate and
# silicone renders have a light reflectance value (LRV, the luminous albedo) of 80-90, the
# whitest paints ~85-92 (BRANZ/Standards NZ; Resene White 92), creams 70-78), the rest
# pastels, greys and earth tones of LRV 30-65
PLASTER = ((0.80, 0.79, 0.76), (0.58, 0.52, 0.40), (0.62, 0.55, 0.36), (0.55, 0.45, 0.40),
           (0.45, 0.46, 0.45), (0.76, 0.72, 0.61), (0.50, 0.38, 0.26), (0.40, 0.44, 0.48),
           (0.85, 0.85, 0.83), (0.48, 0.52, 0.42), (0.66, 0.62, 0.50), (0.72, 0.71, 0.68))
BRICK = ((0.30, 0.11, 0.06), (0.25, 0.12, 0.08), (0.38, 0.22, 0.14), (0.22, 0.16, 0.13))
STONE = ((0.28, 0.27, 0.25), (0.35, 0.34, 0.31), (0.22, 0.21, 0.20), (0.40, 0.36, 0.30))
FRAME = ((0.75, 0.75, 0.74), (0.72, 0.72, 0.72), (0.06, 0.06, 0.065), (0.20, 0.11, 0.05), (0.30, 0.31, 0.32))
DOOR = ((0.20, 0.11, 0.06), (0.06, 0.07, 0.08), (0.30, 0.18, 0.09), (0.38, 0.38, 0.40), (0.05, 0.10, 0.07),
        (0.35, 0.06, 0.04))
ROOF = ((0.28, 0.085, 0.045), (0.10, 0.095, 0.095), (0.33, 0.13, 0.07), (0.18, 0.07, 0.04))
CAR_PAINT = (  # colour, weight: the usual mix of a European street
    ((0.72, 0.72, 0.70), 5), ((0.015, 0.015, 0.016), 5), ((0.35, 0.36, 0.37), 5), ((0.08, 0.08, 0.085), 4),
    ((0.02, 0.04, 0.12), 2), ((0.35, 0.02, 0.02), 2), ((0.03, 0.07, 0.04), 1), ((0.40, 0.33, 0.24), 1),
    ((0.50, 0.51, 0.53), 3), ((0.04, 0.12, 0.28), 1))
LEAVES = ((0.05, 0.09, 0.025), (0.06, 0.10, 0.03), (0.04, 0.075, 0.02), (0.07, 0.10, 0.03), (0.055, 0.08, 0.03))
NEEDLES = ((0.025, 0.05, 0.025), (0.03, 0.06, 0.03), (0.02, 0.04, 0.02))
BARK = ((0.13, 0.10, 0.08), (0.16, 0.14, 0.12), (0.10, 0.08, 0.065), (0.20, 0.19, 0.17))
PAVING = ((0.30, 0.29, 0.27), (0.34, 0.33, 0.31), (0.26, 0.25, 0.24), (0.31, 0.22, 0.18))
METAL_PAINT = ((0.30, 0.31, 0.32), (0.12, 0.22, 0.16), (0.05, 0.05, 0.05), (0.45, 0.46, 0.47), (0.10, 0.15, 0.12))
PLASTIC_BIN = ((0.03, 0.03, 0.03), (0.03, 0.10, 0.04), (0.03, 0.07, 0.25), (0.25, 0.12, 0.02), (0.30, 0.02, 0.02))
FABRIC = ((0.18, 0.20, 0.26), (0.35, 0.33, 0.30), (0.08, 0.08, 0.09), (0.30, 0.10, 0.06), (0.12, 0.20, 0.12),
          (0.45, 0.42, 0.38), (0.20, 0.14, 0.10))
WOOD = ((0.33, 0.19, 0.09), (0.45, 0.30, 0.16), (0.20, 0.11, 0.05), (0.52, 0.40, 0.25))


def pick(rng, palette):
    """One colour of ``palette`` (a tuple of colours, or of (colour, weight) pairs)."""
    if isinstance(palette[0][0], tuple):
        w = np.array([p[1] for p in palette], float)
        return palette[int(rng.choice(len(palette), p=w / w.sum()))][0]
    return palette[int(rng.integers(len(palette)))]


def scaled(colour, factor: float):
    """``colour`` times ``factor``, rounded to 3 decimals (so near-equal shades share a material)."""
    return tuple(round(float(min(max(c * factor, 0.0), 1.0)), 3) for c in colour)
