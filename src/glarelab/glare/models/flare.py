"""Flare lines: the radial streaks of the ciliary corona and the lenticular halo.

Spencer et al. (1995), §3.2: random antialiased radial lines of random intensity in [0, 1] are
drawn on an image the size of the filter, adjusted to an average of 1.0 in every small
neighbourhood, and multiplied into the smooth PSF, which keeps the PSF's macroscopic shape.
The corona (``f1``, ``f2``) and the halo (``f3``) get independent sets of lines, as they have
different physical causes.

Here "every small neighbourhood" is every ring about the centre: the pattern at radius ``r``
is divided by its mean around that ring, computed in closed form. A line of width ``w`` pixels
covers an angle ``w / r`` at radius ``r``, so the normalised streaks brighten with distance,
as Spencer describes. Lines are triangles across their width (antialiased); triangles of unit
width sampled at unit spacing sum to exactly their area, so the pixel average around a ring
equals the continuous mean.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from glarelab.files.values import check_generator
from glarelab.glare._validation import check_positive, check_positive_int
from glarelab.glare.models.digitise import check_kernel_shape

__all__ = ["CORONA_LINES", "HALO_LINES", "MAX_FLARE_LINES", "flare_line_pattern"]

# Spencer 1995 §3.2 chose the number of lines "to visually match Simpson's observations";
# these counts give the look of Simpson's drawing (Spencer Fig. 2) at typical kernel sizes.
CORONA_LINES = 150
HALO_LINES = 300
# glarelab's bound: a million lines are 72 MB of sorted angles and sums, and already a smooth
# ring (the pattern tends to 1 as the lines fill every angle); 1e9 took all memory
MAX_FLARE_LINES = 1_000_000


def flare_line_pattern(
    shape: Sequence[int],
    *,
    rng: np.random.Generator,
    n_lines: int,
    line_width_px: float = 1.0,
) -> np.ndarray:
    """Random radial lines with mean 1 around every ring about the centre.

    Parameters
    ----------
    shape
        Odd kernel shape ``(KH, KW)``; the lines radiate from the centre pixel.
    rng
        Source of randomness: line angles uniform in [0, 2π), intensities uniform in [0, 1].
    n_lines
        Number of lines, 1 to :data:`MAX_FLARE_LINES`.
    line_width_px
        Full width of a line at its base in pixels (triangular profile); default 1.

    Returns
    -------
    numpy.ndarray
        Pattern of shape ``shape``, >= 0, with mean 1 around every circle about the centre
        (exactly, for the continuous pattern); 1 within ``line_width_px / π`` of the centre,
        where the lines cover every angle.

    Raises
    ------
    ValueError
        For a shape that is not two odd positive integers, an ``rng`` that is not a
        ``numpy.random.Generator``, or a count or width out of range.

    Notes
    -----
    At radius ``r`` and angle ``φ`` the lines give
    ``A(r, φ) = Σ_k u_k max(0, 1 - r |φ - φ_k| / w)`` with mean around the ring
    ``m(r) = (w / 2π r) Σ_k u_k``; the pattern is ``A / m``. Sums over the lines within
    ``w / r`` of ``φ`` come from prefix sums over the sorted angles, so the cost is
    ``O(pixels · log lines)``.

    References
    ----------
    Spencer et al. 1995, §3.2 and Fig. 10.

    Examples
    --------
    >>> p = flare_line_pattern((101, 101), rng=np.random.default_rng(0), n_lines=50)
    >>> p.shape, bool(p.min() >= 0)
    ((101, 101), True)
    """
    check_generator(rng)
    n_lines = check_positive_int("n_lines", n_lines)
    if n_lines > MAX_FLARE_LINES:
        raise ValueError(
            f"n_lines must be at most {MAX_FLARE_LINES:,} (so many lines are a smooth ring "
            f"already); got {n_lines:,}"
        )
    width = check_positive("line_width_px", line_width_px, unit="px")
    height, breadth = check_kernel_shape(shape)
    angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, n_lines))
    intensity = rng.uniform(0.0, 1.0, n_lines)
    # periodic copies so that windows crossing 0 or 2π need no special case
    phi_k = np.concatenate([angles - 2 * np.pi, angles, angles + 2 * np.pi])
    u_k = np.tile(intensity, 3)
    cum_u = np.concatenate([[0.0], np.cumsum(u_k)])
    cum_uphi = np.concatenate([[0.0], np.cumsum(u_k * phi_k)])

    y, x = np.mgrid[-(height // 2) : height // 2 + 1, -(breadth // 2) : breadth // 2 + 1]
    radius = np.hypot(x, y).astype(float)
    phi = np.mod(np.arctan2(y, x), 2 * np.pi)
    inner = radius <= width / np.pi  # the triangles would span more than a full turn
    r = np.where(inner, 1.0, radius)
    half_angle = width / r
    lo = np.searchsorted(phi_k, phi - half_angle, side="left")
    mid = np.searchsorted(phi_k, phi, side="right")
    hi = np.searchsorted(phi_k, phi + half_angle, side="right")
    # Σ u_k (1 - r|φ - φ_k|/w) = Σ u_k - (r/w) Σ u_k |φ - φ_k|, split left/right of φ
    left_u, right_u = cum_u[mid] - cum_u[lo], cum_u[hi] - cum_u[mid]
    left_up, right_up = cum_uphi[mid] - cum_uphi[lo], cum_uphi[hi] - cum_uphi[mid]
    distance_sum = (phi * left_u - left_up) + (right_up - phi * right_u)
    lines = (left_u + right_u) - (r / width) * distance_sum
    ring_mean = width / (2 * np.pi * r) * intensity.sum()
    pattern = np.maximum(lines, 0.0) / ring_mean
    return np.where(inner, 1.0, pattern)
