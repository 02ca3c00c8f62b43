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

import json
from collections import OrderedDict
from pathlib import Path

import numpy as np

from ..errors import VoError
from .color import linear_to_srgb8, rgb8_to_gray8
from .exr import find_pass, read_exr_channels
from .files import read_image
from .sequence import check_frame_view

FORMAT = "sesgen-render/1"
REQUIRED_KEYS = ("format", "resolution", "K", "baseline", "frames", "views", "poses", "files")

# pass name candidates (Blender 5.0 first, then 4.x names)
PASS_COMBINED = ("Combined",)
PASS_DEPTH = ("Depth",)
PASS_INDEX = ("Object Index", "IndexOB")


def read_manifest(root) -> dict:
    """Load and check ``manifest.json`` of a render folder; VoError on any defect."""
    root = Path(root)
    path = root / "manifest.json"
    if not path.is_file():
        raise VoError(f"{root}: no manifest.json (not a render folder)")
    try:
        m = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise VoError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(m, dict):
        raise VoError(f"{path}: expected a JSON object")
    fmt = m.get("format")
    if fmt != FORMAT:
        raise VoError(f"{path}: format {fmt!r} is not supported (this reader reads {FORMAT!r})")
    missing = [k for k in REQUIRED_KEYS if k not in m]
    if missing:
        raise VoError(f"{path}: missing key(s) {', '.join(missing)}")
    return m


class RenderSequence:
    """A render folder as a :class:`~vo_reference.io.sequence.Sequence`.

    Extras: ``manifest`` (the dict), ``root``, ``near``/``far``, ``noise`` ((sigma, seed)
    or None), ``objects``, :meth:`rgb_linear`, :meth:`alpha`, :meth:`frame_complete`,
    :meth:`exr_path`.
    """

    def __init__(self, root, cache_frames: int = 4):
        self.root = Path(root)
        self.manifest = m = read_manifest(self.root)
        where = self.root / "manifest.json"
        try:
            W, H = (int(v) for v in m["resolution"])
            self.K = np.array(m["K"], dtype=float).reshape(3, 3)
            self.baseline_m = float(m["baseline"])
            self.num_frames = int(m["frames"])
            self.views = tuple(str(v) for v in m["views"])
        except (TypeError, ValueError) as e:
            raise VoError(f"{where}: bad resolution/K/baseline/frames/views ({e})") from None
        self.resolution = (W, H)
        if not self.views or self.views[0] != "left" or not set(self.views) <= {"left", "right"}:
            raise VoError(f"{where}: views must be ['left'] or ['left', 'right'], got {list(self.views)}")
        if "right" not in self.views:
            self.baseline_m = 0.0
        depth = m.get("depth") or {}
        if depth.get("kind", "planar_z") != "planar_z":
            raise VoError(f"{where}: depth kind {depth.get('kind')!r} not supported (planar_z)")
        self.depth_background = float(depth.get("background", 1e10))
        self.near = float(m.get("near", 0.0))
        self.far = float(m.get("far", np.inf))
        self.objects = list(m.get("objects") or [])
        noise = m.get("noise")
        self.noise = (float(noise["sigma"]), int(noise.get("seed", 0))) if isinstance(noise, dict) else None

        self._poses: dict[str, np.ndarray] = {}
        for v in self.views:
            try:
                T = np.array(m["poses"][v], dtype=float)
            except (KeyError, TypeError, ValueError):
                raise VoError(f"{where}: no usable poses for view {v!r}") from None
            if T.shape != (self.num_frames, 4, 4):
                raise VoError(f"{where}: poses[{v!r}] has shape {T.shape}, expected ({self.num_frames}, 4, 4)")
            self._poses[v] = T
        self._files: dict[str, list] = {}
        for v in self.views:
            files = (m["files"] or {}).get(v)
            if not isinstance(files, list) or len(files) != self.num_frames:
                raise VoError(f"{where}: files[{v!r}] must list {self.num_frames} paths")
            self._files[v] = files
        self.timestamps_s = _timestamps(m, self.num_frames, where)
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
        """True when frame k is recorded complete and its EXR files exist for every view.

        The manifest's per-frame state is ``frames_complete`` (list of bools; a dict
        view -> list is accepted too); without it, existence of the listed files decides."""
        if not 0 <= int(k) < self.num_frames:
            return False
        state = self.manifest.get("frames_complete", self.manifest.get("complete"))
        for v in self.views:
            rel = self._files[v][int(k)]
            if not rel or not (self.root / rel).is_file():
                return False
            if isinstance(state, dict) and v in state and not state[v][int(k)]:
                return False
        if isinstance(state, list) and len(state) == self.num_frames and not state[int(k)]:
            return False
        return True

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
        named = (self.manifest.get("channels") or {}).get(key) if key else None
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
        z = z.astype(np.float32, copy=True)
        z[~np.isfinite(z) | (z >= 0.999 * self.depth_background) | (z <= 0.0)] = np.inf
        return z

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


def _timestamps(m: dict, n: int, where) -> np.ndarray:
    """Per-frame times: ``timestamps`` (s) if given, else frame / ``fps`` (top level or in
    ``render``), else the frame index (1 s per frame)."""
    ts = m.get("timestamps")
    if ts is not None:
        t = np.asarray(ts, dtype=float)
        if t.shape != (n,):
            raise VoError(f"{where}: timestamps has {t.size} values for {n} frames")
        return t
    fps = m.get("fps") or (m.get("render") or {}).get("fps")
    if fps:
        return np.arange(n, dtype=float) / float(fps)
    return np.arange(n, dtype=float)
