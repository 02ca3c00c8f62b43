"""The add-on's settings: one PropertyGroup on every Scene (``scene.sesgen``)."""
from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..contract.timing import DEFAULT_FPS
from ..scene.lighting import BUILTIN_HDRIS
from ..scene.camera_profiles import PROFILES
from ..study.factors import FACTORS
from ..study.systems import BUILTIN as BUILTIN_SYSTEMS
from .export_job import TARGETS
from .preview import KINDS

_LABELS = {"kitti": "KITTI", "euroc": "EuRoC", "tum": "TUM RGB-D", "robotcar": "RobotCar"}
# built here: Blender evaluates the annotations below where module names inside a generator are not seen
CAMERA_ITEMS = (("script", "Script", "The script's own SENSOR (an ideal camera without one)"),
                *((n, _LABELS.get(n, n.capitalize()), f"{p.camera} (SENSOR profile {n})") for n, p in PROFILES.items()))


class SESGEN_PG_settings(bpy.types.PropertyGroup):
    script_path: StringProperty(name="Script", description="The SES scene script (.ses)",
                                subtype="FILE_PATH", default="")
    # frames
    # half-open First:Stop, as --frames A:B everywhere (contract.timing)
    use_frame_range: BoolProperty(name="Frame Range", default=False,
                                  description="Render only the frames First..Stop-1 (else every frame)")
    frame_first: IntProperty(name="First", min=0, default=0, description="First frame to render (0-based)")
    frame_stop: IntProperty(name="Stop", min=1, default=1,
                            description="The frame after the last one rendered: First..Stop-1, as --frames First:Stop")
    # sampling
    quality: EnumProperty(name="Quality", default="script", description="Render preset (docs/rendering.md)",
                          items=(("script", "Script", "The script's RENDER quality (final when it names none)"),
                                 ("gt", "Ground Truth", "Exact depth and ids at primary-ray cost; flat-shaded RGB, "
                                  "not photoreal"),
                                 ("draft", "Draft", "At least 32 dB PSNR against a converged render"),
                                 ("final", "Final", "At least 38 dB PSNR (the default)"),
                                 ("reference", "Reference", "At least 45 dB PSNR")))
    world: EnumProperty(name="World", default="script",
                        description="Light the scene with a bundled HDRI instead of the script's WORLD "
                                    "(the rendered scene.ses says so)",
                        items=(("script", "Script", "The script's WORLD (the default lighting when it has none)"),
                               *((n, n.capitalize(), f"Blender's bundled CC0 HDRI '{n}' (WORLD hdri {n})")
                                 for n in BUILTIN_HDRIS)))
    camera_profile: EnumProperty(name="Camera", default="script", items=CAMERA_ITEMS,
                                 description="See the scene through a real camera's measured profile instead of "
                                             "the script's SENSOR (docs/sensors.md; the rendered scene.ses says so)")
    world_strength: FloatProperty(name="Strength", min=0.0, soft_max=10.0, default=1.0,
                                  description="HDRI strength (WORLD hdri ... strength)")
    world_rotation: FloatProperty(name="Rotation", soft_min=-180.0, soft_max=180.0, default=0.0,
                                  description="HDRI rotation about the vertical, degrees (WORLD hdri ... rotation)")
    override_render: BoolProperty(name="Override Script Settings", default=False,
                                  description="Use these samples/denoise/seed over the quality preset and the "
                                              "script's RENDER line")
    samples: IntProperty(name="Samples", min=1, soft_max=4096, default=16,
                         description="Exactly this many Cycles samples per pixel (adaptive sampling off)")
    denoise: BoolProperty(name="Denoise", default=True,
                          description="OpenImageDenoise on the beauty pass (ground truth is never denoised)")
    seed: IntProperty(name="Seed", min=0, default=0, description="Base seed (per-frame/view seeds derive from it)")
    # camera timing (the script's TIMING statement; docs/ses-language.md)
    override_timing: BoolProperty(name="Override Script Timing", default=False,
                                  description="Use this frame rate, exposure, readout, motion blur and still "
                                              "camera instead of the script's TIMING line")
    rate_hz: FloatProperty(name="Frame Rate", min=0.001, soft_max=240.0, default=DEFAULT_FPS, unit="NONE",
                           description="Frames per second (frame k is stamped at the middle of its exposure)")
    exposure_ms: FloatProperty(name="Exposure (ms)", min=0.0, soft_max=100.0, default=0.0,
                               description="Exposure time; with motion blur on, the image is blurred over it")
    readout_ms: FloatProperty(name="Readout (ms)", min=0.0, soft_max=100.0, default=0.0,
                              description="Rolling-shutter readout, top row to bottom row (0: global shutter)")
    motion_blur: BoolProperty(name="Motion Blur", default=False,
                              description="Blur over the exposure (ground truth stays sharp, at mid-exposure)")
    still: BoolProperty(name="Still Camera", default=True,
                        description="Where the camera stands still its frames hold the path tracer's noise: each "
                                    "shows the stretch's first frame's beauty reprojected (needs motion blur)")
    resolution_scale: FloatProperty(name="Resolution Scale", min=0.01, max=4.0, soft_max=2.0, default=1.0,
                                    description="Scale the image size and K (e.g. 0.5 for a quick look)")
    device: EnumProperty(name="Device", items=(("cpu", "CPU", "Render on the CPU"),
                                               ("gpu", "GPU", "Render on the GPU (CUDA/OptiX/HIP/Metal/oneAPI)")),
                         default="cpu")
    # output
    output_dir: StringProperty(name="Output", description="Output folder (manifest.json, exr/, poses/, scene.ses)",
                               subtype="DIR_PATH", default="")
    resume: BoolProperty(name="Resume", default=True,
                         description="Render only the frames not complete in the output folder")
    overwrite: BoolProperty(name="Overwrite", default=False,
                            description="Write into a folder that holds another scene's or other settings' output")
    # preview
    preview_frame: IntProperty(name="Frame", min=0, default=0, description="Frame to preview")
    preview_view: EnumProperty(name="View", items=(("left", "Left", ""), ("right", "Right", "")), default="left")
    preview_kind: EnumProperty(name="Show", default="disparity",
                               items=tuple((k, "RGB" if k == "rgb" else k.capitalize(),
                                            f"Preview the {k} of a rendered frame") for k in KINDS))
    # export (vo_reference, run as a child process)
    export_target: EnumProperty(name="Layout", items=TARGETS, default="kitti-odometry",
                                description="The dataset layout to export the rendered frames to")
    export_dir: StringProperty(name="Export To", subtype="DIR_PATH", default="",
                               description="Folder of the exported dataset (several renders can share one tree)")
    export_sequence: StringProperty(name="Sequence", default="",
                                    description="The render's slot in the dataset tree: KITTI NN, SceneFlow "
                                                "TRAIN/A/0000, a TartanAir/vKITTI 2 sub-folder (empty: the default)")
    export_undistort: BoolProperty(name="Undistort", default=False,
                                   description="A render with a distorting LENS: write pinhole images and ground truth "
                                               "(needed by every layout but EuRoC, ROS 2 bag, Bayer and Cityscapes)")
    vo_command: StringProperty(name="VO Command", default="",
                               description="How to run vo_reference (a Python with pip install 'blender-sesgen[vo]'), "
                                           "e.g. /path/venv/bin/vo-reference; empty: vo-reference on PATH")
    # a one-factor study of the script (blender_sesgen.study, run as a child process)
    study_factor: EnumProperty(name="Factor", default="exposure_time",
                               description="What changes from variant to variant (docs/studies.md)",
                               items=tuple((f.name, f.name, f"{f.doc} ({f.unit})") for f in FACTORS.values()))
    study_levels: StringProperty(name="Levels", default="0.005, 0.01, 0.02",
                                 description="The factor's levels, benign to harsh (numbers in its unit, or names)")
    study_systems: StringProperty(name="Systems", default="accurate-stereo, opencv-stereo",
                                  description="Built-in systems, comma-separated: " + ", ".join(BUILTIN_SYSTEMS))
    study_frames: IntProperty(name="Frames", min=0, default=0, description="The first N frames (0: all)")
    study_resolution: FloatProperty(name="Size", min=0.01, max=4.0, default=0.5,
                                    description="Image size of the study's renders (a scale of the script's)")
    study_dir: StringProperty(name="Study Folder", subtype="DIR_PATH", default="",
                              description="The study's folder: renders, runs, results.json, report.html")
    study_command: StringProperty(name="Study Command", default="",
                                  description="How to run sesgen outside Blender (a Python with pip install "
                                              "'blender-sesgen[render,vo,farm]'), e.g. /path/venv/bin/python -m "
                                              "blender_sesgen; empty: sesgen on PATH")
    # state shown in the panel
    status: StringProperty(name="Status", default="")
    progress: FloatProperty(name="Progress", min=0.0, max=1.0, default=0.0, subtype="FACTOR")
    origin_scene: StringProperty(name="Origin Scene", default="", options={"HIDDEN"},
                                 description="The scene the settings came from before a build switched to SESGen")


