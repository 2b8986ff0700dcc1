"""A command's warnings are one line each on stderr, as its other messages, not Python's
two-line form with the source line; Python's own printing is back after the command."""

from __future__ import annotations

import warnings

from glarelab import cli
from glarelab.commands import tools


def test_a_commands_warning_is_one_line(monkeypatch, capsys, tmp_path):
    def warns(args):
        warnings.warn("the simulated observers extrapolate:\n  glare: mesopic", stacklevel=2)
        return 0

    monkeypatch.setattr(tools, "_docs", warns)
    before = warnings.showwarning
    assert cli.main(["docs", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert err == (
        "[glarelab] warning (UserWarning): the simulated observers extrapolate: glare: mesopic\n"
    )
    assert "warnings.warn" not in err
    assert warnings.showwarning is before
