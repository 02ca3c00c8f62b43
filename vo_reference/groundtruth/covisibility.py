"""Place-recognition and loop-closure ground truth: the covisibility of every pair of frames,
from the exact depth and poses of a render.

**Covisibility** c(i -> j): of frame i's sampled pixels that see a surface (finite depth), the
share whose 3-D point is visible in frame j: it projects into j's image (pixel centres at
integers, the image covers [-0.5, W-0.5) x [-0.5, H-0.5)), in front of the camera, and is not
hidden there -- j's own depth at that point (bilinear in inverse depth over the 2x2 pixels
around it, :func:`vo_reference.groundtruth.flow.hidden_behind`) is not nearer than the point by
more than ``rtol`` (relative). The optical flow's occlusion test, between any two frames. A
pixel of a moving object carries its point with the object (its pose at both frames, from
the manifest); every other point is static. Pixels are sampled every ``stride`` pixels in x
and y, from (stride // 2, stride // 2); ``stride`` 1 uses every pixel. The frames of one
view (``left`` by default) at their frame stamps (a rolling-shutter render's rows are taken
at the frame stamp, as for the flow); a distorting lens projects through the lens.

**Scaling**: the points of every frame are grouped into image tiles, and a tile's points are
projected into frame j only when the tile's bounding box meets j's view volume (the pyramid of
its pixel area); a pair whose tiles all miss has covisibility 0 without a single projection. Each frame's depth is read twice (once for its points, once as target).

**Files** (``OUT/covisibility/``, written whole or not at all):

- ``pairs.csv``: ``i,j,c_ij,c_ji`` for every pair i < j with c(i -> j) or c(j -> i) at least
  ``threshold`` (both values exact, one below the threshold included);
- ``loop_closures.csv``: ``query,match,t_query_s,t_match_s,gap_s,c_query_match,c_match_query``:
  every pair at least ``min_gap_s`` apart whose later frame (the query) sees at least
  ``loop_threshold`` of itself in the earlier one (the match): what a loop-closure or
  place-recognition system should find;
- ``covisibility.json``: the parameters, the view, the frames, each frame's number of sampled
  surface points, the definition and the counts.

:func:`read_covisibility` reads them back (``Covisibility``: ``c(i, j)``, ``pairs``,
``loop_closures``, ``positives(threshold, min_gap_s)``).
"""
from __future__ import annotations

import csv
import io
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from blender_sesgen.contract import atomic
from blender_sesgen.contract.inputs import read_bytes
from blender_sesgen.contract.se3 import invert

from ..errors import VoError
from .flow import hidden_behind

COVIS_DIR = "covisibility"
FORMAT = "sesgen-covisibility/1"
DEFINITION = ("c(i -> j) = share of frame i's sampled surface pixels whose 3-D point (moving with its object) "
              "projects into frame j's image, in front of it, and is not hidden by more than rtol (relative) "
              "behind j's depth there (bilinear in inverse depth)")


@dataclass(frozen=True)
class CovisibilityParams:
    """How the covisibility is computed and what is written (see the module docstring)."""
    stride: int = 4
    rtol: float = 1e-3
    threshold: float = 0.05
    loop_threshold: float = 0.3
    min_gap_s: float = 30.0
    view: str = "left"
    tiles: tuple = (8, 4)

    def __post_init__(self):
        if int(self.stride) < 1:
            raise VoError(f"stride must be >= 1, got {self.stride}")
        if not (0.0 < self.threshold <= 1.0 and 0.0 < self.loop_threshold <= 1.0):
            raise VoError("thresholds must lie in (0, 1]")
        if self.loop_threshold < self.threshold:
            raise VoError(f"the loop-closure threshold {self.loop_threshold:g} is below the pairs' threshold "
                          f"{self.threshold:g}: pairs between them would not be written")
        if not self.rtol >= 0 or not self.min_gap_s >= 0:
            raise VoError("rtol and min_gap_s must be >= 0")


