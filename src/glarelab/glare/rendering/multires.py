"""Multi-resolution numerics: the far tail of a smooth kernel on a grid ``f`` times coarser.

Beyond a split radius ``R0`` a smooth PSF changes little over ``f`` pixels, so its part there
is convolved on a coarse grid: the excess is splatted onto the coarse nodes with cubic weights
(Keys 1981, ``a = -½``: the total, centroid and second moments are kept), convolved with the
model digitised at ``f`` pixels (cell energies sharpened to point values), and interpolated
back with the same cubic. The near part ``(1 - w) K`` stays at full resolution; ``w`` rises
from 0 at ``R0`` to 1 at ``2 R0`` as Perlin's smootherstep.

The far path's relative error against the full-resolution kernel is **measured**, for point
sources at the corners and the centre of a coarse block, over the whole footprint of the
approximate kernel (to the reach and a few coarse nodes beyond it, borders and corners
included), not predicted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from glarelab.glare.rendering._convolve import spread

__all__ = [
    "FOOTPRINT_NODES",
    "PAD_NODES",
    "SPARSE_SPLAT_SHARE",
    "MultiresKernels",
    "cell_sums",
    "far_spread",
    "least_kernel",
    "multires_kernels",
]

PAD_NODES = 2  # nodes in front of the first cell, so that every cubic weight is on the grid
# A source splats onto nodes up to 2 cells from it and a target interpolates from nodes up to
# 2 cells from it: the coarse kernel must reach ceil(R / f) + 4 nodes for offsets up to R,
# plus one for the rounding of R / f.
FOOTPRINT_NODES = 5
# A splat by pixel (sixteen weights each) where at most this share of the box is bright: on
# the 2048² night with a glint of the sun (31 bright pixels in a 1150 × 1076 box) it took
# the plan's preview of the far tail (splat, darkest cells, coarse convolution) from 60 to
# 48 ms, medians of nine alternating rounds at a load average of 3.5
SPARSE_SPLAT_SHARE = 1 / 16


def channels(values: np.ndarray) -> list[np.ndarray]:
    """The channels of a ``(H, W)`` or ``(H, W, C)`` array, as 2-D views."""
    return [values] if values.ndim == 2 else [values[..., c] for c in range(values.shape[2])]


def blend(radius_px: np.ndarray, split_px: int) -> np.ndarray:
    """Weight of the far part: 0 within ``R0``, 1 beyond ``2 R0``, between them Perlin's
    smootherstep ``6t⁵ - 15t⁴ + 10t³``, whose first and second derivatives vanish at both
    ends (a kink in ``w''`` would cost cubic interpolation an order)."""
    t = np.clip((radius_px - split_px) / split_px, 0.0, 1.0)
    return t**3 * (t * (6.0 * t - 15.0) + 10.0)


def radius(shape: tuple[int, int], scale: float = 1.0) -> np.ndarray:
    """Distance of each element from the centre of an odd array, times ``scale``."""
    y = (np.arange(shape[0]) - shape[0] // 2) * scale
    x = (np.arange(shape[1]) - shape[1] // 2) * scale
    return np.hypot(y[:, None], x[None, :])


def grid_shape(shape: tuple[int, int], factor: int) -> tuple[int, int]:
    """Nodes of the coarse grid of an image: its cells and :data:`PAD_NODES` on each side."""
    return tuple(-(-n // factor) + 2 * PAD_NODES for n in shape[:2])


def _cubic(n_fine: int, factor: int, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Cubic-convolution weights (Keys 1981, a = -½) between fine pixels
    ``start … start + n_fine - 1`` and the nodes of a grid ``f`` times coarser
    (:func:`_cubic_at`)."""
    return _cubic_at(np.arange(start, start + n_fine), factor)


