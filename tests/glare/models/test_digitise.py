import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import integrate

from glarelab.glare import VosGlare
from glarelab.glare.models import vos
from glarelab.glare.models.digitise import (
    digitise_radial,
    gaussian_pixel_energies,
    kernel_shape_for,
    mirror_quadrant,
)

SR_PER_DEG2 = (math.pi / 180) ** 2


def pixel_energy(profile, i, j, pixel_deg):
    """Energy of pixel (i, j) by scipy's adaptive dblquad: independent reference."""

    def integrand(y, x):
        theta = math.hypot(x, y)
        jac = math.sin(math.radians(theta)) / math.radians(theta) if theta > 0 else 1.0
        return float(profile(np.array(theta))) * jac

    value, _ = integrate.dblquad(
        integrand,
        (j - 0.5) * pixel_deg,
        (j + 0.5) * pixel_deg,
        (i - 0.5) * pixel_deg,
        (i + 0.5) * pixel_deg,
        epsrel=1e-9,
    )
    return value * SR_PER_DEG2


@pytest.mark.parametrize("pixel_deg", [0.006, 0.05, 0.5])
@pytest.mark.parametrize("offset", [(0, 1), (1, 1), (3, 2), (10, 7)])
def test_pixel_energies_match_adaptive_quadrature(pixel_deg, offset):
    values, _, _total, _ = digitise_radial([vos.f1], pixel_deg=pixel_deg, shape=(41, 41))
    i, j = offset
    expected = pixel_energy(vos.f1, i, j, pixel_deg)
    assert_allclose(values[0, 20 + i, 20 + j], expected, rtol=2e-4)


def test_centre_pixel_is_exact_even_for_coarse_pixels():
    # 1° pixels: f1's 0.02° peak is far narrower than a pixel
    values, _, _, _ = digitise_radial([vos.f1], pixel_deg=1.0, shape=(5, 5))
    assert_allclose(values[0, 2, 2], pixel_energy(vos.f1, 0, 0, 1.0), rtol=1e-6)


@pytest.mark.parametrize(
    ("width_deg", "pixel_deg"), [(0.0707, 0.02), (0.0707, 0.05), (1.0, 0.01), (127.0, 1e-5)]
)
def test_gaussian_pixel_energies_are_accurate_far_in_the_tail(width_deg, pixel_deg):
    # the energy of pixel i is ∫ exp(-(x/w)²)/(w √π) over it: scipy's quad, relative only,
    # down to 1e-250 (a difference of two erf near 1 left round-off of 1e-17 there)
    energies = gaussian_pixel_energies(width_deg, pixel_deg, 400)
    assert energies[0] > 0 and np.all(energies >= 0)
    offsets = [i for i in range(1, 401) if 1e-250 < energies[i] or i < 3]
    assert len(offsets) > 20
    # near the centre of a Gaussian 1e7 px wide, erfc are near 1: erf keeps the digits

    def density(x):
        return math.exp(-((x / width_deg) ** 2)) / (width_deg * math.sqrt(math.pi))

    for i in offsets:
        expected, _ = integrate.quad(
            density, (i - 0.5) * pixel_deg, (i + 0.5) * pixel_deg, epsabs=0.0, epsrel=1e-12
        )
        assert_allclose(energies[i], expected, rtol=1e-10, err_msg=f"pixel {i}")
    # past them the energy is below 1e-250, not round-off
    assert np.all(energies[offsets[-1] + 1 :] <= 1e-250)


@pytest.mark.parametrize("pixel_deg", [1e-4, 0.003, 0.0119, 0.1, 1.0, 5.0])
@pytest.mark.parametrize("regime", ["photopic", "mesopic", "scotopic"])
def test_kernel_sums_to_one_minus_reported_energy_outside(pixel_deg, regime):
    k = VosGlare(regime=regime).kernel(pixel_deg, (41, 41))
    assert np.isfinite(k.values).all() and (k.values >= 0).all()
    assert_allclose(k.values.sum() + k.energy_outside, 1.0, atol=1e-12)
    assert 0.0 <= k.energy_outside < 1.0
    assert abs(k.quadrature_error) < 1e-3


