"""The automatic exposure's preview kept in the asset cache (blender/exposure.py: ``cached_measure``,
``preview_key``; issue 29: the build).

Oracle: the same scene built with the cache off, which renders its preview: a build that reads
the preview back must have the same film exposure and the same metered brightness of frame 0
(taken from the preview's image), float for float; a changed input (the scene, the size, the
code) must render its own preview. ``fingerprint`` and ``reads_files`` against values written
by hand.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from blender_sesgen.scene.assets import cache


def _build(tmp_path, monkeypatch, name: str, extra=(), scale: float = 1.0):
    """A small AUTOEXPOSURE scene built for frames 0:3 (its exposure preview is frame 0's
    metering preview; frame 1's follows in the metering pass, which reuses the exposure
    preview's Cycles session when it renders); (film exposure, metered brightness of frames 0
    and 1, previews rendered)."""
    from blender_sesgen.blender import exposure
    from blender_sesgen.pipeline import RenderJob, RenderOptions
    from render_support import oracle_script
    rendered = []
    real = exposure.measure_exposure
    monkeypatch.setattr(exposure, "measure_exposure", lambda *a, **k: rendered.append(1) or real(*a, **k))
    script = tmp_path / f"{name}.ses"
    script.write_text(oracle_script(width=64, height=48, focal=44.0, principal=(32.1, 23.4), baseline=0,
                                    extra_lines=["TIMING rate 20 exposure 0.02 blur off", "SENSOR seed 1",
                                                 "AUTOEXPOSURE", *extra]))
    job = RenderJob.prepare(script, tmp_path / f"out-{name}-{len(rendered)}-{scale}",
                            RenderOptions(samples=1, frames="0:3", resolution_scale=scale))
    job.build()
    s = job.session
    return s.exposure, tuple(s.metering[:2]), len(rendered)


@pytest.mark.render
def test_a_build_reads_the_preview_back_bit_for_bit_and_a_changed_input_renders_it(tmp_path, monkeypatch):
    from blender_sesgen.blender import exposure
    monkeypatch.setenv(cache.ENV, "off")
    oracle = _build(tmp_path, monkeypatch, "a")                  # the preview rendered
    assert oracle[2] == 1 and oracle[0] > 0 and min(oracle[1]) > 0
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    first = _build(tmp_path, monkeypatch, "a")                   # rendered, kept
    again = _build(tmp_path, monkeypatch, "a")                   # read back: no preview
    assert first == oracle and again[:2] == oracle[:2] and again[2] == 0
    assert len(list((tmp_path / "cache" / "exposure").glob("*.npy"))) == 1
    # a brighter world, another size, another code: each renders its own preview
    world = _build(tmp_path, monkeypatch, "a", extra=["WORLD sky strength 3"])
    assert world[2] == 1 and world[0] != oracle[0]
    small = _build(tmp_path, monkeypatch, "a", scale=0.5)
    assert small[2] == 1
    monkeypatch.setattr(exposure, "code_version", lambda: "another code")
    assert _build(tmp_path, monkeypatch, "a")[2] == 1
    # a damaged file is rendered again, and replaced
    monkeypatch.undo()
    monkeypatch.setenv(cache.ENV, str(tmp_path / "cache"))
    for f in (tmp_path / "cache" / "exposure").glob("*.npy"):
        f.write_bytes(f.read_bytes()[:100])
    damaged = _build(tmp_path, monkeypatch, "a")
    assert damaged == oracle


def test_fingerprint_tells_every_bit():
    from blender_sesgen.blender.exposure import fingerprint
    from blender_sesgen.scene.model import TextureRef
    a = TextureRef(kind="builtin", name="brick", number=3, scale=1.0)
    assert fingerprint([a, {"k": (1, 2.0)}]) == fingerprint([TextureRef(kind="builtin", name="brick", number=3),
                                                           {"k": (1, 2.0)}])
    for other in (dataclasses.replace(a, scale=np.nextafter(1.0, 2.0)), dataclasses.replace(a, number=4)):
        assert fingerprint(other) != fingerprint(a)
    x = np.arange(6, dtype=np.float64).reshape(2, 3)
    assert fingerprint(x) != fingerprint(x.astype(np.float32)) != fingerprint(x.reshape(3, 2))
    assert fingerprint((1, 2)) != fingerprint([1, 2]) and fingerprint(1) != fingerprint(1.0) != fingerprint("1.0")
    assert fingerprint(np.float64(1.0)) != fingerprint(1.0)


@pytest.mark.render
def test_what_does_not_pickle_is_not_cached():
    from blender_sesgen.blender.exposure import preview_key
    assert preview_key([1.0]) is not None and preview_key([lambda: 1.0]) is None


def test_a_scene_that_reads_files_is_not_cached(repo):
    from blender_sesgen.blender.exposure import reads_files
    from blender_sesgen.ses import parse_file
    from blender_sesgen.scene.model import TextureRef
    scene = parse_file(str(repo / "scenes" / "paper_room.ses"))
    assert not reads_files(scene)
    image = TextureRef(kind="image", name="wall", path="/data/wall.png", source="wall.png")
    obj = next(o for o in scene.objects if hasattr(o, "texture"))
    assert reads_files(dataclasses.replace(scene, objects=(dataclasses.replace(obj, texture=image),)))
