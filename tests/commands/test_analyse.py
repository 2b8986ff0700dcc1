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


def test_csvs_after_the_options_are_sessions_too(sessions, tmp_path, capsys):
    # the form the attack round used: STUDY, options, then the CSVs
    argv = ["import-psychopy", "luidolt2020", "--out", str(tmp_path / "im"),
            "--set", "participant=P99", *map(str, sessions)]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    for session in sessions:  # each read as a source (and refused: a session glarelab ran)
        assert f"{session}: a glarelab session file" in err, err


def test_a_csv_as_study_is_refused_in_one_line(capsys):
    assert main(["analyse", "a.csv", "b.csv", "--out", "rep"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "glarelab analyse: STUDY 'a.csv' is a CSV file: give the study first (a shipped name "
        "or a protocol TOML), or --protocol FILE before the session CSV files"
    )


def test_protocol_with_a_single_csv_says_how(capsys):
    with pytest.raises(SystemExit):
        main(["analyse", "--protocol", "p.toml", "a.csv", "--out", "rep"])
    err = capsys.readouterr().err.strip()
    assert "read STUDY as 'a.csv'; with --protocol FILE give two or more CSVs, or one CSV " in err
    assert len(err.splitlines()) == 1


def test_a_folder_among_the_sessions_is_named_as_one(sessions, tmp_path, capsys):
    argv = ["analyse", "luidolt2020", *map(str, sessions), str(sessions[0].parent),
            "--out", str(tmp_path / "rep")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{sessions[0].parent}: a folder; give the session CSV files in it" in err, err
    assert not (tmp_path / "rep").exists()


@pytest.mark.parametrize("command", ["analyse", "import-psychopy"])
def test_a_protocol_of_another_study_is_refused_in_one_line(command, tmp_path, capsys):
    """``import-psychopy luidolt2020 … --protocol spencer1995.toml`` gave 14 "no column …"
    lines and never said the two name different studies; analyse said it in one line."""
    protocol = tmp_path / "spencer.toml"
    assert main(["protocol", "copy", "spencer1995", str(protocol)]) == 0
    capsys.readouterr()
    source = tmp_path / "run.csv"
    source.write_text("participant,rating\nP01,5\n")
    argv = [command, "luidolt2020", str(source), "--protocol", str(protocol),
            "--out", str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"glarelab {command}: --protocol {protocol} is the protocol of study 'spencer1995', "
        "not of 'luidolt2020'; give the study's own protocol"
    )
    assert not (tmp_path / "out").exists()