@dataclass
class Covisibility:
    """Covisibility of a sequence's frames: ``pairs`` (M, 4) rows i, j (i < j), c(i -> j),
    c(j -> i) for the pairs written (either value >= ``params.threshold``); ``timestamps_s``
    (N,); ``points`` (N,) sampled surface pixels per frame."""
    pairs: np.ndarray
    timestamps_s: np.ndarray
    params: CovisibilityParams
    points: np.ndarray
    frames: Optional[np.ndarray] = None        # the frame indices covered (default 0..N-1)
    _lookup: dict = field(default=None, repr=False)

    @property
    def num_frames(self) -> int:
        return len(self.timestamps_s)

    def c(self, i: int, j: int) -> float:
        """c(i -> j); 0 for a pair not written (both directions below the threshold)."""
        if self._lookup is None:
            self._lookup = {}
            for a, b, cab, cba in self.pairs:
                self._lookup[(int(a), int(b))] = float(cab)
                self._lookup[(int(b), int(a))] = float(cba)
        if i == j:
            return 1.0
        return self._lookup.get((int(i), int(j)), 0.0)

    def positives(self, threshold: Optional[float] = None, min_gap_s: Optional[float] = None) -> np.ndarray:
        """(L, 2) query, match (query later by at least ``min_gap_s``) with c(query -> match) >=
        ``threshold`` (defaults: the loop-closure threshold and gap of the parameters); a
        threshold below the pairs' one would miss pairs: refused."""
        th = self.params.loop_threshold if threshold is None else float(threshold)
        gap = self.params.min_gap_s if min_gap_s is None else float(min_gap_s)
        if th < self.params.threshold:
            raise VoError(f"covisibility threshold {th:g} is below the {self.params.threshold:g} the pairs were "
                          "written with: compute them again with a lower --threshold")
        if len(self.pairs) == 0:
            return np.zeros((0, 2), dtype=int)
        i, j = self.pairs[:, 0].astype(int), self.pairs[:, 1].astype(int)
        t = self.timestamps_s
        later_i = t[i] >= t[j]
        q = np.where(later_i, i, j)
        m = np.where(later_i, j, i)
        c_qm = np.where(later_i, self.pairs[:, 2], self.pairs[:, 3])
        keep = (np.abs(t[i] - t[j]) >= gap) & (c_qm >= th)
        out = np.column_stack([q[keep], m[keep]])
        return out[np.lexsort((out[:, 1], out[:, 0]))] if len(out) else out

    @property
    def loop_closures(self) -> np.ndarray:
        """(L, 2) query, match of the loop-closure pairs (``positives()`` at the parameters' values)."""
        return self.positives()


# --- computing ---------------------------------------------------------------------------

@dataclass
class _Points:
    """Every frame's sampled surface points: world coordinates (static), or coordinates in
    the object's frame at that frame (movers), with their frame, tile and mover index."""
    X: np.ndarray            # (P, 3) float64
    frame: np.ndarray        # (P,) int32
    tile: np.ndarray         # (P,) int32: frame * n_tiles + tile, or -1 on a mover
    mover: np.ndarray        # (P,) int16: index into the movers' poses, -1 static
    count: np.ndarray        # (N,) points per frame
    tile_lo: np.ndarray      # (N * n_tiles, 3) bounding boxes of the static points of each tile
    tile_hi: np.ndarray
    tile_start: np.ndarray   # (N * n_tiles + 1,) the points of tile t are X[order[start[t]:start[t+1]]]
    order: np.ndarray


def _rays(K: np.ndarray, W: int, H: int, u: np.ndarray, v: np.ndarray, lens) -> np.ndarray:
    """Camera rays with unit z through pixels (u, v) (a distorting lens: through it)."""
    if lens is None:
        Kinv = np.linalg.inv(K)
        pix = np.stack([u, v, np.ones_like(u)], axis=-1)
        return pix @ Kinv.T
    r = lens.unproject(np.stack([u, v], axis=-1).reshape(-1, 2)).reshape(np.shape(u) + (3,))
    return r / r[..., 2:3]


