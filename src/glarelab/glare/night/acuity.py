"""Loss of visual acuity in the dark, and the spatially varying blur that shows it.

**Acuity.** Larson et al. (1997) fitted the finest grating the eye resolves at a luminance
(Shlaer's 1937 foveal data); Luidolt 2020 prints the fit as eq. 5.14:

.. math:: R(Y) = 17.25 \\arctan(1.4 \\log_{10} Y + 0.35) + 25.72 \\quad \\text{cycles/deg}

(about 50 cycles/deg in daylight, 7.4 at the 0.03 cd/m² where cone vision ends).

**Blur.** A pixel is blurred by a Gaussian of a standard deviation that follows from its
luminance; in visual degrees, so the blur is the same on any display. Two variants
(:func:`blur_sigma_deg`):

- ``'Krawczyk2005'``: eq. 5.15, ``σ = width / (fov · 1.86 · √2 · R(Y))`` pixels, which is
  ``σ = 1 / (1.86 √2 R(Y))`` degrees (Krawczyk et al. 2005, as Luidolt prints it; Luidolt
  calls it a variance, it is used as the standard deviation).
- ``'Luidolt2020'``: Luidolt's faster fit, eq. 5.16, ``σ = max(1 - L, 0)`` pixels of his
  headset, with ``L`` the CIE 1976 lightness of ``Y`` for a white of 100 cd/m² (eq. 5.17: the
  headset's 13.85 pixels per degree resolve what the eye resolves at ``L = 1.31``, which holds
  for that white only). In degrees: ``σ = max(1 - L, 0) / 13.85``.

**Applying it** (:func:`varying_blur`): each output pixel is the Gaussian-weighted mean of
its neighbours with its own σ (Luidolt §5.3.1, Fig. 5.9: the kernel of the pixel blurred),
normalised over the pixels inside the image. Three ways:

- ``'exact'``: that sum, pixel by pixel; costs ``(2r + 1)²`` passes over the image for the
  largest radius ``r = ⌊4 σ_max + ½⌋``: the reference.
- ``'layers'`` (default): the image blurred at a ladder of σ (``levels_per_octave`` per
  octave, scipy's separable Gaussian filter), and each pixel interpolated between the two
  levels around its σ, linearly in variance (the two-Gaussian mixture then has the exact
  second moment). Error measured in ``docs/night-vision.md``.
- ``'separable'``: Luidolt §5.3.3: a horizontal and a vertical 1-D pass, the second pass's σ
  from the horizontally blurred image, as in his shader; ``2 (2r + 1)`` passes.

Luidolt blurs only CIE L* of the image (keeping a*, b*); here every linear channel is
blurred with the same σ, so that light is averaged as light (L* of an HDR image in cd/m²
needs a white that the scene does not have).

References
----------
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, §5.3, eqs. 5.14-5.17,
Figs. 5.8-5.10.
Larson, G. W., Rushmeier, H., Piatko, C. (1997). A visibility matching tone reproduction
operator for high dynamic range scenes. IEEE TVCG 3(4).
Krawczyk, G., Myszkowski, K., Seidel, H.-P. (2005). Perceptual effects in real-time tone
mapping. SCCG '05.
"""

from __future__ import annotations

import itertools
import math
from functools import cache
from typing import Literal

import numpy as np
from scipy import ndimage

from glarelab.glare._colour import colour
from glarelab.glare._validation import (
    check_choice,
    check_image,
    check_in_range,
    check_luminances,
    check_positive,
    check_real,
)

__all__ = [
    "BLUR_METHODS",
    "KRAWCZYK2005_FACTOR",
    "LAB_WHITE_CD_M2_LUIDOLT2020",
    "LARSON1997",
    "MIN_LUMINANCE_CD_M2",
    "SIGMA_METHODS",
    "TRUNCATE",
    "VIVE_PRO_PX_PER_DEG",
    "acuity_blur",
    "acuity_cpd",
    "blur_sigma_deg",
    "layers_error_bound",
    "lightness",
    "luminance_for_acuity",
    "varying_blur",
]

