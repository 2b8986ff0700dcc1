"""The far tail of the multi-resolution path."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.glare.rendering import multires
from glarelab.glare.rendering.multires import cell_sums, far_spread, grid_shape, least_kernel


def test_a_channel_without_excess_spreads_nothing():
    # a tinted source: one channel's excess is zero everywhere (this ended in an IndexError
    # when the renderer passed the channel's splat, all zeros)
    far = np.ones((5, 5)) / 25
    for splatted in (None, np.zeros(grid_shape((16, 16), 4))):
        spread = far_spread(np.zeros((4, 4)), (6, 10, 6, 10), (16, 16), far, 4, splatted=splatted)
        assert_allclose(spread, np.zeros((16, 16)), atol=0)
    one = np.zeros((4, 4))
    one[1, 1] = 1.0
    assert far_spread(one, (6, 10, 6, 10), (16, 16), far, 4).sum() > 0


def test_the_least_kernel_is_the_least_value_between_the_pixels_of_two_cells():
    # the lower bound on the spread the precision is planned with: at each cell offset, the
    # least kernel value over every pair of pixels of the two cells (0 beyond the reach), on
    # images whose sides are and are not multiples of the cell, with one channel or three
    rng = np.random.default_rng(35)
    for shape, factor, reach in (((7, 9), 2, (6, 3)), ((6, 8), 3, (5, 7)), ((5, 4), 4, (2, 9))):
        kernel = rng.random((2 * shape[0] + 1, 2 * shape[1] + 3, 3))
        least = least_kernel(kernel, factor, reach, shape)
        cells = [-(-n // factor) for n in shape]
        assert least.shape == (2 * cells[0] - 1, 2 * cells[1] - 1, 3)
        half = (kernel.shape[0] // 2, kernel.shape[1] // 2)
        expected = np.full(least.shape, np.inf)
        for p in np.ndindex(shape):
            for q in np.ndindex(shape):
                o = (p[0] - q[0], p[1] - q[1])
                d = (p[0] // factor - q[0] // factor, p[1] // factor - q[1] // factor)
                inside = abs(o[0]) <= reach[0] and abs(o[1]) <= reach[1]
                value = kernel[half[0] + o[0], half[1] + o[1]] if inside else 0.0
                at = (d[0] + cells[0] - 1, d[1] + cells[1] - 1)
                expected[at] = np.minimum(expected[at], value)
        assert_allclose(least, expected, rtol=0, atol=0)


def test_cell_sums_add_the_excess_of_each_cell():
    rng = np.random.default_rng(35)
    excess = rng.random((5, 7, 2))
    image = np.zeros((11, 13, 2))
    image[3:8, 2:9] = excess
    expected = np.zeros((3, 4, 2))
    for y, x in np.ndindex(11, 13):
        expected[y // 4, x // 4] += image[y, x]
    assert_allclose(cell_sums(excess, 4, (3, 8, 2, 9), (11, 13)), expected, rtol=1e-12)


@settings(max_examples=80, deadline=None)
@given(
    factor=st.sampled_from([2, 3, 4, 8]),
    size=st.tuples(st.integers(1, 70), st.integers(1, 70)),
    origin=st.tuples(st.integers(0, 40), st.integers(0, 40)),
    margin=st.tuples(st.integers(0, 9), st.integers(0, 9)),
    bright=st.integers(0, 40),
    seed=st.integers(0, 2**32 - 1),
)
def test_a_splat_pixel_by_pixel_is_the_dense_splat(factor, size, origin, margin, bright, seed):
    """Lamps and glints are splatted pixel by pixel, any other box by dense products per cell:
    the same nodes to the rounding of the sums (8 decades of luminance, pixels at the box's
    and the image's borders, empty boxes, and boxes dense enough to take the dense way)."""
    rng = np.random.default_rng(seed)
    excess = np.zeros(size)
    excess[rng.integers(0, size[0], bright), rng.integers(0, size[1], bright)] = rng.random(
        bright
    ) * 10.0 ** rng.integers(0, 9, bright)
    box = (origin[0], origin[0] + size[0], origin[1], origin[1] + size[1])
    grid = multires.grid_shape((box[1] + margin[0], box[3] + margin[1]), factor)
    columns = multires._splat_last(excess, factor, box[2], grid[1])
    dense = multires._splat_last(columns.T, factor, box[0], grid[0]).T
    got = multires.splat(excess, factor, box, grid)
    assert got.shape == dense.shape
    assert_allclose(got, dense, rtol=0, atol=1e-14 * max(excess.sum(), 1e-300))
    assert_allclose(got.sum(), excess.sum(), rtol=1e-12)  # the splat keeps the total
