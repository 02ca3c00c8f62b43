"""The stable Python API of blender_sesgen (docs/api.md): what user scripts may import.

Everything named in ``__all__`` keeps its name and meaning across releases; the modules
behind it (the parser, the pipeline, the Blender layer) are internal and may move:

>>> from blender_sesgen import api as sg
>>> scene = sg.parse_file("scenes/minimal.ses")          # ScriptError: file:line:col: error: ...
>>> print(sg.summary(scene))
>>> results = sg.render(scene, "out/room", sg.RenderOptions(samples=4), progress=print)
>>> doc = sg.Study("studies/city_exposure.toml").run("out/city_exposure")   # a verification study

Only :func:`render` needs Blender's Python module ``bpy``; the rest is pure (numpy).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from .scene.summary import summary
from .contract.progress import Progress
from .errors import ScriptError, SesgenError
from .scene.model import (Asset, Cuboid, Cylinder, Fog, Light, Material, Mesh, Motion, Noise, Quad, Rig, Scene, Sphere,
                    TextureRef, Timeline, World, mat4)
from .render.job import frame_progress, have_bpy
from .pipeline import RenderOptions
from .ses import parse_file, parse_string

__all__ = [
    # scripts
    "parse_file", "parse_string", "summary", "ScriptError", "SesgenError",
    # the scene model
    "Scene", "Rig", "Quad", "Cuboid", "Sphere", "Cylinder", "Mesh", "Asset", "Material", "TextureRef", "Light",
    "World", "Fog", "Noise", "Motion", "Timeline", "builtin_texture", "ego_timeline", "pose_timeline",
    "asset_kinds", "asset_mesh",
    # rendering
    "RenderOptions", "render", "frame_progress",
    # verification studies
    "Study",
]


def builtin_texture(name: "str | int", scale: float = 1.0) -> TextureRef:
    """One of the 12 numbered procedural textures (docs/rendering.md), by name or number."""
    from .scene.textures import BUILTIN_TEXTURES, NAME_TO_NUMBER
    number = NAME_TO_NUMBER.get(name) if isinstance(name, str) else int(name)
    if number not in BUILTIN_TEXTURES:
        raise SesgenError(f"unknown built-in texture {name!r} (one of: {', '.join(NAME_TO_NUMBER)})")
    return TextureRef(kind="builtin", name=BUILTIN_TEXTURES[number][0], number=number, scale=float(scale))


def asset_kinds() -> tuple[str, ...]:
    """The kinds an :class:`Asset` (``ASSET`` statement) can be (docs/ses-language.md)."""
    from .scene import assets
    return tuple(assets.KINDS)


def asset_mesh(kind: str, size: Optional[Sequence[float]] = None, seed: int = 0,
               bend: Sequence[float] = (0.0,), offset: float = 0.0):
    """The exact triangles of a procedural asset, as rendered: ``.vertices`` (n, 3) in the
    asset's own frame (SES axes, metres), ``.faces`` (m, 3), ``.face_surface`` and
    ``.surfaces`` (material names and colours). ``size`` None: the kind's seeded default."""
    from .scene import assets
    if kind not in assets.KINDS:
        raise SesgenError(f"unknown asset kind {kind!r} (one of: {', '.join(assets.KINDS)})")
    return assets.generate(kind, size if size is not None else assets.default_size(kind, seed), seed, bend, offset)


def pose_timeline(T_world_left: np.ndarray) -> Timeline:
    """A :class:`Timeline` from (N, 4, 4) left-camera poses ``T_world_cam`` (SES world,
    OpenCV camera: x right, y down, z forward)."""
    T = np.asarray(T_world_left, dtype=float)
    if T.ndim != 3 or T.shape[1:] != (4, 4) or len(T) == 0:
        raise SesgenError(f"T_world_left must be (N, 4, 4) poses, got shape {T.shape}")
    return Timeline(T_world_left=tuple(mat4(t) for t in T))


