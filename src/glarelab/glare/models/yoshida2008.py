"""The Gaussian glare kernel of Yoshida et al. 2008 (Method I): :class:`GaussianGlare`."""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np

from glarelab.glare._validation import check_choice, check_pixel_deg, check_positive
from glarelab.glare.models.base import GlareModel, TailBound
from glarelab.glare.models.digitise import (
    Kernel,
    check_kernel_shape,
    gaussian_pixel_energies,
)

__all__ = ["GAUSSIAN_NORMALISATIONS", "SIGMA_DEG_YOSHIDA2008", "GaussianGlare"]

SIGMA_DEG_YOSHIDA2008 = 0.34  # Yoshida 2008 §3: σ = 0.34 visual degrees (Method I)
MAX_SIGMA_DEG = 90.0  # as the command line: a halo wider than the visual field is a typo
MIN_SIGMA_DEG = 1e-5  # as the command line: 0.04 arcsec, far below the eye's resolution
GAUSSIAN_NORMALISATIONS = ("infinite", "Yoshida2008")
_POISSON_FROM_SIGMA_PX = 2.0  # above this σ the Poisson form of the lattice sum is used


def _lattice_sum(sigma_px: float) -> float:
    """``Σ_{i ∈ ℤ} exp(-i² / 2σ²)``, the sum of the point-sampled profile over every integer.

    By Poisson summation it is ``σ √(2π) (1 + 2 Σ_{k≥1} exp(-2π² σ² k²))``; for ``σ >= 2`` px
    the first correction is below 1e-34, so three terms are exact to the last bit. Narrower
    profiles are summed directly over ``|i| <= 40 σ + 2`` (the terms beyond are below e⁻⁸⁰⁰).
    """
    if sigma_px >= _POISSON_FROM_SIGMA_PX:
        k = np.arange(1, 4, dtype=float)
        return (
            sigma_px
            * math.sqrt(2.0 * math.pi)
            * (1.0 + 2.0 * float(np.exp(-2.0 * math.pi**2 * sigma_px**2 * k**2).sum()))
        )
    i = np.arange(1, math.ceil(40.0 * sigma_px) + 3, dtype=float)
    return 1.0 + 2.0 * float(np.exp(-(i**2) / (2.0 * sigma_px**2)).sum())


