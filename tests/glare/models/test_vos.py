import itertools
import math
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import integrate

from glarelab.glare.models import vos


def eq4_volume(profile, upper=90.0):
    """Spencer eq. 4 with scipy's adaptive quad, independent of glarelab.glare.models._radial."""
    edges = [0.0, 0.005, 0.02, 0.1, 0.5, 1.0, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 10.0, 30.0, upper]
    edges = [e for e in edges if e < upper] + [upper]
    total = sum(
        integrate.quad(lambda t: profile(t) * math.sin(math.radians(t)), a, b, limit=200)[0]
        for a, b in itertools.pairwise(edges)
    )
    return math.pi**2 / 90 * total


def test_printed_values_of_spencer_3_1_1():
    # Spencer 1995 §3.1.1: "P_p(3°) = 1.462 and f3(3°, 568) = 436.9"
    assert_allclose(vos.psf(3.0, "photopic"), 1.462, rtol=5e-3)
    assert_allclose(vos.f3(3.0, 568.0), 436.9, rtol=1e-12)


def test_halo_coefficient_reasoning_of_spencer_3_1_1():
    # Spencer §3.1.1: 10 × P_p(3°) / f3(3°, 568) = 0.033, halved to 0.016 for P_m
    ratio = 10 * vos.psf(3.0) / vos.f3(3.0, 568.0)
    assert_allclose(ratio, vos.WEIGHTS["scotopic"][3], rtol=0.02)
    assert_allclose(ratio / 2, vos.WEIGHTS["mesopic"][3], rtol=0.05)


@pytest.mark.parametrize("component", [vos.f0, vos.f1, vos.f2])
def test_components_have_unit_volume(component):
    # Spencer eq. 4; tolerance from the issue: 1 %
    assert_allclose(eq4_volume(component), 1.0, rtol=0.01)


@pytest.mark.parametrize("wavelength", [380.0, 400.0, 500.0, 568.0, 650.0, 700.0, 780.0])
def test_halo_has_unit_volume_at_every_wavelength(wavelength):
    # the docs' "within 0.04 % of 1" (README: where we depart), not 1.0000 as they said
    assert_allclose(eq4_volume(lambda t: vos.f3(t, wavelength)), 1.0, rtol=4e-4)


@pytest.mark.parametrize("regime", vos.REGIMES)
@pytest.mark.parametrize("age", [None, 20.0, 45.0, 70.0])
def test_psfs_have_unit_volume(regime, age):
    # Spencer eqs. 5, 8, 9, 10: weighted averages of unit-volume components
    assert_allclose(eq4_volume(lambda t: vos.psf(t, regime, 568.0, age)), 1.0, rtol=0.01)
    assert_allclose(sum(vos.weights(regime, age)), 1.0, rtol=1e-12)


def test_printed_equation_7_without_19_75_is_not_a_psf():
    # As printed, exp(-(θ - θ0)²): volume √19.75 = 4.44 (hand calculation), so the factor
    # of eq. 6 is needed; with it the volume is 1 (tested above).
    printed = lambda t: 436.9 * math.exp(-((t - 3.0) ** 2))  # noqa: E731
    assert_allclose(eq4_volume(printed), math.sqrt(19.75), rtol=1e-3)


def test_halo_radius_and_width_match_the_text():
    # Spencer §3.1.1: radius 3° and width "approximately 0.35°" at 568 nm
    theta = np.linspace(2.0, 4.0, 200_001)
    ring = vos.f3(theta, 568.0)
    assert theta[np.argmax(ring)] == pytest.approx(3.0, abs=1e-5)
    above = theta[ring >= ring.max() / 2]
    fwhm = above[-1] - above[0]
    assert_allclose(fwhm, 2 * math.sqrt(math.log(2) / 19.75), atol=2e-5)  # 0.375°
    assert abs(fwhm - 0.35) / 0.35 < 0.08


def test_halo_radius_grows_with_wavelength():
    # Spencer §3.1.1: θ0(λ) = 3 λ / 568
    theta = np.linspace(0.0, 6.0, 60_001)
    for wavelength in (400.0, 700.0):
        peak = theta[np.argmax(vos.f3(theta, wavelength))]
        assert peak == pytest.approx(3.0 * wavelength / 568.0, abs=2e-4)


def fraction_beyond(weights, angle_deg=0.05):
    w0, w1, w2, _ = weights
    return sum(
        w * (1 - eq4_volume(f, angle_deg) / eq4_volume(f))
        for w, f in ((w0, vos.f0), (w1, vos.f1), (w2, vos.f2))
    )


def test_age_relation_reproduces_the_fractions_stated_in_3_1_2():
    # Spencer §3.1.2: eq. 10 "implies that the fraction of light scattered more than 0.05°
    # increases from 0.36 at age 20 to 0.45 at age 60"
    assert_allclose(fraction_beyond(vos.weights("photopic", 20)), 0.36, atol=0.005)
    assert_allclose(fraction_beyond(vos.weights("photopic", 60)), 0.45, atol=0.006)


