"""Stereo visual odometry: the SESGen paper's reference method and an accurate variant.

- :mod:`.motion_field` — the paper's Eqs. 2–6 (motion field, H X = K), twist <-> pose.
- :mod:`.blockmatch` — SAD block matching (tracking, disparity), pixel accuracy.
- :mod:`.paper` — the paper's method; :mod:`.accurate` — sub-pixel, RANSAC, SE(3) refinement;
  :mod:`.baseline` — a plain OpenCV comparison.
- :mod:`.groundtruth` — keypoint depth / correspondences from a render (error-source switches).
- :mod:`.pipeline` — run a method over a sequence; :mod:`.cli`, :mod:`.run_cli` — commands.
See docs/stereo-vo.md.
"""
