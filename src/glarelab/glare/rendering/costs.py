"""What each path costs on this machine: :class:`PathCosts`, measured once and kept.

The planner chooses the cheapest path by estimated seconds; only their ratios matter, so the
constants must be measured where the render runs, at the number of threads it will use: the
FFTs run on every core (``scipy.fft`` workers), the direct spread shares its rows among the
cores, and the far tail's splat and interpolation are numpy products on one. The first
renderer on a machine with a kernel cache measures them (about 1.3 s on a quiet
machine: 21 alternating rounds, each unit's median ratio to the FFT's in the same round,
scaled by the FFT's fastest round) and writes them next to the kernels
(``costs-<threads>-threads.json``, written to a temporary name and renamed); later processes
read them. Without a cache, the constants measured on a 2-core
machine are used (:data:`DEFAULT_COSTS`).
"""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

__all__ = [
    "DEFAULT_COSTS",
    "PathCosts",
    "coarse_lengths",
    "cores",
    "fft_unit",
    "machine_costs",
    "measure_costs",
    "n_log_n",
]

COSTS_VERSION = 11  # bump when what is measured changes (11: spans in float64 and float32)
# calibration rounds: the FFT's fastest, the others' median ratio to it. Four calibrations
# on the quiet 2-core machine put a scaled kernel copy at 13.8-21.6 FFT units with 7 rounds
# (0.5 s), 14.2-16.2 with 21 (1.3 s, once per machine): on two lamps and a glint (512²)
# the direct path and the FFT are within 15 % of each other, and the wider spread chose
# the FFT where the direct spread was faster
ROUNDS = 21
# The FFT's cost per n log2 n grows once its arrays leave the caches: measured with a 2048²
# box into 4096² transforms (n = LARGE_FFT_POINTS) beside the 1024² unit, it was 2.1 times
# the unit in float64 and 3.5 times in float32 (2-core machine, load average 3.4), where
# 2048² transforms cost the unit's. The unit grows log-linearly from SMALL_FFT_POINTS to
# LARGE_FFT_POINTS and stays there beyond; a 2048² scene with a sun's glint (4096²
# transforms) was costed at half its time and rendered by FFT in twice the direct path's.
SMALL_FFT_POINTS = 2**22
LARGE_FFT_POINTS = 2**24
LARGE_ROUNDS = 3  # the large transforms' rounds (0.2-0.4 s each)
# The direct spread is timed over a DIRECT_COST_SIDE² output, where its cost per output pixel
# includes what a spread costs whatever its size (threads, windows), and over one twice as
# wide, whose extra time per extra pixel is ``direct_wide_share`` of that: a 3 × 3 cluster
# from a 2049² quadrant cost 16.7 ns per output pixel at 512², 10.3 at 1024² and 8.2 at
# 2048² (2-core machine without AVX-512). Costed per pixel at 512² alone, the 2048² night
# scene with a sun's four clusters was put at 1.6 times its direct spread's time, a tie
# with its transforms, which took 1.5 times the direct path; costed by the extra time alone,
# small scenes (two to four lamps at 256² and 512²) took the direct path at 1.2-1.5 times
# the FFT's time. The large cluster has BIG_SIDE² pixels (8 × 8: about 45 ms at 1024²)
DIRECT_COST_SIDE = 512
# measured 0.43-0.67; at 0.1 the direct path was taken for 10 lamps at 1024² and 20 at 2048²
# where the FFT took 0.58 and 0.46 of its time
WIDE_SHARE_LIMITS = (0.3, 1.0)
BIG_SIDE = 8


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


