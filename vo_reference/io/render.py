"""Reader of render folders in the ``sesgen-render/1`` format (docs/output-format.md).

::

    OUT/manifest.json          everything a reader needs (K, baseline, poses, files...)
    OUT/exr/left/NNNNNN.exr    multilayer EXR per frame and view, one part per pass:
    OUT/exr/right/NNNNNN.exr   ViewLayer.Combined.R/G/B/A, ViewLayer.Depth.Z,
                               ViewLayer.Object Index.X (float32)

Blender 4.x writes the same channels in one single-part file and names the index pass
``IndexOB`` (``ViewLayer.IndexOB.X``): both layouts and both names read the same.

Depth is planar z; Cycles writes 1e10 (the manifest's ``depth.background``) where a ray
hits nothing: the reader returns +inf there, never a finite depth.
"""
from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import numpy as np

from blender_sesgen.contract.colour import linear_to_srgb8
from blender_sesgen.contract.depth import depth_from_pass
from blender_sesgen.contract.manifest import MANIFEST, Manifest

from ..errors import VoError, as_vo_error
from .color import rgb8_to_gray8
from .base import check_frame_view
from .exr import find_pass, read_exr_channels
from .files import read_image

# pass name candidates (Blender 5.0 first, then 4.x names)
PASS_COMBINED = ("Combined",)
PASS_DEPTH = ("Depth",)
PASS_INDEX = ("Object Index", "IndexOB")


def read_manifest(root) -> Manifest:
    """The validated manifest of a render folder (completion logs merged); VoError on any defect."""
    root = Path(root)
    if not (root / MANIFEST).is_file():
        raise VoError(f"{root}: no manifest.json (not a render folder)")
    with as_vo_error():
        return Manifest.read(root)