LARSON1997 = (17.25, 1.4, 0.35, 25.72)  # Luidolt eq. 5.14 (Larson et al. 1997): A, B, C, D
KRAWCZYK2005_FACTOR = 1.86 * math.sqrt(2.0)  # Luidolt eq. 5.15 (Krawczyk et al. 2005)
VIVE_PRO_PX_PER_DEG = 1440.0 / 104.0  # Luidolt §5.3.2: 1440 px over a 104° field, 13.85 px/deg
# The white of eq. 5.16's lightness: eq. 5.17 gives L = 1.31 at R = 13.85 only for Y_n = 100
LAB_WHITE_CD_M2_LUIDOLT2020 = 100.0
# Below the absolute threshold of vision (Luidolt §3.3: 1e-6 cd/m²) the acuity is that at the
# threshold: eq. 5.14 falls to 0 cycles/deg at 6.6e-10 cd/m² and is negative below
MIN_LUMINANCE_CD_M2 = 1e-6
TRUNCATE = 4.0  # Gaussians are cut at ⌊4σ + ½⌋ pixels, as scipy.ndimage.gaussian_filter
# the ladder's default: the error within half a code of a 10-bit display on the night street
# (glarelab bench --acuity, docs/night-vision.md: 0.24 codes at 16, 0.75 at 8, 3.3 at 4)
LEVELS_PER_OCTAVE = 16
SIGMA_METHODS = ("Krawczyk2005", "Luidolt2020")
BLUR_METHODS = ("layers", "separable", "exact")
_SMALLEST_LEVEL_PX = 0.25  # below this a sampled Gaussian moves < 3e-4 of a pixel's light


def acuity_cpd(luminance_cd_m2: float | np.ndarray) -> float | np.ndarray:
    """The finest resolvable grating at a luminance, Larson et al.'s fit (Luidolt eq. 5.14).

    Parameters
    ----------
    luminance_cd_m2
        Luminance (adaptation) in cd/m², >= 0; below 1e-6 cd/m² taken as 1e-6.

    Returns
    -------
    float or numpy.ndarray
        Acuity ``R`` in cycles per degree, 0.76 (at 1e-6 cd/m²) to 51.5 (at 1e9 cd/m²).

    Notes
    -----
    .. math:: R(Y) = 17.25 \\arctan(1.4 \\log_{10} Y + 0.35) + 25.72 \\qquad (5.14)

    References
    ----------
    Luidolt 2020, eq. 5.14; Larson et al. 1997.

    Examples
    --------
    >>> round(acuity_cpd(0.03), 2), round(acuity_cpd(100.0), 2)
    (7.44, 47.51)
    """
    y = np.maximum(check_luminances("luminance_cd_m2", luminance_cd_m2), MIN_LUMINANCE_CD_M2)
    a, b, c, d = LARSON1997
    r = a * np.arctan(b * np.log10(y) + c) + d
    return float(r) if np.ndim(luminance_cd_m2) == 0 else r


def luminance_for_acuity(cpd: float | np.ndarray) -> float | np.ndarray:
    """The luminance at which the eye resolves ``cpd`` cycles per degree: eq. 5.14 inverted
    (Luidolt eq. 5.17 before its lightness conversion).

    Parameters
    ----------
    cpd
        Acuity in cycles per degree, in (0, 52.776): eq. 5.14's range above 0 cd/m²
        (0-52.82) up to where its luminance, growing without bound towards 52.82, leaves the
        range of a float (about 1.8e308 cd/m²).

    Returns
    -------
    float or numpy.ndarray
        Luminance in cd/m².

    Raises
    ------
    ValueError
        For a ``cpd`` outside the range, or a string, bool, complex number or masked array.

    Notes
    -----
    .. math:: Y = \\exp\\bigl(-1.64 \\tan(1.49 - 0.06 R) - 0.575646\\bigr) \\qquad (5.17)

    as printed, with its constants rounded (``ln 10 / 1.4``, ``25.72 / 17.25``,
    ``1 / 17.25``); here the exact inverse is used (the rounded one gives 0.158 cd/m²,
    L = 1.43, at R = 13.85; the exact one 0.1455 cd/m², L = 1.31 as Luidolt states).

    Examples
    --------
    >>> round(luminance_for_acuity(13.85), 4)  # the headset's 13.85 px/deg
    0.1455
    """
    r = check_real("cpd", cpd)
    a, b, c, d = LARSON1997
    # eq. 5.14's asymptote, a π/2 + D = 52.82, less the last cycles/deg whose luminance is
    # beyond a float: 10^((tan((R − D)/A) − C)/B) < 1.8e308
    high = a * math.atan(c + b * math.log10(np.finfo(float).max)) + d
    if not np.isfinite(r).all() or (r <= 0).any() or (r >= high).any():
        raise ValueError(
            f"cpd must be in (0, {high:.5g}) cycles/deg (eq. 5.14's range, its luminance "
            f"finite); got {cpd!r}"
        )
    y = 10.0 ** ((np.tan((r - d) / a) - c) / b)
    return float(y) if np.ndim(cpd) == 0 else y


