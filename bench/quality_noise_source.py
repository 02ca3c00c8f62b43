"""Where the hall's noise comes from: the quality bench's crop rendered without the sky and sun,
without the lamps, and with the frosted glazing taken out (open openings), each at N samples
without denoiser under two Cycles seeds, at the full scene's metered exposure (held, so levels
compare). Two independent renders differ by MSE = 2 v / N, so v = N MSE / 2 is the variance
one sample leaves (sRGB units; rel_var_linear: in linear light over the mean's square, level-free);
a light whose removal takes most of v is what is sampled badly. noise_psnr: one render's own noise
(MSE/2). ``glazing_glow@S``: the frosted panes as Lambertian emitters of strength S (one for every
pane; the sky stays outside), the light-sampled path a diffuser's transmitted daylight could take.
``sun_only`` / ``sky_only`` (a ``WORLD sky`` scene, e.g. city_kitti): the sky's sun lamp alone
(the sky's background at strength 0) / the sky alone (the lamp at 0), as built: with ``--bounces
0`` (direct light only) their variances against ``base``'s say how much is each light's own and
how much the light tree's choice between them adds. ``--preset final``: the denoised images of a
preset instead. Diagnostic only (the variants are not scenes).

Usage: ``.venv/bin/python bench/quality_noise_source.py [--scene scenes/hall.ses] [--samples 32]
[--bounces N] [--frame 0] [--variants base sun_only sky_only ...] [--out DIR]`` (centre window of
the scene's view at its own size, left view: hall.ses 188x120 of 752x480). Measured in
bench/RESULTS.md (sessions 14 and 17)."""
import argparse, json, os, re, sys, tempfile
from dataclasses import replace
from pathlib import Path
import importlib.util
import numpy as np
REPO = str(Path(__file__).resolve().parents[1])
sys.path.insert(0, REPO)
spec = importlib.util.spec_from_file_location("qb", f"{REPO}/bench/quality.py")
qb = importlib.util.module_from_spec(spec); spec.loader.exec_module(qb)


KNOWN = ("base", "sky_off", "lamps_off", "open_glazing", "sun_only", "sky_only")
LIGHT_SCALES = {"sun_only": (1.0, 0.0), "sky_only": (0.0, 1.0)}   # (the sun lamp's, the sky background's)


class LitBench(qb.Bench):
    """The quality bench with the built scene's sun lamps and world background scaled."""

    def __init__(self, args, sun: float = 1.0, sky: float = 1.0):
        super().__init__(args)
        self.scales = (sun, sky)

    def session(self, preset):
        s = super().session(preset)
        sun, sky = self.scales
        bscene = s.built.scene
        for o in bscene.objects:
            if o.type == "LIGHT" and o.data.type == "SUN":
                o.data.energy *= sun
        if bscene.world is not None and bscene.world.node_tree is not None:
            for n in bscene.world.node_tree.nodes:
                if n.type == "BACKGROUND":
                    n.inputs["Strength"].default_value *= sky
        return s


def variant(text: str, name: str) -> str:
    if name == "sky_off":      # no sky, no sun: a black world
        return re.sub(r"(?m)^WORLD .*$", "WORLD colour 0 0 0", text)
    if name == "lamps_off":    # the area lights and their diffusers' glow
        text = re.sub(r"(?m)^(LIGHT area .* strength )[0-9.]+", r"\g<1>0", text)
        return re.sub(r"(?m)^(MATERIAL name light_panel .*emission_strength )[0-9.]+", r"\g<1>0", text)
    if name == "open_glazing":  # the frosted panes taken out: the openings let the daylight in
        return "\n".join(l for l in text.splitlines() if not (l.startswith("QUAD") and "frosted_glass" in l)) + "\n"
    if name.startswith("glazing_glow"):  # the panes as Lambertian emitters (light-sampled), no transmission
        strength = float(name.split("@")[1]) if "@" in name else 0.2
        text = re.sub(r"(?m)^(QUAD .*material )frosted_glass", r"\g<1>glazing_glow", text)
        glow = (f"MATERIAL name glazing_glow colour 0.40 0.40 0.39 roughness 0.6 emission 1 1 1 "
                f"emission_strength {strength}\n")
        return text.replace("\nMATERIAL name light_panel", "\n" + glow + "MATERIAL name light_panel", 1)
    return text


