"""Ground-truth products derived from renders (disparity, flow, occlusion, dense flow,
noise, segmentation) and dataset exports (KITTI odometry and stereo, TUM, EuRoC, PNG,
Bayer, TartanAir, Virtual KITTI 2, SceneFlow: one module per layout, registered in
:data:`vo_reference.products.exports.EXPORTERS`)."""