def lightness(luminance_cd_m2, *, white_cd_m2: float = LAB_WHITE_CD_M2_LUIDOLT2020):
    """CIE 1976 lightness L* of a luminance for a white of ``white_cd_m2`` (colour-science).

    Parameters
    ----------
    luminance_cd_m2
        Luminance, cd/m², >= 0, a number or an array.
    white_cd_m2
        The luminance of the white (L* = 100), cd/m², > 0; default
        :data:`LAB_WHITE_CD_M2_LUIDOLT2020`.

    Returns
    -------
    float or numpy.ndarray
        L*, 0-100 for luminances up to the white, the shape of ``luminance_cd_m2``.

    Examples
    --------
    >>> round(lightness(luminance_for_acuity(13.85)), 2)  # Luidolt §5.3.2: "approximately 1.31"
    1.31
    """
    y = check_luminances("luminance_cd_m2", luminance_cd_m2)
    white = check_positive("white_cd_m2", white_cd_m2, unit="cd/m²")
    value = colour.colorimetry.lightness_CIE1976(y / white * 100.0, 100.0)
    return float(value) if np.ndim(luminance_cd_m2) == 0 else np.asarray(value)


def blur_sigma_deg(
    luminance_cd_m2: float | np.ndarray,
    *,
    method: Literal["Krawczyk2005", "Luidolt2020"] = "Krawczyk2005",
) -> float | np.ndarray:
    """Standard deviation of the acuity blur at a luminance, in visual degrees.

    Parameters
    ----------
    luminance_cd_m2
        Luminance in cd/m², >= 0.
    method
        ``'Krawczyk2005'`` (default, eq. 5.15 from Larson's acuity) or ``'Luidolt2020'``
        (eq. 5.16, Luidolt's linear fit in lightness, his headset's pixels made degrees).

    Returns
    -------
    float or numpy.ndarray
        σ in degrees, >= 0.

    Notes
    -----
    .. math::

       \\sigma_{K} = \\frac{1}{1.86 \\sqrt{2} \\, R(Y)} \\quad (5.15), \\qquad
       \\sigma_{L} = \\frac{\\max(1 - L^*(Y), 0)}{13.85} \\quad (5.16)

    References
    ----------
    Luidolt 2020, eqs. 5.15-5.17, Fig. 5.8; Krawczyk et al. 2005.

    Examples
    --------
    >>> round(blur_sigma_deg(0.03), 4), round(blur_sigma_deg(0.0, method="Luidolt2020"), 4)
    (0.0511, 0.0722)
    """
    check_choice("method", method, SIGMA_METHODS)
    if method == "Krawczyk2005":
        sigma = 1.0 / (KRAWCZYK2005_FACTOR * np.asarray(acuity_cpd(luminance_cd_m2)))
    elif method == "Luidolt2020":
        sigma = np.maximum(1.0 - np.asarray(lightness(luminance_cd_m2)), 0.0)
        sigma = sigma / VIVE_PRO_PX_PER_DEG
    else:
        raise ValueError(f"method must be one of {SIGMA_METHODS}; got {method!r}")
    return float(sigma) if np.ndim(luminance_cd_m2) == 0 else sigma


