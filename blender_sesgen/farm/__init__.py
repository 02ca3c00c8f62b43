"""Render farms on Ray: many scenes and long sequences, nothing lost when a worker dies.

``python -m blender_sesgen farm SCENE... --out ROOT`` (docs/farm.md) splits every scene into
chunks of frames and renders each chunk as one Ray task that runs the render command in a
subprocess (``render SCENE --out ROOT/NAME --frames A:B --resume``). The render folder does
the rest: disjoint chunks of one plan write into one folder concurrently (a lock per frame
range, a completion log per writer, merged into the manifest), every frame is written
atomically, so a lost task is simply run again and resumes.

- :mod:`.work`: what to render -- scene names, chunks, the render command line (pure);
- :mod:`.chunk`: the body of one task -- run the render subprocess, relay its progress;
- :mod:`.child`: the render subprocess, bound to the life of the worker that started it;
- :mod:`.cluster`: Ray -- start or join, resources, the shared-filesystem check;
- :mod:`.driver`: the scheduling loop -- retries, progress across tasks, verification;
- :mod:`.cli`: the command line.

Only :mod:`.cluster`, :mod:`.driver` and :mod:`.cli` import Ray (the ``[farm]`` extra).
"""
