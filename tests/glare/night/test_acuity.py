"""Acuity at night (Luidolt 2020 §5.3, eqs. 5.14-5.17) and the spatially varying blur, against
the paper's numbers, hand calculations and the exact per-pixel blur."""

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose
from scipy import ndimage

from glarelab.glare.night import acuity

# --- eq. 5.14: Larson et al. 1997 -------------------------------------------------------------


@pytest.mark.parametrize(
    ("luminance", "expected"),
    [
        # hand calculation of 17.25 atan(1.4 log10 Y + 0.35) + 25.72:
        (0.03, 17.25 * math.atan(1.4 * math.log10(0.03) + 0.35) + 25.72),  # 7.445
        (100.0, 17.25 * math.atan(1.4 * 2 + 0.35) + 25.72),  # 47.51
        (1.0, 17.25 * math.atan(0.35) + 25.72),  # 31.53
    ],
)
def test_eq_5_14_at_the_luminances_luidolt_names(luminance, expected):
    assert_allclose(acuity.acuity_cpd(luminance), expected, rtol=1e-14)


def test_eq_5_14_runs_from_night_to_daylight_acuity():
    # at 0.03 cd/m², where Luidolt (§2.2.2, §4.3) says cone acuity is lost: 7.4 cycles/deg,
    # a seventh of the daylight 47.5 at 100 cd/m²; the fit's limit 17.25 π/2 + 25.72 = 52.8
    assert acuity.acuity_cpd(0.03) == pytest.approx(7.445, abs=5e-4)
    assert acuity.acuity_cpd(100.0) == pytest.approx(47.51, abs=5e-3)
    assert acuity.acuity_cpd(1e9) < 17.25 * math.pi / 2 + 25.72
    levels = np.logspace(-6, 9, 200)
    assert (np.diff(acuity.acuity_cpd(levels)) > 0).all()


def test_below_the_absolute_threshold_the_acuity_is_the_thresholds():
    # eq. 5.14 crosses 0 at 6.6e-10 cd/m²; darker pixels get the acuity at 1e-6 cd/m²
    crossing = 10 ** ((math.tan(-25.72 / 17.25) - 0.35) / 1.4)
    assert crossing == pytest.approx(6.6e-10, rel=0.01)
    assert acuity.acuity_cpd(0.0) == acuity.acuity_cpd(1e-6) > 0.75


def test_eq_5_17_inverts_eq_5_14_and_gives_l_1_31_at_the_headsets_resolution():
    # Luidolt §5.3.2: 13.85 px/deg "corresponds to approximately 1.31 L" (L* of a 100 cd/m² white)
    y = acuity.luminance_for_acuity(13.85)
    assert_allclose(acuity.acuity_cpd(y), 13.85, rtol=1e-12)
    assert acuity.lightness(y) == pytest.approx(1.31, abs=0.005)
    cpd = np.linspace(0.8, 52.0, 50)
    assert_allclose(acuity.acuity_cpd(acuity.luminance_for_acuity(cpd)), cpd, rtol=1e-10)


def test_eq_5_17_as_printed_is_a_rounding_of_the_inverse():
    printed = math.exp(-1.64 * math.tan(1.49 - 0.06 * 13.85) - 0.575646)
    assert printed == pytest.approx(acuity.luminance_for_acuity(13.85), rel=0.1)


# --- eqs. 5.15, 5.16: the blur's σ in degrees --------------------------------------------------


def test_eq_5_15_in_degrees():
    # σ = width / (fov 1.86 √2 R) px: in degrees 1 / (1.86 √2 R)
    for y in (1e-4, 0.03, 1.0, 1e4):
        assert_allclose(
            acuity.blur_sigma_deg(y), 1 / (1.86 * math.sqrt(2) * acuity.acuity_cpd(y)), rtol=1e-14
        )
    # where R equals the headset's 13.85 px/deg, σ is 1 / (1.86 √2) = 0.38 of its pixels
    y = acuity.luminance_for_acuity(acuity.VIVE_PRO_PX_PER_DEG)
    assert_allclose(
        acuity.blur_sigma_deg(y) * acuity.VIVE_PRO_PX_PER_DEG, 1 / (1.86 * math.sqrt(2)), rtol=1e-9
    )


