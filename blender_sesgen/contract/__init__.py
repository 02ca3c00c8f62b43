"""The contract between the renderer and ``vo_reference``: every convention both sides must
agree on to the last bit, and the on-disk format they exchange, in one place.

numpy + the standard library only, so it imports inside Blender's own Python and in a
``vo_reference`` install without Blender; it imports nothing else of ``blender_sesgen``
(a test enforces both). One module per concept:

- ``se3``: SO(3)/SE(3), quaternions, Euler angles (rad; ``_deg`` names hold degrees)
- ``frames``: SES world (Y up) / Blender world, OpenCV / Blender camera, START
- ``rig``: the stereo rig (``T_left_right``, each view's pose, points in a view, P matrices)
- ``motion``: EGO rows (degrees) <-> twists (radians), their integration and log
- ``camera``: K, principal point, rescaling, K <-> Blender camera settings
- ``depth``: planar depth, the background marker, disparity
- ``colour``: sRGB
- ``timing``: timestamps and the ``--frames`` syntax
- ``manifest``: the render folder layout and the manifest's writer and reader
  (``manifest_schema``: the JSON types of its keys, checked first; ``manifest_sections``:
  the optional sensor sections as typed records)
- ``pixel_settings``: the settings that change pixels (lock, resume and manifest alike)
- ``exr_format``: the EXR channel names of each product and the one header parser
- ``trajectory_files``: TUM, KITTI and EuRoC text, the EGO table
- ``atomic``: atomic (and durable) writes
- ``inputs``: reading a user's input file (regular files only, bounded size)
- ``errors``: :class:`ContractError`
"""
