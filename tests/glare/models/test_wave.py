import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.glare import HybridGlare, VosGlare, WaveOpticsGlare, digitise_kernel
from glarelab.glare.models import apertures as ap
from glarelab.glare.models.wave import (
    compare_spectral_methods,
    psf_fraunhofer,
    rebin,
    sigmoid_Kakimoto2004,
)

CAMERA = {"eyelashes": False, "eyelid": False, "particles": 0}


def radial_profile(values):
    n = values.shape[0]
    y, x = np.indices(values.shape) - n // 2
    r = np.hypot(x, y).round().astype(int)
    return np.bincount(r.ravel(), values.ravel()) / np.bincount(r.ravel())


def angular_profile(values, r_min, r_max, bins=360):
    n = values.shape[0]
    y, x = np.indices(values.shape) - n // 2
    r = np.hypot(x, y)
    phi = np.degrees(np.arctan2(y, x)) % 360
    ring = (r >= r_min) & (r <= r_max)
    return np.bincount((phi[ring] * bins / 360).astype(int), values[ring], minlength=bins)


@pytest.mark.parametrize("diameter_mm", [3.0, 6.0])
@pytest.mark.parametrize("wavelength_nm", [450.0, 650.0])
def test_circular_pupil_gives_the_airy_pattern(diameter_mm, wavelength_nm):
    # first dark ring at 1.22 λ / D (Airy), within one PSF sample
    grid = ap.ApertureGrid(1024, diameter_mm / 100)
    psf = psf_fraunhofer(ap.aperture_pupil(grid, diameter_mm), grid.spacing_mm, wavelength_nm)
    profile = radial_profile(psf.values)[:40]
    first_minimum = np.argmax((profile[1:-1] < profile[:-2]) & (profile[1:-1] < profile[2:])) + 1
    expected_deg = math.degrees(1.22 * wavelength_nm * 1e-6 / diameter_mm)
    assert abs(first_minimum * psf.spacing_deg - expected_deg) <= psf.spacing_deg


def test_airy_ring_scales_with_wavelength():
    grid = ap.ApertureGrid(512, 0.04)
    t = ap.aperture_pupil(grid, 4.0)
    blue, red = (psf_fraunhofer(t, grid.spacing_mm, w) for w in (450.0, 650.0))
    assert_allclose(red.spacing_deg / blue.spacing_deg, 650 / 450, rtol=1e-12)
    assert np.array_equal(blue.values, red.values)  # same pattern, other angular scale


def test_psf_sums_to_one_and_obeys_parseval():
    grid = ap.ApertureGrid(256, 0.05)
    t = ap.aperture_pupil(grid, 4.0) * ap.aperture_particles(grid, rng=np.random.default_rng(0))
    psf = psf_fraunhofer(t, grid.spacing_mm, 550.0)
    assert_allclose(psf.values.sum(), 1.0, rtol=1e-12)
    # Parseval: Σ|DFT t|² = N² Σ|t|²
    assert_allclose(psf.raw_energy, 256**2 * psf.transmitted_samples, rtol=1e-6)
    assert_allclose(psf.transmitted_samples, np.sum(t**2), rtol=1e-12)


def test_hexagonal_diaphragm_is_six_fold_symmetric():
    grid = ap.ApertureGrid(1024, 0.01)
    psf = psf_fraunhofer(ap.aperture_diaphragm(grid, 4.0, 6), grid.spacing_mm, 550.0)
    n = psf.values.shape[0]
    y, x = np.indices(psf.values.shape) - n // 2
    r = np.hypot(x, y) * psf.spacing_deg
    phi = np.degrees(np.arctan2(y, x)) % 360
    ring = (r >= 0.1) & (r <= 0.5)
    # the six streaks run along the edge normals, 30° + k 60°
    counts = np.bincount(phi[ring].astype(int), minlength=360)
    mean = np.bincount(phi[ring].astype(int), psf.values[ring], minlength=360) / counts
    peaks = np.sort(np.argsort(mean)[-6:])
    assert_allclose(peaks, np.arange(30, 360, 60), atol=1)
    # every 60° sector holds the same energy (to the grid's rasterisation of oblique edges)
    for centres in (range(0, 360, 60), range(30, 360, 60)):
        sectors = np.array(
            [psf.values[ring & (np.abs((phi - c + 180) % 360 - 180) <= 15)].sum() for c in centres]
        )
        assert_allclose(sectors / sectors.mean(), 1.0, atol=0.02)
    # ... and it is not circular: streak directions carry more than the directions between
    assert mean[peaks].min() > 3 * np.median(mean)


