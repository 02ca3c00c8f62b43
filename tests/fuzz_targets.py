"""Fuzz targets shared by the CI fuzz tests (``test_fuzz_readers.py``, hypothesis, bounded)
and the local campaign (``bench/fuzz_campaign.py``, many more mutants, each in a child
process so that a crash or a hang is counted, not fatal).

A target is a valid input file (the *seed*), written into a fresh folder, and a consumer
that feeds a file through a public reader or command of ``vo_reference``. A *mutant* is the
seed after a list of mutation operations (:func:`mutate`): byte flips, truncation,
insertion, deletion, and for text files the replacement of a number by an "interesting"
value (nan, -inf, 1e308, 0, a non-ASCII digit...). The promise checked: the consumer
returns (the command exits 0) or fails with a user error (``VoError``/``ContractError``,
exit 2) whose message is one line; anything else -- a traceback, another exit code -- is a
finding.
"""
from __future__ import annotations

import contextlib
import copy
import io
import json
import random
import re
import shutil
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from blender_sesgen.contract.errors import ContractError
from blender_sesgen.errors import SesgenError
from vo_reference.errors import VoError

USER_ERRORS = (VoError, ContractError, SesgenError)
INTERESTING = ["nan", "-nan", "inf", "-inf", "1e308", "-1e308", "1e999", "0", "-0", "1e-320", "1e9", "1e10",
               "99999999999999999999", "", "x", "\u0661", "\u00a0", ",", "#", "1,2", "0x10", "1_0", "+", "-",
               ".", "e5", "-1", "2147483648", "\x00"]
VALUES = ["0", "-0", "1e-320", "1e8", "-1e8", "1e-8", "1", "-1", "0.5", "999999999", "3.14159", "1e-300"]
_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


# --- mutations ------------------------------------------------------------------------------

def mutate(data: bytes, ops: list[tuple]) -> bytes:
    """Apply mutation operations in order. Positions are fractions of the current length."""
    b = bytearray(data)
    for op in ops:
        kind, a = op[0], op[1]
        at = min(int(a * len(b)), max(len(b) - 1, 0))
        if kind == "flip" and b:
            b[at] ^= op[2] or 1
        elif kind == "truncate":
            del b[int(a * len(b)):]
        elif kind == "insert":
            b[at:at] = op[2]
        elif kind == "delete":
            del b[at:at + op[2]]
        elif kind == "duplicate":
            b[at:at] = b[at:at + op[2]]
        elif kind == "number":  # replace the k-th number (k as a fraction of their count)
            hits = list(_NUMBER.finditer(bytes(b)))
            if hits:
                m = hits[min(int(a * len(hits)), len(hits) - 1)]
                b[m.start():m.end()] = op[2].encode("utf-8")
        elif kind == "fixcrc":  # a PNG's CRCs made right again, so the mutation reaches the decoder
            b = bytearray(_fix_png_crcs(bytes(b)))
        elif kind == "reseal":  # a manifest sealed again, so the mutation reaches its validation
            b = bytearray(reseal(bytes(b)))
        elif kind in ("dupline", "dropline", "swapline"):  # whole lines: order, repeats, gaps
            lines = bytes(b).split(b"\n")
            i = min(int(a * len(lines)), len(lines) - 1)
            j = min(int(op[2] * len(lines)), len(lines) - 1)
            if kind == "dupline":
                lines.insert(j, lines[i])
            elif kind == "dropline" and len(lines) > 1:
                del lines[i]
            else:
                lines[i], lines[j] = lines[j], lines[i]
            b = bytearray(b"\n".join(lines))
    return bytes(b)


def _fix_png_crcs(data: bytes) -> bytes:
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return data
    b, pos = bytearray(data), 8
    while pos + 12 <= len(b):
        length = int.from_bytes(b[pos:pos + 4], "big")
        end = pos + 12 + length
        if end > len(b):
            break
        b[end - 4:end] = (zlib.crc32(bytes(b[pos + 4:end - 4])) & 0xFFFFFFFF).to_bytes(4, "big")
        pos = end
    return bytes(b)


