"""OpenEXR 3.x reading and writing, every part of multi-part files.

Blender 5.0 writes a multilayer EXR as one part per pass (``ViewLayer.Combined``,
``ViewLayer.Depth``, ``ViewLayer.Object Index``...), so a reader must walk all parts; a
reader that looks at the first part only (``cv2.imread``) sees just the beauty pass.
Blender 4.x writes a single part holding every pass (index pass named ``IndexOB``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.depth import depth_to_pass
from blender_sesgen.contract.exr_format import PASS_COMBINED, PASS_DEPTH, PASS_INDEX, VIEW_LAYER
from blender_sesgen.contract.inputs import check_regular

from ..errors import VoError, as_vo_error
from .native import captured_stderr, first_complaint


def read_exr_channels(path) -> dict[str, np.ndarray]:
    """All channels of all parts: full channel name -> (H, W) array (row 0 = top).

    Raises VoError for a missing file, a file OpenEXR cannot read, a part whose pixel data
    is corrupt or truncated (its header lists channels that could not be decoded), or parts
    whose sizes disagree. What OpenEXR prints about a bad file goes into that one message.
    """
    import OpenEXR
    path = Path(path)
    if not path.exists():
        raise VoError(f"{path}: no such EXR file")
    with as_vo_error():
        check_regular(path, "EXR file")
    channels: dict[str, np.ndarray] = {}
    with captured_stderr((1, 2)) as complaints:  # OpenEXR's binding prints warnings on stdout
        try:
            with OpenEXR.File(str(path), header_only=True) as f:
                declared = {p.name() or f"#{i}": [c.name for c in p.header.get("channels", [])]
                            for i, p in enumerate(f.parts)}
            with OpenEXR.File(str(path), separate_channels=True) as f:
                for part in f.parts:
                    channels.update((name, np.asarray(ch.pixels)) for name, ch in part.channels.items())
        except Exception as e:  # OpenEXR raises RuntimeError/OSError/... for bad files
            error = f"{type(e).__name__}: {e}"
        else:
            error = None
    if error is not None:
        raise VoError(f"{path}: not a readable EXR file ({error})")
    # a part whose pixel data cannot be decoded is dropped (with a warning printed), never raised
    corrupt = [name for name, names in declared.items()
               if any(n not in channels or channels[n] is None or channels[n].size == 0 for n in names)]
    if corrupt:
        why = first_complaint(complaints, path)
        raise VoError(f"{path}: corrupt or truncated EXR: the pixel data of part(s) {', '.join(corrupt)} "
                      f"cannot be decoded" + (f" ({why})" if why else ""))
    shapes = {a.shape for a in channels.values()}
    if len(shapes) > 1:
        raise VoError(f"{path}: EXR parts of different sizes {sorted(shapes)}")
    if not channels:
        raise VoError(f"{path}: EXR file has no channels")
    return channels


def write_exr_parts(path, parts: dict[str, dict[str, np.ndarray]], *, compression: str = "zip") -> Path:
    """Write a multi-part EXR (one part per key; each part's channels given by full name),
    float32/uint32/float16 as given, atomically. ``compression``: 'zip' or 'none'."""
    import OpenEXR
    path = Path(path)
    comp = {"zip": OpenEXR.ZIP_COMPRESSION, "none": OpenEXR.NO_COMPRESSION}[compression]
    oparts = []
    for pname, chans in parts.items():
        header = {"compression": comp, "type": OpenEXR.scanlineimage}
        oparts.append(OpenEXR.Part(header, {n: OpenEXR.Channel(np.ascontiguousarray(a)) for n, a in chans.items()},
                                   name=pname))
    return _write_atomic(path, OpenEXR.File(oparts))


def write_exr_single(path, channels: dict[str, np.ndarray]) -> Path:
    """Write a single-part EXR with the given channels (e.g. {'Y': disparity})."""
    import OpenEXR
    path = Path(path)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    return _write_atomic(path, OpenEXR.File(header, {n: np.ascontiguousarray(a) for n, a in channels.items()}))


def _write_atomic(path: Path, exr_file) -> Path:
    """Write an ``OpenEXR.File`` under a temporary name, then rename it into place."""
    with atomic.replacing(path) as tmp, exr_file as f:
        f.write(str(tmp))
    return path


def find_pass(channels: dict[str, np.ndarray], pass_names: tuple[str, ...], components: tuple[str, ...]):
    """The channel names ``<layer>.<pass>.<component>`` for the first pass name that has
    all ``components`` (layer 'ViewLayer' preferred, any layer accepted), or None."""
    for pname in pass_names:
        for comp_layer_first in (True, False):
            found = []
            for c in components:
                suffix = f"{pname}.{c}"
                cands = [n for n in channels if n == suffix or n.endswith("." + suffix)]
                if comp_layer_first:
                    cands = [n for n in cands if n.startswith(VIEW_LAYER + ".")]
                if not cands:
                    break
                found.append(sorted(cands)[0])
            else:
                return found
    return None


def render_exr_parts(rgb_linear: np.ndarray, depth: np.ndarray, ids: np.ndarray | None,
                     alpha: np.ndarray | None = None, layer: str = VIEW_LAYER) -> dict:
    """The parts of one render EXR as Blender 5.0 writes it (``contract.exr_format``: one part
    per pass), for :func:`write_exr_parts`: a render folder written without Blender (tests,
    benches). Depth +inf becomes the background marker (``contract.depth``)."""
    H, W = depth.shape
    z = depth_to_pass(depth)
    rgb = np.asarray(rgb_linear, dtype=np.float32)
    a = np.ones((H, W), np.float32) if alpha is None else np.asarray(alpha, np.float32)
    combined, dpass, index = PASS_COMBINED[0], PASS_DEPTH[0], PASS_INDEX[0]
    parts = {
        f"{layer}.{combined}": {f"{layer}.{combined}.{c}": np.ascontiguousarray(x)
                                for c, x in zip("RGBA", (rgb[..., 0], rgb[..., 1], rgb[..., 2], a))},
        f"{layer}.{dpass}": {f"{layer}.{dpass}.Z": z},
    }
    if ids is not None:
        parts[f"{layer}.{index}"] = {f"{layer}.{index}.X": np.asarray(ids, dtype=np.float32)}
    return parts
