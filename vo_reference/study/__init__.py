"""The ``vo_reference`` half of a verification study (``python -m blender_sesgen study``,
docs/studies.md): what needs OpenCV, SciPy and matplotlib. ``blender_sesgen.study`` runs it
as child processes:

- :mod:`.evaluate`: one run's trajectory against its variant's ground truth (failure,
  tracking loss, APE, RPE per frame and per metre, KITTI), and the ground-truth controls;
- :mod:`.report`: the self-contained HTML page;
- :mod:`.cli`: ``python -m vo_reference study evaluate JOB.json`` and ``study report DIR``.
"""
