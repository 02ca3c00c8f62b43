"""The built-in procedural texture palette: stable numbers and names.

SESGen numbered its textures and its example scripts use 1-10, so numbers 1..12 are
fixed forever (new textures get new numbers, never reuse). ``texture 0`` means plain
colour. The Blender node set for each name lives in ``blender/textures.py``; pictures
of each are in docs/rendering.md (Textures).
"""
from __future__ import annotations

# number -> (name, one-line description). Names are case-insensitive in scripts.
BUILTIN_TEXTURES: dict[int, tuple[str, str]] = {
    1: ("noise", "fine high-contrast fractal noise (multi-scale blobs)"),
    2: ("voronoi", "Voronoi cells with dark borders"),
    3: ("bricks", "brick wall with mortar and per-brick tone"),
    4: ("checker", "checkerboard with noise-modulated tones"),
    5: ("marble", "marble veins (distorted wave)"),
    6: ("wood", "wood rings with grain noise"),
    7: ("granite", "speckled granite (several noise scales)"),
    8: ("tiles", "square tiles with grout and random tones"),
    9: ("blotches", "coarse blotches over fine noise"),
    10: ("gravel", "gravel: small Voronoi stones with noise"),
    11: ("concrete", "concrete: low-contrast noise with pits"),
    12: ("camouflage", "camouflage: thresholded multi-scale noise"),
}

NAME_TO_NUMBER: dict[str, int] = {name: number for number, (name, _) in BUILTIN_TEXTURES.items()}
