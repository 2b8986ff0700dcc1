"""Linear convolution of the excess with a kernel, restricted to the bright pixels' box."""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from itertools import pairwise
from typing import Literal

import numpy as np
import scipy.fft
from scipy import ndimage

from glarelab.glare.models.digitise import mirror_quadrant

__all__ = [
    "FFT_WORKERS",
    "FLOAT32_NOISE_LIMIT_CD_M2",
    "SINGLE_THREAD_FFT_POINTS",
    "bounding_box",
    "convolution_dtype",
    "fft_roundoff",
    "fft_workers",
    "line_roundoff_norms",
    "line_sums",
    "spread",
]

FFT_WORKERS = -1  # scipy.fft threads for the convolutions: all cores
# Below this many points a 2-D transform runs in one thread: pocketfft starts its threads per
# call, which cost more than they save on small grids. Measured on the 2-core machine (median
# of 30, the pruned spread of a quarter-size box): 256² transforms 0.17 ms in one thread,
# 0.56 ms on both cores; 96² (a 256² scene's coarse bound) 0.10 and 0.42 ms; 512² alike
# (0.93 and 0.81 ms in float32, 1.15 and 1.40 ms in float64); 1024² and up faster on both.
SINGLE_THREAD_FFT_POINTS = 512 * 512

FLOAT32_NOISE_LIMIT_CD_M2 = 1e-3  # largest FFT round-off the float32 path may add anywhere
# FFT round-off of a convolution by rfft · spectrum · irfft, per pixel (fft_roundoff): a part
# ROUNDOFF_WHITE × √(2 ln n) times its modelled standard deviation (white, and kept in the
# rows and columns of the sources and of the brightest spread), and a part
# ROUNDOFF_RELATIVE · u · log2 n of the pixel's own spread. The constant needed, measured in
# float32 on 1,103 scenes (the bench's; 150 with glints up to 1e9 cd/m² along the image's
# edges; 150 single lamps or glints at corners, edges and centres; 150 random scenes of
# 20-420 px, 300 of 2-64 px and 200 strips one pixel wide, drawn as the property tests draw
# them, with the models with a tail bound; 140 with wave optics, the hybrid and flare
# lines), reached 1.35 (glints along an edge) and 1.5 on a strip; the 1024² city of 2,000
# lamps 0.48. A white model alone needed up to 26.8 and the bound with its constant then,
# 10, failed on 44 of them (by up to 2.68 times): a glint's row keeps the round-off of its
# row transform. The relative part reached 6.6 u log2 n. A strip's one-dimensional
# transforms are not bounded so (up to 5.2 on a 1 × 900 strip): the plan keeps them in
# float64 (glarelab.glare.rendering.plan._choose_precision).
ROUNDOFF_WHITE = 3.0
ROUNDOFF_RELATIVE = 10.0
# Direct spread, seconds per output pixel (2-core machine): a correlation with a cluster's
# box costs CORRELATE_S plus CORRELATE_WEIGHT_S per pixel of the box (scipy.ndimage: 3 × 3 in
# 29 ms at 2048²); a bright pixel's span (_span_spread) SPAN_PIXEL_S in float64 and
# SPAN32_PIXEL_S in float32 per value it runs over (span_values per output pixel). On the
# machine without AVX-512, over 2048² from the 1638 × 1894 quadrant of the night scene's Vos
# kernel (its 31 bright pixels: three 3 × 3 lamps, a 2 × 2 sun; a stride of 3,124, 1.53
# values per output pixel), minima of 7: correlated 155 ms, spans 109 ms in float64 and
# 65 ms in float32 (0.55 and 0.33 ns a value); a lamp's nine spans in float32 over 1,400
# rows 10.4 ms on BLAS's two threads, 13.9 ms on one
CORRELATE_S = 4.5e-9
CORRELATE_WEIGHT_S = 0.4e-9
SPAN_PIXEL_S = 0.55e-9
SPAN32_PIXEL_S = 0.33e-9
# A band of spans holds about this many values (its rows of the kernel's stride): 2^16 84.8
# ms, 2^18 76.4, 2^20 157.5, 2^22 202.3 on the night scene in float32 (a stride of 3,941)
SPAN_BAND_VALUES = 2**18
# float32 spans are summed in float32 at most this many at a time, then added to the float64
# output: the bound on their round-off grows with this number, not with the bright pixels
SPAN32_FLUSH_TERMS = 32
# Laying out the kernel's rows for spans (_span_kernel), seconds per value of the layout: 12 ms
# for the night scene's 1638 × 3941 float32 rows in a fresh process, 1.9 ns a value; with one
# or two glints across a 4096-wide image the layout was most of the spans' time, and a
# correlation per pixel 1.2-2.2 times faster (the choice now counts it)
SPAN_LAYOUT_S = 1.9e-9
# float32 spans' terms and sums stay finite (below 3.4e38): the plan spreads float32 spans only
# where the excess sums to at most this (cd/m² × pixels; a kernel's values are at most 1)
SPAN32_MAX_TOTAL_EXCESS = 1e36
DIRECT_THREAD_PIXELS = 256 * 256  # below this, a direct spread runs in one thread
# A quadrant whose full kernel has at most this many pixels is unfolded for a direct spread
# (about 0.3 ms): a bright pixel then adds one view of it, not up to nine pieces of the quadrant
DIRECT_UNFOLD_PIXELS = 512 * 512


def fft_workers(lengths) -> int:
    """The ``scipy.fft`` workers for transforms of ``lengths`` (one thread below
    :data:`SINGLE_THREAD_FFT_POINTS` points, else :data:`FFT_WORKERS`).

    Examples
    --------
    >>> fft_workers((256, 256)), fft_workers((1024, 1024))
    (1, -1)
    """
    return 1 if math.prod(int(n) for n in lengths) < SINGLE_THREAD_FFT_POINTS else FFT_WORKERS