def srgb_to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default=f"{REPO}/scenes/hall.ses")
    p.add_argument("--frame", type=int, default=0)
    p.add_argument("--samples", type=int, default=32)
    p.add_argument("--preset", default=None, help="a preset of bench/quality.py (e.g. final: its denoised "
                   "images; v is then N x its variance) instead of N samples without denoiser")
    p.add_argument("--exposure", type=float, default=None, help="held exposure (default: metered on the scene)")
    p.add_argument("--bounces", type=int, default=None, help="the light paths' max bounces without denoiser "
                   "(default 12; 0: direct light only)")
    p.add_argument("--variants", nargs="*", default=["base", "sky_off", "lamps_off", "open_glazing"])
    p.add_argument("--out", default=None)
    a = p.parse_args()
    if a.preset is not None and a.preset not in qb.PRESETS:
        p.error(f"--preset {a.preset!r}: one of {', '.join(qb.PRESETS)}")
    for name in a.variants:
        if name not in KNOWN and not re.fullmatch(r"glazing_glow(@[0-9.]+)?", name):
            p.error(f"unknown variant {name!r}: {', '.join(KNOWN)}, glazing_glow[@STRENGTH]")
    if not Path(a.scene).is_file():
        p.error(f"no scene {a.scene}")
    if a.bounces is not None and (a.bounces < 0 or a.preset):
        p.error("--bounces N >= 0, without --preset")
    text = Path(a.scene).read_text()
    for name in a.variants:
        if name in LIGHT_SCALES:
            if not re.search(r"(?m)^WORLD sky", text):
                p.error(f"variant {name!r}: {a.scene} has no WORLD sky")
        elif name != "base" and variant(text, name) == text:
            p.error(f"variant {name!r} changes nothing in {a.scene}")
    tmp = Path(tempfile.mkdtemp(prefix="sesgen-noise-"))
    exposure, rows = a.exposure, {}
    what = f"preset {a.preset}" if a.preset else f"{a.samples} samples, no denoiser"
    print(f"# load {os.getloadavg()[0]:.1f}; {what}, two seeds", flush=True)
    for name in a.variants:
        path = tmp / f"{Path(a.scene).stem}_{name}.ses"   # includes beside the script: none in the hall
        path.write_text(variant(text, name))
        args = argparse.Namespace(scene=str(path), frame=a.frame, scale=1.0, crop=0.25, crop_centre=(0.5, 0.5),
                                  views="left", device="cpu")
        b = LitBench(args, *LIGHT_SCALES.get(name, (1.0, 1.0)))
        b.exposure = exposure
        imgs, cpu = [], 0.0
        seed0 = b.plan.settings.seed
        for s in (seed0, seed0 + 1):
            b.plan = replace(b.plan, settings=replace(b.plan.settings, seed=s))
            unbiased = qb.reference_preset(a.samples)
            if a.bounces is not None:
                unbiased = replace(unbiased, max_bounces=a.bounces)
            r = b.render(qb.PRESETS[a.preset] if a.preset else unbiased, 1)
            imgs.append(r["images"]["left"].astype(float)); cpu += r["cpu_stereo"] / r["factor"]
        exposure = b.exposure
        mse = float(((imgs[0] - imgs[1]) ** 2).mean())
        h = imgs[0].shape[0]
        lin = [srgb_to_linear(np.clip(i, 0, 1)) for i in imgs]  # clipped at white: a level, not a sensor
        v_lin = a.samples * float(((lin[0] - lin[1]) ** 2).mean()) / 2
        m_lin = float((lin[0] + lin[1]).mean() / 2)
        rows[name] = dict(v_per_sample=a.samples * mse / 2, mean_linear=m_lin, rel_var_linear=v_lin / m_lin ** 2,
                          psnr_between_seeds=qb.psnr_mse(mse), noise_psnr=qb.psnr_mse(mse / 2),
                          mean_srgb=float((imgs[0] + imgs[1]).mean() / 2),
                          lower_half_srgb=float((imgs[0][h // 2:] + imgs[1][h // 2:]).mean() / 2),
                          cpu_two_left_views=cpu, load=os.getloadavg()[0])
        print(name, json.dumps(rows[name]), flush=True)
        if a.out:
            Path(a.out).mkdir(parents=True, exist_ok=True)
            np.savez_compressed(f"{a.out}/{name}.npz", seed0=imgs[0], seed1=imgs[1])
    print(f"# exposure held {exposure}; load {os.getloadavg()[0]:.1f} at the end", flush=True)
    if a.out:
        json.dump(rows, open(f"{a.out}/noise_source.json", "w"), indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
