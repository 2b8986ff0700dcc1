"""A session whose CSV lost or reordered a row by hand is not resumed: the next trial would be
recorded under a number the file already holds."""

import json

import pytest

from .test_session_safety import data_files, simulated


@pytest.mark.parametrize(
    ("edit", "found"),
    [
        (lambda lines: lines[:3] + lines[4:], "trial '4' after trial 2 (expected 3)"),  # deleted
        (lambda lines: [*lines[:2], lines[3], lines[2], *lines[4:]], "trial '3' after trial 1"),
        (lambda lines: [lines[0], *lines[2:]], "trial '2' after trial 0 (expected 1)"),
    ],
    ids=["a middle row deleted", "two rows swapped", "the first row deleted"],
)
def test_a_csv_with_rows_deleted_or_moved_is_not_resumed(tmp_path, edit, found):
    assert simulated(tmp_path).returncode == 0
    (csv,) = tmp_path.glob("P01_luidolt2020_s1_*.csv")
    sidecar = json.loads(csv.with_suffix(".json").read_text())
    sidecar["status"] = "aborted"  # as a session stopped part-way
    csv.with_suffix(".json").write_text(json.dumps(sidecar))
    lines = csv.read_text().splitlines(keepends=True)
    csv.write_text("".join(edit(lines)))
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2, done.stderr
    message = done.stderr.strip().splitlines()
    assert len(message) == 1 and found in message[0] and "line " in message[0]
    assert "Traceback" not in done.stderr
    assert data_files(tmp_path) == before
