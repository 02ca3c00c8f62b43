"""The render pipeline shared by the CLI and the Blender add-on (no top-level bpy import).

    job = RenderJob.prepare("scene.ses", "out/", RenderOptions(samples=16), resume=True)
    job.build()                      # the Blender scene (bpy)
    for k in job.pending_frames():   # the add-on: one frame per timer tick
        job.render_frame(k)          # all views of frame k, atomically, then the manifest

``prepare`` parses and validates everything and checks the output folder, and writes
nothing: a bad script, bad options or a folder holding another scene's output raise
:class:`SesgenError` before any file exists. ``begin()`` (called by ``render_frame`` if
needed) creates the folder, ``scene.ses``, ``poses/`` and ``manifest.json``. Each EXR is
written under a temporary name and renamed; the frame is then marked complete in the
manifest (also replaced atomically). Stopping at any point leaves a consistent folder that
``--resume`` completes with results identical to an uninterrupted run (the Cycles seed of
each frame/view depends only on the seed, the frame and the view).
"""
from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from . import contract
from .contract import RenderOptions
from .errors import SesgenError
from .model import Mesh, Scene

_OWN_EXR = re.compile(r"^(\d{6}\.exr|\.\d{6}\.exr\.tmp-\d+|\.\d{6}\.exr\.tmp-\d+\.exr)$")
_OWN_PNG = re.compile(r"^(\d{6}\.png|\.\d{6}\.png\.tmp-\d+\.png)$")


def parse_frames(text: str, n_frames: Optional[int] = None) -> tuple[int, int]:
    """``A:B`` (half-open, like Python), ``A:``, ``:B`` or ``K`` -> (start, stop)."""
    t = text.strip()
    try:
        if ":" in t:
            a, b = t.split(":", 1)
            start = int(a) if a.strip() else 0
            stop = int(b) if b.strip() else (n_frames if n_frames is not None else 2**31)
        else:
            start = int(t)
            stop = start + 1
    except ValueError:
        raise SesgenError(f"--frames: expected A:B, A:, :B or K (frame indices), got '{text}'") from None
    return start, stop


@dataclass
class FrameResult:
    frame: int
    wall_s: float
    cycles_s: Optional[float]
    views: dict = field(default_factory=dict)