@dataclass(frozen=True)
class GaussianGlare(GlareModel):
    """Gaussian glare kernel of Yoshida et al. 2008 (Method I).

    Parameters
    ----------
    sigma_deg
        Standard deviation in visual degrees, in [1e-5, 90] (as the command line); default
        0.34 (Yoshida §3).
    sampling
        ``'point'`` samples eq. 2 at pixel centres, as the paper does; ``'pixel'`` integrates
        the Gaussian over each pixel (exact; use it when σ is only a few pixels).
    normalisation
        ``'infinite'`` (default): ``k`` is the sum of eq. 2 over every pixel of the infinite
        plane, so the kernel is the same crop of one Gaussian whatever its size, and the
        light beyond the kernel is booked as ``energy_outside`` (not spread).
        ``'Yoshida2008'``: ``k`` is the sum over the kernel's own elements (eq. 2 as
        printed), so a kernel cut short puts its lost tail back inside: on a ``(2H-1)²``
        kernel the same 0.3° disk then glows 1.82 times as much at its edge in a 33² image
        at 0.0118°/px as in a 271² one.

    Notes
    -----
    .. math:: F(x, y) = \\frac{1}{k} \\exp\\Bigl(-\\frac{x^2 + y^2}{2\\sigma^2}\\Bigr)

    with ``x, y`` pixel offsets and ``σ`` in pixels ``= sigma_deg / pixel_deg``. Yoshida §3:
    "k is a normalization factor computed as the sum of all kernel elements", with ``x, y``
    "from −s/2 to s/2, where s is the stimulus size". Under ``'infinite'``, ``k`` is that sum
    over all integer ``x, y``, ``(Σ_i exp(-i²/2σ²))²`` (:func:`_lattice_sum`; ``2πσ²`` to
    1e-34 for ``σ >= 2`` px); with ``sampling='pixel'`` the pixel energies of the continuous
    Gaussian already sum to 1 over the plane. The truncated tail of the continuous Gaussian
    is reported in ``Kernel.description['truncated_tail']`` under both normalisations.

    References
    ----------
    Yoshida et al. 2008, eq. 2 and §3.

    Examples
    --------
    >>> k = GaussianGlare(sigma_deg=0.34).kernel(0.034, (41, 41))
    >>> round(float(k.values.sum() + k.energy_outside), 12), k.description["sigma_px"]
    (1.0, 10.0)
    >>> round(k.energy_outside, 4)  # the samples beyond ±20 px (±2 σ); continuous: 0.0791
    0.0789
    >>> literal = GaussianGlare(sigma_deg=0.34, normalisation="Yoshida2008")
    >>> round(float(literal.kernel(0.034, (41, 41)).values.sum()), 12)
    1.0
    """

    sigma_deg: float = SIGMA_DEG_YOSHIDA2008
    sampling: Literal["point", "pixel"] = "point"
    normalisation: Literal["infinite", "Yoshida2008"] = "infinite"

    def __post_init__(self) -> None:
        check_positive("sigma_deg", self.sigma_deg, unit="deg")
        if self.sigma_deg > MAX_SIGMA_DEG:
            raise ValueError(
                f"sigma_deg must be at most {MAX_SIGMA_DEG:g} deg (a halo wider than the visual "
                f"field); got {self.sigma_deg!r}"
            )
        if self.sigma_deg < MIN_SIGMA_DEG:
            raise ValueError(
                f"sigma_deg must be at least {MIN_SIGMA_DEG:g} deg (0.04 arcsec, far below the "
                f"eye's resolution); got {self.sigma_deg!r}"
            )
        check_choice("sampling", self.sampling, ("point", "pixel"))
        check_choice("normalisation", self.normalisation, GAUSSIAN_NORMALISATIONS)

    @property
    def achromatic(self) -> bool:
        """The Gaussian is the same in every channel."""
        return True

    def halo(self) -> str:
        return "none in this model"

    def tail_bound(
        self, pixel_deg: float, radius_px: np.ndarray, *, colour: bool = False
    ) -> TailBound:
        """What a kernel cut to a centred square of half-size ``radius_px`` leaves out.

        Exact for the separable kernel: the largest pixel outside is ``max_{i>r} a_i · max a``
        (``a[r+1] a[0]`` where the rounded profile falls) and the energy outside
        ``1 - (Σ_{|i|≤r} a_i)²`` for the normalised 1-D profile ``a``. Under
        ``normalisation='Yoshida2008'`` the cut kernel is normalised over its support (eq. 2's
        ``k``), so it is marked renormalised; under ``'infinite'`` a cut loses that energy.
        The energy is taken as ``t (2 - t)`` with ``t = 2 Σ_{i>r} a_i`` the 1-D profile's tail,
        summed from the outside in: ``1 - (Σ_{|i|≤r} a_i)²`` is 0 in floating point wherever
        the tail is below 1e-16, while a glint of 1e9 cd/m² shows it; what is kept,
        ``(Σ_{|i|≤r} a_i)²``, is summed from the inside out, for the same reason where a
        kernel holds a small share of a wide Gaussian.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        radius_px
            Half-sizes of the centred squares the kernel is cut to, whole pixels (a square spans
            ``2 r + 1`` pixels a side).
        colour
            Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False. The Gaussian is achromatic: the
            bound is the same.

        Returns
        -------
        TailBound
            Exact bounds, marked renormalised under ``'Yoshida2008'``.
        """
        pixel_deg = check_pixel_deg(pixel_deg)
        radius = np.asarray(radius_px, dtype=np.int64)
        sigma_px = self.sigma_deg / pixel_deg
        n = int(radius.max()) + 2 + math.ceil(12 * sigma_px)
        if self.sampling == "point":
            profile = np.exp(-(np.arange(n + 1, dtype=float) ** 2) / (2.0 * sigma_px**2))
        else:
            profile = gaussian_pixel_energies(self.sigma_deg * math.sqrt(2.0), pixel_deg, n)
        total = self._profile_total(sigma_px, profile)
        profile = profile / total
        # the tail t = 2 Σ_{i>r} a_i summed from the outside in, and what lies past the
        # profile's last offset n: nothing under 'Yoshida2008' (normalised over |i| ≤ n), the
        # exact erfc for pixel energies, and for point samples ∫_n^∞ exp(-x²/2σ²) dx, which
        # bounds the samples' sum past n
        beyond = 2.0 * np.cumsum(profile[::-1])[::-1]  # beyond[i] = 2 Σ_{j≥i} a_j
        if self.normalisation == "Yoshida2008":
            past_n = 0.0
        elif self.sampling == "pixel":
            past_n = math.erfc((n + 0.5) / (sigma_px * math.sqrt(2.0)))
        else:
            past_n = (
                sigma_px * math.sqrt(2.0 * math.pi) * math.erfc(n / (sigma_px * math.sqrt(2.0)))
            ) / total
        tail = beyond[radius + 1] + past_n
        inside = 2.0 * np.cumsum(profile) - profile[0]  # Σ_{|i|≤r} a_i, summed outwards
        # the largest a_i a_j with |i| or |j| > r: the largest a_i past r times the largest
        # a_j (the profile falls, but its rounding need not: 1e-13 apart a pixel 1e5 px in)
        after = np.maximum.accumulate(profile[::-1])[::-1]  # after[i] = max_{j≥i} a_j
        return TailBound(
            peak=after[radius + 1] * after[0],
            energy=np.clip(tail * (2.0 - tail), 0.0, 1.0),
            renormalised=self.normalisation == "Yoshida2008",
            kept=inside[radius] ** 2,
        )

    def _profile_total(self, sigma_px: float, profile: np.ndarray) -> float:
        """The 1-D normaliser: over the mirrored ``profile`` (``'Yoshida2008'``) or over every
        integer offset (``'infinite'``: the lattice sum, or 1 for pixel energies)."""
        if self.normalisation == "Yoshida2008":
            return float(2.0 * profile.sum() - profile[0])
        if self.normalisation == "infinite":
            return _lattice_sum(sigma_px) if self.sampling == "point" else 1.0
        raise ValueError(
            f"normalisation must be one of {GAUSSIAN_NORMALISATIONS}; got {self.normalisation!r}"
        )

    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        """Digitise the Gaussian for pixels of ``pixel_deg`` degrees into an odd ``shape``.

        ``colour`` is accepted for a uniform interface: the Gaussian is achromatic, so the same
        2-D kernel serves every channel.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.

        Returns
        -------
        Kernel
            The kernel, each channel summing to its PSF energy inside the support, with its
            energy account.
        """
        pixel_deg = check_pixel_deg(pixel_deg)
        height, width = check_kernel_shape(shape)
        sigma_px = self.sigma_deg / pixel_deg
        if self.sampling == "point" and sigma_px < 1.0:
            warnings.warn(
                f"sigma_deg / pixel_deg = {sigma_px:.3g} px: point sampling under-resolves a "
                "Gaussian narrower than a pixel; use sampling='pixel'",
                UserWarning,
                stacklevel=2,
            )
        profiles = []
        for half in (height // 2, width // 2):
            if self.sampling == "point":
                offsets = np.arange(half + 1, dtype=float)
                profiles.append(np.exp(-(offsets**2) / (2.0 * sigma_px**2)))
            elif self.sampling == "pixel":
                profiles.append(
                    gaussian_pixel_energies(self.sigma_deg * math.sqrt(2.0), pixel_deg, half)
                )
            else:
                raise ValueError(f"sampling must be 'point' or 'pixel'; got {self.sampling!r}")
        # the kernel's sum is the product of the mirrored profiles' sums: normalise those
        # (eq. 2's k); the kernel is their outer product's quadrant, unfolded when used
        rows, cols = (p / self._profile_total(sigma_px, p) for p in profiles)
        reach = [(n // 2 + 0.5) * pixel_deg / (self.sigma_deg * math.sqrt(2.0)) for n in shape]
        tail = 1.0 - math.erf(reach[0]) * math.erf(reach[1])
        if self.normalisation == "infinite":
            inside = (2.0 * rows.sum() - rows[0]) * (2.0 * cols.sum() - cols[0])
            outside = float(min(max(1.0 - inside, 0.0), 1.0))
        else:
            outside = 0.0
        return Kernel(
            quadrant=np.outer(rows, cols),
            pixel_deg=pixel_deg,
            energy_outside=outside,
            quadrature_error=0.0,
            description={
                "model": "GaussianGlare",
                **asdict(self),
                "sigma_px": sigma_px,
                "truncated_tail": tail,
            },
        )