def convolution_dtype(excess: np.ndarray, kernel: np.ndarray, requested: np.dtype) -> np.dtype:
    """float32 unless its FFT round-off could exceed FLOAT32_NOISE_LIMIT_CD_M2.

    FFT round-off is about machine epsilon times the largest values in the transform, and it
    lands everywhere, including the dark parts of the image. The spread's largest value is at
    most ``Σ ΔL × max K``; next to the sun (Spencer Fig. 16: 7.5e8 cd/m²) float32 would add
    ±2 cd/m² of noise to dark pixels, so such scenes are convolved in float64.
    """
    if requested == np.float64:
        return np.dtype(np.float64)
    bound = float(excess.sum(dtype=np.float64)) * float(kernel.max()) * np.finfo(np.float32).eps
    return np.dtype(np.float64 if bound > FLOAT32_NOISE_LIMIT_CD_M2 else np.float32)


def fft_roundoff(
    lengths: tuple[int, int],
    excess_l1: float,
    excess_l2: float,
    kernel_l1: float,
    kernel_l2: float,
    dtype,
    *,
    rows: tuple[float, float],
    cols: tuple[float, float],
) -> tuple[float, float]:
    """Bound on the round-off of :func:`spectral_spread` in ``dtype``: ``(a, r)`` such that
    each pixel's spread is off by at most ``a + r · S`` cd/m² (``S`` its spread).

    Parameters
    ----------
    lengths
        The FFT lengths ``N0 × N1`` (``n = N0 N1`` points).
    excess_l1, excess_l2
        ``ΣΔL`` and ``(ΣΔL²)^½`` of the excess, cd/m² (the largest over the channels).
    kernel_l1, kernel_l2
        ``Σ|K|`` and ``(ΣK²)^½`` of the kernel (the largest over the channels).
    dtype
        The transforms' precision (its unit round-off ``u = ε / 2``); the kernel spectrum is
        made in float64 and rounded once to it.
    rows, cols
        ``(F, I)`` of :func:`line_roundoff_norms` along the rows and along the columns,
        cd/m²: the round-off a row transform keeps in its row.

    Returns
    -------
    tuple of float
        ``a`` in cd/m² and ``r``, dimensionless.

    Notes
    -----
    Rounding errors of an FFT have a relative RMS of about :math:`u \\sqrt{\\log_2 n}`
    (Schatzman 1996) and are close to white. The forward transform's (carried through the
    spectrum), the inverse's, and the rounding of the spectrum and of the product are
    independent, so their variances add: the white part of a pixel's error has a standard
    deviation

    .. math::

       \\sigma = u \\sqrt{\\log_2 n\\,(|\\Delta L|_2 |K|_2)^2 + (\\log_2 n + 2)\\,|S|_2^2}
       \\,/ \\sqrt{n}, \\qquad |S|_2 \\le \\min(|\\Delta L|_2 |K|_1, |\\Delta L|_1 |K|_2)

    (Parseval and Young's inequality). A row transform's rounding stays in its row: the
    forward transform of a source's row leaves an error of RMS :math:`u \\sqrt{\\log_2
    N_1}\\,|\\Delta L_k|_2 / \\sqrt{N_1}` along row :math:`k`, which the kernel's rows
    spread to the rows near it, and the inverse transform of an output row one of RMS
    :math:`u \\sqrt{\\log_2 N_1}\\,|S_i|_2 / \\sqrt{N_1}` along it (the columns alike),
    so that

    .. math::

       \\sigma^2 \\mathrel{+}= u^2 \\log_2 N_1\\,(F_r^2 + I_r^2) / N_1
       + u^2 \\log_2 N_0\\,(F_c^2 + I_c^2) / N_0

    with :math:`F, I` from :func:`line_roundoff_norms`: next to one glint this part is up to
    :math:`\\sqrt{N_0}` times the white one. The largest of ``n`` such errors is about
    :math:`\\sqrt{2 \\ln n}\\,\\sigma`; next to the sources the error follows the spread
    itself. ``a = ROUNDOFF_WHITE · √(2 ln n) σ`` and ``r = ROUNDOFF_RELATIVE · u · log2 n``,
    with constants measured (:data:`ROUNDOFF_WHITE`): a bound tested on random scenes
    (``tests/glare/rendering/test_error_bound.py``), not a worst case, which would be
    :math:`\\sqrt{n}` times larger and rule float32 out everywhere.

    References
    ----------
    Schatzman, J. C. (1996). Accuracy of the discrete Fourier transform and the fast Fourier
    transform. SIAM J. Sci. Comput. 17(5), 1150-1166.

    Examples
    --------
    A spread whose brightest row holds half its norm rounds it mostly there:

    >>> lines = {"rows": (5e3, 5e4), "cols": (5e3, 5e4)}
    >>> a, r = fft_roundoff((1024, 1024), 1e6, 1e5, 1.0, 0.05, np.float32, **lines)
    >>> f"{a:.2g} cd/m², r = {r:.2g}"
    '0.0066 cd/m², r = 1.2e-05'
    >>> lines = {"rows": (0.0, 0.0), "cols": (0.0, 0.0)}
    >>> a, r = fft_roundoff((1024, 1024), 1e6, 1e5, 1.0, 0.05, np.float32, **lines)
    >>> f"{a:.2g} cd/m² (white alone)"
    '0.00022 cd/m² (white alone)'
    """
    n0, n1 = int(lengths[0]), int(lengths[1])
    n = max(n0 * n1, 2)
    u = float(np.finfo(dtype).eps) / 2.0
    levels = math.log2(n)
    spread_l2 = min(excess_l2 * kernel_l1, excess_l1 * kernel_l2)
    variance = (levels * (excess_l2 * kernel_l2) ** 2 + (levels + 2.0) * spread_l2**2) / n
    for length, (forward, inverse) in ((n1, rows), (n0, cols)):
        if length > 1:
            variance += math.log2(length) * (forward**2 + inverse**2) / length
    sigma = u * math.sqrt(variance)
    return (
        ROUNDOFF_WHITE * math.sqrt(2.0 * math.log(n)) * sigma,
        ROUNDOFF_RELATIVE * u * levels,
    )


