"""The raw sensor chain: photon transfer, seeds, CFA, demosaic, response, optics, auto-exposure,
PNG encoding — against closed forms and independent implementations (OpenCV, SciPy)."""
from __future__ import annotations

import numpy as np
import pytest

from blender_sesgen.scene import model
from blender_sesgen.contract import cfa
from blender_sesgen.files.png import encode_png
from blender_sesgen.render.sensor import autoexposure, optics, pipeline, raw

cv2 = pytest.importorskip("cv2")


def test_photon_transfer_follows_the_poisson_gaussian_model():
    """EMVA 1288 style: two flat frames per level, variance from their difference."""
    fw, bits, gain, read, black = 8000.0, 12, 1.5, 4.0, 64.0
    K = raw.conversion_gain(fw, bits, gain)
    rng = np.random.default_rng(1)
    means, variances = [], []
    for level in np.linspace(0.02, 0.6, 12):
        signal = np.full((256, 256), level * fw / gain)
        sensor = model.Sensor(full_well_e=fw, read_noise_e=read, bits=bits, black_level_dn=black)
        a, b = (raw.capture(signal, sensor, gain=gain, rng=rng).astype(float) for _ in range(2))
        means.append((a.mean() + b.mean()) / 2 - black)
        variances.append(np.var(a - b) / 2)
    slope, intercept = np.polyfit(means, variances, 1)
    assert slope == pytest.approx(K, rel=0.02)                         # shot noise: var = K * mean
    assert intercept == pytest.approx(K**2 * read**2 + 1 / 12, rel=0.1)  # read noise + quantisation
    assert np.allclose(means, np.linspace(0.02, 0.6, 12) * fw / gain * K, rtol=2e-3)


def test_same_seed_same_noise_and_ground_truth_untouched():
    s = model.Sensor(read_noise_e=3, prnu=0.01, dsnu_e=2, row_noise_e=1, cfa="rggb", bits=10, seed=7)
    lin = np.random.default_rng(0).uniform(0, 1, (24, 32, 3))
    cam = pipeline.Camera(s, nominal_exposure_s=0.01)
    shot = lambda frame: pipeline.Shot(exposure_s=0.01, gain=1.0, frame=frame, view_index=0)  # noqa: E731
    a = pipeline.process(lin, cam, shot(3))
    b = pipeline.process(lin.copy(), cam, shot(3))
    c = pipeline.process(lin, cam, shot(4))
    assert np.array_equal(a.raw_dn, b.raw_dn) and np.array_equal(a.rgb8, b.rgb8)
    assert not np.array_equal(a.raw_dn, c.raw_dn)
    assert a.raw_dn.shape == (24, 32) and a.raw_dn.max() <= 1023
    d = pipeline.process(lin, pipeline.Camera(model.Sensor(**{**s.__dict__, "seed": 8}), nominal_exposure_s=0.01), shot(3))
    assert not np.array_equal(a.raw_dn, d.raw_dn)


@pytest.mark.parametrize("kw", [dict(mono=True, bits=8, black_level_dn=16, response="srgb"),
                                dict(cfa=None, bits=12, black_level_dn=64, response="gamma", gamma=1.8),
                                dict(cfa=None, bits=10, response="linear")])
def test_rgb_of_a_sensor_without_mosaic_is_the_response_of_each_raw_value(kw):
    """Without a colour filter array each RGB value follows from one raw value: the chain's
    response and quantisation applied to every pixel's normalised raw value directly, above
    the black level, which the 8-bit output keeps (black / (2^bits - 1) of full scale)."""
    s = model.Sensor(read_noise_e=4, prnu=0.01, seed=3, **kw)
    lin = np.random.default_rng(2).uniform(0, 1, (22, 24, 3))   # mirrored 54 x 56: fast FFT lengths
    f = pipeline.process(lin, pipeline.Camera(s, nominal_exposure_s=0.01), pipeline.Shot(0.02, 2.0, 1, 0))
    x = (f.raw_dn.astype(np.float64) - s.black_level_dn) / (2 ** s.bits - 1 - s.black_level_dn)
    x = np.repeat(x[..., None], 3, axis=-1) if s.mono else x
    assert len(np.unique(f.raw_dn)) > 20
    b = s.black_level_dn / (2 ** s.bits - 1)
    assert np.array_equal(f.rgb8, raw.quantise(b + (1 - b) * raw.response(x, s.response, s.gamma), 8))


