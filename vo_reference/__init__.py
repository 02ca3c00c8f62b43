"""vo_reference: reference visual odometry and evaluation for sesgen renders and real datasets.

Standalone: needs numpy, OpenEXR, OpenCV, scipy (+ matplotlib for plots); never imports
bpy nor blender_sesgen. The contract with the renderer is the on-disk format
``sesgen-render/1`` (docs/output-format.md).
"""
__version__ = "0.1.0"
