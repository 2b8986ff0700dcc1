"""Wave-optics kernels against analytic pixel-integrated diffraction patterns.

A kernel pixel must hold the integral of the PSF over its area. The references are computed
independently of the model's DFT: the Airy pattern ``(2 J1(x)/x)²`` of a circular pupil and
the Fourier transform of a regular polygon (a sum over its edges) integrated over each pixel
by Gauss-Legendre quadrature, and the ``sinc²`` pattern of a square integrated in closed form
(the sine integral). Promise: within 1 % at the centre pixel and within 2 % of the peak pixel
everywhere, for pixels of 0.0005° to 0.05°, every wavelength and pupil the model accepts.
"""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.special import j0, j1, sici

from glarelab.glare import WaveOpticsGlare
from glarelab.glare.models.spectral import Spectrum

CAMERA = {"eyelashes": False, "eyelid": False, "particles": 0}
SHAPE = (15, 15)  # small kernels: the promise is per pixel, and wave kernels are memory-heavy
CENTRE_RTOL = 0.01
PEAK_ATOL = 0.02

pixel_sizes = st.floats(math.log10(0.0005), math.log10(0.05)).map(lambda e: 10.0**e)
wavelengths = st.floats(380.0, 770.0)
pupils = st.floats(1.0, 10.0)