def acuity_blur(
    image_cd_m2: np.ndarray,
    *,
    pixel_deg: float,
    method: Literal["Krawczyk2005", "Luidolt2020"] = "Krawczyk2005",
    blur: Literal["layers", "separable", "exact"] = "layers",
    space: Literal["lightness", "linear"] = "lightness",
    white_cd_m2: float | None = None,
    luminance_scale: float = 1.0,
    levels_per_octave: int | None = None,
    colourspace: str = "ITU-R BT.709",
) -> np.ndarray:
    """The image as the dark-adapted eye resolves it: each pixel blurred by the σ of its
    luminance.

    Parameters
    ----------
    image_cd_m2
        ``(H, W)`` luminance or ``(H, W, 3)`` linear RGB (channels in cd/m² of a white of
        equal R, G, B), finite and >= 0.
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    method
        How σ follows from luminance (:func:`blur_sigma_deg`).
    blur
        How the varying blur is applied (:func:`varying_blur`): ``'layers'`` (default),
        ``'separable'`` (Luidolt §5.3.3, the second pass's σ from the first pass's image),
        ``'exact'``.
    space
        ``'lightness'`` (default, Luidolt §5.3.1): CIE L* is blurred and a*, b* kept, for a
        white of ``white_cd_m2`` (channels clipped at 0 where a kept chroma does not fit a
        lower lightness); ``'linear'``: every channel is blurred as light.
    white_cd_m2
        The white of L*, a*, b*, cd/m² (in the image's units), for ``space='lightness'``;
        default None: 100 (eq. 5.16's). Refused with ``space='linear'``, which has no white.
    luminance_scale
        The scene luminance σ follows from is the image's luminance times this; default 1
        (the image is the scene). The night pipeline blurs a display image: 1 / exposure.
    levels_per_octave
        Levels of the ``'layers'`` ladder per doubling of σ; default None: 16
        (:data:`LEVELS_PER_OCTAVE`: within half a code of a 10-bit display, measured).
        Refused with another ``blur``, which has no ladder.
    colourspace
        The RGB colourspace of an RGB image.

    Returns
    -------
    numpy.ndarray
        The blurred image, same shape, >= 0.

    References
    ----------
    Luidolt 2020, §5.3; Krawczyk et al. 2005.

    Examples
    --------
    >>> image = np.zeros((5, 5))
    >>> image[2, 2] = 1.0  # a point in the dark: it stays sharp, the dark around it does not
    >>> out = acuity_blur(image, pixel_deg=0.05, space="linear")
    >>> round(float(out[2, 2]), 3), round(float(out[0, 0]), 3)
    (0.999, 0.041)
    """
    image = check_image("image_cd_m2", image_cd_m2, channels=(3,))
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    scale = check_positive("luminance_scale", luminance_scale)
    check_choice("space", space, ("lightness", "linear"))
    check_choice("blur", blur, BLUR_METHODS)
    if white_cd_m2 is not None and space == "linear":  # options that would act on nothing
        raise ValueError(
            f"white_cd_m2={white_cd_m2!r} with space='linear': it is the white of L*a*b*, "
            "which a linear blur does not use; leave it None or blur in space='lightness'"
        )
    if levels_per_octave is not None and blur != "layers":
        raise ValueError(
            f"levels_per_octave={levels_per_octave!r} with blur={blur!r}: it spaces the "
            "'layers' ladder, which that blur does not use; leave it None"
        )
    white = check_positive(
        "white_cd_m2",
        LAB_WHITE_CD_M2_LUIDOLT2020 if white_cd_m2 is None else white_cd_m2,
        unit="cd/m²",
    )
    levels_per_octave = LEVELS_PER_OCTAVE if levels_per_octave is None else levels_per_octave
    check_choice("colourspace", colourspace, sorted(colour.RGB_COLOURSPACES))
    check_choice("method", method, SIGMA_METHODS)
    space_rgb = colour.RGB_COLOURSPACES[colourspace]
    white_xy = space_rgb.whitepoint
    planes_of, image_of, luminance_of = _space(image, space, white, space_rgb, white_xy)

    def sigma_of(luminance: np.ndarray) -> np.ndarray:
        y = np.maximum(np.asarray(luminance, float), 0.0) * scale
        return np.asarray(blur_sigma_deg(y, method=method)) / pixel_deg

    planes = planes_of(image)
    sigma = sigma_of(luminance_of(planes))
    second = (lambda p: sigma_of(luminance_of(p))) if blur == "separable" else None
    out = varying_blur(
        planes, sigma, method=blur, levels_per_octave=levels_per_octave, second_sigma=second
    )
    return np.maximum(image_of(out), 0.0)


