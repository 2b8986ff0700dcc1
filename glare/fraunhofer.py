"""Fraunhofer diffraction on a grid: the PSF of an aperture and its exact rebinning onto pixels.

On a grid of ``N`` samples spaced ``δ`` mm, the DFT of the aperture's transmittance gives
``F[t]`` at frequencies ``k / (N δ)``, so the PSF's angular sample spacing is ``λ / (N δ)``
radians and its extent ``λ / δ`` (Kakimoto et al. 2004, eqs. 2, 5). :func:`psf_fraunhofer`
keeps the grid at least twice the aperture and the aperture resolved; :func:`rebin`
integrates the PSF exactly (area-weighted) onto the stimulus' pixels. The model that uses
them is :class:`glare.wave.WaveOpticsGlare`.

References
----------
Kakimoto, M., Matsuoka, K., Nishita, T., Naemura, T., Harashima, H. (2004). Glare generation
based on wave optics. Computer Graphics International, eqs. 1-7.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.fft
import scipy.sparse

from . import apertures as ap
from ._validation import check_in_range, check_positive
from .vos import WAVELENGTH_RANGE_NM

__all__ = ["MAX_GRID", "MIN_APERTURE_SAMPLES", "DiffractionPSF", "psf_fraunhofer", "rebin"]

MIN_APERTURE_SAMPLES = 32  # fewest samples across the open aperture we accept
_MM_PER_NM = 1e-6
MAX_GRID = 8192  # largest FFT grid (complex64: 512 MB)


@dataclass(frozen=True)
class DiffractionPSF:
    """A monochromatic diffraction PSF on its native angular grid.

    Attributes
    ----------
    values
        ``(N, N)`` PSF, centred at ``N // 2``, summing to 1.
    spacing_deg
        Angular sample spacing, degrees: ``λ / (N δ)``.
    wavelength_nm
        Wavelength.
    raw_energy
        ``Σ |DFT[t]|²`` before normalisation; Parseval: ``N² Σ |t|²``.
    transmitted_samples
        ``Σ |t|²``: the transmitted area in samples.
    padded_to
        Grid size after automatic padding (equals the input size when none was needed).
    """

    values: np.ndarray
    spacing_deg: float
    wavelength_nm: float
    raw_energy: float
    transmitted_samples: float
    padded_to: int


def _support_extent(aperture: np.ndarray) -> tuple[int, int]:
    rows = np.flatnonzero(aperture.any(axis=1))
    cols = np.flatnonzero(aperture.any(axis=0))
    return rows[-1] - rows[0] + 1, cols[-1] - cols[0] + 1


def psf_fraunhofer(
    aperture: np.ndarray,
    spacing_mm: float,
    wavelength_nm: float,
    *,
    fresnel_distance_mm: float | None = None,
) -> DiffractionPSF:
    """Monochromatic Fraunhofer PSF of an aperture (Kakimoto eq. 5; Luidolt eqs. 5.5-5.11).

    Parameters
    ----------
    aperture
        ``(N, N)`` amplitude transmittance in [0, 1] (use :mod:`glare.apertures`), centred at
        ``N // 2``.
    spacing_mm
        Sample spacing of the aperture in mm, > 0.
    wavelength_nm
        Wavelength in nm, 380-780.
    fresnel_distance_mm
        If given, multiply by Luidolt's Fresnel term ``exp(iπ r² / (λ d))`` with this ``d``
        (eq. 5.6; see the module notes on what it models).

    Returns
    -------
    DiffractionPSF

    Raises
    ------
    ValueError
        For a bad aperture (not square and 2-D, NaN, values outside [0, 1], nothing open), a
        non-positive spacing, a wavelength outside 380-780 nm, an aperture narrower than
        :data:`MIN_APERTURE_SAMPLES` samples (undersampled: its spectrum would alias), or a
        Fresnel chirp faster than the grid can sample (``δ > λ d / 2r``).

    Notes
    -----
    .. math:: M(\\theta) = \\frac{|\\mathrm{DFT}[t \\cdot F](\\theta)|^2}{\\sum |\\mathrm{DFT}|^2},
              \\qquad \\Delta\\theta = \\frac{\\lambda}{N \\delta}

    An aperture wider than half its grid would wrap its autocorrelation round the grid; it is
    zero-padded to twice its extent first (reported in ``padded_to``).

    Examples
    --------
    >>> grid = ap.ApertureGrid(256, 0.05)
    >>> psf = psf_fraunhofer(ap.aperture_pupil(grid, 4.0), 0.05, 550.0)
    >>> round(psf.spacing_deg, 5), round(float(psf.values.sum()), 12)
    (0.00246, 1.0)
    """
    t = ap.aperture_from_image(aperture)
    if t.shape[0] != t.shape[1]:
        raise ValueError(f"aperture must be square (N, N); got shape {t.shape}")
    spacing = check_positive("spacing_mm", spacing_mm, unit="mm")
    wavelength = check_in_range("wavelength_nm", wavelength_nm, *WAVELENGTH_RANGE_NM, unit="nm")
    if not t.any():
        raise ValueError("aperture is opaque everywhere: no light passes")
    extent = max(_support_extent(t > 0))
    if extent < MIN_APERTURE_SAMPLES:
        raise ValueError(
            f"aperture is undersampled: its open part spans {extent} samples, fewer than "
            f"{MIN_APERTURE_SAMPLES}; sample it finer (smaller spacing_mm)"
        )
    n = t.shape[0]
    needed = 2 * extent
    if n < needed:  # the autocorrelation would wrap round the grid: pad, centred
        size = scipy.fft.next_fast_len(needed + needed % 2)
        padded = np.zeros((size, size))
        offset = size // 2 - n // 2
        padded[offset : offset + n, offset : offset + n] = t
        t, n = padded, size
    field_: np.ndarray = t.astype(np.complex64)
    if fresnel_distance_mm is not None:
        d = check_positive("fresnel_distance_mm", fresnel_distance_mm, unit="mm")
        axis = (np.arange(n) - n // 2) * spacing
        r2 = axis[None, :] ** 2 + axis[:, None] ** 2
        # the chirp's local frequency r / (λ d) must stay below Nyquist, 1 / (2 δ)
        r_open = math.sqrt(float(r2[t > 0].max()))
        limit = wavelength * _MM_PER_NM * d / (2.0 * r_open)
        if spacing > limit:
            raise ValueError(
                f"the Fresnel term is undersampled: at r = {r_open:.3g} mm its phase needs "
                f"spacing_mm <= {limit:.3g} (λ d / 2r), got {spacing:.3g}; its PSF spreads "
                f"over the pupil's shadow, {math.degrees(2 * r_open / d):.3g}°"
            )
        field_ = field_ * np.exp(1j * np.pi * r2 / (wavelength * _MM_PER_NM * d)).astype(
            np.complex64
        )
    spectrum = scipy.fft.fft2(scipy.fft.ifftshift(field_), workers=-1)
    intensity = scipy.fft.fftshift(spectrum.real.astype(np.float64) ** 2 + spectrum.imag**2)
    raw = float(intensity.sum())
    return DiffractionPSF(
        values=intensity / raw,
        spacing_deg=math.degrees(wavelength * _MM_PER_NM / (n * spacing)),
        wavelength_nm=wavelength,
        raw_energy=raw,
        transmitted_samples=float(np.sum(t**2)),
        padded_to=n,
    )


def _rebin_matrix(n: int, src: float, dst: float, size: int) -> scipy.sparse.csr_matrix:
    """``(size, n)`` band matrix integrating a centred axis of ``n`` cells of ``src`` onto
    ``size`` cells of ``dst``: each output cell receives each input cell times the length of
    their overlap (in input cells), the same as interpolating the cumulative sum at the output
    edges."""
    src_edges = (np.arange(n + 1) - n // 2 - 0.5) * src
    dst_edges = (np.arange(size + 1) - size // 2 - 0.5) * dst
    position = np.clip((dst_edges - src_edges[0]) / src, 0.0, n)
    start, stop = position[:-1], position[1:]
    first = np.minimum(np.floor(start).astype(np.int64), n - 1)
    span = int(np.max(np.ceil(stop) - first, initial=1))
    rows, cols, weights = [], [], []
    for k in range(max(span, 1)):
        cell = first + k
        overlap = np.minimum(stop, cell + 1) - np.maximum(start, cell)
        keep = (overlap > 0) & (cell < n)
        rows.append(np.flatnonzero(keep))
        cols.append(cell[keep])
        weights.append(overlap[keep])
    return scipy.sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(size, n)
    )


def _rebin_cropped(values: np.ndarray, src: float, dst: float, shape) -> np.ndarray:
    """``A V Bᵀ`` for a C-contiguous ``values``: the sparse rows product first (no copy), then
    the columns, which needs one transposed copy of the smaller intermediate."""
    rows = _rebin_matrix(values.shape[0], src, dst, shape[0])
    cols = _rebin_matrix(values.shape[1], src, dst, shape[1])
    return np.asarray(cols @ np.asarray(rows @ values).T).T


def _crop_to_reach(
    values: np.ndarray, spacing_deg: float, to_spacing_deg: float, shape: tuple[int, int]
) -> np.ndarray:
    """The centred part of ``values`` that the output grid can reach (with one sample spare)."""
    n = values.shape[0]
    half = [min(n // 2, math.ceil((m / 2 * to_spacing_deg) / spacing_deg) + 1) for m in shape]
    c = n // 2
    return values[c - half[0] : c + half[0] + 1, c - half[1] : c + half[1] + 1]


def rebin(
    values: np.ndarray, from_spacing_deg: float, to_spacing_deg: float, shape: tuple[int, int]
) -> np.ndarray:
    """Integrate a centred, piecewise-constant image onto a grid of another spacing.

    Exact for energy: each output pixel receives the integral of the input over its area
    (cumulative sums interpolated at the output pixel edges), so the sum is conserved
    wherever the output covers the input.

    Examples
    --------
    >>> a = np.zeros((5, 5)); a[2, 2] = 1.0
    >>> rebin(a, 1.0, 2.0, (3, 3))[1, 1]
    1.0
    """
    values = np.ascontiguousarray(_crop_to_reach(values, from_spacing_deg, to_spacing_deg, shape))
    return _rebin_cropped(values, from_spacing_deg, to_spacing_deg, shape)