def reseal(data: bytes) -> bytes:
    """A manifest (JSON object with a seal) with its seal made right again; else unchanged."""
    from blender_sesgen.contract.manifest import SEAL, seal_of
    try:
        doc = json.loads(data)
        if isinstance(doc, dict) and SEAL in doc:
            doc[SEAL] = seal_of(doc)
            return json.dumps(doc, indent=1).encode()
    except (ValueError, TypeError, RecursionError):
        pass
    return data


def random_ops(rng: random.Random, text: bool, n_max: int = 4) -> list[tuple]:
    ops = []
    for _ in range(rng.randint(1, n_max)):
        kind = rng.choice(["number", "number", "value", "value", "value", "dupline", "dropline", "swapline",
                           "flip", "truncate", "insert", "delete", "duplicate"]
                          if text else ["flip", "flip", "flip", "truncate", "insert", "delete", "duplicate"])
        a = rng.random()
        if kind == "flip":
            ops.append((kind, a, rng.randint(1, 255)))
        elif kind == "truncate":
            ops.append((kind, a))
        elif kind == "insert":
            ops.append((kind, a, rng.choice([b"\n", b" ", b"\x00", b"nan ", b"1e308 ", b"\xff\xfe", b"\r",
                                             bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))])))
        elif kind in ("delete", "duplicate"):
            ops.append((kind, a, rng.randint(1, 64)))
        elif kind in ("dupline", "dropline", "swapline"):
            ops.append((kind, a, rng.random()))
        elif kind == "value":  # a valid number in an odd place: deeper code sees it
            ops.append(("number", a, rng.choice(VALUES)))
        else:
            ops.append((kind, a, rng.choice(INTERESTING)))
    if not text and rng.random() < 0.5:
        ops.append(("fixcrc", 0.0))
    if text and rng.random() < 0.5:
        ops.append(("reseal", 0.0))
    return ops


def mutate_json(doc, rng: random.Random, n: int = 2):
    """Structure-aware: replace, delete or retype ``n`` random leaves or members of a JSON doc."""
    doc = json.loads(json.dumps(doc))
    values = [None, True, "", "x", 0, -1, 1e308, -1e308, 1e-320, 2**63, [], {}, [0, 0], [[0, 0, 0]] * 3,
              "left", ["right"], 1.5, "../../../etc/passwd", "/etc/passwd"]
    for _ in range(n):
        paths = list(_paths(doc))
        if not paths:
            break
        path = rng.choice(paths)
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        key = path[-1]
        if isinstance(parent, dict) and rng.random() < 0.25:
            del parent[key]
        elif isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool) and rng.random() < 0.5:
            parent[key] = rng.choice([0.0, -parent[key], parent[key] * 1e12, parent[key] + 1e-9, 1e308])
        else:   # a copy: a shared list could be put inside itself by the next mutation
            parent[key] = copy.deepcopy(rng.choice(values))
    return doc


def _paths(node, prefix=()):
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield prefix + (key,)
        if isinstance(value, (dict, list)) and len(prefix) < 4:
            yield from _paths(value, prefix + (key,))


# --- running a command in-process -----------------------------------------------------------

def vo(*argv) -> int:
    """``python -m vo_reference ARGV`` in-process: its exit code; printing suppressed. A user
    error is exit 2; any other exception propagates (a finding)."""
    from vo_reference.commands.main import main
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
        code = main([str(a) for a in argv])
    if code == 2:
        lines = err.getvalue().strip().splitlines()
        if len(lines) != 1:
            raise AssertionError(f"exit 2 with {len(lines)} lines on stderr: {err.getvalue()[:500]!r}")
    if code not in (0, 2):
        raise AssertionError(f"exit code {code}: {err.getvalue()[-500:]!r}")
    EXITS.append(code)
    return code


EXITS: list[int] = []  # exit codes of the commands the current mutant ran


# --- the targets ------------------------------------------------------------------------------

@dataclass
class Target:
    name: str
    text: bool                              # mutate numbers as text too
    setup: Callable[[Path], Path]           # writes the fixture into a folder, returns the file to mutate
    consume: Callable[[Path, Path], None]   # (mutated file, folder) -> reads it; raises on a finding
    json_doc: bool = False                  # also structure-aware JSON mutations


