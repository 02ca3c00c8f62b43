"""Frame preparation before feature detection, in this order: demosaic (Bayer pattern),
undistort (LUT maps), Gaussian blur, greyscale, histogram equalisation or CLAHE.
The mask (image regions that move with the camera, e.g. the car's bonnet) is kept apart
and handed to the feature detector/tracker.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import VoError
from ..camera.bayer import demosaic


@dataclass
class Preparation:
    bayer: str | None = None                  # Bayer pattern of raw frames (None: already RGB/grey)
    maps: tuple[np.ndarray, np.ndarray] | None = None   # undistortion (map_x, map_y)
    blur_sigma: float = 0.0                   # Gaussian blur sigma in px (0: none)
    equalize: str = "none"                    # none | hist | clahe
    clahe_clip: float = 2.0

    def rgb(self, image: np.ndarray) -> np.ndarray:
        """Demosaiced and undistorted colour image (uint8 RGB, or grey if the input is)."""
        img = np.asarray(image)
        if self.bayer:
            img = demosaic(img, self.bayer)
        if self.maps is not None:
            from ..camera.undistort import remap
            img = remap(img, *self.maps)
        return img

    def gray(self, image: np.ndarray) -> np.ndarray:
        """The uint8 grey image the features see."""
        import cv2
        img = self.rgb(image)
        if self.blur_sigma > 0:
            img = cv2.GaussianBlur(img, (0, 0), self.blur_sigma)
        if img.ndim == 3:
            img = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
        if img.dtype != np.uint8:
            raise VoError(f"expected 8-bit images, got {img.dtype}")
        if self.equalize == "hist":
            img = cv2.equalizeHist(img)
        elif self.equalize == "clahe":
            img = cv2.createCLAHE(clipLimit=self.clahe_clip, tileGridSize=(8, 8)).apply(img)
        elif self.equalize != "none":
            raise VoError(f"unknown equalisation {self.equalize!r} (none, hist or clahe)")
        return img


def build_mask(width: int, height: int, bottom: float = 0.0, top: float = 0.0,
               rects: list[tuple[int, int, int, int]] | None = None, file=None,
               maps: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray | None:
    """uint8 (H, W) mask, 255 where features may be used, or None when nothing is masked.

    ``bottom``/``top``: rows to drop at the bottom/top edge, in pixels (≥ 1) or as a
    fraction of the height (< 1); ``rects``: (x0, y0, x1, y1) boxes to drop; ``file``: an
    image, non-zero = usable. With undistortion ``maps`` the pixels that sample outside the
    distorted image (black border) are dropped as well.
    """
    mask = np.full((height, width), 255, np.uint8)
    changed = False

    def rows(v):
        return int(round(v * height)) if 0 < v < 1 else int(v)
    if bottom:
        mask[height - rows(bottom):] = 0
        changed = True
    if top:
        mask[: rows(top)] = 0
        changed = True
    for x0, y0, x1, y1 in rects or []:
        mask[max(0, int(y0)):int(y1), max(0, int(x0)):int(x1)] = 0
        changed = True
    if file is not None:
        import cv2
        m = cv2.imread(str(file), cv2.IMREAD_GRAYSCALE)
        if m is None:
            raise VoError(f"{file}: cannot read the mask image")
        if m.shape != (height, width):
            raise VoError(f"{file}: mask is {m.shape[1]}x{m.shape[0]}, images are {width}x{height}")
        mask[m == 0] = 0
        changed = True
    if maps is not None:
        mx, my = maps
        sh, sw = mx.shape
        inside = (mx >= 0) & (mx <= sw - 1) & (my >= 0) & (my <= sh - 1)
        mask[~inside] = 0
        changed = changed or not inside.all()
    return mask if changed else None
