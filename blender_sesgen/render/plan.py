"""What to render, decided and validated once (pure: no bpy, writes nothing).

A :class:`RenderPlan` holds the parsed scene, its script text and hash, the effective
:class:`EffectiveSettings` (script values overridden by :class:`RenderOptions`), the frames
asked for and the per-view camera poses. Everything a user can get wrong is checked here,
before any file exists: the script, the options, and the limits Blender would otherwise
apply silently (image sizes, ids, files that must exist).
"""
from __future__ import annotations

import enum
import functools
import hashlib
import json
import os
import platform
import tomllib
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from ..scene import assets
from ..contract import semantics
from ..contract.camera import scaled_K, scaled_size
from ..contract.depth import DEPTH_BACKGROUND
from ..contract.errors import ContractError
from ..contract.exr_format import LAYOUT_PARTS
from ..contract.pixel_settings import PixelSettings
from ..contract.manifest import SEED_RULE, Manifest, display_relpath, exr_relpath, object_motion_fields
from ..contract.timing import FrameSelection, frame_timestamps
from ..errors import SesgenError
from ..scene.lighting import AGX_LOOKS, VIEW_TRANSFORMS
from ..scene.model import Mesh, Scene, TextureRef
from ..scene.presets import QUALITIES, Preset, effective
from ..ses.checks import MAX_SEED

MAX_IMAGE_SIDE = 16384   # the script's own limit, applied to scaled sizes too
MIN_IMAGE_SIDE = 4       # Blender renders nothing smaller (its resolution's hard minimum)
MAX_ID = 32767           # Blender's object-index pass clamps larger values


class Device(enum.Enum):
    """Where Cycles renders. Parsed once from the user's text."""
    CPU = "cpu"
    GPU = "gpu"

    @classmethod
    def parse(cls, value) -> "Device":
        if isinstance(value, Device):
            return value
        try:
            return cls(str(value).lower())
        except ValueError:
            raise SesgenError(f"--device must be cpu or gpu, got '{value}'") from None


@dataclass(frozen=True)
class RenderOptions:
    """Settings of one render (CLI flags / add-on properties). ``None`` = the script's value.

    ``frames``: a :class:`FrameSelection` (or its text, e.g. ``"0:10"``); ``None`` = all frames.
    ``resolution_scale`` scales the image size and K (square pixels kept). ``quality``: a
    preset (``presets.QUALITIES``) taken as it is; ``samples``/``denoise`` override it
    (``presets.effective``).
    """
    quality: Optional[str] = None
    samples: Optional[int] = None
    denoise: Optional[bool] = None
    seed: Optional[int] = None
    device: Device = Device.CPU
    resolution_scale: float = 1.0
    frames: Optional[FrameSelection] = None
    normal_pass: bool = False
    position_pass: bool = False
    threads: int = 0                     # 0 = Cycles' automatic thread count
    verbose: bool = False                # let Blender print its render log
    rate_hz: Optional[float] = None      # TIMING overrides (None = the script's value)
    exposure_s: Optional[float] = None
    readout_s: Optional[float] = None
    motion_blur: Optional[bool] = None
    still: Optional[bool] = None         # a still camera's held noise (TIMING still)
    fast_pipeline: bool = True           # False: a fresh Cycles render per view (same pixels, slower)
    reuse_exr: Optional[str] = None      # a render folder whose EXRs this one reuses (blender_sesgen.render.reuse)
    cull: bool = False                   # build only what the frames can see (culling.py)

    def __post_init__(self):
        object.__setattr__(self, "device", Device.parse(self.device))
        if self.quality is not None:
            q = str(self.quality).lower()
            if q not in QUALITIES:
                raise SesgenError(f"--quality must be one of {', '.join(QUALITIES)}, got '{self.quality}'")
            object.__setattr__(self, "quality", q)
        if isinstance(self.frames, str):
            try:
                object.__setattr__(self, "frames", FrameSelection.parse(self.frames))
            except ContractError as e:
                raise SesgenError(str(e)) from None