@dataclass(frozen=True)
class PathCosts:
    """Seconds per unit of work of each path.

    Attributes
    ----------
    fft_s, fft32_s
        A forward and an inverse pruned real FFT and the product, per ``n log2 n`` of the
        ``N0 × N1`` transform, in float64 and float32, up to :data:`SMALL_FFT_POINTS`.
    fft_large_s, fft32_large_s
        The same from :data:`LARGE_FFT_POINTS` on (:func:`fft_unit` between the two).
    direct_pixel_s, span32_pixel_s
        A bright pixel's scaled kernel copy (a span), per value it runs over
        (:func:`~glarelab.glare.rendering._convolve.span_values` per output pixel), in
        float64 and in float32.
    correlate_s, correlate_weight_s
        A cluster's correlation, per output pixel, plus per pixel of the cluster's box.
    direct_wide_share
        What each output pixel beyond the first ``DIRECT_COST_SIDE ** 2`` costs a direct
        spread, as a share of the costs above (measured over an output of that many pixels,
        :data:`DIRECT_COST_SIDE` a side).
    multires_s
        The far tail's splat and interpolation, per image pixel.
    bound_s
        The error bound of a spread with a relative error (the far tail's, float32
        round-off's), per image pixel and channel: checked by blocks, with no block over the
        tolerance (those are checked again pixel by pixel; where the preview predicts the
        error, few are).
    coarse_fft_s
        One convolution on the coarse grid (a full linear convolution: three real FFTs
        and the product), per ``n log2 n`` of its ``N0 × N1`` transform: its size follows
        the coarse grid, not the image.
    preview_s
        The plan's preview of the far tail, but for its coarse convolution: the darkest
        pixel of each cell and the brightest channel's splat, per image pixel.
    threads
        The threads they were measured with.
    """

    fft_s: float = 4.5e-10
    fft32_s: float = 3.0e-10
    # the defaults' unit was set on large transforms already (4.5e-10 s where the 1024²
    # unit measured 2.6-3.4e-10 s): no growth
    fft_large_s: float = 4.5e-10
    fft32_large_s: float = 3.0e-10
    # glarelab.glare.rendering._convolve's SPAN_PIXEL_S, SPAN32_PIXEL_S, CORRELATE_S and
    # CORRELATE_WEIGHT_S
    direct_pixel_s: float = 0.55e-9
    span32_pixel_s: float = 0.33e-9
    correlate_s: float = 4.5e-9
    correlate_weight_s: float = 0.4e-9
    direct_wide_share: float = 0.6
    # the far tail's, the bound's and the preview's: their ratios to fft_s in the fastest of
    # five rounds on the 2-core machine (at a load average of 6-9: 9, 20, 3.3 and 4)
    multires_s: float = 4.0e-9
    bound_s: float = 9.0e-9
    coarse_fft_s: float = 1.5e-9
    preview_s: float = 2.0e-9
    threads: int = 2


DEFAULT_COSTS = PathCosts()


def _relative(functions: dict, reference: str, rounds: int = ROUNDS) -> dict:
    """Seconds of each function: the ``reference``'s fastest round times the median, over
    rounds, of the function's time over the reference's in the same round.

    The functions run in turn ``rounds`` times (alternating rounds: a busy moment of a shared
    machine falls on all of them alike). The planner compares only ratios, and the planner
    test and the benchmark compare paths by medians of per-round times and ratios; the
    fastest round of each function alone pairs a quiet moment of one with a busy one of
    another: at a load average of 2-8 on the 2-core machine, three calibrations by fastest
    rounds put a 3 × 3 cluster's direct spread at 0.29, 0.39 and 0.61 of the FFT unit.
    """
    times = {name: [] for name in functions}
    for _ in range(rounds):
        for name, function in functions.items():
            start = time.perf_counter()
            function()
            times[name].append(time.perf_counter() - start)
    base = np.asarray(times[reference])
    fastest = float(base.min())
    return {name: fastest * float(np.median(np.asarray(t) / base)) for name, t in times.items()}


