"""The render settings that change pixels, as one typed record: what the manifest records,
what ``--resume`` compares with a folder's manifest and what a folder lock compares between
live writers -- the same record, read and written here only.

Device and threads are not in it (the same pixels are expected on any device); the quality
label is not (two labels may name the same settings). The timing is (rate, exposure and
readout change motion blur, rolling shutter and the poses of every frame); so is the culling
rule (``render --cull``: what each chunk builds).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Optional

# the keys of the manifest's ``timing`` entry that change pixels or poses
TIMING_KEYS = ("rate_hz", "start_s", "exposure_s", "readout_s", "motion_blur", "still_frames")
# the keys of the manifest's ``render`` entry that this record writes
RENDER_KEYS = ("samples", "denoise", "sampling", "seed", "resolution_scale", "passes", "culling")


@dataclass(frozen=True)
class PixelSettings:
    """Every setting that changes the pixels of a render.

    ``sampling``: the preset's light-path settings as JSON text (a string, so that the record
    is hashable and compares exactly); ``size``: (W, H) in pixels; ``timing``: the
    :data:`TIMING_KEYS` values as JSON text, None without a TIMING; ``culling``: the culling
    rule as JSON text, None without ``--cull``.
    """
    samples: int
    denoise: bool
    sampling: str
    seed: int
    resolution_scale: float
    passes: tuple[str, ...]
    size: tuple[int, int]
    timing: Optional[str] = None
    culling: Optional[str] = None

    @classmethod
    def create(cls, *, samples: int, denoise: bool, sampling: dict, seed: int, resolution_scale: float,
               passes, size, timing: Optional[dict] = None, culling: Optional[dict] = None) -> "PixelSettings":
        return cls(int(samples), bool(denoise), _canonical(sampling), int(seed), float(resolution_scale),
                   tuple(str(p) for p in passes), (int(size[0]), int(size[1])),
                   None if timing is None else _canonical({k: timing.get(k) for k in TIMING_KEYS}),
                   None if culling is None else _canonical(culling))

    @classmethod
    def from_manifest(cls, manifest: dict) -> Optional["PixelSettings"]:
        """The record of a manifest (a raw dict, as found on disk), or None when it lacks one
        (not a render of ours, or a damaged entry: then nothing in the folder can be kept)."""
        if not isinstance(manifest, dict):
            return None
        r, timing, size = manifest.get("render"), manifest.get("timing"), manifest.get("resolution")
        try:
            return cls.create(samples=r["samples"], denoise=r["denoise"], sampling=r["sampling"], seed=r["seed"],
                              resolution_scale=r.get("resolution_scale", 1.0), passes=r.get("passes", []),
                              size=size, timing=timing if isinstance(timing, dict) else None,
                              culling=r.get("culling"))
        except (KeyError, TypeError, ValueError, IndexError):
            return None

    def render_entries(self) -> dict:
        """The manifest ``render`` entry's keys of this record (:data:`RENDER_KEYS`)."""
        return {"samples": self.samples, "denoise": self.denoise, "sampling": json.loads(self.sampling),
                "seed": self.seed, "resolution_scale": self.resolution_scale, "passes": list(self.passes),
                **({} if self.culling is None else {"culling": json.loads(self.culling)})}

    def key(self) -> str:
        """The record as one string (what a folder lock stores and compares)."""
        return json.dumps({"samples": self.samples, "denoise": self.denoise, "sampling": json.loads(self.sampling),
                           "seed": self.seed, "scale": self.resolution_scale, "passes": list(self.passes),
                           "size": list(self.size),
                           "timing": None if self.timing is None else json.loads(self.timing),
                           **({} if self.culling is None else {"culling": json.loads(self.culling)})},
                          sort_keys=True)


def _canonical(value: dict) -> str:
    """The object as JSON text, its keys in the writer's order (what the manifest holds;
    :meth:`PixelSettings.key` sorts them)."""
    if not isinstance(value, dict):
        raise TypeError("expected a JSON object")
    return json.dumps(value)