def render_argv(o: RenderOptions) -> list[str]:
    """The render arguments that give the forwarded options of ``o`` (the inverse of
    ``commands.render.forwarded_options``; options at their default are left out): what a farm adds to
    every chunk's render command, what a study renders with."""
    out = []
    for flag, value in (("--quality", o.quality), ("--samples", o.samples)):
        if value is not None:
            out += [flag, str(value)]
    if o.denoise is not None:
        out.append("--denoise" if o.denoise else "--no-denoise")
    if o.seed is not None:
        out += ["--seed", str(o.seed)]
    if o.resolution_scale != 1.0:
        out += ["--resolution-scale", str(o.resolution_scale)]
    if o.device is not Device.CPU:
        out += ["--device", o.device.value]
    out += [flag for flag, on in (("--plain-pipeline", not o.fast_pipeline), ("--normal-pass", o.normal_pass),
                                  ("--position-pass", o.position_pass), ("--cull", o.cull)) if on]
    for flag, value in (("--rate", o.rate_hz), ("--exposure", o.exposure_s), ("--readout", o.readout_s)):
        if value is not None:
            out += [flag, str(value)]
    if o.motion_blur is not None:
        out.append("--motion-blur" if o.motion_blur else "--no-motion-blur")
    if o.still is not None:
        out.append("--still" if o.still else "--no-still")
    return out


@dataclass(frozen=True)
class EffectiveSettings:
    """The settings a render runs with: the script's RENDER statement (``scene.model.RenderSettings``)
    and the rest of the script, overridden by the :class:`RenderOptions`; what the manifest records; :attr:`pixel` is what resume
    and the folder lock compare. ``preset``: the effective sampling and light-path settings
    (``presets.Preset``); ``timing``: the manifest's timing values (None without one: set
    by :class:`RenderPlan` from its sensor plan)."""
    engine: str
    device: Device
    preset: Preset
    seed: int
    resolution_scale: float
    passes: tuple[str, ...]
    width: int
    height: int
    K: tuple[tuple[float, float, float], ...]
    timing: Optional[dict] = None
    cull: bool = False

    @classmethod
    def of(cls, scene: Scene, options: RenderOptions) -> "EffectiveSettings":
        rig = scene.rig
        s = float(options.resolution_scale)
        if not (s > 0.0 and np.isfinite(s)):
            raise SesgenError(f"--resolution-scale must be a positive number, got {options.resolution_scale}")
        W, H = scaled_size(rig.width, rig.height, s)
        if not (MIN_IMAGE_SIDE <= W <= MAX_IMAGE_SIDE and MIN_IMAGE_SIDE <= H <= MAX_IMAGE_SIDE):
            raise SesgenError(f"--resolution-scale {options.resolution_scale:g} gives {W}x{H} px: each side must be "
                              f"{MIN_IMAGE_SIDE}..{MAX_IMAGE_SIDE} px")
        K = scaled_K(rig.K(), rig.width, rig.height, W, H)
        passes = ["combined", "depth", "object_index"]
        if options.normal_pass:
            passes.append("normal")
        if options.position_pass:
            passes.append("position")
        r = scene.render
        if options.samples is not None and options.samples < 1:
            raise SesgenError(f"samples must be >= 1, got {options.samples}")
        if options.seed is not None and not 0 <= options.seed <= MAX_SEED:
            raise SesgenError(f"--seed must lie in 0..{MAX_SEED} (Cycles seeds are 32-bit), got {options.seed}")
        settings = cls(
            engine="CYCLES",
            device=options.device,
            preset=effective(options.quality, options.samples, options.denoise, r.quality, r.samples, r.denoise),
            seed=int(options.seed if options.seed is not None else scene.render.seed),
            resolution_scale=s,
            passes=tuple(passes),
            width=W,
            height=H,
            K=tuple(tuple(float(x) for x in row) for row in K),
            cull=bool(options.cull),
        )
        if settings.cull:
            from .culling import check_cullable
            check_cullable(scene)
        return settings

    @property
    def quality(self) -> str:
        return self.preset.quality

    @property
    def samples(self) -> int:
        return self.preset.samples

    @property
    def denoise(self) -> bool:
        return self.preset.denoise

    @property
    def pixel(self) -> PixelSettings:
        """Every setting that changes pixels (the one record of resume, the lock and the manifest)."""
        return PixelSettings.create(samples=self.samples, denoise=self.denoise, sampling=self.preset.pixel_settings(),
                                    seed=self.seed, resolution_scale=self.resolution_scale, passes=self.passes,
                                    size=(self.width, self.height), timing=self.timing, culling=self.culling_block())

    def manifest_block(self) -> dict:
        """The manifest's ``render`` entry (extended by the session with what it measured)."""
        pixel = self.pixel.render_entries()
        return {
            "engine": self.engine,
            "device": self.device.value.upper(),
            "quality": self.quality,
            "quality_overridden": list(self.preset.overridden),
            "samples": pixel["samples"],
            "denoise": pixel["denoise"],
            "sampling": pixel["sampling"],
            "seed": pixel["seed"],
            "seed_rule": SEED_RULE,
            "resolution_scale": pixel["resolution_scale"],
            "passes": pixel["passes"],
            "exr": {"codec": "ZIP", "bits": 32, "layout": LAYOUT_PARTS},
            **({"culling": pixel["culling"]} if "culling" in pixel else {}),
        }

    def culling_block(self) -> Optional[dict]:
        """The manifest's ``render.culling`` (None without ``--cull``)."""
        if not self.cull:
            return None
        from .culling import EDGE_MARGIN_PX, RGB_RADIUS_M
        return {"rule": "each chunk builds the objects whose bounds meet a view volume of its frames "
                        "(both views, to the far plane)" + ("" if self.preset.shading == "flat" else
                                                            ", their sun shadows' casters and everything "
                                                            f"within {RGB_RADIUS_M:g} m of the camera"),
                "exact": "depth, object ids, normals, positions" + (", flat RGB" if self.preset.shading == "flat"
                                                                     else ""),
                "edge_margin_px": EDGE_MARGIN_PX}


