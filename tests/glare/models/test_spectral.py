import colour
import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.glare import HaloSpectrum, VosGlare
from glarelab.glare.models import vos
from glarelab.glare.models.spectral import halo_profiles

THETA = np.linspace(0.0, 8.0, 8001)


def test_at_least_50_wavelengths_from_400_to_700_nm():
    # Spencer 1995 §3.2: 50 wavelengths from 400 to 700 nm
    wavelengths = HaloSpectrum().wavelengths_nm
    assert wavelengths.size >= 50
    assert wavelengths[0] == 400.0 and wavelengths[-1] == 700.0


def test_white_source_is_neutral_in_display_rgb():
    weights = HaloSpectrum().channel_weights("RGB")
    assert_allclose(weights.sum(axis=1), 1.0, rtol=1e-12)


def test_xyz_weights_come_from_the_cie_1931_observer():
    spectrum = HaloSpectrum(n_wavelengths=31)
    weights = spectrum.channel_weights("XYZ")
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"][spectrum.wavelengths_nm]
    d65 = colour.SDS_ILLUMINANTS["D65"][spectrum.wavelengths_nm]
    expected = (d65[:, None] * cmfs).T / (d65 * cmfs[:, 1]).sum()
    assert_allclose(weights, expected, rtol=1e-12)


@pytest.mark.parametrize("channels", ["Y", "XYZ", "RGB"])
def test_every_channel_profile_has_unit_energy(channels):
    for profile in halo_profiles(channels, HaloSpectrum()):
        expected = 1.0
        if channels == "XYZ":  # X and Z of a D65 white relative to its Y
            continue
        assert_allclose(vos.volume(profile), expected, rtol=1e-3)


def test_rgb_halo_is_in_gamut_and_keeps_luminance():
    spectrum = HaloSpectrum()
    r, g, b = (p(THETA) for p in halo_profiles("RGB", spectrum))
    (y,) = (p(THETA) for p in halo_profiles("Y", spectrum))
    assert min(r.min(), g.min(), b.min()) >= 0.0
    space = colour.RGB_COLOURSPACES["ITU-R BT.709"]
    white = (space.matrix_XYZ_to_RGB @ spectrum.channel_weights("XYZ")).sum(axis=1)
    luminance_weights = space.matrix_RGB_to_XYZ[1] * white
    luminance = luminance_weights @ np.stack([r, g, b])
    assert np.abs(luminance - y).max() < 0.03 * y.max()


def test_luminance_path_never_computes_colour(monkeypatch):
    requested = []
    original = HaloSpectrum.channel_weights

    def spy(self, channels):
        requested.append(channels)
        return original(self, channels)

    monkeypatch.setattr(HaloSpectrum, "channel_weights", spy)
    VosGlare(regime="mesopic").kernel(0.1, (81, 81))
    assert requested == ["Y"]


def test_other_display_primaries_are_configurable():
    k709 = VosGlare(regime="mesopic").kernel(0.05, (161, 161), colour=True).values
    wide = VosGlare(regime="mesopic", halo_spectrum=HaloSpectrum(colourspace="ITU-R BT.2020"))
    k2020 = wide.kernel(0.05, (161, 161), colour=True).values
    assert not np.allclose(k709, k2020)
    with pytest.raises(ValueError, match="colourspace must be one of"):
        HaloSpectrum(colourspace="my monitor")
    with pytest.raises(ValueError, match="n_wavelengths must be an integer >= 2"):
        HaloSpectrum(n_wavelengths=1)


@pytest.mark.parametrize("given", [(400,), "ab", (400, 500, 600), 5])
def test_a_wavelength_range_that_is_not_two_numbers_is_named(given):
    """HaloSpectrum(wavelength_range_nm=(400,)) gave Python's "not enough values to unpack
    (expected 2, got 1)", naming neither the argument nor what is allowed."""
    from glarelab.glare.models.spectral import HaloSpectrum

    with pytest.raises(ValueError, match=r"wavelength_range_nm must be \(low, high\) in nm"):
        HaloSpectrum(wavelength_range_nm=given)
