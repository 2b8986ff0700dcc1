"""Fraunhofer diffraction on a grid: the PSF of an aperture, sampled or integrated over pixels.

On a grid of ``N`` samples spaced ``δ`` mm, the DFT of the aperture's transmittance gives
``F[t]`` at frequencies ``k / (N δ)``, so the PSF's angular sample spacing is ``λ / (N δ)``
radians and its extent ``λ / δ`` (Kakimoto et al. 2004, eqs. 2, 5). :func:`psf_fraunhofer`
keeps the grid at least twice the aperture and the aperture resolved; :func:`rebin`
spreads those samples, each taken as constant over its cell, onto the stimulus' pixels.

That rebinning is exact for energy but not for the pattern: the samples are ``λ / (2.1 D)``
apart, so a display pixel of 0.01° holds two or three of them and the centre pixel of a
3 mm pupil's Airy pattern got 0.58 of the energy instead of 0.63.
:func:`psf_pixel_integrated` integrates the intensity over each pixel exactly instead. The
intensity of a sampled aperture ``t_m`` is a trigonometric polynomial whose coefficients
are the aperture's autocorrelation ``C_k = Σ_m t_{m+k} t*_m``:

.. math:: I(\\theta) = \\sum_k C_k\\, e^{-2\\pi i\\, k \\delta \\theta / \\lambda},

so its integral over the pixel ``[c - p/2, c + p/2]²`` is, term by term,

.. math:: \\int_{\\rm pixel} I = p^2 \\sum_{k, l} C_{kl}\\,
          \\mathrm{sinc}(k \\beta p)\\, \\mathrm{sinc}(l \\beta p)\\,
          e^{-2\\pi i \\beta (k c_y + l c_x)}, \\qquad \\beta = \\delta / \\lambda,

a matrix DFT (two matrix products) from the ``(2M - 1)²`` lags of an aperture ``M`` samples
wide to the pixel centres. It is exact for any pixel size and wavelength: no sampling of the
PSF, no rebinning. The model that uses them is :class:`glarelab.glare.models.wave.WaveOpticsGlare`.

References
----------
Kakimoto, M., Matsuoka, K., Nishita, T., Naemura, T., Harashima, H. (2004). Glare generation
based on wave optics. Pacific Graphics 2004 (12th Pacific Conference on Computer Graphics and
Applications), eqs. 1-7.
Soummer, R., Pueyo, L., Sivaramakrishnan, A., Vanderbei, R. J. (2007). Fast computation of
Lyot-style coronagraph propagation. Optics Express 15(24) (the matrix Fourier transform).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.fft
import scipy.sparse

from glarelab.glare._validation import (
    check_in_range,
    check_pixel_deg,
    check_positive,
    check_positive_int,
)
from glarelab.glare.models import apertures as ap
from glarelab.glare.models.vos import WAVELENGTH_RANGE_NM

__all__ = [
    "MAX_GRID",
    "MIN_APERTURE_SAMPLES",
    "ApertureAutocorrelation",
    "DiffractionPSF",
    "aperture_autocorrelation",
    "pixel_integrated_psf",
    "psf_fraunhofer",
    "psf_pixel_integrated",
    "rebin",
]

MIN_APERTURE_SAMPLES = 32  # fewest samples across the open aperture we accept
_MM_PER_NM = 1e-6
MAX_GRID = 8192  # largest FFT grid (complex64: 512 MB)
_BLOCK_ELEMENTS = 4_000_000  # float64 elements per intermediate block of the matrix DFT (32 MB)


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
        ``(N, N)`` amplitude transmittance in [0, 1] (use :mod:`glarelab.glare.models.apertures`),
        centred at ``N // 2``.
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
    field_ = t.astype(np.complex64)
    if fresnel_distance_mm is not None:
        field_ = _fresnel_field(t, spacing, wavelength, fresnel_distance_mm).astype(np.complex64)
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


def _fresnel_field(
    t: np.ndarray, spacing: float, wavelength_nm: float, fresnel_distance_mm: float
) -> np.ndarray:
    """``t · exp(iπ r² / (λ d))`` (Luidolt eq. 5.6) on a grid centred at ``N // 2``, refusing a
    chirp the grid cannot sample."""
    d = check_positive("fresnel_distance_mm", fresnel_distance_mm, unit="mm")
    rows, cols = t.shape
    y = (np.arange(rows) - rows // 2) * spacing
    x = (np.arange(cols) - cols // 2) * spacing
    r2 = x[None, :] ** 2 + y[:, None] ** 2
    # the chirp's local frequency r / (λ d) must stay below Nyquist, 1 / (2 δ)
    r_open = math.sqrt(float(r2[t > 0].max()))
    limit = wavelength_nm * _MM_PER_NM * d / (2.0 * r_open)
    if spacing > limit:
        raise ValueError(
            f"the Fresnel term is undersampled: at r = {r_open:.3g} mm its phase needs "
            f"spacing_mm <= {limit:.3g} (λ d / 2r), got {spacing:.3g}; its PSF spreads "
            f"over the pupil's shadow, {math.degrees(2 * r_open / d):.3g}°"
        )
    return t * np.exp(1j * np.pi * r2 / (wavelength_nm * _MM_PER_NM * d))


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

    Parameters
    ----------
    values
        The image, centred, each sample constant over its ``from_spacing_deg`` square.
    from_spacing_deg
        The image's sample spacing, degrees.
    to_spacing_deg
        The output's pixel size, degrees.
    shape
        Odd output shape ``(KH, KW)``, centred on the image's centre.

    Returns
    -------
    numpy.ndarray
        ``shape``: the integral of ``values`` over each output pixel.

    Examples
    --------
    >>> a = np.zeros((5, 5)); a[2, 2] = 1.0
    >>> float(rebin(a, 1.0, 2.0, (3, 3))[1, 1])
    1.0
    """
    values = np.ascontiguousarray(_crop_to_reach(values, from_spacing_deg, to_spacing_deg, shape))
    return _rebin_cropped(values, from_spacing_deg, to_spacing_deg, shape)