class RenderSequence:
    """A render folder as a :class:`~vo_reference.io.sequence.Sequence`.

    Extras: ``manifest`` (the dict), ``root``, ``near``/``far``, ``noise`` ((sigma, seed)
    or None), ``objects``, :meth:`rgb_linear`, :meth:`alpha`, :meth:`frame_complete`,
    :meth:`exr_path`.
    """

    def __init__(self, root, cache_frames: int = 4):
        self.root = Path(root)
        self.info = m = read_manifest(self.root)
        self.manifest = m.to_json()
        self.resolution = m.resolution
        self.K = m.K
        self.baseline_m = m.baseline
        self.num_frames = m.frames
        self.views = m.views
        self.depth_background = m.depth_background
        self.near, self.far = m.near, m.far
        self.objects = m.objects
        noise = m.extra.get("noise")
        self.noise = (float(noise["sigma"]), int(noise.get("seed", 0))) if isinstance(noise, dict) else None
        self._poses = m.poses
        self._files = m.files
        self.timestamps_s = m.timestamps_s
        self._cache: OrderedDict = OrderedDict()
        self._cache_frames = max(1, int(cache_frames))

    # --- files ------------------------------------------------------------------------
    def exr_path(self, k: int, view: str = "left") -> Path:
        check_frame_view(self, k, view)
        rel = self._files[view][int(k)]
        if not rel:
            raise VoError(f"{self.root}: frame {k} ({view}) was not rendered")
        return self.root / rel

    def frame_complete(self, k: int) -> bool:
        """True when frame k is recorded complete and its EXR files exist for every view."""
        if not 0 <= int(k) < self.num_frames or not self.info.frames_complete[int(k)]:
            return False
        return all((self.root / self._files[v][int(k)]).is_file() for v in self.views)

    def _channels(self, k: int, view: str) -> dict:
        key = (int(k), view)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        path = self.exr_path(k, view)
        ch = read_exr_channels(path)
        W, H = self.resolution
        shape = next(iter(ch.values())).shape
        if shape != (H, W):
            raise VoError(f"{path}: image is {shape[1]}x{shape[0]}, manifest says {W}x{H}")
        ch["__path__"] = path
        self._cache[key] = ch
        while len(self._cache) > self._cache_frames:
            self._cache.popitem(last=False)
        return ch

    def _pass(self, k, view, names, comps, what, key=None):
        ch = self._channels(k, view)
        found = None
        named = self.info.channels.get(key) if key else None
        if named:  # the manifest names the channels: use them exactly
            named = [named] if isinstance(named, str) else list(named)[:len(comps)]
            found = named if all(n in ch for n in named) else None
        if found is None:
            found = find_pass(ch, names, comps)
        if found is None:
            have = sorted(n for n in ch if n != "__path__")
            raise VoError(f"{ch['__path__']}: missing {what} pass "
                          f"(expected ViewLayer.{names[0]}.{'/'.join(comps)}; channels: {', '.join(have)})")
        return [ch[n] for n in found]

    # --- images and ground truth ------------------------------------------------------
    def rgb_linear(self, k: int, view: str = "left") -> np.ndarray:
        """float32 (H, W, 3) scene-linear RGB (the Combined pass as written)."""
        r, g, b = self._pass(k, view, PASS_COMBINED, ("R", "G", "B"), "Combined (RGB)", "rgb")
        return np.stack([r, g, b], axis=-1).astype(np.float32)

    def alpha(self, k: int, view: str = "left") -> np.ndarray | None:
        found = find_pass(self._channels(k, view), PASS_COMBINED, ("A",))
        return None if found is None else self._channels(k, view)[found[0]].astype(np.float32)

    def display_path(self, k: int, view: str = "left") -> Path | None:
        """The display-referred 8-bit PNG of frame k (manifest ``display.files``), or None
        when the render has none (renders made before it existed)."""
        check_frame_view(self, k, view)
        files = ((self.manifest.get("display") or {}).get("files") or {}).get(view)
        if not isinstance(files, list) or len(files) != self.num_frames or not files[int(k)]:
            return None
        path = self.root / files[int(k)]
        return path if path.is_file() else None

    def image_rgb(self, k: int, view: str = "left") -> np.ndarray:
        """uint8 (H, W, 3) sRGB: the display-referred image Blender wrote through the view
        transform (manifest ``display``), else the Combined pass encoded with the sRGB
        transfer function (IEC 61966-2-1, clipped)."""
        path = self.display_path(k, view)
        if path is None:
            return linear_to_srgb8(self.rgb_linear(k, view))
        import cv2
        img = read_image(path, cv2.IMREAD_COLOR)
        W, H = self.resolution
        if img.shape[:2] != (H, W):
            raise VoError(f"{path}: image is {img.shape[1]}x{img.shape[0]}, manifest says {W}x{H}")
        return np.ascontiguousarray(img[..., ::-1])

    def image_gray(self, k: int, view: str = "left") -> np.ndarray:
        return rgb8_to_gray8(self.image_rgb(k, view))

    def depth(self, k: int, view: str = "left") -> np.ndarray:
        """float32 (H, W) planar z in metres, +inf where nothing was hit."""
        (z,) = self._pass(k, view, PASS_DEPTH, ("Z",), "Depth", "depth")
        return depth_from_pass(z, self.depth_background)

    def ids(self, k: int, view: str = "left") -> np.ndarray:
        """int32 (H, W) object ids (the script's ``id``), 0 = background."""
        (x,) = self._pass(k, view, PASS_INDEX, ("X",), "Object Index", "object_index")
        return np.rint(np.nan_to_num(x, nan=0.0)).astype(np.int32)

    def T_world_cam(self, view: str = "left") -> np.ndarray:
        if view not in self.views:
            raise VoError(f"view {view!r} not in this sequence (views: {', '.join(self.views)})")
        return self._poses[view].copy()

    def __repr__(self) -> str:
        W, H = self.resolution
        return f"RenderSequence({str(self.root)!r}, {self.num_frames} frames, {W}x{H}, views={self.views})"
