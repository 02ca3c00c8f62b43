"""The library materials' level of detail (blender/library/lod.py), measured: a sample's CPU with
and without it, its noise, and its bias (the LOD scene's mean image against the full scene's).

For each variant (``full``: the library as built; ``lod``: with the level of detail) the scene is
built once and the crop's left view rendered at each of ``--samples`` (no denoiser, the preset's
light paths, ``final`` by default) under Cycles seeds 0 and 1 at the largest count, 0 at the
others. A sample's CPU s a stereo frame of the window is the slope between the smallest and the
largest count (the scene's fixed costs cancel). Two renders of N samples differ by MSE = 2 v / N:
v, the variance one sample leaves (sRGB units). The bias: with L0, L1 (lod) and F0, F1 (full)
the squared difference of the two converged images is
MSE((L0 + L1) / 2, (F0 + F1) / 2) - MSE(L0, L1) / 4 - MSE(F0, F1) / 4 (their own noise removed):
printed as a PSNR (``inf``: below the noise), with its 90 % block bootstrap (20-px tiles). At
equal CPU the LOD takes ``ratio`` times the samples: its error against the truth is
v_lod / (N ratio) + bias^2 against the full scene's v_full / N (printed for N = the largest count
and for 32).

``--states off lod relief all`` (the figures in docs): one LOD scene instead, its switches set per
state (``off``: the full graph everywhere; ``relief`` / ``all``: bounds, the relief / every recipe
dropped at every distance), the states' renders interleaved ``--repeat`` times so that the shared
machine's load drifts cancel; biases against ``off``.

Usage: ``PYTHONPATH=. .venv/bin/python bench/material_lod.py [--scene scenes/city_kitti.ses]
[--crop 0.25] [--crop-centre 0.5,0.5] [--samples 8 32] [--exposure E] [--variants full lod lod@0.1]
[--states off lod relief all --repeat 2] [--out DIR]``. Measured in bench/RESULTS.md (session 21,
lod21)."""
import argparse, json, os, sys, time
from dataclasses import replace
from pathlib import Path
import importlib.util
import numpy as np
REPO = str(Path(__file__).resolve().parents[1])
sys.path.insert(0, REPO)
spec = importlib.util.spec_from_file_location("qb", f"{REPO}/bench/quality.py")
qb = importlib.util.module_from_spec(spec); spec.loader.exec_module(qb)


def bias_map(L0, L1, F0, F1) -> np.ndarray:
    """Per pixel, an unbiased estimate of the squared difference of the two converged images
    from two renders of each under the same two seeds (the differences D_k = L_k - F_k are
    independent draws, their noise correlated or not): mean(D)^2 - (D0 - D1)^2 / 4."""
    D0, D1 = L0 - F0, L1 - F1
    return (((D0 + D1) / 2) ** 2 - ((D0 - D1) ** 2) / 4).mean(-1)


def bias_mse(L0, L1, F0, F1) -> float:
    """The mean of ``bias_map``: may be negative (then below the noise)."""
    return float(bias_map(L0, L1, F0, F1).mean())


