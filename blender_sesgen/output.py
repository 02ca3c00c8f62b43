"""A render's output folder: what it holds, whether a plan may write into it, and every
write into it (pure: numpy + stdlib; the files' layout is ``contract.manifest``'s).

The folder owns the one comparison of settings (:meth:`OutputFolder.same_settings`): a
folder holding frames of the same scene rendered with the same pixel-affecting settings
can be resumed; anything else is refused unless the user forces it. Every file is written
under a temporary name and renamed (``contract.atomic``), so stopping at any point leaves a
folder that ``--resume`` completes with results identical to an uninterrupted run.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Optional

from .contract import atomic
from .contract.errors import ContractError
from .contract.manifest import (DISPLAY_DIR, display_relpath, EXR_DIR, FORMAT, MANIFEST, POSES_DIR, SCENE_COPY, Manifest, exr_relpath,
                                load_json, trajectory_relpaths)
from .contract.trajectory_files import format_ego_table, format_kitti, format_tum
from .errors import SesgenError
from .plan import RenderPlan, RenderSettings

_OWN_EXR = re.compile(r"^\d{6}\.exr$")
_OWN_PNG = re.compile(r"^\d{6}\.png$")


class OutputFolder:
    """The folder ``root`` as seen by one render (see the module docstring)."""

    def __init__(self, root):
        self.root = Path(root)
        self._previous: Optional[dict] = None
        self._loaded = False
        self._kept: Optional[dict] = None
        self._kept_for: Optional[RenderPlan] = None
        self.manifest: Optional[Manifest] = None    # this render's manifest, once begun

    # --- what is there ------------------------------------------------------------------
    def previous(self) -> Optional[dict]:
        """The manifest found in the folder (raw dict, read once), or None."""
        if not self._loaded:
            path = self.root / MANIFEST
            self._previous = load_json(path) if path.is_file() else None
            self._loaded = True
        return self._previous

    @staticmethod
    def same_settings(manifest: Optional[dict], settings: RenderSettings) -> bool:
        """True when ``manifest``'s frames were rendered with the pixel-affecting ``settings``
        (device aside: the same output is expected on any device)."""
        if not manifest:
            return False
        r = manifest.get("render", {})
        return (r.get("samples") == settings.samples and r.get("denoise") == settings.denoise
                and r.get("seed") == settings.seed
                and float(r.get("resolution_scale", 1.0)) == settings.resolution_scale
                and list(r.get("passes", [])) == list(settings.passes)
                and manifest.get("resolution") == [settings.width, settings.height])

    def resumable(self, plan: RenderPlan) -> Optional[dict]:
        """The previous manifest if its frames may be kept for ``plan`` (same scene and
        settings), else None. Decided once per plan."""
        if self._kept_for is not plan:
            prev = self.previous()
            same = prev and prev.get("scene_sha256") == plan.scene_sha256 and self.same_settings(prev, plan.settings)
            self._kept, self._kept_for = (prev if same else None), plan
        return self._kept

    def check(self, plan: RenderPlan, force: bool) -> None:
        """Refuse a folder that is not ours or holds another scene's output (unless ``force``).
        Writes nothing."""
        out = self.root
        if out.exists() and not out.is_dir():
            raise SesgenError(f"--out {out}: exists and is not a folder")
        if not out.exists():
            return
        try:
            previous = self.previous()
        except ContractError as e:
            self._previous, self._loaded = None, True
            if not force:
                raise SesgenError(f"--out {out}: unreadable manifest.json ({e.detail}); use --force to overwrite") \
                    from None
            return
        if previous is None:
            if any(out.iterdir()) and not force:
                raise SesgenError(f"--out {out}: folder is not empty and holds no render (no manifest.json); "
                                  "use --force to write into it anyway")
            return
        if previous.get("format") != FORMAT and not force:
            raise SesgenError(f"--out {out}: holds a render of format {previous.get('format')!r}; "
                              "use --force to overwrite")
        if previous.get("scene_sha256") != plan.scene_sha256 and not force:
            raise SesgenError(f"--out {out}: holds the output of a different scene ({previous.get('scene_source')}); "
                              "use --force to replace it")
        if not self.same_settings(previous, plan.settings) and any(previous.get("frames_complete", [])) and not force:
            r = previous.get("render", {})
            raise SesgenError(f"--out {out}: holds frames rendered with other settings "
                              f"(samples {r.get('samples')}, denoise {r.get('denoise')}, seed {r.get('seed')}, "
                              f"resolution {previous.get('resolution')}); use --force to re-render")

    def pending(self, plan: RenderPlan, resume: bool) -> list[int]:
        """The plan's frames still to render (all of them unless resuming)."""
        if self.manifest is not None:
            done = self.manifest.frames_complete
        elif resume and self.resumable(plan) is not None:
            done = self.previous().get("frames_complete", [])
        else:
            return list(plan.frames)
        return [k for k in plan.frames if not (k < len(done) and done[k])]

    # --- writing ------------------------------------------------------------------------
    def begin(self, plan: RenderPlan, manifest: Manifest, resume: bool, force: bool) -> None:
        """Create the folder, scene.ses, poses/ and the manifest (keeping the completion
        state of frames already rendered with the same scene and settings)."""
        out = self.root
        prev = self.previous()
        if prev is not None and force and prev.get("scene_sha256") != plan.scene_sha256:
            self._remove_own_outputs()
        for view in plan.views:
            (out / EXR_DIR / view).mkdir(parents=True, exist_ok=True)
            (out / DISPLAY_DIR / view).mkdir(parents=True, exist_ok=True)
        self._remove_stale_temporaries()
        atomic.write_text(out / SCENE_COPY, plan.scene_text, durable=True)
        kept = self.resumable(plan)
        if kept is not None:
            prev_done = kept.get("frames_complete", [])
            redo = set() if resume else set(plan.frames)
            manifest = manifest.with_complete(
                [bool(k < len(prev_done) and prev_done[k] and k not in redo and self._files_exist(manifest, k))
                 for k in range(manifest.frames)])
        self._write_pose_files(plan, manifest)
        self.manifest = manifest
        manifest.write(out)

    def exr_path(self, view: str, k: int) -> Path:
        return self.root / exr_relpath(view, k)

    def display_path(self, view: str, k: int) -> Path:
        return self.root / display_relpath(view, k)

    def mark_complete(self, k: int) -> None:
        """Record frame ``k`` complete (its files are in place)."""
        self.manifest.frames_complete[k] = True
        self.manifest.write(self.root)

    def _files_exist(self, m: Manifest, k: int) -> bool:
        display = (m.extra.get("display") or {}).get("files") or {}
        return all((self.root / m.files[v][k]).is_file() and
                   (v not in display or (self.root / display[v][k]).is_file()) for v in m.views)

    def _write_pose_files(self, plan: RenderPlan, manifest: Manifest) -> None:
        (self.root / POSES_DIR).mkdir(parents=True, exist_ok=True)
        rel = trajectory_relpaths(manifest.views)
        for view, T in plan.view_poses.items():
            atomic.write_text(self.root / rel["tum"][view],
                              format_tum(manifest.timestamps_s, T, "T_world_cam: OpenCV camera, SES world"))
            atomic.write_text(self.root / rel["kitti"][view], format_kitti(T))
        atomic.write_text(self.root / rel["ego"], format_ego_table(plan.scene.timeline.ego_table()))

    def _remove_own_outputs(self) -> None:
        """Delete the files a previous render wrote (our own names only; nothing else)."""
        for view in ("left", "right"):
            for folder, own in ((EXR_DIR, _OWN_EXR), (DISPLAY_DIR, _OWN_PNG)):
                d = self.root / folder / view
                if d.is_dir():
                    for f in d.iterdir():
                        if own.match(f.name) or atomic.is_temp_name(f.name):
                            f.unlink()
        pd = self.root / POSES_DIR
        if pd.is_dir():
            for f in pd.iterdir():
                if f.name.endswith((".tum.txt", ".kitti.txt")) or f.name == "ego.txt":
                    f.unlink()
        (self.root / MANIFEST).unlink(missing_ok=True)
        self._previous, self._loaded, self._kept_for = None, True, None

    def _remove_stale_temporaries(self) -> None:
        for view in ("left", "right"):
            for folder in (EXR_DIR, DISPLAY_DIR):
                d = self.root / folder / view
                if d.is_dir():
                    for f in d.iterdir():
                        if atomic.is_temp_name(f.name) or (f.name.startswith(".") and ".exr.tmp-" in f.name):
                            f.unlink()
