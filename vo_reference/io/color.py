"""RGB -> grey with OpenCV's weights (the sRGB encoding itself is the contract's:
``blender_sesgen.contract.colour``)."""
from __future__ import annotations

import numpy as np


def rgb8_to_gray8(rgb: np.ndarray) -> np.ndarray:
    """uint8 RGB (H, W, 3) -> uint8 grey with OpenCV's weights (0.299 R + 0.587 G + 0.114 B)."""
    import cv2
    return cv2.cvtColor(np.ascontiguousarray(rgb, dtype=np.uint8), cv2.COLOR_RGB2GRAY)
