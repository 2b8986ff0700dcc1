"""A kernel held as its quadrant is the same kernel as its unfolded values."""

from __future__ import annotations

import numpy as np
from glarelab.glare.models.digitise import Kernel, mirror_quadrant
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

# quadrants of 1 × 1 to 40 × 40 (kernels of 1 × 1 to 79 × 79), 1 or 3 channels, values in
# [0, 1] as a digitised kernel's
quadrants = st.tuples(st.integers(1, 40), st.integers(1, 40), st.sampled_from([(), (3,)])).flatmap(
    lambda s: arrays(
        np.float32,
        (s[0], s[1], *s[2]),
        elements=st.floats(0, 1, width=32, allow_subnormal=False),
    )
)


@settings(max_examples=60, deadline=None)
@given(quadrants)
def test_a_quadrants_total_is_its_unfolded_kernels_at_any_precision(quadrant):
    """Both forms sum in float64 (a float32 quadrant's sum in float32 put the energy account
    of a 1e9 cd/m² source off by tens of cd/m²·px against the same kernel unfolded)."""
    half = Kernel(quadrant=quadrant, pixel_deg=0.1)
    whole = Kernel(values=mirror_quadrant(quadrant), pixel_deg=0.1)
    reference = mirror_quadrant(quadrant.astype(np.float64)).sum(axis=(0, 1))
    np.testing.assert_allclose(half.total(), reference, rtol=1e-12, atol=0)
    np.testing.assert_allclose(whole.total(), reference, rtol=1e-12, atol=0)
    assert np.asarray(half.total()).dtype == np.float64
