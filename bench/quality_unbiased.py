"""A preset's error against the truth without a converged reference: two unbiased references
(``reference_preset``: N samples, no denoiser, no clamp) under two Cycles seeds. Their noise is
independent and of mean zero, so for an image F (another seed)

    MSE(F, truth) = MSE(F, (A + B) / 2) - MSE(A, B) / 4

(the references' own variance, v / 2N, is MSE(A, B) / 4): the error a converged reference would
show, at the cost of 2 N samples of noise estimated rather than 19 000 samples rendered. Also
printed: the references' own noise (PSNR of MSE(A, B) / 2: one N-sample reference against the
truth), each configuration against the averaged reference as measured, and its CPU s a stereo
frame. Exposure: metered on the scene (or ``--exposure``), held for every render.

Usage: ``.venv/bin/python bench/quality_unbiased.py [--scene scenes/hall.ses] [--crop 0.25]
[--ref-samples 1024] [--configs final] [--try NAME:base=final,samples=64 ...] [--device cpu|gpu] [--explain]
[--out DIR]`` (the window, frame, ``--try`` and ``--device`` as bench/quality.py's;
``--out``: the images as DIR/NAME.npz and the rows as DIR/unbiased.json; an existing
DIR/ref_*.npz of the same settings is reused, given ``--exposure``). Each row has the 90 % block bootstrap of its
estimate (20-px tiles: the denoiser's errors are correlated over neighbours); with ``--seeds 2``
also the part of the error a seed changes (own noise: MSE(F0, F1) / 2) and the part it does not;
``--explain``: the error against the truth by object kind (a ``gt`` render's object index) and
on the pixels the references show clipped white, and the pass before the denoiser's. Measured
in bench/RESULTS.md (sessions 15 and 16)."""
import argparse, json, os, sys
from dataclasses import replace
from pathlib import Path
import importlib.util
import numpy as np
REPO = str(Path(__file__).resolve().parents[1])
sys.path.insert(0, REPO)
spec = importlib.util.spec_from_file_location("qb", f"{REPO}/bench/quality.py")
qb = importlib.util.module_from_spec(spec); spec.loader.exec_module(qb)


def truth_error_map(F: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Per pixel, an unbiased estimate of F's squared error against the truth (mean over the
    channels): (F - (A + B) / 2)^2 - (A - B)^2 / 4. Single pixels may be negative; its mean
    over any region is the region's MSE against the truth, in expectation."""
    return (((F - (A + B) / 2) ** 2) - ((A - B) ** 2) / 4).mean(-1)


def block_bootstrap(t: np.ndarray, block: int = 20, draws: int = 2000, level: float = 0.90,
                    rng: int = 0) -> tuple[float, float]:
    """The ``level`` interval of the mean of the per-pixel map ``t`` (truth_error_map) by a
    block bootstrap (``block`` x ``block`` pixel tiles drawn with replacement: neighbouring
    pixels' errors are correlated, the denoiser's especially), as PSNR (low, high) in dB."""
    h, w = t.shape
    sums = np.add.reduceat(np.add.reduceat(t, np.arange(0, h, block), 0), np.arange(0, w, block), 1).ravel()
    counts = np.add.reduceat(np.add.reduceat(np.ones_like(t), np.arange(0, h, block), 0),
                             np.arange(0, w, block), 1).ravel()
    idx = np.random.default_rng(rng).integers(0, sums.size, (draws, sums.size))
    means = sums[idx].sum(1) / counts[idx].sum(1)
    lo, hi = np.quantile(means, [(1 - level) / 2, (1 + level) / 2])
    return qb.psnr_mse(float(hi)) if hi > 0 else float("inf"), qb.psnr_mse(float(lo)) if lo > 0 else float("inf")


def explain(t: np.ndarray, kinds: np.ndarray | None, clipped: np.ndarray) -> dict:
    """Where the error against the truth lies: shares of the summed map ``t`` by object kind
    (beside the share of pixels) and on the pixels the references show clipped white."""
    total = float(t.sum())
    out = {"clipped": (float(t[clipped].sum()) / total, float(clipped.mean()))}
    if kinds is not None:
        for k in np.unique(kinds):
            out[str(k)] = (float(t[kinds == k].sum()) / total, float((kinds == k).mean()))
    return out


