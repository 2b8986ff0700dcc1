"""Digitising by symmetry (glarelab.glare.models.digitise._quadrature_symmetric) against the exact
digitisation that evaluates every pixel (symmetric=False), for every radially symmetric model
and regime at several pixel sizes: per pixel and in display codes."""

import numpy as np
import pytest

from glarelab import glare
from glarelab.glare.models import vos
from glarelab.glare.models.digitise import digitise_radial, mirror_quadrant, quadrant_sum
from glarelab.glare.rendering.display import display_codes, display_lut

PIXELS_DEG = (0.003, 0.02, 0.1, 1.0)  # a fine fovea, the night scenes, a coarse far-tail grid
SYMMETRIC_MODELS = {
    "photopic": glare.VosGlare(),
    "mesopic": glare.VosGlare(regime="mesopic"),
    "scotopic": glare.VosGlare(regime="scotopic"),
    "old-eye": glare.VosGlare(age=70.0),
    "small-pupil": glare.VosGlare(regime="mesopic", pupil_mm=2.5),  # halo dropped
    "monochromatic": glare.VosGlare(regime="scotopic", wavelength_nm=520.0),
}
PER_PIXEL = 1e-6  # relative, largest over the kernel's pixels (measured: 1.6e-7)


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    significant = b > 1e-12 * b.max()
    assert np.all(np.abs(a - b)[~significant] <= 1e-12 * b.max())
    return float(np.max(np.abs(a - b)[significant] / b[significant]))


@pytest.mark.parametrize("pixel_deg", PIXELS_DEG)
@pytest.mark.parametrize("name", list(SYMMETRIC_MODELS))
def test_symmetric_digitisation_matches_the_exact_one(name, pixel_deg):
    model = SYMMETRIC_MODELS[name]
    shape = (161, 121) if pixel_deg < 1 else (61, 61)
    colour = name in ("mesopic", "scotopic")
    fast = model._kernel(pixel_deg, shape, colour=colour)
    exact = model._kernel(pixel_deg, shape, colour=colour, symmetric=False)
    assert fast.values.shape == exact.values.shape
    assert _relative(fast.values, exact.values) < PER_PIXEL
    np.testing.assert_allclose(fast.energy_outside, exact.energy_outside, rtol=1e-12, atol=0)
    np.testing.assert_allclose(fast.quadrature_error, exact.quadrature_error, rtol=1e-2)
    np.testing.assert_allclose(fast.values.sum(axis=(0, 1)), exact.values.sum(axis=(0, 1)),
                               rtol=1e-12)  # fmt: skip
    assert model.kernel(pixel_deg, shape, colour=colour).values.tobytes() == (
        fast.values.tobytes()
    )


def test_the_night_kernel_is_within_a_thousandth_of_a_code():
    """A sun-bright glint and a lamp on a dark street (the bench's night scene, small): the
    render with the symmetric kernel against the one with the exact kernel, in codes of the
    default 10-bit display."""
    model = glare.VosGlare()
    shape, pixel = (301, 301), 0.02
    image = np.full((151, 151), 0.05)
    image[40:42, 90:92] = 7.5e8
    image[120:123, 20:23] = 1e4
    lut = display_lut(None, 220.0)
    codes = []
    for symmetric in (True, False):
        kernel = model._kernel(pixel, shape, colour=False, symmetric=symmetric)
        out = glare.render_glare(image, model, pixel_deg=pixel, kernel=kernel, cache=False)
        codes.append(display_codes(out.image, lut))
    assert float(np.max(np.abs(codes[0] - codes[1]))) < 1e-3


@pytest.mark.parametrize("pixel_deg", PIXELS_DEG)
def test_components_and_halo_with_a_support(pixel_deg):
    """f1, f2 over the hemisphere, and the ring f3 within its support. The ring's Gaussian
    flanks fall by up to e^-47 per degree at 4°: on the 1/64-px table a flank is interpolated
    to 7e-4 of its own value where that is 1e-12 of the peak (0.1° pixels); every pixel is
    within 1e-8 of the peak, and the ring above 1e-3 of its peak within 1e-5."""
    shape = (201, 141) if pixel_deg < 0.5 else (185, 185)  # 1°: reaches past 90°
    options = {"pixel_deg": pixel_deg, "shape": shape}
    fast = digitise_radial([vos.f1, vos.f2], **options)
    exact = digitise_radial([vos.f1, vos.f2], **options, symmetric=False)
    for a, b in zip(fast[0], exact[0], strict=True):
        assert _relative(a, b) < PER_PIXEL
    np.testing.assert_allclose(fast[1], exact[1], rtol=1e-14)
    ring = {"support_deg": 8.0, "breakpoints": (2.0, 3.0, 4.0)}
    (a,), inside, _, _ = digitise_radial([vos.f3], **options, **ring)
    (b,), inside_exact, _, _ = digitise_radial([vos.f3], **options, **ring, symmetric=False)
    peak = vos.f3(3.0) * np.radians(pixel_deg) ** 2
    assert np.max(np.abs(a - b)) < 1e-8 * peak
    visible = b > 1e-3 * peak
    if visible.any():
        assert np.max(np.abs(a - b)[visible] / b[visible]) < 1e-5
    np.testing.assert_allclose(inside, inside_exact, rtol=1e-14)


def test_the_gaussian_kernel_is_its_normalised_outer_product():
    for sampling in ("point", "pixel"):
        model = glare.GaussianGlare(
            sigma_deg=0.1, sampling=sampling, normalisation="Yoshida2008"
        )  # normalised over the kernel: the outer product over its own sum
        values = model.kernel(0.02, (61, 81)).values
        offsets = [np.arange(-(n // 2), n // 2 + 1) * 0.02 for n in (61, 81)]
        if sampling == "point":
            rows, cols = (np.exp(-(o**2) / (2 * 0.1**2)) for o in offsets)
        else:  # Φ(hi/σ) - Φ(lo/σ) taken on the upper tail, where it keeps its digits
            rows, cols = (
                np.where(
                    o == 0,
                    1.0 - 2.0 * _ndtr(-0.01 / 0.1),
                    _ndtr(-(np.abs(o) - 0.01) / 0.1) - _ndtr(-(np.abs(o) + 0.01) / 0.1),
                )
                for o in offsets
            )
        expected = np.outer(rows, cols)
        np.testing.assert_allclose(values, expected / expected.sum(), rtol=1e-12, atol=0)


def _ndtr(x):
    from scipy.special import ndtr

    return ndtr(x)


def test_mirror_and_sum_of_a_quadrant_with_channels():
    rng = np.random.default_rng(2)
    quadrant = rng.random((4, 6, 3))
    full = mirror_quadrant(quadrant)
    assert full.shape == (7, 11, 3)
    np.testing.assert_array_equal(full, full[::-1])
    np.testing.assert_array_equal(full, full[:, ::-1])
    np.testing.assert_array_equal(full[3:, 5:], quadrant)
    np.testing.assert_allclose(quadrant_sum(quadrant), full.sum(axis=(0, 1)), rtol=1e-14)
    single = mirror_quadrant(np.ones((1, 1)))
    assert single.shape == (1, 1)
