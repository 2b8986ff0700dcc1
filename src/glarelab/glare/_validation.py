"""Checks at the public boundary of :mod:`glarelab.glare`.

Every check raises :class:`ValueError` whose message names the argument, the value it got and
what is allowed, so that a wrong call is fixed from the message alone.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from glarelab.files.values import is_real, is_whole, plain_array, real_array

__all__ = [
    "check_choice",
    "check_flag",
    "check_image",
    "check_in_range",
    "check_luminances",
    "check_pixel_deg",
    "check_positive",
    "check_positive_int",
    "real_number",
]


TINY = float(np.finfo(float).tiny)  # the smallest normal float64, 2.2e-308


def _describe(value: object) -> str:
    if isinstance(value, float | np.floating):
        return repr(float(value))
    return repr(value)


def real_number(value: object) -> float:
    """``value`` as a float if it is a real number (not a bool, a string or an array of more
    than one value), else raise ``TypeError``."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if not is_real(value):
        raise TypeError(f"not a real number: {value!r}")
    return float(value)


def check_positive(name: str, value: float, *, unit: str = "") -> float:
    """Return ``value`` as a float if it is finite and > 0, else raise ``ValueError``.

    Subnormal numbers (below 2.2e-308) are refused too: a quantity that small cannot be
    squared or divided by without becoming 0 or infinite.
    """
    try:
        number = real_number(value)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a finite number > 0{' ' + unit if unit else ''}, got {value!r}"
        ) from None
    if not math.isfinite(number) or number < TINY:
        raise ValueError(
            f"{name} must be a finite number > 0{' ' + unit if unit else ''}, "
            f"got {_describe(value)}"
        )
    return number


MIN_PIXEL_DEG = 1e-5  # as the command line: 0.04 arcsec, far below the eye's resolution
MAX_PIXEL_DEG = 180.0  # a pixel cannot subtend more than half the visual field


def check_pixel_deg(value: float, *, high: float = MAX_PIXEL_DEG) -> float:
    """Return ``pixel_deg`` as a float if it is a number in ``[1e-5, high]`` degrees (the
    command line's lower bound), else raise ``ValueError``."""
    return check_in_range("pixel_deg", value, MIN_PIXEL_DEG, high, unit="deg")


def check_in_range(
    name: str,
    value: float,
    low: float,
    high: float,
    *,
    unit: str = "",
    low_inclusive: bool = True,
    high_inclusive: bool = True,
) -> float:
    """Return ``value`` as a float if it lies in the interval, else raise ``ValueError``."""
    lb = "[" if low_inclusive else "("
    hb = "]" if high_inclusive else ")"
    allowed = f"{lb}{low:g}, {high:g}{hb}{' ' + unit if unit else ''}"
    if high == math.inf and math.isfinite(low):  # "in [0, inf]" reads as if inf were allowed
        allowed = f"{'>=' if low_inclusive else '>'} {low:g}{' ' + unit if unit else ''}"
    try:
        number = real_number(value)
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be a {'finite ' if high == math.inf else ''}number "
            f"{'' if high == math.inf and math.isfinite(low) else 'in '}{allowed}, got {value!r}"
        ) from None
    above = number >= low if low_inclusive else number > low
    below = number <= high if high_inclusive else number < high
    if not (math.isfinite(number) and above and below):
        if high == math.inf and math.isfinite(low):
            raise ValueError(f"{name} must be a finite number {allowed}, got {_describe(value)}")
        raise ValueError(f"{name} must be in {allowed}, got {_describe(value)}")
    return number


def check_positive_int(
    name: str, value: int, *, minimum: int = 1, maximum: int | None = None
) -> int:
    """Return ``value`` if it is an integer >= ``minimum`` (and <= ``maximum`` when given),
    else raise ``ValueError``."""
    if maximum is not None and (not is_whole(value) or not minimum <= value <= maximum):
        raise ValueError(f"{name} must be an integer from {minimum} to {maximum}, got {value!r}")
    if not is_whole(value) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def check_flag(name: str, value: object) -> bool:
    """Return ``value`` if it is a bool, else raise ``ValueError`` (the string ``'no'`` is
    true to ``if``)."""
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_choice(name: str, value: object, allowed: Iterable[object]) -> object:
    """Return ``value`` if it is one of ``allowed``, else raise ``ValueError``."""
    options = tuple(allowed)
    if value not in options:
        raise ValueError(
            f"{name} must be one of {', '.join(repr(o) for o in options)}; got {value!r}"
        )
    return value