@pytest.mark.parametrize(("kind", "streaks"), [("4-point", 4), ("trigonal", 6)])
def test_cross_screens_give_their_streaks(kind, streaks):
    grid = ap.ApertureGrid(1024, 0.0125)
    t = ap.aperture_pupil(grid, 6.0) * ap.aperture_cross_screen(grid, kind)
    psf = psf_fraunhofer(t, grid.spacing_mm, 550.0)
    profile = angular_profile(psf.values, 30, 400, bins=72)  # 5° bins
    peaks = profile > 5 * np.median(profile)
    starts = np.flatnonzero(peaks & ~np.roll(peaks, 1))
    assert starts.size == streaks
    # the streaks are evenly spaced, 360/streaks apart
    assert_allclose(np.diff(np.sort(starts)) * 5, 360 / streaks, atol=5)


def test_undersampled_aperture_is_refused():
    grid = ap.ApertureGrid(64, 0.2)  # a 3 mm pupil over 15 samples
    with pytest.raises(ValueError, match=r"undersampled: its open part spans 1[5-7] samples"):
        psf_fraunhofer(ap.aperture_pupil(grid, 3.0), grid.spacing_mm, 550.0)


def test_aperture_filling_its_grid_is_padded_not_wrapped():
    grid = ap.ApertureGrid(128, 0.05)
    t = ap.aperture_pupil(grid, 6.3)  # 126 of 128 samples: the autocorrelation would wrap
    psf = psf_fraunhofer(t, grid.spacing_mm, 550.0)
    assert psf.padded_to >= 2 * 126
    padded = np.zeros((psf.padded_to, psf.padded_to))
    o = psf.padded_to // 2 - 64
    padded[o : o + 128, o : o + 128] = t
    assert_allclose(psf.values, psf_fraunhofer(padded, 0.05, 550.0).values, atol=1e-12)


def test_fresnel_term_spreads_light_over_the_pupil_shadow():
    # Luidolt eq. 5.6 without a lens: the PSF fills the geometric shadow, radius D / 2d rad
    diameter, d = 2.0, 24.0
    grid = ap.ApertureGrid(1024, 0.004)
    psf = psf_fraunhofer(ap.aperture_pupil(grid, diameter), 0.004, 550.0, fresnel_distance_mm=d)
    shadow = math.degrees(diameter / (2 * d))
    n = psf.values.shape[0]
    y, x = np.indices(psf.values.shape) - n // 2
    r = np.hypot(x, y) * psf.spacing_deg
    assert psf.values[r <= 1.1 * shadow].sum() > 0.97
    assert_allclose(psf.values[r <= 0.5 * shadow].sum(), 0.25, atol=0.03)  # a uniform disc


def test_undersampled_fresnel_term_is_refused():
    grid = ap.ApertureGrid(512, 0.02)
    with pytest.raises(ValueError, match=r"Fresnel term is undersampled"):
        psf_fraunhofer(ap.aperture_pupil(grid, 6.0), 0.02, 550.0, fresnel_distance_mm=24.0)
    with pytest.raises(ValueError, match="the Fresnel term below Nyquist with a 6 mm pupil"):
        WaveOpticsGlare(pupil_mm=6.0, fresnel=True).kernel(0.01, (201, 201))


def test_rebin_conserves_energy_and_integrates_exactly():
    rng = np.random.default_rng(0)
    values = rng.random((301, 301))
    out = rebin(values, 0.01, 0.025, (121, 121))  # the output covers the input
    assert_allclose(out.sum(), values.sum(), rtol=1e-12)
    # integer ratio: plain block sums (5 × 5 blocks of a 0.01° grid onto 0.05°)
    blocks = rebin(values[3:298, 3:298], 0.01, 0.05, (59, 59))
    expected = values[3:298, 3:298].reshape(59, 5, 59, 5).sum(axis=(1, 3))
    assert_allclose(blocks, expected, rtol=1e-10)