def line_roundoff_norms(
    excess_lines: tuple[np.ndarray, np.ndarray], kernel_lines: tuple[np.ndarray, np.ndarray]
) -> tuple[float, float]:
    """Norms of the round-off one axis's transforms keep in their lines, for
    :func:`fft_roundoff`: ``(F, I)``, cd/m².

    Parameters
    ----------
    excess_lines
        ``(Σ_j ΔL_kj, Σ_j ΔL_kj²)`` of each line ``k`` of the excess (rows: summed along
        each row), cd/m² and (cd/m²)², in order.
    kernel_lines
        ``(Σ_j |K_dj|, Σ_j K_dj²)`` of each line ``d`` of the whole kernel, centred (offset
        ``d`` at index ``d + half``).

    Returns
    -------
    tuple of float
        ``F = max_i (Σ_k |ΔL_k|_2² |K_{i-k}|_2²)^½``, the RMS over a line of what the
        forward transforms' round-off becomes at line ``i``, and ``I``, a bound on the largest
        line norm ``|S_i|_2`` of the spread, whose inverse transform rounds it:
        ``max_i min(Σ_k |ΔL_k|_2 |K_{i-k}|_1, Σ_k |ΔL_k|_1 |K_{i-k}|_2)`` (the triangle
        inequality and Young's, line by line).

    Examples
    --------
    One glint of 1e6 cd/m² and a kernel of three lines:

    >>> glint = (np.array([1e6]), np.array([1e12]))
    >>> kernel = (np.array([0.1, 0.5, 0.1]), np.array([0.01, 0.2, 0.01]))
    >>> [round(value) for value in line_roundoff_norms(glint, kernel)]
    [447214, 447214]
    """
    (e1, e2), (k1, k2) = excess_lines, kernel_lines
    forward = _line_convolution(e2, k2).max()
    inverse = np.minimum(
        _line_convolution(np.sqrt(e2), k1), _line_convolution(e1, np.sqrt(k2))
    ).max()
    return math.sqrt(float(forward)), float(inverse)


