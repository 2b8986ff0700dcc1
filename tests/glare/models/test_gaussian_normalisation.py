"""The Gaussian of Yoshida eq. 2 normalised over the infinite plane: the same crop of one
Gaussian whatever the kernel's or the image's size, the light beyond booked as outside."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.glare import GaussianGlare, render_glare


@pytest.mark.parametrize("sigma_px", [0.7, 1.5, 2.0, 10.0, 28.8])
def test_infinite_kernel_total_is_the_analytic_integral(sigma_px):
    # ∫∫ exp(-r²/2σ²) / (2πσ²) over the square ±(h + ½) px: erf((h + ½) / (σ √2))²
    pixel_deg = 0.34 / sigma_px
    for half in (3, 20, 60):
        k = GaussianGlare(sampling="pixel").kernel(pixel_deg, (2 * half + 1, 2 * half + 1))
        inside = math.erf((half + 0.5) / (sigma_px * math.sqrt(2.0))) ** 2
        assert_allclose(k.values.sum(), inside, rtol=1e-12)
        assert_allclose(k.energy_outside, 1.0 - inside, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("sigma_px", [2.0, 10.0, 28.8])
def test_point_sampled_peak_is_one_over_two_pi_sigma_squared(sigma_px):
    # the lattice sum of exp(-i²/2σ²) is σ√(2π) to 1e-34 for σ >= 2 px (Poisson summation),
    # so the centre of the infinite kernel is 1 / (2πσ²) whatever the kernel's size
    pixel_deg = 0.34 / sigma_px
    for size in (5, 41, 301):
        k = GaussianGlare().kernel(pixel_deg, (size, size))
        assert_allclose(
            k.values[size // 2, size // 2], 1.0 / (2 * math.pi * sigma_px**2), rtol=1e-13
        )
        assert_allclose(k.values.sum() + k.energy_outside, 1.0, rtol=1e-13)


def test_narrow_point_sampled_kernel_is_normalised_by_the_direct_lattice_sum():
    # σ = 0.8 px: the lattice sum differs from σ√(2π) by 2 exp(-2π²σ²) ≈ 6e-6
    with pytest.warns(UserWarning):
        k = GaussianGlare(sigma_deg=0.016).kernel(0.02, (61, 61))
    assert_allclose(k.values.sum(), 1.0, rtol=1e-14)
    assert k.energy_outside < 1e-14


def test_small_kernel_is_the_large_kernels_centre():
    big = GaussianGlare().kernel(0.0118, (201, 201)).values
    small = GaussianGlare().kernel(0.0118, (21, 21)).values
    assert_allclose(small, big[90:111, 90:111], rtol=1e-14)


def test_yoshida2008_normalisation_is_the_sum_of_the_kernels_elements():
    k = GaussianGlare(normalisation="Yoshida2008").kernel(0.0118, (21, 21))
    assert_allclose(k.values.sum(), 1.0, rtol=1e-14)
    assert k.energy_outside == 0.0
    infinite = GaussianGlare().kernel(0.0118, (21, 21))
    assert_allclose(k.values, infinite.values / infinite.values.sum(), rtol=1e-14)


def _disk_glow(size_px: int, normalisation: str) -> np.ndarray:
    """The glow of a 0.3° disk at 0.0118°/px (Yoshida §3) along the row through its centre,
    at offsets 0 .. 15 px from its centre, on a (2H-1)² kernel."""
    pixel_deg = 0.0118
    c = size_px // 2
    y, x = np.indices((size_px, size_px)) - c
    image = np.where(np.hypot(x, y) * pixel_deg <= 0.15, 4000.0, 150.0)
    result = render_glare(
        image, GaussianGlare(normalisation=normalisation), pixel_deg=pixel_deg, cache=False
    )
    return result.spread[c, c : c + 16]


def test_same_disk_gets_the_same_glow_in_any_image_size():
    reference = _disk_glow(271, "infinite")
    for size in (33, 61, 101):
        assert_allclose(_disk_glow(size, "infinite"), reference, rtol=1e-9)
    # eq. 2 normalised over the (2H-1)² kernel: the 33² image's kernel puts its lost tail back
    literal = _disk_glow(33, "Yoshida2008")[-1] / _disk_glow(271, "Yoshida2008")[-1]
    assert 1.7 < literal < 1.9


def test_energy_beyond_the_image_is_booked_as_outside():
    pixel_deg = 0.0118
    image = np.full((33, 33), 150.0)
    image[16, 16] = 1e4
    result = render_glare(image, GaussianGlare(), pixel_deg=pixel_deg, cache=False)
    kernel = GaussianGlare().kernel(pixel_deg, (65, 65))
    assert_allclose(result.energy_outside_kernel, kernel.energy_outside * (1e4 - 220), rtol=1e-9)
    half = 32.5 * pixel_deg / (0.34 * math.sqrt(2.0))
    assert_allclose(kernel.energy_outside, 1.0 - math.erf(half) ** 2, rtol=2e-3)


def test_bad_normalisation_is_refused():
    with pytest.raises(ValueError, match="normalisation must be one of 'infinite', 'Yoshida2008'"):
        GaussianGlare(normalisation="sum")