def test_kernel_energy_account_and_pupil_from_the_eye_state():
    model = WaveOpticsGlare(pupil_mm=None, field_luminance_cd_m2=10.0, particles=200)
    assert_allclose(model.pupil_diameter, 4.9 - 3 * math.tanh(0.8), rtol=1e-12)  # Moon-Spencer
    k = model.kernel(0.02, (101, 101))
    assert_allclose(k.values.sum() + k.energy_outside, 1.0, atol=1e-9)
    assert (k.values >= 0).all()
    colour = model.kernel(0.02, (101, 101), colour=True)
    assert colour.values.shape == (101, 101, 3)
    assert_allclose(colour.values.sum(axis=(0, 1)) + colour.energy_outside, 1.0, atol=1e-9)


def test_scaled_copies_equal_the_reference_without_fresnel_and_kakimoto_does_not():
    model = WaveOpticsGlare(pupil_mm=3.0, **CAMERA, diaphragm_sides=6)
    rows = {r["method"]: r for r in compare_spectral_methods(model, 0.02, (61, 61))}
    assert rows["reference"]["delta_e_mean"] == 0.0
    assert rows["scaled"]["delta_e_max"] < 1e-6  # exact in Fraunhofer: FFT is λ-independent
    assert rows["kakimoto"]["delta_e_mean"] > 1.0  # three spectral lines are visibly off
    assert all(r["seconds"] > 0 for r in rows.values())


def test_source_position_moves_the_eyelashes():
    model = WaveOpticsGlare(pupil_mm=4.0, particles=0)
    centre = model.kernel(0.02, (101, 101)).values
    again = model.at_source(0.0).kernel(0.02, (101, 101)).values
    moved = model.at_source(15.0).kernel(0.02, (101, 101)).values
    assert np.array_equal(centre, again)
    assert np.abs(moved - centre).sum() > 0.01
    kernels = model.kernel_set(0.02, (101, 101), [0.0, 15.0])
    assert list(kernels) == [0.0, 15.0]
    assert np.array_equal(kernels[15.0].values, moved)


def test_user_obstacle_image_is_used():
    image = np.ones((201, 201))
    image[:, 95:106] = 0.0  # a vertical bar 0.11 mm wide through the pupil centre
    model = WaveOpticsGlare(pupil_mm=4.0, **CAMERA, obstacle_image=image, obstacle_spacing_mm=0.01)
    plain = WaveOpticsGlare(pupil_mm=4.0, **CAMERA).kernel(0.02, (101, 101)).values
    barred = model.kernel(0.02, (101, 101)).values
    # a vertical bar diffracts horizontally: more light along the horizontal axis
    assert barred[50, 70:].sum() > 2 * plain[50, 70:].sum()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"pupil_mm": 0.0}, r"pupil_mm must be in \[1, 10\] mm"),
        ({"pupil_mm": 12.0}, "pupil_mm"),
        ({"spectral": "fast"}, "spectral must be one of"),
        ({"particles": -5}, "particles must be an integer from 0 to 100000, got -5"),
        # a billion particles asked for 7.45 GiB; a million lashes rendered for over an hour
        ({"particles": 10**9}, "particles must be an integer from 0 to 100000, got 1000000000"),
        ({"eyelash_count": 10**6}, "eyelash_count must be an integer from 0 to 1000, got 1000000"),
        ({"eyelash_count": 1.5}, "eyelash_count must be an integer from 0 to 1000, got 1.5"),
        ({"cross_screen": "star"}, "cross_screen must be one of"),
        ({"field_luminance_cd_m2": -1.0}, "field_luminance_cd_m2 must be >= 0"),
        ({"obstacle_image": np.full((3, 3), 2.0), "obstacle_spacing_mm": 0.1}, r"\[0, 1\]"),
        ({"obstacle_image": np.ones((3, 3))}, "obstacle_spacing_mm must be a finite number"),
    ],
)
def test_bad_parameters_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        WaveOpticsGlare(**kwargs)