def _trajectory_T(n: int = 12) -> np.ndarray:
    from blender_sesgen.contract.se3 import se3_exp
    T = [np.eye(4)]
    for k in range(1, n):
        T.append(T[-1] @ se3_exp([0.002 * k, 0.01, 0.0], [0.1, 0.0, 10.0]))  # 10 m steps: KITTI segments fit
    return np.stack(T)


def _write_gt(folder: Path) -> Path:
    from blender_sesgen.contract.trajectory_files import format_tum
    T = _trajectory_T()
    return _put(folder / "gt.tum", format_tum(np.arange(len(T)) * 0.1, T))


def _put(path: Path, text) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


def _setup_tum(folder: Path) -> Path:
    from blender_sesgen.contract.trajectory_files import format_tum
    T = _trajectory_T()
    T[:, :3, 3] *= 1.1
    _write_gt(folder)
    return _put(folder / "est.tum", format_tum(np.arange(len(T)) * 0.1 + 0.001, T))


def _setup_kitti_poses(folder: Path) -> Path:
    from blender_sesgen.contract.trajectory_files import format_kitti
    _write_gt(folder)
    return _put(folder / "est.txt", format_kitti(_trajectory_T()))


def _setup_euroc(folder: Path) -> Path:
    from blender_sesgen.contract.trajectory_files import format_euroc
    T = _trajectory_T()
    _write_gt(folder)
    return _put(folder / "est.csv", format_euroc(np.arange(len(T)) * 100_000_000, T))


def _consume_evaluate(path: Path, folder: Path) -> None:
    gt = folder / "gt.tum"
    kitti = path.suffix == ".txt"
    for extra in (["--align", "se3", "--egomotion"], ["--align", "sim3", "--kitti", "--delta", "2"]):
        if kitti:  # KITTI carries no timestamps: both sides by index, ground truth as KITTI too
            from vo_reference.io.trajectory import read_tum, write_kitti
            gtk = folder / "gt_kitti.txt"
            if not gtk.exists():
                write_kitti(gtk, read_tum(gt))
            vo("evaluate", "--gt", gtk, "--est", path, *extra)
        else:
            vo("evaluate", "--gt", gt, "--est", path, *extra)


def _render(folder: Path) -> Path:
    """A 3-frame stereo render (160 x 120) of a textured slanted plane, ray cast by
    ``stereo_synth`` (so stereo and mono VO succeed on the seed and mutants reach their maths)."""
    import stereo_synth as S
    from synthetic_render import write_render
    saved = S.F, S.W, S.H, S.K
    S.F, S.W, S.H = 150.0, 160, 120
    S.K = np.array([[S.F, 0, (S.W - 1) / 2], [0, S.F, (S.H - 1) / 2], [0, 0, 1.0]])
    try:
        frames, T = S.sequence(S.smooth_twists(2), seed=2)
        K = S.K
    finally:
        S.F, S.W, S.H, S.K = saved
    fr = []
    for f in frames:
        views = {}
        for v, dk in (("left", "depth"), ("right", "depth_right")):
            lin = (f[v].astype(np.float32) / 255.0) ** 2.2
            views[v] = (np.repeat(lin[..., None], 3, axis=2), f[dk], np.full(f[dk].shape, 3, np.int32))
        fr.append(views)
    return write_render(folder / "render", K=K, baseline_m=S.B, T_world_left=T, frames=fr)


def _setup_manifest(folder: Path) -> Path:
    from vo_reference.io.trajectory import read_render_poses, write_tum
    root = _render(folder)
    est = read_render_poses(root)
    est.T_world_cam[:, :3, 3] *= 1.05
    write_tum(folder / "est.tum", est)
    return root / "manifest.json"


def _consume_manifest(path: Path, folder: Path) -> None:
    root = path.parent
    vo("evaluate", "--gt", root, "--est", folder / "est.tum", "--align", "sim3", "--egomotion")
    out = folder / "export"
    shutil.rmtree(out, ignore_errors=True)
    vo("export", root, out, "--to", "kitti-folder", "-q")
    vo("stereo-vo", root, "--out", folder / "e.txt", "--quiet", "--method", "paper")


