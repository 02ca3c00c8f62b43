"""Image quality per second of the render presets, side by side with Blender's own defaults
and BlenderProc's defaults, in one run at one resolution.

    .venv/bin/python bench/quality.py [--scene scenes/paper_room.ses] [--frame 0] [--scale 0.25]
        [--views left] [--configs gt draft final reference blender blenderproc]
        [--try NAME:base=final,samples=24,adaptive_threshold=0.03 ...] [--repeat 1]
        [--reference-samples 4096] [--cache out/bench-cache] [--crop 0.25 [--crop-centre 0.5,0.5]]
        [--explain] [--save DIR]

For every configuration the frame is rendered through the real Blender session (the same
code as ``render``) and compared with a converged reference render of the same frame:
``--reference-samples`` samples per pixel, no adaptive sampling, no denoiser, no clamping,
Cycles' default light paths (12 bounces, caustics on), Filter Glossy off (Cycles' default
blurs glossy seen after a blurry bounce). A reference of fewer samples errs on the safe side
(its own noise, independent of the render's, adds to the error measured) except for sub-pixel
highlights far above display white, which it can miss as the render does. The reference is cached in
``--cache`` (keyed by the script without its comments and RENDER statement, the seed, frame, size, crop, views and
Blender version): it is the expensive part.

``--crop f`` renders only the centred window of f·W × f·H pixels (Cycles' render border,
cropped; the denoiser sees that window): with ``--scale 1 --crop 0.25`` the quality at the
script's own resolution for the cost of a 0.25-scale render (at 0.25 scale the denoiser sees
the whole view with 16× fewer pixels per feature, a harder case than the renders users make).
``--crop-centre x,y`` moves the window's centre (fractions of the width from the left and
of the height from the top).

Columns: PSNR and SSIM (vo_reference.evaluate.image_quality) of the sRGB-encoded beauty
pass against the reference's, averaged over the views; seconds per stereo frame (the wall
time of the session's render of the frame's views, EXR writing included; with one view,
twice that view's time, marked ``x2``), the CPU seconds the process used for it (robust
to a shared machine) and Cycles' own time; dB/s = PSNR / s per stereo frame; and the
ratios to the BlenderProc configuration measured in the same run. Every configuration
uses the same film exposure (the automatic exposure is measured once).

``--explain``: where each configuration's error lies, to find what keeps a scene below a
floor: the share of the squared error carried by the 0.1 % and 1 % worst pixels, by the
pixels the reference shows clipped white (highlights brighter than the display: sun glints),
and by each kind of object (the ASSET kind or statement of the object each pixel sees, from
a ``gt`` render's object index), beside the share of pixels each covers; the PSNR of
the 5 × 5 box-filtered images (the error left once fine detail is averaged out); and how many
of the reference's white highlights a render shows darker, and of those how many its samples
had found (white in the noisy pass before the denoiser: the denoiser took them away).
``--save DIR``: each configuration's sRGB images (and its noisy pass) as ``DIR/NAME.npz``.

Configurations: the presets (``blender_sesgen.scene.presets``); ``blender``: a new Blender
scene's Cycles settings (4096 samples, adaptive threshold 0.01, OpenImageDenoise, 12
bounces, indirect clamp 10, caustics); ``blenderproc``: BlenderProc 2's defaults
(``DefaultConfig``: at most 1024 samples, adaptive threshold 0.01, Intel OpenImageDenoise,
3 bounces: diffuse 3, glossy 0, transmission 0, transparent 8) with all CPU threads;
``today``: the renderer's settings before the presets (16 samples, no denoiser, 6/3/3/6
bounces, indirect clamp 10, no caustics).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import resource
import statistics
import sys
import tempfile
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]

from blender_sesgen.contract.colour import linear_to_srgb
from blender_sesgen.contract.exr_format import PASS_COMBINED, PASS_NOISY
from blender_sesgen.files.exr import read_exr
from blender_sesgen.scene.presets import PRESETS, Preset
from vo_reference.evaluate.image_quality import psnr, ssim

CYCLES_DEFAULT_PATHS = dict(max_bounces=12, diffuse_bounces=4, glossy_bounces=4, transmission_bounces=12,
                            volume_bounces=0, transparent_bounces=8, caustics=True, light_tree=True)
OTHERS = {
    "blender": Preset("custom", samples=4096, adaptive_threshold=0.01, denoise=True, clamp_indirect=10.0,
                      **CYCLES_DEFAULT_PATHS),
    "blenderproc": Preset("custom", samples=1024, adaptive_threshold=0.01, denoise=True, max_bounces=3,
                          diffuse_bounces=3, glossy_bounces=0, transmission_bounces=0, volume_bounces=0,
                          transparent_bounces=8, clamp_indirect=10.0, caustics=True, light_tree=True),
    # the renderer before the presets: 16 samples, no denoiser, 6/3/3/6 bounces, indirect clamp 10
    "today": Preset("custom", samples=16),
}


def reference_preset(samples: int) -> Preset:
    return Preset("custom", samples=samples, denoise=False, clamp_direct=0.0, clamp_indirect=0.0,
                  filter_glossy=0.0, **CYCLES_DEFAULT_PATHS)


def parse_try(text: str) -> tuple[str, Preset]:
    """``NAME:base=final,samples=24,...`` -> a Preset (fields of presets.Preset)."""
    name, _, spec = text.partition(":")
    kv = dict(item.split("=", 1) for item in spec.split(",") if item)
    base = PRESETS[kv.pop("base", "final")]
    types = {f.name: f.type for f in fields(Preset)}
    conv = {}
    for k, v in kv.items():
        if k not in types:
            raise SystemExit(f"--try {text}: unknown setting {k!r}")
        t = str(types[k])
        conv[k] = (v.lower() in ("1", "true", "on", "yes")) if "bool" in t else int(v) if t == "int" else \
            float(v) if t == "float" else v
    return name, replace(base, quality="custom", overridden=(), **conv)


def scene_key(plan) -> str:
    """The script's hash without its comment lines and its RENDER statement, which the
    reference replaces entirely (the seed it may set is in the plan's settings, added here):
    a library script that drops its pinned samples or whose header names its generator
    elsewhere keeps its cached references."""
    lines = [ln for ln in plan.scene_text.splitlines(keepends=True)
             if not ln.lstrip().upper().startswith("RENDER") and not ln.lstrip().startswith("//")]
    return hashlib.sha256(("".join(lines) + f"\nseed {plan.settings.seed}").encode()).hexdigest()


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


class Bench:
    def __init__(self, args):
        from blender_sesgen.render.plan import RenderOptions, RenderPlan
        self.args = args
        self.plan = RenderPlan.from_file(args.scene, RenderOptions(resolution_scale=args.scale, device=args.device,
                                                                   frames=f"{args.frame}:{args.frame + 1}"))
        self.views = tuple(self.plan.views) if args.views == "both" else ("left",)
        self.exposure = None
        self.tmp = Path(tempfile.mkdtemp(prefix="sesgen-quality-"))

    def session(self, preset: Preset):
        from blender_sesgen.blender.session import BlenderSession
        plan = replace(self.plan, settings=replace(self.plan.settings, preset=preset))
        s = BlenderSession(plan, known_exposure=self.exposure)
        if preset.shading != "flat" and self.exposure is None:
            self.exposure = s.exposure
        if self.args.crop < 1:  # after the exposure, which is measured on the whole view
            r, f, (cx, cy) = s.built.scene.render, self.args.crop, self.args.crop_centre
            r.use_border, r.use_crop_to_border = True, True
            r.border_min_x, r.border_max_x = cx - f / 2, cx + f / 2
            r.border_min_y, r.border_max_y = 1 - cy - f / 2, 1 - cy + f / 2  # Blender's y is up
        return s

    def render(self, preset: Preset, repeat: int) -> dict:
        """Render the frame's views with ``preset``; images and timings (median of repeats)."""
        from blender_sesgen.blender import render as brender
        from blender_sesgen.blender import rig
        from blender_sesgen.contract.manifest import render_seed
        s = self.session(preset)
        k = self.args.frame
        paths = {v: self.tmp / f"{v}.exr" for v in self.views}
        walls, cpus, cycles = [], [], []
        for i in range(max(1, repeat)):
            c0, t0 = cpu_s(), time.perf_counter()
            if self.views == tuple(self.plan.views):
                stats = s.render_frame(k, paths)
            else:  # one view: the session's per-view path
                stats = brender.render_views(s.built.scene, s.built.cameras, self.views, rig.blender_frame(k),
                                             render_seed(self.plan.settings.seed, k, 0), paths)
            walls.append(time.perf_counter() - t0)
            cpus.append(cpu_s() - c0)
            cyc = [st["cycles_s"] for st in stats.values()]
            cycles.append(None if None in cyc else sum(cyc))
        images, noisy = {}, {}
        for v in self.views:
            ch = read_exr(paths[v])
            rgb = np.stack([next(a for n, a in ch.items() if n.endswith(f"{PASS_COMBINED[0]}.{c}")) for c in "RGB"], -1)
            images[v] = linear_to_srgb(rgb)
            if any(n.endswith(f"{PASS_NOISY[0]}.R") for n in ch):  # denoised: the samples before the denoiser
                noisy[v] = linear_to_srgb(np.stack([next(a for n, a in ch.items() if n.endswith(f"{PASS_NOISY[0]}.{c}"))
                                                    for c in "RGB"], -1))
        factor = len(self.plan.views) / len(self.views)
        med = statistics.median
        return {"images": images, "noisy": noisy, "s_stereo": med(walls) * factor, "cpu_stereo": med(cpus) * factor,
                "cycles_stereo": None if None in cycles else med(cycles) * factor, "factor": factor}

    def reference(self) -> dict:
        from blender_sesgen.blender import compat
        a = self.args
        # the keys of the caches made before --crop stay as they were
        cropped, centred = a.crop < 1, a.crop_centre == (0.5, 0.5)
        crop = ({"crop": a.crop} | ({} if centred else {"crop_centre": list(a.crop_centre)})) if cropped else {}
        key = json.dumps({"scene": scene_key(self.plan), "frame": a.frame, "scale": a.scale, "views": self.views,
                          "samples": a.reference_samples, "blender": compat.version_string(),
                          "preset": reference_preset(a.reference_samples).pixel_settings()} | crop, sort_keys=True)
        h = hashlib.sha256(key.encode()).hexdigest()[:16]
        tag = (f"-c{a.crop}" + ("" if centred else "@{:g},{:g}".format(*a.crop_centre))) if cropped else ""
        cache = Path(a.cache) / f"{Path(a.scene).stem}-f{a.frame}-s{a.scale}{tag}-{h}.npz"
        if cache.is_file():
            data = np.load(cache)
            self.exposure = float(data["exposure"])
            return {"images": {v: data[v] for v in self.views}, "cached": True,
                    "s_stereo": float(data["s_stereo"])}
        r = self.render(reference_preset(a.reference_samples), 1)
        cache.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(cache, exposure=self.exposure, s_stereo=r["s_stereo"], **r["images"])
        r["cached"] = False
        return r


def object_kinds(bench) -> np.ndarray:
    """Per pixel of the left view, the kind of object it sees ('sky' for none): a ``gt``
    render's object index mapped through the script's objects."""
    from blender_sesgen.scene.model import Asset
    bench.render(PRESETS["gt"], 1)
    ch = read_exr(bench.tmp / "left.exr")
    index = next(a for n, a in ch.items() if n.endswith(("Object Index.X", "IndexOB.X")))
    names = {o.id: (o.kind if isinstance(o, Asset) else type(o).__name__.lower()) for o in bench.plan.scene.objects}
    return np.vectorize(lambda i: names.get(int(i), "sky" if i == 0 else "other"), otypes=[object])(index)


def explain(bench, rows: dict, ref: dict) -> None:
    from scipy.ndimage import uniform_filter
    kinds = object_kinds(bench)
    R = ref["images"]["left"].astype(float)
    clipped = (R >= 0.999).all(-1)
    print(f"# where the error lies (left view; reference clipped white: {clipped.mean():.2%} of the pixels)")
    for name, r in rows.items():
        img = r["images"]["left"].astype(float)
        e = ((img - R) ** 2).mean(-1)
        worst = np.sort(e.ravel())[::-1].cumsum() / e.sum()
        blur = uniform_filter(img, (5, 5, 1)) - uniform_filter(R, (5, 5, 1))
        share = {k: (e[kinds == k].sum() / e.sum(), (kinds == k).mean()) for k in np.unique(kinds)}
        top = sorted(share.items(), key=lambda kv: -kv[1][0])[:6]
        print(f"{name:14s} worst 0.1 %/1 % of pixels: {worst[max(int(e.size / 1000) - 1, 0)]:.0%}/"
              f"{worst[max(int(e.size / 100) - 1, 0)]:.0%} of the error; clipped highlights {e[clipped].sum() / e.sum():.0%} "
              f"(PSNR without them {psnr_mse(e[~clipped].mean()):.2f} dB); 5x5-averaged PSNR {psnr_mse((blur ** 2).mean()):.2f} dB")
        print(f"{'':14s} by object: " + ", ".join(f"{k} {v:.0%} ({px:.0%} of px)" for k, (v, px) in top))
        # the reference's white highlights this render shows darker: never sampled, or found by the
        # samples (their estimate before the denoiser is white too) and taken away by the denoiser
        lost = clipped & (img.mean(-1) < 0.9)
        if clipped.any():
            line = (f"{'':14s} highlights: {lost.sum() / clipped.sum():.0%} of the reference's white pixels darker "
                    f"(< 0.9), {e[lost].sum() / e.sum():.0%} of the error")
            if "left" in r.get("noisy", {}):
                found = lost & (r["noisy"]["left"].mean(-1) >= 0.999)
                line += f"; of those, white before the denoiser: {found.sum() / max(lost.sum(), 1):.0%}"
            print(line)


def psnr_mse(mse: float) -> float:
    return float(10 * np.log10(1.0 / max(mse, 1e-12)))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=str(REPO / "scenes" / "paper_room.ses"))
    p.add_argument("--frame", type=int, default=0)
    p.add_argument("--scale", type=float, default=0.25,
                   help="resolution scale (0.25: 160x120 for the paper room, as in docs/rendering.md; a 4096-sample "
                        "reference at 0.5 takes hours on 2 cores)")
    p.add_argument("--crop", type=float, default=1.0,
                   help="render only the centred window of this fraction of the width and height (e.g. --scale 1 "
                        "--crop 0.25: the script's resolution at the cost of a 0.25-scale render)")
    p.add_argument("--crop-centre", type=lambda s: tuple(float(v) for v in s.split(",")), default=(0.5, 0.5),
                   metavar="X,Y", help="the window's centre, fractions of the width (from the left) and height (from "
                                       "the top); default the view's centre")
    p.add_argument("--views", choices=("left", "both"), default="left")
    p.add_argument("--configs", nargs="*", default=["gt", "draft", "final", "reference", "blender", "blenderproc"])
    p.add_argument("--try", dest="tries", nargs="*", default=[], metavar="NAME:key=value,...",
                   help="extra configurations: a preset (base=...) with settings changed")
    p.add_argument("--repeat", type=int, default=1, help="timed renders per configuration (median)")
    p.add_argument("--reference-samples", type=int, default=4096)
    p.add_argument("--device", choices=("cpu", "gpu"), default="cpu",
                   help="Cycles device of every render (a cached reference serves either device)")
    p.add_argument("--cache", default=str(REPO / "out" / "bench-cache"))
    p.add_argument("--json", metavar="FILE", help="also write the results as JSON")
    p.add_argument("--save", metavar="DIR", help="also write each configuration's sRGB images (and the reference's) "
                                                 "as DIR/NAME.npz, for a closer look")
    p.add_argument("--explain", action="store_true", help="where each configuration's error lies (worst pixels, "
                                                              "clipped highlights, object kinds)")
    a = p.parse_args(argv)
    configs = {}
    for name in a.configs:
        configs[name] = PRESETS.get(name) or OTHERS.get(name)
        if configs[name] is None:
            raise SystemExit(f"unknown configuration {name!r}")
    configs.update(parse_try(t) for t in a.tries)

    bench = Bench(a)
    load0 = os.getloadavg()[0]
    s = bench.plan.settings
    cx, cy = a.crop_centre
    if not 0 < a.crop <= 1 or not (a.crop / 2 <= cx <= 1 - a.crop / 2 and a.crop / 2 <= cy <= 1 - a.crop / 2):
        raise SystemExit("--crop must be in (0, 1] and its window inside the view (--crop-centre)")
    window = (f" (the {round(s.width * a.crop)}x{round(s.height * a.crop)} window centred at x {cx:g} W, y {cy:g} H "
              "from the top)" if a.crop < 1 else "")
    print(f"# quality bench: {Path(a.scene).name} frame {a.frame}, {s.width}x{s.height}{window}, "
          f"views {'+'.join(bench.views)}, {os.cpu_count()} CPUs, {platform.machine()}, load {load0:.1f} at the start", flush=True)
    t0 = time.perf_counter()
    ref = bench.reference()
    print(f"# reference: {a.reference_samples} samples, {'cached' if ref['cached'] else 'rendered'} "
          f"({ref['s_stereo']:.0f} s per stereo frame)", flush=True)
    head = (f"{'config':14s} {'quality':9s} {'samples':>10s} {'s/stereo':>9s} {'cpu s':>8s} {'cycles s':>9s} "
            f"{'PSNR dB':>8s} {'SSIM':>7s} {'dB/s':>8s}")
    print(head, flush=True)
    rows = {}
    for name, preset in configs.items():
        r = bench.render(preset, a.repeat)
        r["psnr"] = float(np.mean([psnr(r["images"][v], ref["images"][v]) for v in bench.views]))
        r["ssim"] = float(np.mean([ssim(r["images"][v], ref["images"][v]) for v in bench.views]))
        r["preset"] = preset
        rows[name] = r
        samp = f"<={preset.samples}/{preset.adaptive_threshold:g}" if preset.adaptive else str(preset.samples)
        mark = " x2" if r["factor"] > 1 else ""
        cyc = f"{r['cycles_stereo']:9.2f}" if r["cycles_stereo"] is not None else f"{'-':>9s}"
        print(f"{name:14s} {preset.quality:9s} {samp:>10s} {r['s_stereo']:9.2f}{mark} {r['cpu_stereo']:8.2f} {cyc} "
              f"{r['psnr']:8.2f} {r['ssim']:7.4f} {r['psnr'] / r['s_stereo']:8.2f}", flush=True)
    if a.save:
        out = Path(a.save)
        out.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(out / "reference.npz", **ref["images"])
        for name, r in rows.items():
            np.savez_compressed(out / f"{name}.npz", **r["images"], **{f"{v}_noisy": im for v, im in r["noisy"].items()})
    if "blenderproc" in rows:
        bp = rows["blenderproc"]
        print("# against blenderproc (same run):")
        for name, r in rows.items():
            print(f"#   {name:14s} time x{r['s_stereo'] / bp['s_stereo']:.3f} (cpu x{r['cpu_stereo'] / bp['cpu_stereo']:.3f})"
                  f"  PSNR {r['psnr'] - bp['psnr']:+.2f} dB  SSIM {r['ssim'] - bp['ssim']:+.4f}")
    if a.explain:
        explain(bench, rows, ref)
    print(f"# {time.perf_counter() - t0:.0f} s in all; load {os.getloadavg()[0]:.1f} at the end")
    if a.json:
        out = {n: {k: v for k, v in r.items() if k not in ("images", "noisy", "preset")} | {"preset": r["preset"].pixel_settings(),
               "samples": r["preset"].samples, "denoise": r["preset"].denoise} for n, r in rows.items()}
        Path(a.json).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