def check_image(name: str, image: object, *, channels: tuple[int, ...] = ()) -> np.ndarray:
    """Return ``image`` as a float array after checking it is a finite, non-negative image.

    Parameters
    ----------
    name
        Argument name used in the error message.
    image
        Array-like of shape ``(H, W)`` or, when ``channels`` is given, ``(H, W, C)`` with
        ``C`` in ``channels``.
    channels
        Allowed channel counts for a 3-D image; empty means 2-D only.
    """
    if isinstance(image, np.ma.MaskedArray):
        raise ValueError(
            f"{name} must be a plain array, not a masked array (its mask would be ignored); "
            "give image.filled(value) with the value the masked pixels should have"
        )
    allowed = "a 2-D (H, W) array"
    if channels:
        allowed += " or a 3-D (H, W, C) array with C in " + str(list(channels))
    if isinstance(image, str | bytes | dict | set) or image is None:
        raise ValueError(f"{name} must be {allowed} of numbers; got {type(image).__name__}")
    try:
        array = np.asarray(image)
    except ValueError:  # rows of different lengths
        raise ValueError(
            f"{name} must be {allowed} of numbers; got rows of different lengths"
        ) from None
    if array.ndim == 3 and channels:
        if array.shape[2] not in channels:
            raise ValueError(f"{name} must be {allowed}; got shape {array.shape}")
    elif array.ndim != 2:
        raise ValueError(f"{name} must be {allowed}; got shape {array.shape}")
    if array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"{name} must have at least one pixel; got shape {array.shape}")
    if not (np.issubdtype(array.dtype, np.floating) or np.issubdtype(array.dtype, np.integer)):
        raise ValueError(f"{name} must hold real numbers; got dtype {array.dtype}")
    low, high = (array.min(), array.max()) if array.size else (0, 0)  # NaN propagates
    if not (np.isfinite(low) and np.isfinite(high)):
        finite = np.isfinite(array)
        raise ValueError(
            f"{name} must be finite (NaN and Inf are not luminances); got {_first(array, ~finite)}"
        )
    if low < 0:
        raise ValueError(f"{name} must be >= 0 cd/m²; got {_first(array, array < 0)}")
    return array


def check_luminances(name: str, value: object) -> np.ndarray:
    """Return ``value`` (a number or an array of any shape) as a float array of luminances,
    finite and >= 0, else raise ``ValueError`` naming ``name``: a string (``'100'``), a bool,
    a complex number or a masked array is refused, not converted."""
    array = plain_array(name, value)
    if array.dtype == bool:
        raise ValueError(f"{name} must hold numbers >= 0 (cd/m²), not True/False")
    check_image(name, array.reshape(1, -1) if array.size else np.zeros((1, 1)))
    return array.astype(float)


def check_real(name: str, value: object) -> np.ndarray:
    """Return ``value`` (a number or an array of any shape) as a float array, else raise
    ``ValueError`` naming ``name``: a string (``'0.25'``), a bool, a complex number, None or
    a masked array is refused, not converted. Range and finiteness are the caller's."""
    if isinstance(value, np.ma.MaskedArray):
        raise ValueError(
            f"{name} must be a plain array, not a masked array (its mask would be ignored)"
        )
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if is_real(value):
        return np.asarray(value, dtype=float)
    if isinstance(value, str | bytes) or value is None or not hasattr(value, "__len__"):
        raise ValueError(f"{name} must be a real number or an array of them; got {value!r}")
    try:
        return real_array(value, name)
    except TypeError as error:
        raise ValueError(str(error)) from None
    except ValueError:  # rows of different lengths
        raise ValueError(
            f"{name} must be an array of numbers; got rows of different lengths"
        ) from None


def _first(array: np.ndarray, bad: np.ndarray) -> str:
    """The first offending value, with its index when the array holds more than one."""
    where = tuple(int(i) for i in np.argwhere(bad)[0])
    value = float(array[where])
    return f"{value!r}" if array.size == 1 else f"{value!r} at index {where}"
