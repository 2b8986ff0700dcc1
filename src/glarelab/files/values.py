"""Values given to glarelab's functions: which count as real numbers, whole numbers and
random generators.

NumPy reads a bool as 0 or 1, a string such as ``'2'`` as 2.0 and a masked array's hidden
values as if they were there, all without a word. These checks are shared by every layer that
takes numbers at its boundary (the statistics, the display's calibration, the glare models), so
that each refuses the same things the same way.
"""

from __future__ import annotations

import numbers
import re

import numpy as np

__all__ = [
    "DECIMAL_TEXT",
    "WHOLE_TEXT",
    "check_generator",
    "is_real",
    "is_whole",
    "plain_array",
    "real_array",
]

# a number as a person or a program writes it in a text file: digits, a decimal point, an
# exponent (nan and inf read, for the caller to refuse with its own words); not what Python
# also reads ("2_50" is 250 to int() and float(), " 7" is 7)
WHOLE_TEXT = re.compile(r"[+-]?\d+", re.ASCII)  # ASCII: not a full-width １
DECIMAL_TEXT = re.compile(
    r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.IGNORECASE | re.ASCII
)


def is_real(value: object) -> bool:
    """Whether ``value`` is a real number: not a bool, a string, a complex number or an array
    of more than one value (a 0-d array holding a real number counts).

    Parameters
    ----------
    value
        Anything given where a number is expected.

    Returns
    -------
    bool
        True for a real number (NaN and the infinities included: finiteness is the caller's).

    Examples
    --------
    >>> is_real(2), is_real(np.float32(0.5)), is_real(True), is_real("2")
    (True, True, False, False)
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    return not isinstance(value, bool | np.bool_) and isinstance(value, numbers.Real)


def is_whole(value: object) -> bool:
    """Whether ``value`` is a whole number (a Python or NumPy integer, not a bool and not a
    float such as 2.0 that ``int`` would read).

    Parameters
    ----------
    value
        Anything given where a count is expected.

    Returns
    -------
    bool
        True for a Python or NumPy integer that is not a bool.

    Examples
    --------
    >>> is_whole(3), is_whole(np.int64(3)), is_whole(True), is_whole(3.0)
    (True, True, False, False)
    """
    return not isinstance(value, bool | np.bool_) and isinstance(value, int | np.integer)


def plain_array(name: str, value: object) -> np.ndarray:
    """``value`` as an array (``np.asarray``), refusing what NumPy would take wrongly: a masked
    array (its mask dropped), a string, None, or rows of different lengths. Its dtype is the
    caller's to check (codes must be integers, luminances real numbers).

    Parameters
    ----------
    name
        The argument, as the message should name it.
    value
        A number, a sequence or an array.

    Returns
    -------
    numpy.ndarray
        ``np.asarray(value)``.

    Raises
    ------
    ValueError
        Naming ``name`` and what it got.

    Examples
    --------
    >>> plain_array("codes", [1, 2]).tolist()
    [1, 2]
    >>> plain_array("codes", [[1, 2], [3]])
    Traceback (most recent call last):
    ...
    ValueError: codes must be an array of numbers; got rows of different lengths
    """
    if isinstance(value, np.ma.MaskedArray):
        raise ValueError(
            f"{name} must be a plain array, not a masked array (its mask would be ignored)"
        )
    if isinstance(value, str | bytes) or value is None:
        raise ValueError(f"{name} must be a number or an array of numbers; got {value!r}")
    try:
        return np.asarray(value)
    except ValueError:
        raise ValueError(
            f"{name} must be an array of numbers; got rows of different lengths"
        ) from None


def real_array(values: object, what: str) -> np.ndarray:
    """``values`` as a float array, after checking it holds real numbers only.

    A masked array is refused (its mask would be ignored), as are strings, bools, ``None`` and
    complex numbers anywhere in it. Finiteness is not checked here: each caller says what a NaN
    means to it.

    Parameters
    ----------
    values
        A sequence or array of numbers.
    what
        The argument, as the message should name it (e.g. ``"ttest_welch: a"``).

    Raises
    ------
    TypeError
        Naming ``what``, the first value that is not a real number and its position.

    Examples
    --------
    >>> real_array([1, 2.5], "x")
    array([1. , 2.5])
    >>> real_array(["1", 2], "x")
    Traceback (most recent call last):
    ...
    TypeError: x must hold real numbers (not strings, bools or None); got '1' at position 0
    """
    if isinstance(values, np.ma.MaskedArray):
        raise TypeError(
            f"{what} must be a plain array, not a masked array (its mask would be ignored); "
            "give values.compressed() to leave the masked values out"
        )
    if isinstance(values, str | bytes):
        raise TypeError(f"{what} must be a sequence of numbers; got the string {values!r}")
    # a list is read value by value: NumPy would turn [False, 0.5] into floats and ['1', 2]
    # into strings, hiding which value was wrong; an array or a pandas Series has one dtype
    array = np.asarray(values) if hasattr(values, "dtype") else np.asarray(values, dtype=object)
    if array.dtype.kind in "iuf":
        return array.astype(float)
    if array.dtype.kind == "O":
        flat = array.ravel()
        bad = next((i for i, value in enumerate(flat) if not is_real(value)), None)
        if bad is None:
            return array.astype(float)
    else:
        bad = 0  # bools, strings, complex numbers, dates: the first value is already wrong
    if array.size == 0:
        raise TypeError(f"{what} must hold real numbers; got an array of dtype {array.dtype}")
    position = tuple(int(i) for i in np.unravel_index(bad, array.shape)) if array.ndim > 1 else bad
    value = array.ravel()[bad]
    value = value.item() if isinstance(value, np.generic) else value
    raise TypeError(
        f"{what} must hold real numbers (not strings, bools or None); got {value!r} at "
        f"position {position}"
    )


def check_generator(rng: object, name: str = "rng") -> np.random.Generator:
    """``rng`` if it is a :class:`numpy.random.Generator` (every draw of the suite goes
    through one the caller passes), else a ValueError naming ``name``.

    Parameters
    ----------
    rng
        What was given.
    name
        The argument, as the message should name it; default ``'rng'``.

    Returns
    -------
    numpy.random.Generator
        ``rng``.

    Raises
    ------
    ValueError
        For anything else: a seed, None, the legacy ``RandomState``.

    Examples
    --------
    >>> check_generator(0)
    Traceback (most recent call last):
    ...
    ValueError: rng must be a numpy.random.Generator (np.random.default_rng(seed)); got 0
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(
            f"{name} must be a numpy.random.Generator (np.random.default_rng(seed)); got {rng!r}"
        )
    return rng