def _space(image: np.ndarray, space: str, white: float, space_rgb, white_xy):
    """What is blurred: ``(planes_of(image), image_of(planes), luminance_of(planes))``, the
    planes ``(H, W, C)``."""
    y_row = np.asarray(space_rgb.matrix_RGB_to_XYZ[1], float)
    y_row = y_row / y_row.sum()
    if space == "linear":
        if image.ndim == 2:
            return (lambda i: i[..., None]), (lambda p: p[..., 0]), (lambda p: p[..., 0])
        return (lambda i: i.astype(float)), (lambda p: p), (lambda p: p @ y_row)

    def to_y(lightness_plane: np.ndarray) -> np.ndarray:
        return colour.colorimetry.luminance_CIE1976(lightness_plane, 100.0) / 100.0 * white

    if image.ndim == 2:
        return (
            lambda i: lightness(i, white_cd_m2=white)[..., None],
            lambda p: to_y(p[..., 0]),
            lambda p: to_y(p[..., 0]),
        )
    xyz = colour.RGB_to_XYZ(image / white, space_rgb, apply_cctf_decoding=False)
    lab = colour.XYZ_to_Lab(xyz, white_xy)

    def back(p: np.ndarray) -> np.ndarray:
        blurred = lab.copy()
        blurred[..., 0] = p[..., 0]
        rgb = colour.XYZ_to_RGB(
            colour.Lab_to_XYZ(blurred, white_xy), space_rgb, apply_cctf_encoding=False
        )
        return rgb * white

    return (lambda i: lab[..., :1].copy()), back, (lambda p: to_y(p[..., 0]))