def line_sums(
    values: np.ndarray, *, absolute: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``Σ|x|`` and ``Σx²`` of each row and of each column of ``values`` ``(H, W, ...)``, in
    float64, by blocks of rows (one pass; no temporary of the array's size): ``(rows_l1,
    rows_l2², cols_l1, cols_l2²)``, of shapes ``(H, ...)`` and ``(W, ...)``. ``absolute``
    False skips ``|x|`` for values known not to be negative.

    Examples
    --------
    >>> [line.tolist() for line in line_sums(np.array([[1.0, -2.0], [0.0, 3.0]]), absolute=True)]
    [[3.0, 3.0], [5.0, 9.0], [1.0, 5.0], [1.0, 13.0]]
    """
    height, width = values.shape[:2]
    channels = values.shape[2:]
    lines = math.prod(channels)
    rows_l1, rows_l2 = np.empty((height, lines)), np.empty((height, lines))
    cols_l1, cols_l2 = np.zeros((width, *channels)), np.zeros((width, *channels))
    for start in range(0, height, _LINE_BLOCK_ROWS):
        block = np.asarray(values[start : start + _LINE_BLOCK_ROWS], dtype=np.float64)
        stop = start + block.shape[0]
        square = block * block
        if absolute:
            block = np.abs(block)
        cols_l1 += block.sum(axis=0)
        cols_l2 += square.sum(axis=0)
        # each channel's rows as a strided 2-D view: a sum over the middle axis of
        # (rows, W, 3) runs an inner loop of 3 and took 100 ms at 2048²
        flat, squares = block.reshape(stop - start, -1), square.reshape(stop - start, -1)
        for channel in range(lines):
            rows_l1[start:stop, channel] = flat[:, channel::lines].sum(axis=1)
            rows_l2[start:stop, channel] = squares[:, channel::lines].sum(axis=1)
    shape = (height, *channels)
    return rows_l1.reshape(shape), rows_l2.reshape(shape), cols_l1, cols_l2


_LINE_BLOCK_ROWS = 16  # rows of line_sums' block: its temporaries stay in the cache


def _line_convolution(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Full convolution of two non-negative 1-D arrays, float64 (by :func:`_full_convolution`
    when long: its round-off, about 1e-13 of the largest value, is far below the constants
    above; what it leaves below zero is clipped)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.size * b.size <= 1 << 16:
        return np.convolve(a, b)
    return np.maximum(_full_convolution(a[None, :], b[None, :])[0], 0.0)


def bounding_box(mask: np.ndarray) -> tuple[slice, slice]:
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def spread(
    excess: np.ndarray,
    kernel: np.ndarray,
    box: tuple[slice, slice],
    *,
    into: np.ndarray | None = None,
    method: str = "fft",
) -> np.ndarray:
    """Linear convolution of ``excess`` (zero outside ``box``) with a centred odd kernel,
    cropped to the image. Only the bounding box of the bright pixels is transformed: exact,
    and far cheaper than the whole image when the bright region is small. With ``into``, the
    result is added to that image-sized array (only where it is non-zero) and returned.
    ``method='direct'`` sums the products instead (for comparison: exact, far slower)."""
    height, width = excess.shape
    rows, cols = box
    if method == "fft":
        full = _full_convolution(excess[rows, cols], kernel)
    elif method == "direct":
        from scipy.signal import convolve

        full = convolve(excess[rows, cols], kernel, mode="full", method="direct")
    else:
        raise ValueError(f"method must be 'fft' or 'direct'; got {method!r}")
    kh, kw = kernel.shape
    # full[a, b] is the response at image pixel (a + rows.start - kh//2, b + cols.start - kw//2)
    top, left = rows.start - kh // 2, cols.start - kw // 2
    out = np.zeros((height, width), dtype=full.dtype) if into is None else into
    src_r0, src_c0 = max(0, -top), max(0, -left)
    dst_r0, dst_c0 = max(0, top), max(0, left)
    n_rows = min(full.shape[0] - src_r0, height - dst_r0)
    n_cols = min(full.shape[1] - src_c0, width - dst_c0)
    if n_rows > 0 and n_cols > 0:
        out[dst_r0 : dst_r0 + n_rows, dst_c0 : dst_c0 + n_cols] += full[
            src_r0 : src_r0 + n_rows, src_c0 : src_c0 + n_cols
        ]
    return out


def _full_convolution(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Full linear convolution of two real 2-D arrays by real FFTs of the next fast lengths:
    the transforms, product and crop ``scipy.signal.fftconvolve(a, b, mode='full')`` makes
    (the same ``scipy.fft`` calls, so the same numbers), on every core, without importing
    ``scipy.signal``, which imports ``scipy.stats``: 0.25-0.3 s of a fresh process's one call
    on a quiet machine, more than the render it served."""
    shape = (a.shape[0] + b.shape[0] - 1, a.shape[1] + b.shape[1] - 1)
    if 0 in a.shape or 0 in b.shape:
        return np.zeros((0, 0), dtype=np.result_type(a, b, np.float32))
    # an axis along which either is one pixel long is a product, not a transform
    axes = [axis for axis in (0, 1) if a.shape[axis] != 1 and b.shape[axis] != 1]
    if not axes:
        return a * b
    lengths = [scipy.fft.next_fast_len(shape[axis], True) for axis in axes]
    with scipy.fft.set_workers(fft_workers(lengths)):  # a scope, not global state
        product = scipy.fft.rfftn(a, lengths, axes=axes) * scipy.fft.rfftn(b, lengths, axes=axes)
        full = scipy.fft.irfftn(product, lengths, axes=axes)
    return full[: shape[0], : shape[1]].copy()


def fft_length(source: tuple[int, int], out: tuple[int, int], half: int) -> int:
    """Shortest fast FFT length along one axis for the linear convolution of sources at
    ``[s0, s1)`` with a kernel of half-size ``half``, wanted at ``[o0, o1)``: no kernel
    value wraps onto a wanted output (``N > max |offset| + half``, ``N >= 2 half + 1``)."""
    (s0, s1), (o0, o1) = source, out
    wanted = max(2 * half + 1, max(o1 - 1 - s0, s1 - 1 - o0) + half + 1)
    return scipy.fft.next_fast_len(wanted, real=True)


def kernel_spectrum(kernel: np.ndarray, lengths: tuple[int, int]) -> np.ndarray:
    """``rfft2`` of a centred odd kernel placed circularly (offset ``d`` at index ``d mod N``)
    on an ``N0 × N1`` grid, for :func:`spectral_spread`."""
    a, b = kernel.shape[0] // 2, kernel.shape[1] // 2
    placed = np.zeros(lengths, dtype=kernel.dtype)
    placed[: 2 * a + 1, : 2 * b + 1] = kernel
    placed = np.roll(placed, (-a, -b), axis=(0, 1))
    with scipy.fft.set_workers(fft_workers(lengths)):
        return scipy.fft.rfft2(placed, overwrite_x=True)


def spectral_spread(
    excess: np.ndarray,
    box: tuple[int, int, int, int],
    out_box: tuple[int, int, int, int],
    spectrum: np.ndarray,
    lengths: tuple[int, int],
) -> np.ndarray:
    """The spread of ``excess`` (the image's ``box``; zero elsewhere) at the pixels of
    ``out_box``, with a kernel spectrum from :func:`kernel_spectrum` (lengths from
    :func:`fft_length`). Exact: linear convolution, no wrap-around onto the pixels returned.

    The 2-D transforms are pruned: the forward row transforms run over the box's rows only
    (the others are zero) and the inverse row transforms over the wanted rows only, which
    saves about a quarter of the work of ``irfft2(rfft2(x) · K̂)`` when the box and the
    output are half the FFT length.
    """
    r0, r1, c0, c1 = box
    o0, o1, u0, u1 = out_box
    n0, n1 = lengths
    cols = (np.arange(c0, c1) - u0) % n1
    rows = (np.arange(r0, r1) - o0) % n0
    with scipy.fft.set_workers(fft_workers(lengths)):
        if cols[0] + cols.size <= n1:
            placed = np.zeros((r1 - r0, n1), dtype=excess.dtype)
            placed[:, cols[0] : cols[0] + cols.size] = excess
        else:
            placed = np.zeros((r1 - r0, n1), dtype=excess.dtype)
            placed[:, cols] = excess
        half_rows = scipy.fft.rfft(placed, axis=1, overwrite_x=True)
        del placed
        product = np.zeros((n0, n1 // 2 + 1), dtype=half_rows.dtype)
        product[rows] = half_rows
        del half_rows
        product = scipy.fft.fft(product, axis=0, overwrite_x=True)
        product *= spectrum
        product = scipy.fft.ifft(product, axis=0, overwrite_x=True)
        full = scipy.fft.irfft(product[: o1 - o0], n=n1, axis=1)
    return full[:, : u1 - u0]


def clusters(bright: np.ndarray) -> list[tuple[tuple[slice, slice], np.ndarray]]:
    """The connected groups of ``bright`` pixels (4-neighbours): each one's bounding box and
    its pixels within the box."""
    labels, _ = ndimage.label(bright)
    return [
        (box, labels[box] == index)
        for index, box in enumerate(ndimage.find_objects(labels), start=1)
    ]


def cluster_method(
    box_shape: tuple[int, int],
    pixels: int,
    *,
    precision: Literal["float64", "float32"] = "float64",
    costs: tuple[float, float, float] | None = None,
    values: float = 1.0,
) -> Literal["correlation", "spans"]:
    """How :func:`direct_spread` spreads a cluster of ``pixels`` bright pixels in a box of
    ``box_shape``: ``'correlation'`` (one ``scipy.ndimage.correlate`` of the kernel with the
    box) or ``'spans'`` (a scaled copy of the kernel per bright pixel, :func:`_span_spread`),
    the cheaper by ``costs``, ``(correlate_s, correlate_weight_s, span_pixel_s)`` seconds
    per output pixel (default: :data:`CORRELATE_S`, :data:`CORRELATE_WEIGHT_S` and the
    precision's :data:`SPAN_PIXEL_S` or :data:`SPAN32_PIXEL_S`), a span's per value it runs
    over, ``values`` per output pixel (:func:`span_values`). The plan prices the same choice
    with the machine's costs.

    Examples
    --------
    >>> cluster_method((3, 3), 9), cluster_method((3, 3), 9, values=8.0)
    ('spans', 'correlation')
    """
    if costs is None:
        costs = (CORRELATE_S, CORRELATE_WEIGHT_S, _span_cost(precision))
    correlate_s, weight_s, span_s = costs
    if correlate_s + weight_s * box_shape[0] * box_shape[1] < span_s * values * pixels:
        return "correlation"
    return "spans"


def cluster_ways(
    clusters: list[tuple[tuple[int, int], int]],
    *,
    area: int,
    values: float,
    layout_values: int,
    precision: Literal["float64", "float32"] = "float64",
    costs: tuple[float, float, float] | None = None,
) -> list[Literal["correlation", "spans"]]:
    """How :func:`direct_spread` spreads each cluster ``(box_shape, pixels)``: by
    :func:`cluster_method`, unless the spans chosen, with the kernel's layout they share
    (``layout_values`` values at :data:`SPAN_LAYOUT_S` each), cost more than correlating
    those clusters over ``area`` output pixels: then every cluster is correlated. The plan
    prices the same choice with the machine's costs.

    Examples
    --------
    >>> cluster_ways([((1, 1), 1)], area=512**2, values=8.0, layout_values=10**6)
    ['correlation']
    >>> cluster_ways([((3, 3), 9)] * 3, area=2048**2, values=1.5, layout_values=5 * 10**6,
    ...              precision="float32")
    ['spans', 'spans', 'spans']
    """
    ways = [
        cluster_method(shape, pixels, precision=precision, costs=costs, values=values)
        for shape, pixels in clusters
    ]
    if "spans" not in ways:
        return ways
    correlate_s, weight_s, span_s = (
        costs if costs is not None else (CORRELATE_S, CORRELATE_WEIGHT_S, _span_cost(precision))
    )
    chosen = [(shape, pixels) for (shape, pixels), way in zip(clusters, ways, strict=True)
              if way == "spans"]  # fmt: skip
    spans = sum(span_s * values * pixels for _, pixels in chosen) * area
    spans += SPAN_LAYOUT_S * layout_values
    correlated = sum(correlate_s + weight_s * shape[0] * shape[1] for shape, _ in chosen) * area
    return ["correlation"] * len(ways) if spans > correlated else ways


def span_layout_values(kernel_rows: int, out_columns: int, source_columns: int) -> int:
    """Values of the kernel's layout for spans (:func:`_span_kernel`): its rows (a
    quadrant's, else all) times the stride, the output's columns plus the bright pixels'
    spread of columns."""
    return kernel_rows * (out_columns + source_columns)


def _span_cost(precision: str) -> float:
    if precision == "float32":
        return SPAN32_PIXEL_S
    if precision == "float64":
        return SPAN_PIXEL_S
    raise ValueError(f"precision must be 'float64' or 'float32'; got {precision!r}")


def span_roundoff(bright_pixels: int, total_excess: float) -> tuple[float, float]:
    """Bound on the round-off of float32 spans (:func:`_span_spread`): ``(a, r)`` such that
    each pixel's spread is off by at most ``a + r · S`` cd/m² (``S`` its spread, exact).

    Parameters
    ----------
    bright_pixels
        The spans spread (bright pixels), at most.
    total_excess
        ``ΣΔL`` of the spans, cd/m² × pixels.

    Returns
    -------
    tuple of float
        ``a`` in cd/m² and ``r``, dimensionless.

    Notes
    -----
    Every term ``ΔL_q K(p - q)`` is at least 0 (a kernel's values are checked to be), so a
    float32 sum of ``m`` of them, each rounded at most twice (the kernel value and the weight
    rounded to float32, the product and the sum rounded unless fused), is within
    :math:`\\gamma_{2m+2} = (2m+2) u / (1 - (2m+2) u)` of its exact value (Higham 2002,
    §3.1 and §4.2), with :math:`u = 2^{-24}` and :math:`m` at most
    :data:`SPAN32_FLUSH_TERMS`. Each such sum is added to the float64 output: at most
    :math:`k = 2 (\\lceil N / m \\rceil + 1)` float64 additions at a pixel (``N`` the
    bright pixels; a band's two halves at each of its flushes and at its end), each within
    :math:`2^{-53}` of the running sum, :math:`\\gamma_k` with :math:`u = 2^{-53}`. Values
    below float32's normal range (:math:`2^{-126}`) round by at most that much, wherever
    they are flushed to zero: ``a`` counts :math:`2^{-125}` per term and per unit of
    excess.

    References
    ----------
    Higham, N. J. (2002). Accuracy and Stability of Numerical Algorithms (2nd ed.). SIAM.

    Examples
    --------
    >>> a, r = span_roundoff(31, 1e9)
    >>> f"{r:.3g}"
    '3.93e-06'
    """
    terms = 2 * SPAN32_FLUSH_TERMS + 2
    u32, u64 = 2.0**-24, 2.0**-53
    sums = 2 * (math.ceil(max(int(bright_pixels), 1) / SPAN32_FLUSH_TERMS) + 1)
    relative = terms * u32 / (1.0 - terms * u32) + sums * u64 / (1.0 - sums * u64)
    absolute = (float(total_excess) + 2.0 * int(bright_pixels)) * 2.0**-125
    return absolute, relative


def direct_spread(
    excess: np.ndarray,
    origin: tuple[int, int],
    kernel: np.ndarray,
    out_box: tuple[int, int, int, int],
    into: np.ndarray,
    *,
    quadrant: bool = False,
    workers: int | None = None,
    groups: list[tuple[tuple[slice, slice], np.ndarray]] | None = None,
    method: Literal["cheapest", "correlation", "spans"] = "cheapest",
    precision: Literal["float64", "float32"] = "float64",
    costs: tuple[float, float, float] | None = None,
) -> np.ndarray:
    """Add the spread of the non-zero pixels of ``excess`` (whose first pixel is the image's
    ``origin``) to ``into`` (image-sized) at the pixels of ``out_box``, with no FFT
    round-off. Each cluster of bright pixels (a glint, a lamp, a sun) is one correlation of
    the kernel with the cluster's box (``scipy.ndimage.correlate``, in float64), or adds a
    scaled copy of the kernel per pixel (:func:`_span_spread`, in ``precision``), whichever
    :func:`cluster_method` estimates cheaper by ``costs``.

    ``kernel`` is the centred odd kernel, or with ``quadrant=True`` the quadrant of offsets
    ``i, j >= 0`` of a kernel symmetric in both axes, read through reversed views where the
    offsets are negative (the full kernel is never made, unless it has at most
    :data:`DIRECT_UNFOLD_PIXELS` pixels). The correlations share the output rows among
    ``workers`` threads (default: every core; ``scipy.ndimage`` releases the GIL); each
    pixel's sum is taken in the same order whatever their number, so the result is the same.
    The spans run on BLAS's threads. ``groups`` are the :func:`clusters` of ``excess > 0``
    when the caller has them already. ``method`` ``'correlation'`` or ``'spans'`` spreads
    every cluster so (the costs' calibration times each);
    ``'cheapest'`` chooses per cluster. float32 spans are within :func:`span_roundoff` of
    the spread.
    """
    if method not in ("cheapest", "correlation", "spans"):
        raise ValueError(f"method must be 'cheapest', 'correlation' or 'spans'; got {method!r}")
    if precision not in ("float64", "float32"):
        raise ValueError(f"precision must be 'float64' or 'float32'; got {precision!r}")
    sources, spans = [], []
    found = []
    for box, mask in clusters(excess > 0) if groups is None else groups:
        weights = np.where(mask, excess[box], 0)
        pixels = int(np.count_nonzero(weights))
        if pixels:  # a caller's group may have nothing to spread
            found.append((weights, (origin[0] + box[0].start, origin[1] + box[1].start), pixels))
    if not found:
        return into
    if method == "cheapest":
        a, b = _kernel_half(kernel, quadrant)
        spread = max(p + w.shape[1] - 1 for w, (_, p), _ in found) - min(
            p for _, (_, p), _ in found
        )
        width = out_box[3] - out_box[2]
        ways = cluster_ways(
            [(weights.shape, pixels) for weights, _, pixels in found],
            area=min(width * (out_box[1] - out_box[0]), (2 * a + 1) * (2 * b + 1)),
            values=span_values(width, spread, b),
            layout_values=span_layout_values(a + 1, width, spread),
            precision=precision,
            costs=costs,
        )
    else:
        ways = [method] * len(found)
    for (weights, start, _), how in zip(found, ways, strict=True):
        if how == "correlation":
            sources.append((weights, start))
        else:
            rows, cols = np.nonzero(weights)
            spans.append((rows + start[0], cols + start[1], weights[rows, cols]))
    if spans:
        points = tuple(np.concatenate(parts) for parts in zip(*spans, strict=True))
        _span_spread(points, kernel, out_box, into, quadrant=quadrant, precision=precision)
    if not sources:
        return into
    if quadrant and (2 * kernel.shape[0] - 1) * (2 * kernel.shape[1] - 1) <= DIRECT_UNFOLD_PIXELS:
        kernel, quadrant = mirror_quadrant(kernel), False
    workers = _direct_workers(out_box) if workers is None else max(1, int(workers))
    edges = np.linspace(out_box[0], out_box[1], workers + 1).round().astype(int)
    bands = [(int(lo), int(hi), out_box[2], out_box[3]) for lo, hi in pairwise(edges) if hi > lo]
    scratch = max(w.shape[0] for w, _ in sources), max(w.shape[1] for w, _ in sources)

    def spread_band(band) -> None:
        buffer = np.empty(
            (band[1] - band[0] + scratch[0]) * (band[3] - band[2] + scratch[1]), dtype=into.dtype
        )
        for weights, start in sources:
            _correlate(weights, start, kernel, band, into, buffer, quadrant=quadrant)

    if len(bands) == 1:
        spread_band(bands[0])
    else:
        with ThreadPoolExecutor(len(bands)) as pool:
            list(pool.map(spread_band, bands))
    return into


def span_values(out_columns: int, source_columns: int, half_columns: int) -> float:
    """Values a span runs over per output pixel it reaches (:func:`_span_spread`): its
    band's stride, the output's ``out_columns`` plus the bright pixels' spread of columns
    ``source_columns`` (their last less their first), over the columns a bright pixel
    reaches, at most ``2 half_columns + 1``. About 1.5 for the night scene's 2048² output,
    and large for a narrow kernel over a wide output, where a correlation costs less.

    Examples
    --------
    >>> round(span_values(2048, 1076, 1893), 2), round(span_values(1024, 1000, 7), 2)
    (1.53, 134.93)
    """
    reached = min(2 * half_columns + 1, out_columns)
    return (out_columns + source_columns) / max(reached, 1)


def _span_kernel(kernel: np.ndarray, quadrant: bool, first: int, stride: int, dtype):
    """The kernel's rows for :func:`_span_spread`: a quadrant's rows of offsets ``0 … a``
    (else every row), each the columns ``first … first + stride - 1`` of the row unfolded
    to the column offsets ``-b … b`` (column ``b + d`` for offset ``d``), zeros outside
    them, contiguous, in ``dtype``."""
    b = _kernel_half(kernel, quadrant)[1]
    rows = np.zeros((kernel.shape[0], stride), dtype=dtype)
    lo, hi = max(first, 0), min(first + stride, 2 * b + 1)  # the support's columns in it
    if lo >= hi:
        return rows
    if not quadrant:
        rows[:, lo - first : hi - first] = kernel[:, lo:hi]
        return rows
    if lo < b:  # offsets lo - b … min(hi, b) - b - 1 < 0: the quadrant read backwards
        top = min(hi, b)
        rows[:, lo - first : top - first] = kernel[:, b - lo : b - top : -1]
    if hi > b:  # offsets max(lo, b) - b … hi - b - 1 >= 0
        low = max(lo, b)
        rows[:, low - first : hi - first] = kernel[:, low - b : hi - b]
    return rows


def _span_spread(points, kernel, out_box, into, *, quadrant: bool, precision: str) -> None:
    """Add ``w K(p - q)`` for each bright pixel ``q`` of weight ``w`` (``points``: arrays of
    rows, columns and weights, image coordinates) to ``into`` at the pixels ``p`` of
    ``out_box``: a BLAS ``axpy`` per bright pixel and band of output rows, over the band as
    one run of values.

    The kernel's rows are laid out with a stride ``S``, the output's columns plus the
    bright pixels' spread of columns, holding the kernel columns any output column reads
    (zeros past the support), and the band's output rows with the same stride: a pixel's
    copy over the band's rows is then one run of memory in both, its values between rows
    landing on zeros or on the band's columns past the output's (discarded). The rows below
    a bright pixel and those above it are summed apart; a quadrant's rows above are read
    downwards into a band held upside down, so that its rows run the way the kernel's do
    (the same sums as the full kernel's, but that BLAS may round the ends of a run
    otherwise). In float32 the sums are added to ``into`` at least every
    :data:`SPAN32_FLUSH_TERMS` terms (:func:`span_roundoff`)."""
    # imports scipy.linalg (about 70 ms) where nothing has yet: a display LUT read from a
    # calibration file has
    from scipy.linalg.blas import daxpy, saxpy

    ys, xs, ws = (np.asarray(part) for part in points)
    r0, r1, c0, c1 = out_box
    a, b = _kernel_half(kernel, quadrant)
    reached = (np.maximum(c0, xs - b) < np.minimum(c1, xs + b + 1)) & (ys - a < r1)
    reached &= ys + a >= r0
    if not reached.any():
        return
    ys, xs, ws = ys[reached], xs[reached], ws[reached]
    width = c1 - c0
    stride = width + int(xs.max() - xs.min())
    first = c0 - int(xs.max()) + b  # the unfolded kernel's column at the layout's first
    dtype = np.float32 if precision == "float32" else np.float64
    axpy = saxpy if precision == "float32" else daxpy
    flat = _span_kernel(kernel, quadrant, first, stride, dtype).ravel()
    band = max(1, SPAN_BAND_VALUES // stride)
    down, up = np.zeros(band * stride, dtype), np.zeros(band * stride, dtype)
    flush = SPAN32_FLUSH_TERMS if precision == "float32" else len(ws)
    order = -1 if quadrant else 1  # the order of the rows above the bright pixels' band
    los, his = np.maximum(c0, xs - b), np.minimum(c1, xs + b + 1)

    def add(y0: int, y1: int, used: list[bool]) -> None:
        rows = y1 - y0
        if used[0]:
            into[y0:y1, c0:c1] += down[: rows * stride].reshape(rows, stride)[:, :width]
            down[: rows * stride] = 0
        if used[1]:
            into[y0:y1, c0:c1] += up[: rows * stride].reshape(rows, stride)[::order, :width]
            up[: rows * stride] = 0
        used[:] = [False, False]

    for y0 in range(r0, r1, band):
        y1 = min(r1, y0 + band)
        used, count = [False, False], 0
        near = np.flatnonzero((ys - a < y1) & (ys + a >= y0))  # the pixels reaching the band
        for y, x, w, lo, hi in zip(
            ys[near].tolist(), xs[near].tolist(), ws[near].tolist(), los[near].tolist(),
            his[near].tolist(), strict=True,
        ):  # fmt: skip
            column = lo - x + b - first  # the layout's column at the first output reached
            # the rows at and below the bright pixel (offsets 0 … a), then those above it
            # (-a … -1): each summed apart, from a quadrant as from the full kernel (the same
            # terms in the same order)
            ya, yb = max(y0, y), min(y1, y + a + 1)
            if ya < yb:
                axpy(
                    flat, down, n=(yb - ya - 1) * stride + hi - lo, a=w,
                    offx=(ya - y + (0 if quadrant else a)) * stride + column,
                    offy=(ya - y0) * stride + lo - c0,
                )  # fmt: skip
                used[0] = True
            ya, yb = max(y0, y - a), min(y1, y)
            if ya < yb:
                if quadrant:  # offsets -1 … -a downwards: into the upside-down band
                    start = (y - yb + 1) * stride + column, (y1 - yb) * stride + lo - c0
                else:
                    start = (ya - y + a) * stride + column, (ya - y0) * stride + lo - c0
                axpy(
                    flat, up, n=(yb - ya - 1) * stride + hi - lo, a=w, offx=start[0],
                    offy=start[1],
                )  # fmt: skip
                used[1] = True
            count += 1
            if count % flush == 0:
                add(y0, y1, used)
        add(y0, y1, used)


def _direct_workers(out_box: tuple[int, int, int, int]) -> int:
    """Threads for a direct spread: every core, for outputs large enough to gain from it."""
    pixels = (out_box[1] - out_box[0]) * (out_box[3] - out_box[2])
    if pixels < DIRECT_THREAD_PIXELS:
        return 1
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, (out_box[1] - out_box[0]) // 64))


def _parts(lo: int, hi: int, first: int, size: int, half: int, quadrant: bool):
    """Output pixels ``lo … hi - 1`` of one axis, for a box of ``size`` pixels from ``first``
    and a kernel reaching ``half`` pixels, cut into runs in which the kernel offsets needed,
    ``d = output - (first + u)`` for ``u < size``, stay within the support or outside it, and
    (for a quadrant) keep one sign: ``(start, stop, lowest d, highest d)`` of each run."""
    cuts = {lo, hi, first + size - 1 - half, first + half + 1}
    if quadrant:
        cuts |= {first, first + size}
    cuts = sorted(c for c in cuts if lo <= c <= hi)
    return [(a, b, a - first - size + 1, b - 1 - first) for a, b in pairwise(cuts) if b > a]


def _select(low: int, high: int, half: int, quadrant: bool):
    """How to read kernel offsets ``low … high`` along one axis: a slice (a view; reversed
    for the negative offsets of a quadrant) or, across the centre of a quadrant or past the
    support, the indices to gather and which of them lie within the support."""
    if quadrant:
        if 0 <= low and high <= half:
            return slice(low, high + 1)
        if -half <= low and high <= 0:
            return slice(-low, -high - 1 if high < 0 else None, -1)
        offsets = np.arange(low, high + 1)
        return np.minimum(np.abs(offsets), half), np.abs(offsets) <= half
    if -half <= low and high <= half:
        return slice(half + low, half + high + 1)
    offsets = np.arange(low, high + 1)
    return np.clip(offsets + half, 0, 2 * half), np.abs(offsets) <= half


def _window(kernel: np.ndarray, rows, cols) -> np.ndarray:
    """The kernel offsets of a row and a column selection (:func:`_select`), zero beyond the
    support: a view where both are slices."""
    if isinstance(rows, slice) and isinstance(cols, slice):
        return kernel[rows, cols]
    row_index = np.arange(kernel.shape[0])[rows] if isinstance(rows, slice) else rows[0]
    col_index = np.arange(kernel.shape[1])[cols] if isinstance(cols, slice) else cols[0]
    window = kernel[np.ix_(row_index, col_index)]
    if not isinstance(rows, slice):
        window[~rows[1]] = 0
    if not isinstance(cols, slice):
        window[:, ~cols[1]] = 0
    return window


def _convolve_cluster(weights, start, kernel, box, into, *, quadrant) -> None:
    """Add the spread of a cluster larger than the kernel to ``into`` at the pixels of
    ``box`` (which it reaches): the kernel slides over the cluster. ``ndimage`` keeps a table
    of the filter's offsets for each border position, about the filter's size squared: with
    the cluster as the filter, a 300 × 256 sky under a 3 × 3 kernel raised MemoryError."""
    full = mirror_quadrant(kernel) if quadrant else kernel
    a, b = full.shape[0] // 2, full.shape[1] // 2
    (bh, bw), (q0, p0), (r0, r1, c0, c1) = weights.shape, start, box
    y0, y1 = max(q0, r0 - a), min(q0 + bh, r1 + a)  # the cluster's rows and columns that
    x0, x1 = max(p0, c0 - b), min(p0 + bw, c1 + b)  # reach the box
    padded = np.zeros((r1 - r0 + 2 * a, c1 - c0 + 2 * b), dtype=into.dtype)
    padded[y0 - r0 + a : y1 - r0 + a, x0 - c0 + b : x1 - c0 + b] = weights[
        y0 - q0 : y1 - q0, x0 - p0 : x1 - p0
    ]
    spread = ndimage.convolve(padded, full, mode="constant")
    into[r0:r1, c0:c1] += spread[a : a + r1 - r0, b : b + c1 - c0]


def _kernel_half(kernel: np.ndarray, quadrant: bool) -> tuple[int, int]:
    """The offsets a kernel reaches on each axis: a quadrant's size less one, a centred odd
    kernel's half-size."""
    if quadrant:
        return kernel.shape[0] - 1, kernel.shape[1] - 1
    return kernel.shape[0] // 2, kernel.shape[1] // 2


def _correlate(weights, start, kernel, out_box, into, buffer, *, quadrant) -> None:
    """Add the spread of ``weights`` (a box whose first pixel is the image's ``start``) to
    ``into`` at the pixels of ``out_box`` it reaches (``buffer``: room for the correlation
    of the largest window): one correlation of each kernel window with the box
    (``scipy.ndimage.correlate``), or for a single pixel a scaled view of each window."""
    a, b = _kernel_half(kernel, quadrant)
    (bh, bw), (q0, p0) = weights.shape, start
    r0, r1 = max(out_box[0], q0 - a), min(out_box[1], q0 + bh + a)
    c0, c1 = max(out_box[2], p0 - b), min(out_box[3], p0 + bw + b)
    if r0 >= r1 or c0 >= c1:
        return
    if weights.size == 1 and not quadrant:  # one pixel: a scaled copy, one view
        window = kernel[r0 - q0 + a : r1 - q0 + a, c0 - p0 + b : c1 - p0 + b]
        into[r0:r1, c0:c1] += weights[0, 0] * window
        return
    if (2 * a + 1) * (2 * b + 1) < weights.size:  # a cluster larger than the kernel
        _convolve_cluster(weights, start, kernel, (r0, r1, c0, c1), into, quadrant=quadrant)
        return
    flipped = weights[::-1, ::-1]
    columns = [
        (ca, cb, _select(d0, d1, b, quadrant))
        for ca, cb, d0, d1 in _parts(c0, c1, p0, bw, b, quadrant)
    ]
    for ra, rb, d0, d1 in _parts(r0, r1, q0, bh, a, quadrant):
        rows = _select(d0, d1, a, quadrant)
        for ca, cb, cols in columns:
            window = _window(kernel, rows, cols)
            if weights.size == 1:  # one pixel: a scaled copy
                into[ra:rb, ca:cb] += weights[0, 0] * window
                continue
            out = buffer[: window.size].reshape(window.shape)
            ndimage.correlate(window, flipped, output=out, mode="constant")
            into[ra:rb, ca:cb] += out[bh // 2 : bh // 2 + rb - ra, bw // 2 : bw // 2 + cb - ca]
