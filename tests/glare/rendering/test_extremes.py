"""Numerical extremes: tiny and huge images, pixels and luminances, and the ends of every
range the models accept. Invariants: energy, symmetry, finiteness, and the planned render
within its tolerance of the exact one."""

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab import glare
from glarelab.glare import GaussianGlare, VosGlare, WaveOpticsGlare, render_planned
from glarelab.glare.models.vos import max_age_years
from glarelab.glare.rendering.display import DISPLAY_CONTRAST, Display, display_codes

L_DMAX = 220.0
LUT = Display.gamma(L_DMAX, black_cd_m2=L_DMAX / DISPLAY_CONTRAST).lut  # the planner's default


@st.composite
def scenes(draw):
    height = draw(st.integers(1, 12))
    width = draw(st.integers(1, 40))
    exponents = draw(
        st.lists(st.floats(-3.0, 9.0), min_size=height * width, max_size=height * width)
    )
    image = 10.0 ** np.array(exponents).reshape(height, width)
    image[image < 1e-2] = 0.0  # true black as well
    return image


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    image=scenes(),
    pixel_deg=st.floats(1e-4, 1.0),
    model=st.sampled_from([VosGlare(), GaussianGlare(sigma_deg=0.34, sampling="pixel")]),
)
def test_planned_render_is_finite_clamped_and_within_tolerance_at_any_scale(
    image, pixel_deg, model
):
    # luminance 0 to 1e9 cd/m², 1 × 1 to 12 × 40 images, pixels from 1e-4° to 1°
    planned = render_planned(image, model, pixel_deg=pixel_deg, l_dmax_cd_m2=L_DMAX)
    out = planned.image
    assert out.shape == image.shape and np.isfinite(out).all()
    assert (out >= np.minimum(image, L_DMAX) - 1e-9).all() and (out <= L_DMAX).all()
    exact = glare.render_glare(image, model, pixel_deg=pixel_deg, l_dmax_cd_m2=L_DMAX).image
    error = np.abs(display_codes(out, LUT) - display_codes(exact, LUT)).max()
    # the bound covers the plan; kernels of other sizes differ by their quadrature (~1e-7)
    assert error <= 0.5 and error <= planned.error_bound_codes + 0.01