def _cubic_at(pixels: np.ndarray, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """Cubic-convolution weights (Keys 1981, a = -½) between the fine ``pixels`` (indices
    along one axis) and the nodes of a grid ``f`` times coarser.

    Node ``j`` sits at the centre of coarse cell ``j - PAD_NODES``, fine coordinate
    ``(j - PAD_NODES) f + (f - 1) / 2``. Returns each pixel's first node (of four) and the
    ``(n, 4)`` weights. The weights reproduce quadratics, so interpolating with them, or
    splatting with them (the adjoint), is exact to second order.
    """
    u = (pixels + 0.5) / factor - 0.5
    base = np.floor(u)
    t = (u - base)[:, None]
    weights = np.hstack(
        [
            -0.5 * t**3 + t**2 - 0.5 * t,
            1.5 * t**3 - 2.5 * t**2 + 1.0,
            -1.5 * t**3 + 2.0 * t**2 + 0.5 * t,
            0.5 * t**3 - 0.5 * t**2,
        ]
    )
    return base.astype(np.int64) + PAD_NODES - 1, weights


def _phase_weights(factor: int) -> np.ndarray:
    """``(f, 5)`` weights of a pixel at each phase ``s`` of cell ``m`` onto the nodes
    ``m + PAD_NODES - 2 + j``: every cell has the same four cubic weights per phase."""
    first, weights = _cubic(factor, factor)
    table = np.zeros((factor, 5))
    for phase in range(factor):
        shift = first[phase] - (PAD_NODES - 2)  # 0 or 1
        table[phase, shift : shift + 4] = weights[phase]
    return table


def _splat_last(values: np.ndarray, factor: int, start: int, n_nodes: int) -> np.ndarray:
    """:func:`splat` along the last axis: pixels ``start …`` onto ``n_nodes`` nodes."""
    offset, first_cell = start % factor, start // factor
    cells = -(-(offset + values.shape[-1]) // factor)
    if offset == 0 and values.shape[-1] == cells * factor and values.flags.c_contiguous:
        padded = values  # whole cells already: no copy (32 MB of a 2048² image)
    else:
        padded = np.zeros((*values.shape[:-1], cells * factor))
        padded[..., offset : offset + values.shape[-1]] = values
    # one product of every cell's pixels with the phase weights (one BLAS call, not one a row)
    parts = (padded.reshape(-1, factor) @ _phase_weights(factor)).reshape(
        *values.shape[:-1], cells, 5
    )
    out = np.zeros((*values.shape[:-1], n_nodes))
    for shift in range(5):
        node = first_cell + PAD_NODES - 2 + shift
        out[..., node : node + cells] += parts[..., shift]
    return out


def _upsample_last(nodes: np.ndarray, factor: int, start: int, n_fine: int) -> np.ndarray:
    """:func:`upsample` along the last axis: nodes onto pixels ``start … start + n_fine``."""
    first_cell = start // factor
    cells = -(-(start + n_fine) // factor) - first_cell
    shifted = np.stack(
        [
            nodes[
                ...,
                first_cell + PAD_NODES - 2 + shift : first_cell + PAD_NODES - 2 + shift + cells,
            ]
            for shift in range(5)
        ],
        axis=-1,
    )
    fine = (shifted @ _phase_weights(factor).T).reshape(*nodes.shape[:-1], cells * factor)
    offset = start - first_cell * factor
    return fine[..., offset : offset + n_fine]


def splat(excess: np.ndarray, factor: int, box, grid: tuple[int, int]) -> np.ndarray:
    """Distribute each pixel of ``excess`` (the image's ``box = (r0, r1, c0, c1)``) over its
    4 × 4 nearest coarse nodes with cubic weights: the total, centroid and second moments of
    the excess are kept, so the coarse convolution is off only in third order of ``f / r``.

    A box whose bright pixels are at most :data:`SPARSE_SPLAT_SHARE` of it (lamps, glints,
    a sun) is splatted pixel by pixel, sixteen products each; any other by dense products
    per cell along each axis. The two agree to the rounding of their sums."""
    # counted before the pixels are listed: listing the 484,000 bright pixels of the 2048²
    # leaves took 31 ms of a 93 ms preview that splats them densely
    if np.count_nonzero(excess) > SPARSE_SPLAT_SHARE * excess.size:
        columns = _splat_last(excess, factor, box[2], grid[1])
        return _splat_last(columns.T, factor, box[0], grid[0]).T
    rows, cols = np.nonzero(excess)
    first_row, row_weights = _cubic_at(rows + box[0], factor)
    first_col, col_weights = _cubic_at(cols + box[2], factor)
    values = excess[rows, cols].astype(np.float64, copy=False)
    index = (first_row[:, None, None] + np.arange(4)[:, None]) * grid[1] + (
        first_col[:, None, None] + np.arange(4)
    )
    weights = values[:, None, None] * row_weights[:, :, None] * col_weights[:, None, :]
    nodes = np.bincount(index.ravel(), weights.ravel(), minlength=grid[0] * grid[1])
    return nodes.reshape(grid)


def upsample(coarse: np.ndarray, factor: int, shape: tuple[int, int], start=(0, 0)) -> np.ndarray:
    """Cubic interpolation of the coarse nodes onto the fine pixels ``start … start + shape``
    (the adjoint of :func:`splat`), one axis at a time, as a few dense products per cell."""
    rows = _upsample_last(coarse.T, factor, start[0], shape[0]).T
    return _upsample_last(rows, factor, start[1], shape[1])


def sharpen_cells(cells: np.ndarray) -> np.ndarray:
    """Point values from cell averages to second order: ``K - (1/24) Δ K`` (a cell average
    is the point value blurred by a box of variance 1/12 per axis)."""
    padded = np.pad(cells, [(1, 1), (1, 1)] + [(0, 0)] * (cells.ndim - 2), mode="edge")
    laplacian = (
        padded[:-2, 1:-1] + padded[2:, 1:-1] + padded[1:-1, :-2] + padded[1:-1, 2:] - 4.0 * cells
    )
    return cells - laplacian / 24.0


def far_spread(
    excess: np.ndarray,
    box: tuple[int, int, int, int],
    shape: tuple[int, int],
    far: np.ndarray,
    factor: int,
    *,
    nodes: bool = False,
    splatted: np.ndarray | None = None,
) -> np.ndarray:
    """The far tail's spread of one channel of an image of ``shape`` whose excess is
    ``excess`` within ``box`` (zero elsewhere): splat (or take ``splatted``), convolve on
    the coarse grid, interpolate (or, with ``nodes``, the values at the coarse nodes).

    Parameters
    ----------
    excess
        The excess luminance over ``L_dmax`` within ``box``, cd/m², one channel.
    box
        ``(r0, r1, c0, c1)``: where ``excess`` lies in the image, pixels.
    shape
        The image's shape ``(H, W)``, pixels.
    far
        The far kernel on the coarse grid (:class:`MultiresKernels`).
    factor
        The coarse grid's factor ``f``: one node every ``f`` pixels.
    nodes
        Whether to return the spread at the coarse nodes instead of on the pixels; default
        False.
    splatted
        The excess already splatted onto the coarse grid (:func:`splat`), to reuse; default
        None: splatted here.

    Returns
    -------
    numpy.ndarray
        The far tail's spread, cd/m²: ``shape``, or the coarse grid with ``nodes``.
    """
    coarse = (
        splat(excess, factor, box, grid_shape(shape, factor)) if splatted is None else splatted
    )
    rows = np.flatnonzero(coarse.any(axis=1))
    cols = np.flatnonzero(coarse.any(axis=0))
    if rows.size == 0:  # a channel without excess (a tinted source): nothing to spread
        spread_coarse = np.zeros(coarse.shape)
    else:
        box_nodes = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
        spread_coarse = spread(coarse, far, box_nodes)
    return spread_coarse if nodes else upsample(spread_coarse, factor, shape)


def cell_sums(excess: np.ndarray, factor: int, box, shape: tuple[int, int]) -> np.ndarray:
    """The sum of an excess over each cell of ``factor × factor`` pixels of an image.

    Parameters
    ----------
    excess
        The excess, cd/m², ``(rows, cols[, C])``: the image's ``box``, zero elsewhere.
    factor
        Pixels per cell side ``f``: cell ``(i, j)`` holds rows ``i f … i f + f - 1`` and
        columns ``j f … j f + f - 1``.
    box
        ``(r0, r1, c0, c1)``: where ``excess`` lies in the image, pixels.
    shape
        The image's ``(H, W)``, pixels.

    Returns
    -------
    numpy.ndarray
        ``(ceil(H / f), ceil(W / f)[, C])``, cd/m² × pixels, float64.

    Notes
    -----
    Columns first: ``np.add.reduceat`` along the last pixel axis runs over contiguous memory
    (1 ms at 1024², three channels 3.5 ms; along the rows first, 7-20 ms).

    Examples
    --------
    >>> cell_sums(np.ones((3, 3)), 2, (1, 4, 1, 4), (4, 4)).tolist()
    [[1.0, 2.0], [2.0, 4.0]]
    """
    r0, r1, c0, c1 = box
    rows = np.arange(r0 // factor * factor + factor, r1, factor) - r0
    cols = np.arange(c0 // factor * factor + factor, c1, factor) - c0
    sums = np.add.reduceat(excess, np.r_[0, cols], axis=1, dtype=np.float64)
    sums = np.add.reduceat(sums, np.r_[0, rows], axis=0)
    cells = np.zeros((-(-shape[0] // factor), -(-shape[1] // factor), *excess.shape[2:]))
    top, left = r0 // factor, c0 // factor
    cells[top : top + sums.shape[0], left : left + sums.shape[1]] = sums
    return cells


def least_kernel(
    values: np.ndarray, factor: int, reach: tuple[int, int], shape: tuple[int, int]
) -> np.ndarray:
    """The kernel's least value between any pixel of one cell of ``factor × factor`` pixels
    and any pixel of another, for each offset between the cells, in an image of ``shape``.

    Parameters
    ----------
    values
        The kernel, centred, odd, ``(KH, KW[, C])``.
    factor
        Pixels per cell side ``f``.
    reach
        ``(rows, columns)``: the kernel is applied up to these offsets and is 0 beyond.
    shape
        The image's ``(H, W)``: offsets beyond ``H - 1``, ``W - 1`` cannot occur and are left
        out.

    Returns
    -------
    numpy.ndarray
        ``(2 ceil(H / f) - 1, 2 ceil(W / f) - 1[, C])``, centred: at cell offset ``D`` the least
        ``K(o)`` over the pixel offsets ``o`` between the two cells, ``|o - D f| <= f - 1``
        along each axis (0 where some of them lie beyond the reach).

    Notes
    -----
    With ``E(A)`` the excess summed over cell ``A`` (:func:`cell_sums`), the spread at every
    pixel of cell ``B`` is at least ``Σ_A E(A) m(B - A)`` for a non-negative excess: each
    pixel's share ``ΔL(q) K(p - q)`` is at least ``ΔL(q) m(B - A)``. The window of offsets
    ``[D f - f + 1, D f + f - 1]`` is two blocks of ``f``, ``[(D - 1) f + 1, D f]`` and
    ``[D f, D f + f - 1]``: two reshaped minima per axis, one axis at a time.

    Examples
    --------
    >>> kernel = np.arange(1.0, 26.0).reshape(5, 5)  # offsets -2 … 2 along each axis
    >>> least_kernel(kernel, 2, (2, 2), (3, 3))[1].tolist()  # cells in the same row of cells
    [6.0, 7.0, 9.0]
    >>> least_kernel(kernel, 2, (1, 1), (3, 3))[1].tolist()  # cut beyond 1 pixel
    [0.0, 7.0, 0.0]
    """
    half = (values.shape[0] // 2, values.shape[1] // 2)
    least = values
    for axis in (0, 1):
        n, cells = shape[axis], -(-shape[axis] // factor)
        kept = min(reach[axis], half[axis], n - 1)
        centre = cells * factor - 1  # offsets -centre … centre: every window fits
        part = np.moveaxis(least, axis, 0)[half[axis] - kept : half[axis] + kept + 1]
        padded = np.full((2 * centre + 1, *part.shape[1:]), np.inf)
        padded[centre - (n - 1) : centre + n] = 0.0  # beyond the reach, within the image
        padded[centre - kept : centre + kept + 1] = part
        blocks = 2 * cells - 1
        lower = padded[: blocks * factor].reshape(blocks, factor, *part.shape[1:]).min(axis=1)
        upper = padded[factor - 1 : factor - 1 + blocks * factor]
        upper = upper.reshape(blocks, factor, *part.shape[1:]).min(axis=1)
        least = np.moveaxis(np.minimum(lower, upper), 0, axis)
    return least


@dataclass(frozen=True)
class MultiresKernels:
    """Near and far kernels of one split, and the far path's measured relative error.

    Attributes
    ----------
    factor, split_px
        The coarse grid factor ``f`` and the split radius ``R0`` (pixels).
    near
        ``(1 - w) K`` within ``2 R0``, full resolution, ``(4 R0 + 1)²`` (``[, C]``).
    far
        ``w K / f²`` on the coarse grid, point values at the nodes.
    relative_error
        Largest ``|K̃ - K| / K`` of the approximate kernel ``K̃`` over its footprint.
    """

    factor: int
    split_px: int
    near: np.ndarray
    far: np.ndarray
    relative_error: float


def multires_kernels(
    full: np.ndarray, coarse: np.ndarray, factor: int, split_px: int, reach: tuple[int, int]
) -> MultiresKernels:
    """Near and far kernels from the full-resolution kernel ``full`` (centred, odd, ``[, C]``)
    and the model digitised at ``factor`` pixels (``coarse``, at least
    ``ceil(reach / f) + FOOTPRINT_NODES`` nodes each side), with the relative error measured.

    The error is measured for a point source at each corner and the centre of a coarse cell,
    at every offset from 0 to the footprint of the approximate kernel (the reach plus
    ``FOOTPRINT_NODES`` cells, within the full kernel), in the quadrant of positive offsets;
    the kernel is symmetric in both axes (checked), so the corners' mirror images cover the
    other quadrants.

    Parameters
    ----------
    full
        The kernel at full resolution, centred, odd, ``(KH, KW[, C])``.
    coarse
        The model digitised at ``factor`` pixels per node.
    factor
        The coarse grid's factor ``f``.
    split_px
        The split radius ``R0`` between the near and far kernels, pixels, at most a quarter
        of the kernel's size.
    reach
        ``(rows, columns)``: how far the kernel is applied from a source, pixels.

    Returns
    -------
    MultiresKernels
        The near and far kernels and the far path's measured relative error.

    Raises
    ------
    ValueError
        For a split radius larger than a quarter of the kernel.
    """
    half = (full.shape[0] // 2, full.shape[1] // 2)
    if 2 * split_px > min(half):
        raise ValueError(
            f"split_px must be at most a quarter of the kernel's size, got {split_px} for a "
            f"{full.shape[0]} × {full.shape[1]} kernel"
        )
    w_fine = blend(radius((4 * split_px + 1,) * 2), split_px)
    w_coarse = blend(radius(coarse.shape[:2], factor), split_px)
    if full.ndim == 3:
        w_fine, w_coarse = w_fine[..., None], w_coarse[..., None]
    window = full[
        half[0] - 2 * split_px : half[0] + 2 * split_px + 1,
        half[1] - 2 * split_px : half[1] + 2 * split_px + 1,
    ]
    near = (1.0 - w_fine) * window
    far = w_coarse * sharpen_cells(coarse) / factor**2
    symmetric = np.array_equal(full, full[::-1]) and np.array_equal(full, full[:, ::-1])
    extent = tuple(min(reach[a] + FOOTPRINT_NODES * factor, half[a]) for a in (0, 1))
    corners = sorted({0, factor - 1})
    phases = [(dy, dx) for dy in corners for dx in corners] + [(factor // 2,) * 2]
    worst = 0.0
    for dy, dx in phases:
        for n_k, f_k, k in zip(channels(near), channels(far), channels(full), strict=True):
            worst = max(worst, _worst_ratio(n_k, f_k, k, factor, split_px, (dy, dx), extent))
            if not symmetric:  # every quadrant: the mirror images are not the same
                for flip in (
                    (slice(None, None, -1), slice(None)),
                    (slice(None), slice(None, None, -1)),
                    (slice(None, None, -1),) * 2,
                ):
                    worst = max(
                        worst,
                        _worst_ratio(
                            n_k[flip], f_k[flip], k[flip], factor, split_px, (dy, dx), extent
                        ),
                    )
    return MultiresKernels(factor, split_px, near, far, worst)


def _worst_ratio(near, far, full, factor, split_px, phase, extent) -> float:
    """Largest relative error of near + far against ``full`` for a point source at ``phase``
    within a coarse cell, over offsets ``0 … extent`` in both axes."""
    dy, dx = phase
    shape = (dy + extent[0] + 1, dx + extent[1] + 1)
    point = np.ones((1, 1))
    approx = far_spread(point, (dy, dy + 1, dx, dx + 1), shape, far, factor)[dy:, dx:]
    r = min(2 * split_px, extent[0]), min(2 * split_px, extent[1])
    approx[: r[0] + 1, : r[1] + 1] += near[2 * split_px :, 2 * split_px :][: r[0] + 1, : r[1] + 1]
    half = (full.shape[0] // 2, full.shape[1] // 2)
    exact = full[half[0] : half[0] + extent[0] + 1, half[1] : half[1] + extent[1] + 1]
    error = np.abs(approx - exact)
    positive = exact > 0
    if np.any(error[~positive] > 0):
        return np.inf  # the approximation spreads light where the kernel has none
    return float(np.max(error[positive] / exact[positive], initial=0.0))