def ego_timeline(start_position: Sequence[float], start_rotation_deg: Sequence[float] = (0.0, 0.0, 0.0),
                 steps: Sequence[Sequence[float]] = ()) -> Timeline:
    """The timeline of ``START position x y z rx ry rz`` followed by one ``EGO U V W alpha
    beta gamma`` per step (units per frame, degrees per frame, camera frame): the same
    poses as the script statements (docs/ses-language.md)."""
    from .contract.frames import start_pose
    from .contract.motion import integrate_ego
    return pose_timeline(integrate_ego(start_pose(start_position, start_rotation_deg), [tuple(s) for s in steps]))


def render(scene: "Scene | str | os.PathLike", out: "str | os.PathLike", options: Optional[RenderOptions] = None, *,
           resume: bool = False, force: bool = False, progress: Optional[Callable[[dict], None]] = None,
           progress_mode: str = "off") -> list:
    """Render a script (path) or a :class:`Scene` built in Python into ``out`` (the
    ``sesgen-render/1`` folder of docs/output-format.md) and return one ``FrameResult``
    (``frame``, ``wall_s``, ``cycles_s``) per rendered frame.

    ``progress(event)`` receives the reporter's events (dicts: ``start``, one ``progress``
    per frame with ``done``, ``total``, ``eta_s``, ``frame``..., ``end``), the same objects
    ``--progress json`` prints; ``progress_mode`` also prints them ('plain', 'bar', 'json').
    Bad input raises :class:`SesgenError` before anything is written; needs ``bpy``."""
    from .pipeline import RenderJob
    options = options if options is not None else RenderOptions()
    if isinstance(scene, Scene):
        job = RenderJob.from_scene(scene, out, options, resume=resume, force=force)
    else:
        job = RenderJob.prepare(Path(scene), out, options, resume=resume, force=force)
    if not have_bpy():
        raise SesgenError("rendering needs Blender's Python module 'bpy': pip install 'blender-sesgen[render]' "
                          "(Python 3.11), or run inside Blender: blender -b -P render.py -- SCENE.ses --out DIR")
    todo = job.pending_frames()
    job.build()
    with Progress(len(todo), "render", mode=progress_mode, callback=progress) as bar:
        return job.run(frame_progress(bar))


class Study:
    """A verification study (docs/studies.md) read from its study file (TOML):
    ``SesgenError`` naming the file and the key when it is wrong.

    ``plan(out)`` gives its variants (``.variants``: each with ``name``, ``point``, ``seed``,
    ``stage``, ``key``, ``developed``), distinct renders (``.renders``) and developed
    variants (``.develops``) without running anything; ``run(out)`` runs it (renders, every
    system, evaluation, report; resumes a folder holding the same study) and returns the
    ``results.json`` document (format ``sesgen-study-results/3``: a run's ``ape_rot_rmse_deg`` is
    None where its alignment leaves the rotation free, ``alignment_ill_posed``; a monocular run's
    scale and translation measures None where the fit does not fix the scale, ``scale_ill_posed``);
    ``compare(old, new)`` is ``study compare``'s verdicts (worse, better, same, unmeasured; a
    SesgenError for results of two evaluation versions)."""

    def __init__(self, path: "str | os.PathLike"):
        from .study.spec import load
        self.path = Path(path)
        self.spec = load(self.path)

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def factors(self) -> list[str]:
        return [f.name for f in self.spec.factors]

    @property
    def systems(self) -> list[str]:
        return [s.name for s in self.spec.systems]

    def plan(self, out: "str | os.PathLike"):
        from .study.variants import make_plan
        return make_plan(self.spec, Path(out).absolute() / "scripts")

    def run(self, out: "str | os.PathLike", *, address: Optional[str] = None, num_cpus: Optional[int] = None,
            progress: str = "off", rerun: Sequence[str] = (), no_ray: bool = False) -> dict:
        from .study.runner import StudyRun
        StudyRun(self.spec, out, address=address, num_cpus=num_cpus, progress=progress, rerun=rerun,
                 no_ray=no_ray).run()
        return self.results(out)

    @staticmethod
    def results(out: "str | os.PathLike") -> dict:
        import json
        path = Path(out) / "results.json"
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as e:
            raise SesgenError(f"{path}: no study results there ({e})") from None

    @staticmethod
    def compare(old: dict, new: dict, sigmas: float = 1.0) -> list[dict]:
        from .study.results import compare
        return compare(old, new, sigmas)