@pytest.mark.parametrize("shape", [(1, 1), (1, 257), (257, 1)])
@pytest.mark.parametrize("pixel_deg", [1e-4, 0.01, 1.0])
def test_single_bright_pixel_conserves_energy_in_degenerate_shapes(shape, pixel_deg):
    image = np.zeros(shape)
    image[shape[0] // 2, shape[1] // 2] = 1e9
    result = glare.render_glare(
        image, VosGlare(), pixel_deg=pixel_deg, l_dmax_cd_m2=L_DMAX, composition="Spencer1995"
    )
    kept = result.spread.sum() + result.energy_outside_kernel + result.energy_outside_image
    assert_allclose(kept, result.excess_energy, rtol=1e-9)  # energy conservation


def test_every_pixel_bright():
    image = np.full((33, 47), 1e6)
    # Yoshida's clamp: every pixel at L_dmax, and nothing is convolved
    assert (glare.add_glare(image, VosGlare(), pixel_deg=0.05) == L_DMAX).all()
    spencer = glare.render_glare(image, VosGlare(), pixel_deg=0.05, composition="Spencer1995")
    kept = spencer.spread.sum() + spencer.energy_outside_kernel + spencer.energy_outside_image
    assert_allclose(kept, spencer.excess_energy, rtol=1e-9)
    # the middle pixel receives more than a corner, and everything stays finite
    assert spencer.image[16, 23] > spencer.image[0, 0] > L_DMAX
    assert np.isfinite(spencer.image).all()


def test_a_bright_sky_under_a_narrow_kernel_is_spread_directly():
    """80 % of a 300 × 256 sky over L_dmax, a Gaussian of 0.1° at 0.38°/px: the plan's
    direct path correlated the 3 × 3 kernel with the sky as ndimage's filter and raised
    MemoryError (ndimage's table of the filter's offsets); now within the tolerance."""
    rng = np.random.default_rng(0)
    image = np.where(rng.random((300, 256)) < 0.8, 300.0, 10.0)
    model = GaussianGlare(sigma_deg=0.1, sampling="pixel")
    planned = glare.GlareRenderer(model, pixel_deg=0.38, shape=image.shape).render(image)
    assert planned.plan.path == "direct"
    exact = glare.render_glare(image, model, pixel_deg=0.38, l_dmax_cd_m2=L_DMAX).image
    error = np.abs(display_codes(planned.image, LUT) - display_codes(exact, LUT)).max()
    assert error <= planned.error_bound_codes + 1e-6 and planned.error_bound_codes <= 0.5


@pytest.mark.parametrize(
    "model", [VosGlare(), VosGlare(regime="scotopic"), GaussianGlare(sigma_deg=0.2)]
)
def test_smooth_psfs_are_radially_symmetric(model):
    k = model.kernel(0.05, (41, 41)).values
    assert_allclose(k, k.T, rtol=1e-12)
    assert_allclose(k, k[::-1], rtol=1e-12)
    assert_allclose(k, k[:, ::-1], rtol=1e-12)
    # the same radius, 5 px, along an axis and at (3, 4): pixel integrals differ only by the
    # pixel's orientation to the gradient
    centre = 20
    assert_allclose(k[centre, centre + 5], k[centre + 3, centre + 4], rtol=0.05)


def test_f0_narrower_than_a_pixel_and_theta_zero():
    # at 1°/px the 0.02°-wide f0 lies inside the centre pixel: Spencer's delta function
    kernel = VosGlare().kernel(1.0, (5, 5))
    w0 = glare.vos.weights("photopic")[0]
    assert kernel.values[2, 2] > w0 and np.isfinite(kernel.values).all()
    assert_allclose(kernel.values.sum() + kernel.energy_outside, 1.0, rtol=1e-9)
    assert np.isfinite(glare.vos.psf(0.0)) and glare.vos.psf(0.0) > glare.vos.psf(1e-4)


@pytest.mark.parametrize("regime", ["photopic", "mesopic", "scotopic"])
def test_the_ends_of_the_age_range(regime):
    oldest = max_age_years(regime)
    for age in (0.0, 20.0, 70.0, np.nextafter(oldest, 0.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # outside 20-70 warns, tested in vos
            kernel = VosGlare(regime=regime, age=age).kernel(0.1, (21, 21))
        assert (kernel.values >= 0).all()
        assert_allclose(kernel.values.sum() + kernel.energy_outside, 1.0, rtol=1e-9)
    with pytest.raises(ValueError, match="age"):
        VosGlare(regime=regime, age=oldest)


@pytest.mark.parametrize("wavelength_nm", [380.0, 780.0])
def test_the_ends_of_the_wavelength_range(wavelength_nm):
    kernel = VosGlare(regime="mesopic", wavelength_nm=wavelength_nm).kernel(0.1, (161, 161))
    assert_allclose(kernel.values.sum() + kernel.energy_outside, 1.0, rtol=1e-9)
    with pytest.raises(ValueError, match="wavelength"):
        VosGlare(
            regime="mesopic", wavelength_nm=wavelength_nm + (1 if wavelength_nm > 500 else -1)
        )


@pytest.mark.parametrize("pupil_mm", [0.5, 2.999, 3.0, 10.0])
def test_the_ends_of_the_vos_pupil_range(pupil_mm):
    model = VosGlare(regime="scotopic", pupil_mm=pupil_mm)
    assert model.halo_skipped == (pupil_mm < 3.0)
    assert_allclose(sum(model.weights), 1.0, rtol=1e-12)
    kernel = model.kernel(0.1, (81, 81))
    assert_allclose(kernel.values.sum() + kernel.energy_outside, 1.0, rtol=1e-9)


@pytest.mark.parametrize("pupil_mm", [1.0, 8.0])
def test_the_ends_of_the_wave_optics_pupil_range(pupil_mm):
    model = WaveOpticsGlare(pupil_mm=pupil_mm, eyelashes=False, eyelid=False, particles=0)
    kernel = model.kernel(0.02, (61, 61))
    assert np.isfinite(kernel.values).all() and (kernel.values >= 0).all()
    assert 0.5 < kernel.values.sum() <= 1.0 + 1e-9
    # the Airy core widens as the pupil shrinks
    assert kernel.values[30, 30] < 0.9 or pupil_mm > 2


def test_float32_planned_render_next_to_the_sun_has_no_noise_in_the_dark():
    # Spencer Fig. 16's 7.5e8 cd/m² sun in an otherwise dark 0.01-1 cd/m² scene
    rng = np.random.default_rng(3)
    image = 10 ** rng.uniform(-2, 0, (256, 256))
    image[120:124, 120:124] = 7.5e8
    far = np.s_[:, :40]
    for method in ("Spencer1995", "Yoshida2008"):
        planned = render_planned(
            image,
            VosGlare(),
            pixel_deg=0.5,
            l_dmax_cd_m2=L_DMAX,
            composition=method,
            precision="float32",
        )
        exact = glare.render_glare(
            image, VosGlare(), pixel_deg=0.5, l_dmax_cd_m2=L_DMAX, composition=method
        ).image
        assert (planned.image >= 0).all()
        error = np.abs(display_codes(planned.image, LUT) - display_codes(exact, LUT))
        assert error[far].max() <= 0.5 and error.max() <= 0.5