def test_bad_wavelength_raises():
    grid = ap.ApertureGrid(128, 0.05)
    with pytest.raises(ValueError, match=r"wavelength_nm must be in \[380, 780\] nm"):
        psf_fraunhofer(ap.aperture_pupil(grid, 3.0), 0.05, 0.0)
    with pytest.raises(ValueError, match="spacing_mm must be a finite number > 0"):
        psf_fraunhofer(ap.aperture_pupil(grid, 3.0), -0.05, 550.0)
    with pytest.raises(ValueError, match="opaque everywhere"):
        psf_fraunhofer(np.zeros((64, 64)), 0.05, 550.0)


def test_hybrid_keeps_vos_scattering_and_spreads_the_core_by_diffraction():
    wave = WaveOpticsGlare(pupil_mm=3.0, **CAMERA)
    hybrid = HybridGlare(wave=wave, regime="mesopic").kernel(0.02, (101, 101))
    vos_model = VosGlare(regime="mesopic")
    parts = vos_model.parts(0.02, (101, 101))
    w0 = parts["weights"][0]
    diffraction = wave.kernel(0.02, (101, 101))
    assert_allclose(
        hybrid.values, w0 * diffraction.values + parts["scatter"] + parts["halo"][0], rtol=1e-12
    )
    assert_allclose(hybrid.values.sum() + hybrid.energy_outside, 1.0, atol=1e-9)


def test_sigmoid_tone_curve_of_kakimoto():
    # eq. 7 with D = 640, k = 20, g = 0.465 (§3.4), in the form §3.3 describes: D the maximum,
    # k² the contrast between minimum and maximum: D / k² at 0, D / k at 1, rising towards D
    x = np.array([0.0, 1.0, 1e3, 1e12])
    y = sigmoid_Kakimoto2004(x)
    assert_allclose(y[:2], [640 / 400, 640 / 20], rtol=1e-12)
    assert np.all(np.diff(y) > 0) and y[-1] < 640.0
    assert_allclose(sigmoid_Kakimoto2004(np.array(1e300)) / y[0], 20.0**2, rtol=1e-9)
    # log-log symmetric about x = 1: sig(x) sig(1/x) = (D / k)²
    assert_allclose(sigmoid_Kakimoto2004(np.array(7.0)) * sigmoid_Kakimoto2004(np.array(1 / 7)),
                    32.0**2, rtol=1e-12)  # fmt: skip
    # eq. 7 as printed: contrast k, a floor of 32
    printed = sigmoid_Kakimoto2004(x, form="as printed")
    assert_allclose(printed[:2], [32.0, 640 * 2 / 21], rtol=1e-12)
    with pytest.raises(ValueError, match=">= 0"):
        sigmoid_Kakimoto2004(np.array([-1.0]))
    with pytest.raises(ValueError, match="form must be one of"):
        sigmoid_Kakimoto2004(x, form="tumblin")


def test_eyelash_parameters_reach_the_aperture():
    base = WaveOpticsGlare(pupil_mm=4.0, particles=0)
    grid = base.grid_for(0.02, (101, 101))
    few = WaveOpticsGlare(pupil_mm=4.0, particles=0, eyelash_count=5).aperture(grid)
    thick = WaveOpticsGlare(pupil_mm=4.0, particles=0, eyelash_thickness_mm=0.2).aperture(grid)
    plain = base.aperture(grid)
    assert few.sum() > plain.sum() > thick.sum()


def test_wave_models_render_like_the_others():
    from glarelab.glare import add_glare, render_glare

    image = np.full((61, 61), 100.0)
    image[30, 30] = 1e6
    model = WaveOpticsGlare(pupil_mm=3.0, particles=100)
    result = render_glare(image, model, pixel_deg=0.03, composition="Spencer1995")
    total = result.spread.sum() + result.energy_outside_image + result.energy_outside_kernel
    assert_allclose(total, result.excess_energy, rtol=1e-9)
    assert add_glare(image, "hybrid", pixel_deg=0.05).max() == 220.0