def test_reported_energy_outside_is_bracketed_by_discs():
    # outside the square [-h, h]²: less than outside the inscribed disc of radius h, more than
    # outside the circumscribed disc of radius h√2 (Spencer eq. 4 by scipy quad)
    pixel_deg, n = 0.05, 41
    h = (n // 2 + 0.5) * pixel_deg
    k = VosGlare().kernel(pixel_deg, (n, n))
    psf = lambda t: vos.psf(t, "photopic")  # noqa: E731

    def outside(radius):
        inside = integrate.quad(
            lambda t: psf(t) * math.sin(math.radians(t)), 0, radius, points=[0.02, 0.1], limit=200
        )[0]
        beyond = integrate.quad(lambda t: psf(t) * math.sin(math.radians(t)), radius, 90)[0]
        return beyond / (inside + beyond)

    assert outside(h * math.sqrt(2)) < k.energy_outside < outside(h)


def test_a_kernel_over_the_hemisphere_loses_nothing():
    k = VosGlare().kernel(5.0, (37, 37))  # ±92.5°
    assert k.energy_outside < 1e-9


def test_kernels_are_symmetric():
    k = VosGlare(regime="mesopic").kernel(0.02, (201, 201)).values
    assert np.array_equal(k, k[::-1, :]) and np.array_equal(k, k[:, ::-1])
    assert_allclose(k, k.T, rtol=1e-9, atol=0)


def test_rectangular_kernels_are_allowed():
    k = VosGlare().kernel(0.05, (21, 61))
    assert k.values.shape == (21, 61)
    assert_allclose(k.values.sum() + k.energy_outside, 1.0, atol=1e-12)


def test_more_samples_converge():
    coarse = VosGlare(samples_per_pixel=2, center_samples_per_pixel=10).kernel(0.02, (61, 61))
    fine = VosGlare(samples_per_pixel=20, center_samples_per_pixel=200).kernel(0.02, (61, 61))
    default = VosGlare().kernel(0.02, (61, 61))
    err_coarse = (np.abs(coarse.values - fine.values) / fine.values).max()
    err_default = (np.abs(default.values - fine.values) / fine.values).max()
    assert err_default < err_coarse / 10
    assert err_default < 2e-4  # per-pixel relative error of the default integration


def test_f0_becomes_a_delta_for_wide_pixels():
    # Spencer §3.1: f0 may be a delta when narrower than a pixel; 0.02° in a 1° pixel:
    # the centre pixel holds all of f0's weight (0.384) plus the scattering inside it
    k = VosGlare().kernel(1.0, (11, 11)).values
    f1_f2_centre = sum(
        w * pixel_energy(f, 0, 0, 1.0) / vos.volume(f)
        for w, f in ((0.478, vos.f1), (0.138, vos.f2))
    )
    assert_allclose(k[5, 5], 0.384 + f1_f2_centre, rtol=1e-6)


@pytest.mark.parametrize("shape", [(40, 41), (41, 0), (3,), "big"])
def test_even_or_malformed_shapes_are_rejected(shape):
    with pytest.raises(ValueError, match="shape must be two odd positive integers"):
        VosGlare().kernel(0.1, shape)


@pytest.mark.parametrize("pixel_deg", [0.0, -0.1, float("nan"), float("inf")])
def test_bad_pixel_size_is_rejected(pixel_deg):
    with pytest.raises(ValueError, match=r"pixel_deg must be in \[1e-05, 180\] deg"):
        VosGlare().kernel(pixel_deg, (11, 11))


def test_mirror_quadrant_and_default_shape():
    q = np.arange(6.0).reshape(2, 3)
    full = mirror_quadrant(q)
    assert full.shape == (3, 5) and full[1, 2] == 0 and full[0, 0] == q[1, 2]
    assert kernel_shape_for((1536, 2048)) == (3071, 4095)


@settings(max_examples=25, deadline=None)
@given(
    pixel_deg=st.floats(1e-3, 2.0),
    half=st.integers(1, 30),
    regime=st.sampled_from(["photopic", "mesopic", "scotopic"]),
)
def test_energy_account_holds_for_any_geometry(pixel_deg, half, regime):
    k = VosGlare(regime=regime).kernel(pixel_deg, (2 * half + 1, 2 * half + 1))
    assert (k.values >= 0).all()
    assert_allclose(k.values.sum() + k.energy_outside, 1.0, atol=1e-12)


def test_a_kernel_made_from_its_quadrant_behaves_as_the_full_kernel():
    import pickle

    from glarelab.glare.models.digitise import Kernel

    quadrant = np.random.default_rng(0).random((4, 6, 3))
    half = Kernel(quadrant=quadrant, pixel_deg=0.1, energy_outside=np.full(3, 0.01))
    whole = Kernel(mirror_quadrant(quadrant), 0.1, np.full(3, 0.01))
    assert half.shape == whole.shape == (7, 11, 3) and half.center == (3, 5)
    assert half._values is None  # nothing unfolded for shape, centre, peak and sum
    assert half.peak == whole.peak
    assert_allclose(half.total(), whole.total(), rtol=1e-14, atol=0)
    assert half._values is None
    np.testing.assert_array_equal(half.values, whole.values)
    one = half.replace(quadrant=quadrant[..., 0])
    assert one.shape == (7, 11) and one.pixel_deg == 0.1
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(half)).values, whole.values)
    with pytest.raises(AttributeError, match="not changed"):
        half.pixel_deg = 0.2
    with pytest.raises(ValueError, match="exactly one of values and quadrant"):
        Kernel(whole.values, 0.1, quadrant=quadrant)
    with pytest.raises(ValueError, match="exactly one of values and quadrant"):
        Kernel(pixel_deg=0.1)