def _setup_manifest_sensor(folder: Path) -> Path:
    """A render whose manifest carries the sensor statements' sections (rig motion, rolling
    shutter timing, a Brown-Conrady lens), so that mutants reach those readers."""
    from blender_sesgen.contract.manifest import MANIFEST
    from synthetic_render import write_manifest_dict
    root = _render(folder)
    m = json.loads((root / MANIFEST).read_text())
    m["rig_motion"] = {"interpolation": "c2_spline", "rate_hz": 1.0, "start_s": 0.0}
    m["timing"] = {"rate_hz": 1.0, "start_s": 0.0, "exposure_s": 0.01, "readout_s": 0.02}
    m["lens"] = {"model": "brown", "coeffs": [-0.1, 0.02, 0.001, -0.001, 0.0]}
    return write_manifest_dict(root, m)


def _consume_manifest_sensor(path: Path, folder: Path) -> None:
    """The readers of those sections (API: there is no command for them)."""
    from vo_reference.io.render import RenderSequence
    seq = RenderSequence(path.parent)
    rows = seq.T_world_cam_rows(1)
    assert rows.shape == (seq.resolution[1], 4, 4)
    seq.T_world_cam_at([0.25, 1.5])
    lens = seq.lens
    if lens is not None:
        lens.project(np.array([[0.1, -0.2, 2.0], [0.0, 0.0, 1.0]]))


def _setup_done_log(folder: Path) -> Path:
    """A render whose frames are recorded complete in a completion log, not the manifest."""
    from blender_sesgen.contract.manifest import MANIFEST, STATE_DIR
    from synthetic_render import write_manifest_dict
    root = _render(folder)
    m = json.loads((root / MANIFEST).read_text())
    m["frames_complete"] = [False] * len(m["frames_complete"])
    write_manifest_dict(root, m)
    lines = [json.dumps({"frame": k, "files": {f"exr/{v}/{k:06d}.exr": "0" * 64 for v in ("left", "right")}})
             for k in range(len(m["frames_complete"]))]
    return _put(root / STATE_DIR / "done-host-1.jsonl", "\n".join(lines) + "\n")


def _consume_done_log(path: Path, folder: Path) -> None:
    root = folder / "render"
    vo("stereo-vo", root, "--out", folder / "e.txt", "--quiet", "--gt-depth", "--method", "paper")
    out = folder / "export"
    vo("export", root, out, "--to", "png", "-q")


def _setup_exr(folder: Path) -> Path:
    return _render(folder) / "exr" / "left" / "000001.exr"


def _consume_exr(path: Path, folder: Path) -> None:
    root = folder / "render"
    out = folder / "export"
    shutil.rmtree(out, ignore_errors=True)
    vo("export", root, out, "--to", "png", "-q")
    vo("stereo-vo", root, "--out", folder / "e.txt", "--quiet", "--gt-depth", "--gt-flow")


def _kitti_folder(folder: Path) -> Path:
    root = _render(folder)
    out = folder / "kitti"
    if vo("export", root, out, "--to", "kitti-folder", "-q") != 0:
        raise RuntimeError("could not build the KITTI fixture")
    return out


def _setup_calib(folder: Path) -> Path:
    return _kitti_folder(folder) / "calib.txt"


def _setup_kitti_folder_poses(folder: Path) -> Path:
    return _kitti_folder(folder) / "poses.txt"


def _consume_kitti_folder(path: Path, folder: Path) -> None:
    root = path.parent
    vo("stereo-vo", root, "--out", folder / "e.txt", "--quiet")
    vo("mono-vo", root, "--out", folder / "m.txt", "-q")


def _setup_pfm(folder: Path) -> Path:
    from vo_reference.io.pfm import write_pfm
    d = np.linspace(1, 30, 6 * 8, dtype=np.float32).reshape(6, 8)
    write_pfm(folder / "gt.pfm", d)
    return write_pfm(folder / "est.pfm", d + 0.3)