def _project(K: np.ndarray, X: np.ndarray, lens) -> tuple[np.ndarray, np.ndarray]:
    if lens is None:
        z = X[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            return (K[0, 0] * X[:, 0] + K[0, 1] * X[:, 1]) / z + K[0, 2], K[1, 1] * X[:, 1] / z + K[1, 2]
    px = lens.project(X)
    return px[:, 0], px[:, 1]


def _gather(seq, frames, p: CovisibilityParams, K, W, H, lens, mover_poses, report) -> _Points:
    s = int(p.stride)
    us = np.arange(s // 2, W, s, dtype=np.float64)
    vs = np.arange(s // 2, H, s, dtype=np.float64)
    uu, vv = np.meshgrid(us, vs)
    rays = _rays(K, W, H, uu, vv, lens)
    tx, ty = p.tiles
    tile_of = (np.minimum((uu * tx / W).astype(int), tx - 1) + tx * np.minimum((vv * ty / H).astype(int), ty - 1))
    n_tiles = tx * ty
    T = seq.T_world_cam(p.view)
    Xs, fr, tl, mv, count = [], [], [], [], np.zeros(len(frames), int)
    mover_ids = list(mover_poses)
    for n, k in enumerate(frames):
        z = np.asarray(seq.depth(k, p.view), dtype=np.float64)[vv.astype(int), uu.astype(int)]
        ok = np.isfinite(z) & (z > 0)
        Xc = rays[ok] * z[ok][:, None]
        Xw = Xc @ T[k][:3, :3].T + T[k][:3, 3]
        m = np.full(len(Xw), -1, np.int16)
        if mover_ids:
            ids = np.asarray(seq.ids(k, p.view))[vv.astype(int), uu.astype(int)][ok]
            for mi, oid in enumerate(mover_ids):
                on = ids == oid
                if on.any():
                    T_obj = mover_poses[oid][k]
                    Xw[on] = (Xw[on] - T_obj[:3, 3]) @ T_obj[:3, :3]        # into the object's frame at k
                    m[on] = mi
        Xs.append(Xw)
        fr.append(np.full(len(Xw), n, np.int32))
        tl.append(np.where(m < 0, n * n_tiles + tile_of[ok], -1).astype(np.int32))
        mv.append(m)
        count[n] = len(Xw)
        if report:
            report(1)
    X, frame, tile, mover = (np.concatenate(a) if a else np.zeros((0, 3)) for a in (Xs, fr, tl, mv))
    n_all = len(frames) * n_tiles
    static = tile >= 0
    order = np.flatnonzero(static)[np.argsort(tile[static], kind="stable")]
    start = np.searchsorted(tile[order], np.arange(n_all + 1))
    lo = np.full((n_all, 3), np.inf)
    hi = np.full((n_all, 3), -np.inf)
    if len(order):
        np.minimum.at(lo, tile[order], X[order])
        np.maximum.at(hi, tile[order], X[order])
    return _Points(X, frame.astype(np.int32), tile.astype(np.int32), mover.astype(np.int16), count, lo, hi, start,
                   order)


def _pyramid_planes(K, W, H, lens, far: float) -> np.ndarray:
    """(5, 4) unit-normal half-spaces of the camera's view volume (pixel area, z <= far)."""
    u = np.linspace(-0.5, W - 0.5, 33)
    v = np.linspace(-0.5, H - 0.5, 33)
    border = np.concatenate([np.stack([u, np.full_like(u, v[0])], 1), np.stack([u, np.full_like(u, v[-1])], 1),
                             np.stack([np.full_like(v, u[0]), v], 1), np.stack([np.full_like(v, u[-1]), v], 1)])
    xy = _rays(K, W, H, border[:, 0], border[:, 1], lens)[:, :2]
    a0, a1 = xy[:, 0].min() - 1e-6, xy[:, 0].max() + 1e-6
    b0, b1 = xy[:, 1].min() - 1e-6, xy[:, 1].max() + 1e-6
    P = np.array([[1.0, 0.0, -a0, 0.0], [-1.0, 0.0, a1, 0.0], [0.0, 1.0, -b0, 0.0], [0.0, -1.0, b1, 0.0],
                  [0.0, 0.0, -1.0, min(far, 1e30)]])
    return P / np.linalg.norm(P[:, :3], axis=1, keepdims=True)


def _boxes_meet(planes: np.ndarray, T_cam_world: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """bool (n,): the world boxes lo..hi are not entirely outside one plane of the pyramid."""
    R, t = T_cam_world[:3, :3], T_cam_world[:3, 3]
    n_w = planes[:, :3] @ R                         # plane normals in the world
    c_w = planes[:, :3] @ t + planes[:, 3]
    # the box corner farthest along each normal: if even it is outside, the box is
    best = np.where(n_w[None, :, :] >= 0, hi[:, None, :], lo[:, None, :])        # (n, 5, 3)
    s = np.einsum("npj,pj->np", best, n_w) + c_w[None]
    return np.all(s >= 0, axis=1)


def compute_covisibility(seq, params: CovisibilityParams = CovisibilityParams(), frames=None,
                         progress: Optional[Callable[[int], None]] = None) -> Covisibility:
    """The covisibility of ``frames`` (default all) of a sequence with depth, ids and poses (a
    ``RenderSequence``), see the module docstring; ``progress(n)`` as units are done (2 per
    frame: gathering its points, then testing them against it)."""
    p = params
    if p.view not in seq.views:
        raise VoError(f"view {p.view!r} not in this sequence (views: {', '.join(seq.views)})")
    N_all = seq.num_frames
    frames = np.arange(N_all) if frames is None else np.asarray(sorted(set(int(k) for k in frames)))
    if len(frames) < 2:
        raise VoError("covisibility needs at least two frames")
    if frames.min() < 0 or frames.max() >= N_all:
        raise VoError(f"frames out of range 0..{N_all - 1}")
    for k in frames:
        if not seq.frame_complete(int(k)):
            raise VoError(f"frame {k} is not rendered completely: finish the render or choose --frames")
    K = np.asarray(seq.K, dtype=np.float64)
    W, H = seq.resolution
    lens = seq.lens
    mover_poses = {int(i): seq.T_world_obj(i) for i in seq.moving_ids}
    movers = list(mover_poses)
    pts = _gather(seq, frames, p, K, W, H, lens, mover_poses, progress)
    T = seq.T_world_cam(p.view)[frames]
    n_tiles = p.tiles[0] * p.tiles[1]
    N = len(frames)
    seen_i, seen_j, seen_n = [], [], []              # sparse: points of frame i visible in frame j
    mover_rows = np.flatnonzero(pts.mover >= 0)
    for jn, k in enumerate(frames):
        depth_j = np.asarray(seq.depth(int(k), p.view), dtype=np.float64)
        finite = np.isfinite(depth_j) & (depth_j > 0)
        if finite.any():
            # no far plane: beside a background pixel (or extrapolated in the border) the depth
            # test lets points of any depth through, as it does for the flow
            T_j = invert(T[jn])
            planes = _pyramid_planes(K, W, H, lens, np.inf)
            meet = _boxes_meet(planes, T_j, pts.tile_lo, pts.tile_hi)
            meet[jn * n_tiles:(jn + 1) * n_tiles] = False                  # not with itself
            tiles = np.flatnonzero(meet)
            idx = np.concatenate([pts.order[pts.tile_start[t]:pts.tile_start[t + 1]] for t in tiles]) \
                if len(tiles) else np.zeros(0, int)
            idx = np.concatenate([idx, mover_rows[pts.frame[mover_rows] != jn]])
            if len(idx):
                X = pts.X[idx]
                m = pts.mover[idx]
                for mi in np.unique(m[m >= 0]):                             # movers: where they are at j
                    on = m == mi
                    T_obj = mover_poses[movers[mi]][k]
                    X[on] = X[on] @ T_obj[:3, :3].T + T_obj[:3, 3]
                Xc = X @ T_j[:3, :3].T + T_j[:3, 3]
                front = Xc[:, 2] > 1e-12
                u, v = _project(K, Xc, lens)
                inside = front & (u >= -0.5) & (u < W - 0.5) & (v >= -0.5) & (v < H - 0.5)
                ok = np.zeros(len(idx), bool)
                ok[inside] = ~hidden_behind(depth_j, u[inside], v[inside], Xc[inside, 2], p.rtol)
                counts = np.bincount(pts.frame[idx[ok]], minlength=N)
                nz = np.flatnonzero(counts)
                seen_i.append(nz)
                seen_j.append(np.full(len(nz), jn))
                seen_n.append(counts[nz])
        if progress:
            progress(1)
    pairs = _pairs(np.concatenate(seen_i) if seen_i else np.zeros(0, int),
                   np.concatenate(seen_j) if seen_j else np.zeros(0, int),
                   np.concatenate(seen_n) if seen_n else np.zeros(0, int), pts.count, frames, p.threshold)
    t_all = np.asarray(seq.timestamps_s, dtype=np.float64)
    return Covisibility(pairs=pairs, timestamps_s=t_all, params=p, points=_full(pts.count, frames, N_all),
                        frames=frames)


def _pairs(i, j, n_seen, count, frames, threshold) -> np.ndarray:
    """(M, 4) rows i < j (frame indices), c(i -> j), c(j -> i), for the pairs where either
    value reaches ``threshold``, from sparse counts of i's points seen in j."""
    c = n_seen / np.maximum(count[i], 1)
    lookup = dict(zip(zip(i.tolist(), j.tolist()), c.tolist()))
    keys = {(a, b) if a < b else (b, a) for (a, b), v in lookup.items() if v >= threshold}
    rows = sorted((a, b, lookup.get((a, b), 0.0), lookup.get((b, a), 0.0)) for a, b in keys)
    out = np.array(rows, dtype=np.float64).reshape(-1, 4)
    out[:, 0], out[:, 1] = frames[out[:, 0].astype(int)], frames[out[:, 1].astype(int)]
    return out


def _full(count, frames, n):
    out = np.zeros(n, int)
    out[frames] = count
    return out


# --- files -------------------------------------------------------------------------------

def write_covisibility(root, cov: Covisibility) -> Path:
    """``root/covisibility/`` (pairs.csv, loop_closures.csv, covisibility.json), whole or not at all."""
    root = Path(root)
    final = root / COVIS_DIR
    t = cov.timestamps_s
    lc = cov.loop_closures
    with atomic.replacing_folder(final) as tmp:
        buf = io.StringIO()
        buf.write("i,j,c_ij,c_ji\n")
        for a, b, cab, cba in cov.pairs:
            buf.write(f"{int(a)},{int(b)},{cab:.6f},{cba:.6f}\n")
        (tmp / "pairs.csv").write_text(buf.getvalue())
        buf = io.StringIO()
        buf.write("query,match,t_query_s,t_match_s,gap_s,c_query_match,c_match_query\n")
        for q, m in lc:
            buf.write(f"{q},{m},{t[q]:.6f},{t[m]:.6f},{t[q] - t[m]:.6f},{cov.c(q, m):.6f},{cov.c(m, q):.6f}\n")
        (tmp / "loop_closures.csv").write_text(buf.getvalue())
        frames = cov.frames if cov.frames is not None else np.arange(cov.num_frames)
        meta = {"format": FORMAT, "definition": DEFINITION, "params": {**asdict(cov.params),
                                                                       "tiles": list(cov.params.tiles)},
                "frames": _ranges(frames), "num_frames": cov.num_frames,
                "points_per_frame": [int(x) for x in cov.points], "timestamps_s": [float(x) for x in t],
                "counts": {"pairs": int(len(cov.pairs)), "loop_closures": int(len(lc))},
                "files": {"pairs": "pairs.csv", "loop_closures": "loop_closures.csv"}}
        (tmp / "covisibility.json").write_text(atomic.dumps_json(meta, str(final / "covisibility.json")))
    return final


def _ranges(frames) -> list[list[int]]:
    """The frame indices as half-open ranges [[a, b], ...] (a selection may have gaps)."""
    f = np.asarray(frames, dtype=int)
    cuts = np.flatnonzero(np.diff(f) != 1) + 1
    return [[int(r[0]), int(r[-1]) + 1] for r in np.split(f, cuts)]


def read_covisibility(root) -> Covisibility:
    """The covisibility written into a render folder (``root`` or ``root/covisibility``)."""
    d = Path(root)
    if (d / COVIS_DIR).is_dir():
        d = d / COVIS_DIR
    meta_path = d / "covisibility.json"
    try:
        meta = json.loads(read_bytes(meta_path, 256 << 20, "covisibility.json"))
    except (OSError, ValueError) as e:
        raise VoError(f"{meta_path}: cannot read the covisibility ({e}); compute it with "
                      "`python -m vo_reference covisibility RENDER`") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise VoError(f"{meta_path}: not a {FORMAT} file")
    try:
        prm = dict(meta["params"])
        prm["tiles"] = tuple(prm.get("tiles", (8, 4)))
        params = CovisibilityParams(**prm)
        text = read_bytes(d / meta["files"]["pairs"], 4 << 30, "pairs.csv").decode("utf-8")
        rows = list(csv.reader(io.StringIO(text)))
        if rows[0] != ["i", "j", "c_ij", "c_ji"]:
            raise ValueError("bad header")
        pairs = np.array([[int(a), int(b), float(x), float(y)] for a, b, x, y in rows[1:]], dtype=np.float64) \
            .reshape(-1, 4)
        t = np.asarray(meta["timestamps_s"], dtype=np.float64)
        n = int(meta["num_frames"])
        frames = np.concatenate([np.arange(int(a), int(b)) for a, b in meta["frames"]])
    except (KeyError, TypeError, ValueError, IndexError, OSError) as e:
        raise VoError(f"{d}: malformed covisibility files ({e})") from None
    if len(t) != n or (len(pairs) and (pairs[:, :2].min() < 0 or pairs[:, :2].max() >= n
                                       or np.any(pairs[:, 2:] < 0) or np.any(pairs[:, 2:] > 1))):
        raise VoError(f"{d}: covisibility pairs out of range")
    return Covisibility(pairs=pairs, timestamps_s=t, params=params,
                        points=np.asarray(meta.get("points_per_frame", [0] * n), dtype=int),
                        frames=frames)
