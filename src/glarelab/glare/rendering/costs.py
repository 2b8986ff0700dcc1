"""What each path costs on this machine: :class:`PathCosts`, measured once and kept.

The planner chooses the cheapest path by estimated seconds; only their ratios matter, so the
constants must be measured where the render runs, at the number of threads it will use: the
FFTs run on every core (``scipy.fft`` workers), the direct spread shares its rows among the
cores, and the far tail's splat and interpolation are numpy products on one. The first
renderer on a machine with a kernel cache measures them (about a quarter of a second) and
writes them next to the kernels (``costs-<threads>-threads.json``, written to a temporary name
and renamed); later processes read them. Without a cache, the constants measured on a 2-core
machine are used (:data:`DEFAULT_COSTS`).
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

__all__ = ["DEFAULT_COSTS", "PathCosts", "cores", "machine_costs", "measure_costs"]

COSTS_VERSION = 3  # bump when what is measured changes


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
        ``N0 × N1`` transform, in float64 and float32.
    direct_pixel_s
        A scaled kernel copy, per output pixel and bright pixel.
    correlate_s, correlate_weight_s
        A cluster's correlation, per output pixel, plus per pixel of the cluster's box.
    multires_s
        The far tail's splat, coarse convolution, interpolation and per-pixel error bound,
        per image pixel.
    threads
        The threads they were measured with.
    """

    fft_s: float = 4.5e-10
    fft32_s: float = 3.0e-10
    direct_pixel_s: float = 2.5e-9
    correlate_s: float = 4.5e-9
    correlate_weight_s: float = 0.4e-9
    multires_s: float = 3.5e-8
    threads: int = 2


DEFAULT_COSTS = PathCosts()


def _medians(functions: dict, rounds: int = 5) -> dict:
    """Median seconds of each function, run in turn ``rounds`` times (alternating rounds: a
    busy moment of a shared machine falls on all of them alike)."""
    times = {name: [] for name in functions}
    for _ in range(rounds):
        for name, function in functions.items():
            start = time.perf_counter()
            function()
            times[name].append(time.perf_counter() - start)
    return {name: float(np.median(t)) for name, t in times.items()}


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
        spectral_spread,
    )
    from glarelab.glare.rendering.display import CodeBound, block_reduce, display_lut
    from glarelab.glare.rendering.multires import far_spread, grid_shape, splat, upsample

    rng = np.random.default_rng(0)
    n = 512  # a 512² box into a 1024² transform: large enough for the threads to matter
    lengths = (2 * n, 2 * n)
    excess = rng.random((n, n))
    kernel = rng.random((2 * n - 1, 2 * n - 1))
    unit = lengths[0] * lengths[1] * np.log2(lengths[0] * lengths[1])
    box, out = (0, n, 0, n), (0, n, 0, n)
    full = kernel_spectrum(kernel, lengths)
    work = {np.float64: excess, np.float32: excess.astype(np.float32)}
    spectra = {np.float64: full, np.float32: full.astype(np.complex64)}
    into = np.zeros((n, n))
    kernel_small = kernel[: n + 1, : n + 1]
    centre = (n // 2, n // 2)
    one = np.ones((1, 1))
    small, big = np.ones((3, 3)), np.ones((12, 12))
    small_groups = [((slice(0, 3), slice(0, 3)), np.ones((3, 3), bool))]
    big_groups = [((slice(0, 12), slice(0, 12)), np.ones((12, 12), bool))]
    # far tail: splat, coarse convolution, interpolation, the plan's preview and the
    # per-pixel bound, for a 1024² image at 1/8
    size, factor = 1024, 8
    image = rng.random((size, size))
    far = rng.random((2 * (size // factor + 5) + 1,) * 2)
    whole = (0, size, 0, size)
    bound = CodeBound(display_lut(None, 220.0), 220.0, "Yoshida2008")
    planes = image[..., None] * 100.0

    def far_tail():
        nodes = splat(image, factor, whole, grid_shape((size, size), factor))
        far_spread(None, whole, (size, size), far, factor, nodes=True, splatted=nodes)
        block_reduce(image, np.minimum, factor)
        spread = far_spread(None, whole, (size, size), far, factor, nodes=True, splatted=nodes)
        fine = upsample(spread, factor, (size, size))
        bound.codes(planes, fine[..., None], absolute=0.0, relative=1e-4, tolerance_codes=0.5)

    workers = cores()
    medians = _medians(
        {
            "fft64": lambda: spectral_spread(
                work[np.float64], box, out, spectra[np.float64], lengths
            ),
            "fft32": lambda: spectral_spread(
                work[np.float32], box, out, spectra[np.float32], lengths
            ),
            "pixel": lambda: direct_spread(one, centre, kernel_small, out, into, workers=workers),
            "small": lambda: direct_spread(
                small, centre, kernel_small, out, into, workers=workers, groups=small_groups
            ),
            "big": lambda: direct_spread(
                big, centre, kernel_small, out, into, workers=workers, groups=big_groups
            ),
            "far": far_tail,
        }
    )
    pixel_s = medians["pixel"] / (n * n)
    cluster_s = medians["small"] / (n * n)
    weight_s = max((medians["big"] / (n * n) - cluster_s) / (144 - 9), 1e-12)
    multires_s = medians["far"] / (size * size)
    per = {np.float64: medians["fft64"] / unit, np.float32: medians["fft32"] / unit}
    return PathCosts(
        fft_s=per[np.float64],
        fft32_s=per[np.float32],
        direct_pixel_s=pixel_s,
        correlate_s=max(cluster_s - 9 * weight_s, 1e-12),
        correlate_weight_s=weight_s,
        multires_s=multires_s,
        threads=cores(),
    )


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

    path = Path(folder) / f"costs-{cores()}-threads.json"
    try:
        stored = json.loads(path.read_text())
        if stored.pop("version", None) == COSTS_VERSION:
            names = {f.name for f in fields(PathCosts)}
            if set(stored) == names:
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