def psnr(mse: float) -> float:
    return qb.psnr_mse(mse) if mse > 0 else float("inf")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=f"{REPO}/scenes/city_kitti.ses")
    p.add_argument("--frame", type=int, default=0)
    p.add_argument("--crop", type=float, default=0.25)
    p.add_argument("--crop-centre", default="0.5,0.5")
    p.add_argument("--preset", default="final")
    p.add_argument("--samples", type=int, nargs=2, default=[8, 32], metavar=("LOW", "HIGH"))
    p.add_argument("--exposure", type=float, default=None)
    p.add_argument("--variants", nargs="+", default=["full", "lod"],
                   help="full | lod | lod@T (both tolerances T) | lod@relief (the relief as roughness at every "
                        "distance) | lod@all (every LOD material its means at every distance): bounds, not settings")
    p.add_argument("--states", nargs="+", default=None,
                   help="instead of --variants: one LOD scene, its switches set per state and the states' renders "
                        "interleaved --repeat times (load drifts cancel): off (distances infinite: the full graph) | "
                        "lod | relief (the relief as roughness at every distance) | all (every LOD material its means "
                        "everywhere)")
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--bare", action="store_true",
                   help="the far branch a plain Principled BSDF of the means, without the object's variation and the "
                        "dirt (a bound: the per-object differences go)")
    p.add_argument("--out", default=None)
    a = p.parse_args()
    for st in a.states or ():
        if st not in ("off", "lod", "relief", "all"):
            p.error(f"--states: unknown {st!r}")
    if a.repeat < 1:
        p.error("--repeat must be >= 1")
    for v in a.variants:
        if v not in ("full", "lod", "lod@relief", "lod@all") and not v.startswith("lod@"):
            p.error(f"--variants: unknown {v!r}")
    if not Path(a.scene).is_file():
        p.error(f"no scene {a.scene}")
    if a.preset not in qb.PRESETS:
        p.error(f"--preset: one of {', '.join(qb.PRESETS)}")
    lo, hi = a.samples
    if not 1 <= lo < hi or not 0 < a.crop <= 1:
        p.error("--samples LOW HIGH with 1 <= LOW < HIGH; --crop in (0, 1]")
    try:
        centre = tuple(float(x) for x in a.crop_centre.split(","))
        assert len(centre) == 2
    except (ValueError, AssertionError):
        p.error(f"--crop-centre X,Y, got {a.crop_centre!r}")
    import bpy
    from blender_sesgen.blender import builder, render as brender, rig
    from blender_sesgen.blender.library import lod as lodm
    from blender_sesgen.contract.manifest import render_seed
    preset = replace(qb.PRESETS[a.preset], samples=hi, denoise=False, adaptive_threshold=0.0, quality="custom")
    args = argparse.Namespace(scene=a.scene, frame=a.frame, scale=1.0, crop=a.crop, crop_centre=centre,
                              views="left", device="cpu")
    out = Path(a.out) if a.out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    print(f"# load {os.getloadavg()[0]:.1f}; {a.scene} frame {a.frame} crop {a.crop} at {centre}; "
          f"{a.preset} light paths, no denoiser, samples {lo} / {hi}", flush=True)
    build = builder.build_scene
    rows, images = {}, {}
    exposure = a.exposure
    if a.states:
        return interleaved(a, args, preset, out, exposure, lo, hi)
    tolerances = (lodm.TOLERANCE, lodm.TILT_TOLERANCE)
    for v in a.variants:
        lodm.TOLERANCE, lodm.TILT_TOLERANCE = tolerances
        if v.startswith("lod@") and v not in ("lod@relief", "lod@all"):
            lodm.TOLERANCE = lodm.TILT_TOLERANCE = float(v[4:])
        builder.build_scene = lambda *x, _lod=v.startswith("lod"), **kw: build(*x, material_lod=_lod, **kw)
        b = qb.Bench(args)
        b.exposure = exposure
        c0, t0 = qb.cpu_s(), time.perf_counter()
        s = b.session(preset)
        exposure = b.exposure
        row = {"build_s": time.perf_counter() - t0, "build_cpu_s": qb.cpu_s() - c0, "load": os.getloadavg()[0]}
        lod = getattr(s.built, "lod", {})
        if v in ("lod@relief", "lod@all"):      # the bounds: the cheap branches everywhere
            for mat in bpy.data.materials:
                if lodm.has_lod(mat):
                    mat.node_tree.nodes[lodm.LOD_RELIEF_DISTANCE_NODE].outputs[0].default_value = 0.0
                    if v == "lod@all":
                        mat.node_tree.nodes[lodm.LOD_DISTANCE_NODE].outputs[0].default_value = 0.0
        if v.startswith("lod"):
            row["lod_materials"] = len(lod)
            focal = float(b.plan.settings.K[0][0])
            row["distances_m"] = {name: [round(min(m.relief_distance(focal), 1e9), 1), round(min(m.distance(focal), 1e9), 1)]
                                  for name, m in sorted(lod.items())}
        bscene = s.built.scene
        k = a.frame
        cpu = {}
        for n, seeds in ((lo, (0,)), (hi, (0, 1))):
            bscene.cycles.samples = n
            for seed in seeds:
                path = b.tmp / f"{v}_{n}_{seed}.exr"
                c0 = qb.cpu_s()
                brender.render_views(bscene, s.built.cameras, ("left",), rig.blender_frame(k),
                                     render_seed(seed, k, 0), {"left": path})
                cpu[(n, seed)] = 2 * (qb.cpu_s() - c0)          # left view x 2: a stereo frame
                ch = qb.read_exr(path)
                rgb = np.stack([next(x for name, x in ch.items() if name.endswith(f"{qb.PASS_COMBINED[0]}.{c}"))
                                for c in "RGB"], -1)
                images[(v, n, seed)] = qb.linear_to_srgb(rgb).astype(float)
                print(f"{v} {n} spp seed {seed}: {cpu[(n, seed)]:.2f} CPU s a stereo frame, load "
                      f"{os.getloadavg()[0]:.1f}", flush=True)
                if out:
                    np.save(out / f"{v}_{n}_{seed}.npy", images[(v, n, seed)].astype(np.float32))
        A, B = images[(v, hi, 0)], images[(v, hi, 1)]
        row.update(cpu_s={f"{n}@{seed}": c for (n, seed), c in cpu.items()},
                   cpu_per_sample=(cpu[(hi, 0)] - cpu[(lo, 0)]) / (hi - lo),
                   var_per_sample=hi * float(((A - B) ** 2).mean()) / 2, mean_srgb=float((A + B).mean() / 2))
        rows[v] = row
        print(f"{v} {json.dumps(row)}", flush=True)
    for v in rows:
        if v == "full" or "full" not in rows:
            continue
        L0, L1, F0, F1 = (images[(x, hi, s)] for x in (v, "full") for s in (0, 1))
        m = bias_mse(L0, L1, F0, F1)
        bl, bh = qb_boot(bias_map(L0, L1, F0, F1))
        f, l = rows["full"], rows[v]
        ratio = f["cpu_per_sample"] / l["cpu_per_sample"]
        cmp = {"bias_mse": m, "bias_psnr": psnr(m), "bias_psnr_90": [bl, bh], "samples_ratio_equal_cpu": ratio,
               "mean_srgb_minus_full": l["mean_srgb"] - f["mean_srgb"]}
        for n in sorted({hi, 32}):
            cmp[f"full_{n}_psnr_vs_truth"] = psnr(f["var_per_sample"] / n)
            cmp[f"equal_cpu_{n}_psnr_vs_truth"] = psnr(l["var_per_sample"] / (n * ratio) + max(m, 0.0))
        rows[f"compare {v}"] = cmp
        print(f"compare {v} {json.dumps(cmp)}", flush=True)
    print(f"# exposure held {exposure}; load {os.getloadavg()[0]:.1f} at the end", flush=True)
    if out:
        json.dump(rows, open(out / "material_lod.json", "w"), indent=1)
    return 0