def test_fixed_pattern_noise_is_fixed_and_temporal_noise_is_not():
    s = model.Sensor(prnu=0.02, dsnu_e=5, full_well_e=1e9, cfa=None, bits=16, seed=2)
    lin = np.full((64, 64, 3), 0.5)
    cam = pipeline.Camera(s, nominal_exposure_s=1)
    f0, f1 = (pipeline.process(lin, cam, pipeline.Shot(exposure_s=1, gain=1.0, frame=k, view_index=1)).raw_dn
              for k in (0, 1))
    # the pattern (2 % of ~32768 DN) stays from frame to frame, the temporal noise (~1.5 DN) does not
    temporal = np.std(f0.astype(float) - f1.astype(float)) / np.sqrt(2)
    assert 1.0 < temporal < 2.5
    assert np.std(f0.astype(float)) / np.mean(f0) == pytest.approx(0.02, rel=0.1)


@pytest.mark.parametrize("pattern", cfa.PATTERNS)
def test_mosaic_matches_the_vo_reference_mosaic_and_opencv_demosaic(pattern):
    from vo_reference.camera.bayer import demosaic, mosaic
    rgb = np.random.default_rng(2).integers(0, 256, (40, 48, 3)).astype(np.uint8)
    m = cfa.mosaic(rgb, pattern)
    assert np.array_equal(m, mosaic(rgb, pattern))
    ours = raw.demosaic_bilinear(m.astype(float), pattern)
    ref = demosaic(m, pattern).astype(float)
    assert np.abs(ours - ref)[2:-2, 2:-2].max() <= 1.0               # OpenCV rounds to 8 bits


def test_malvar_demosaic_beats_bilinear_on_a_smooth_image():
    # natural images: the colour channels share their detail (MHC's premise)
    v, u = np.mgrid[0:64, 0:80] / 3.0
    detail = 0.5 + 0.2 * np.sin(u + v) + 0.15 * np.cos(0.7 * u - 1.3 * v)
    rgb = detail[..., None] * np.array([0.9, 0.7, 0.4]) + np.array([0.02, 0.05, 0.1])
    for p in cfa.PATTERNS:
        m = cfa.mosaic(rgb, p)
        err_b = np.abs(raw.demosaic_bilinear(m, p) - rgb)[4:-4, 4:-4].mean()
        err_m = np.abs(raw.demosaic_mhc(m, p) - rgb)[4:-4, 4:-4].mean()
        assert err_m < 0.8 * err_b, (p, err_m, err_b)


def test_response_and_quantisation():
    x = np.linspace(0, 1, 1001)
    from blender_sesgen.contract.colour import linear_to_srgb
    assert np.abs(raw.response(x, "srgb") - linear_to_srgb(x)).max() < 1e-6
    assert np.allclose(raw.response(x, "gamma", 2.0), np.sqrt(x))
    for bits in (8, 10, 12):
        q = raw.quantise(x, bits)
        assert q.max() == 2**bits - 1 and len(np.unique(q)) == min(1001, 2**bits)


def test_png_encoder_round_trips_through_opencv(tmp_path):
    rng = np.random.default_rng(0)
    for img in (rng.integers(0, 256, (7, 9, 3)).astype(np.uint8), rng.integers(0, 65536, (7, 9)).astype(np.uint16),
                rng.integers(0, 65536, (5, 6, 3)).astype(np.uint16)):
        for level in (0, 1, 6, 9):      # the sensor images' fast level decodes to the same pixels
            p = tmp_path / "x.png"
            p.write_bytes(encode_png(img, level))
            back = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
            back = back[..., ::-1] if back.ndim == 3 else back
            assert back.dtype == img.dtype and np.array_equal(back, img)


