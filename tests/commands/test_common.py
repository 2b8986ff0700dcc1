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


def test_a_refusal_offers_force_only_where_the_command_has_it(tmp_path):
    """run --screenshot onto a user's PNG was refused with "or --force to overwrite it", an
    option run does not have ("unrecognized arguments: --force")."""
    from glarelab.commands.common import output_file

    users = tmp_path / "user.png"
    users.write_bytes(b"a user's picture")
    with pytest.raises(ValueError) as refused:
        output_file(users, (".png",), "screenshot", forceable=False)
    assert "--force" not in str(refused.value)
    assert "give another name (nothing was changed)" in str(refused.value)
    with pytest.raises(ValueError, match=r"give another name, or --force to overwrite it"):
        output_file(users, (".png",), "figure")
    assert users.read_bytes() == b"a user's picture"
