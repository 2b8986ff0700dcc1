"""Night colours: Spencer 1995 §5 (HSV saturation less 70 %) and Luidolt 2020 eq. 5.18 (a blend
towards a tinted rod image), with the rod response from V′(λ) through colour-science."""

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numpy.testing import assert_allclose

from glarelab.glare.night import scotopic

REC709 = "ITU-R BT.709"
Y_ROW = np.asarray(colour.RGB_COLOURSPACES[REC709].matrix_RGB_to_XYZ[1])
D65_XY = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]

# Linear RGB from 0 to 1e9 cd/m², the suite's range; subnormal floats (below 2.2e-308) are
# not luminances, and HSV's saturation of (0, 5e-324, 5e-324) underflows to 0 when scaled.
pixels = arrays(
    float,
    st.tuples(st.integers(1, 6), st.just(3)),
    elements=st.one_of(st.just(0.0), st.just(1e9), st.floats(0.0, 1e9, allow_subnormal=False)),
)


# --- the rod response from V′(λ) ---------------------------------------------------------


def test_scotopic_luminance_of_a_spectrum_agrees_with_colour_luminous_flux():
    d65 = colour.SDS_ILLUMINANTS["D65"]
    ours = scotopic.luminance_from_spectra(d65.values, d65.wavelengths)
    theirs = colour.luminous_flux(
        d65,
        colour.colorimetry.SDS_LEFS_SCOTOPIC[scotopic.SCOTOPIC_OBSERVER],
        colour.constants.CONSTANT_KP_M,
    )
    assert_allclose(ours, theirs, rtol=1e-3)  # V′ interpolated linearly vs colour's reshape


def test_photopic_and_scotopic_units_agree_at_555_nm():
    # 1700 lm/W × V′(555 nm) = 1700 × 0.402 = 683.4 lm/W ≈ K_m = 683 lm/W: the two luminances
    # of monochromatic 555 nm light are equal to 0.06 %
    w = np.array([554.0, 555.0, 556.0])
    line = np.array([0.0, 1.0, 0.0])
    ratio = scotopic.luminance_from_spectra(line, w) / scotopic.luminance_from_spectra(
        line, w, vision="photopic"
    )
    assert_allclose(ratio, 1700 * 0.402 / 683, rtol=1e-9)


def test_d65_s_over_p_ratio():
    # the S/P ratio of D65 is 2.47 (CIE 1951 V′ and CIE 1924 V, 5 nm steps)
    assert scotopic.scotopic_to_photopic_ratio() == pytest.approx(2.465, abs=0.005)


def test_the_basis_reproduces_rec_709_photopic_luminance():
    # the check that the primaries' spectra are right: their photopic luminances, weighted by
    # V(λ), are the Rec. 709 luminance row
    from colour.recovery import MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019 as basis

    d65 = colour.SDS_ILLUMINANTS["D65"][basis.wavelengths]
    primaries = (basis.values * d65[:, None]).T
    photopic = scotopic.luminance_from_spectra(primaries, basis.wavelengths, vision="photopic")
    assert_allclose(photopic / photopic.sum(), Y_ROW, atol=2e-4)


def test_rod_weights_keep_grey_and_shift_towards_blue():
    weights = scotopic.rod_weights(REC709)
    assert_allclose(weights.sum(), 1.0, atol=2e-4)  # a D65 grey: L' = Y (the reference white)
    red, green, blue = weights / Y_ROW
    assert red < 0.1 and blue > 5.0  # Purkinje: red nearly black, blue brighter at night
    assert 0.75 < green < 0.9


def test_rod_weights_of_another_colourspace_agree_on_its_own_white():
    # P3-D65 shares the white: its (1, 1, 1) is D65 and keeps its luminance
    assert_allclose(scotopic.rod_luminance(np.ones(3), colourspace="P3-D65"), 1.0, atol=1e-3)


# --- Spencer 1995: HSV saturation less 70 % -------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(rgb=pixels)
def test_spencer_removes_70_percent_of_the_hsv_saturation_and_keeps_hue_and_value(rgb):
    before = colour.RGB_to_HSV(rgb)
    out = scotopic.desaturate_Spencer1995(rgb)
    after = colour.RGB_to_HSV(out)
    assert np.isfinite(out).all() and (out >= 0).all()
    assert_allclose(after[:, 1], 0.3 * before[:, 1], atol=1e-9)
    assert_allclose(after[:, 2], before[:, 2], rtol=1e-12)
    coloured = before[:, 1] > 1e-6
    turn = (after[coloured, 0] - before[coloured, 0] + 0.5) % 1.0 - 0.5  # hue is circular: 1 ≡ 0
    assert_allclose(turn, 0.0, atol=1e-9)


