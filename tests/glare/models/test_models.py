import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab import glare
from glarelab.glare import GaussianGlare, VosGlare


def radial_average(image, bin_px=4):
    cy, cx = image.shape[0] // 2, image.shape[1] // 2
    y, x = np.indices(image.shape[:2])
    r = np.hypot(y - cy, x - cx)
    bins = (r // bin_px).astype(int)
    counts = np.bincount(bins.ravel())
    sums = np.bincount(bins.ravel(), image.ravel())
    return sums / np.maximum(counts, 1), counts


# --- Gaussian (Yoshida 2008, eq. 2) ------------------------------------------------------


@pytest.mark.parametrize(("sigma_deg", "pixel_deg"), [(0.34, 0.0119), (0.34, 0.034), (1.0, 0.1)])
def test_gaussian_sigma_in_pixels_is_sigma_deg_over_pixel_deg(sigma_deg, pixel_deg):
    sigma_px = sigma_deg / pixel_deg
    half = int(8 * sigma_px)
    k = GaussianGlare(sigma_deg=sigma_deg).kernel(pixel_deg, (2 * half + 1, 2 * half + 1))
    assert k.description["sigma_px"] == pytest.approx(sigma_px, rel=1e-12)
    _y, x = np.indices(k.values.shape) - half
    variance_x = (k.values * x**2).sum()  # second moment of a normalised Gaussian: σ²
    assert_allclose(np.sqrt(variance_x), sigma_px, rtol=2e-3)


def test_gaussian_is_normalised_to_one_and_shaped_as_eq_2():
    # Yoshida eq. 2 as printed: k is the sum of the kernel's own elements
    k = GaussianGlare(normalisation="Yoshida2008").kernel(0.034, (41, 41))  # σ = 10 px
    assert_allclose(k.values.sum(), 1.0, rtol=1e-14)
    assert k.energy_outside == 0.0
    # eq. 2: F(x, 0) / F(0, 0) = exp(-x² / 2σ²)
    assert_allclose(k.values[20, 30] / k.values[20, 20], np.exp(-100 / 200), rtol=1e-12)
    # the tail beyond ±20.5 px of a σ = 10 px Gaussian is redistributed and reported
    assert 0.07 < k.description["truncated_tail"] < 0.09


def test_pixel_integrated_gaussian_agrees_with_point_sampling_for_wide_kernels():
    point = GaussianGlare(sampling="point").kernel(0.0119, (301, 301)).values
    pixel = GaussianGlare(sampling="pixel").kernel(0.0119, (301, 301)).values
    # they differ at second order, ≈ (x²/σ² - 1) / (24 σ²) relative: here σ = 28.6 px
    sigma_px = 0.34 / 0.0119
    assert_allclose(pixel, point, rtol=0, atol=2 / (24 * sigma_px**2) * point.max())


def test_narrow_point_sampled_gaussian_warns():
    with pytest.warns(UserWarning, match="sampling='pixel'"):
        GaussianGlare(sigma_deg=0.01).kernel(0.02, (11, 11))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        k = GaussianGlare(sigma_deg=0.01, sampling="pixel").kernel(0.02, (11, 11))
    assert_allclose(k.values.sum(), 1.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sigma_deg": 0.0}, "sigma_deg must be a finite number > 0"),
        ({"sigma_deg": float("nan")}, "sigma_deg"),
        ({"sampling": "area"}, "sampling must be one of 'point', 'pixel'"),
    ],
)
def test_gaussian_rejects_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        GaussianGlare(**kwargs)


# --- Vos / Spencer --------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"regime": "twilight"}, "regime must be one of"),
        ({"age": 90.0}, "age must be in"),
        ({"wavelength_nm": 300.0}, "wavelength_nm must be in"),
        ({"seed": -1}, "seed must be an integer >= 0"),
        ({"samples_per_pixel": 0}, "samples_per_pixel must be an integer >= 1"),
    ],
)
def test_vos_rejects_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        VosGlare(**kwargs)


def test_photopic_colour_kernel_is_grey_and_equals_the_luminance_kernel():
    luminance = VosGlare().kernel(0.05, (101, 101))
    colour = VosGlare().kernel(0.05, (101, 101), colour=True)
    assert colour.values.shape == (101, 101, 3)
    for c in range(3):
        assert_allclose(colour.values[..., c], luminance.values, rtol=1e-12)


def test_mesopic_halo_is_a_coloured_ring_at_3_degrees():
    pixel_deg = 0.02
    k = VosGlare(regime="mesopic").kernel(pixel_deg, (501, 501), colour=True)
    smooth = VosGlare(regime="photopic").kernel(pixel_deg, (501, 501)).values
    profile, _ = radial_average(k.values[..., 1] - smooth * (0.368 / 0.384), bin_px=1)
    # the extra energy peaks near 3° (= 150 px) and the ring colours run blue → red outwards
    ring = np.argmax(profile[100:]) + 100
    assert abs(ring * pixel_deg - 3.0) < 0.15
    red, _ = radial_average(k.values[..., 0], bin_px=1)
    blue, _ = radial_average(k.values[..., 2], bin_px=1)
    inner, outer = int(2.4 / pixel_deg), int(3.5 / pixel_deg)
    assert blue[inner] > red[inner] and red[outer] > blue[outer]
    # every channel carries the same energy: the halo moves light, it does not tint it
    assert_allclose(k.values.sum(axis=(0, 1)) + k.energy_outside, 1.0, atol=1e-12)


