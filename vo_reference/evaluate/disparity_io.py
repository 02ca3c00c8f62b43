"""Reading disparity maps and masks for evaluation (pixels, float; invalid = NaN or 0).

- ``.png`` 16-bit (KITTI style): d = value / 256, 0 = invalid → NaN; an 8-bit PNG is read as
  is (value = disparity, 0 = invalid), as the Middlebury 2003 ground truth at scale 1.
- ``.pfm`` (Middlebury 2014 / SceneFlow): float, bottom-up rows, inf = invalid → NaN.
- ``.npy``: a 2-D array as saved. ``.tif``/``.tiff``: float32 via OpenCV.
- ``.exr``: the first channel named ``Y``/``disparity``/``R``/``Z``… of a single-channel
  image, or the one named by ``channel``.
Masks: any image; True where the (first channel) value is nonzero.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import VoError


def read_disparity(path, channel: str | None = None) -> np.ndarray:
    """Disparity (H, W) float64 in pixels, NaN where invalid."""
    path = Path(path)
    if not path.is_file():
        raise VoError(f"{path}: no such disparity file")
    ext = path.suffix.lower()
    if ext == ".pfm":
        d = read_pfm(path)
    elif ext == ".npy":
        try:
            d = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise VoError(f"{path}: not a readable .npy array ({e})") from None
    elif ext == ".exr":
        d = _read_exr(path, channel)
    elif ext in (".png", ".tif", ".tiff"):
        img = _imread(path)
        if img.ndim == 3:
            raise VoError(f"{path}: a disparity image must have one channel, got {img.shape[2]}")
        if ext == ".png" and img.dtype == np.uint16:
            d = img.astype(float) / 256.0
            d[img == 0] = np.nan
        else:
            d = img.astype(float)
            if np.issubdtype(img.dtype, np.integer):
                d[img == 0] = np.nan
    else:
        raise VoError(f"{path}: unknown disparity format {ext!r} (png, pfm, npy, tif, exr)")
    d = np.asarray(d, dtype=float)
    if d.ndim == 3 and d.shape[2] == 1:
        d = d[:, :, 0]
    if d.ndim != 2:
        raise VoError(f"{path}: expected a 2-D disparity map, got shape {d.shape}")
    d = d.copy()
    d[~np.isfinite(d)] = np.nan
    return d


def read_mask(path) -> np.ndarray:
    """Boolean (H, W) mask: True where the image (first channel) is nonzero."""
    path = Path(path)
    if not path.is_file():
        raise VoError(f"{path}: no such mask file")
    if path.suffix.lower() == ".npy":
        m = np.load(path, allow_pickle=False)
    else:
        m = _imread(path)
    if m.ndim == 3:
        m = m[:, :, 0]
    return np.asarray(m) != 0


def _imread(path: Path) -> np.ndarray:
    import cv2
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise VoError(f"{path}: not a readable image")
    return img


def read_pfm(path) -> np.ndarray:
    """PFM (``Pf`` grey or ``PF`` colour → first channel), rows flipped to top-down."""
    path = Path(path)
    with open(path, "rb") as f:
        header = f.readline().strip()
        if header not in (b"Pf", b"PF"):
            raise VoError(f"{path}: not a PFM file")
        dims = f.readline().split()
        while len(dims) < 2:  # tolerate the width/height split over lines
            dims += f.readline().split()
        try:
            w, h = int(dims[0]), int(dims[1])
            scale = float(f.readline().strip())
        except ValueError:
            raise VoError(f"{path}: bad PFM header") from None
        c = 3 if header == b"PF" else 1
        data = np.fromfile(f, dtype="<f4" if scale < 0 else ">f4")
    if data.size != w * h * c:
        raise VoError(f"{path}: PFM holds {data.size} values, expected {w * h * c}")
    img = data.reshape(h, w, c)[::-1, :, 0]
    return img.astype(float)


def write_pfm(path, image: np.ndarray) -> None:
    """Grey PFM (little endian), rows bottom-up as the format wants."""
    img = np.asarray(image, dtype="<f4")
    with open(path, "wb") as f:
        f.write(b"Pf\n%d %d\n-1\n" % (img.shape[1], img.shape[0]))
        f.write(np.ascontiguousarray(img[::-1]).tobytes())


def _read_exr(path: Path, channel: str | None) -> np.ndarray:
    try:
        import OpenEXR
    except ImportError:  # pragma: no cover - OpenEXR is a dependency of the vo extra
        raise VoError("reading EXR needs the OpenEXR package") from None
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            channels = {}
            for part in f.parts:
                channels.update({name: ch.pixels for name, ch in part.channels.items()})
    except Exception as e:  # OpenEXR raises plain exceptions on bad files
        raise VoError(f"{path}: not a readable EXR ({e})") from None
    if channel is not None:
        if channel not in channels:
            raise VoError(f"{path}: no channel {channel!r} (have {sorted(channels)})")
        return np.asarray(channels[channel], dtype=float)
    if len(channels) == 1:
        return np.asarray(next(iter(channels.values())), dtype=float)
    for want in ("disparity", "Disparity", "Y", "R", "Z", "V"):
        for name in sorted(channels):
            if name == want or name.endswith("." + want):
                return np.asarray(channels[name], dtype=float)
    raise VoError(f"{path}: several channels {sorted(channels)}; say which one")
