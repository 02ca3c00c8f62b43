"""Ground truth computed from renders: disparity, flow, scene flow, dense flow, segmentation, image noise, sparse points. Never imports the exporters."""