def test_eq_5_16_is_one_headset_pixel_in_the_dark_and_none_above_l_1():
    assert acuity.blur_sigma_deg(0.0, method="Luidolt2020") == pytest.approx(104 / 1440)
    y_at_l1 = 100.0 * 27 / 24389  # L* = 1 (the linear part of CIE L*): 0.1107 cd/m²
    assert acuity.blur_sigma_deg(y_at_l1 * 1.0001, method="Luidolt2020") == 0.0
    assert acuity.blur_sigma_deg(1e9, method="Luidolt2020") == 0.0
    # half way: L* = 0.5 → σ = 0.5 px of the headset
    assert_allclose(
        acuity.blur_sigma_deg(y_at_l1 / 2, method="Luidolt2020") * acuity.VIVE_PRO_PX_PER_DEG,
        0.5,
        rtol=1e-9,
    )


def test_luidolts_fit_against_the_acuity_curve_it_replaces():
    # Fig. 5.8: the linear fit follows Krawczyk's σ (in headset pixels) between L* = 0 and 1
    # only in order of magnitude; in the deep dark it stays at one pixel where Larson's acuity
    # asks for seven
    at = np.array([1e-6, 1e-3, 0.05])
    luidolt = acuity.blur_sigma_deg(at, method="Luidolt2020")
    krawczyk = acuity.blur_sigma_deg(at)
    assert (luidolt > 0).all() and (krawczyk > 0).all()
    assert krawczyk[0] / luidolt[0] == pytest.approx(6.96, abs=0.05)


# --- the varying blur --------------------------------------------------------------------------


def _normalised_gaussian(image, sigma):
    blurred = ndimage.gaussian_filter(image, sigma, mode="constant", truncate=4.0)
    ones = ndimage.gaussian_filter(np.ones(image.shape), sigma, mode="constant", truncate=4.0)
    return blurred / ones


@pytest.mark.parametrize(
    ("method", "sigma"),
    [
        *((m, s) for m in ("exact", "separable") for s in (0.0, 0.3, 1.0, 2.7)),
        *(("layers", s) for s in (0.0, 0.25, 1.0, 2.0)),  # levels of the ladder
    ],
)
def test_a_uniform_sigma_is_scipys_gaussian_filter(method, sigma):
    rng = np.random.default_rng(3)
    image = rng.uniform(0, 1, (13, 17))
    out = acuity.varying_blur(image, np.full(image.shape, sigma), method=method)
    expected = image if sigma == 0 else _normalised_gaussian(image, sigma)
    assert_allclose(out, expected, rtol=1e-12, atol=1e-14)


def test_layers_are_exact_where_sigma_is_a_level():
    rng = np.random.default_rng(4)
    image = rng.uniform(0, 1, (11, 12, 2))
    levels = acuity._levels(3.0, 4)
    sigma = rng.choice(levels, size=image.shape[:2])
    assert_allclose(
        acuity.varying_blur(image, sigma),
        acuity.varying_blur(image, sigma, method="exact"),
        rtol=1e-12,
        atol=1e-14,
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    image=arrays(
        float,
        st.tuples(st.integers(1, 14), st.integers(1, 14)),
        elements=st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0)),
    ),
    sigma_scale=st.floats(0.0, 5.0),
    per_octave=st.sampled_from([2, 4, 8]),
    seed=st.integers(0, 2**32 - 1),
)
def test_layers_keep_their_error_bound_at_borders_and_corners(
    image, sigma_scale, per_octave, seed
):
    sigma = sigma_scale * np.random.default_rng(seed).uniform(0, 1, image.shape)
    exact = acuity.varying_blur(image, sigma, method="exact")
    layers = acuity.varying_blur(image, sigma, levels_per_octave=per_octave)
    spread = image.max() - image.min()
    assert np.abs(layers - exact).max() <= acuity.layers_error_bound(per_octave) * spread + 1e-12


