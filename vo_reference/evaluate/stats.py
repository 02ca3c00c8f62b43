"""Summary statistics of an error array, with evo's definitions (population std)."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import VoError


@dataclass(frozen=True)
class ErrorStats:
    """rmse = sqrt(mean(e^2)), mean, median, std (population, ddof=0), min, max, sse = sum(e^2), n."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    sse: float
    n: int

    @classmethod
    def of(cls, errors: np.ndarray) -> "ErrorStats":
        e = np.asarray(errors, dtype=float).ravel()
        if e.size == 0:
            raise VoError("no errors to summarise (empty pose set)")
        sq = e * e
        return cls(
            rmse=float(np.sqrt(np.mean(sq))),
            mean=float(np.mean(e)),
            median=float(np.median(e)),
            std=float(np.std(e)),
            min=float(np.min(e)),
            max=float(np.max(e)),
            sse=float(np.sum(sq)),
            n=int(e.size),
        )

    def as_dict(self) -> dict:
        return asdict(self)
