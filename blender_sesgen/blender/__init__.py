"""The bpy layer: the only part of blender_sesgen that imports bpy.

``builder`` maps the scene model onto Blender objects, ``rig`` keys the cameras,
``textures`` and ``lighting`` make shader node setups, ``render`` drives Cycles and writes
multilayer EXRs, ``compat`` hides Blender 4.2 vs 5.0 differences. Nothing here parses
scripts or does pose math: that is the pure core's job.
"""