def estimate(F: np.ndarray, A: np.ndarray, B: np.ndarray) -> dict:
    """The rows of image F against references A, B (sRGB floats)."""
    ref_var = float(((A - B) ** 2).mean()) / 4
    measured = float(((F - (A + B) / 2) ** 2).mean())
    truth = measured - ref_var
    return {"psnr_vs_avg_ref": qb.psnr_mse(measured), "psnr_vs_truth_est": qb.psnr_mse(truth) if truth > 0 else None,
            "mse_vs_truth_est": truth, "ref_avg_own_psnr": qb.psnr_mse(ref_var)}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=f"{REPO}/scenes/hall.ses")
    p.add_argument("--frame", type=int, default=0)
    p.add_argument("--scale", type=float, default=1.0)
    p.add_argument("--crop", type=float, default=0.25)
    p.add_argument("--crop-centre", default="0.5,0.5")
    p.add_argument("--ref-samples", type=int, default=1024)
    p.add_argument("--configs", nargs="*", default=["final"])
    p.add_argument("--try", dest="tries", nargs="*", default=[], metavar="NAME:key=value,...",
                   help="more configurations: a preset's settings changed (bench/quality.py --try)")
    p.add_argument("--device", choices=("cpu", "gpu"), default="cpu", help="Cycles device of every render")
    p.add_argument("--explain", action="store_true",
                   help="where the error against the truth lies (object kinds from a gt render, clipped pixels, "
                        "the pass before the denoiser, the seed-independent share with --seeds 2)")
    p.add_argument("--seeds", type=int, default=1, help="renders of each configuration under other seeds")
    p.add_argument("--exposure", type=float, default=None)
    p.add_argument("--out", default=None)
    a = p.parse_args()
    configs = {}
    for c in a.configs:
        configs[c] = qb.PRESETS.get(c) or qb.OTHERS.get(c)
        if configs[c] is None:
            p.error(f"--configs {c!r}: one of {', '.join([*qb.PRESETS, *qb.OTHERS])}")
    try:
        configs.update(qb.parse_try(t) for t in a.tries)
    except (ValueError, KeyError) as e:
        p.error(f"--try: {e}")
    if not Path(a.scene).is_file():
        p.error(f"no scene {a.scene}")
    if a.ref_samples < 1 or a.seeds < 1 or not 0 < a.crop <= 1:
        p.error("--ref-samples and --seeds must be >= 1, --crop in (0, 1]")
    try:
        centre = tuple(float(x) for x in a.crop_centre.split(","))
        assert len(centre) == 2
    except (ValueError, AssertionError):
        p.error(f"--crop-centre X,Y, got {a.crop_centre!r}")
    args = argparse.Namespace(scene=a.scene, frame=a.frame, scale=a.scale, crop=a.crop, crop_centre=centre,
                              views="left", device=a.device)
    b = qb.Bench(args)
    b.exposure = a.exposure
    seed0 = b.plan.settings.seed
    out = Path(a.out) if a.out else None
    if out:
        out.mkdir(parents=True, exist_ok=True)
    print(f"# load {os.getloadavg()[0]:.1f}; {a.scene} frame {a.frame} crop {a.crop} at {centre}, device {a.device}",
          flush=True)
    rows, refs = {}, []
    for i in range(2):                      # the two references: seeds far from the configurations'
        seed = seed0 + 1000 + i
        cached = out / f"ref_{a.ref_samples}_{seed}.npz" if out else None
        if cached and cached.is_file() and a.exposure is not None:
            d = np.load(cached)
            refs.append(d["left"])
            print(f"ref seed {seed}: cached", flush=True)
            continue
        b.plan = replace(b.plan, settings=replace(b.plan.settings, seed=seed))
        r = b.render(qb.reference_preset(a.ref_samples), 1)
        refs.append(r["images"]["left"].astype(float))
        rows[f"ref{i}"] = {"seed": seed, "samples": a.ref_samples, "cpu_stereo": r["cpu_stereo"],
                           "load": os.getloadavg()[0]}
        print(f"ref seed {seed}: {json.dumps(rows[f'ref{i}'])}; exposure {b.exposure}", flush=True)
        if cached:
            np.savez_compressed(cached, left=refs[-1], exposure=b.exposure)
    A, B = refs
    rows["references"] = {"one_ref_own_psnr": qb.psnr_mse(float(((A - B) ** 2).mean()) / 2),
                          "avg_ref_own_psnr": qb.psnr_mse(float(((A - B) ** 2).mean()) / 4),
                          "mean_srgb": float((A + B).mean() / 2)}
    print("references", json.dumps(rows["references"]), flush=True)
    kinds = None
    if a.explain:
        kinds = qb.object_kinds(b)
        if out:
            np.save(out / "kinds.npy", kinds.astype(str))
    clipped = (((A + B) / 2) >= 0.999).all(-1)
    for c, preset in configs.items():
        images = []
        for k in range(a.seeds):
            b.plan = replace(b.plan, settings=replace(b.plan.settings, seed=seed0 + k))
            r = b.render(preset, 1)
            F = r["images"]["left"].astype(float)
            images.append(F)
            t = truth_error_map(F, A, B)
            row = {"seed": seed0 + k, **estimate(F, A, B), "bootstrap90": block_bootstrap(t),
                   "cpu_stereo": r["cpu_stereo"], "mean_srgb": float(F.mean()), "load": os.getloadavg()[0]}
            if a.explain:
                row["where"] = explain(t, kinds, clipped)
                if "left" in r["noisy"]:                        # the samples before the denoiser
                    row["noisy"] = estimate(r["noisy"]["left"].astype(float), A, B)
            rows[f"{c}@{seed0 + k}"] = row
            print(f"{c} {json.dumps(row)}", flush=True)
            if out:
                np.savez_compressed(out / f"{c}_{seed0 + k}.npz", left=F,
                                    **({"noisy": r["noisy"]["left"]} if "left" in r["noisy"] else {}))
        if len(images) >= 2:   # the part of the error a seed changes (own noise) and the part it does not
            own = float(((images[0] - images[1]) ** 2).mean()) / 2
            mean_truth = float(np.mean([rows[f"{c}@{seed0 + k}"]["mse_vs_truth_est"] for k in range(len(images))]))
            rows[f"{c}:seeds"] = {"own_noise_mse": own, "own_noise_psnr": qb.psnr_mse(own),
                                  "seed_independent_mse": mean_truth - own,
                                  "seed_independent_psnr": qb.psnr_mse(mean_truth - own) if mean_truth > own else None}
            print(f"{c} seeds {json.dumps(rows[f'{c}:seeds'])}", flush=True)
    print(f"# exposure held {b.exposure}; load {os.getloadavg()[0]:.1f} at the end", flush=True)
    if out:
        json.dump(rows, open(out / "unbiased.json", "w"), indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
