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

COSTS_VERSION = 2  # bump when what is measured changes


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


def _best(function, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


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
    from glarelab.glare.rendering.display import CodeBound, display_lut
    from glarelab.glare.rendering.multires import far_spread, grid_shape, splat, upsample

    rng = np.random.default_rng(0)
    n = 512  # a 512² box into a 1024² transform: large enough for the threads to matter
    lengths = (2 * n, 2 * n)
    excess = rng.random((n, n))
    kernel = rng.random((2 * n - 1, 2 * n - 1))
    unit = lengths[0] * lengths[1] * np.log2(lengths[0] * lengths[1])
    box, out = (0, n, 0, n), (0, n, 0, n)
    per = {}
    full = kernel_spectrum(kernel, lengths)
    for dtype in (np.float64, np.float32):
        spectrum = full.astype(np.complex64 if dtype == np.float32 else np.complex128)
        work = excess.astype(dtype)
        per[dtype] = (
            _best(lambda w=work, k=spectrum: spectral_spread(w, box, out, k, lengths)) / unit
        )
    # direct: one bright pixel, then a 3 × 3 cluster, onto a 512² output
    into = np.zeros((n, n))
    kernel_small = kernel[: n + 1, : n + 1]
    one = np.zeros((1, 1)) + 1.0
    pixel_s = _best(
        lambda: direct_spread(one, (n // 2, n // 2), kernel_small, out, into, workers=cores())
    ) / (n * n)
    cluster = np.ones((3, 3))
    groups = [((slice(0, 3), slice(0, 3)), np.ones((3, 3), bool))]
    cluster_s = _best(
        lambda: direct_spread(
            cluster, (n // 2, n // 2), kernel_small, out, into, workers=cores(), groups=groups
        )
    ) / (n * n)
    big = np.ones((12, 12))
    groups = [((slice(0, 12), slice(0, 12)), np.ones((12, 12), bool))]
    big_s = _best(
        lambda: direct_spread(
            big, (n // 2, n // 2), kernel_small, out, into, workers=cores(), groups=groups
        )
    ) / (n * n)
    weight_s = max((big_s - cluster_s) / (144 - 9), 1e-12)
    # far tail: splat, coarse convolution and interpolation of a 1024² image at 1/8
    size, factor = 1024, 8
    image = rng.random((size, size))
    far = rng.random((2 * (size // factor + 5) + 1,) * 2)
    whole = (0, size, 0, size)

    bound = CodeBound(display_lut(None, 220.0), 220.0, "Yoshida2008")
    planes = image[..., None] * 100.0

    def far_tail():
        nodes = splat(image, factor, whole, grid_shape((size, size), factor))
        spread = far_spread(None, whole, (size, size), far, factor, nodes=True, splatted=nodes)
        fine = upsample(spread, factor, (size, size))
        bound.codes(planes, fine[..., None], absolute=0.0, relative=1e-4, tolerance_codes=0.5)

    multires_s = _best(far_tail) / (size * size)
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
    cache's), else measured and written there; :data:`DEFAULT_COSTS` without a folder."""
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
