"""Shi–Tomasi keypoints (OpenCV ``goodFeaturesToTrack``) with a border margin."""
from __future__ import annotations

import cv2
import numpy as np


def shi_tomasi(gray: np.ndarray, max_corners: int, quality: float, min_distance: float,
               margin: int, block_size: int = 3) -> np.ndarray:
    """Integer corner positions (N, 2) as float (x, y), strongest first, ``margin`` px from the border."""
    H, W = gray.shape
    mask = np.zeros((H, W), np.uint8)
    if H > 2 * margin and W > 2 * margin:
        mask[margin:H - margin, margin:W - margin] = 255
    c = cv2.goodFeaturesToTrack(gray, maxCorners=int(max_corners), qualityLevel=float(quality),
                                minDistance=float(min_distance), mask=mask, blockSize=int(block_size))
    if c is None:
        return np.zeros((0, 2))
    return c.reshape(-1, 2).astype(np.float64)
