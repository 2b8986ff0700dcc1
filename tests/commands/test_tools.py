"""``glarelab bench``'s options: --live and --acuity are benches of their own, so the standard
bench's options given with them are refused naming those options, never an --only that was
not given."""

from __future__ import annotations

import pytest

from glarelab.cli import main


@pytest.mark.parametrize(
    ("options", "message"),
    [(["--acuity", "--live"], "--live and --acuity are two benches of their own: give one"),
     (["--acuity", "--large"], "--acuity runs its own workloads: --large (of the standard "
      "bench) would do nothing; leave it out"),
     (["--live", "--large", "--no-fresh"], "--live runs its own workloads: --large and "
      "--no-fresh (of the standard bench) would do nothing; leave them out"),
     (["--acuity", "--no-spectral"], "--acuity runs its own workloads: --no-spectral")],
)  # fmt: skip
def test_options_the_bench_would_ignore_are_named(options, message, tmp_path, capsys):
    # --acuity --live said "--only --acuity is not one", naming an --only not given
    assert main(["bench", "--out", str(tmp_path / "b"), *options]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"glarelab bench: {message}"), err
    assert "--only" not in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []
