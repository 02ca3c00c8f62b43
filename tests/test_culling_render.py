"""A culled render equals the full render where it must: sampled frames of a generated city
(with moving traffic), rendered chunk by chunk with ``--cull`` (each chunk builds only what
its frames can see) and in one piece with the whole world, have exactly the same depth,
object ids and -- the ``gt`` preset's flat shading being a function of the surface seen --
the same RGB, bit for bit; and the chunks really build far fewer objects."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.exr import read_exr
from blender_sesgen.generators.builtin.city_grid import generate as city_grid
from blender_sesgen.plan import RenderOptions



@pytest.mark.render
@pytest.mark.slow
def test_culled_chunks_render_the_full_worlds_ground_truth(tmp_path):
    pytest.importorskip("bpy")
    from blender_sesgen.job import RenderJob
    text = city_grid(3, route_m=220.0, closures=1, traffic=2, blocks=2)
    script = tmp_path / "city.ses"
    script.write_text(text)
    n = text.count("\nPOSE ")
    chunks = [(0, 2), (n // 2, n // 2 + 2), (n - 2, n)]
    opts = dict(quality="gt", resolution_scale=0.12, threads=1)
    full = RenderJob.prepare(script, tmp_path / "full", RenderOptions(**opts))    # the whole world
    full.build()
    n_full = len(full.built.objects)
    try:
        for a, b in chunks:
            for k in range(a, b):
                full.render_frame(k)
    finally:
        full.close()
    built = []
    for a, b in chunks:
        job = RenderJob.prepare(script, tmp_path / "culled", RenderOptions(frames=f"{a}:{b}", cull=True, **opts),
                                resume=True)
        job.build()
        built.append(len(job.built.objects))
        job.run()
    assert max(built) < 0.8 * n_full, (built, n_full)
    compared = 0
    for a, b in chunks:
        for k in range(a, b):
            for view in ("left", "right"):
                A = read_exr(tmp_path / "full" / "exr" / view / f"{k:06d}.exr")
                B = read_exr(tmp_path / "culled" / "exr" / view / f"{k:06d}.exr")
                assert A.keys() == B.keys()
                for name in A:
                    assert np.array_equal(A[name], B[name]), (k, view, name)
                ids = A["ViewLayer.Object Index.X"]
                compared += len(np.unique(ids))
    assert compared > 30                      # the frames see many objects, not a blank sky
