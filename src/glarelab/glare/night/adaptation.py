"""Temporal eye adaptation: the luminance the eye is adapted to, frame by frame (Luidolt 2020,
§5.1, eqs. 5.1-5.4, after Krawczyk et al. 2005).

The target of adaptation is the mean luminance of what is looked at: the frame's luminance
(eq. 5.1, linear RGB to Y) weighted by a Gaussian window centred on the gaze, so that lights in
the periphery count little (§5.1, the "view-dependent" adaptation). The adapted luminance
follows the target exponentially, with a time constant that moves from the cones' 0.1 s to the
rods' 0.4 s as the rods take over (eqs. 5.2-5.4):

.. math::

   L_i = L_{i-1} + (Y - L_{i-1}) \\bigl(1 - e^{-\\Delta t / \\tau(Y)}\\bigr), \\quad
   \\tau(Y) = \\sigma(Y) \\tau_{rod} + (1 - \\sigma(Y)) \\tau_{cone}, \\quad
   \\sigma(Y) = \\frac{0.04}{0.04 + Y}.

Each step is a convex combination of the previous state and the target, so the adapted
luminance stays between them: it is never negative and never overshoots, from 0 to 1e9 cd/m².

References
----------
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, §5.1, eqs. 5.1-5.4.
Krawczyk, G., Myszkowski, K., Seidel, H.-P. (2005). Perceptual effects in real-time tone
mapping. SCCG '05 (as quoted by Luidolt).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from glarelab.glare._colour import colour
from glarelab.glare._validation import (
    check_choice,
    check_image,
    check_in_range,
    check_luminances,
    check_positive,
    check_real,
    real_number,
)

__all__ = [
    "ABSOLUTE_THRESHOLD_CD_M2",
    "ADAPTATION_MEANS",
    "RGB_TO_Y_LUIDOLT2020",
    "SIGMA_HALF_CD_M2",
    "TAU_CONE_S",
    "TAU_ROD_S",
    "WINDOW_SIGMA_DEG",
    "adaptation_luminance",
    "adaptation_step",
    "adaptation_time_s",
    "frame_luminance",
    "gaze_falloff",
    "luminance",
    "rod_sensitivity",
    "window_mean",
]

TAU_ROD_S = 0.4  # Luidolt 2020 §5.1: adaptation time of the rods
TAU_CONE_S = 0.1  # Luidolt 2020 §5.1: adaptation time of the cones
SIGMA_HALF_CD_M2 = 0.04  # Luidolt 2020 eq. 5.4: rods and cones weigh alike at 0.04 cd/m²
# Luidolt 2020 eq. 5.1 (after Poynton 1998), printed to four decimals; the colour conversions
# here use colour-science's Rec. 709 matrix, which differs from these by at most 2e-4
RGB_TO_Y_LUIDOLT2020 = (0.2125, 0.7154, 0.0721)
# Luidolt §5.1 weights the frame by a Gaussian around the gaze without giving its width; we
# assume σ = 5°, a window whose half maximum (11.8° across) covers the central visual field
WINDOW_SIGMA_DEG = 5.0
ADAPTATION_MEANS = ("log", "arithmetic")  # the adapting luminance's mean over the window
ABSOLUTE_THRESHOLD_CD_M2 = 1e-6  # Luidolt §3.3: human vision spans 1e-6 to 1e8 cd/m²


def luminance(rgb: np.ndarray, *, colourspace: str = "ITU-R BT.709") -> np.ndarray:
    """Luminance of linear RGB (Luidolt eq. 5.1), from colour-science's RGB → XYZ matrix.

    Parameters
    ----------
    rgb
        ``(..., 3)`` linear RGB whose channels are in cd/m² of a white of equal R, G, B.
    colourspace
        A colour-science RGB colourspace; default ``'ITU-R BT.709'`` (D65 white, eq. 5.1).

    Returns
    -------
    numpy.ndarray
        ``(...)`` luminance Y in cd/m².

    Notes
    -----
    .. math:: Y = 0.2125 R + 0.7154 G + 0.0721 B \\qquad (5.1)

    as printed (Poynton 1998); the Rec. 709 row used here is (0.2126, 0.7152, 0.0722).

    References
    ----------
    Luidolt 2020, eq. 5.1.

    Examples
    --------
    >>> float(luminance(np.array([1.0, 1.0, 1.0])))
    1.0
    """
    check_choice("colourspace", colourspace, sorted(colour.RGB_COLOURSPACES))
    weights = np.asarray(colour.RGB_COLOURSPACES[colourspace].matrix_RGB_to_XYZ[1], float)
    weights = weights / weights.sum()  # a white of equal R, G, B has Y = R = G = B
    array = np.asarray(rgb, dtype=float)
    if array.shape[-1:] != (3,):
        raise ValueError(f"rgb must have 3 channels in its last axis; got shape {array.shape}")
    return array @ weights


def rod_sensitivity(luminance_cd_m2: float | np.ndarray) -> float | np.ndarray:
    """Sensitivity of the rods at a luminance, σ(Y) of Luidolt eq. 5.4.

    Parameters
    ----------
    luminance_cd_m2
        Luminance in cd/m², >= 0 (scalar or array).

    Returns
    -------
    float or numpy.ndarray
        σ in (0, 1]: 1 in the dark, 0.5 at 0.04 cd/m², towards 0 in daylight.

    Raises
    ------
    ValueError
        For a negative, NaN or infinite luminance.

    Notes
    -----
    .. math:: \\sigma(Y) = \\frac{0.04}{0.04 + Y} \\qquad (5.4)

    References
    ----------
    Luidolt 2020, eq. 5.4 (after Krawczyk et al. 2005).

    Examples
    --------
    >>> rod_sensitivity(0.04), rod_sensitivity(0.0)
    (0.5, 1.0)
    """
    y = check_luminances("luminance_cd_m2", luminance_cd_m2)
    sigma = SIGMA_HALF_CD_M2 / (SIGMA_HALF_CD_M2 + y)
    return float(sigma) if np.ndim(luminance_cd_m2) == 0 else sigma


def adaptation_time_s(
    luminance_cd_m2: float | np.ndarray,
    *,
    tau_rod_s: float = TAU_ROD_S,
    tau_cone_s: float = TAU_CONE_S,
) -> float | np.ndarray:
    """Time constant of adaptation towards a luminance, τ(Y) of Luidolt eq. 5.3.

    Parameters
    ----------
    luminance_cd_m2
        The luminance adapted to, cd/m², >= 0.
    tau_rod_s, tau_cone_s
        Time constants of rods and cones in seconds, > 0; defaults 0.4 and 0.1 (Luidolt §5.1).

    Returns
    -------
    float or numpy.ndarray
        τ in seconds, between ``tau_cone_s`` and ``tau_rod_s``.

    Notes
    -----
    .. math:: \\tau(Y) = \\sigma(Y) \\tau_{rod} + (1 - \\sigma(Y)) \\tau_{cone} \\qquad (5.3)

    References
    ----------
    Luidolt 2020, eq. 5.3.

    Examples
    --------
    >>> adaptation_time_s(0.04)  # half rods, half cones
    0.25
    """
    tau_rod_s = check_positive("tau_rod_s", tau_rod_s, unit="s")
    tau_cone_s = check_positive("tau_cone_s", tau_cone_s, unit="s")
    sigma = rod_sensitivity(luminance_cd_m2)
    tau = sigma * tau_rod_s + (1.0 - sigma) * tau_cone_s
    return float(tau) if np.ndim(luminance_cd_m2) == 0 else tau


def adaptation_step(
    previous_cd_m2: float,
    target_cd_m2: float,
    frame_time_s: float,
    *,
    tau_rod_s: float = TAU_ROD_S,
    tau_cone_s: float = TAU_CONE_S,
) -> float:
    """One frame of temporal adaptation, Luidolt eq. 5.2.

    Parameters
    ----------
    previous_cd_m2
        Adapted luminance after the previous frame, ``L_{i-1}``, cd/m², >= 0.
    target_cd_m2
        The frame's (windowed) luminance ``Y``, cd/m², >= 0.
    frame_time_s
        Duration of the frame ``ft``, seconds, >= 0.
    tau_rod_s, tau_cone_s
        As for :func:`adaptation_time_s`.

    Returns
    -------
    float
        ``L_i`` in cd/m², between ``previous_cd_m2`` and ``target_cd_m2``.

    Notes
    -----
    .. math:: L_i = L_{i-1} + (Y - L_{i-1}) \\bigl(1 - e^{-ft / \\tau(Y)}\\bigr) \\qquad (5.2)

    References
    ----------
    Luidolt 2020, eq. 5.2.

    Examples
    --------
    >>> round(adaptation_step(1.0, 0.0, 0.4), 6)  # one rod time constant in the dark: 1/e left
    0.367879
    """
    previous = float(check_luminances("previous_cd_m2", previous_cd_m2))
    target = float(check_luminances("target_cd_m2", target_cd_m2))
    frame_time_s = check_in_range("frame_time_s", frame_time_s, 0.0, math.inf, unit="s")
    tau = adaptation_time_s(target, tau_rod_s=tau_rod_s, tau_cone_s=tau_cone_s)
    # the convex combination of eq. 5.2, each weight computed to full precision: never
    # below 0 or past the two luminances, even from 1e9 cd/m² into the dark
    gain = -math.expm1(-frame_time_s / tau)  # 1 - exp(-ft/τ)
    return target * gain + previous * math.exp(-frame_time_s / tau)


def adaptation_luminance(
    targets_cd_m2: np.ndarray,
    frame_time_s: float | np.ndarray,
    *,
    initial_cd_m2: float | None = None,
    tau_rod_s: float = TAU_ROD_S,
    tau_cone_s: float = TAU_CONE_S,
) -> np.ndarray:
    """The adapted luminance after each frame of a sequence (eq. 5.2 applied frame by frame).

    Parameters
    ----------
    targets_cd_m2
        ``(N,)`` windowed luminance of each frame (:func:`frame_luminance`), cd/m², >= 0;
        N >= 1.
    frame_time_s
        Duration of every frame (scalar) or of each frame ``(N,)``, seconds, >= 0.
    initial_cd_m2
        The luminance adapted to before the first frame, cd/m² (e.g. a lit corridor before a
        dark room); default None: adapted to the first frame already.
    tau_rod_s, tau_cone_s
        As for :func:`adaptation_time_s`.

    Returns
    -------
    numpy.ndarray
        ``(N,)`` adapted luminance ``L_i`` after frame ``i``, cd/m².

    Raises
    ------
    ValueError
        For an empty sequence, negative or non-finite luminances or times, a frame time
        that is a string, a bool, a complex number or a masked array, or a frame-time array
        of another length.

    References
    ----------
    Luidolt 2020, eqs. 5.2-5.4.

    Examples
    --------
    >>> steps = adaptation_luminance(np.full(4, 0.04), 0.25, initial_cd_m2=10.0)
    >>> [round(float(v), 3) for v in steps]  # τ(0.04) = 0.25 s: 1/e of the step left per frame
    [3.704, 1.388, 0.536, 0.222]
    """
    targets = check_luminances("targets_cd_m2", targets_cd_m2).reshape(-1)
    if targets.size == 0 or np.ndim(targets_cd_m2) != 1:
        raise ValueError(
            f"targets_cd_m2 must be a 1-D sequence of at least one luminance; got shape "
            f"{np.shape(targets_cd_m2)}"
        )
    frame_times = check_real("frame_time_s", frame_time_s)
    if np.ndim(frame_time_s) not in (0, 1) or (
        np.ndim(frame_time_s) == 1 and np.size(frame_time_s) != targets.size
    ):
        raise ValueError(
            f"frame_time_s must be a number or one per frame ({targets.size}); got shape "
            f"{np.shape(frame_time_s)}"
        )
    times = np.broadcast_to(frame_times, targets.shape)
    if not (np.isfinite(times).all() and (times >= 0).all()):
        raise ValueError(f"frame_time_s must be finite and >= 0 s; got {frame_time_s!r}")
    if initial_cd_m2 is not None:  # named as given, not as adaptation_step's previous state
        initial_cd_m2 = check_in_range("initial_cd_m2", initial_cd_m2, 0.0, math.inf, unit="cd/m²")
    state = float(targets[0]) if initial_cd_m2 is None else initial_cd_m2
    out = np.empty_like(targets)
    for index, (target, step) in enumerate(zip(targets, times, strict=True)):
        state = adaptation_step(
            state, float(target), float(step), tau_rod_s=tau_rod_s, tau_cone_s=tau_cone_s
        )
        out[index] = state
    return out


def frame_luminance(
    image_cd_m2: np.ndarray,
    *,
    pixel_deg: float,
    gaze_px: tuple[float, float] | None = None,
    window_sigma_deg: float = WINDOW_SIGMA_DEG,
    mean: Literal["log", "arithmetic"] = "log",
    colourspace: str = "ITU-R BT.709",
) -> float:
    """The luminance a frame asks the eye to adapt to: its mean, weighted around the gaze
    (Luidolt 2020 §5.1).

    Parameters
    ----------
    image_cd_m2
        ``(H, W)`` luminance or ``(H, W, 3)`` linear RGB, cd/m², finite and >= 0.
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    gaze_px
        ``(row, column)`` where the eye looks, in pixels (may lie outside the image); None
        (default): the whole frame alike, as Krawczyk et al. 2005.
    window_sigma_deg
        Standard deviation of the Gaussian window around the gaze, degrees, > 0 (judged
        without a gaze too); default 5 (an assumption: Luidolt gives no width).
    mean
        ``'log'`` (default): the weighted logarithmic mean, luminances below 1e-6 cd/m² (the
        absolute threshold) taken as 1e-6; ``'arithmetic'``: the weighted mean, as Luidolt
        prints it ("the average"). See Notes.
    colourspace
        The RGB colourspace of an RGB image (eq. 5.1).

    Returns
    -------
    float
        The windowed mean luminance ``Y``, cd/m².

    Notes
    -----
    Luidolt multiplies the frame by the window, downsamples it to 128 × 128, builds a Gaussian
    pyramid down to 16 × 16 and takes the mean: a fast mean on a GPU. Here the weighted mean
    is computed exactly, and divided by the window's mean weight: Luidolt's unnormalised
    product would make a uniform field look darker the further the gaze is from the centre.
    The default is the logarithmic mean (the "key" of Reinhard et al. 2002): in the
    arithmetic mean four pixels of a 5e4 cd/m² lamp outweigh a 0.02 cd/m² street of 1500, and
    the eye would adapt to daylight in the middle of the night.

    .. math:: Y = \\exp \\frac{\\sum_x w(x) \\ln Y(x)}{\\sum_x w(x)}, \\quad
              w(x) = \\exp\\Bigl(-\\frac{|x - g|^2 \\Delta^2}{2 s^2}\\Bigr)

    References
    ----------
    Luidolt 2020, §5.1 and eq. 5.1.

    Examples
    --------
    >>> image = np.full((50, 100), 0.5)
    >>> image[:, 50:] = 2.0
    >>> frame_luminance(image, pixel_deg=0.1)  # exp of the mean of ln 0.5 and ln 2
    1.0
    >>> frame_luminance(image, pixel_deg=0.1, mean="arithmetic")
    1.25
    >>> round(frame_luminance(image, pixel_deg=0.1, gaze_px=(25, 90), window_sigma_deg=1.0), 3)
    2.0
    """
    image = check_image("image_cd_m2", image_cd_m2, channels=(3,))
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    # judged with a gaze or without (where the whole frame is alike): as window_mean judges it
    window_sigma_deg = check_positive("window_sigma_deg", window_sigma_deg, unit="deg")
    check_choice("mean", mean, ADAPTATION_MEANS)
    check_choice("colourspace", colourspace, sorted(colour.RGB_COLOURSPACES))  # grey too
    y = luminance(image, colourspace=colourspace) if image.ndim == 3 else image.astype(float)
    if mean == "log":
        y = np.log(np.maximum(y, ABSOLUTE_THRESHOLD_CD_M2))

    def back(value: float) -> float:
        return float(np.exp(value)) if mean == "log" else float(value)

    if gaze_px is None:
        return back(np.mean(y))
    return back(
        window_mean(y, pixel_deg=pixel_deg, gaze_px=gaze_px, window_sigma_deg=window_sigma_deg)
    )


def window_mean(
    values: np.ndarray,
    *,
    pixel_deg: float,
    gaze_px: tuple[float, float],
    window_sigma_deg: float = WINDOW_SIGMA_DEG,
) -> float:
    """The mean of ``values`` weighted by the Gaussian window around the gaze (Luidolt §5.1).

    :func:`frame_luminance` is this of the frame's (log) luminance; a live renderer takes the
    log luminance once and calls this per frame, with the same numbers.

    Parameters
    ----------
    values
        ``(H, W)`` values per pixel (luminance in cd/m², or its natural log).
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    gaze_px
        ``(row, column)`` where the eye looks, pixels (may lie outside the image).
    window_sigma_deg
        Standard deviation of the window, degrees, > 0; default 5 (an assumption: Luidolt
        gives no width).

    Returns
    -------
    float
        ``Σ w(x) v(x) / Σ w(x)``, in the unit of ``values``.

    Raises
    ------
    ValueError
        For a bad pixel size, window or gaze (a gaze however far off the image is weighted
        relative to its nearest pixel).

    Notes
    -----
    .. math:: w(x) = \\exp\\Bigl(-\\frac{|x - g|^2 \\Delta^2}{2 s^2}\\Bigr)

    separable in rows and columns, so the mean is ``rows @ values @ cols / (Σrows Σcols)``.

    References
    ----------
    Luidolt 2020, §5.1.

    Examples
    --------
    >>> window_mean(np.array([[0.0, 1.0]]), pixel_deg=1.0, gaze_px=(0, 1), window_sigma_deg=1.0)
    0.6224593312018546
    """
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    window_sigma_deg = check_positive("window_sigma_deg", window_sigma_deg, unit="deg")
    y = np.asarray(values)
    if y.ndim != 2 or y.size == 0:
        raise ValueError(f"values must be an (H, W) array of pixels; got shape {y.shape}")
    try:
        row, col = (real_number(v) for v in gaze_px)  # not a bool, a string or an array
    except (TypeError, ValueError):
        raise ValueError(f"gaze_px must be (row, column) in pixels; got {gaze_px!r}") from None
    if not (math.isfinite(row) and math.isfinite(col)):
        raise ValueError(f"gaze_px must be finite; got {gaze_px!r}")
    sigma_px = window_sigma_deg / pixel_deg
    # a gaze farther than 800 σ² beyond an edge weights that edge's pixels alone: the next
    # pixels' weight relative to theirs, exp(-distance / σ²), is below the smallest float;
    # brought that near, the squares below stay finite however far the gaze was
    margin = 800.0 * sigma_px**2 + 1.0
    row = min(max(row, -margin), y.shape[0] - 1 + margin)
    col = min(max(col, -margin), y.shape[1] - 1 + margin)
    row_exponents = -0.5 * ((np.arange(y.shape[0]) - row) / sigma_px) ** 2
    col_exponents = -0.5 * ((np.arange(y.shape[1]) - col) / sigma_px) ** 2
    rows, cols = np.exp(row_exponents), np.exp(col_exponents)
    total = rows.sum() * cols.sum()
    if not total >= np.finfo(float).tiny:  # a gaze far off the frame: its weights underflow
        # relative to the largest weight (the ratio is the same; the nearest pixel's is 1)
        rows = np.exp(row_exponents - row_exponents.max())
        cols = np.exp(col_exponents - col_exponents.max())
        total = rows.sum() * cols.sum()
    return float(rows @ y @ cols / total)


def gaze_falloff(
    shape: tuple[int, int], *, pixel_deg: float, gaze_px: tuple[float, float], sigma_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """The Gaussian falloff around the gaze with which Luidolt blends the glare (§5.2.3, §6.3.3),
    as its row and column factors.

    Parameters
    ----------
    shape
        ``(H, W)`` of the image, pixels.
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    gaze_px
        ``(row, column)`` of the gaze, pixels (may lie off the image).
    sigma_deg
        The falloff's standard deviation, degrees, > 0.

    Returns
    -------
    tuple of numpy.ndarray
        ``(rows (H,), cols (W,))``: the weight of pixel ``(r, c)`` is ``rows[r] · cols[c]``,
        1 at the gaze.

    Raises
    ------
    ValueError
        For a bad pixel size, width or gaze.

    Notes
    -----
    .. math:: w(x) = \\exp\\Bigl(-\\frac{|x - g|^2 \\Delta^2}{2 s^2}\\Bigr)

    "a custom post-processing stage was added, that blends the original (unconvolved) image
    with the bloomed window using a Gaussian falloff" (Luidolt 2020, §6.3.3); he gives no
    width.

    References
    ----------
    Luidolt 2020, §5.2.3 and §6.3.3.

    Examples
    --------
    >>> rows, cols = gaze_falloff((3, 3), pixel_deg=1.0, gaze_px=(1, 1), sigma_deg=1.0)
    >>> float(rows[1] * cols[1]), round(float(rows[0] * cols[1]), 4)
    (1.0, 0.6065)
    """
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    sigma_deg = check_positive("sigma_deg", sigma_deg, unit="deg")
    try:
        row, col = (real_number(v) for v in gaze_px)  # not a bool, a string or an array
    except (TypeError, ValueError):
        raise ValueError(f"gaze_px must be (row, column) in pixels; got {gaze_px!r}") from None
    if not (math.isfinite(row) and math.isfinite(col)):
        raise ValueError(f"gaze_px must be finite; got {gaze_px!r}")
    sigma_px = sigma_deg / pixel_deg
    rows = np.exp(-0.5 * ((np.arange(int(shape[0])) - row) / sigma_px) ** 2)
    cols = np.exp(-0.5 * ((np.arange(int(shape[1])) - col) / sigma_px) ** 2)
    return rows, cols