def test_spencer_on_a_pure_red():
    # S = 1 → 0.3: the other channels rise to 70 % of the value
    assert_allclose(scotopic.desaturate_Spencer1995(np.array([2.0, 0.0, 0.0])), [2.0, 1.4, 1.4])


def test_spencer_at_the_ends_of_its_range():
    rgb = np.array([[0.8, 0.1, 0.3]])
    assert_allclose(scotopic.desaturate_Spencer1995(rgb, desaturation=0.0), rgb)
    assert_allclose(scotopic.desaturate_Spencer1995(rgb, desaturation=1.0), [[0.8, 0.8, 0.8]])


# --- Luidolt 2020 eq. 5.18 -------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(rgb=pixels)
def test_where_the_rods_are_blind_the_colour_is_the_original(rgb):
    # σ(L) → 0 in daylight: at 1e9 cd/m², σ = 4e-11 of the rod image is mixed in
    out = scotopic.scotopic_shift_Luidolt2020(rgb, 1e9)
    assert_allclose(out, rgb, rtol=1e-9, atol=1e-10 * rgb.max())


def test_with_sigma_zero_exactly_nothing_changes(monkeypatch):
    monkeypatch.setattr(scotopic, "rod_sensitivity", lambda luminance: 0.0)
    rgb = np.array([[0.3, 0.6, 0.1], [5.0, 0.0, 2.0]])
    np.testing.assert_array_equal(scotopic.scotopic_shift_Luidolt2020(rgb, 0.5), rgb)


@pytest.mark.parametrize("level", [0.0, 1e-6, 0.2, 1.0, 1e9])
def test_at_sigma_one_a_grey_keeps_its_luminance_and_turns_lavender(level):
    # σ(0) = 1: the output is the tint times the rod response; of a D65 grey (the reference
    # white) the rod response is its luminance, so Y is kept and the chromaticity is the tint's
    grey = np.full(3, level)
    out = scotopic.scotopic_shift_Luidolt2020(grey, 0.0)
    assert_allclose(out @ Y_ROW, level, rtol=3e-4)
    if level > 0:
        xy = colour.XYZ_to_xy(colour.RGB_to_XYZ(out, REC709))
        tint_xy = colour.XYZ_to_xy(colour.RGB_to_XYZ(np.array(scotopic.TINT_LUIDOLT2020), REC709))
        assert_allclose(xy, tint_xy, atol=1e-6)
        assert xy[0] < D65_XY[0] and xy[1] < D65_XY[1]  # bluer than the white
        assert out[2] > out[0] > out[1]  # Luidolt's "lavender purple": blue, then red


def test_the_printed_tint_is_nearly_luminance_neutral():
    # [1.05, 0.97, 1.27] has Rec. 709 luminance 1.0087: we divide it out (a 0.9 % brightening)
    assert_allclose(np.array(scotopic.TINT_LUIDOLT2020) @ Y_ROW, 1.0087, atol=1e-4)


def test_photopic_rod_response_is_luidolts_printed_blend():
    # with L' the pixel's luminance, eq. 5.18 as printed (tint normalised)
    rgb = np.array([0.4, 0.1, 0.05])
    sigma = 0.04 / (0.04 + 0.1)
    tint = np.array(scotopic.TINT_LUIDOLT2020) / (np.array(scotopic.TINT_LUIDOLT2020) @ Y_ROW)
    expected = rgb * (1 - sigma) + tint * (rgb @ (Y_ROW / Y_ROW.sum())) * sigma
    assert_allclose(
        scotopic.scotopic_shift_Luidolt2020(rgb, 0.1, rod="photopic"), expected, rtol=1e-12
    )


def test_at_night_red_darkens_and_blue_brightens():
    red, blue = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    night_red = scotopic.scotopic_shift_Luidolt2020(red, 0.0) @ Y_ROW
    night_blue = scotopic.scotopic_shift_Luidolt2020(blue, 0.0) @ Y_ROW
    assert night_red < 0.1 * (red @ Y_ROW)
    assert night_blue > 5.0 * (blue @ Y_ROW)


@settings(max_examples=100, deadline=None)
@given(
    rgb=pixels,
    adaptation=st.one_of(st.just(0.0), st.just(1e9), st.floats(0.0, 1e9)),
    method=st.sampled_from(scotopic.METHODS),
)
def test_no_nan_and_no_negative_light_at_any_luminance(rgb, adaptation, method):
    level = adaptation if method == "Luidolt2020" else None  # Spencer's is level-free
    out = scotopic.scotopic_colour(rgb, method=method, adaptation_luminance_cd_m2=level)
    assert out.shape == rgb.shape and np.isfinite(out).all() and (out >= 0).all()


