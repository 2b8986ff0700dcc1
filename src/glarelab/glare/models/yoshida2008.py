"""The Gaussian glare kernel of Yoshida et al. 2008 (Method I): :class:`GaussianGlare`."""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np

from glarelab.glare._validation import check_choice, check_positive
from glarelab.glare.models.base import GlareModel, TailBound
from glarelab.glare.models.digitise import (
    Kernel,
    check_kernel_shape,
    gaussian_pixel_energies,
)

__all__ = ["SIGMA_DEG_YOSHIDA2008", "GaussianGlare"]

SIGMA_DEG_YOSHIDA2008 = 0.34  # Yoshida 2008 §3: σ = 0.34 visual degrees (Method I)
MAX_SIGMA_DEG = 90.0  # as the command line: a halo wider than the visual field is a typo


@dataclass(frozen=True)
class GaussianGlare(GlareModel):
    """Gaussian glare kernel of Yoshida et al. 2008 (Method I).

    Parameters
    ----------
    sigma_deg
        Standard deviation in visual degrees, > 0; default 0.34 (Yoshida §3).
    sampling
        ``'point'`` samples eq. 2 at pixel centres, as the paper does; ``'pixel'`` integrates
        the Gaussian over each pixel (exact; use it when σ is only a few pixels).

    Notes
    -----
    .. math:: F(x, y) = \\frac{1}{k} \\exp\\Bigl(-\\frac{x^2 + y^2}{2\\sigma^2}\\Bigr)

    with ``x, y`` pixel offsets, ``σ`` in pixels ``= sigma_deg / pixel_deg``, and ``k`` the sum
    of all kernel elements, so the kernel sums to 1 and the truncated tail (reported in
    ``Kernel.description['truncated_tail']``) is redistributed over the support, not lost.

    References
    ----------
    Yoshida et al. 2008, eq. 2 and §3.

    Examples
    --------
    >>> k = GaussianGlare(sigma_deg=0.34).kernel(0.034, (41, 41))
    >>> round(float(k.values.sum()), 12), k.description["sigma_px"]
    (1.0, 10.0)
    """

    sigma_deg: float = SIGMA_DEG_YOSHIDA2008
    sampling: Literal["point", "pixel"] = "point"

    def __post_init__(self) -> None:
        check_positive("sigma_deg", self.sigma_deg, unit="deg")
        if self.sigma_deg > MAX_SIGMA_DEG:
            raise ValueError(
                f"sigma_deg must be at most {MAX_SIGMA_DEG:g} deg (a halo wider than the visual "
                f"field); got {self.sigma_deg!r}"
            )
        check_choice("sampling", self.sampling, ("point", "pixel"))

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

        Exact for the separable kernel: the largest pixel outside is ``a[r+1] a[0]`` and the
        energy outside ``1 - (Σ_{|i|≤r} a_i)²`` for the normalised 1-D profile ``a``. The cut
        kernel is normalised over its support (eq. 2's ``k``), so it is marked renormalised.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, > 0.
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
            Exact bounds, marked renormalised.
        """
        pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
        radius = np.asarray(radius_px, dtype=np.int64)
        sigma_px = self.sigma_deg / pixel_deg
        n = int(radius.max()) + 2 + math.ceil(12 * sigma_px)
        if self.sampling == "point":
            profile = np.exp(-(np.arange(n + 1, dtype=float) ** 2) / (2.0 * sigma_px**2))
        else:
            profile = gaussian_pixel_energies(self.sigma_deg * math.sqrt(2.0), pixel_deg, n)
        profile = profile / (2.0 * profile.sum() - profile[0])
        inside = 2.0 * np.cumsum(profile) - profile[0]  # Σ_{|i|≤r} a_i
        return TailBound(
            peak=profile[radius + 1] * profile[0],
            energy=np.clip(1.0 - inside[radius] ** 2, 0.0, 1.0),
            renormalised=True,
        )

    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        """Digitise the Gaussian for pixels of ``pixel_deg`` degrees into an odd ``shape``.

        ``colour`` is accepted for a uniform interface: the Gaussian is achromatic, so the same
        2-D kernel serves every channel.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, > 0.
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
        pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
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
        rows, cols = (p / (2.0 * p.sum() - p[0]) for p in profiles)
        reach = [(n // 2 + 0.5) * pixel_deg / (self.sigma_deg * math.sqrt(2.0)) for n in shape]
        tail = 1.0 - math.erf(reach[0]) * math.erf(reach[1])
        return Kernel(
            quadrant=np.outer(rows, cols),
            pixel_deg=pixel_deg,
            energy_outside=0.0,
            quadrature_error=0.0,
            description={
                "model": "GaussianGlare",
                **asdict(self),
                "sigma_px": sigma_px,
                "truncated_tail": tail,
            },
        )
