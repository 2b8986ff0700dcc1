"""The command line's shared argument types."""

from __future__ import annotations

import argparse

import pytest

from glarelab.commands.common import number


def test_a_number_without_an_upper_bound_is_called_finite_not_in_0_inf():
    # --pupil-calibration-s inf said "inf must be a finite number in (0, inf]"
    with pytest.raises(argparse.ArgumentTypeError) as refused:
        number(0, above=True)("inf")
    assert str(refused.value) == "inf must be a finite number > 0"
    with pytest.raises(argparse.ArgumentTypeError, match=r"^-1 must be a finite number >= 0$"):
        number(0)("-1")
    with pytest.raises(argparse.ArgumentTypeError, match=r"must be a finite number in \[1, 2\]"):
        number(1, 2)("3")
