"""The camera and IMU as sensors (pure: numpy + standard library; runs in Blender's Python).

Modules, each with one job:

- ``timing``      frame stamps (middle of the exposure), exposure windows, rolling-shutter
                  row times, Cycles shutter settings derived from them;
- ``lens``        lens distortion models (Brown-Conrady, Kannala-Brandt): projection,
                  unprojection, folding check, undistortion lookup tables, calibration files;
- ``rig_motion``  the rig's pose at any time (exact constant twists for EGO, a C2 spline
                  through POSE/TRAJECTORY keyframes) with velocities and accelerations;
- ``imu``         ideal and noisy accelerometer/gyroscope streams from the rig's motion;
- ``raw``         the raw sensor: electrons, shot/read/dark/row noise, PRNU/DSNU, CFA
                  mosaic, quantisation, demosaic, camera response;
- ``optics``      lens and pixel MTF, vignetting, lateral chromatic aberration;
- ``autoexposure`` exposure control that adapts over time;
- ``pipeline``    the per-frame chain from a linear render to raw/RGB outputs;
- ``png``         a small PNG writer (8-bit RGB, 16-bit grey) for Blender's Python.

Conventions shared with ``vo_reference`` (timing, lens, rig_motion, imu) are documented in
docs/output-format.md; everything here is off unless a script turns it on.
"""