def test_separable_is_exact_for_one_sigma_and_not_at_an_edge():
    # Luidolt Fig. 5.9: the two 1-D passes differ from the 2-D filter where σ changes
    image = np.full((9, 9), 0.5)
    image[:4, :4] = 25.0
    sigma = np.where(image > 1, 0.3, 1.5)
    exact = acuity.varying_blur(image, sigma, method="exact")
    separable = acuity.varying_blur(image, sigma, method="separable")
    assert np.abs(separable - exact).max() > 0.1


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    image=arrays(
        float,
        st.tuples(st.integers(1, 9), st.integers(1, 9), st.just(3)),
        elements=st.one_of(st.just(0.0), st.just(1e9), st.floats(0.0, 1e9)),
    ),
    blur=st.sampled_from(acuity.BLUR_METHODS),
    space=st.sampled_from(["lightness", "linear"]),
    method=st.sampled_from(acuity.SIGMA_METHODS),
)
def test_no_nan_and_no_negative_light_from_0_to_1e9_cd_m2(image, blur, space, method):
    out = acuity.acuity_blur(image, pixel_deg=0.05, blur=blur, space=space, method=method)
    assert out.shape == image.shape and np.isfinite(out).all() and (out >= 0).all()


@pytest.mark.parametrize("space", ["lightness", "linear"])
def test_uniform_and_black_images_are_unchanged(space):
    for image in (np.zeros((6, 7, 3)), np.full((6, 7, 3), 0.01), np.zeros((1, 1))):
        out = acuity.acuity_blur(image, pixel_deg=0.03, space=space)
        assert_allclose(out, image, rtol=1e-9, atol=1e-15)


