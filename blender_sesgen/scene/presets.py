"""Render quality presets: every Cycles setting that changes the beauty pass, in one table
(pure: no bpy). ``--quality`` / ``RENDER quality`` picks a row; explicit samples / denoise
override it. Ground truth (depth, object index, normal, position) never depends on the
preset: Cycles writes it from the first sample, which goes through the pixel centre.

The values are measured choices (docs/rendering.md#quality-presets, ``bench/quality.py``):
PSNR of the sRGB image against a converged 4096-sample render, at the scene's own resolution
(two windows each of the paper room and of the photoreal hall as it stood before its rebuild
in sessions 11-12): draft >= 35.3 dB, final >= 38.7 dB; reference 45.4 dB on the paper room at
160x120. The rebuilt hall read ~37.4 dB at final with the daylight traced through its frosted
panes (their light found by bounces); with the panes glowing (``MATERIAL ... glow``) ~38.0 dB
against the truth, estimated from two unbiased references (docs/rendering.md#quality-presets).

- ``gt``: ground truth at primary-ray cost. One sample, no bounces, no lights: the RGB is
  each object's flat colour under a head-light (not photoreal, not a photograph of the
  scene: a picture of the ground truth).
- ``draft``: >= 32 dB, for looking at a sequence.
- ``final`` (the default): >= 38 dB, what a data set is rendered with.
- ``reference``: >= 45 dB, for checking the others.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Optional

QUALITIES = ("gt", "draft", "final", "reference")
DEFAULT_QUALITY = "final"
SHADINGS = ("full", "flat")
DENOISE_GUIDES = ("none", "albedo", "albedo_normal")
DENOISE_PREFILTERS = ("none", "fast", "accurate")
SAMPLING_PATTERNS = ("automatic", "blue_noise", "tabulated_sobol")


@dataclass(frozen=True)
class Preset:
    """The sampling and light-path settings of one render (what the manifest records)."""
    quality: str                      # the preset this came from (gt|draft|final|reference|custom)
    samples: int                      # samples per pixel (the maximum when adaptive)
    adaptive_threshold: float = 0.0   # Cycles' noise threshold; 0 = adaptive sampling off
    adaptive_min_samples: int = 0     # 0 = Cycles' automatic minimum
    denoise: bool = False             # OpenImageDenoise on the beauty pass
    denoise_guides: str = "albedo_normal"
    denoise_prefilter: str = "accurate"
    max_bounces: int = 6
    diffuse_bounces: int = 3
    glossy_bounces: int = 3
    transmission_bounces: int = 6
    volume_bounces: int = 0
    transparent_bounces: int = 8
    clamp_direct: float = 0.0         # 0 = no clamping
    clamp_indirect: float = 10.0
    caustics: bool = False
    light_tree: bool = True
    path_guiding: bool = False        # CPU only (Cycles ignores it on a GPU)
    filter_glossy: float = 1.0        # Cycles' Filter Glossy (its default): sharp glossy seen after a
    #                                   blurry bounce is blurred (less noise, biased); 0 = unbiased
    sampling_pattern: str = "automatic"  # Cycles' sampling pattern: automatic (its default: blue noise on a
    #                                   non-adaptive render), blue_noise or tabulated_sobol (classic)
    shading: str = "full"             # full | flat (gt: flat colour, no lights)
    overridden: tuple[str, ...] = ()  # which fields the user set over the preset

    def __post_init__(self):
        if self.quality not in QUALITIES + ("custom",):
            raise ValueError(f"unknown quality {self.quality!r}")
        if self.shading not in SHADINGS or self.denoise_guides not in DENOISE_GUIDES \
                or self.denoise_prefilter not in DENOISE_PREFILTERS or self.sampling_pattern not in SAMPLING_PATTERNS:
            raise ValueError(f"bad preset {self}")

    @property
    def adaptive(self) -> bool:
        return self.adaptive_threshold > 0.0

    @property
    def deterministic_rgb(self) -> bool:
        """The beauty pass uses no random numbers (one sample through the pixel centre, flat
        shading): the Cycles seed cannot change it, so both views may share one render."""
        return self.shading == "flat" and self.samples == 1 and not self.adaptive

    def with_overrides(self, samples: Optional[int] = None, denoise: Optional[bool] = None) -> "Preset":
        """Explicit samples (exactly N per pixel: adaptive sampling off) and/or denoise."""
        p, over = self, list(self.overridden)
        if samples is not None:
            p = replace(p, samples=int(samples), adaptive_threshold=0.0, adaptive_min_samples=0)
            over.append("samples")
        if denoise is not None:
            p = replace(p, denoise=bool(denoise))
            over.append("denoise")
        return replace(p, overridden=tuple(dict.fromkeys(over)))

    def pixel_settings(self) -> dict:
        """Every setting that changes pixels, as JSON (the manifest's ``render.sampling``;
        resume compares it). ``quality`` and ``overridden`` are labels, not settings."""
        d = asdict(self)
        for k in ("quality", "overridden", "samples", "denoise"):
            d.pop(k)
        if d["filter_glossy"] == 1.0:  # what every folder before the field was rendered with: they resume
            d.pop("filter_glossy")
        if d["sampling_pattern"] == "automatic":  # likewise
            d.pop("sampling_pattern")
        return d


PRESETS: dict[str, Preset] = {p.quality: p for p in (
    Preset("gt", samples=1, max_bounces=0, diffuse_bounces=0, glossy_bounces=0, transmission_bounces=0,
           transparent_bounces=0, clamp_indirect=0.0, light_tree=False, shading="flat"),
    # measured in docs/rendering.md#quality-presets (bench/quality.py, paper room and hall,
    # 4096-sample references): 4 diffuse bounces (+1.4 dB over 3) and caustics (+1.9 dB) are
    # worth more than samples; 8 bounces give the pixels of 12; the light tree is worth 5 dB in
    # the hall's 21 lamps; path guiding, adaptive sampling and the fast prefilter cost more dB
    # than they save time; the indirect clamp changes nothing here. final: the fewest samples
    # that keep 38 dB in every window measured at the scenes' own resolution (the hall's centre:
    # 16 -> 37.1, 24 -> 38.0, 32 -> 38.7, 48 -> 39.6 dB).
    Preset("draft", samples=8, denoise=True, max_bounces=8, diffuse_bounces=4, glossy_bounces=4,
           transmission_bounces=8, caustics=True),
    Preset("final", samples=32, denoise=True, max_bounces=8, diffuse_bounces=4, glossy_bounces=4,
           transmission_bounces=8, caustics=True),
    Preset("reference", samples=4096, adaptive_threshold=0.01, denoise=True, max_bounces=12, diffuse_bounces=4,
           glossy_bounces=4, transmission_bounces=12, clamp_indirect=0.0, caustics=True),
)}


# The automatic exposure's preview (blender/exposure.py) renders with these settings whatever
# the preset, so that every preset gets the same exposure (and the same brightness).
EXPOSURE_PREVIEW = Preset("custom", samples=8)


def preset(quality: str) -> Preset:
    """The preset named ``quality`` (KeyError-free: ValueError names the choices)."""
    try:
        return PRESETS[str(quality).lower()]
    except KeyError:
        raise ValueError(f"quality must be one of {', '.join(QUALITIES)}, got '{quality}'") from None


def effective(cli_quality: Optional[str], cli_samples: Optional[int], cli_denoise: Optional[bool],
              script_quality: Optional[str] = None, script_samples: Optional[int] = None,
              script_denoise: Optional[bool] = None) -> Preset:
    """The preset a render uses.

    A quality given on the command line (or the add-on) is taken as it is: the script's
    RENDER samples/denoise do not apply to it. Without one, the script's ``RENDER quality``
    (else ``final``) is the base and the script's samples/denoise override it. Samples and
    denoise given on the command line override either.
    """
    if cli_quality is not None:
        base = preset(cli_quality)
        samples, denoise = cli_samples, cli_denoise
    else:
        base = preset(script_quality or DEFAULT_QUALITY)
        samples = cli_samples if cli_samples is not None else script_samples
        denoise = cli_denoise if cli_denoise is not None else script_denoise
    return base.with_overrides(samples, denoise)