def _nodes(pixel_rad: float, scale_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes on [-1/2, 1/2] with enough points for a pattern of scale λ/D."""
    n = 16 + 2 * math.ceil(6 * pixel_rad / scale_rad)
    x, w = np.polynomial.legendre.leggauss(n)
    return x / 2, w / 2


def _pixel_integrals(
    density, pixel_deg: float, scale_rad: float, half: int, mask: np.ndarray | None = None
) -> np.ndarray:
    """``∫∫ density(θx, θy)`` over each pixel (rad²) of a ``(2 half + 1)²`` kernel (only where
    ``mask`` is true, if given; 0 elsewhere); rows run down the image, so row ``i`` is at
    ``θy = -i p``."""
    p = math.radians(pixel_deg)
    x, w = _nodes(p, scale_rad)
    out = np.zeros((2 * half + 1, 2 * half + 1))
    for i in range(-half, half + 1):
        ty = (-i + x[:, None]) * p
        for j in range(-half, half + 1):
            if mask is not None and not mask[i + half, j + half]:
                continue
            tx = (j + x[None, :]) * p
            out[i + half, j + half] = np.sum(w[:, None] * w[None, :] * density(tx, ty)) * p * p
    return out


def airy_pixels(diameter_mm: float, wavelength_nm: float, pixel_deg: float, half: int):
    lam = wavelength_nm * 1e-6
    peak = math.pi * (diameter_mm / 2) ** 2 / lam**2  # density at 0 of a unit-energy PSF

    def density(tx, ty):
        a = math.pi * diameter_mm * np.hypot(tx, ty) / lam
        safe = np.where(a > 1e-9, a, 1.0)
        return peak * np.where(a > 1e-9, (2 * j1(safe) / safe) ** 2, 1.0)

    return _pixel_integrals(density, pixel_deg, lam / diameter_mm, half)


def _sinc2_integral(x: np.ndarray) -> np.ndarray:
    """``∫_0^x sinc²(s) ds`` with ``sinc(s) = sin(π s)/(π s)``: ``Si(2πx)/π - sin²(πx)/(π² x)``."""
    x = np.asarray(x, dtype=float)
    safe = np.where(x == 0, 1.0, x)
    return np.where(
        x == 0, 0.0, sici(2 * np.pi * x)[0] / np.pi - np.sin(np.pi * x) ** 2 / (np.pi**2 * safe)
    )


def square_pixels(side_mm: float, wavelength_nm: float, pixel_deg: float, half: int):
    """A square of side ``a``: ``sinc²(a θx / λ) sinc²(a θy / λ)``, separable and exact."""
    scale = side_mm / (wavelength_nm * 1e-6) * math.radians(pixel_deg)  # pixel in units λ/a
    edges = (np.arange(-half, half + 2) - 0.5) * scale
    one = np.diff(_sinc2_integral(edges))
    return np.outer(one, one)


def polygon_pixels(
    sides: int,
    diameter_mm: float,
    rotation_deg: float,
    wavelength_nm: float,
    pixel_deg,
    half,
    mask: np.ndarray | None = None,
):
    """The Fourier transform of a regular polygon (vertices on a circle of ``diameter_mm`` at
    ``rotation + k 360°/sides``, the diaphragm of :func:`glarelab.glare.models.apertures.aperture_diaphragm`),
    by the divergence theorem: ``∫_P e^{-ik·x} = (i/|k|²) Σ_edges (k·n) L e^{-ik·m}
    sinc(k·(b-a)/2π)``."""
    lam = wavelength_nm * 1e-6
    angles = np.radians(rotation_deg) + 2 * np.pi * np.arange(sides + 1) / sides
    vertices = diameter_mm / 2 * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    a, b = vertices[:-1], vertices[1:]
    edge = b - a
    length = np.hypot(edge[:, 0], edge[:, 1])
    normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1) / length[:, None]  # outward (ccw)
    middle = (a + b) / 2
    area = 0.5 * sides * (diameter_mm / 2) ** 2 * math.sin(2 * math.pi / sides)

    def density(tx, ty):
        tx, ty = np.broadcast_arrays(tx, ty)
        kx, ky = 2 * np.pi * tx / lam, 2 * np.pi * ty / lam
        k2 = kx**2 + ky**2
        total = np.zeros(kx.shape, dtype=complex)
        for e in range(sides):
            k_n = kx * normal[e, 0] + ky * normal[e, 1]
            k_m = kx * middle[e, 0] + ky * middle[e, 1]
            k_d = kx * edge[e, 0] + ky * edge[e, 1]
            total += k_n * length[e] * np.exp(-1j * k_m) * np.sinc(k_d / (2 * np.pi))
        f = 1j * total / k2
        return np.abs(f) ** 2 / (lam**2 * area)

    return _pixel_integrals(density, pixel_deg, lam / diameter_mm, half, mask)


def assert_matches(kernel: np.ndarray, reference: np.ndarray) -> None:
    c = kernel.shape[0] // 2
    assert_allclose(kernel[c, c], reference[c, c], rtol=CENTRE_RTOL)
    assert np.abs(kernel - reference).max() <= PEAK_ATOL * reference.max()


def test_references_are_unit_energy_patterns():
    # Airy: the energy in a square lies between the encircled energies of its inscribed and
    # circumscribed circles, 1 - J0(v)² - J1(v)² (Born & Wolf §8.5.2)
    airy = airy_pixels(3.0, 550.0, 0.004, 30)
    radii = np.radians(30.5 * 0.004 * np.array([1.0, math.sqrt(2)]))
    v = np.pi * 3.0 * radii / 550e-6
    inscribed, circumscribed = 1 - j0(v) ** 2 - j1(v) ** 2  # 0.9824, 0.9876
    assert inscribed < airy.sum() < circumscribed
    # sinc²: the whole pattern holds 1, and the closed form is symmetric
    assert_allclose(2 * _sinc2_integral(np.array(1e6)), 1.0, atol=1e-6)
    # the polygon transform of an axis-aligned square is the sinc² pattern
    square_by_edges = polygon_pixels(4, 2.0 * math.sqrt(2), 45.0, 550.0, 0.004, 10)
    assert_allclose(square_by_edges, square_pixels(2.0, 550.0, 0.004, 10), atol=1e-7)
    # and a 60-gon is nearly the disc
    assert_allclose(polygon_pixels(60, 3.0, 0.0, 550.0, 0.004, 5), airy[25:36, 25:36], atol=2e-3)


@settings(max_examples=12, deadline=None)
@given(pupil_mm=pupils, pixel_deg=pixel_sizes, low=wavelengths, high=wavelengths)
def test_circular_pupil_kernel_is_the_pixel_integrated_airy_pattern(
    pupil_mm, pixel_deg, low, high
):
    low, high = sorted((low, high + 10.0))
    spectrum = Spectrum(n_wavelengths=2, wavelength_range_nm=(low, min(high, 780.0)))
    model = WaveOpticsGlare(pupil_mm=pupil_mm, **CAMERA, spectrum=spectrum)
    kernels, nm = model.monochromatic_kernels(pixel_deg, SHAPE)
    for kernel, wavelength in zip(kernels, nm, strict=True):
        assert_matches(kernel, airy_pixels(pupil_mm, wavelength, pixel_deg, SHAPE[0] // 2))


@settings(max_examples=10, deadline=None)
@given(diameter_mm=pupils, pixel_deg=pixel_sizes)
def test_square_diaphragm_kernel_is_the_pixel_integrated_sinc2_pattern(diameter_mm, pixel_deg):
    model = WaveOpticsGlare(
        pupil_mm=diameter_mm, **CAMERA, diaphragm_sides=4, diaphragm_rotation_deg=45.0,
        spectral="kakimoto",
    )  # fmt: skip
    kernels, nm = model.monochromatic_kernels(pixel_deg, SHAPE)
    side = diameter_mm / math.sqrt(2)
    for kernel, wavelength in zip(kernels, nm, strict=True):
        assert_matches(kernel, square_pixels(side, wavelength, pixel_deg, SHAPE[0] // 2))


@settings(max_examples=10, deadline=None)
@given(
    sides=st.sampled_from([3, 5, 6, 8]),
    diameter_mm=pupils,
    rotation_deg=st.floats(0.0, 120.0),
    pixel_deg=pixel_sizes,
)
def test_polygonal_diaphragm_kernel_is_the_pixel_integrated_polygon_pattern(
    sides, diameter_mm, rotation_deg, pixel_deg
):
    model = WaveOpticsGlare(
        pupil_mm=diameter_mm, **CAMERA, diaphragm_sides=sides,
        diaphragm_rotation_deg=rotation_deg, spectral="kakimoto",
    )  # fmt: skip
    kernels, nm = model.monochromatic_kernels(pixel_deg, SHAPE)
    kernel, wavelength = kernels[1], nm[1]  # 530 nm
    reference = polygon_pixels(
        sides, diameter_mm, rotation_deg, wavelength, pixel_deg, SHAPE[0] // 2
    )
    assert_matches(kernel, reference)


def test_yoshida_display_centre_pixel():
    # the case that showed the rebinning error: 3 mm pupil, 530 nm, 0.0118°/px (Yoshida's
    # display), where the pixel-averaged Airy pattern holds 0.6292 of the energy
    model = WaveOpticsGlare(pupil_mm=3.0, **CAMERA, spectral="kakimoto")
    kernels, _ = model.monochromatic_kernels(0.0118, (21, 21))
    reference = airy_pixels(3.0, 530.0, 0.0118, 10)
    assert_allclose(reference[10, 10], 0.6292, atol=5e-5)
    assert_allclose(kernels[1][10, 10], reference[10, 10], rtol=1e-3)
    rebinned = WaveOpticsGlare(
        pupil_mm=3.0, **CAMERA, spectral="kakimoto", pixel_integration="rebin"
    ).monochromatic_kernels(0.0118, (21, 21))[0][1]
    assert rebinned[10, 10] < 0.95 * reference[10, 10]  # the old path: 0.582


def test_huge_and_tiny_pixels():
    # a pixel wider than psf_extent_deg still gets a PSF period of two pixels
    model = WaveOpticsGlare(pupil_mm=3.0, **CAMERA, spectral="kakimoto", psf_extent_deg=0.5)
    huge = model.kernel(1.0, (3, 3))
    assert huge.values[1, 1] > 0.99  # the whole PSF in one pixel
    assert_allclose(huge.values.sum() + huge.energy_outside, 1.0, atol=1e-9)
    tiny = model.monochromatic_kernels(1e-5, (3, 3))[0][1]  # 530 nm, a fiftieth of the core
    assert_allclose(tiny, airy_pixels(3.0, 530.0, 1e-5, 1), rtol=0.01)
