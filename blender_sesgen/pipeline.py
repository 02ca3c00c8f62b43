"""Rendering from Python, frame by frame: the public names (docs/api.md) of the classes the
command line and the add-on render with (they import them from ``plan`` and ``job``).

    >>> from blender_sesgen.pipeline import RenderJob, RenderOptions
    >>> job = RenderJob.prepare("scene.ses", "out/", RenderOptions(samples=16, frames="0:10"), resume=True)
    >>> job.run(progress=lambda i, n, result, elapsed_s: print(f"{i}/{n}"))

What lives where: :mod:`~blender_sesgen.plan` decides what to render (RenderPlan,
RenderOptions, RenderSettings, Device), :mod:`~blender_sesgen.output` owns the output
folder, :mod:`~blender_sesgen.blender.session` the Blender side, :mod:`~blender_sesgen.job`
puts them together. This module only names the public ones.
"""
from __future__ import annotations

from .contract.timing import FrameSelection
from .job import FrameResult, RenderJob
from .plan import Device, RenderOptions, RenderPlan, RenderSettings

__all__ = ["Device", "FrameResult", "FrameSelection", "RenderJob", "RenderOptions", "RenderPlan", "RenderSettings"]
