"""The manifest is sealed and ``verify`` checks everything it lists.

A render folder says what it holds only through its manifest: a manifest edited afterwards
(K, baseline) must not pass ``verify`` nor be exported as the truth; ``verify`` compares
``scene.ses`` with the manifest's SHA-256 and checks every file the manifest lists (display
PNGs, sensor images, lens tables, IMU streams), not only the EXRs; a reader never substitutes
one product for a missing one. Render folders here are written without Blender
(tests/synthetic_render.py), completed with the files a real render has, each recorded with
its SHA-256 by the manifest's own writer.
"""
from __future__ import annotations

import hashlib
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cv2")
pytest.importorskip("OpenEXR")

from synthetic_render import COMPLETE_SCRIPT as SCRIPT, complete_render  # noqa: E402

from blender_sesgen.contract.manifest import display_relpath, seal_of  # noqa: E402
from markers import examples  # noqa: E402
from render_support import cli_in_process  # noqa: E402



def verify(root: Path, *args) -> subprocess.CompletedProcess:
    return cli_in_process("blender_sesgen", "verify", root, *args)


def export(root: Path, out: Path, target: str = "kitti-folder") -> subprocess.CompletedProcess:
    return cli_in_process("vo_reference", "export", root, out, "--to", target, "--progress", "off")


def edit_manifest(root: Path, change) -> None:
    """Edit manifest.json as a person would: load, change a value, save (seal untouched)."""
    m = json.loads((root / "manifest.json").read_text())
    change(m)
    (root / "manifest.json").write_text(json.dumps(m, indent=1))


def test_a_clean_render_verifies(tmp_path):
    r = verify(complete_render(tmp_path / "r"))
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.parametrize("what", ["K", "baseline", "pose", "checksum", "seal removed"])
def test_a_hand_edited_manifest_fails_verify_and_is_never_exported(tmp_path, what):
    root = complete_render(tmp_path / "r")
    before = None

    def change(m):
        nonlocal before
        if what == "K":
            m["K"][0][0] *= 1.01
        elif what == "baseline":
            m["baseline"] = 0.25
        elif what == "pose":
            m["poses"]["left"][1][0][3] += 0.05
        elif what == "checksum":
            m["checksums"]["exr/left/000001.exr"] = "0" * 64
        else:
            del m["seal"]
            m["K"][0][0] *= 1.01
        before = json.dumps(m, sort_keys=True)
    edit_manifest(root, change)
    r = verify(root)
    assert r.returncode == 1, r.stdout + r.stderr
    assert "manifest.json" in r.stdout and "Traceback" not in r.stderr
    assert json.dumps(json.loads((root / "manifest.json").read_text()), sort_keys=True) == before  # not re-sealed
    if what != "seal removed":   # a manifest without a seal is read (older renders); verify names it
        e = export(root, tmp_path / "E")
        # refused: by the seal, or first by a value no render has (a baseline the poses do not show)
        why = "baseline" if what in ("baseline", "pose") else "seal"
        assert e.returncode == 2 and why in e.stderr and e.stderr.strip().count("\n") == 0, e.stderr
        assert not (tmp_path / "E").exists()


@pytest.mark.parametrize("what", ["baseline", "right pose"])
def test_a_resealed_manifest_whose_right_camera_leaves_the_rig_is_refused(tmp_path, what):
    """The seal is a checksum, not a signature: an edit sealed again (found by the campaign:
    a right pose's x from 0.2 to 1e-320) passes it, so the reader checks what holds in every
    render: the right camera is the left one moved by the baseline along its x axis."""
    root = complete_render(tmp_path / "r")

    def change(m):
        if what == "baseline":
            m["baseline"] = 0.25
        else:
            m["poses"]["right"][0][0][3] = 1e-320
        m["seal"] = seal_of(m)
    edit_manifest(root, change)
    r = verify(root)
    assert r.returncode == 2 and "poses['right'][0]" in r.stderr and "baseline" in r.stderr, r.stdout + r.stderr
    e = export(root, tmp_path / "E")
    assert e.returncode == 2 and "baseline" in e.stderr and not (tmp_path / "E").exists(), e.stderr


