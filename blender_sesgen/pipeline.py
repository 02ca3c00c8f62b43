"""Rendering from Python, frame by frame: the public names (docs/api.md) of the classes the
command line and the add-on render with (they import them from ``plan`` and ``job``).

    >>> from blender_sesgen.pipeline import RenderJob, RenderOptions
    >>> job = RenderJob.prepare("scene.ses", "out/", RenderOptions(samples=16, frames="0:10"), resume=True)
    >>> job.run(progress=lambda i, n, result, elapsed_s: print(f"{i}/{n}"))

What lives where: :mod:`~blender_sesgen.render.plan` decides what to render (RenderPlan,
RenderOptions, EffectiveSettings, Device), :mod:`~blender_sesgen.render.folder` owns the output
folder, :mod:`~blender_sesgen.blender.session` the Blender side, :mod:`~blender_sesgen.render.job`
puts them together. This module only names the public ones.
"""
from __future__ import annotations

from .contract.timing import FrameSelection
from .render.job import FrameResult, RenderJob
from .render.plan import Device, EffectiveSettings, RenderOptions, RenderPlan

RenderSettings = EffectiveSettings   # its earlier public name, kept for scripts that use it

__all__ = ["Device", "EffectiveSettings", "FrameResult", "FrameSelection", "RenderJob", "RenderOptions", "RenderPlan",
           "RenderSettings"]
