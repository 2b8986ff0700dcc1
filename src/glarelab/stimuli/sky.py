"""A procedural cloudy sky: the background of the Yoshida et al. (2008) stimuli.

Yoshida et al. used a photograph of a cloudy sky (mean 150 cd/m²) that is not available; this
sky is generated from a seed instead. Its spectrum of cloud sizes is documented and set by the
protocol: Gaussian noise filtered to an amplitude spectrum ``∝ f^-slope`` between the spatial
frequencies of the largest and the smallest cloud structure (``1 / cloud_max_deg`` and
``1 / cloud_min_deg`` cycles/deg, with smooth half-octave edges), mapped through ``exp`` so
that contrast is multiplicative (a log-normal sky, as luminance in natural scenes), scaled to
the wanted mean and RMS contrast, and kept below a ceiling (``L_dmax``: the sky itself must
not glare). The mean is exact after the ceiling is applied.
"""

from __future__ import annotations

import math

import numpy as np

from glarelab.files.values import check_generator

__all__ = ["CONTRAST_TOLERANCE", "cloudy_sky"]

# the RMS contrast a sky delivers may differ from the one asked by sampling (1-2 % at 0.15);
# more means the ceiling cut its clouds, and a stimulus set would state a contrast not shown
CONTRAST_TOLERANCE = 0.1
MEAN_TOLERANCE = 1e-6  # the mean is exact after the ceiling, unless the ceiling cuts too much