def test_the_seal_is_the_sha256_of_the_rest_of_the_manifest(tmp_path):
    """An independent computation: canonical JSON (sorted keys, no spaces) without the seal."""
    root = complete_render(tmp_path / "r")
    m = json.loads((root / "manifest.json").read_text())
    body = {k: v for k, v in m.items() if k != "seal"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    assert m["seal"] == hashlib.sha256(text.encode()).hexdigest() == seal_of(m)


def test_verify_compares_scene_ses_with_the_manifests_sha256(tmp_path):
    root = complete_render(tmp_path / "r")
    (root / "scene.ses").write_text(SCRIPT.replace("baseline 0.2", "baseline 0.3"))
    r = verify(root)
    assert r.returncode == 1 and "scene.ses" in r.stdout, r.stdout
    (root / "scene.ses").unlink()
    r = verify(root)
    assert r.returncode == 1 and "scene.ses: missing" in r.stdout, r.stdout


@pytest.mark.parametrize("damage", ["delete", "change", "truncate"])
def test_verify_checks_the_display_pngs_and_marks_their_frame(tmp_path, damage):
    root = complete_render(tmp_path / "r")
    png = root / display_relpath("right", 1)
    if damage == "delete":
        png.unlink()
    elif damage == "change":
        import cv2
        img = cv2.imread(str(png))
        img[0, 0] ^= 1
        cv2.imwrite(str(png), img)
    else:
        png.write_bytes(png.read_bytes()[:200])
    r = verify(root, "--dry-run")
    assert r.returncode == 1 and "frame 1:" in r.stdout and "rgb/right/000001.png" in r.stdout, r.stdout
    assert json.loads((root / "manifest.json").read_text())["frames_complete"] == [True] * 3
    r = verify(root)
    assert json.loads((root / "manifest.json").read_text())["frames_complete"] == [True, False, True]
    assert verify(root).returncode == 0       # frame 1 is now recorded as not rendered: nothing to check


@pytest.mark.parametrize("rel", ["imu/data.csv", "poses/left.tum.txt"])
def test_verify_checks_the_files_listed_once_per_render(tmp_path, rel):
    root = complete_render(tmp_path / "r")
    with open(root / rel, "a") as f:
        f.write("0,0,0,0,0,0,0\n")
    r = verify(root)
    assert r.returncode == 1 and rel in r.stdout and "SHA-256" in r.stdout, r.stdout
    (root / rel).unlink()
    r = verify(root)
    assert r.returncode == 1 and f"{rel}: missing" in r.stdout, r.stdout


def test_a_missing_display_png_is_never_replaced_by_another_image(tmp_path):
    """The export used to encode the EXR to sRGB in its place: about 9.5 grey levels off the
    display image Blender wrote through the view transform."""
    from vo_reference.io.render import RenderSequence
    root = complete_render(tmp_path / "r")
    (root / display_relpath("left", 2)).unlink()
    seq = RenderSequence(root)
    assert not seq.frame_complete(2) and seq.frame_complete(1)
    with pytest.raises(Exception, match="missing"):
        seq.image_rgb(2, "left")
    e = export(root, tmp_path / "E")
    assert e.returncode == 2 and "(2)" in e.stderr and "not rendered completely" in e.stderr, e.stderr
    assert export(root, tmp_path / "E2", "png").returncode == 2
    assert np.array_equal(seq.image_rgb(1, "left"),
                          __import__("cv2").imread(str(root / display_relpath("left", 1)))[..., ::-1])


def test_the_written_seal_is_the_seal_of_what_the_file_holds():
    """The writer makes the manifest's text and its seal's canonical JSON from one encoding
    (contract.atomic.dumps_json_sealed); seal_of, what verify recomputes, is json's own
    canonical form: the two must agree on any document, not only on manifests."""
    from hypothesis import given, settings, strategies as st

    from blender_sesgen.contract.atomic import dumps_json, dumps_json_sealed
    from blender_sesgen.contract.manifest import SEAL, _sha256_hex

    leaf = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                     st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=6))
    doc = st.recursive(leaf, lambda inner: st.one_of(st.lists(inner, max_size=20),
                                                     st.dictionaries(st.text(max_size=5), inner, max_size=6)),
                       max_leaves=60)

    @settings(max_examples=examples(300), deadline=None)
    @given(st.dictionaries(st.text(max_size=5).filter(lambda k: k != SEAL), doc, max_size=8))
    def check(m):
        text, seal = dumps_json_sealed(m, SEAL, _sha256_hex)
        back = json.loads(text)
        assert back.pop(SEAL) == seal == seal_of(m)
        assert back == json.loads(json.dumps(m)) == json.loads(dumps_json(m))

    check()