def snapshot(pg) -> dict:
    """The settings as a plain dict (safe to keep after the scene holding them is gone)."""
    return {k: getattr(pg, k) for k in pg.bl_rna.properties.keys() if k != "rna_type"}


def restore(pg, values: dict) -> None:
    for k, v in values.items():
        setattr(pg, k, v)


def abspath(path: str) -> str:
    """A Blender path ('//' = relative to the .blend) as an absolute file-system path."""
    import os
    return os.path.abspath(bpy.path.abspath(path)) if path else ""


def render_options(values: dict):
    """RenderOptions from a settings snapshot (None = the script's value)."""
    from ..contract.timing import FrameSelection
    from ..render.plan import RenderOptions
    o, t = values["override_render"], values.get("override_timing", False)
    q = values.get("quality", "script")
    return RenderOptions(
        quality=None if q == "script" else q,
        samples=values["samples"] if o else None,
        denoise=values["denoise"] if o else None,
        seed=values["seed"] if o else None,
        device=values["device"],
        resolution_scale=float(values["resolution_scale"]),
        frames=FrameSelection.of(values["frame_first"], values["frame_stop"]) if values["use_frame_range"] else None,
        rate_hz=float(values["rate_hz"]) if t else None,
        exposure_s=values["exposure_ms"] / 1000.0 if t else None,
        readout_s=values["readout_ms"] / 1000.0 if t else None,
        motion_blur=bool(values["motion_blur"]) if t else None,
        still=bool(values["still"]) if t else None,
    )
