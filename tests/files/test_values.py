"""The shared number checks: bools, strings, None, complex numbers and masked arrays are not
real numbers, wherever they are given; a value that is wrong is named with its position."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.files.values import is_real, is_whole, real_array

SETTINGS = settings(max_examples=25, deadline=None)
NOT_REAL_SCALAR = st.one_of(
    st.booleans(),
    st.sampled_from([np.True_, np.False_, None, b"1"]),
    st.text(max_size=3),
    st.complex_numbers(allow_nan=False, allow_infinity=False, min_magnitude=1e-3),
)
# an array of two values is not one number (in a list of one it is a row: real_array's callers
# judge the shape)
NOT_REAL = st.one_of(NOT_REAL_SCALAR, st.just(np.array([1.0, 2.0])))


@SETTINGS
@given(value=NOT_REAL)
def test_what_numpy_reads_as_a_number_is_not_a_real_number(value):
    assert not is_real(value) and not is_whole(value)


@SETTINGS
@given(value=st.one_of(st.integers(), st.floats(allow_nan=True), st.just(np.float32(0.5))))
def test_ints_and_floats_are_real_and_only_ints_whole(value):
    assert is_real(value) and is_real(np.array(value))
    assert is_whole(value) == isinstance(value, int)


@SETTINGS
@given(
    values=st.lists(st.floats(allow_nan=True), max_size=6),
    bad=NOT_REAL_SCALAR,
    at=st.integers(0, 6),
)
def test_real_array_names_the_first_value_that_is_not_a_number(values, bad, at):
    at = min(at, len(values))
    values.insert(at, bad)
    with pytest.raises(TypeError, match=rf"^x must hold real numbers .* at position {at}$"):
        real_array(values, "x")


def test_real_array_keeps_nan_for_its_caller_and_refuses_masks_and_strings():
    assert math.isnan(real_array([1, math.nan], "x")[1])
    with pytest.raises(TypeError, match=r"^x must be a plain array, not a masked array"):
        real_array(np.ma.masked_array([1.0, 2.0], mask=[0, 1]), "x")
    with pytest.raises(TypeError, match=r"^x must be a sequence of numbers; got the string"):
        real_array("12", "x")
    with pytest.raises(TypeError, match=r"^x must hold real numbers .* True at position 0$"):
        real_array(np.array([True, False]), "x")
