"""Smaller items of issue 33: one warning for an age outside 20-70, render_planned's
default maximum display luminance as the other render functions', and the white of Luidolt's
eq. 5.12 against the suite's (docs/optics-departures.md)."""

import inspect
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.special import j1

from glarelab.glare import VosGlare, WaveOpticsGlare
from glarelab.glare._colour import colour
from glarelab.glare.rendering import render

CIE1931 = "CIE 1931 2 Degree Standard Observer"


@pytest.mark.parametrize("path", ["kernel", "render"])
def test_an_age_outside_the_papers_span_warns_once(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = VosGlare(age=80)
        if path == "kernel":
            model.kernel(0.05, (11, 11))
        else:
            image = np.full((15, 15), 1.0)
            image[7, 7] = 1e4
            render.render_planned(image, model, pixel_deg=0.05)
    ages = [w for w in caught if "outside 20-70 years" in str(w.message)]
    assert len(ages) == 1


@pytest.mark.parametrize("name", ["render_planned", "add_glare"])
def test_render_functions_default_l_dmax_to_yoshidas_display(name):
    default = inspect.signature(getattr(render, name)).parameters["l_dmax_cd_m2"].default
    assert default == render.L_DMAX_YOSHIDA2008_CD_M2 == 220.0


def _airy(theta_deg: np.ndarray, pupil_mm: float, wavelength_nm: float) -> np.ndarray:
    """The Airy pattern of a round pupil, 1 at its centre (Born & Wolf §8.5.2)."""
    z = np.pi * pupil_mm * 1e-3 * np.deg2rad(theta_deg) / (wavelength_nm * 1e-9)
    z = np.where(z == 0.0, 1e-12, z)
    return (2 * j1(z) / z) ** 2


def test_luidolts_eq_5_12_as_printed_has_a_yellowish_white():
    # Luidolt 2020 eq. 5.12: S_XYZ(x, y) = 1/(k+1) Σ_i Wavelength2XYZ(φ_i) M(x λ/φ_i, y λ/φ_i),
    # eq. 5.13: φ_i = 380 + (i/k)(770 − 380), λ = 575 nm (§5.2.2), M a 3 mm pupil's PSF read
    # on one pixel grid. Each copy holds (φ_i/λ)² of M's energy there, so the white is
    # xy (0.388, 0.370) (docs/optics-departures.md), not the equal-energy (1/3, 1/3).
    wavelength_nm, k = 575.0, 39
    offsets_deg = (np.arange(401) - 200) * 0.005
    theta = np.hypot(*np.meshgrid(offsets_deg, offsets_deg))
    m_sum = _airy(theta, 3.0, wavelength_nm).sum()
    cmfs = colour.MSDS_CMFS[CIE1931]
    xyz = np.zeros(3)
    for i in range(k + 1):
        phi = 380.0 + i / k * (770.0 - 380.0)
        copy_sum = _airy(theta * wavelength_nm / phi, 3.0, wavelength_nm).sum()
        assert_allclose(copy_sum / m_sum, (phi / wavelength_nm) ** 2, rtol=2e-3)
        xyz += np.asarray(cmfs[phi]) * copy_sum / (k + 1)
    assert_allclose(xyz[:2] / xyz.sum(), (0.388, 0.370), atol=1e-3)


def test_the_suites_spectral_kernel_white_is_the_displays_d65():
    # Spectrum: every wavelength's PSF carries the same energy, weighted by the CIE 1931
    # observer and D65; the RGB kernel's channels each hold all the light (inside the kernel
    # or booked outside), so a flat glow is the display's white.
    model = WaveOpticsGlare(pupil_mm=3.0, eyelashes=False, eyelid=False, particles=0)
    weights = model.spectrum.channel_weights("XYZ").sum(axis=1)
    d65 = colour.CCS_ILLUMINANTS[CIE1931]["D65"]
    assert_allclose(weights[:2] / weights.sum(), d65, atol=1e-3)
    kernel = model.kernel(0.02, (21, 21), colour=True)
    assert_allclose(kernel.values.sum(axis=(0, 1)) + kernel.energy_outside, 1.0, atol=1e-9)