@dataclass(frozen=True)
class RenderPlan:
    """One scene, its settings and the frames to render: validated once, immutable."""
    scene: Scene
    scene_text: str
    options: RenderOptions
    settings: EffectiveSettings
    frames: tuple[int, ...]
    scene_sha256: str = field(default="")

    @classmethod
    def from_file(cls, scene_path, options: RenderOptions = RenderOptions(),
                  edit: Optional[Callable[[str], str]] = None) -> "RenderPlan":
        """Parse and validate ``scene_path`` with ``options`` (SesgenError/ScriptError);
        ``edit`` rewrites the script's text first (the plan's script is the edited one)."""
        path = Path(scene_path)
        if not path.is_file():
            raise SesgenError(f"{scene_path}: no such script")
        try:
            data = path.read_bytes()
        except OSError as e:
            raise SesgenError(f"{scene_path}: cannot read: {e.strerror}") from None
        if edit is not None:   # undecodable bytes pass through, for the parser to locate
            data = edit(data.decode("utf-8", errors="surrogateescape")).encode("utf-8", errors="surrogateescape")
        from ..ses import parse_bytes
        scene = parse_bytes(data, source=str(scene_path), base_dir=str(path.resolve().parent))
        return cls.from_scene(scene, options, scene_text=data.decode("utf-8", errors="replace"))

    @classmethod
    def from_scene(cls, scene: Scene, options: RenderOptions = RenderOptions(), *,
                   scene_text: Optional[str] = None) -> "RenderPlan":
        """A plan for a Scene built in Python (``scene_text``: its script, if it has one)."""
        text = scene_text if scene_text is not None else scene_text_for(scene)
        validate_scene(scene)
        settings = EffectiveSettings.of(scene, options)
        N = scene.frames
        try:
            frames = tuple((options.frames or FrameSelection()).resolve(N))
        except ContractError as e:
            raise SesgenError(str(e)) from None
        # the sensor plan validates the timing overrides (SesgenError) before anything is written
        settings = replace(settings, timing=_sensor_plan(scene, settings, options).timing_values())
        return cls(scene, text, options, settings, frames, sha256_text(text))

    @cached_property
    def sensor(self):
        """The sensor statements' plan (``sensor.render_plan.SensorPlan``; inactive without them)."""
        return _sensor_plan(self.scene, self.settings, self.options)

    @property
    def writes_display(self) -> bool:
        """Whether Blender writes the display-referred PNGs (``rgb/``): for every render but
        ``gt``, whose flat RGB is a picture of the ground truth, not a photograph: its EXR is
        enough, and the view transform and PNG writer would cost it 15-20 % per frame
        (docs/rendering.md, Speed). The sensor path (motion blur, rolling shutter, lens)
        writes them too, through the same view transform and exposure, so that a blurred
        frame looks as the sharp one but for its blur (a SENSOR's own images, when there
        is one, are the camera's: readers take those first)."""
        return self.settings.preset.shading != "flat"

    @cached_property
    def view_poses(self) -> dict[str, np.ndarray]:
        """``{view: (N, 4, 4) T_world_cam}`` (OpenCV camera, SES world)."""
        poses = {"left": self.scene.timeline.left()}
        if self.scene.rig.stereo:
            poses["right"] = self.scene.timeline.right(self.scene.rig.baseline)
        return poses

    @property
    def views(self) -> tuple[str, ...]:
        return self.scene.rig.views

    def manifest(self, *, channels: dict, render_extra: dict, blender_version: Optional[str],
                 fps: Optional[float] = None) -> Manifest:
        """The manifest of this plan with no frame complete yet; ``channels``: the EXR channel
        names of each product (the session knows them), ``render_extra``: what the session
        adds to the ``render`` entry (exposure, EXR layout)."""
        scene, s = self.scene, self.settings
        N = scene.frames
        fps = self.sensor.rate_hz if fps is None else fps
        render = self.settings.manifest_block()
        render["exr"]["layout"] = render_extra.pop("exr_layout", render["exr"]["layout"])
        render.update(render_extra)
        extra = {}
        if scene.noise is not None:
            extra["noise"] = {"sigma": float(scene.noise.sigma), "seed": int(scene.noise.seed)}
        if scene.fog is not None:
            extra["fog"] = {"start": scene.fog.start, "end": scene.fog.end, "colour": list(scene.fog.colour),
                            "applies_to": "rgb only"}
        extra.update(self.sensor.manifest_entries(N))
        if self.writes_display:
            extra["display"] = {
                "kind": "display-referred sRGB, 8-bit PNG (the Combined pass through the view transform)",
                "view_transform": VIEW_TRANSFORMS[scene.look.view],
                "look": AGX_LOOKS[scene.look.look],
                "files": {v: [display_relpath(v, k) for k in range(N)] for v in self.views}}
        product_channels = {k: channels[k] for k in ("rgb", "depth", "object_index")}
        for p in ("normal", "position"):
            if p in s.passes:
                product_channels[p] = channels[p]
        return Manifest(
            resolution=(s.width, s.height),
            K=np.array(s.K),
            baseline=float(scene.rig.baseline),
            views=self.views,
            poses=self.view_poses,
            files={v: [exr_relpath(v, k) for k in range(N)] for v in self.views},
            timestamps_s=frame_timestamps(N, fps, self.sensor.frame_times_s(1)[0]),
            fps=float(fps),
            near=float(scene.rig.near),
            far=float(scene.rig.far),
            frames_complete=[False] * N,
            depth={"kind": "planar_z", "background": DEPTH_BACKGROUND, "channel": channels["depth"]},
            segmentation={"kind": "object_index", "background": 0, "channel": channels["object_index"]},
            channels=product_channels,
            objects=object_table(scene),
            render=render,
            scene_source=scene.source,
            scene_sha256=self.scene_sha256,
            generator={"name": "blender-sesgen", "version": generator_version(), "blender": blender_version,
                       "python": platform.python_version()},
            extra=extra,
        )