@pytest.mark.parametrize(
    "aperture",
    [
        {"cross_screen": "trigonal"},
        {"cross_screen": "4-point"},
        {"diaphragm_sides": 6},
        {"eyelid": True},
        {"obstacle_image": np.ones((5, 5)), "obstacle_spacing_mm": 0.01},
    ],
)
def test_the_fast_grid_keeps_the_one_sample_drawing_beside_the_prefilters(aperture):
    # aperture_grid="fast" is the faster path the prefilters (1.3-30 times the time) leave
    # available, its error in codes in docs/optics/fast_drawing_codes.csv
    plain = {"eyelashes": False, "eyelid": False, "particles": 0, **aperture}
    assert WaveOpticsGlare(**plain)._prefilter() != ap.PREFILTER_BOX
    assert WaveOpticsGlare(**plain, aperture_grid="fast")._prefilter() == ap.PREFILTER_BOX


@pytest.mark.parametrize("colour", [False, True])
def test_under_luidolts_convention_only_light_beyond_the_support_is_booked_outside(colour):
    # the pupil's share of the light was booked as outside: 0.938 for a 2 mm pupil, where the
    # light beyond the 31² support is 0.012 of what enters the eye
    own = WaveOpticsGlare(pupil_mm=2.0)
    luidolt = WaveOpticsGlare(pupil_mm=2.0, pupil_convention="Luidolt2020")
    unit = digitise_kernel(own, 0.05, (31, 31), colour=colour, cache=False)
    scaled = digitise_kernel(luidolt, 0.05, (31, 31), colour=colour, cache=False)
    share = scaled.description["admitted_share"]
    assert_allclose(scaled.energy_outside, share * np.asarray(unit.energy_outside), rtol=1e-9)
    total = scaled.values.sum(axis=(0, 1)) + scaled.energy_outside
    assert_allclose(total, share, rtol=1e-12)


def test_a_reference_spectrum_that_would_equal_the_scaled_one_is_refused():
    # under the exact pixel integration without the Fresnel term one autocorrelation serves
    # every wavelength: spectral='reference' gave the 'scaled' kernel bit for bit, unsaid
    with pytest.raises(ValueError, match=r"^spectral='reference' with pixel_integration='exact'"):
        WaveOpticsGlare(pupil_mm=3.0, **CAMERA, spectral="reference")
    # where it acts: a Fresnel term per wavelength, or one FFT per wavelength
    WaveOpticsGlare(pupil_mm=3.0, **CAMERA, spectral="reference", fresnel=True)
    WaveOpticsGlare(pupil_mm=3.0, **CAMERA, spectral="reference", pixel_integration="rebin")


def test_models_of_two_obstacle_images_are_not_equal_nor_share_a_kernel():
    """Two wave models with different aperture images compared equal (the image is left out
    of the comparison), and a renderer took one's kernel for the other's without a word."""
    from glarelab.glare import GlareRenderer

    first = np.ones((32, 32))
    first[10:20, :] = 0.0
    second = np.ones((32, 32))
    second[:, 10:20] = 0.0
    a = WaveOpticsGlare(obstacle_image=first, obstacle_spacing_mm=0.1)
    b = WaveOpticsGlare(obstacle_image=second, obstacle_spacing_mm=0.1)
    same = WaveOpticsGlare(obstacle_image=first.copy(), obstacle_spacing_mm=0.1)
    assert a != b and a == same and hash(a) == hash(same)
    assert a != WaveOpticsGlare(obstacle_image=first.astype(np.float32), obstacle_spacing_mm=0.1)
    kernel = a.kernel(0.05, (31, 31))
    assert kernel.description["obstacle_image"].startswith("user image, sha256 ")
    with pytest.raises(ValueError, match="kernel was digitised"):
        GlareRenderer(b, pixel_deg=0.05, shape=(16, 16), kernel=kernel)
    GlareRenderer(same, pixel_deg=0.05, shape=(16, 16), kernel=kernel)  # its own image's
