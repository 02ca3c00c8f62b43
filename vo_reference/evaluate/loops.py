"""A loop-closure (place-recognition) detector's output against covisibility ground truth.

The ground truth (:mod:`vo_reference.products.covisibility`): a pair of frames (query q, the
later one; match m) is a **true loop closure** when they are at least ``min_gap_s`` apart and
c(q -> m) >= ``threshold``: at least that share of the query's surface pixels is visible in the
match. A detection (q, m) -- which of the two is later is read from the timestamps -- is a
true positive when its pair is one, else a false positive (a detection closer in time than
``min_gap_s`` is not a loop closure).

- **pairs**: precision = true detections / detections; recall = true loop-closure pairs
  detected / true loop-closure pairs;
- **queries** (the usual loop-closure curves): per query frame its best detection (highest
  score; the first given when there are no scores); precision = queries whose best match is
  true / queries with a detection; recall = the same / query frames that have a true loop
  closure at all;
- with scores: the pairs' precision-recall curve over the score threshold, its average
  precision (the area under the step curve, each recall step weighted by its precision) and
  the largest recall at 100 % precision.

Detections files: one detection per line, ``query match [score]`` (frame indices; commas or
spaces; ``#`` comments), or with ``by_time`` the two frames' timestamps in seconds, each
matched to the nearest frame within ``max_diff_s``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from blender_sesgen.contract.inputs import read_bytes

from ..errors import VoError


@dataclass(frozen=True)
class Detections:
    """Detected loop closures: frame indices (query, match) and an optional score each."""
    query: np.ndarray
    match: np.ndarray
    score: Optional[np.ndarray] = None

    def __len__(self) -> int:
        return len(self.query)


def read_detections(path, timestamps_s: Optional[np.ndarray] = None, by_time: bool = False,
                    max_diff_s: float = 0.01) -> Detections:
    """Read a detections file (see the module docstring); ``timestamps_s``: the frames' stamps
    (needed ``by_time``, and to check frame indices)."""
    path = Path(path)
    try:
        text = read_bytes(path, 256 << 20, "detections file").decode("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise VoError(f"{path}: cannot read ({e})") from None
    rows = []
    for n, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").split()
        if len(parts) not in (2, 3):
            raise VoError(f"{path}:{n}: expected 'query match [score]', got {len(parts)} values")
        try:
            vals = [float(x) for x in parts]
        except ValueError:
            raise VoError(f"{path}:{n}: not a number: {line!r}") from None
        if not all(np.isfinite(vals)):
            raise VoError(f"{path}:{n}: a value is not finite")
        rows.append(vals + ([np.nan] if len(vals) == 2 else []))
    a = np.array(rows, dtype=float).reshape(-1, 3)
    if by_time:
        if timestamps_s is None:
            raise VoError("matching detections by time needs the frames' timestamps")
        t = np.asarray(timestamps_s, float)
        idx = np.clip(np.searchsorted(t, a[:, :2]), 1, len(t) - 1)
        nearest = np.where(np.abs(t[idx - 1] - a[:, :2]) <= np.abs(t[idx] - a[:, :2]), idx - 1, idx)
        bad = np.abs(t[nearest] - a[:, :2]) > max_diff_s
        if bad.any():
            r = int(np.flatnonzero(bad.any(axis=1))[0])
            raise VoError(f"{path}: detection {r + 1}: no frame within {max_diff_s} s of its time stamps")
        qm = nearest
    else:
        if np.any(a[:, :2] != np.round(a[:, :2])):
            raise VoError(f"{path}: frame indices must be integers (use --by-time for time stamps)")
        qm = a[:, :2].astype(int)
        if timestamps_s is not None and len(qm) and (qm.min() < 0 or qm.max() >= len(timestamps_s)):
            raise VoError(f"{path}: a frame index outside 0..{len(timestamps_s) - 1}")
    scores = a[:, 2]
    return Detections(qm[:, 0], qm[:, 1], None if np.all(np.isnan(scores)) else np.nan_to_num(scores, nan=-np.inf))


@dataclass(frozen=True)
class LoopEvaluation:
    """The numbers of :func:`evaluate_loops` (see the module docstring)."""
    threshold: float
    min_gap_s: float
    detections: int
    true_detections: int
    positives: int                    # true loop-closure pairs
    positives_found: int
    pair_precision: float
    pair_recall: float
    query_positives: int              # query frames with a true loop closure
    queries_detected: int             # query frames with a detection
    queries_correct: int
    query_precision: float
    query_recall: float
    average_precision: Optional[float] = None
    recall_at_full_precision: Optional[float] = None
    curve: Optional[np.ndarray] = None  # (n, 3): score threshold, precision, recall

    def metrics(self) -> dict:
        out = {k: getattr(self, k) for k in ("threshold", "min_gap_s", "detections", "true_detections", "positives",
                                             "positives_found", "pair_precision", "pair_recall", "query_positives",
                                             "queries_detected", "queries_correct", "query_precision",
                                             "query_recall", "average_precision", "recall_at_full_precision")}
        return out

    def summary_lines(self) -> list[str]:
        rows = [f"loop closures: c(query -> match) >= {self.threshold:g}, >= {self.min_gap_s:g} s apart: "
                f"{self.positives} true pairs, {self.query_positives} query frames",
                f"  pairs:   {self.detections} detections, {self.true_detections} true: precision "
                f"{self.pair_precision:.4f}, recall {self.pair_recall:.4f}",
                f"  queries: {self.queries_detected} with a detection, {self.queries_correct} right: precision "
                f"{self.query_precision:.4f}, recall {self.query_recall:.4f}"]
        if self.average_precision is not None:
            rows.append(f"  scores:  average precision {self.average_precision:.4f}, recall at 100 % precision "
                        f"{self.recall_at_full_precision:.4f}")
        return rows


def _ratio(a: int, b: int) -> float:
    return float(a) / b if b else 0.0


def evaluate_loops(cov, det: Detections, threshold: Optional[float] = None,
                   min_gap_s: Optional[float] = None) -> LoopEvaluation:
    """Detections ``det`` against the covisibility ``cov`` (a ``Covisibility``) at
    ``threshold`` and ``min_gap_s`` (defaults: the ground truth's loop-closure values)."""
    th = cov.params.loop_threshold if threshold is None else float(threshold)
    gap = cov.params.min_gap_s if min_gap_s is None else float(min_gap_s)
    pos = cov.positives(th, gap)
    pos_set = {(int(q), int(m)) for q, m in pos}
    t = cov.timestamps_s
    n = len(t)
    if len(det) and (min(det.query.min(), det.match.min()) < 0 or max(det.query.max(), det.match.max()) >= n):
        raise VoError(f"a detection names a frame outside 0..{n - 1}")
    later = t[det.query] >= t[det.match]
    q = np.where(later, det.query, det.match)
    m = np.where(later, det.match, det.query)
    true = np.array([(int(a), int(b)) in pos_set for a, b in zip(q, m)], dtype=bool)
    found = {(int(a), int(b)) for a, b, ok in zip(q, m, true) if ok}
    # queries: each query frame's best detection
    score = det.score if det.score is not None else -np.arange(len(q), dtype=float)   # first given is best
    best = {}
    for i in np.argsort(-score, kind="stable"):
        best.setdefault(int(q[i]), bool(true[i]))
    query_pos = {int(a) for a, _ in pos}
    correct = sum(1 for a, ok in best.items() if ok)
    ap = r100 = None
    curve = None
    if det.score is not None and len(q):
        order = np.argsort(-det.score, kind="stable")
        tp = np.cumsum(true[order])
        # a detection of a pair found before adds precision but no recall
        seen, new = set(), np.zeros(len(order), bool)
        for k, i in enumerate(order):
            key = (int(q[i]), int(m[i]))
            if true[i] and key not in seen:
                new[k] = True
                seen.add(key)
        recall = np.cumsum(new) / max(len(pos), 1)
        precision = tp / np.arange(1, len(order) + 1)
        last = np.r_[det.score[order][1:] != det.score[order][:-1], True]     # cut only between different scores
        curve = np.column_stack([det.score[order][last], precision[last], recall[last]])
        r_prev = np.r_[0.0, curve[:-1, 2]]
        ap = float(np.sum((curve[:, 2] - r_prev) * curve[:, 1]))
        full = curve[curve[:, 1] >= 1.0 - 1e-12]
        r100 = float(full[:, 2].max()) if len(full) else 0.0
    return LoopEvaluation(threshold=th, min_gap_s=gap, detections=int(len(q)), true_detections=int(true.sum()),
                          positives=len(pos_set), positives_found=len(found),
                          pair_precision=_ratio(int(true.sum()), len(q)), pair_recall=_ratio(len(found), len(pos_set)),
                          query_positives=len(query_pos), queries_detected=len(best), queries_correct=correct,
                          query_precision=_ratio(correct, len(best)), query_recall=_ratio(correct, len(query_pos)),
                          average_precision=ap, recall_at_full_precision=r100, curve=curve)