class RenderJob:
    """One render of one scene into one output folder (see the module docstring)."""

    def __init__(self, scene: Scene, scene_text: str, out_dir: Path, options: RenderOptions,
                 settings: contract.EffectiveSettings, frames: list[int], previous: Optional[dict],
                 resume: bool, force: bool):
        self.scene = scene
        self.scene_text = scene_text
        self.out_dir = Path(out_dir)
        self.options = options
        self.settings = settings
        self.frames = frames                       # requested frame indices, in order
        self.resume = resume
        self.force = force
        self._previous = previous                  # manifest found in the folder (or None)
        self.manifest: Optional[dict] = None       # set by begin()
        self.built = None                          # blender.builder.BuiltScene after build()
        self.exposure: Optional[float] = None      # film exposure, set by build()
        self.timings: list[FrameResult] = []

    # --- preparation (pure, writes nothing) -------------------------------------------

    @classmethod
    def prepare(cls, scene_path, out_dir, options: RenderOptions = RenderOptions(), *,
                resume: bool = False, force: bool = False) -> "RenderJob":
        """Parse and validate ``scene_path`` and check ``out_dir``. Writes nothing."""
        path = Path(scene_path)
        if not path.is_file():
            raise SesgenError(f"{scene_path}: no such script")
        try:
            data = path.read_bytes()
        except OSError as e:
            raise SesgenError(f"{scene_path}: cannot read: {e.strerror}") from None
        from .ses import parse_bytes
        scene = parse_bytes(data, source=str(scene_path), base_dir=str(path.resolve().parent))
        return cls.from_scene(scene, out_dir, options, scene_text=data.decode("utf-8", errors="replace"),
                              resume=resume, force=force)

    @classmethod
    def from_scene(cls, scene: Scene, out_dir, options: RenderOptions = RenderOptions(), *,
                   scene_text: Optional[str] = None, resume: bool = False, force: bool = False) -> "RenderJob":
        """Like :meth:`prepare` for a Scene built in Python (``scene_text`` = its script, if any)."""
        text = scene_text if scene_text is not None else contract.scene_text_for(scene)
        _validate_scene(scene)
        settings = contract.effective_settings(scene, options)
        if settings.samples < 1:
            raise SesgenError(f"samples must be >= 1, got {settings.samples}")
        if options.device.lower() not in ("cpu", "gpu"):
            raise SesgenError(f"--device must be cpu or gpu, got '{options.device}'")
        N = scene.frames
        start, stop = options.frames if options.frames is not None else (0, N)
        stop = min(stop, N)
        if not (0 <= start < stop):
            raise SesgenError(f"--frames {start}:{stop} selects no frame of a {N}-frame sequence (frames 0..{N - 1})")
        frames = list(range(start, stop))
        previous = _check_out_dir(Path(out_dir), contract.sha256_text(text), settings, force)
        return cls(scene, text, Path(out_dir), options, settings, frames, previous, resume, force)

    # --- writing the folder ------------------------------------------------------------

    def begin(self) -> None:
        """Create the folder, scene.ses, poses/ and the manifest (keeping the completion
        state of frames already rendered when resuming)."""
        if self.manifest is not None:
            return
        out = self.out_dir
        if self._previous is not None and self.force and self._previous.get("scene_sha256") != contract.sha256_text(self.scene_text):
            _remove_own_outputs(out)
            self._previous = None
        for view in self.scene.rig.views:
            (out / contract.EXR_DIR / view).mkdir(parents=True, exist_ok=True)
            (out / contract.DISPLAY_DIR / view).mkdir(parents=True, exist_ok=True)
        _remove_stale_temporaries(out)
        contract.atomic_write_text(out / contract.SCENE_COPY, self.scene_text)
        m = contract.build_manifest(self.scene, contract.sha256_text(self.scene_text), self.settings,
                                    contract.generator_info(_blender_version()))
        from .blender.compat import exr_channel_names
        ch = exr_channel_names()
        m["channels"] = {k: ch[k] for k in ("rgb", "depth", "object_index")}
        if self.options.normal_pass:
            m["channels"]["normal"] = ch["normal"]
        if self.options.position_pass:
            m["channels"]["position"] = ch["position"]
        m["depth"]["channel"] = ch["depth"]
        m["render"]["exr"]["layout"] = ch.get("layout", m["render"]["exr"]["layout"])
        if self.exposure is not None:
            m["render"]["exposure"] = self.exposure
            m["render"]["exposure_rule"] = (f"auto: 90th-percentile luminance of frame 0 = {exposure_target()}"
                                            if self.auto_exposure else
                                            f"fixed: {self.scene.look.exposure_ev:g} EV (factor 2^EV)")
        m["segmentation"]["channel"] = ch["object_index"]
        if self.built is not None and self.built.imported:   # BLEND objects: ids given when loaded
            m["objects"] = m["objects"] + list(self.built.imported)
        if self._previous is not None and _same_settings(self._previous, self.settings):
            prev_done = self._previous.get("frames_complete", [])
            redo = set() if self.resume else set(self.frames)
            m["frames_complete"] = [bool(k < len(prev_done) and prev_done[k] and k not in redo and self._files_exist(m, k))
                                    for k in range(self.scene.frames)]
        contract.write_pose_files(out, self.scene, m["timestamps"])
        self.manifest = m
        contract.atomic_write_json(out / contract.MANIFEST, m)

    def _files_exist(self, m: dict, k: int) -> bool:
        return all((self.out_dir / m["files"][v][k]).is_file() and (self.out_dir / m["display"]["files"][v][k]).is_file()
                   for v in m["views"])

    # --- Blender -----------------------------------------------------------------------

    def build(self) -> None:
        """Build the scene in Blender (a dedicated scene 'SESGen'; rebuild replaces)."""
        from .blender import builder, render
        s = self.settings
        self.built = builder.build_scene(self.scene, width=s.width, height=s.height, K=s.K,
                                         view_poses=contract.view_poses(self.scene))
        if self.options.device.lower() == "gpu":
            render.enable_gpu()
        render.configure(self.built.scene, samples=s.samples, denoise=s.denoise, device=self.options.device,
                         threads=self.options.threads, normal_pass=self.options.normal_pass,
                         position_pass=self.options.position_pass,
                         view_transform=contract.VIEW_TRANSFORMS[self.scene.look.view])
        self._set_exposure()

    @property
    def auto_exposure(self) -> bool:
        """LOOK exposure auto, or no LOOK exposure and no emitting LIGHT (portals emit nothing)."""
        look = self.scene.look
        if look.auto_exposure is not None:
            return look.auto_exposure
        return not any(light.kind != "portal" for light in self.scene.lights)

    def _set_exposure(self) -> None:
        """One film exposure for the whole sequence: automatic (blender/exposure.py; taken from
        the manifest being resumed so that resumed frames match) or the LOOK's fixed EV."""
        if not self.auto_exposure:
            self.exposure = float(2.0 ** self.scene.look.exposure_ev)
            from .blender import exposure
            exposure.set_exposure(self.built.scene, self.exposure)
            return
        from .blender import exposure, rig
        prev = (self._previous or {}).get("render", {}).get("exposure")
        same_scene = (self._previous or {}).get("scene_sha256") == contract.sha256_text(self.scene_text)
        if prev is not None and same_scene and _same_settings(self._previous, self.settings):
            self.exposure = float(prev)
        else:
            self.exposure = exposure.measure_exposure(self.built.scene, self.built.cameras["left"], rig.blender_frame(0))
        exposure.set_exposure(self.built.scene, self.exposure)

    def pending_frames(self) -> list[int]:
        """Requested frames not complete yet (all requested ones unless resuming)."""
        if self.manifest is None:
            if self.resume and self._previous is not None and _same_settings(self._previous, self.settings):
                done = self._previous.get("frames_complete", [])
                return [k for k in self.frames if not (k < len(done) and done[k])]
            return list(self.frames)
        done = self.manifest["frames_complete"]
        return [k for k in self.frames if not done[k]]

    def render_frame(self, k: int) -> FrameResult:
        """Render every view of frame ``k``; EXRs written atomically, then the manifest."""
        if self.built is None:
            self.build()
        self.begin()
        from .blender import render, rig
        res = FrameResult(frame=k, wall_s=0.0, cycles_s=0.0)
        t0 = time.perf_counter()
        for vi, view in enumerate(self.scene.rig.views):
            final = self.out_dir / contract.exr_relpath(view, k)
            tmp = final.with_name(f".{final.name}.tmp-{os.getpid()}.exr")
            display = self.out_dir / contract.display_relpath(view, k)
            display_tmp = display.with_name(f".{display.name}.tmp-{os.getpid()}.png")
            st = render.render_view(self.built.scene, self.built.cameras[view], rig.blender_frame(k),
                                    contract.render_seed(self.settings.seed, k, vi), str(tmp),
                                    quiet=not self.options.verbose, display_path=str(display_tmp))
            if not tmp.is_file() or not display_tmp.is_file():
                raise RuntimeError(f"Blender wrote no file for frame {k}, view {view}")
            os.replace(display_tmp, display)
            os.replace(tmp, final)
            res.views[view] = st
            if st["cycles_s"] is None:
                res.cycles_s = None
            elif res.cycles_s is not None:
                res.cycles_s += st["cycles_s"]
        res.wall_s = time.perf_counter() - t0
        self.manifest["frames_complete"][k] = True
        contract.atomic_write_json(self.out_dir / contract.MANIFEST, self.manifest)
        self.timings.append(res)
        return res

    def run(self, progress: Optional[Callable[[int, int, FrameResult, float], None]] = None) -> list[FrameResult]:
        """Render every pending frame; ``progress(i, n, result, elapsed_s)`` after each."""
        todo = self.pending_frames()
        if self.built is None:
            self.build()
        self.begin()
        t0 = time.perf_counter()
        out = []
        for i, k in enumerate(todo):
            r = self.render_frame(k)
            out.append(r)
            if progress:
                progress(i + 1, len(todo), r, time.perf_counter() - t0)
        return out


