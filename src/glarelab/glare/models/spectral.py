"""Colour of the lenticular halo: spectral ring → CIE 1931 XYZ → linear display RGB.

Spencer §3.2 evaluates eq. 7 for 50 wavelengths between 400 and 700 nm and converts the
spectrum to a trichromatic image (after Meyer). Here the halo of a white source (spectrum of
the display white, D65 for Rec. 709) is

.. math::

   H_c(\\theta) = \\frac{\\sum_\\lambda S(\\lambda) \\bar c(\\lambda) f_3(\\theta, \\lambda)}
                        {\\sum_\\lambda S(\\lambda) \\bar y(\\lambda)}

for the colour-matching functions ``c̄ ∈ {x̄, ȳ, z̄}`` (colour-science's CIE 1931 2° observer),
followed by the display's XYZ → RGB matrix and a white balance that maps a wavelength-flat
ring to R = G = B. Every channel then has unit volume: the halo moves energy in each channel,
it does not add or remove any. The luminance path uses ``H_Y`` alone and never touches X, Z
or RGB.

The channel profiles are tabulated on a 0.0005° grid over 0-8° (the ring at 780 nm sits at
4.1° and has fallen to 1e-120 by 8°) and interpolated linearly: relative interpolation error
below 2e-6, and one interpolation per sample instead of one exponential per wavelength.

References
----------
Spencer et al. 1995, §3.2 and eq. 7; CIE 1931 2° standard observer (colour-science).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from glarelab.glare._validation import check_choice, check_in_range, check_positive_int
from glarelab.glare.models.vos import f3

__all__ = [
    "HALO_TABLE_MAX_DEG",
    "HALO_WAVELENGTHS_NM",
    "HaloSpectrum",
    "Spectrum",
    "halo_profiles",
]

HALO_WAVELENGTHS_NM = (400.0, 700.0)  # Spencer 1995 §3.2: 50 wavelengths from 400 to 700 nm
HALO_TABLE_MAX_DEG = 8.0
_HALO_TABLE_STEP_DEG = 0.0005
_OBSERVER = "CIE 1931 2 Degree Standard Observer"
_DEFAULT_NAMES = ("ITU-R BT.709", "D65")  # a colourspace and an illuminant of colour-science


@dataclass(frozen=True)
class Spectrum:
    """Spectral sampling of a white source and the display it is shown on.

    Attributes
    ----------
    n_wavelengths
        Wavelengths across ``wavelength_range_nm``, evenly spaced; default 61 (5 nm steps over
        the default range; Spencer uses 50). At least 2.
    wavelength_range_nm
        First and last wavelength in nm, within 380-780; default (400, 700) (Spencer §3.2).
    colourspace
        Name of a colour-science RGB colourspace for the display primaries; default
        ``'ITU-R BT.709'``.
    illuminant
        Name of a colour-science illuminant spectrum for the white source; default ``'D65'``.
    in_gamut_above
        The RGB halo is desaturated until it is inside the display gamut wherever it exceeds
        this fraction of its peak (see ``_into_gamut``); default 0.1. 0 keeps the whole ring in
        gamut at the cost of most of its colour.
    """

    n_wavelengths: int = 61
    wavelength_range_nm: tuple[float, float] = HALO_WAVELENGTHS_NM
    colourspace: str = "ITU-R BT.709"
    illuminant: str = "D65"
    in_gamut_above: float = 0.1

    def __post_init__(self) -> None:
        check_in_range("in_gamut_above", self.in_gamut_above, 0.0, 1.0)
        check_positive_int("n_wavelengths", self.n_wavelengths, minimum=2)
        given = self.wavelength_range_nm
        if isinstance(given, str | bytes) or np.ndim(given) != 1 or len(given) != 2:
            raise ValueError(
                f"wavelength_range_nm must be (low, high) in nm within 380-780; got {given!r:.80}"
            )
        low, high = given
        check_in_range("wavelength_range_nm[0]", low, 380.0, 780.0, unit="nm")
        check_in_range("wavelength_range_nm[1]", high, low, 780.0, unit="nm", low_inclusive=False)
        if (self.colourspace, self.illuminant) != _DEFAULT_NAMES:  # valid names, colour unread
            from glarelab.glare._colour import (
                colour,  # imported when needed: it imports matplotlib (1.5 s)
            )

            check_choice("colourspace", self.colourspace, sorted(colour.RGB_COLOURSPACES))
            check_choice("illuminant", self.illuminant, sorted(colour.SDS_ILLUMINANTS))

    @property
    def wavelengths_nm(self) -> np.ndarray:
        return np.linspace(*self.wavelength_range_nm, self.n_wavelengths)

    def channel_weights(self, channels: Literal["Y", "XYZ", "RGB"]) -> np.ndarray:
        """Weights ``(C, n_wavelengths)`` turning ``f3(θ, λ)`` into channel profiles.

        Parameters
        ----------
        channels
            ``'Y'`` (luminance), ``'XYZ'`` (CIE 1931) or ``'RGB'`` (the spectrum's
            colourspace, balanced so that a flat ring has R = G = B = Y).

        Returns
        -------
        numpy.ndarray
            ``(C, n_wavelengths)``, normalised so that the illuminant's luminance weights sum
            to 1.

        Raises
        ------
        ValueError
            For other ``channels``.
        """
        from glarelab.glare._colour import colour

        wavelengths = self.wavelengths_nm
        cmfs = np.asarray(colour.MSDS_CMFS[_OBSERVER][wavelengths])  # (n, 3): x̄, ȳ, z̄
        spectrum = np.asarray(colour.SDS_ILLUMINANTS[self.illuminant][wavelengths])
        xyz = (spectrum[:, None] * cmfs).T / np.sum(spectrum * cmfs[:, 1])  # (3, n)
        if channels == "Y":
            return xyz[1:2]
        if channels == "XYZ":
            return xyz
        if channels == "RGB":
            space = colour.RGB_COLOURSPACES[self.colourspace]
            rgb = space.matrix_XYZ_to_RGB @ xyz
            white = rgb.sum(axis=1)  # RGB of a flat ring: balance it to R = G = B = Y = 1
            return rgb / white[:, None]
        raise ValueError(f"channels must be one of 'Y', 'XYZ', 'RGB'; got {channels!r}")


HaloSpectrum = Spectrum  # the name the halo code and its users know it by


def _into_gamut(
    rgb: np.ndarray, neutral: np.ndarray, grid: np.ndarray, in_gamut_above: float
) -> np.ndarray:
    """Bring an RGB ring inside the display gamut, keeping each channel's energy.

    The spectral ring is more saturated than Rec. 709 can show: at each angle only a ~50 nm
    band of the spectrum lands there, and blue falls to -11 % of green at 3°. A negative
    kernel channel would paint negative light. Desaturating each angle separately would keep
    its luminance but move energy between channels (a white source's halo would turn orange:
    channel volumes 1.17, 0.99, 0.63). Instead the whole ring is mixed with its neutral
    ``(Y, Y, Y)`` by one factor ``s``, which keeps the luminance at every angle and every
    channel's volume exactly; ``s`` is the largest value that is in gamut wherever the ring
    exceeds ``in_gamut_above`` of its peak. The fainter tails are clipped at 0 and each
    channel rescaled to its volume before clipping.
    """
    significant = neutral >= in_gamut_above * neutral.max()
    deficit = neutral[None, :] - rgb
    with np.errstate(divide="ignore", invalid="ignore"):
        limits = np.where(rgb < 0, neutral[None, :] / deficit, 1.0)
    saturation = float(np.clip(limits[:, significant].min(), 0.0, 1.0))
    mixed = neutral[None, :] + saturation * (rgb - neutral[None, :])
    clipped = np.maximum(mixed, 0.0)
    sin_weight = np.sin(np.radians(grid))
    volumes = np.trapezoid(clipped * sin_weight, grid, axis=1)
    targets = np.trapezoid(mixed * sin_weight, grid, axis=1)
    return clipped * (targets / volumes)[:, None]


def halo_profiles(
    channels: Literal["Y", "XYZ", "RGB"],
    spectrum: Spectrum,
    *,
    wavelength_nm: float | None = None,
) -> list[Callable[[np.ndarray], np.ndarray]]:
    """Radial halo profiles, one per channel, each of unit volume under Spencer eq. 4.

    Parameters
    ----------
    channels
        ``'Y'`` (luminance only), ``'XYZ'`` or ``'RGB'`` (linear display RGB).
    spectrum
        Wavelength sampling, display primaries and source white.
    wavelength_nm
        If given, a monochromatic halo at this wavelength (380-780 nm) in every channel
        instead of a white source's spectrum.

    Returns
    -------
    list of callables
        ``profile(theta_deg) -> density per sr``.

    Examples
    --------
    >>> (y,) = halo_profiles("Y", HaloSpectrum())
    >>> round(float(y(np.array(3.0))), 1)  # below f3(3°, 568 nm) = 436.9: white light spreads
    252.0
    """
    check_choice("channels", channels, ("Y", "XYZ", "RGB"))
    n_channels = 1 if channels == "Y" else 3
    if wavelength_nm is not None:
        f3(0.0, wavelength_nm)  # validates the wavelength

        def mono(theta: np.ndarray) -> np.ndarray:
            return f3(theta, wavelength_nm)

        return [mono] * n_channels
    grid = np.arange(0.0, HALO_TABLE_MAX_DEG + _HALO_TABLE_STEP_DEG, _HALO_TABLE_STEP_DEG)
    rings = f3(grid[None, :], spectrum.wavelengths_nm[:, None])  # (n_wavelengths, n_grid)
    table = spectrum.channel_weights(channels) @ rings  # (C, n_grid)
    if channels == "RGB":
        neutral = (spectrum.channel_weights("Y") @ rings)[0]
        table = _into_gamut(table, neutral, grid, spectrum.in_gamut_above)

    def make(row: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        def profile(theta: np.ndarray) -> np.ndarray:
            return np.interp(theta, grid, row, right=0.0)

        return profile

    return [make(row) for row in table]