def _setup_png16(folder: Path) -> Path:
    from vo_reference.groundtruth.disparity import write_disparity_png16
    d = np.linspace(1, 30, 6 * 8, dtype=np.float32).reshape(6, 8)
    d[0, 0] = np.nan
    write_disparity_png16(folder / "gt.png", d)
    return write_disparity_png16(folder / "est.png", d + 0.5)


def _consume_disparity(path: Path, folder: Path) -> None:
    vo("evaluate-disparity", "--gt", folder / f"gt{path.suffix}", "--est", path)


def _setup_flow_png(folder: Path) -> Path:
    from vo_reference.groundtruth.flow import write_kitti_flow_png
    f = np.stack(np.meshgrid(np.linspace(-3, 3, 8), np.linspace(-2, 2, 6)), -1).astype(np.float32)
    return write_kitti_flow_png(folder / "flow.png", f)


def _consume_flow_png(path: Path, folder: Path) -> None:
    from vo_reference.groundtruth.flow import read_kitti_flow_png
    flow, valid = read_kitti_flow_png(path)
    assert flow.shape[:2] == valid.shape


def _texture_setup(kind: str):
    def setup(folder: Path) -> Path:
        import cv2
        img = (np.random.default_rng(0).random((24, 32, 3)) * 255).astype(np.uint8)
        if kind == "exr":
            from vo_reference.io.exr import write_exr_parts
            path = write_exr_parts(folder / "tex.exr", {"RGB": {c: img[..., i].astype(np.float32) / 255
                                                                for i, c in enumerate("BGR")}})
        else:
            path = folder / f"tex.{kind}"
            path.write_bytes(cv2.imencode(f".{kind}", img)[1].tobytes())
        _put(folder / "s.ses", f"QUAD id 1 vertices 0 0 0 1 0 0 1 1 0 0 1 0 texture {path.name}\n")
        return path
    return setup


def _consume_texture(path: Path, folder: Path) -> None:
    """``check`` on a script whose texture is the mutant (a ScriptError is the user error)."""
    from blender_sesgen.ses import parse_file
    parse_file(folder / "s.ses")


# --- a render folder, damaged: verify must see every change ----------------------------------------

def _render_file(rel: str):
    """A complete synthetic render (display PNGs, scene.ses, IMU stream, every SHA-256); the
    file ``rel`` of it is mutated (its original kept beside, for the oracle)."""
    def setup(folder: Path) -> Path:
        from synthetic_render import complete_render
        root = complete_render(folder / "render")
        (folder / "orig.bin").write_bytes((root / rel).read_bytes())
        return root / rel
    return setup


def _changed(path: Path, folder: Path) -> bool:
    """Whether the mutant differs from the original in what it says (a manifest: its JSON
    values; anything else: its bytes; not a regular file: changed)."""
    orig = (folder / "orig.bin").read_bytes()
    if path.is_symlink() or not path.is_file() or path.stat().st_size > 2 * len(orig) + (1 << 20):
        return True   # (an injected 5 GiB file is not read into memory to be compared)
    data = path.read_bytes()
    if path.name == "manifest.json":
        try:
            return json.loads(data) != json.loads(orig)
        except (ValueError, RecursionError):
            return True
    return data != orig


def _sealed_again(path: Path) -> bool:
    """A manifest whose seal matches its changed content: the seal is a checksum, not a
    signature, so verify may pass it (the reader has refused what is inconsistent)."""
    from blender_sesgen.contract.manifest import SEAL, seal_problem
    if path.name != "manifest.json" or path.is_symlink() or not path.is_file() or path.stat().st_size > 64 << 20:
        return False
    try:
        m = json.loads(path.read_bytes())
    except (ValueError, RecursionError):
        return False
    return isinstance(m, dict) and SEAL in m and not seal_problem(m)


def _consume_damaged_render(path: Path, folder: Path) -> None:
    """``verify --dry-run`` must fail (1, or 2 for a manifest that does not read) exactly when
    the file changed; the reader and an export then read the folder or refuse it."""
    root = folder / "render"
    code = sesgen("verify", root, "--dry-run", "--quiet")
    changed = _changed(path, folder)
    if changed and code == 0 and not _sealed_again(path):
        raise AssertionError(f"verify passed a changed {path.name}")
    if not changed and code != 0:
        raise AssertionError(f"verify failed an unchanged {path.name} (exit {code})")
    out = folder / "export"
    shutil.rmtree(out, ignore_errors=True)
    vo("export", root, out, "--to", "png", "-q")


