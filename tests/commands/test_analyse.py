"""``glarelab analyse`` and ``import-psychopy``'s arguments: ``--protocol FILE CSV…`` is the
form without a study (the first CSV is a session, not the study), and what is missing or
misplaced is refused in one line naming it."""

from __future__ import annotations

from pathlib import Path

import pytest

from glarelab.cli import main


@pytest.fixture(scope="module")
def sessions(tmp_path_factory) -> list[Path]:
    folder = tmp_path_factory.mktemp("sessions")
    assert main(["run", "luidolt2020", "--simulate", "--participants", "2", "--seed", "1",
                 "--out", str(folder)]) == 0  # fmt: skip
    return sorted(folder.glob("*.csv"))


def test_protocol_instead_of_study_reads_every_csv_as_a_session(sessions, tmp_path, capsys):
    # the help's '--protocol FILE (instead of STUDY)' read the first CSV as the protocol
    protocol = tmp_path / "p.toml"
    assert main(["protocol", "copy", "luidolt2020", str(protocol)]) == 0
    out = tmp_path / "rep"
    argv = ["analyse", "--protocol", str(protocol), *map(str, sessions), "--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    provenance = (out / "provenance.json").read_text()
    assert all(session.name in provenance for session in sessions)  # both, none as the study


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["analyse", "a.csv", "b.csv", "--out", "rep"],
         "STUDY 'a.csv' is a CSV file: give the study first"),
        (["analyse", "luidolt2020", "--out", "rep"],
         "no session CSV files given; read STUDY as 'luidolt2020'"),
    ],
)  # fmt: skip
def test_a_csv_as_study_or_no_csv_is_refused_in_one_line(argv, message, tmp_path, capsys):
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2
    assert message in err and len(err.strip().splitlines()) == 1, err
