"""Write tests/golden/static_flow.npz: the static-scene products (flow, occlusion,
disparity) of tests/dynamic_scene.py's scene with nothing moving, computed by the
vo_reference of commit 9808421 — the code before moving objects existed.

    git worktree add /tmp/before 9808421
    PYTHONPATH=/tmp/before:tests python tests/golden/make_static_flow.py

tests/test_products_scene_flow.py checks that today's code gives the same bits.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

import dynamic_scene  # tests/ (on PYTHONPATH; pytest's pythonpath in the tests)

HERE = Path(__file__).resolve().parent


def products(seq) -> dict:
    from vo_reference.products.disparity import sequence_disparity
    from vo_reference.products.flow import sequence_flow, sequence_stereo_occlusion
    out = {}
    for k, kt in ((0, 1), (1, 2), (1, 0), (2, 1)):
        f = sequence_flow(seq, k, kt, "left")
        out[f"flow_{k}_{kt}"] = f.flow
        out[f"occluded_{k}_{kt}"] = f.occluded
        out[f"out_of_image_{k}_{kt}"] = f.out_of_image
    for k in range(seq.num_frames):
        for view in ("left", "right"):
            out[f"disparity_{k}_{view}"] = sequence_disparity(seq, k, view)
            out[f"stereo_occlusion_{k}_{view}"] = sequence_stereo_occlusion(seq, k, view)
    return out


def main() -> None:
    from vo_reference.io.render import RenderSequence
    import vo_reference
    with tempfile.TemporaryDirectory() as tmp:
        root = dynamic_scene.write(Path(tmp) / "static", dynamic_scene.make_scene(static=True), moving=False)
        out = products(RenderSequence(root))
    np.savez_compressed(HERE / "static_flow.npz", **out)
    print(f"wrote {HERE / 'static_flow.npz'} with {vo_reference.__file__}")


if __name__ == "__main__":
    main()