def varying_blur(
    image: np.ndarray,
    sigma_px: np.ndarray,
    *,
    method: Literal["layers", "separable", "exact"] = "layers",
    levels_per_octave: int = 4,
    second_sigma=None,
) -> np.ndarray:
    """Blur each pixel of an image by a Gaussian of its own standard deviation.

    Parameters
    ----------
    image
        ``(H, W)`` or ``(H, W, C)``, finite.
    sigma_px
        ``(H, W)`` standard deviation of each output pixel's Gaussian, pixels, finite, >= 0
        (0: the pixel is kept).
    method
        ``'layers'`` (default), ``'separable'`` or ``'exact'`` (see the module notes).
    levels_per_octave
        ``'layers'``: levels per doubling of σ, 1-64; default 4.
    second_sigma
        ``'separable'``: a function giving the vertical pass's σ from the horizontally
        blurred image (Luidolt); default None: ``sigma_px`` again.

    Returns
    -------
    numpy.ndarray
        The blurred image (float64, same shape).

    Notes
    -----
    .. math:: I'(x) = \\frac{\\sum_{y} g_{\\sigma(x)}(x - y) \\, I(y)}
                          {\\sum_{y} g_{\\sigma(x)}(x - y)}

    over the pixels ``y`` inside the image within ``⌊4σ(x) + ½⌋`` of ``x`` in each axis
    (``'exact'``): each output pixel gathers its neighbourhood with its own σ, so light is
    not conserved where σ varies (a bright point in the dark keeps its light, sharp, and the
    dark pixels around it, blurred wide, gather some of it too). ``'layers'`` replaces
    ``g_σ`` by ``(1 - t) g_a + t g_b`` for the levels
    ``a ≤ σ < b`` around it, ``t = (σ² - a²) / (b² - a²)``: exact wherever σ is a level and in
    every region where the image is linear.

    Examples
    --------
    >>> image = np.zeros((1, 9))
    >>> image[0, 4] = 1.0
    >>> sigma = np.full((1, 9), 1.0)
    >>> exact = varying_blur(image, sigma, method="exact")
    >>> layers = varying_blur(image, sigma)
    >>> bool(np.allclose(exact, layers)), round(float(exact[0, 4]), 4)
    (True, 0.3989)
    """
    array = np.asarray(image, dtype=float)
    if array.ndim not in (2, 3) or array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"image must be (H, W) or (H, W, C); got shape {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError("image must be finite")
    sigma = np.asarray(sigma_px, dtype=float)
    if sigma.shape != array.shape[:2]:
        raise ValueError(
            f"sigma_px must have the image's shape {array.shape[:2]}; got {sigma.shape}"
        )
    if not np.isfinite(sigma).all() or (sigma < 0).any():
        raise ValueError("sigma_px must be finite and >= 0 pixels")
    check_choice("method", method, BLUR_METHODS)
    planes = array if array.ndim == 3 else array[..., None]
    if method == "exact":
        out = _exact(planes, sigma)
    elif method == "layers":
        levels = int(check_in_range("levels_per_octave", levels_per_octave, 1, 64))
        if levels != levels_per_octave:
            raise ValueError(f"levels_per_octave must be an integer; got {levels_per_octave!r}")
        out = _layers(planes, sigma, levels)
    elif method == "separable":
        horizontal = _pass_1d(planes, sigma, axis=1)
        second = (
            sigma
            if second_sigma is None
            else np.asarray(second_sigma(horizontal if array.ndim == 3 else horizontal[..., 0]))
        )
        out = _pass_1d(horizontal, second, axis=0)
    else:
        raise ValueError(f"method must be one of {BLUR_METHODS}; got {method!r}")
    return out if array.ndim == 3 else out[..., 0]


@cache
def layers_error_bound(levels_per_octave: int = 4) -> float:
    """How far the ``'layers'`` blur may be from the exact one, as a fraction of the image's
    range (largest minus smallest value within reach).

    Parameters
    ----------
    levels_per_octave
        Levels per doubling of σ, 1-64.

    Returns
    -------
    float
        ``max ½ ‖(1 - t) G_a + t G_b - G_σ‖₁`` over the ladder's intervals up to 8 px (beyond,
        the discrete kernels are the continuous ones and the maximum, near 0.6 px, is passed)
        and 49 values of ``t``, times 1.1 for the values between them: with ``K`` summing to
        0, ``|Σ K I| ≤ ½ ‖K‖₁ (max I - min I)``. Kernels cut by the image border are
        renormalised on both sides; ``tests/glare/night/test_acuity.py`` checks the bound there on
        random images.

    Examples
    --------
    >>> [round(layers_error_bound(n), 4) for n in (2, 4, 8)]
    [0.0597, 0.015, 0.0039]
    """
    per_octave = int(check_in_range("levels_per_octave", levels_per_octave, 1, 64))
    worst = 0.0
    for low, high in itertools.pairwise(_levels(8.0, per_octave)):
        reach = int(_radius(high)) + 1
        k_low, k_high = _kernel_2d(low, reach), _kernel_2d(high, reach)
        for t in np.linspace(0.0, 1.0, 49):
            target = _kernel_2d(math.sqrt((1 - t) * low**2 + t * high**2), reach)
            difference = (1 - t) * k_low + t * k_high - target
            worst = max(worst, 0.5 * float(np.abs(difference).sum()))
    return 1.1 * worst


def _kernel_2d(sigma: float, reach: int) -> np.ndarray:
    """The normalised, truncated, sampled 2-D Gaussian of the blur, on ±``reach`` pixels."""
    d = np.arange(-reach, reach + 1, dtype=float)
    if sigma == 0.0:
        k = (d == 0).astype(float)
    else:
        k = np.exp(-(d**2) / (2 * sigma**2)) * (np.abs(d) <= _radius(sigma))
    k /= k.sum()
    return np.outer(k, k)