def test_dark_detail_blurs_and_bright_detail_does_not():
    # a grating of 0.2° bars: at 0.001 cd/m² (σ = 0.13°) it is washed out, at 100 cd/m² kept
    x = np.arange(64)
    grating = np.tile(((x // 4) % 2).astype(float), (16, 1)) * 0.5 + 0.5
    for level, contrast_kept in ((1e-3, False), (100.0, True)):
        out = acuity.acuity_blur(grating * level, pixel_deg=0.05, space="linear")
        row = out[8, 16:48]
        contrast = (row.max() - row.min()) / (row.max() + row.min())
        assert (contrast > 0.3) == contrast_kept, (level, contrast)


def test_the_scale_from_display_to_scene_sets_the_blur():
    # an image in display units shown at exposure 1000 is a scene 1000 times darker
    rng = np.random.default_rng(5)
    scene = rng.uniform(0.0, 0.01, (12, 12))
    direct = acuity.acuity_blur(scene, pixel_deg=0.05, space="linear")
    display = acuity.acuity_blur(
        scene * 1000, pixel_deg=0.05, space="linear", luminance_scale=1e-3
    )
    assert_allclose(display / 1000, direct, rtol=1e-12)


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: acuity.acuity_cpd(-1.0), "luminance_cd_m2"),
        (lambda: acuity.acuity_cpd(True), "luminance_cd_m2"),  # was 1 cd/m²
        (lambda: acuity.acuity_cpd("0.03"), "luminance_cd_m2"),  # was 0.03 cd/m²
        (lambda: acuity.luminance_for_acuity(60.0), "cpd"),
        (lambda: acuity.luminance_for_acuity(0.0), "cpd"),
        (lambda: acuity.blur_sigma_deg(1.0, method="Ferwerda1996"), "method"),
        (lambda: acuity.acuity_blur(np.ones((3, 3)), pixel_deg=0.0), "pixel_deg"),
        (lambda: acuity.acuity_blur(np.ones((3, 3)), pixel_deg=0.1, space="Lab"), "space"),
        (lambda: acuity.acuity_blur(np.ones((3, 3)), pixel_deg=0.1, white_cd_m2=0), "white_cd_m2"),
        (
            lambda: acuity.acuity_blur(np.ones((3, 3)), pixel_deg=0.1, blur="box"),
            "blur must be one of",
        ),
        (lambda: acuity.acuity_blur(np.full((3, 3), np.nan), pixel_deg=0.1), "image_cd_m2"),
        # each was taken and acted on nothing
        (
            lambda: acuity.acuity_blur(
                np.ones((3, 3)), pixel_deg=0.1, space="linear", white_cd_m2=50.0
            ),
            "white_cd_m2=50.0 with space='linear'",
        ),
        (
            lambda: acuity.acuity_blur(
                np.ones((3, 3)), pixel_deg=0.1, blur="exact", levels_per_octave=4
            ),
            "levels_per_octave=4 with blur='exact'",
        ),
        (lambda: acuity.varying_blur(np.ones((3, 3)), np.ones((3, 4))), "sigma_px"),
        (lambda: acuity.varying_blur(np.ones((3, 3)), -np.ones((3, 3))), "sigma_px"),
        (
            lambda: acuity.varying_blur(np.ones((3, 3)), np.ones((3, 3)), levels_per_octave=0),
            "levels_per_octave",
        ),
    ],
)
def test_bad_input_is_refused_by_name(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()


def test_the_layers_blur_at_chosen_pixels_equals_the_whole_images():
    # the live renderer blurs a few pixels directly: the same numbers as varying_blur
    rng = np.random.default_rng(5)
    image, sigma = rng.random((30, 40, 2)), rng.random((30, 40)) * 3.0
    sigma[0, 0], sigma[5, 5] = 0.0, 0.1  # kept, and between level 0 and the first level
    rows, cols = np.nonzero(rng.random((30, 40)) < 0.3)
    whole = acuity.varying_blur(image, sigma, levels_per_octave=16)
    chosen = acuity._layers_at(image, sigma[rows, cols], rows, cols, 16)
    np.testing.assert_allclose(chosen, whole[rows, cols], atol=1e-12)


@pytest.mark.parametrize(
    ("cpd", "shown"),
    [
        (True, "True"),  # was read as 1 cpd (3.96e-06 cd/m²)
        ("13.85", "'13.85'"),  # was read as 13.85
        (np.array([True]), "True"),
        (np.ma.masked_array([13.85, 20.0], [0, 1]), "masked array"),  # the mask was dropped
        ([13.85, "x"], "'x' at position 1"),
        (1 + 0j, r"\(1\+0j\)"),
    ],
)
def test_luminance_for_acuity_refuses_what_is_not_real_numbers(cpd, shown):
    with pytest.raises(ValueError, match=f"^cpd must .*{shown}"):
        acuity.luminance_for_acuity(cpd)


def test_luminance_for_acuity_of_valid_numbers_is_unchanged():
    assert acuity.luminance_for_acuity(13.85) == 0.14545650817873282
    assert acuity.luminance_for_acuity(np.array([13.85]))[0] == 0.14545650817873282


@settings(max_examples=200, deadline=None)
@given(cpd=st.floats(52.7, 52.83) | st.floats(1e-300, 60.0))
def test_luminance_for_acuity_is_finite_or_refused_up_to_the_asymptote(cpd):
    # eq. 5.14's luminance grows without bound towards 52.82 cycles/deg: within the last
    # 0.04 it was inf, with numpy's overflow warning only
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            y = acuity.luminance_for_acuity(cpd)
        except ValueError as error:
            assert str(error).startswith("cpd must be in (0, 52.776)")
            assert cpd >= 52.776
        else:
            assert np.isfinite(y) and y > 0