def test_a_luminance_per_pixel_broadcasts():
    rgb = np.ones((2, 3, 3))
    adapted = np.array([[0.0, 0.04, 1e9], [1.0, 1.0, 1.0]])
    out = scotopic.scotopic_shift_Luidolt2020(rgb, adapted)
    assert out.shape == rgb.shape
    assert_allclose(out[0, 2], 1.0, rtol=1e-9)


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: scotopic.scotopic_colour(np.ones(3), method="Krawczyk"), "method"),
        (lambda: scotopic.scotopic_colour(np.ones(3)), "adaptation_luminance_cd_m2"),
        (
            lambda: scotopic.scotopic_colour(
                np.ones(3), method="Spencer1995", adaptation_luminance_cd_m2=0.01
            ),
            "adaptation_luminance_cd_m2=0.01 with method 'Spencer1995'",
        ),
        (lambda: scotopic.desaturate_Spencer1995(np.ones(3), desaturation=1.5), "desaturation"),
        (lambda: scotopic.desaturate_Spencer1995(np.ones(2)), "rgb"),
        (lambda: scotopic.desaturate_Spencer1995(-np.ones(3)), "rgb"),
        (lambda: scotopic.scotopic_shift_Luidolt2020(np.ones(3), -1.0), "luminance_cd_m2"),
        (lambda: scotopic.scotopic_shift_Luidolt2020(np.ones(3), 1.0, tint=(1, 0, 1)), "tint"),
        (lambda: scotopic.scotopic_shift_Luidolt2020(np.ones(3), 1.0, rod="cones"), "rod"),
        (
            lambda: scotopic.scotopic_shift_Luidolt2020(np.ones((2, 2, 3)), np.ones(3)),
            "broadcast",
        ),
        (lambda: scotopic.rod_weights("no such space"), "colourspace"),
        (
            lambda: scotopic.luminance_from_spectra(np.ones(3), np.array([3.0, 2.0, 1.0])),
            "wavelengths_nm",
        ),
        (
            lambda: scotopic.luminance_from_spectra(np.ones(2), np.array([1.0, 2.0, 3.0])),
            "radiance",
        ),
        (lambda: scotopic.luminance_from_spectra(-np.ones(2), np.array([1.0, 2.0])), "radiance"),
    ],
)
def test_bad_input_is_refused_by_name(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()


@pytest.mark.parametrize(
    ("rgb", "shown"),
    [
        (["1", "0", "0.5"], "'1' at position 0"),
        ([True, False, True], "True at position 0"),
        (np.array([1 + 0j, 0, 0]), r"\(1\+0j\)"),
        (np.ma.masked_array([1.0, 0.2, 0.5], [0, 1, 0]), "masked array"),  # was [1, 0.76, 0.85]
        ("abc", "'abc'"),
    ],
)
def test_desaturate_refuses_rgb_that_is_not_real_numbers(rgb, shown):
    with pytest.raises(ValueError, match=f"^rgb must .*{shown}"):
        scotopic.desaturate_Spencer1995(rgb)


@pytest.mark.parametrize(
    ("tint", "shown"),
    [
        ((True, True, True), "True at position 0"),
        (("1", "1", "1"), "'1' at position 0"),
        (np.ma.masked_array([1.0, 1.0, 1.0], [0, 1, 0]), "masked array"),
        ("abc", "'abc'"),
    ],
)
def test_the_scotopic_shift_refuses_a_tint_that_is_not_real_numbers(tint, shown):
    with pytest.raises(ValueError, match=f"^tint must .*{shown}"):
        scotopic.scotopic_shift_Luidolt2020(np.full(3, 0.2), 0.0, tint=tint)


def test_the_scotopic_shift_refuses_a_masked_rgb():
    with pytest.raises(ValueError, match=r"^rgb must be a plain array, not a masked array"):
        scotopic.scotopic_shift_Luidolt2020(np.ma.masked_array(np.full(3, 0.2), [0, 1, 0]), 0.0)


def test_the_night_colours_of_valid_rgb_are_unchanged():
    assert scotopic.desaturate_Spencer1995(np.array([1.0, 0.0, 0.5])).tolist() == [1.0, 0.7, 0.85]
    shifted = scotopic.scotopic_shift_Luidolt2020(np.full(3, 0.2), 0.0)
    assert_allclose(shifted, [0.20821284, 0.192349, 0.25183838], rtol=0, atol=5e-9)


@pytest.mark.parametrize("adapted", [-1.0, float("nan"), "0.1", True])
def test_a_bad_adaptation_luminance_is_named_as_given(adapted):
    # the messages named luminance_cd_m2, rod_sensitivity's argument
    with pytest.raises(ValueError, match=r"^adaptation_luminance_cd_m2 must"):
        scotopic.scotopic_colour(np.array([0.2, 0.2, 0.2]), adaptation_luminance_cd_m2=adapted)