def _radius(sigma: np.ndarray | float) -> np.ndarray:
    """scipy's truncation radius: ⌊4σ + ½⌋ pixels."""
    return np.floor(TRUNCATE * np.asarray(sigma, float) + 0.5).astype(np.int64)


def _shifted(planes: np.ndarray, dy: int, dx: int) -> tuple[np.ndarray, np.ndarray]:
    """``planes[y + dy, x + dx]`` with zeros outside, and the mask of pixels inside."""
    height, width = planes.shape[:2]
    out = np.zeros_like(planes)
    inside = np.zeros((height, width), dtype=bool)
    rows = slice(max(0, -dy), min(height, height - dy))
    cols = slice(max(0, -dx), min(width, width - dx))
    source_rows = slice(rows.start + dy, rows.stop + dy)
    source_cols = slice(cols.start + dx, cols.stop + dx)
    if rows.start < rows.stop and cols.start < cols.stop:
        out[rows, cols] = planes[source_rows, source_cols]
        inside[rows, cols] = True
    return out, inside


def _weights(sigma: np.ndarray, distance2: float, fits: np.ndarray) -> np.ndarray:
    """Unnormalised Gaussian weight at squared distance ``distance2`` for each pixel's σ,
    0 beyond each pixel's radius (``fits`` says the offset is within it per axis)."""
    if distance2 == 0.0:
        return np.ones_like(sigma)
    with np.errstate(divide="ignore", over="ignore"):
        weight = np.exp(-distance2 / (2.0 * sigma * sigma))  # σ = 0 → exp(-inf) = 0
    return np.where(fits, weight, 0.0)


