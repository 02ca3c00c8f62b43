"""The camera as a sensor, for readers, exporters and VO alike: Bayer mosaics, RobotCar-style
camera models, lens distortion and its lookup tables."""