# --- helpers ----------------------------------------------------------------------------

def exposure_target() -> float:
    from .lighting_data import EXPOSURE_TARGET
    return EXPOSURE_TARGET


def _blender_version() -> Optional[str]:
    try:
        from .blender.compat import version_string
        return version_string()
    except ImportError:
        return None


def _validate_scene(scene: Scene) -> None:
    if scene.frames < 1:
        raise SesgenError("the scene has no frames (no START/motion?)")
    ids = [o.id for o in scene.objects]
    for o in scene.objects:
        if not (1 <= o.id <= 32767):
            raise SesgenError(f"object {o.name}: id {o.id} outside 1..32767")
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


def _same_settings(manifest: dict, settings: contract.EffectiveSettings) -> bool:
    r = manifest.get("render", {})
    return (r.get("samples") == settings.samples and r.get("denoise") == settings.denoise
            and r.get("seed") == settings.seed
            and float(r.get("resolution_scale", 1.0)) == settings.resolution_scale
            and list(r.get("passes", [])) == list(settings.passes)
            and manifest.get("resolution") == [settings.width, settings.height])


def _check_out_dir(out: Path, scene_sha: str, settings: contract.EffectiveSettings, force: bool) -> Optional[dict]:
    """Refuse a folder that is not ours or holds another scene's output (unless ``force``)."""
    if out.exists() and not out.is_dir():
        raise SesgenError(f"--out {out}: exists and is not a folder")
    if not out.exists():
        return None
    try:
        previous = contract.load_manifest(out)
    except (OSError, ValueError) as e:
        if not force:
            raise SesgenError(f"--out {out}: unreadable manifest.json ({e}); use --force to overwrite") from None
        return None
    if previous is None:
        if any(out.iterdir()) and not force:
            raise SesgenError(f"--out {out}: folder is not empty and holds no render (no manifest.json); "
                              "use --force to write into it anyway")
        return None
    if previous.get("format") != contract.FORMAT and not force:
        raise SesgenError(f"--out {out}: holds a render of format {previous.get('format')!r}; use --force to overwrite")
    if previous.get("scene_sha256") != scene_sha and not force:
        raise SesgenError(f"--out {out}: holds the output of a different scene ({previous.get('scene_source')}); "
                          "use --force to replace it")
    if not _same_settings(previous, settings) and any(previous.get("frames_complete", [])) and not force:
        r = previous.get("render", {})
        raise SesgenError(f"--out {out}: holds frames rendered with other settings "
                          f"(samples {r.get('samples')}, denoise {r.get('denoise')}, seed {r.get('seed')}, "
                          f"resolution {previous.get('resolution')}); use --force to re-render")
    return previous


def _remove_own_outputs(out: Path) -> None:
    """Delete the files a previous render wrote (our own names only; nothing else)."""
    for view in ("left", "right"):
        for folder, own in ((contract.EXR_DIR, _OWN_EXR), (contract.DISPLAY_DIR, _OWN_PNG)):
            d = out / folder / view
            if d.is_dir():
                for f in d.iterdir():
                    if own.match(f.name):
                        f.unlink()
    pd = out / contract.POSES_DIR
    if pd.is_dir():
        for f in pd.iterdir():
            if f.name.endswith((".tum.txt", ".kitti.txt")) or f.name == "ego.txt":
                f.unlink()
    (out / contract.MANIFEST).unlink(missing_ok=True)


def _remove_stale_temporaries(out: Path) -> None:
    for view in ("left", "right"):
        for folder in (contract.EXR_DIR, contract.DISPLAY_DIR):
            d = out / folder / view
            if d.is_dir():
                for f in d.iterdir():
                    if f.name.startswith(".") and (".exr.tmp-" in f.name or ".png.tmp-" in f.name):
                        f.unlink()
