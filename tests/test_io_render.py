"""Render-folder reader: multi-part EXR as Blender 5.0 writes it + manifest -> Sequence."""
from __future__ import annotations

import json

import numpy as np
import pytest

from vo_reference.errors import VoError
from vo_reference.io.exr import read_exr_channels, write_exr_parts
from vo_reference.io.render import RenderSequence
from vo_reference.io.sequence import Sequence, open_sequence
from synthetic_render import plane_scene, write_manifest_dict, write_render

pytest.importorskip("OpenEXR")


def _srgb_reference(c: float) -> int:
    """IEC 61966-2-1, scalar, written independently of the package."""
    c = min(max(c, 0.0), 1.0)
    s = 12.92 * c if c <= 0.0031308 else 1.055 * c ** (1 / 2.4) - 0.055
    return int(np.floor(s * 255 + 0.5))


@pytest.fixture
def tiny(tmp_path):
    """2 frames, stereo, 6x4: known RGB, depth with background, ids."""
    H, W = 4, 6
    K = np.array([[10.0, 0, 2.5], [0, 10.0, 1.5], [0, 0, 1]])
    rng = np.random.default_rng(1)
    frames = []
    for k in range(2):
        d = {}
        for v in ("left", "right"):
            rgb = rng.uniform(-0.1, 1.2, (H, W, 3)).astype(np.float32)
            z = rng.uniform(1, 5, (H, W)).astype(np.float32)
            z[0, 0] = np.inf  # -> 1e10 in the file
            ids = rng.integers(0, 300, (H, W)).astype(np.int32)
            d[v] = (rgb, z, ids)
        frames.append(d)
    T = np.tile(np.eye(4), (2, 1, 1))
    T[1, 2, 3] = 0.5
    root = write_render(tmp_path / "r", K=K, baseline_m=0.3, T_world_left=T, frames=frames, noise=(2.0, 5))
    return root, frames, K, T


def test_fixture_is_multipart_with_blender_channel_names(tiny):
    import OpenEXR
    root = tiny[0]
    with OpenEXR.File(str(root / "exr/left/000000.exr"), separate_channels=True) as f:
        parts = {p.name(): sorted(p.channels) for p in f.parts}
    assert parts == {
        "ViewLayer.Combined": ["ViewLayer.Combined.A", "ViewLayer.Combined.B", "ViewLayer.Combined.G", "ViewLayer.Combined.R"],
        "ViewLayer.Depth": ["ViewLayer.Depth.Z"],
        "ViewLayer.Object Index": ["ViewLayer.Object Index.X"],
    }
    z = read_exr_channels(root / "exr/left/000000.exr")["ViewLayer.Depth.Z"]
    assert z[0, 0] == np.float32(1e10)


def test_reader_returns_exact_passes(tiny):
    root, frames, K, T = tiny
    seq = open_sequence(root)
    assert isinstance(seq, RenderSequence) and isinstance(seq, Sequence)
    assert seq.resolution == (6, 4) and seq.num_frames == 2 and seq.views == ("left", "right")
    assert seq.baseline_m == 0.3 and np.array_equal(seq.K, K)
    assert seq.noise == (2.0, 5)
    for k in range(2):
        for v in ("left", "right"):
            rgb, z, ids = frames[k][v]
            assert np.array_equal(seq.rgb_linear(k, v), rgb)
            d = seq.depth(k, v)
            assert d.dtype == np.float32 and np.isposinf(d[0, 0])
            assert np.array_equal(d[1:], z[1:])
            got_ids = seq.ids(k, v)
            assert got_ids.dtype == np.int32 and np.array_equal(got_ids, ids)
            assert seq.frame_complete(k)
    assert np.allclose(seq.T_world_cam("left"), T)
    Tr = seq.T_world_cam("right")
    assert np.allclose(Tr[1][:3, 3], [0.3, 0, 0.5])


def test_srgb8_uses_the_srgb_transfer_function(tiny):
    root, frames, _, _ = tiny
    seq = RenderSequence(root)
    rgb = frames[0]["left"][0]
    got = seq.image_rgb(0, "left")
    want = np.vectorize(_srgb_reference)(rgb.astype(float))
    assert got.dtype == np.uint8 and got.shape == (4, 6, 3)
    assert np.abs(got.astype(int) - want).max() == 0
    # the linear segment and mid-grey, spelled out
    assert _srgb_reference(0.0031308 / 2) == round(12.92 * 0.0031308 / 2 * 255)
    assert _srgb_reference(0.2158605) == 128 and _srgb_reference(0.18) == 118
    g = seq.image_gray(0, "left")
    assert g.dtype == np.uint8 and g.shape == (4, 6)
    want_g = np.floor(got.astype(float) @ [0.299, 0.587, 0.114] + 0.5)
    assert np.abs(g.astype(int) - want_g).max() <= 1


def test_plane_scene_depth_is_analytic(tmp_path):
    seq = open_sequence(plane_scene(tmp_path / "p", frames=2))
    assert np.allclose(seq.depth(1, "right"), 4.0)
    assert np.all(seq.ids(0) == 7)


def test_manifest_json_file_path_also_opens(tiny):
    assert open_sequence(tiny[0] / "manifest.json").num_frames == 2


# --- errors -----------------------------------------------------------------------------

def _edit_manifest(root, **changes):
    m = json.loads((root / "manifest.json").read_text())
    for k, v in changes.items():
        if v is None:
            del m[k]
        else:
            m[k] = v
    write_manifest_dict(root, m)