def sesgen(*argv) -> int:
    """``python -m blender_sesgen ARGV`` in-process, like :func:`vo`: exit 0, 1 (a failure the
    command reports in one line) or 2 (a user error in one line); anything else raises."""
    from blender_sesgen.commands.main import main
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
        code = main([str(a) for a in argv])
    lines = err.getvalue().strip().splitlines()
    if code == 2 and len(lines) != 1:
        raise AssertionError(f"exit 2 with {len(lines)} lines on stderr: {err.getvalue()[:500]!r}")
    if code not in (0, 1, 2) or "Traceback" in err.getvalue():
        raise AssertionError(f"exit code {code}: {err.getvalue()[-500:]!r}")
    EXITS.append(code if code != 1 else 0)
    return code


# --- hostile asset files: check refuses, or what it passes is numbers -------------------------------

_TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5]], dtype="<f4")


def _model_setup(kind: str):
    def setup(folder: Path) -> Path:
        import base64
        if kind == "gltf":
            data = _TRIANGLE.tobytes() + np.array([0, 1, 2, 1, 3, 2], "<u2").tobytes()
            doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
                   "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
                   "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64,"
                                + base64.b64encode(data).decode()}],
                   "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                                   {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
                   "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                                  "min": [0, 0, 0], "max": [1, 1, 0.5]},
                                 {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
            path = _put(folder / "m.gltf", json.dumps(doc, indent=1))
        elif kind == "obj":
            path = _put(folder / "m.obj", "".join(f"v {x:g} {y:g} {z:g}\n" for x, y, z in _TRIANGLE)
                        + "f 1 2 3\nf 2 4 3\n")
        elif kind == "stl":
            tris = _TRIANGLE[[0, 1, 2, 1, 3, 2]].reshape(2, 9)
            path = _put(folder / "m.stl", b"\0" * 80 + struct.pack("<I", 2) + b"".join(
                struct.pack("<3f", 0, 0, 1) + t.tobytes() + b"\0\0" for t in tris))
        else:
            head = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n")
            path = _put(folder / "m.ply", head.encode() + _TRIANGLE.tobytes() + struct.pack("<B3iB3i", 3, 0, 1, 2,
                                                                                            3, 1, 3, 2))
        _put(folder / "s.ses", f"CAMERA resolution 32 24 focal 30\nMESH id 1 file {path.name} position 0 0 -3\n")
        return path
    return setup


def _consume_model(path: Path, folder: Path) -> None:
    """``check``; a model it passes has finite vertices within range (the OBJ's and STL's read
    here independently), and no more than the limit."""
    from blender_sesgen.ses import parse_file
    from blender_sesgen.ses.mesh_content import MAX_MESH_VERTICES
    parse_file(folder / "s.ses")
    xyz = None
    if path.suffix == ".obj":
        rows = [ln.split()[1:4] for ln in path.read_bytes().decode("utf-8", "replace").splitlines()
                if ln.split()[:1] == ["v"]]
        xyz = np.array([[float(v) for v in r] for r in rows if len(r) == 3]).reshape(-1, 3)
    elif path.suffix == ".stl" and path.stat().st_size >= 84:
        data = path.read_bytes()
        n = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * n:
            xyz = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                                count=n, offset=84)["v"].reshape(-1, 3).astype(float)
    if xyz is not None and (len(xyz) > MAX_MESH_VERTICES or not np.all(np.isfinite(xyz))
                            or np.abs(xyz).max(initial=0) > 1e9):
        raise AssertionError(f"check passed {path.name} with {len(xyz)} vertices, non-finite or out of range")


