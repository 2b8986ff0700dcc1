"""The command line's shared argument types."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np
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


@pytest.mark.parametrize(
    "command",
    [
        ["render", "in.exr", "ro/out.exr", "--pixel-deg", "0.05"],
        ["psf", "--model", "gaussian", "--size", "31", "--out", "ro/x.png"],
        ["check-display", "yoshida2008", "--out", "ro/c.json", "--windowed", "--frames", "30"],
    ],
)
def test_an_output_in_a_folder_that_cannot_be_written_is_refused_before_the_work(
    command, tmp_path, monkeypatch, capsys
):
    """render, psf and check-display rendered (or checked the display) first, then failed
    naming '.glarelab-files.lock'; the folder is named before any work now."""
    from glarelab.cli import main
    from glarelab.commands import render
    from glarelab.stimuli.exr import write_exr

    monkeypatch.chdir(tmp_path)
    write_exr(tmp_path / "in.exr", np.full((8, 8), 500.0, np.float32))
    (tmp_path / "ro").mkdir()
    access = os.access
    read_only = str(tmp_path / "ro")
    monkeypatch.setattr(  # a read-only folder, as chattr +i makes one even for root
        os,
        "access",
        lambda p, mode, **kw: os.path.abspath(p) != read_only and access(p, mode, **kw),
    )

    def work(*args, **kwargs):
        raise AssertionError("the work started")

    monkeypatch.setattr(render, "build_model", work)
    monkeypatch.setattr("glarelab.frontend.check_display.check_display", work, raising=False)
    assert main(command) == 2
    err = capsys.readouterr().err
    assert f"the folder {Path('ro')} cannot be written into" in err, err
    assert ".glarelab-files.lock" not in err
