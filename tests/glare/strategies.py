"""Hypothesis strategies shared by the glare package's boundary tests: what a caller may pass
by mistake for a number."""

import math

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# bools (True is 1), strings, None, complex numbers and sequences
NOT_A_NUMBER = st.one_of(
    st.booleans(),
    st.text(max_size=4),
    st.none(),
    st.complex_numbers(allow_nan=False, allow_infinity=False),
    st.lists(st.floats(0.1, 1.0), min_size=2, max_size=3),
)
# zero, negatives, NaN, the infinities and subnormal numbers
NOT_FINITE_POSITIVE = st.one_of(
    st.floats(max_value=0.0),
    st.sampled_from([math.nan, math.inf, -math.inf, 5e-324, 1e-310]),
)
