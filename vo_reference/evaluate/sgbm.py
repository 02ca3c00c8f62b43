"""OpenCV's semi-global block matching with the settings of the OpenCV baseline VO
(``stereo.opencv_comparison``, its depth) and of the realism statistics (``realism``, its
valid share): one matcher, so that the statistic measures what that VO sees."""
from __future__ import annotations

import cv2
import numpy as np


def sgbm_disparity(left: np.ndarray, right: np.ndarray, num_disp: int = 128, block: int = 5) -> np.ndarray:
    """Left disparity (float px, <= 0 invalid) by OpenCV's semi-global block matching. The
    range is at most half the image width (SGBM fails on an image narrower than its range)."""
    num_disp = max(16, min(int(num_disp), left.shape[1] // 2 // 16 * 16))
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num_disp, blockSize=block,
                                 P1=8 * block * block, P2=32 * block * block, disp12MaxDiff=1,
                                 uniquenessRatio=10, speckleWindowSize=100, speckleRange=2,
                                 mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY)
    return sgbm.compute(left, right).astype(np.float32) / 16.0