def test_bessel_j1_and_the_mtf():
    special = pytest.importorskip("scipy.special")
    x = np.linspace(-30, 30, 2001)
    assert np.abs(optics.bessel_j1(x) - special.j1(x)).max() < 1e-7
    # a sinusoid of frequency nu keeps contrast MTF(nu): diffraction at f/8, 550 nm, 2 um pixels
    H, W, nu = 64, 256, 0.125
    img = 0.5 + 0.25 * np.cos(2 * np.pi * nu * np.arange(W))[None, :].repeat(H, 0)
    out = optics.apply_mtf(np.stack([img] * 3, -1), pixel_um=2.0, f_number=8.0, wavelength_nm=550.0)[..., 1]
    x = nu / (2.0 / (0.55 * 8.0))
    expected = 2 / np.pi * (np.arccos(x) - x * np.sqrt(1 - x * x))
    contrast = (out[32, 64:192].max() - out[32, 64:192].min()) / 0.5
    assert contrast == pytest.approx(expected, rel=0.01)
    # the stored OTFs of later images: the values of an OTF made afresh for each
    params = dict(pixel_um=2.0, f_number=8.0, defocus_px=1.5, fill_factor=0.9)
    rgb = np.random.default_rng(1).random((20, 30, 3))
    for _ in range(2):
        got = optics.apply_mtf(rgb, margin=4, **params)
        for c, lam in enumerate(optics.WAVELENGTH_NM):   # mirrored to 28 x 38, padded to the fast 28 x 40
            p = np.pad(rgb[..., c], ((4, 4), (4, 6)), mode="reflect")
            T = optics.otf(p.shape, **params, wavelength_nm=lam)
            assert np.array_equal(got[..., c], np.fft.irfft2(np.fft.rfft2(p) * T, s=p.shape)[4:24, 4:34])
    # defocus disc: the OTF at its first zero (pi d nu = 3.8317) vanishes
    T = optics.otf((1, 512), defocus_px=6.0)
    k = int(round(3.8317 / (np.pi * 6.0) * 512))
    assert abs(T[0, k]) < 0.02 and T[0, 0] == pytest.approx(1.0)


def test_the_lens_blur_pads_to_fast_fft_lengths():
    # the smallest length >= n without a prime factor above 7 (brute force as the oracle)
    def smooth(k):
        for f in (2, 3, 5, 7):
            while k % f == 0:
                k //= f
        return k == 1
    for n in range(1, 1400):
        assert optics.fast_length(n) == next(k for k in range(n, 2 * n + 8) if smooth(k))
    assert optics.fast_length(402) == 405 and optics.fast_length(1258) == 1260   # KITTI's view, mirrored
    assert optics.fast_length(512) == 512 and optics.fast_length(784) == 784     # 640/752 x 480: as before
    # the blur of an image whose mirrored size is not fast (41 x 67, primes, filtered on 42 x 70)
    # equals the blur on the unpadded grid but for the kernel's tails beyond the margin, which
    # each grid wraps onto other mirrored pixels (white noise at f/16, 8 px: 0.3 % of the peak
    # at most; a pixel's shift or zero padding: ~30 %); of a mirrored size that is fast, to the bit
    rgb = np.random.default_rng(2).random((25, 51, 3))
    params = dict(pixel_um=2.0, f_number=16.0)
    for margin, tol in ((8, 5e-3), (12, 0.0)):
        got = optics.apply_mtf(rgb, margin=margin, **params)
        for c, lam in enumerate(optics.WAVELENGTH_NM):
            p = np.pad(rgb[..., c], margin, mode="reflect")
            want = np.fft.irfft2(np.fft.rfft2(p) * optics.otf(p.shape, **params, wavelength_nm=lam),
                                 s=p.shape)[margin:margin + 25, margin:margin + 51]
            assert np.abs(got[..., c] - want).max() <= tol * np.abs(want).max()


def test_vignetting_and_chromatic_aberration():
    rays = np.array([[[0, 0, 1.0], [np.sin(0.5), 0, np.cos(0.5)]]])
    assert np.allclose(optics.vignetting(rays, 1.0), [[1.0, np.cos(0.5) ** 4]])
    img = np.zeros((41, 61, 3))
    img[20, 55, :] = 1.0                                               # a point right of centre
    out = optics.chromatic_aberration(img, 30.0, 20.0, 2.0)
    corner = np.hypot(30, 20)
    col = lambda c: (out[20, :, c] * np.arange(61)).sum() / out[20, :, c].sum()  # noqa: E731
    assert col(0) == pytest.approx(30 + 25 * (1 + 2 / corner), abs=0.02)   # centroid of a resampled point
    assert col(1) == pytest.approx(55) and col(2) == pytest.approx(30 + 25 * (1 - 2 / corner), abs=0.02)


