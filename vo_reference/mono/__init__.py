"""The classic monocular VO pipeline (issue 7), our own geometry on numpy/scipy.

Layout, in pipeline order:
- data preparation: :mod:`.bayer` (demosaic), :mod:`.camera_model` (RobotCar model files),
  :mod:`.undistort` (RobotCar LUTs, OpenCV distortion coefficients), :mod:`.prepare`
  (blur, grey, equalisation/CLAHE, bonnet mask);
- correspondences: :mod:`.features` (ORB/SIFT + ratio test, pyramidal LK with
  forward-backward check, best N);
- geometry: :mod:`.fundamental` (normalised 8-point, Sampson, RANSAC), :mod:`.essential`
  (E = KᵀFK, four (R, C) candidates, cheirality), :mod:`.triangulation` (linear, non-linear),
  :mod:`.pnp` (linear DLT, non-linear with quaternions);
- pipeline: :mod:`.scale` (gt / speed / stereo / none), :mod:`.pipeline` (frame-to-frame
  VO and trajectory accumulation), :mod:`.opencv_ref` (OpenCV comparison), :mod:`.cli`.

Only data preparation, features/LK and the comparison mode use OpenCV.
"""