def cloudy_sky(
    shape: tuple[int, int],
    *,
    pixel_deg: float,
    rng: np.random.Generator,
    mean_cd_m2: float,
    contrast: float,
    cloud_min_deg: float,
    cloud_max_deg: float,
    slope: float,
    ceiling_cd_m2: float,
) -> np.ndarray:
    """A sky of luminances (cd/m²) with the given mean and spectrum of cloud sizes.

    Gaussian noise is filtered to an amplitude spectrum ``f^-slope`` between the cloud sizes
    (edges half an octave wide), made log-normal with the RMS contrast asked for, then scaled
    to the mean and kept below the ceiling.

    Parameters
    ----------
    shape
        ``(height, width)``, pixels.
    pixel_deg
        Visual angle of one pixel, degrees, > 0.
    rng
        The random generator of the noise (the protocol's seed).
    mean_cd_m2
        The sky's mean luminance, cd/m² (Yoshida et al.'s photograph: 150).
    contrast
        RMS contrast, standard deviation over mean, >= 0.
    cloud_min_deg, cloud_max_deg
        The smallest and largest cloud structures, degrees: the band of spatial frequencies
        ``1 / cloud_max_deg`` to ``1 / cloud_min_deg`` cycles per degree.
    slope
        The exponent of the amplitude spectrum, ``f^-slope``.
    ceiling_cd_m2
        The most any pixel may reach, cd/m² (the display's maximum), above ``mean_cd_m2``.

    Returns
    -------
    numpy.ndarray
        ``shape`` luminances, cd/m².

    Raises
    ------
    ValueError
        For an argument out of its range (a shape of fewer than two pixels a side, an ``rng``
        that is no ``numpy.random.Generator``, a pixel size, mean or ceiling that is not a
        finite number above 0, a contrast that is not a finite number >= 0, a slope that is
        not finite), cloud sizes not in increasing order, a ceiling not above the mean, or
        a sky whose contrast (within :data:`CONTRAST_TOLERANCE`) or mean the ceiling cuts.

    Examples
    --------
    >>> sky = cloudy_sky((64, 64), pixel_deg=0.05, rng=np.random.default_rng(0),
    ...                  mean_cd_m2=150.0, contrast=0.15, cloud_min_deg=0.1,
    ...                  cloud_max_deg=3.0, slope=1.0, ceiling_cd_m2=220.0)
    >>> round(float(sky.mean()), 6), bool(sky.max() <= 220.0)
    (150.0, True)
    """
    check_generator(rng)
    if not (
        isinstance(shape, tuple | list)
        and len(shape) == 2
        and all(isinstance(n, int | np.integer) and not isinstance(n, bool) for n in shape)
        and min(shape) >= 2
    ):
        raise ValueError(f"shape must be two whole numbers of pixels >= 2; got {shape!r}")
    for name, value, low in (
        ("pixel_deg", pixel_deg, "above 0"),
        ("mean_cd_m2", mean_cd_m2, "above 0"),
        ("ceiling_cd_m2", ceiling_cd_m2, "above 0"),
        ("contrast", contrast, ">= 0"),
        ("slope", slope, None),
        ("cloud_min_deg", cloud_min_deg, "above 0"),
        ("cloud_max_deg", cloud_max_deg, "above 0"),
    ):
        number = isinstance(value, int | float | np.integer | np.floating) and not isinstance(
            value, bool | np.bool_
        )
        if not (number and math.isfinite(value)) or (
            low is not None and not (value > 0 if low == "above 0" else value >= 0)
        ):
            allowed = f"a finite number {low}" if low else "a finite number"
            raise ValueError(f"{name} must be {allowed}; got {value!r}")
    if not 0 < cloud_min_deg < cloud_max_deg:
        raise ValueError(
            f"cloud_min_deg = {cloud_min_deg!r} must be above 0 and below cloud_max_deg = "
            f"{cloud_max_deg!r}"
        )
    if not 0 < mean_cd_m2 < ceiling_cd_m2:
        raise ValueError(
            f"mean_cd_m2 = {mean_cd_m2!r} must be above 0 and below ceiling_cd_m2 = "
            f"{ceiling_cd_m2!r} (no sky of that mean stays under it)"
        )
    height, width = shape
    noise = rng.standard_normal(shape)
    fy = np.fft.fftfreq(height, d=pixel_deg)[:, None]
    fx = np.fft.rfftfreq(width, d=pixel_deg)[None, :]
    f = np.hypot(fx, fy)
    low, high = 1.0 / cloud_max_deg, 1.0 / cloud_min_deg
    with np.errstate(divide="ignore"):
        amplitude = np.where(f > 0, f ** (-slope), 0.0)
    # smooth band edges, half an octave wide, in log frequency
    logf = np.log2(np.where(f > 0, f, low))
    edge_low = np.clip((logf - np.log2(low)) / 0.5 + 0.5, 0.0, 1.0)
    edge_high = np.clip((np.log2(high) - logf) / 0.5 + 0.5, 0.0, 1.0)
    spectrum = np.fft.rfft2(noise) * amplitude * edge_low * edge_high
    field = np.fft.irfft2(spectrum, s=shape)
    sd = field.std()
    z = (field - field.mean()) / sd if sd > 0 else np.zeros(shape)
    sigma = np.sqrt(np.log1p(contrast**2))  # log-normal with this RMS contrast
    sky = np.exp(sigma * z - sigma**2 / 2)
    cut = False
    for _ in range(20):  # scale to the mean, then keep under the ceiling, until both hold
        sky *= mean_cd_m2 / sky.mean()
        if sky.max() <= ceiling_cd_m2:
            break
        cut = True
        sky = np.minimum(sky, ceiling_cd_m2)
    sky = np.minimum(sky, ceiling_cd_m2)
    given = float(sky.std() / sky.mean())
    # the contrast a few clouds sample may differ from the one asked; refused only where the
    # ceiling cut the sky to it
    if cut and contrast > 0 and abs(given - contrast) > CONTRAST_TOLERANCE * contrast:
        raise ValueError(
            f"contrast = {contrast:g}: the sky reaches only {given:.3g} under the ceiling of "
            f"{ceiling_cd_m2:.4g} cd/m² at a mean of {mean_cd_m2:g} cd/m² (its bright clouds "
            "are cut); ask a lower contrast or a lower mean"
        )
    if abs(sky.mean() - mean_cd_m2) > MEAN_TOLERANCE * mean_cd_m2:
        raise ValueError(
            f"mean_cd_m2 = {mean_cd_m2:g}: the ceiling of {ceiling_cd_m2:.4g} cd/m² cuts the "
            f"sky to a mean of {sky.mean():.6g} cd/m²; ask a lower contrast or a lower mean"
        )
    return sky
