"""Ground-truth products derived from renders (disparity, flow, occlusion, noise,
segmentation) and dataset exports (KITTI, TUM, PNG)."""
