"""Display maths: codes of luminances, code steps, and errors in display codes.

The error that matters is the one a display shows: an error below half a code step cannot be
seen. A display is its code → luminance table (``lut``, cd/m², increasing); a
:class:`glarelab.display.calibration.Calibration` serves as well. :class:`CodeBound` turns a bound
on the spread (cd/m², per pixel) into a bound in display codes, block by block, looking up
code steps directly in the table (no interpolation over the image).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from glarelab.files.values import plain_array
from glarelab.glare._validation import check_in_range, check_positive, check_positive_int
from glarelab.glare.rendering.compose import METHODS, compose, over_channels

__all__ = [
    "DISPLAY_BITS",
    "DISPLAY_CONTRAST",
    "DISPLAY_GAMMA",
    "CodeBound",
    "CodeTable",
    "Display",
    "display_codes",
    "display_lut",
    "steps_above",
]

# The reference display used when none is given: a 10-bit (Yoshida 2008 and Luidolt 2020 ask
# for 10 bits), gamma 2.2, 1000:1 display whose white is L_dmax.
DISPLAY_BITS = 10
DISPLAY_GAMMA = 2.2
MAX_DISPLAY_BITS = 16  # codes per channel a display table may have: 2^16
MAX_DISPLAY_GAMMA = 10.0  # displays measure 1.8-2.6; beyond 10 a table is all black but one code
DISPLAY_CONTRAST = 1000.0
BLOCK_PX = 16  # the check bounds blocks of 16 × 16 pixels first, then pixels of failing blocks
STEP_TABLE_SIZE = 2**16  # log-luminance bins of the step table (ratio 1.0001 over 1000:1)
# CodeTable: a float32's bits without the last 10 of its mantissa index a bin of relative width
# 2^-13 (0.012 %), a sixteenth of a 10-bit gamma-2.2 display's step at its white
CODE_TABLE_SHIFT = 10


@dataclass(frozen=True)
class Display:
    """A display as its code → luminance table (cd/m², increasing).

    A :class:`glarelab.display.calibration.Calibration` serves as well: the planner reads ``lut``.

    Attributes
    ----------
    lut
        The display's code → luminance table, cd/m², increasing, one entry per code, at
        least two, finite and >= 0, a plain array (not a masked one) or a list (else
        ValueError).
    """

    lut: np.ndarray

    def __post_init__(self) -> None:  # a table as display_lut takes it, or refused now
        # None would be display_lut's reference display (its white 1 cd/m² here): not a table
        if self.lut is None or isinstance(self.lut, str | bytes) or hasattr(self.lut, "lut"):
            raise ValueError(f"lut must be a code → cd/m² table; got {self.lut!r:.80}")
        plain_array("lut", self.lut)  # a masked table's mask would be dropped
        try:
            lut = display_lut(self.lut, 1.0)
            if lut[0] < 0:
                raise ValueError
        except ValueError:
            raise ValueError(
                "lut must be a 1-D increasing code → cd/m² table of >= 2 finite luminances "
                f">= 0; got {self.lut!r:.80}"
            ) from None
        object.__setattr__(self, "lut", lut)

    @classmethod
    def gamma(
        cls,
        white_cd_m2: float,
        *,
        black_cd_m2: float,
        bits: int = DISPLAY_BITS,
        gamma: float = DISPLAY_GAMMA,
    ) -> Display:
        """A gain-offset-gamma display: ``L = black + (white - black) (code / max)^γ``.

        Parameters
        ----------
        white_cd_m2
            The top code's luminance, cd/m², > 0.
        black_cd_m2
            Code 0's luminance, cd/m², in ``[0, white_cd_m2)``.
        bits
            Bits per channel, 1 to :data:`MAX_DISPLAY_BITS`: ``2^bits`` codes; default
            :data:`DISPLAY_BITS`.
        gamma
            The exponent ``γ``, in ``(0, MAX_DISPLAY_GAMMA]``; default :data:`DISPLAY_GAMMA`.

        Returns
        -------
        Display
            The display.

        Raises
        ------
        ValueError
            For a white that is not positive, a black outside ``[0, white)``, bits that are
            not a whole number in ``[1, MAX_DISPLAY_BITS]`` or a gamma outside
            ``(0, MAX_DISPLAY_GAMMA]`` (bools, strings and NaN included).

        Examples
        --------
        >>> d = Display.gamma(220.0, black_cd_m2=0.22)
        >>> d.lut.size, float(d.lut[0]), float(d.lut[-1])
        (1024, 0.22, 220.0)
        """
        white = check_positive("white_cd_m2", white_cd_m2, unit="cd/m²")
        black = check_in_range(
            "black_cd_m2", black_cd_m2, 0.0, white, unit="cd/m²", high_inclusive=False
        )
        bits = check_positive_int("bits", bits)
        if bits > MAX_DISPLAY_BITS:
            raise ValueError(f"bits must be an integer in [1, {MAX_DISPLAY_BITS}], got {bits!r}")
        gamma = check_in_range("gamma", gamma, 0.0, MAX_DISPLAY_GAMMA, low_inclusive=False)
        levels = np.linspace(0.0, 1.0, 2**bits)
        return cls(lut=black + (white - black) * levels**gamma)


def display_lut(display, l_dmax_cd_m2: float) -> np.ndarray:
    """The display's code → cd/m² table; for ``None`` the reference display: 10-bit, gamma
    2.2, 1000:1, white at ``l_dmax_cd_m2``.

    Parameters
    ----------
    display
        A :class:`Display`, a calibration (anything with a ``lut``), a table itself, or None.
    l_dmax_cd_m2
        The reference display's white, cd/m², > 0 (used only for None).

    Returns
    -------
    numpy.ndarray
        The table, cd/m², float.

    Raises
    ------
    ValueError
        For anything but a 1-D, finite, increasing table of numbers with at least two codes
        (a display's name, a ragged list, a masked array).
    """
    if display is None:
        l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
        return Display.gamma(l_dmax, black_cd_m2=l_dmax / DISPLAY_CONTRAST).lut
    allowed = (
        "a Display, a calibration, or a 1-D increasing code → cd/m² table of >= 2 finite "
        "luminances"
    )
    lut = getattr(display, "lut", display)
    if isinstance(lut, np.ma.MaskedArray):  # its masked codes would be used as luminances
        plain_array("display", lut)
    try:
        lut = np.asarray(lut)
    except ValueError:  # a ragged list
        raise ValueError(f"display must be {allowed}; got {display!r}") from None
    if lut.dtype.kind not in "iuf":
        raise ValueError(f"display must be {allowed}; got {display!r}")
    lut = lut.astype(float, copy=False)
    if (
        lut.ndim != 1
        or lut.size < 2
        or not np.all(np.isfinite(lut))
        or not np.all(np.diff(lut) > 0)
    ):
        raise ValueError(f"display must be {allowed}; got {display!r:.80}")
    return lut


def display_codes(luminance_cd_m2: np.ndarray, lut: np.ndarray) -> np.ndarray:
    """Continuous display codes of luminances (clipped to the display's range).

    Parameters
    ----------
    luminance_cd_m2
        Luminances, cd/m², any shape.
    lut
        The display's code → luminance table, cd/m², increasing, one entry per code.

    Returns
    -------
    numpy.ndarray
        Fractional codes, interpolated linearly in the table, 0 … ``lut.size - 1``.

    Examples
    --------
    >>> display_codes(np.array([0.0, 1.5, 9.0]), np.array([1.0, 2.0, 4.0])).tolist()
    [0.0, 0.5, 2.0]
    """
    values = np.clip(luminance_cd_m2, lut[0], lut[-1])
    return np.interp(values, lut, np.arange(lut.size, dtype=float))


class CodeTable:
    """The nearest display codes of float32 luminances by a table look-up: equal to
    ``np.rint(display_codes(x, lut))`` for every float32 ``x``, in a tenth of the time or less (a
    live frame's encoding at the display's refresh rate).

    Parameters
    ----------
    lut
        The display's code → luminance table, cd/m², increasing, >= 0, one entry per code
        (or anything :func:`display_lut` takes).

    Raises
    ------
    ValueError
        For a table that is not 1-D and increasing, or that begins below 0 cd/m².

    Notes
    -----
    The bits of a float32 read as a signed integer increase with its value; shifted right by
    :data:`CODE_TABLE_SHIFT` they index bins of relative width ``2^-13`` (a negative float's
    index lies below the first bin and is held at it, a float above the table's at the last).
    A bin's code is the code of its least and of its greatest float (``rint`` of the
    interpolation is non-decreasing in the luminance): one look-up over the image, in blocks
    that stay in the cache. Where the two differ by one code (about 1 % of the bins of a
    10-bit table, 1 % of a night street's pixels), the bin keeps the least float that takes
    the greater code, found by bisection over the bin's floats when the table is made, and the
    pixel is compared with it; where they differ by more (tables with codes closer than a
    bin), the pixel's code is interpolated as :func:`display_codes` does. Other dtypes take
    :func:`display_codes` itself. Non-finite luminances are not checked (a NaN takes the code
    of the first or the last bin).

    Examples
    --------
    >>> lut = Display.gamma(200.0, black_cd_m2=0.2).lut
    >>> image = np.array([[0.0, 0.5, 37.25, 199.9, 500.0]], dtype=np.float32)
    >>> CodeTable(lut)(image).tolist()
    [[0, 53, 476, 1023, 1023]]
    >>> np.rint(display_codes(image, lut)).astype(int).tolist()
    [[0, 53, 476, 1023, 1023]]
    """

    BLOCK = 2**15  # values encoded at a time: their bin indices (8 bytes each) stay in the cache

    def __init__(self, lut) -> None:
        lut = display_lut(lut, 1.0)
        if lut[0] < 0:
            raise ValueError(f"lut must begin at >= 0 cd/m²; got {lut[0]!r}")
        self.lut = lut
        self._codes = np.arange(lut.size, dtype=float)
        # the float32 range that holds the table's: its ends rounded outwards, so that a value
        # clipped to them is clipped to the table's own ends by the interpolation
        self.low, self.high = np.float32(lut[0]), np.float32(lut[-1])
        if float(self.low) > lut[0]:
            self.low = np.nextafter(self.low, np.float32(0.0))
        if float(self.high) < lut[-1]:
            self.high = np.nextafter(self.high, np.float32(np.inf))
        low_bits = int(np.array(self.low).view(np.int32))
        high_bits = int(np.array(self.high).view(np.int32))
        first, last = low_bits >> CODE_TABLE_SHIFT, high_bits >> CODE_TABLE_SHIFT
        bins = np.arange(first, last + 1, dtype=np.int64)
        least = np.maximum(bins << CODE_TABLE_SHIFT, low_bits)  # each bin's ends, as bits
        greatest = np.minimum(((bins + 1) << CODE_TABLE_SHIFT) - 1, high_bits)
        at_least, at_greatest = self._nearest_bits(least), self._nearest_bits(greatest)
        # the least float of a bin that takes the greater code: bisection over its floats
        one = at_greatest == at_least + 1
        below, above = least[one], greatest[one]
        target = at_greatest[one]
        while np.any(above - below > 1):
            middle = (below + above) // 2
            greater = self._nearest_bits(middle) >= target
            above = np.where(greater, middle, above)
            below = np.where(greater, below, middle)
        self._switch = np.full(bins.size, np.nan, dtype=np.float32)  # NaN: interpolated
        self._switch[one] = above.astype(np.int32).view(np.float32)
        self._first = first
        self._flag = 2**15 if lut.size <= 2**15 else 2**31  # marks a bin of two codes or more
        self._dtype = np.dtype(np.uint16 if lut.size <= 2**16 else np.uint32)
        table = at_least.astype(np.uint16 if self._flag == 2**15 else np.uint32)
        table[at_least != at_greatest] |= table.dtype.type(self._flag)
        self._table = table

    def _nearest_bits(self, bits: np.ndarray) -> np.ndarray:
        """:meth:`_nearest` of the float32s of these bit patterns."""
        return self._nearest(np.asarray(bits).astype(np.int32).view(np.float32))

    def _nearest(self, values: np.ndarray) -> np.ndarray:
        clipped = np.clip(values.astype(float), self.lut[0], self.lut[-1])
        return np.rint(np.interp(clipped, self.lut, self._codes))

    def __call__(self, luminance_cd_m2: np.ndarray) -> np.ndarray:
        """The nearest codes, unsigned integers of the image's shape.

        Parameters
        ----------
        luminance_cd_m2
            Luminances, cd/m² (float32 for the table; other dtypes are interpolated).

        Returns
        -------
        numpy.ndarray
            Codes, 0 … ``lut.size - 1``.
        """
        image = np.asarray(luminance_cd_m2)
        if image.dtype != np.float32:
            return self._nearest(image).astype(self._dtype)
        bits = np.ascontiguousarray(image).reshape(-1).view(np.int32)
        codes = np.empty(bits.size, dtype=self._table.dtype)
        index = np.empty(min(self.BLOCK, bits.size), dtype=np.intp)
        for start in range(0, bits.size, self.BLOCK):
            stop = min(start + self.BLOCK, bits.size)
            part = index[: stop - start]
            np.right_shift(bits[start:stop], CODE_TABLE_SHIFT, out=part)
            part -= self._first
            self._table.take(part, mode="clip", out=codes[start:stop])
        unsure = np.flatnonzero(codes >= self._flag)
        if unsure.size:
            values = bits[unsure].view(np.float32)
            where = np.clip((bits[unsure] >> CODE_TABLE_SHIFT) - self._first, 0, None)
            switch = self._switch.take(where, mode="clip")
            lower = codes[unsure] & (self._flag - 1)
            codes[unsure] = lower + (values >= switch)  # a bin of two codes
            split = np.isnan(switch)  # a bin of more: interpolated
            if split.any():
                codes[unsure[split]] = self._nearest(values[split])
        return codes.reshape(image.shape).astype(self._dtype, copy=False)


def steps_above(lut: np.ndarray) -> np.ndarray:
    """For each code, the smallest step (cd/m²) between it and white (non-decreasing).

    Parameters
    ----------
    lut
        The display's code → luminance table, cd/m², increasing, one entry per code.

    Returns
    -------
    numpy.ndarray
        ``(lut.size - 1,)`` steps, cd/m².
    """
    steps = np.diff(lut)
    return np.minimum.accumulate(steps[::-1])[::-1]


class CodeBound:
    """Bounds, in display codes, on the error of an image whose spread is uncertain.

    The exact spread ``S`` lies within ``S̃ ± b`` with ``b = absolute + relative · S̃``
    (cd/m²). A pixel's output moves by at most ``b`` cd/m², and never beyond its lowest and
    highest possible outputs ``lo, hi`` inside the display's range (Yoshida's clamp and the
    display's black and white cut it), so its error is at most
    ``min(b, hi - lo) / step(lo)`` codes, with ``step(lo)`` the smallest code step at or
    above ``lo`` (the codes of a piecewise linear table move by at most ``Δ / min step`` over
    an interval of ``Δ`` cd/m²).

    The bound is taken per block of :data:`BLOCK_PX` pixels first (the block's darkest pixel,
    smallest and largest spread), and per pixel only in blocks whose bound exceeds the
    tolerance. Steps are looked up directly: a table of :data:`STEP_TABLE_SIZE` bins in
    log-luminance holds, for each bin, the smallest step at or above its lower edge.

    Parameters
    ----------
    lut
        The display's code → luminance table, cd/m², increasing.
    l_dmax_cd_m2
        The display maximum of the glare's composition ``L_dmax``, cd/m²: Yoshida's clamp
        keeps the output below it.
    method
        The composition, ``'Yoshida2008'`` (clamped at ``L_dmax``) or ``'Spencer1995'``
        (summed).

    Raises
    ------
    ValueError
        For an unknown ``method``.
    """

    def __init__(self, lut: np.ndarray, l_dmax_cd_m2: float, method: str) -> None:
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}; got {method!r}")
        self.lut = np.asarray(lut, dtype=float)
        self.steps = steps_above(self.lut)
        self.l_dmax = float(l_dmax_cd_m2)
        self.method = method
        self.top = min(self.lut[-1], self.l_dmax) if method == "Yoshida2008" else self.lut[-1]
        self.black = float(self.lut[0])
        self._offset = float(self.steps[0])  # log(L + offset): finite at a black of 0
        self._u0 = math.log(self.black + self._offset)
        span = math.log(self.lut[-1] + self._offset) - self._u0
        self._scale = STEP_TABLE_SIZE / span
        edges = np.exp(self._u0 + np.arange(STEP_TABLE_SIZE) / self._scale) - self._offset
        self._table = self.step(np.maximum(edges, self.black))
        shown = self.lut[:-1] <= self.top
        # codes per relative change of the output, at most: L / step over the display's range
        self.relative_codes = float(np.max(self.lut[:-1][shown] / self.steps[shown], initial=0))
        self.largest_step = float(self.steps.max())
        # the same over the step table: L / _table_step(L) at most, for L up to the top (each
        # bin's upper edge over its step; a hair more for the rounding of the bin's index)
        upper = np.exp(self._u0 + np.arange(1, STEP_TABLE_SIZE + 1) / self._scale) - self._offset
        lower = np.concatenate([[self.black], upper[:-1]])
        inside = lower <= self.top
        ratios = np.minimum(upper, self.top)[inside] / self._table[inside]
        self._table_relative_codes = float(ratios.max(initial=0.0)) * (1.0 + 1e-9)

    def step(self, luminance_cd_m2: np.ndarray | float) -> np.ndarray:
        """Smallest code step (cd/m²) at or above each luminance's code.

        Parameters
        ----------
        luminance_cd_m2
            Luminances, cd/m², a number or an array.

        Returns
        -------
        numpy.ndarray
            The step at each, cd/m².
        """
        code = np.searchsorted(self.lut, luminance_cd_m2, side="right") - 1
        return self.steps[np.clip(code, 0, self.steps.size - 1)]

    def roundoff_codes(
        self,
        darkest_cd_m2: np.ndarray,
        spread_cd_m2: np.ndarray,
        *,
        absolute: float,
        relative: float,
    ) -> float:
        """A bound, before the spread is computed, on what :meth:`codes` will find for a
        spread off by at most ``absolute + relative · S`` (FFT round-off, ``S`` the spread
        without it), from lower bounds on the pixels and on ``S``.

        Parameters
        ----------
        darkest_cd_m2
            For each part of the image (a coarse cell), a value at most each of its pixels,
            cd/m² (every channel).
        spread_cd_m2
            For each part, a value at most the spread without round-off at each of its pixels,
            cd/m² (every channel), of ``darkest_cd_m2``'s shape.
        absolute, relative
            The round-off's bound, ``a`` cd/m² and ``r`` (< 1).

        Returns
        -------
        float
            Codes, at least what :meth:`codes` finds pixel by pixel for the spread computed
            with that round-off (its first, per-block bound may be larger, but below the
            tolerance: above it, :meth:`codes` looks at the block's pixels).

        Notes
        -----
        With ``S̃`` the spread computed, ``|S̃ - S| <= a + r S`` gives
        ``S̃ >= (1 - r) S - a``, so the lowest spread :meth:`codes` considers at a pixel,
        ``S̃ - b`` with ``b = a + r S̃``, is at least ``(1 - r)² S - 2a``: its lowest output
        is at least ``lo``, that output for the part's darkest pixel and spread. Where the
        output can move at all (neither end clamped), ``(1 - r) S̃ - a <= lo``, so
        ``b <= (a + r lo) / (1 - r)`` and the error is at most
        ``a / ((1 - r) step(lo)) + r / (1 - r) · L / step(L)``: the first term at the part's
        ``lo`` (steps grow with the luminance), the second over the display's range (the
        step table's, which :meth:`codes` reads pixel by pixel and which is never larger
        than :meth:`step`).
        """
        if relative >= 1.0:
            return math.inf
        spread = np.maximum((1.0 - relative) ** 2 * spread_cd_m2 - 2.0 * absolute, 0.0)
        low = np.clip(
            compose(darkest_cd_m2, spread, self.l_dmax, self.method), self.black, self.top
        )
        return float(np.max(self._moving_codes(low, absolute, relative), initial=0.0))

    def _moving_codes(self, low_cd_m2: np.ndarray, absolute: float, relative: float):
        """``a / ((1 - r) step(lo)) + r / (1 - r) · max L / step(L)``: the codes of a pixel
        whose lowest output is at least ``lo`` and whose spread ``S̃`` is off by at most
        ``a + r S̃`` (:meth:`roundoff_codes`), with the step table's steps, as :meth:`codes`
        reads them pixel by pixel (``r < 1``)."""
        scale = 1.0 / (1.0 - relative)
        return (absolute * scale) / self._table_step(low_cd_m2) + (
            relative * scale * self._table_relative_codes
        )

    def _table_step(self, luminance_cd_m2: np.ndarray) -> np.ndarray:
        """:meth:`step` from the log-luminance table: never larger, no search."""
        u = np.log(luminance_cd_m2 + self._offset)
        u -= self._u0
        u *= self._scale
        index = np.clip(u, 0, STEP_TABLE_SIZE - 1).astype(np.intp)
        return self._table[index]

    def _outputs(self, planes, spread_low, spread_high):
        """Lowest and highest output (cd/m²) for spreads in ``[low, high]``, within the
        display's range."""
        low = compose(planes, spread_low, self.l_dmax, self.method)
        high = compose(planes, spread_high, self.l_dmax, self.method)
        return np.clip(low, self.black, self.top), np.clip(high, self.black, self.top)

    def codes(
        self,
        planes: np.ndarray,
        spread: np.ndarray,
        *,
        absolute: float,
        relative: float,
        tolerance_codes: float = 0.0,
    ) -> float:
        """Largest error in codes over the image (an upper bound).

        Parameters
        ----------
        planes
            The image, ``(H, W, C)``, cd/m².
        spread
            The computed spread, ``(H, W, C)`` or ``(H, W, 1)``, cd/m², >= 0.
        absolute, relative
            The spread's bound: ``absolute + relative · spread`` cd/m².
        tolerance_codes
            Blocks whose bound is within it are not looked at pixel by pixel.

        Notes
        -----
        A block's bound is the smaller of two: its spread's range through the display at
        its lowest output ``lo``, and ``a / ((1 - r) step(lo)) + r / (1 - r) · max L /
        step(L)`` (the relative part at most ``r`` times each pixel's own output, as in
        :meth:`roundoff_codes`), which does not grow with the block's brightest spread. On
        the 1024² city at night (2,000 lamps, float32 transforms) the first alone put 1,157
        of the 4,096 blocks over half a code, looked at pixel by pixel (7 ms; the bound
        0.50 codes, 0.36 by every pixel); with the second none (2.6 ms, 0.37 codes).
        """
        if absolute == 0.0 and relative == 0.0:
            return 0.0
        p_lo, p_hi = _channel_extremes(planes)
        s_lo, s_hi = _channel_extremes(spread)
        p_min, p_max = block_reduce(p_lo, np.minimum), block_reduce(p_hi, np.maximum)
        s_min, s_max = block_reduce(s_lo, np.minimum), block_reduce(s_hi, np.maximum)
        low, _ = self._outputs(p_min, np.maximum((1.0 - relative) * s_min - absolute, 0.0), 0.0)
        _, high = self._outputs(p_max, 0.0, (1.0 + relative) * s_max + absolute)
        width = np.clip(high - low, 0.0, absolute + relative * s_max)
        blocks = width / self.step(low)
        if relative < 1.0:  # or, at each pixel, within _moving_codes of its lowest output
            blocks = np.minimum(blocks, self._moving_codes(low, absolute, relative))
        worst = float(blocks.max())
        if worst <= tolerance_codes:
            return worst
        failing = blocks > tolerance_codes
        worst = float(blocks[~failing].max(initial=0.0))
        for p, s in _failing_pixels(planes, spread, failing):
            bound = absolute + relative * s
            low, high = self._outputs(p, np.maximum(s - bound, 0.0), s + bound)
            pixels = np.minimum(high - low, bound) / self._table_step(low)
            worst = max(worst, float(pixels.max(initial=0.0)))
        return worst


def _channel_extremes(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest channel of each pixel of ``(H, W, C)`` (views for one channel)."""
    if values.shape[2] == 1:
        return values[..., 0], values[..., 0]
    return over_channels(values, np.minimum), over_channels(values, np.maximum)


def _failing_pixels(planes: np.ndarray, spread: np.ndarray, failing: np.ndarray):
    """The pixels of the failing blocks, as ``(planes, spread)`` pairs of arrays: whole
    blocks gathered through a strided view, then the partial blocks of the last row and
    column of blocks."""
    height, width, n = planes.shape
    spread = np.broadcast_to(spread, planes.shape)
    rows, cols = height // BLOCK_PX, width // BLOCK_PX
    inner = np.nonzero(failing[:rows, :cols])
    if inner[0].size:
        views = []
        for array in (planes, spread):
            s0, s1, s2 = array.strides
            views.append(
                np.lib.stride_tricks.as_strided(
                    array,
                    (rows, cols, BLOCK_PX, BLOCK_PX, n),
                    (BLOCK_PX * s0, BLOCK_PX * s1, s0, s1, s2),
                    writeable=False,
                )[inner]
            )
        yield views[0], views[1]
    if height % BLOCK_PX and failing[rows:].any():
        band = np.s_[rows * BLOCK_PX :]
        yield planes[band], spread[band]
    if width % BLOCK_PX and failing[:, cols:].any():
        band = np.s_[:, cols * BLOCK_PX :]
        yield planes[band], spread[band]


def block_reduce(values: np.ndarray, ufunc, block: int = BLOCK_PX) -> np.ndarray:
    """``ufunc`` over blocks of ``block × block`` pixels of a 2-D array (the last ones
    smaller): rows of blocks first, over contiguous memory."""
    height, width = values.shape
    full_rows, full_cols = height // block, width // block
    parts = []
    if full_rows:
        parts.append(ufunc.reduce(values[: full_rows * block].reshape(full_rows, block, width), 1))
    if height % block:
        parts.append(ufunc.reduce(values[full_rows * block :], axis=0, keepdims=True))
    rows = np.concatenate(parts) if len(parts) > 1 else parts[0]
    parts = []
    if full_cols:
        main = np.ascontiguousarray(rows[:, : full_cols * block])
        parts.append(ufunc.reduce(main.reshape(rows.shape[0], full_cols, block), axis=2))
    if width % block:
        parts.append(ufunc.reduce(rows[:, full_cols * block :], axis=1, keepdims=True))
    return np.concatenate(parts, axis=1) if len(parts) > 1 else parts[0]
