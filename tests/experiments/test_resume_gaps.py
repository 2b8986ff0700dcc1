"""A session whose CSV lost or reordered a row by hand is not resumed: the next trial would be
recorded under a number the file already holds."""

import json

import pytest

from .test_session_safety import data_files, simulated


@pytest.mark.parametrize(
    ("edit", "found"),
    [
        (lambda lines: lines[:3] + lines[4:], "trial '4' after trial 2 (expected 3)"),  # deleted
        (lambda lines: [lines[0], *lines[2:]], "trial '2' after trial 0 (expected 1)"),
        # a row pasted twice: the resume counted it as a trial done and skipped the next one
        (lambda lines: [*lines[:4], lines[3], *lines[4:]], "trial 3 is there twice"),
        # an editor's blank line: the resumed file was one the analysis refuses
        (lambda lines: [*lines[:3], "\n", *lines[3:]], "line 4 is blank"),
        (lambda lines: [*lines, "   \n"], "is blank (added by an editor?)"),
        (lambda lines: [*lines, "   "], "is blank (added by an editor?)"),  # was a traceback
        (lambda lines: [line.replace("\n", "\r\n") for line in lines], "end in CR LF"),
        (lambda lines: ["\ufeff" + lines[0], *lines[1:]], "starts with a byte-order mark"),
        (lambda lines: [",".join(reversed(line.rstrip("\n").split(","))) + "\n" for line in lines],
         "columns are in another order"),
    ],
    ids=["a middle row deleted", "the first row deleted", "a row twice", "a blank line",
         "a line of spaces", "spaces at the end", "CR LF", "a byte-order mark", "columns moved"],
)  # fmt: skip
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


def _stopped_part_way(tmp_path, keep: int):
    assert simulated(tmp_path).returncode == 0
    (csv,) = tmp_path.glob("P01_luidolt2020_s1_*.csv")
    sidecar = json.loads(csv.with_suffix(".json").read_text())
    sidecar["status"] = "aborted"  # as a session stopped part-way
    # killed while it wrote trial `keep`: the digests are those recorded before it
    sidecar["row_sha256"] = sidecar["row_sha256"][: keep - 1]
    csv.with_suffix(".json").write_text(json.dumps(sidecar))
    lines = csv.read_text().splitlines(keepends=True)[: keep + 1]
    return csv, lines


def test_a_csv_whose_rows_were_changed_is_not_resumed(tmp_path):
    csv, lines = _stopped_part_way(tmp_path, keep=4)
    cells, rating = lines[2].split(","), lines[0].split(",").index("rating")
    cells[rating] = "1" if cells[rating] != "1" else "2"  # trial 2's rating, in a spreadsheet
    csv.write_text("".join([*lines[:2], ",".join(cells), *lines[3:]]))
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2, done.stderr
    message = done.stderr.strip().splitlines()
    assert len(message) == 1 and "trial 2 is not the row the session wrote" in message[0]
    assert data_files(tmp_path) == before


def test_a_whole_last_row_without_its_newline_is_neither_deleted_nor_run_again(tmp_path):
    csv, lines = _stopped_part_way(tmp_path, keep=4)
    csv.write_text("".join(lines).removesuffix("\n"))  # an editor's save
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2, done.stderr
    message = done.stderr.strip().splitlines()
    assert len(message) == 1 and "line 5" in message[0] and "no final newline" in message[0]
    assert data_files(tmp_path) == before


def test_a_row_cut_by_a_crash_is_dropped_and_its_trial_run_again(tmp_path):
    csv, lines = _stopped_part_way(tmp_path, keep=4)
    csv.write_text("".join(lines[:4]) + lines[4][:12])  # cut in its first cells
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 0, done.stderr
    rows = csv.read_text().splitlines()
    assert [row.split(",")[3] for row in rows[1:5]] == ["1", "2", "3", "4"]
    assert rows[1:4] == [line.rstrip("\n") for line in lines[1:4]]


def test_rows_sorted_in_a_spreadsheet_are_resumed_in_trial_order(tmp_path):
    # the analysis reads any row order; the resume refused it ("rows were deleted or moved")
    from glarelab.analysis.load import load_sessions
    from glarelab.protocols import load_protocol

    csv, lines = _stopped_part_way(tmp_path, keep=4)
    csv.write_text("".join([lines[0], *reversed(lines[1:])]))
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 0, done.stderr
    trials = [int(row.split(",")[3]) for row in csv.read_text().splitlines()[1:]]
    assert trials[:4] == [4, 3, 2, 1] and sorted(trials) == list(range(1, len(trials) + 1))
    dataset = load_sessions(load_protocol("luidolt2020"), [csv])
    assert sorted(dataset.trials["trial"]) == list(range(1, len(trials) + 1))


def test_a_row_changed_after_a_run_was_killed_is_not_resumed(tmp_path):
    # the digests were recorded at a run's start and end only: a run killed by SIGKILL left
    # its rows without them, and a value changed before --resume was sealed and analysed
    import signal
    import subprocess
    import sys
    import time

    process = subprocess.Popen(
        [sys.executable, "-m", "glarelab", "run", "luidolt2020", "--simulate", "--participant",
         "P01", "--out", str(tmp_path), "--trial-delay-ms", "300"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        found = list(tmp_path.glob("P01_luidolt2020_s1_*.csv"))
        if found and len(found[0].read_text().splitlines()) >= 5:  # the header, 4 trials
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=60)
    (csv,) = tmp_path.glob("P01_luidolt2020_s1_*.csv")
    sidecar = json.loads(csv.with_suffix(".json").read_text())
    lines = csv.read_text().splitlines(keepends=True)
    assert sidecar["status"] == "running" and len(sidecar["row_sha256"]) >= len(lines) - 2
    cells, rating = lines[2].split(","), lines[0].split(",").index("rating")
    cells[rating] = "1" if cells[rating] != "1" else "2"  # trial 2's rating, by hand
    csv.write_text("".join([*lines[:2], ",".join(cells), *lines[3:]]))
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2, done.stderr
    assert "trial 2 is not the row the session wrote" in done.stderr
    assert data_files(tmp_path) == before