def interleaved(a, args, preset, out, exposure, lo, hi) -> int:
    """--states: one LOD scene; per repeat, each state at LOW then HIGH samples (seed 0); then
    each state at HIGH under seed 1 (its noise, its bias against ``off``)."""
    import bpy
    from blender_sesgen.blender import builder, render as brender, rig
    from blender_sesgen.blender.library import lod as lodm
    from blender_sesgen.contract.manifest import render_seed
    build = builder.build_scene
    builder.build_scene = lambda *x, **kw: build(*x, material_lod=True, **kw)
    if a.bare:
        switch = lodm.switch
        lodm.switch = lambda g, ctx, full, bsdf, s, finish: switch(g, ctx, full, bsdf, s, lambda c, r: (c, r))
    b = qb.Bench(args)
    b.exposure = exposure
    c0, t0 = qb.cpu_s(), time.perf_counter()
    s = b.session(preset)
    rows = {"build": {"s": time.perf_counter() - t0, "cpu_s": qb.cpu_s() - c0, "load": os.getloadavg()[0],
                      "lod_materials": len(s.built.lod)}}
    print(f"build {json.dumps(rows['build'])}", flush=True)
    mats = [m for m in bpy.data.materials if lodm.has_lod(m)]
    measured = {m.name: (m.node_tree.nodes[lodm.LOD_RELIEF_DISTANCE_NODE].outputs[0].default_value,
                         m.node_tree.nodes[lodm.LOD_DISTANCE_NODE].outputs[0].default_value) for m in mats}

    def set_state(st):
        for m in mats:
            relief, recipe = measured[m.name]
            if st == "off":
                relief = recipe = lodm.FAR_AWAY
            elif st == "relief":
                relief = 0.0
            elif st == "all":
                relief = recipe = 0.0
            nodes = m.node_tree.nodes
            nodes[lodm.LOD_RELIEF_DISTANCE_NODE].outputs[0].default_value = relief
            nodes[lodm.LOD_DISTANCE_NODE].outputs[0].default_value = recipe
    bscene, k = s.built.scene, a.frame
    cpu, images = {}, {}

    def render(st, n, seed):
        set_state(st)
        bscene.cycles.samples = n
        path = b.tmp / f"{st}_{n}_{seed}.exr"
        c0 = qb.cpu_s()
        brender.render_views(bscene, s.built.cameras, ("left",), rig.blender_frame(k), render_seed(seed, k, 0),
                             {"left": path})
        c = 2 * (qb.cpu_s() - c0)
        ch = qb.read_exr(path)
        rgb = np.stack([next(x for name, x in ch.items() if name.endswith(f"{qb.PASS_COMBINED[0]}.{c_}"))
                        for c_ in "RGB"], -1)
        images[(st, n, seed)] = qb.linear_to_srgb(rgb).astype(float)
        print(f"{st} {n} spp seed {seed}: {c:.2f} CPU s a stereo frame, load {os.getloadavg()[0]:.1f}", flush=True)
        return c
    for r in range(a.repeat):
        for st in a.states:
            cpu.setdefault(st, []).append(-render(st, lo, 0))
        for st in a.states:
            cpu[st][-1] += render(st, hi, 0)
    for st in a.states:
        render(st, hi, 1)
    for st in a.states:
        A, B = images[(st, hi, 0)], images[(st, hi, 1)]
        slopes = [c / (hi - lo) for c in cpu[st]]
        rows[st] = {"cpu_per_sample": float(np.median(slopes)), "cpu_per_sample_each": slopes,
                    "var_per_sample": hi * float(((A - B) ** 2).mean()) / 2, "mean_srgb": float((A + B).mean() / 2)}
        print(f"{st} {json.dumps(rows[st])}", flush=True)
        if out:
            np.save(out / f"{st}_{hi}_0.npy", A.astype(np.float32))
            np.save(out / f"{st}_{hi}_1.npy", B.astype(np.float32))
    base = "off" if "off" in a.states else None
    for st in a.states:
        if base is None or st == base:
            continue
        L0, L1, F0, F1 = images[(st, hi, 0)], images[(st, hi, 1)], images[(base, hi, 0)], images[(base, hi, 1)]
        m = bias_mse(L0, L1, F0, F1)
        f, l = rows[base], rows[st]
        ratio = f["cpu_per_sample"] / l["cpu_per_sample"]
        each = [x / y for x, y in zip(f["cpu_per_sample_each"], l["cpu_per_sample_each"])]
        cmp = {"bias_mse": m, "bias_psnr": psnr(m), "bias_psnr_90": list(qb_boot(bias_map(L0, L1, F0, F1))),
               "samples_ratio_equal_cpu": ratio, "ratio_each_repeat": each,
               "mean_srgb_minus_off": l["mean_srgb"] - f["mean_srgb"]}
        for n in sorted({hi, 32}):
            cmp[f"off_{n}_psnr_vs_truth"] = psnr(f["var_per_sample"] / n)
            cmp[f"equal_cpu_{n}_psnr_vs_truth"] = psnr(l["var_per_sample"] / (n * ratio) + max(m, 0.0))
        rows[f"compare {st}"] = cmp
        print(f"compare {st} {json.dumps(cmp)}", flush=True)
    print(f"# exposure held {b.exposure}; load {os.getloadavg()[0]:.1f} at the end", flush=True)
    if out:
        json.dump(rows, open(out / "material_lod.json", "w"), indent=1)
    return 0


def qb_boot(t: np.ndarray) -> tuple[float, float]:
    spec = importlib.util.spec_from_file_location("qu", f"{REPO}/bench/quality_unbiased.py")
    qu = importlib.util.module_from_spec(spec); spec.loader.exec_module(qu)
    return qu.block_bootstrap(t)


if __name__ == "__main__":
    sys.exit(main())