def _hdri_setup(kind: str):
    def setup(folder: Path) -> Path:
        rgb = np.random.default_rng(1).uniform(0.1, 2.0, (8, 16, 3)).astype(np.float32)
        if kind == "exr":     # uncompressed: a flipped byte is a different number (NaN, inf, 3e38...)
            import OpenEXR
            with OpenEXR.File({"compression": OpenEXR.NO_COMPRESSION, "type": OpenEXR.scanlineimage},
                              {"RGB": rgb}) as f:
                f.write(str(folder / "sky.exr"))
            path = folder / "sky.exr"
        else:                 # flat RGBE pixels
            m, e = np.frexp(rgb.max(axis=2))
            scale = np.where(rgb.max(axis=2) > 0, m * 256.0 / rgb.max(axis=2), 0)
            pix = np.concatenate([np.clip(rgb * scale[..., None], 0, 255), (e + 128)[..., None]], axis=2)
            path = _put(folder / "sky.hdr", b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n"
                        + pix.astype(np.uint8).tobytes())
        _put(folder / "s.ses", f"CAMERA resolution 32 24 focal 30\nCUBOID id 1 position 0 0 -3 dim 1 1 1\n"
                               f"WORLD hdri {path.name}\n")
        return path
    return setup


def _consume_hdri(path: Path, folder: Path) -> None:
    """``check``; an HDRI it passes decodes (OpenEXR, OpenCV: independent readers) to finite
    values within the limit."""
    import cv2
    from blender_sesgen.files.image_check import MAX_PIXEL_VALUE
    from blender_sesgen.ses import parse_file
    parse_file(folder / "s.ses")
    if path.suffix == ".exr":
        import OpenEXR
        with OpenEXR.File(str(path)) as f:
            values = [np.asarray(c.pixels, dtype=np.float64) for part in f.parts for c in part.channels.values()]
    else:
        img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        values = [] if img is None else [img.astype(np.float64)]
    for v in values:
        if not (np.all(np.isfinite(v)) and np.abs(v).max(initial=0) <= MAX_PIXEL_VALUE * 1.01):
            raise AssertionError(f"check passed {path.name} holding {np.nanmax(np.abs(v))} or non-finite values")


# --- farm indexes ------------------------------------------------------------------------------------

def _setup_scripts_index(folder: Path) -> Path:
    from blender_sesgen.commands.main import main
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["generate", "street", "--count", "2", "--seed", "3", "--out", str(folder / "gen"),
                     "-o", "steps=1", "-q"]) == 0
    return folder / "gen" / "dataset.json"


def _consume_scripts_index(path: Path, folder: Path) -> None:
    """What reads a scripts index: the farm's scene list (``farm.cli.prepare``, no Ray),
    ``generate``'s check of a folder it would replace, the index reader."""
    import argparse
    from blender_sesgen.files.dataset import read_index
    from blender_sesgen.commands import farm as farm_cli
    from blender_sesgen.commands.generate import _check_folder
    read_index(path.parent)
    p = argparse.ArgumentParser()
    farm_cli.add_arguments(p)
    try:
        farm_cli.prepare(p.parse_args([str(path.parent), "--out", str(folder / "R")]))
    except SesgenError:
        EXITS.append(2)
    try:
        _check_folder(path.parent)
    except SesgenError:
        EXITS.append(2)


def _setup_renders_index(folder: Path) -> Path:
    from blender_sesgen.files.dataset import write_render_index
    return write_render_index(folder / "R", [_farm_state("old", complete=True), _farm_state("other")])


def _farm_state(name: str, complete: bool = False, error: str | None = None):
    from blender_sesgen.farm.driver import SceneState
    from blender_sesgen.farm.work import FarmScene
    sc = FarmScene(name=name, script=Path(f"/scripts/{name}.ses"), out=Path(f"/R/{name}"),
                   meta={"split": "train", "seed": 3}, error=error)
    return SceneState(sc, complete=complete, failed=error, user_error=error is not None)


def _consume_renders_index(path: Path, folder: Path) -> None:
    """A farm writing its index over a damaged earlier one: a valid index comes out."""
    from blender_sesgen.files.dataset import FORMAT, read_index, write_render_index
    write_render_index(path.parent, [_farm_state("new", complete=True), _farm_state("old", error="x: error: y")])
    index = read_index(path.parent)
    if not (isinstance(index, dict) and index.get("format") == FORMAT and isinstance(index.get("sequences"), list)
            and {"new", "old"} <= {e.get("name") for e in index["sequences"] if isinstance(e, dict)}):
        raise AssertionError(f"the farm wrote an index that does not read back: {str(index)[:200]}")


