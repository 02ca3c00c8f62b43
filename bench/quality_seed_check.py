"""How converged is the hall's 4096-sample reference? A 1024-sample reference of another Cycles
seed (independent noise, same exposure) against it: MSE = v/1024 + v/4096, so the 4096-sample
reference's own noise is MSE/5. Then a few settings of final against the 4096 reference.

Usage (after ``bench/quality.py --scene scenes/hall.ses --scale 1 --crop 0.25 --cache DIR`` cached the
4096-sample reference): ``.venv/bin/python bench/quality_seed_check.py DIR`` (rows also in DIR/seedref.json).
Measured in bench/RESULTS.md (session 13: quality13)."""
import argparse, glob, importlib.util, json, os, sys
from dataclasses import replace
from pathlib import Path
import numpy as np
REPO = str(Path(__file__).resolve().parents[1])
sys.path.insert(0, REPO)
CACHE = sys.argv[1] if len(sys.argv) > 1 else f"{REPO}/out/bench-cache"
spec = importlib.util.spec_from_file_location("qb", f"{REPO}/bench/quality.py")
qb = importlib.util.module_from_spec(spec); spec.loader.exec_module(qb)
from vo_reference.evaluate.image_quality import psnr, ssim

a = argparse.Namespace(scene=f"{REPO}/scenes/hall.ses", frame=0, scale=1.0, crop=0.25, crop_centre=(0.5, 0.5),
                       views="left", device="cpu", reference_samples=4096, cache=CACHE)
cache = glob.glob(f"{CACHE}/hall-f0-s1.0-c0.25-*.npz")
assert len(cache) == 1, cache
d = np.load(cache[0]); R = d["left"].astype(float)
b = qb.Bench(a); b.exposure = float(d["exposure"])
print(f"# load {os.getloadavg()[0]:.1f}; exposure {b.exposure}", flush=True)
out = {}
seed0 = b.plan.settings.seed
def row(name, preset, seed=seed0):
    b.plan = replace(b.plan, settings=replace(b.plan.settings, seed=seed))
    r = b.render(preset, 1)
    img = r["images"]["left"].astype(float)
    mse = float(((img - R) ** 2).mean())
    out[name] = dict(psnr=psnr(r["images"]["left"], d["left"]), ssim=ssim(r["images"]["left"], d["left"]), mse=mse,
                     cpu_stereo=r["cpu_stereo"], s_stereo=r["s_stereo"], load=os.getloadavg()[0])
    np.savez_compressed(f"{CACHE}/seedref_{name}.npz", left=r["images"]["left"],
                        **({"noisy": r["noisy"]["left"]} if r["noisy"] else {}))
    print(name, json.dumps(out[name]), flush=True)
    return img
F = qb.PRESETS["final"]
ref2 = row("ref1024_seed1", qb.reference_preset(1024), seed=seed0 + 1)
v = out["ref1024_seed1"]["mse"] / 5
print(f"# the 4096 reference's own noise: MSE {v:.3g} = {qb.psnr_mse(v):.2f} dB (against the truth)", flush=True)
row("pathguide32", replace(F, quality="custom", path_guiding=True))
row("final64", replace(F, quality="custom", samples=64))
row("noclamp32", replace(F, quality="custom", clamp_indirect=0.0))
json.dump(out, open(f"{CACHE}/seedref.json", "w"), indent=1)
print(f"# load {os.getloadavg()[0]:.1f} at the end", flush=True)