@dataclass(frozen=True)
class ApertureAutocorrelation:
    """The autocorrelation of a sampled aperture field: the Fourier coefficients of its PSF.

    Attributes
    ----------
    values
        ``(2 M_r - 1, 2 M_c - 1)`` lags ``C_kl = Σ_mn f_{m+k, n+l} f*_mn`` of a field whose
        open part spans ``M_r × M_c`` samples, lag 0 at the centre; real (float64) for a
        real aperture, complex128 with the Fresnel term.
    spacing_mm
        Sample spacing of the aperture, mm.
    open_samples
        ``Σ |f|``: the open area in samples (the area the antialiased edges cover).
    """

    values: np.ndarray
    spacing_mm: float
    open_samples: float

    @property
    def energy(self) -> float:
        """``C_00 = Σ |f|²``, the energy the sampled field diffracts into one period."""
        rows, cols = self.values.shape
        return float(self.values[rows // 2, cols // 2].real)

    @functools.cached_property
    def folded(self) -> tuple[np.ndarray, np.ndarray]:
        """The lags folded by symmetry (real apertures; see :func:`_folded`)."""
        return _folded(self.values)

    @property
    def open_area_mm2(self) -> float:
        """The open area in mm²."""
        return self.open_samples * self.spacing_mm**2


def aperture_autocorrelation(field: np.ndarray, spacing_mm: float) -> ApertureAutocorrelation:
    """Autocorrelation of an aperture field (real transmittance or complex), cropped to the
    bounding box of its open part, by an FFT padded so that no lag wraps round.

    Parameters
    ----------
    field
        2-D amplitude transmittance (real in [0, 1], or complex with the Fresnel term).
    spacing_mm
        Sample spacing, mm, > 0.

    Raises
    ------
    ValueError
        For a field that is not 2-D or finite, nothing open, or an open part narrower than
        :data:`MIN_APERTURE_SAMPLES` samples.

    Examples
    --------
    >>> acf = aperture_autocorrelation(ap.aperture_pupil(ap.ApertureGrid(80, 0.1), 6.0), 0.1)
    >>> acf.values.shape, round(acf.open_area_mm2, 2)  # lags of a 61-sample disc; π 3² mm²
    ((121, 121), 28.27)
    """
    f = np.asarray(field)
    if f.ndim != 2 or not np.isfinite(f).all():
        raise ValueError(f"field must be a finite 2-D array; got shape {f.shape}")
    spacing = check_positive("spacing_mm", spacing_mm, unit="mm")
    open_ = np.abs(f) > 0
    if not open_.any():
        raise ValueError("aperture is opaque everywhere: no light passes")
    rows = np.flatnonzero(open_.any(axis=1))
    cols = np.flatnonzero(open_.any(axis=0))
    f = f[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    if max(f.shape) < MIN_APERTURE_SAMPLES:
        raise ValueError(
            f"aperture is undersampled: its open part spans {max(f.shape)} samples, fewer "
            f"than {MIN_APERTURE_SAMPLES}; sample it finer (smaller spacing_mm)"
        )
    m_r, m_c = f.shape
    size = (scipy.fft.next_fast_len(2 * m_r - 1), scipy.fft.next_fast_len(2 * m_c - 1))
    if np.iscomplexobj(f):
        spectrum = scipy.fft.fft2(f.astype(np.complex128), s=size, workers=-1)
        lags = scipy.fft.ifft2(spectrum.real**2 + spectrum.imag**2, workers=-1)
    else:
        spectrum = scipy.fft.rfft2(f.astype(np.float64), s=size, workers=-1)
        lags = scipy.fft.irfft2(spectrum.real**2 + spectrum.imag**2, s=size, workers=-1)
    del spectrum
    # lag k sits at index k mod size: gather -(M-1) .. M-1
    row_index = np.arange(-(m_r - 1), m_r) % size[0]
    col_index = np.arange(-(m_c - 1), m_c) % size[1]
    return ApertureAutocorrelation(
        values=lags[np.ix_(row_index, col_index)],
        spacing_mm=spacing,
        open_samples=float(np.abs(f).sum()),
    )


def _phase_matrices(
    lags: np.ndarray,
    beta_p: float,
    centres_px: np.ndarray,
    prefilter: tuple[int, int] | None = None,
    parts: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """``sinc(k β p) cos(2π k β c)`` and ``sinc(k β p) sin(2π k β c)``, ``(centres, lags)``,
    for centres ``c`` in pixels (``β p`` periods per pixel).

    With ``prefilter``: the pixel's integral of ``e^{-2π i k β x} / Φ²(x β p)`` instead, the
    prefilter's transfer divided out over ``parts`` parts of the pixel (each
    part's integral exact, ``Φ²`` at its centre): ``Σ_s sinc(k β p / n) e^{-2π i k β c_s}
    / (n Φ²(c_s β p))``, which is the plain matrix when ``Φ = 1``."""
    if prefilter is None:
        weight = np.sinc(lags * beta_p)
        phase = 2.0 * np.pi * beta_p * np.outer(centres_px, lags)
        return weight * np.cos(phase), weight * np.sin(phase)
    n = parts
    offsets = (np.arange(n) - (n - 1) / 2.0) / n  # the parts' centres, pixels from c
    # e^{i(a + b)} = e^{ia} e^{ib}: the parts' phases are the centre's times each offset's
    gain = 1.0 / (
        n * ap.prefilter_transfer((centres_px[:, None] + offsets) * beta_p, prefilter) ** 2
    )
    offset_phase = 2.0 * np.pi * beta_p * np.outer(offsets, lags)
    weight = np.sinc(lags * beta_p / n)
    # einsum: a matrix product over 5 parts is slow in BLAS (0.02 s here against 0.2 ms)
    gain_cos = np.einsum("cs,sk->ck", gain, weight * np.cos(offset_phase))
    gain_sin = np.einsum("cs,sk->ck", gain, weight * np.sin(offset_phase))
    phase = 2.0 * np.pi * beta_p * np.outer(centres_px, lags)
    cos_c, sin_c = np.cos(phase), np.sin(phase)
    return cos_c * gain_cos - sin_c * gain_sin, sin_c * gain_cos + cos_c * gain_sin


def _folded(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A centro-symmetric real autocorrelation folded onto its lags ``k, l >= 0``.

    ``Σ_kl C_kl cos(a_k + b_l)`` with ``C_{-k,-l} = C_kl`` is
    ``Σ_{k,l>=0} E_kl cos a_k cos b_l - Σ_{k,l>0} O_kl sin a_k sin b_l``, with ``E`` and ``O``
    the even and odd parts in ``l`` (``E`` even and ``O`` odd in ``k`` too), doubled for
    ``k > 0``: a quarter of the products."""
    hr, hc = c.shape[0] // 2, c.shape[1] // 2
    plus, minus = c[:, hc:], c[:, hc::-1]
    even = plus + minus
    even[:, 0] *= 0.5
    even = even[hr:]
    even[1:] *= 2.0
    odd = 2.0 * (plus - minus)[hr + 1 :, 1:]
    return np.ascontiguousarray(even), np.ascontiguousarray(odd)


def pixel_integrated_psf(
    acf: ApertureAutocorrelation,
    wavelength_nm: float,
    pixel_deg: float,
    shape: tuple[int, int],
    *,
    reach_deg: float | None = None,
    edge_transfer: bool = False,
    prefilter: tuple[int, int] = ap.PREFILTER_BOX,
    transfer_parts: int = 1,
) -> np.ndarray:
    """The PSF of an aperture integrated exactly over each pixel of a centred kernel.

    Parameters
    ----------
    acf
        The aperture's autocorrelation (:func:`aperture_autocorrelation`).
    wavelength_nm
        Wavelength, nm, 380-780.
    pixel_deg
        Pixel size, degrees, > 0.
    shape
        Odd kernel shape ``(KH, KW)``.
    reach_deg
        Pixels whose centre is farther than this from the centre (along either axis) are left
        at 0; default and largest: half the PSF's period ``λ / 2δ`` less half a pixel, beyond
        which the sampled aperture's periodic spectrum repeats.
    edge_transfer
        Divide out the transfer of the antialiased edges, ``sinc²(ρ δ / λ)`` at each pixel's
        distance ``ρ`` from the centre (see Notes): the result is then the pattern of the
        aperture the edges describe, not of its samples. Default False.
    prefilter
        With ``edge_transfer``: the prefilter the edges were drawn with
        (:func:`glarelab.glare.models.apertures.aperture_diaphragm`). Default ``(1, 1)``: the
        one-sample ramp or box, divided out as ``sinc²(ρ δ / λ)`` at each pixel's centre; any
        other is divided out as its separable transfer ``Φ²(θ_x δ / λ) Φ²(θ_y δ / λ)``
        (:func:`glarelab.glare.models.apertures.prefilter_transfer`), at each pixel's centre
        or over ``transfer_parts`` parts of it.
    transfer_parts
        With ``edge_transfer`` and a prefilter other than ``(1, 1)``: the parts of a pixel
        along each axis over which its transfer is divided out, >= 1. Default 1: at the
        pixel's centre (see Notes).

    Returns
    -------
    numpy.ndarray
        ``(KH, KW)`` float64: the fraction of the light through the aperture's open area that
        falls into each pixel.

    Raises
    ------
    ValueError
        For a wavelength outside 380-780 nm, a bad pixel size or shape, a bad prefilter, or a
        pixel wider than half the PSF's period (the aperture is sampled too coarsely for it).

    Notes
    -----
    .. math:: K_{ij} = \\frac{(\\beta p)^2}{\\sum |t|} \\,\\mathrm{Re}
              \\bigl[W_y\\, C\\, W_x^{\\mathsf T}\\bigr]_{ij}, \\qquad
              W_{ck} = \\mathrm{sinc}(k \\beta p)\\, e^{-2\\pi i k \\beta c},

    with ``β = δ / λ`` (radians⁻¹), ``p`` the pixel and ``c`` its centre in radians. The
    products are formed in blocks of output columns (memory bounded by about 32 MB beyond
    the matrices ``W``); a real aperture's kernel is centro-symmetric and only half of it is
    computed.

    The normalisation is the open area ``Σ |t|`` (what the antialiased edges cover), not the
    energy the samples diffract into the period, ``C_00 = Σ |t|²``: an edge sample covering a
    fraction ``t`` of its cell passes ``t`` of the light but diffracts only ``t²`` of it into
    the period; the rest, about ``2 / (3 M)`` of the total for a disc ``M`` samples wide,
    goes to angles beyond it, as a sharp edge's does, and is energy outside the kernel. With
    ``C_00`` the centre pixel of a 64-sample pupil was 1.1 % high; with ``Σ |t|`` it is 0.02 %
    off the Airy pattern's.

    An edge antialiased by its signed distance ``s``, ``t = clip(1/2 + s/δ, 0, 1)``
    (:mod:`glarelab.glare.models.apertures`), is the sharp edge convolved across itself with
    a box one sample wide: its spectrum is the sharp edge's times ``sinc(f_n δ)``, ``f_n`` the
    frequency along the edge's normal. Far from the centre the pattern of a smooth edge comes
    from the points whose normal is along the direction of view (stationary phase), so the
    samples' pattern is the described aperture's times ``sinc²(f δ)``, ``f = θ / λ``: at the
    border of a kernel half the PSF's period wide, ``f δ = 1/4``, 19 % dim; in its corners
    35 %. ``edge_transfer=True`` divides it out at each pixel's centre (its variation over a
    pixel is of order ``(β p)²`` where the pattern is smooth across the pixel). With
    ``transfer_parts = n > 1`` a prefilter's transfer, separable, is divided out inside the
    matrices ``W`` instead: ``W_{ck} = Σ_s \\mathrm{sinc}(k β p / n)\\,
    e^{-2π i k β c_s} / (n Φ²(c_s β))`` over the ``n`` parts of the pixel centred at ``c_s``
    (the same number of products): where the pattern varies strongly within a pixel (a
    grating's order inside a border pixel), the transfer's slope across the pixel matters
    to first order.

    Examples
    --------
    >>> grid = ap.ApertureGrid(128, 3.0 / 64)
    >>> acf = aperture_autocorrelation(ap.aperture_pupil(grid, 3.0), grid.spacing_mm)
    >>> k = pixel_integrated_psf(acf, 530.0, 0.0118, (21, 21))
    >>> round(float(k[10, 10]), 3)  # the Airy pattern averaged over the pixel: 0.6292
    0.629
    """
    from glarelab.glare.models.digitise import check_kernel_shape

    wavelength = check_in_range("wavelength_nm", wavelength_nm, *WAVELENGTH_RANGE_NM, unit="nm")
    pixel = check_pixel_deg(pixel_deg)
    height, width = check_kernel_shape(shape)
    ap.prefilter_weights(prefilter)
    beta_p = acf.spacing_mm / (wavelength * _MM_PER_NM) * math.radians(pixel)  # periods/pixel
    period_px = 1.0 / beta_p
    if period_px < 2.0:
        raise ValueError(
            f"pixel_deg {pixel:g}° is wider than half the PSF's period "
            f"({math.degrees(wavelength * _MM_PER_NM / acf.spacing_mm) / 2:.3g}° = λ / 2δ): "
            "sample the aperture finer (smaller spacing_mm)"
        )
    largest = period_px / 2.0 - 0.5
    reach_px = largest if reach_deg is None else min(largest, reach_deg / pixel)
    half_h = min(height // 2, math.floor(reach_px))
    half_w = min(width // 2, math.floor(reach_px))
    c = acf.values
    real = not np.iscomplexobj(c)
    rows_px = np.arange(-half_h, half_h + 1, dtype=float)
    row_lags = np.arange(c.shape[0]) - c.shape[0] // 2
    col_lags = np.arange(c.shape[1]) - c.shape[1] // 2
    # a prefilter's separable transfer is divided out inside the pixel integral (W below)
    parts = check_positive_int("transfer_parts", transfer_parts)
    within = None
    if edge_transfer and tuple(prefilter) != ap.PREFILTER_BOX and parts > 1:
        within = tuple(prefilter)
    if real:  # centro-symmetric: fold the lags, and columns 0 .. half_w suffice
        even, odd = acf.folded
        cos_y, sin_y = _phase_matrices(row_lags[row_lags >= 0], beta_p, rows_px, within, parts)
        sin_y = sin_y[:, 1:]
        cols_px = np.arange(0, half_w + 1, dtype=float)
    else:
        cos_y, sin_y = _phase_matrices(row_lags, beta_p, rows_px, within, parts)
        cols_px = np.arange(-half_w, half_w + 1, dtype=float)
    block = max(1, _BLOCK_ELEMENTS // max(c.shape[0], 1))
    part = np.empty((rows_px.size, cols_px.size))
    for start in range(0, cols_px.size, block):
        centres = cols_px[start : start + block]
        if real:
            cos_x, sin_x = _phase_matrices(col_lags[col_lags >= 0], beta_p, centres, within, parts)
            value = cos_y @ (even @ cos_x.T) - sin_y @ (odd @ sin_x[:, 1:].T)
        else:  # Re[(Wc - i Ws)_y (Cr + i Ci) (Wc - i Ws)_xᵀ]
            cos_x, sin_x = _phase_matrices(col_lags, beta_p, centres, within, parts)
            cr, ci = c.real, c.imag
            value = cos_y @ (cr @ cos_x.T - ci @ sin_x.T) - sin_y @ (cr @ sin_x.T + ci @ cos_x.T)
        part[:, start : start + block] = value
    part *= beta_p**2 / acf.open_samples
    if edge_transfer and tuple(prefilter) == ap.PREFILTER_BOX:
        # sinc²(f δ) of the antialiased edges, f δ = ρ β p at ρ pixels
        radius_px = np.hypot(rows_px[:, None], cols_px[None, :])
        part /= np.sinc(radius_px * beta_p) ** 2
    elif edge_transfer and within is None:
        along_rows = ap.prefilter_transfer(rows_px * beta_p, prefilter) ** 2
        along_cols = ap.prefilter_transfer(cols_px * beta_p, prefilter) ** 2
        part /= along_rows[:, None] * along_cols[None, :]
    if real:
        part = np.concatenate([part[::-1, :0:-1], part], axis=1)
    out = np.zeros((height, width))
    out[
        height // 2 - half_h : height // 2 + half_h + 1,
        width // 2 - half_w : width // 2 + half_w + 1,
    ] = part
    return np.maximum(out, 0.0)


def psf_pixel_integrated(
    aperture: np.ndarray,
    spacing_mm: float,
    wavelength_nm: float,
    pixel_deg: float,
    shape: tuple[int, int],
    *,
    fresnel_distance_mm: float | None = None,
    reach_deg: float | None = None,
    edge_transfer: bool = False,
) -> np.ndarray:
    """Monochromatic Fraunhofer PSF of an aperture, integrated exactly over each pixel.

    The aperture (and the Fresnel term, if given) are those of :func:`psf_fraunhofer`; the
    result is :func:`pixel_integrated_psf` of their autocorrelation.

    Parameters
    ----------
    aperture
        ``(N, N)`` amplitude transmittance in [0, 1], centred at ``N // 2``.
    spacing_mm
        Sample spacing of the aperture in mm, > 0.
    wavelength_nm
        Wavelength in nm, 380-780.
    pixel_deg
        Pixel size, degrees, > 0.
    shape
        Odd kernel shape ``(KH, KW)``.
    fresnel_distance_mm
        If given, Luidolt's Fresnel term with this distance, as for :func:`psf_fraunhofer`;
        default None.
    reach_deg
        As for :func:`pixel_integrated_psf`; default None: the largest.
    edge_transfer
        Divide out the transfer of the aperture's antialiased edges, as for
        :func:`pixel_integrated_psf`. Default False.

    Returns
    -------
    numpy.ndarray
        ``shape``: the fraction of the light through the aperture that falls in each pixel.

    Raises
    ------
    ValueError
        As :func:`psf_fraunhofer` and :func:`pixel_integrated_psf`.

    Examples
    --------
    >>> grid = ap.ApertureGrid(128, 0.05)
    >>> k = psf_pixel_integrated(ap.aperture_pupil(grid, 4.0), 0.05, 550.0, 0.002, (61, 61))
    >>> round(float(k.sum()), 2)  # Airy: 98 % within a square of 0.061° (7.7 λ/D) of 4 mm
    0.98
    """
    t = ap.aperture_from_image(aperture)
    spacing = check_positive("spacing_mm", spacing_mm, unit="mm")
    wavelength = check_in_range("wavelength_nm", wavelength_nm, *WAVELENGTH_RANGE_NM, unit="nm")
    field_: np.ndarray = t
    if fresnel_distance_mm is not None:
        field_ = _fresnel_field(t, spacing, wavelength, fresnel_distance_mm)
    acf = aperture_autocorrelation(field_, spacing)
    return pixel_integrated_psf(
        acf, wavelength, pixel_deg, shape, reach_deg=reach_deg, edge_transfer=edge_transfer
    )