def _exact(planes: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    reach = _radius(sigma)
    r = int(reach.max())
    total = np.zeros_like(planes)
    norm = np.zeros(sigma.shape)
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            fits = (abs(dy) <= reach) & (abs(dx) <= reach)
            if not fits.any():
                continue
            shifted, inside = _shifted(planes, dy, dx)
            weight = _weights(sigma, float(dy * dy + dx * dx), fits) * inside
            total += weight[..., None] * shifted
            norm += weight
    return total / norm[..., None]


def _pass_1d(planes: np.ndarray, sigma: np.ndarray, *, axis: int) -> np.ndarray:
    reach = _radius(sigma)
    r = int(reach.max())
    total = np.zeros_like(planes)
    norm = np.zeros(sigma.shape)
    for d in range(-r, r + 1):
        fits = abs(d) <= reach
        shifted, inside = _shifted(planes, d if axis == 0 else 0, d if axis == 1 else 0)
        weight = _weights(sigma, float(d * d), fits) * inside
        total += weight[..., None] * shifted
        norm += weight
    return total / norm[..., None]


def _gaussian(planes: np.ndarray, level: float) -> np.ndarray:
    """The image blurred at one σ, normalised over the pixels inside it (the normalisation of
    a separable kernel is the product of its two 1-D ones)."""
    blurred = ndimage.gaussian_filter(
        planes, (level, level, 0), mode="constant", cval=0.0, truncate=TRUNCATE
    )
    rows, cols = (
        ndimage.gaussian_filter1d(np.ones(n), level, mode="constant", cval=0.0, truncate=TRUNCATE)
        for n in planes.shape[:2]
    )
    return blurred / np.multiply.outer(rows, cols)[..., None]


def _levels(largest: float, per_octave: int) -> np.ndarray:
    """0, then σ from 0.25 px up past ``largest`` in steps of 2^(1/per_octave)."""
    if largest <= 0.0:
        return np.zeros(1)
    octaves = math.log2(max(largest, _SMALLEST_LEVEL_PX) / _SMALLEST_LEVEL_PX)
    count = max(1, math.ceil(per_octave * octaves))
    ladder = _SMALLEST_LEVEL_PX * 2.0 ** (np.arange(count + 1) / per_octave)
    return np.concatenate([[0.0], ladder])


def _layers(planes: np.ndarray, sigma: np.ndarray, per_octave: int) -> np.ndarray:
    levels = _levels(float(sigma.max()), per_octave)
    channels = planes.shape[2]
    flat_sigma = sigma.reshape(-1)
    bins = np.searchsorted(levels, flat_sigma, side="left")  # σ in (levels[k-1], levels[k]]
    order = np.argsort(bins, kind="stable")
    starts = np.concatenate([[0], np.cumsum(np.bincount(bins, minlength=levels.size))])
    out = planes.reshape(-1, channels).copy()  # σ = 0 (bin 0): kept as it is
    below = planes.reshape(-1, channels)  # the image at the level below (level 0: itself)
    for k in range(1, levels.size):
        members = order[starts[k] : starts[k + 1]]
        needed = members.size or starts[k + 1] < starts[-1]
        if not needed:
            break
        above = _gaussian(planes, float(levels[k])).reshape(-1, channels)
        if members.size:
            low, high = levels[k - 1], levels[k]
            t = ((flat_sigma[members] ** 2 - low**2) / (high**2 - low**2))[:, None]
            out[members] = (1.0 - t) * below[members] + t * above[members]
        below = above
    return out.reshape(planes.shape)


def _layers_at(
    planes: np.ndarray, sigma: np.ndarray, rows: np.ndarray, cols: np.ndarray, per_octave: int
) -> np.ndarray:
    """The ``'layers'`` blur of :func:`varying_blur` at the pixels ``(rows, cols)`` only.

    ``planes`` is ``(H, W, C)``; ``sigma`` the ``(n,)`` σ of the chosen pixels. Each pixel
    is the interpolation of :func:`_layers` between its two levels, each level's normalised,
    truncated Gaussian summed over the pixel's neighbourhood directly (``(2r + 1)²``
    products per pixel and level): for a few pixels of a large image, far less work than
    blurring the whole image at every level, with the same numbers.
    """
    height, width = planes.shape[:2]
    levels = _levels(float(sigma.max()) if sigma.size else 0.0, per_octave)
    bins = np.searchsorted(levels, sigma, side="left")
    out = planes[rows, cols].astype(float)  # σ = 0: kept
    blurred = bins > 0
    if not blurred.any():
        return out
    low, high = levels[bins - 1], levels[bins]
    t = ((sigma**2 - low**2) / (high**2 - low**2))[:, None]
    reaches = _radius(high)
    for reach in np.unique(reaches[blurred]):  # pixels of one reach together: small patches
        group = np.flatnonzero(blurred & (reaches == reach))
        d = np.arange(-reach, reach + 1)
        y, x = rows[group], cols[group]
        patch = _patches(planes, y, x, int(reach))  # (n, 2r + 1, 2r + 1, C), 0 outside
        inside_rows = ((y[:, None] + d) >= 0) & ((y[:, None] + d) < height)
        inside_cols = ((x[:, None] + d) >= 0) & ((x[:, None] + d) < width)
        blurred_levels = []
        for level_sigma in (low[group], high[group]):
            s = level_sigma[:, None]
            with np.errstate(divide="ignore", invalid="ignore"):
                k = np.exp(-(d * d) / (2.0 * s * s)) * (np.abs(d) <= _radius(s))
            k = np.where(s > 0, k, (d == 0).astype(float))  # level 0: the image itself
            k_rows, k_cols = k * inside_rows, k * inside_cols
            total = np.einsum("nd,ndec,ne->nc", k_rows, patch, k_cols)
            blurred_levels.append(total / (k_rows.sum(1) * k_cols.sum(1))[:, None])
        out[group] = (1.0 - t[group]) * blurred_levels[0] + t[group] * blurred_levels[1]
    return out


def _patches(planes: np.ndarray, rows: np.ndarray, cols: np.ndarray, reach: int) -> np.ndarray:
    """The ``(2 reach + 1)²`` neighbourhoods of the pixels, zero outside the image."""
    height, width = planes.shape[:2]
    d = np.arange(-reach, reach + 1)
    r = rows[:, None, None] + d[None, :, None]
    c = cols[:, None, None] + d[None, None, :]
    inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
    patch = planes[np.clip(r, 0, height - 1), np.clip(c, 0, width - 1)]
    patch[~inside] = 0.0
    return patch