def test_auto_exposure_darkens_then_recovers_at_its_speed():
    rate, speed = 20.0, 4.0
    metered = [0.5] * 40 + [0.005] * 60                              # drive into a dark area
    kw = dict(nominal_exposure_s=0.002, nominal_gain=1.0, rate_hz=rate, readout_s=0.0, target=0.2, speed=speed,
              saturation=1.0, max_exposure_s=0.04, max_gain=8.0, min_exposure_s=1e-5)
    sched = autoexposure.exposure_schedule(metered, autoexposure.ExposureControl(**kw))
    E = np.array([t * g for t, g in sched])
    level = np.array(metered) * E[:-1] / 0.002
    assert level[39] == pytest.approx(0.2, rel=0.01)                 # converged in the bright part
    assert level[40] < 0.05                                           # the first dark frame is dark
    assert level[-1] == pytest.approx(0.2, rel=0.01)                  # and it recovers
    # in log space the error shrinks by exp(-speed / rate) per frame
    err = np.log(0.2 / level[41:50])
    assert np.allclose(err[1:] / err[:-1], np.exp(-speed / rate), rtol=1e-6)
    t, g = sched[-1]
    assert t == pytest.approx(0.04) and g > 1.0                       # exposure maxed, then gain


@pytest.mark.parametrize("frames", [[0], [0, 1], [2], [5, 6, 7], list(range(100)), [99]])
def test_a_render_meters_what_its_frames_exposures_follow(frames):
    """A render meters the frames before its last one (``metered_frames``): every one of its
    frames gets the exposure of the whole sequence's schedule (the oracle: the schedule from
    every frame metered), and no render meters more (the last frame's value is never used)."""
    rng = np.random.default_rng(3)
    metered = list(np.exp(rng.normal(-1.5, 1.0, 100)))
    c = autoexposure.ExposureControl(nominal_exposure_s=0.002, nominal_gain=1.0, rate_hz=20.0, readout_s=0.0,
                                     target=0.2, speed=4.0, saturation=1.0, max_exposure_s=0.04, max_gain=8.0,
                                     min_exposure_s=1e-5)
    whole = autoexposure.exposure_schedule(metered, c)
    upto = autoexposure.metered_frames(frames, len(metered))
    part = autoexposure.exposure_schedule(metered[:upto], c)
    assert [part[k] for k in frames] == [whole[k] for k in frames]
    assert upto == max(frames) and upto < 100


def test_a_flat_field_ramp_through_the_kitti_camera_uses_every_8_bit_code_above_its_black_level():
    """KITTI's files hold the camera's black level (their darkest pixels at 6-8) and no unused
    codes above it: the Flea2 digitises finer than 8 bits and applies its response before the
    8-bit output. A ramp from dark to past saturation through the profile's chain, at native
    size and binned to half size, must do the same: no code below the black level's 7, every
    code from 7 to 255 in use. (A raw of 8 bits through the gamma-1.3 response leaves 27 codes
    unused, the darkest ones; an output without the black level starts at 0.)"""
    from blender_sesgen.scene.camera_profiles import at_width
    from blender_sesgen.ses.parser import parse_text
    sc = parse_text("CAMERA resolution 1226 370 focal 707\nQUAD id 1 texture 1 vertices 0 0 0  1 0 0  1 0 1  0 0 1\n"
                    "SENSOR profile kitti\n")
    for width in (1226, 613):
        sensor, _ = at_width(sc.sensor, None, width)
        lin = np.tile(np.linspace(0.0, 1.1 * sensor.saturation, 4 * width)[None, :, None], (24, 1, 3))
        f = pipeline.process(lin, pipeline.Camera(sensor, nominal_exposure_s=0.0), pipeline.Shot(0.0, 1.0, 0, 0))
        codes = np.bincount(f.rgb8[..., 0].ravel(), minlength=256)
        assert codes[:7].sum() == 0 and codes[7] > 0, (width, np.nonzero(codes)[0][:3])
        assert np.all(codes[7:] > 0), (width, np.nonzero(codes[7:] == 0)[0] + 7)
