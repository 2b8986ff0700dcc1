"""The far tail of the multi-resolution path."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

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
