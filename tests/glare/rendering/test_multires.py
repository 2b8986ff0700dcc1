"""The far tail of the multi-resolution path."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from glarelab.glare.rendering.multires import far_spread, grid_shape


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