# --- helpers ----------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def generator_version() -> str:
    """This package's version as the manifest records it, read from its extension manifest
    (``blender_manifest.toml``; building the add-on checks that ``__version__`` agrees): as
    data, so that no module the add-on imports imports the package root (an import cycle)."""
    with open(Path(__file__).resolve().parents[1] / "blender_manifest.toml", "rb") as f:
        return str(tomllib.load(f)["version"])


def _sensor_plan(scene: Scene, settings: EffectiveSettings, o: RenderOptions):
    from .sensor.render_plan import SensorPlan, TimingOverrides
    return SensorPlan.create(scene, settings, TimingOverrides(o.rate_hz, o.exposure_s, o.readout_s, o.motion_blur,
                                                                 o.still))


def sha256_text(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def scene_text_for(scene: Scene) -> str:
    """Stand-in for the script text of a Scene built in Python (no .ses file): its JSON."""
    return "// scene built in Python; its model as JSON:\n// " + json.dumps(scene.to_json(), sort_keys=True) + "\n"


def texture_label(tex: Optional[TextureRef]) -> Optional[str]:
    if tex is None:
        return None
    if tex.kind == "builtin":
        return tex.name
    return tex.source or tex.path


def object_table(scene: Scene) -> list[dict]:
    """The manifest's ``objects``: id, name, shape, texture, material, semantic ``class`` and
    its Cityscapes ``label_id`` (contract.semantics) of every object of the script, its
    object frame's pose as the script places it (``T_world_obj_rest``) and its object-frame
    bounding ``box`` where the geometry is known (:mod:`.bounds`), and whether it moves (with
    its per-frame poses if it does). A BLEND file's objects are added by the job, which
    learns their ids when loading them."""
    from ..scene.bounds import object_box
    from ..scene.dynamics import rest_pose
    out, boxes = [], {}
    for o in scene.objects:
        tex = o.texture
        if tex is None and o.material:
            try:
                tex = scene.material(o.material).texture
            except KeyError:
                tex = None
        label = semantics.BY_NAME[semantics.canonical(o.semantic_class)]
        motion = scene.motion_of(o.id)
        row = {"id": int(o.id), "name": o.name, "shape": o.shape,
               "texture": texture_label(tex), "material": o.material,
               "class": label.name, "label_id": label.id, "T_world_obj_rest": rest_pose(o).tolist(),
               **(object_motion_fields(motion.kind, motion.poses()) if motion else object_motion_fields())}
        box = object_box(o, boxes)
        if box is not None:
            row["box"] = box.tolist()
        if o.shape == "asset":   # what regenerates its mesh: blender_sesgen.scene.assets.generate(...)
            row.update(kind=o.kind, seed=int(o.seed), size=[float(x) for x in o.size])
            if assets.KINDS[o.kind].strip:
                row.update(bend=[float(x) for x in o.bend], offset=float(o.offset))
        out.append(row)
    return out


def validate_scene(scene: Scene) -> None:
    """What the parser cannot know for a Scene built in Python: ids, references, files."""
    if scene.frames < 1:
        raise SesgenError("the scene has no frames (no START/motion?)")
    ids = [o.id for o in scene.objects]
    for o in scene.objects:
        if not (1 <= o.id <= MAX_ID):
            raise SesgenError(f"object {o.name}: id {o.id} outside 1..{MAX_ID}")
        if o.material:
            try:
                scene.material(o.material)
            except KeyError:
                raise SesgenError(f"object {o.name}: unknown material '{o.material}'") from None
        tex = o.texture
        if tex is not None and tex.kind == "image" and not (tex.path and os.path.isfile(tex.path)):
            raise SesgenError(f"object {o.name}: texture file not found: {tex.source or tex.path}")
        if isinstance(o, Mesh) and not os.path.isfile(o.path):
            raise SesgenError(f"object {o.name}: mesh file not found: {o.source}")
    for m in scene.materials:
        if m.texture is not None and m.texture.kind == "image" and not (m.texture.path and os.path.isfile(m.texture.path)):
            raise SesgenError(f"material {m.name}: texture file not found: {m.texture.source or m.texture.path}")
    if len(set(ids)) != len(ids):
        raise SesgenError("object ids must be unique")