def test_age_moves_weight_from_f0_to_f2_only():
    young, old = vos.weights("mesopic", 20), vos.weights("mesopic", 70)
    shift = 6.9e-9 * (70**4 - 20**4)  # Spencer eq. 10
    assert_allclose(young[0] - old[0], shift, rtol=1e-12)
    assert_allclose(old[2] - young[2], shift, rtol=1e-12)
    assert young[1] == old[1] and young[3] == old[3]


def test_age_range_limits():
    # f0's weight reaches zero at (0.384 / 6.9e-9)^¼ = 86.4 years (photopic), 80.0 (scotopic)
    assert_allclose(vos.max_age_years("photopic"), (0.384 / 6.9e-9) ** 0.25, rtol=1e-12)
    for regime in vos.REGIMES:
        with pytest.raises(ValueError, match=r"age must be in \[0, .*\) years"):
            vos.weights(regime, vos.max_age_years(regime))
        with pytest.raises(ValueError, match="age"):
            vos.psf(1.0, regime, 568.0, -1.0)
    with pytest.raises(ValueError, match=r"got 81\.0"):
        vos.weights("scotopic", 81.0)


def test_ages_outside_the_stated_span_warn_but_compute():
    with pytest.warns(UserWarning, match="outside 20-70 years"):
        w = vos.weights("photopic", 80.0)
    assert w[0] > 0
    with pytest.warns(UserWarning, match="outside 20-70 years"):
        vos.weights("photopic", 12.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vos.weights("photopic", 45.0)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: vos.f1(-0.1), r"theta_deg must be finite and >= 0 degrees, got -0.1"),
        (lambda: vos.f2(np.array([0.1, np.nan])), "theta_deg"),
        (lambda: vos.f0(np.inf), "theta_deg"),
        (lambda: vos.f3(1.0, 379.0), r"wavelength_nm must be in \[380, 780\] nm, got 379.0"),
        (lambda: vos.f3(1.0, 781.0), "wavelength_nm"),
        (lambda: vos.psf(1.0, "dusk"), "regime must be one of 'photopic', 'mesopic', 'scotopic'"),
        (lambda: vos.psf(1.0, "mesopic", 900.0), "wavelength_nm"),
    ],
)
def test_bad_input_is_named(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_scalar_in_scalar_out_and_arrays_broadcast():
    assert isinstance(vos.f1(0.5), float)
    assert isinstance(vos.psf(0.5, "scotopic"), float)
    values = vos.f3(np.array([[2.0], [3.0]]), np.array([500.0, 600.0]))
    assert values.shape == (2, 2)


@given(
    theta=st.floats(0.0, 90.0),
    regime=st.sampled_from(vos.REGIMES),
    wavelength=st.floats(380.0, 780.0),
    age=st.one_of(st.none(), st.floats(20.0, 70.0)),
)
def test_psf_is_a_finite_non_negative_density(theta, regime, wavelength, age):
    if regime == "photopic":  # no halo: a wavelength would be ignored, and is refused
        wavelength = vos.HALO_REFERENCE_NM
    value = vos.psf(theta, regime, wavelength, age)
    assert math.isfinite(value) and value >= 0


@given(st.floats(0.0, 89.0), st.floats(0.001, 1.0))
def test_scattering_terms_fall_with_angle(theta, step):
    assert vos.f1(theta + step) < vos.f1(theta)
    assert vos.f2(theta + step) < vos.f2(theta)


def test_volume_helper_agrees_with_scipy_quad():
    for profile in (vos.f0, vos.f1, vos.f2, lambda t: vos.psf(t, "scotopic", 450.0)):
        assert_allclose(vos.volume(profile), eq4_volume(profile), rtol=1e-6)
    assert_allclose(vos.volume(vos.f2, upper_deg=5.0), eq4_volume(vos.f2, 5.0), rtol=1e-6)


@pytest.mark.parametrize("function", ["f0", "f1", "f2", "psf"])
def test_a_masked_array_is_refused_not_its_mask_dropped(function):
    """f1(masked_array([0.5, 0.1], mask=[0, 1])) computed the masked entry and dropped the mask."""
    theta = np.ma.masked_array([0.5, 0.1], mask=[0, 1])
    with pytest.raises(ValueError, match=r"^theta_deg must be a plain array, not a masked"):
        getattr(vos, function)(theta)


def test_a_wavelength_for_the_photopic_psf_is_refused_as_ignored():
    """psf(θ, 'photopic', wavelength_nm=450) returned the photopic PSF without a word."""
    with pytest.raises(ValueError, match=r"^wavelength_nm=450: it shapes only the halo"):
        vos.psf(3.0, "photopic", wavelength_nm=450)
    assert vos.psf(3.0, "photopic") == vos.psf(3.0, "photopic", wavelength_nm=568.0)
    assert vos.psf(3.0, "mesopic", wavelength_nm=450) != vos.psf(3.0, "mesopic")