TARGETS = {t.name: t for t in (
    Target("tum", True, _setup_tum, _consume_evaluate),
    Target("kitti-poses", True, _setup_kitti_poses, _consume_evaluate),
    Target("euroc", True, _setup_euroc, _consume_evaluate),
    Target("manifest", True, _setup_manifest, _consume_manifest, json_doc=True),
    Target("kitti-calib", True, _setup_calib, _consume_kitti_folder),
    Target("kitti-folder-poses", True, _setup_kitti_folder_poses, _consume_kitti_folder),
    Target("pfm", False, _setup_pfm, _consume_disparity),
    Target("png16-disparity", False, _setup_png16, _consume_disparity),
    Target("kitti-flow-png", False, _setup_flow_png, _consume_flow_png),
    Target("exr", False, _setup_exr, _consume_exr),
    Target("done-log", True, _setup_done_log, _consume_done_log),
    Target("manifest-sensor", True, _setup_manifest_sensor, _consume_manifest_sensor, json_doc=True),
    Target("texture-png", False, _texture_setup("png"), _consume_texture),
    Target("texture-jpeg", False, _texture_setup("jpg"), _consume_texture),
    Target("texture-exr", False, _texture_setup("exr"), _consume_texture),
    Target("render-display-png", False, _render_file("rgb/left/000001.png"), _consume_damaged_render),
    Target("render-exr-verify", False, _render_file("exr/right/000002.exr"), _consume_damaged_render),
    Target("render-manifest-seal", True, _render_file("manifest.json"), _consume_damaged_render, json_doc=True),
    Target("render-scene-ses", True, _render_file("scene.ses"), _consume_damaged_render),
    Target("render-imu-csv", True, _render_file("imu/data.csv"), _consume_damaged_render),
    Target("model-gltf", True, _model_setup("gltf"), _consume_model, json_doc=True),
    Target("model-obj", True, _model_setup("obj"), _consume_model),
    Target("model-stl", False, _model_setup("stl"), _consume_model),
    Target("model-ply", False, _model_setup("ply"), _consume_model),
    Target("hdri-exr", False, _hdri_setup("exr"), _consume_hdri),
    Target("hdri-hdr", False, _hdri_setup("hdr"), _consume_hdri),
    Target("scripts-index", True, _setup_scripts_index, _consume_scripts_index, json_doc=True),
    Target("renders-index", True, _setup_renders_index, _consume_renders_index, json_doc=True),
)}


def run_mutant(target: Target, folder: Path, path: Path, seed_bytes: bytes, ops: list[tuple],
               json_rng: random.Random | None = None) -> str:
    """Write the mutant over ``path`` and consume it: 'ok' or 'user-error' (a finding raises)."""
    if json_rng is not None:  # structure-aware mutants stay JSON (the byte-level ones rarely do)
        data = json.dumps(mutate_json(json.loads(seed_bytes), json_rng), indent=1).encode()
        if json_rng.random() < 0.75:   # mostly sealed again: the checks behind the seal are the target
            data = reseal(data)
    else:
        data = mutate(seed_bytes, ops)
    path.write_bytes(data)
    EXITS.clear()
    try:
        target.consume(path, folder)
    except USER_ERRORS as e:  # raised by a reader called directly (not through the command line)
        if "\n" in str(e).strip():
            raise AssertionError(f"a user error of several lines: {e!s:.500}") from None
        return "user-error"
    return "user-error" if 2 in EXITS else "ok"


def setup_target(target: Target, folder: Path) -> tuple[Path, bytes]:
    folder.mkdir(parents=True, exist_ok=True)
    with contextlib.redirect_stdout(io.StringIO()):
        path = target.setup(folder)
    return path, path.read_bytes()


def restore(path: Path, seed_bytes: bytes) -> None:
    path.write_bytes(seed_bytes)