def test_monochromatic_halo_peaks_at_its_wavelength_radius():
    pixel_deg = 0.01
    k = VosGlare(regime="scotopic", wavelength_nm=650.0).kernel(pixel_deg, (1001, 1001))
    base = VosGlare(regime="scotopic", wavelength_nm=400.0).kernel(pixel_deg, (1001, 1001))
    diff, _ = radial_average(k.values - base.values, bin_px=1)
    assert abs(np.argmax(diff) * pixel_deg - 3.0 * 650 / 568) < 0.03


def test_from_field_luminance_picks_the_regime():
    assert VosGlare.from_field_luminance(0.001).regime == "scotopic"
    assert VosGlare.from_field_luminance(100.0, age=40.0).age == 40.0


# --- flare lines (Spencer §3.2) -------------------------------------------------------


@pytest.mark.parametrize("regime", ["photopic", "scotopic"])
def test_flare_lines_keep_the_macroscopic_psf(regime):
    shape = (601, 601)
    smooth = VosGlare(regime=regime).kernel(0.01, shape)
    streaked = VosGlare(regime=regime, flare_lines=True, seed=3).kernel(0.01, shape)
    assert_allclose(streaked.values.sum(), smooth.values.sum(), rtol=1e-12)
    assert streaked.energy_outside == smooth.energy_outside
    # the azimuthal average of the streaked kernel matches the smooth kernel
    a_streaked, _counts = radial_average(streaked.values, bin_px=5)
    a_smooth, _ = radial_average(smooth.values, bin_px=5)
    full_rings = slice(1, 300 // 5)
    assert_allclose(a_streaked[full_rings], a_smooth[full_rings], rtol=0.03)
    # ... while individual pixels differ strongly: the lines are there
    ring = np.abs(np.hypot(*(np.indices(shape) - 300)) - 200) < 1
    assert streaked.values[ring].std() > 0.5 * smooth.values[ring].mean()


def test_flare_lines_are_reproducible_by_seed():
    a = VosGlare(flare_lines=True, seed=7).kernel(0.05, (101, 101)).values
    b = VosGlare(flare_lines=True, seed=7).kernel(0.05, (101, 101)).values
    c = VosGlare(flare_lines=True, seed=8).kernel(0.05, (101, 101)).values
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_flare_pattern_has_mean_one_on_every_ring():
    pattern = glare.flare_line_pattern((801, 801), rng=np.random.default_rng(0), n_lines=120)
    means, _counts = radial_average(pattern, bin_px=8)
    assert (pattern >= 0).all()
    assert_allclose(means[1:50], 1.0, rtol=0.02)


# --- registry and dispatcher ----------------------------------------------------------


def test_models_are_reachable_by_name():
    assert isinstance(glare.make_model("Yoshida2008"), GaussianGlare)
    assert isinstance(glare.make_model("Spencer1995", regime="scotopic"), VosGlare)
    k = glare.kernel("gaussian", 0.034, (21, 21))
    assert isinstance(k, np.ndarray) and k.shape == (21, 21)
    with pytest.raises(ValueError, match="method must be one of"):
        glare.make_model("kakimoto")
    with pytest.raises(ValueError, match="model must be a glare model"):
        glare.kernel(42, 0.1, (3, 3))


def test_a_model_name_given_as_model_is_refused_naming_model():
    # render_glare(image, model='Vos') said "method must be one of ...": no such argument
    with pytest.raises(ValueError, match=r"^model must be one of .*; got 'Vos' \(names are "
                       r"case-sensitive: 'vos'\)$"):  # fmt: skip
        glare.render_glare(np.ones((8, 8)), model="Vos", pixel_deg=0.05)
    with pytest.raises(ValueError, match=r"^model must be one of .*; got 'kakimoto'$"):
        glare.kernel("kakimoto", 0.1, (3, 3))


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"shape": (11, 11), "rng": None}, "rng"),  # was an AttributeError
        ({"shape": (11, 11), "rng": 5}, "rng"),  # an int seed: was an AttributeError
        ({"shape": (10, 10), "rng": np.random.default_rng(0)}, "shape"),  # was 11 × 11
        ({"shape": (11,), "rng": np.random.default_rng(0)}, "shape"),
    ],
)
def test_flare_lines_refuse_what_cannot_be_their_kernel_or_randomness(options, name):
    from glarelab.glare.models.flare import flare_line_pattern

    with pytest.raises(ValueError, match=f"^{name} must"):
        flare_line_pattern(n_lines=5, **options)


@pytest.mark.parametrize("value", [3, "x", None])
def test_vos_refuses_a_halo_spectrum_that_is_not_one(value):
    """VosGlare(halo_spectrum=3) was accepted and failed in the digitiser with
    "'int' object has no attribute 'wavelengths_nm'"."""
    with pytest.raises(ValueError, match=r"halo_spectrum must be a HaloSpectrum .*; got "):
        VosGlare(regime="mesopic", halo_spectrum=value)