def coarse_lengths(
    shape: tuple[int, int], kernel_half: tuple[int, int], factor: int
) -> tuple[int, int]:
    """The transform lengths of the far tail's coarse convolution: the whole coarse grid
    against the whole coarse kernel, a full linear convolution (the largest it can be).

    Parameters
    ----------
    shape
        The image's ``(H, W)``, pixels.
    kernel_half
        The reference kernel's half-size ``(rows, cols)``, pixels.
    factor
        Pixels per coarse node ``f``.

    Returns
    -------
    tuple of int
        ``(N0, N1)``: fast real-FFT lengths.

    Examples
    --------
    >>> coarse_lengths((1024, 1024), (1023, 1023), 8), coarse_lengths((512, 512), (511, 511), 4)
    ((400, 400), (400, 400))
    """
    import scipy.fft

    from glarelab.glare.rendering.multires import FOOTPRINT_NODES, grid_shape

    grid = grid_shape(shape, factor)
    kernel = [2 * (-(-h // factor) + FOOTPRINT_NODES) + 1 for h in kernel_half]
    return tuple(
        scipy.fft.next_fast_len(g + k - 1, real=True) for g, k in zip(grid, kernel, strict=True)
    )


def n_log_n(lengths: tuple[int, int]) -> float:
    """``n log2 n`` of an ``N0 × N1`` transform, the unit of the FFT costs.

    Parameters
    ----------
    lengths
        ``(N0, N1)``.

    Returns
    -------
    float
        ``n log2 n`` with ``n = N0 N1``.

    Examples
    --------
    >>> n_log_n((4, 4))
    64.0
    """
    n = int(lengths[0]) * int(lengths[1])
    return n * math.log2(max(n, 2))


def fft_unit(points: int, costs: PathCosts, precision: str = "float64") -> float:
    """Seconds per ``n log2 n`` of an FFT pair of ``points`` points: the small transforms'
    unit up to :data:`SMALL_FFT_POINTS`, the large ones' from :data:`LARGE_FFT_POINTS`, and
    log-linear in ``log2 n`` between.

    Parameters
    ----------
    points
        ``n = N0 N1``.
    costs
        The machine's costs.
    precision
        ``'float64'`` or ``'float32'``.

    Returns
    -------
    float
        Seconds per ``n log2 n``.

    Examples
    --------
    >>> costs = PathCosts(fft_s=1.0, fft_large_s=4.0)
    >>> [fft_unit(2**k, costs) for k in (20, 22, 23, 24, 26)]
    [1.0, 1.0, 2.0, 4.0, 4.0]
    """
    if precision == "float32":
        small, large = costs.fft32_s, costs.fft32_large_s
    elif precision == "float64":
        small, large = costs.fft_s, costs.fft_large_s
    else:
        raise ValueError(f"precision must be 'float64' or 'float32'; got {precision!r}")
    low, high = math.log2(SMALL_FFT_POINTS), math.log2(LARGE_FFT_POINTS)
    share = min(max((math.log2(max(points, 2)) - low) / (high - low), 0.0), 1.0)
    return small * (large / small) ** share


def measure_costs() -> PathCosts:
    """Time each path's unit of work on this machine, at the threads the render uses.

    Examples
    --------
    >>> costs = measure_costs()
    >>> costs.fft_s > 0 and costs.threads >= 1
    True
    """
    from glarelab.glare.rendering._convolve import (
        direct_spread,
        kernel_spectrum,
        span_values,
        spectral_spread,
    )
    from glarelab.glare.rendering.display import CodeBound, block_reduce, display_lut
    from glarelab.glare.rendering.multires import (
        FOOTPRINT_NODES,
        far_spread,
        grid_shape,
        splat,
        upsample,
    )

    rng = np.random.default_rng(0)
    n = DIRECT_COST_SIDE  # a 512² box into a 1024² transform: large enough for threads to matter
    lengths = (2 * n, 2 * n)
    excess = rng.random((n, n))
    kernel = rng.random((2 * n - 1, 2 * n - 1))
    unit = lengths[0] * lengths[1] * np.log2(lengths[0] * lengths[1])
    box, out = (0, n, 0, n), (0, n, 0, n)
    full = kernel_spectrum(kernel, lengths)
    work = {np.float64: excess, np.float32: excess.astype(np.float32)}
    spectra = {np.float64: full, np.float32: full.astype(np.complex64)}
    into = np.zeros((n, n))
    # the quadrant of a symmetric kernel too large to unfold, read through reversed views
    # where the offsets are negative: how the renderer spreads a full-reach kernel directly
    quadrant = kernel[: n + 1, : n + 1]
    centre = (n // 2, n // 2)
    small, big = np.ones((3, 3)), np.ones((BIG_SIDE, BIG_SIDE))
    small_groups = [((slice(0, 3), slice(0, 3)), np.ones((3, 3), bool))]
    big_groups = [((slice(0, BIG_SIDE), slice(0, BIG_SIDE)), np.ones((BIG_SIDE,) * 2, bool))]
    # the same over an output twice as wide, from a quadrant that reaches it: the difference
    # is the cost per output pixel, without what a spread costs whatever its size
    wide = np.random.default_rng(1).random((2 * n + 1, 2 * n + 1))
    wide_into, wide_out, wide_centre = np.zeros((2 * n, 2 * n)), (0, 2 * n, 0, 2 * n), (n, n)
    # far tail of a 1024² image at 1/8: splat, interpolation and the per-pixel bound; its
    # coarse convolution; the plan's preview (the darkest pixel of each cell and a splat)
    size, factor = 1024, 8
    image = rng.random((size, size))
    far = rng.random((2 * (size // factor + FOOTPRINT_NODES) + 1,) * 2)
    whole = (0, size, 0, size)
    grid = grid_shape((size, size), factor)
    nodes = splat(image, factor, whole, grid)
    coarse = coarse_lengths((size, size), (size - 1, size - 1), factor)
    bound = CodeBound(display_lut(None, 220.0), 220.0, "Yoshida2008")
    planes = image[..., None] * 100.0

    def far_tail():
        splatted = splat(image, factor, whole, grid)
        upsample(nodes, factor, (size, size))
        return splatted

    checked = planes[:n, :n]

    def check():  # by blocks of a 512² image; none over the tolerance
        bound.codes(checked, checked, absolute=0.0, relative=1e-4, tolerance_codes=0.5)

    def preview():
        block_reduce(image, np.minimum, factor)
        return splat(image, factor, whole, grid)

    workers = cores()

    def clustered(points, groups, wider=False, method="correlation", precision="float64"):
        where = (
            (wide_centre, wide, wide_out, wide_into) if wider else (centre, quadrant, out, into)
        )
        return direct_spread(
            points, *where, quadrant=True, workers=workers, groups=groups, method=method,
            precision=precision,
        )  # fmt: skip

    fastest = _relative(
        {
            "fft64": lambda: spectral_spread(
                work[np.float64], box, out, spectra[np.float64], lengths
            ),
            "fft32": lambda: spectral_spread(
                work[np.float32], box, out, spectra[np.float32], lengths
            ),
            "spans": lambda: clustered(small, small_groups, method="spans"),
            "spans32": lambda: clustered(small, small_groups, method="spans", precision="float32"),
            "small": lambda: clustered(small, small_groups),
            "big": lambda: clustered(big, big_groups),
            "wide spans": lambda: clustered(small, small_groups, wider=True, method="spans"),
            "wide spans32": lambda: clustered(
                small, small_groups, wider=True, method="spans", precision="float32"
            ),
            "wide small": lambda: clustered(small, small_groups, wider=True),
            "wide big": lambda: clustered(big, big_groups, wider=True),
            "far": far_tail,
            "bound": check,
            "coarse": lambda: far_spread(
                None, whole, (size, size), far, factor, nodes=True, splatted=nodes
            ),
            "preview": preview,
        },
        "fft64",
    )
    large = _large_fft_units(rng, spectral_spread, fastest, unit)

    cluster_s = fastest["small"] / (n * n)
    weight_s = max((fastest["big"] / (n * n) - cluster_s) / (BIG_SIDE**2 - 9), 1e-12)
    # a span's time is per value it runs over: the 3 × 3 cluster's spans run over
    # span_values of them per output pixel, (n + 2) / n at n², (2n + 2) / 2n at (2n)²
    values = span_values(n, 2, n)
    for name in ("spans", "spans32"):
        fastest[name] /= values
        fastest[f"wide {name}"] /= span_values(2 * n, 2, 2 * n)
    # each further pixel of a wider output, as a share of a pixel's cost at n²: the median
    # over the four spreads (a noisy one cannot make the direct path free or dear)
    shares = [
        (fastest[f"wide {name}"] - fastest[name]) / (3 * fastest[name])
        for name in ("spans", "spans32", "small", "big")
    ]
    wide_share = min(max(float(np.median(shares)), WIDE_SHARE_LIMITS[0]), WIDE_SHARE_LIMITS[1])
    per = {np.float64: fastest["fft64"] / unit, np.float32: fastest["fft32"] / unit}
    return PathCosts(
        fft_s=per[np.float64],
        fft32_s=per[np.float32],
        fft_large_s=per[np.float64] * large[np.float64],
        fft32_large_s=per[np.float32] * large[np.float32],
        direct_pixel_s=fastest["spans"] / (9 * n * n),
        span32_pixel_s=fastest["spans32"] / (9 * n * n),
        correlate_s=max(cluster_s - 9 * weight_s, 1e-12),
        correlate_weight_s=weight_s,
        direct_wide_share=wide_share,
        multires_s=fastest["far"] / (size * size),
        bound_s=fastest["bound"] / (n * n),
        coarse_fft_s=fastest["coarse"] / n_log_n(coarse),
        preview_s=fastest["preview"] / (size * size),
        threads=cores(),
    )


def _large_fft_units(rng, spectral_spread, fastest, unit) -> dict:
    """How many times the small transforms' unit (``fastest`` of :func:`measure_costs`,
    per ``unit`` = ``n log2 n``) an FFT pair of :data:`LARGE_FFT_POINTS` takes, per
    ``n log2 n``, in float64 and float32: the fastest of :data:`LARGE_ROUNDS` rounds."""
    side = math.isqrt(LARGE_FFT_POINTS)
    n = side // 2
    lengths = (side, side)
    box = (0, n, 0, n)
    excess = rng.random((n, n))
    spectrum = rng.random((side, side // 2 + 1)) + 0j  # a kernel's spectrum's shape
    large = n_log_n(lengths)
    found = {}
    for dtype, cdtype in ((np.float64, np.complex128), (np.float32, np.complex64)):
        work, kept = excess.astype(dtype), spectrum.astype(cdtype)
        best = min(
            _timed(lambda work=work, kept=kept: spectral_spread(work, box, box, kept, lengths))
            for _ in range(LARGE_ROUNDS)
        )
        small = fastest["fft64" if dtype is np.float64 else "fft32"] / unit
        found[dtype] = max(best / large / small, 1.0)
    return found


def _timed(function) -> float:
    start = time.perf_counter()
    function()
    return time.perf_counter() - start


def _plausible(name: str, value) -> bool:
    """A stored cost as :func:`measure_costs` makes it: a positive finite number (the
    threads a positive integer, the share within :data:`WIDE_SHARE_LIMITS`)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    if name == "threads":
        return isinstance(value, int) and value >= 1
    if name == "direct_wide_share":
        return WIDE_SHARE_LIMITS[0] <= value <= WIDE_SHARE_LIMITS[1]
    return math.isfinite(value) and value > 0


def machine_costs(folder: str | os.PathLike | None) -> PathCosts:
    """The costs of this machine at its thread count: read from ``folder`` (the kernel
    cache's), else measured and written there; :data:`DEFAULT_COSTS` without a folder.

    Parameters
    ----------
    folder
        The folder of the stored costs, ``costs-<threads>-threads.json`` in it (made if
        missing; a file of another costs version is measured again); None: nothing is
        measured or stored, :data:`DEFAULT_COSTS`. A folder that cannot be written is not an
        error: the costs are measured again next time.

    Returns
    -------
    PathCosts
        The costs of each rendering path at :func:`cores` threads.
    """
    if folder is None:
        return DEFAULT_COSTS
    from glarelab.files.atomic import write_text
    from glarelab.files.inputs import loads_json

    path = Path(folder) / f"costs-{cores()}-threads.json"
    try:
        stored = loads_json(path.read_text())
        if stored.pop("version", None) == COSTS_VERSION:
            names = {f.name for f in fields(PathCosts)}
            if set(stored) == names and all(_plausible(k, v) for k, v in stored.items()):
                return PathCosts(**stored)
    except (OSError, ValueError, TypeError):
        pass
    costs = measure_costs()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps(asdict(costs) | {"version": COSTS_VERSION}))
    except OSError:  # a read-only or full cache: measured again next time
        pass
    return costs