def test_wrong_format_version(tiny):
    _edit_manifest(tiny[0], format="sesgen-render/2")
    with pytest.raises(VoError, match="sesgen-render/2.*not supported"):
        open_sequence(tiny[0])


def test_missing_key(tiny):
    _edit_manifest(tiny[0], poses=None)
    with pytest.raises(VoError, match="missing key.*poses"):
        RenderSequence(tiny[0])


def test_corrupt_manifest(tiny):
    (tiny[0] / "manifest.json").write_text("{not json")
    with pytest.raises(VoError, match="not valid JSON"):
        RenderSequence(tiny[0])


def test_missing_exr_file(tiny):
    (tiny[0] / "exr/right/000001.exr").unlink()
    seq = RenderSequence(tiny[0])
    assert seq.frame_complete(0) and not seq.frame_complete(1)
    with pytest.raises(VoError, match="000001.exr: no such EXR file"):
        seq.depth(1, "right")


def test_corrupt_exr_file(tiny):
    p = tiny[0] / "exr/left/000000.exr"
    p.write_bytes(p.read_bytes()[:100])
    with pytest.raises(VoError, match="not a readable EXR"):
        RenderSequence(tiny[0]).image_rgb(0)


def test_missing_pass(tmp_path):
    K = np.array([[10.0, 0, 1.5], [0, 10.0, 1.5], [0, 0, 1]])
    fr = [{"left": (np.zeros((4, 4, 3)), np.ones((4, 4)), np.zeros((4, 4)))}]
    root = write_render(tmp_path / "r", K=K, baseline_m=0.0, T_world_left=np.eye(4)[None], frames=fr,
                        drop_passes=("Depth",))
    seq = open_sequence(root)
    assert seq.views == ("left",) and seq.baseline_m == 0.0
    seq.image_rgb(0)  # fine
    with pytest.raises(VoError, match="missing Depth pass.*ViewLayer.Depth.Z"):
        seq.depth(0)


def test_frame_and_view_out_of_range(tiny):
    seq = RenderSequence(tiny[0])
    with pytest.raises(VoError, match="out of range"):
        seq.image_rgb(2)
    with pytest.raises(VoError, match="view 'middle'"):
        seq.depth(0, "middle")


def test_blender4_index_pass_name_and_other_layer_name(tmp_path):
    """4.x called the pass IndexOB; a renamed view layer still reads."""
    p = tmp_path / "x.exr"
    write_exr_parts(p, {"L.Combined": {f"L.Combined.{c}": np.zeros((2, 3), np.float32) for c in "RGBA"},
                        "L.Depth": {"L.Depth.Z": np.full((2, 3), 2.0, np.float32)},
                        "L.IndexOB": {"L.IndexOB.X": np.full((2, 3), 4.0, np.float32)}})
    from vo_reference.io.exr import find_pass
    ch = read_exr_channels(p)
    assert find_pass(ch, ("Object Index", "IndexOB"), ("X",)) == ["L.IndexOB.X"]
    assert find_pass(ch, ("Depth",), ("Z",)) == ["L.Depth.Z"]


def test_not_a_sequence_folder(tmp_path):
    with pytest.raises(VoError, match="neither a render folder"):
        open_sequence(tmp_path)
    with pytest.raises(VoError, match="no such folder"):
        open_sequence(tmp_path / "nope")


def test_frames_complete_state_and_timestamps_from_manifest(tiny):
    _edit_manifest(tiny[0], frames_complete=[True, False], fps=25.0, timestamps=[0.0, 0.04])
    seq = RenderSequence(tiny[0])
    assert seq.frame_complete(0) and not seq.frame_complete(1)
    assert np.allclose(seq.timestamps_s, [0.0, 0.04])
    _edit_manifest(tiny[0], timestamps=None)
    assert np.allclose(RenderSequence(tiny[0]).timestamps_s, [0.0, 0.04])  # from fps


def test_manifest_channel_names_are_used(tmp_path):
    """The renderer records the channel names; a renamed view layer is found through them."""
    K = np.array([[10.0, 0, 1.5], [0, 10.0, 1.5], [0, 0, 1]])
    H = W = 4
    root = tmp_path / "r"
    write_render(root, K=K, baseline_m=0.0, T_world_left=np.eye(4)[None],
                 frames=[{"left": (np.zeros((H, W, 3)), np.ones((H, W)), np.zeros((H, W)))}])
    parts = {"Main.Combined": {f"Main.Combined.{c}": np.full((H, W), 0.5, np.float32) for c in "RGBA"},
             "Main.Depth": {"Main.Depth.Z": np.full((H, W), 2.5, np.float32)},
             "Main.Depth2": {"Other.Depth.Z": np.full((H, W), 9.0, np.float32)},
             "Main.Object Index": {"Main.Object Index.X": np.full((H, W), 3.0, np.float32)}}
    write_exr_parts(root / "exr/left/000000.exr", parts)
    _edit_manifest(root, channels={"rgb": [f"Main.Combined.{c}" for c in "RGBA"], "depth": "Main.Depth.Z",
                                   "object_index": "Main.Object Index.X"})
    seq = RenderSequence(root)
    assert np.all(seq.depth(0) == 2.5) and np.all(seq.ids(0) == 3) and np.all(seq.rgb_linear(0) == 0.5)
