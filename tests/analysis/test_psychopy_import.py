"""Data a PsychoPy experiment collected are analysed to the same numbers as glarelab's own
session files of the same trials.

The PsychoPy files are written by PsychoPy's own ``ExperimentHandler`` as a Builder experiment
writes them: the experiment info (participant, a zero-padded session, date, expName,
psychopyVersion, frameRate) on every row, an instructions routine's row before the trial loop,
a ``TrialHandler`` loop named ``trials`` (its thisRepN/thisTrialN/thisN/thisIndex columns),
``thisRow.t`` and ``notes``, the trailing empty column, and Python's True/False.
"""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.analysis.psychopy_import import import_psychopy
from glarelab.analysis.report import write_report
from glarelab.protocols import columns, load_protocol

STUDIES = ("yoshida2008", "spencer1995", "luidolt2020")


def _typed(value: str, column):
    """A session cell as the experiment held it before PsychoPy wrote it."""
    if value == "":
        return ""
    if column.kind is bool:
        return value == "true"
    if column.kind is int:
        return int(value)
    if column.kind is float:
        return float(value)
    return value


def write_psychopy(session_csv: Path, protocol, folder: Path, *, rt_name: str) -> Path:
    """The trials of a glarelab session file, recorded again by PsychoPy's ExperimentHandler
    as a Builder experiment records them (``time_s`` under the name ``rt_name``)."""
    from psychopy import data

    rows = list(csv.DictReader(session_csv.open(encoding="utf-8")))
    schema = columns(protocol)
    first = rows[0]
    name = f"{first['participant']}_{protocol.study}_2026-03-02_14h05.33.120"
    info = {
        "participant": first["participant"],
        "session": f"{int(first['session']):03d}",
        "date": "2026-03-02_14h05.33.120",
        "expName": protocol.study,
        "psychopyVersion": "2026.2.5",
        "frameRate": 59.95,
    }
    experiment = data.ExperimentHandler(
        name=protocol.study,
        extraInfo=info,
        dataFileName=str(folder / name),
        savePickle=False,
        saveWideText=False,
    )
    experiment.addData("instructions.started", 0.016)  # a routine outside the loop
    experiment.addData("key_resp_instr.keys", "space")
    experiment.nextEntry()
    trials = data.TrialHandler(
        trialList=[{"row": i} for i in range(len(rows))], nReps=1, method="sequential",
        name="trials",
    )  # fmt: skip
    experiment.addLoop(trials)
    for _, row in zip(trials, rows, strict=True):
        for column in schema:
            if column.name in ("participant", "session"):
                continue  # the experiment info holds them
            name_in_psychopy = rt_name if column.name == "time_s" else column.name
            experiment.addData(name_in_psychopy, _typed(row[column.name], column))
        experiment.addData("key_resp.keys", "return")
        experiment.nextEntry()
    path = folder / f"{name}.csv"
    experiment.saveAsWideText(str(path), delim=",")
    experiment.abort()  # no second save when the handler is collected
    return path


@pytest.mark.parametrize("study", STUDIES)
def test_psychopy_csvs_analyse_to_the_same_numbers(study, simulated, tmp_path):
    pytest.importorskip("psychopy.data")
    protocol = load_protocol(study)
    own = sorted(simulated.glob(f"*_{study}_s1_*.csv"))
    assert len(own) == 10
    psychopy_folder = tmp_path / "psychopy"
    psychopy_folder.mkdir()
    written = [
        write_psychopy(path, protocol, psychopy_folder, rt_name="key_resp.rt") for path in own
    ]
    header = written[0].read_text(encoding="utf-8-sig").splitlines()[0].split(",")
    # what PsychoPy writes of its own accord is in the files the import is given
    assert {"thisRow.t", "notes", "trials.thisN", "trials.thisTrialN", "date"} <= set(header)
    assert header[-1] == ""
    assert ",True," in written[0].read_text() or study != "yoshida2008"
    imported = import_psychopy(
        protocol, written, tmp_path / "imported", mapping={"key_resp.rt": "time_s"}
    )
    assert len(imported) == 10
    first = imported[0]
    assert {"thisRow.t", "notes", "trials.thisN", "expName", "psychopyVersion"} <= set(
        first.dropped_bookkeeping
    )
    # the loop's condition (row), the key components' keys
    assert set(first.dropped_other) == {"row", "key_resp.keys", "key_resp_instr.keys"}
    assert first.dropped_rows == [2]  # the instructions routine's row
    assert "dropped 1 rows without trial data (lines 2)" in first.summary()
    reports = {}
    for name, files in (
        ("own", own),
        ("psychopy", [session.csv for session in imported]),
    ):
        reports[name] = write_report(protocol, files, tmp_path / f"report_{name}").parent
    tables = sorted(p.name for p in reports["own"].glob("*.csv") if p.name != "trials.csv")
    assert tables
    for table in tables:
        assert (reports["psychopy"] / table).read_bytes() == (
            reports["own"] / table
        ).read_bytes(), table
    # every trial the same, but for the name of the file it came from
    trials = {
        name: pd.read_csv(reports[name] / "trials.csv", keep_default_na=False).drop(columns="file")
        for name in reports
    }
    pd.testing.assert_frame_equal(trials["psychopy"], trials["own"], check_exact=True)
    results = "results.md"
    if (reports["own"] / results).exists():
        assert (reports["psychopy"] / results).read_text() == (
            reports["own"] / results
        ).read_text()


def test_the_command_prints_what_it_dropped(simulated, tmp_path):
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="time_s")
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "import-psychopy", "yoshida2008", str(source),
         "--out", str(tmp_path / "sessions")],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "dropped PsychoPy's columns" in done.stderr
    assert "thisRow.t" in done.stderr and "notes" in done.stderr
    assert "key_resp.keys" in done.stderr
    written = Path(done.stdout.strip())
    assert written.name.startswith("sim01_yoshida2008_s1_2026-03-02_1405")
    assert written.read_text().splitlines()[1].split(",")[17] in ("true", "false")


def test_a_required_column_not_recorded_is_refused_by_name(tmp_path):
    protocol = load_protocol("yoshida2008")
    names = [c.name for c in columns(protocol) if c.name != "dropped_frames"]
    source = tmp_path / "run.csv"
    source.write_text(",".join([*names, "thisRow.t", "notes", ""]) + "\n")
    with pytest.raises(DataError, match=r"no column 'dropped_frames'.*--set dropped_frames"):
        import_psychopy(protocol, [source], tmp_path / "out")
    with pytest.raises(DataError, match="'reaction' is not a column of the yoshida2008"):
        import_psychopy(protocol, [source], tmp_path / "out", mapping={"notes": "reaction"})
    assert (
        import_psychopy(protocol, [source], tmp_path / "out", values={"dropped_frames": "0"}) == []
    )


def test_set_of_a_recorded_column_is_refused_not_ignored(tmp_path):
    # --set participant=P99 on a file that records participant was ignored (the session stayed
    # the recorded participant's): --set fills only what the experiment did not record
    protocol = load_protocol("yoshida2008")
    names = [c.name for c in columns(protocol)]
    source = tmp_path / "run.csv"
    source.write_text(",".join([*names, "thisRow.t", "notes", ""]) + "\n")
    with pytest.raises(DataError, match=r"--set participant=P99: the file records 'participant'"):
        import_psychopy(protocol, [source], tmp_path / "out", values={"participant": "P99"})
    mapped = tmp_path / "rt.csv"  # recorded under another name, mapped with --column
    mapped.write_text(",".join("rt" if n == "time_s" else n for n in names) + "\n")
    with pytest.raises(
        DataError, match=r"--set time_s=1: the file records 'time_s' \(column 'rt'"
    ):
        import_psychopy(
            protocol, [mapped], tmp_path / "out", mapping={"rt": "time_s"}, values={"time_s": "1"}
        )
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("value", "named"),
    [("dropped_frames=zero", "--set dropped_frames=zero: 'zero' is not a whole number"),
     ("dropped_frames=-1", "--set dropped_frames=-1: '-1' is outside [0, inf]"),
     ("q1_glow=yes", "--set q1_glow=yes: 'yes' is not true or false")],
)  # fmt: skip
def test_a_set_value_the_analysis_would_refuse_is_refused_at_once(value, named, tmp_path):
    """--set dropped_frames=zero was written into every row; only the analysis refused it."""
    name, text = value.split("=")
    with pytest.raises(DataError, match=re.escape(named)):
        import_psychopy(load_protocol("yoshida2008"), [], tmp_path / "out", values={name: text})
    assert not (tmp_path / "out").exists()


def test_a_named_last_column_with_data_is_not_dropped(tmp_path):
    protocol = load_protocol("yoshida2008")
    names = [c.name for c in columns(protocol)]
    source = tmp_path / "run.csv"
    cells = ["x"] * len(names)
    source.write_text(",".join([*names, ""]) + "\n" + ",".join([*cells, "kept"]) + "\n")
    with pytest.raises(DataError, match="last column has no name but holds data"):
        import_psychopy(protocol, [source], tmp_path / "out")


def _edit_rows(source: Path, edit) -> None:
    """Rewrite a PsychoPy CSV with ``edit(row, date_column)`` applied to each data row."""
    rows = list(csv.reader(source.open(encoding="utf-8")))
    date = rows[0].index("date")
    for row in rows[1:]:
        edit(row, date)
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)


def test_an_excel_resave_is_imported_and_a_missing_date_is_said(simulated, tmp_path):
    """Re-saved by Excel, the date became 03/02/2026 14:05 and true TRUE: the session was
    dated by the file's modification time without a word, and TRUE refused by the analysis."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="time_s")

    def excel(row, date):
        if len(row) > date and row[date]:
            row[date] = "03/02/2026 14:05"
        row[:] = [{"True": "TRUE", "False": "FALSE", "true": "TRUE"}.get(c, c) for c in row]

    _edit_rows(source, excel)
    (imported,) = import_psychopy(protocol, [source], tmp_path / "out")
    assert "modification time" in imported.summary()
    written = imported.csv.read_text(encoding="utf-8")
    assert "TRUE" not in written and ("true" in written or "false" in written)


def test_empty_lines_at_the_end_import_as_the_untouched_file(simulated, tmp_path):
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path / "a", rt_name="time_s")
    edited = tmp_path / "b" / source.name
    edited.parent.mkdir()
    edited.write_text(source.read_text(encoding="utf-8") + "\n\n", encoding="utf-8")
    (plain,) = import_psychopy(protocol, [source], tmp_path / "out_a")
    (padded,) = import_psychopy(protocol, [edited], tmp_path / "out_b")
    assert padded.csv.read_bytes() == plain.csv.read_bytes()


def test_a_session_imported_again_after_a_touch_is_refused(simulated, tmp_path):
    """A file without PsychoPy's date is dated by its modification time: touched and imported
    again, it became a second copy of the session under another name."""
    import os

    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="time_s")
    _edit_rows(source, lambda row, date: row.__setitem__(date, "") if len(row) > date else None)
    (first,) = import_psychopy(protocol, [source], tmp_path / "out")
    later = source.stat().st_mtime + 3600
    os.utime(source, (later, later))
    with pytest.raises(DataError, match=rf"session 1 is in .* already \({first.csv.name};"):
        import_psychopy(protocol, [source], tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(
        [first.csv.name, first.csv.with_suffix(".json").name]
    )


def test_a_file_whose_rows_were_sorted_imports_as_the_session_wrote_it(simulated, tmp_path):
    """Rows in another order (sorted in a spreadsheet, trial numbers kept) were written in that
    order with their digests in it, and the analysis refused every row as changed."""
    from glarelab.analysis.load import load_sessions

    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path / "a", rt_name="time_s")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    sorted_file = tmp_path / "b" / source.name
    sorted_file.parent.mkdir()
    with sorted_file.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows([*rows[:2], *reversed(rows[2:])])  # the header, instructions
    (plain,) = import_psychopy(protocol, [source], tmp_path / "out_a")
    (moved,) = import_psychopy(protocol, [sorted_file], tmp_path / "out_b")
    assert moved.csv.read_bytes() == plain.csv.read_bytes()
    assert len(load_sessions(protocol, [moved.csv]).trials) == 15


def test_a_full_disk_leaves_no_session_of_the_import(simulated, tmp_path, monkeypatch):
    """The disk filled after the first of six sessions: it stayed, and the import run again
    refused it as existing."""
    import errno

    from glarelab.analysis import psychopy_import

    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[:2]
    sources = [write_psychopy(p, protocol, tmp_path / "pp", rt_name="time_s") for p in own]
    calls = []
    real = psychopy_import.write_text

    def filling(path, text):
        calls.append(path)
        if len(calls) == 3:
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, text)

    monkeypatch.setattr(psychopy_import, "write_text", filling)
    with pytest.raises(OSError, match="No space left"):
        import_psychopy(protocol, sources, tmp_path / "out")
    assert list((tmp_path / "out").iterdir()) == []
    monkeypatch.setattr(psychopy_import, "write_text", real)
    assert len(import_psychopy(protocol, sources, tmp_path / "out")) == 2


def test_an_import_into_a_stimulus_set_is_refused(tmp_path):
    """Session files written into a set made it fail verification (sessions then refuse it)."""
    from glarelab.stimuli.stimulus_set import build_stimulus_set

    folder = tmp_path / "set"
    build_stimulus_set(load_protocol("yoshida2008"), folder, progress=None)
    source = tmp_path / "run.csv"
    source.write_text("participant,session\n")
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "import-psychopy", "yoshida2008", str(source),
         "--out", str(folder)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 2 and "inside the stimulus set" in done.stderr, done.stderr


def test_an_out_that_is_a_file_is_refused_as_no_folder(tmp_path):
    """``--out`` given a session file was refused with the system's bare 'File exists'."""
    protocol = load_protocol("yoshida2008")
    source = tmp_path / "run.csv"  # a PsychoPy file without trial rows
    source.write_text(",".join(c.name for c in columns(protocol)) + ",thisRow.t,notes,\n")
    taken = tmp_path / "a_file.csv"
    taken.write_text("kept\n")
    with pytest.raises(ValueError) as refused:
        import_psychopy(protocol, [source], taken)
    assert str(refused.value) == (
        f"--out {taken} is a file; the imported session files go into a folder (give a "
        "folder's path, new or existing)"
    )
    assert taken.read_text() == "kept\n"


def test_a_ragged_csv_of_its_own_in_out_is_no_bug(tmp_path):
    """A CSV of the lab's own in ``--out`` with rows longer or shorter than its header stopped
    the import with a TypeError where it compares the trials of the sessions there."""
    protocol = load_protocol("yoshida2008")
    source = tmp_path / "run.csv"  # a PsychoPy file without trial rows
    source.write_text(",".join(c.name for c in columns(protocol)) + ",thisRow.t,notes,\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.csv").write_text("a,time_s\n1,2,3\n4\n")
    assert import_psychopy(protocol, [source], out) == []


def test_a_file_saved_with_semicolons_is_named_as_such(tmp_path):
    """A spreadsheet in a German locale saved the run with ';': 'no column key_resp.rt'."""
    protocol = load_protocol("yoshida2008")
    names = [c.name for c in columns(protocol) if c.name != "time_s"]
    source = tmp_path / "run.csv"
    source.write_text(";".join([*names, "key_resp.rt"]) + "\n" + ";".join("1" * 23) + "\n")
    with pytest.raises(DataError, match=r"line 1: not comma-separated \(its first line is one "
                       r"cell holding ';'.*save it with ',' between cells\)"):  # fmt: skip
        import_psychopy(protocol, [source], tmp_path / "out", mapping={"key_resp.rt": "time_s"})


@pytest.mark.parametrize(
    "date, stem",
    [
        ("2026_Dec_03_0729", "2026-12-03_0729"),  # older PsychoPy releases' getDateStr
        ("2026-12-03_07h29.22.123", "2026-12-03_0729"),
        ("2026_Feb_30_0729", None),  # no such day: dated by the file, the value named
        ("03/12/2026 07:29", None),  # a spreadsheet's re-save
    ],
)
def test_each_psychopy_date_format_dates_the_session(simulated, tmp_path, date, stem):
    """PsychoPy's older date, 2026_Dec_03_0729, was not read: the session was dated by the
    file's modification time and the message said the file had no date."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="time_s")
    _edit_rows(source, lambda row, at: row.__setitem__(at, date) if len(row) > at else None)
    (imported,) = import_psychopy(protocol, [source], tmp_path / "out")
    if stem is None:
        assert f"its 'date' {date!r} is not PsychoPy's" in imported.summary()
    else:
        assert imported.csv.stem.endswith(stem)
        assert "modification time" not in imported.summary()


def test_a_named_pipe_a_folder_or_nothing_is_refused_without_opening_it(tmp_path):
    """A named pipe among the sources blocked the import forever (it waited for a writer)."""
    import os

    fifo = tmp_path / "run.csv"
    os.mkfifo(fifo)
    (tmp_path / "folder.csv").mkdir()
    protocol = load_protocol("yoshida2008")
    sources = [fifo, tmp_path / "folder.csv", tmp_path / "none.csv"]
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, sources, tmp_path / "out")
    assert refused.value.problems == [
        f"PsychoPy file {fifo}: a named pipe (FIFO), not a regular file",
        f"PsychoPy file {tmp_path / 'folder.csv'}: a folder, not a file",
        f"no PsychoPy file at {tmp_path / 'none.csv'}",
    ]
    assert not (tmp_path / "out").exists()


def _without_trial(source: Path, target: Path, reorder=None) -> Path:
    """A PsychoPy file as Builder writes it (no ``trial`` column), its rows after the header
    and the instructions' reordered by ``reorder``."""
    rows = list(csv.reader(source.open(encoding="utf-8")))
    keep = [i for i, name in enumerate(rows[0]) if name != "trial"]
    rows = [[row[i] for i in keep if i < len(row)] for row in rows]
    clock = rows[0].index("thisRow.t")
    for number, row in enumerate(rows[1:]):  # Builder's routines time each entry
        row[clock] = f"{1.0 + 9.5 * number:.4f}"
    body = rows[2:] if reorder is None else reorder(rows[2:])
    target.parent.mkdir(parents=True, exist_ok=True)
    with target.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows([*rows[:2], *body])
    return target


@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995"])
def test_a_file_without_trial_numbers_sorted_in_a_spreadsheet_imports_as_psychopy_wrote_it(
    study, simulated, tmp_path
):
    """Builder writes no trial column; sorted by a column in a spreadsheet, the rows were
    numbered in their sorted order (training after the main trials), and a staircase's replay
    then blamed an edited cell."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol(study)
    own = sorted(simulated.glob(f"*_{study}_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path / "w", rt_name="time_s")
    plain = _without_trial(source, tmp_path / "a" / source.name)
    moved = _without_trial(source, tmp_path / "b" / source.name, lambda rows: rows[::-1])
    (first,) = import_psychopy(protocol, [plain], tmp_path / "out_a")
    (second,) = import_psychopy(protocol, [moved], tmp_path / "out_b")
    assert second.csv.read_bytes() == first.csv.read_bytes()
    assert "thisRow.t), the file's rows having been moved" in second.summary()
    rows = list(csv.reader(plain.open(encoding="utf-8")))
    for row in rows[1:]:
        row[rows[0].index("thisRow.t")] = ""  # an experiment that does not time its rows
    untimed = tmp_path / "c" / source.name
    untimed.parent.mkdir()
    with untimed.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    (third,) = import_psychopy(protocol, [untimed], tmp_path / "out_c")
    assert "numbered in file order (no thisRow.t on every row" in third.summary()
    from datetime import datetime, timedelta

    start = datetime.fromisoformat("2026-12-03 07:10:14.5+01:00")
    for number, row in enumerate(rows[1:]):  # Builder's clock set to wall-clock time: ISO
        row[rows[0].index("thisRow.t")] = (start + timedelta(seconds=9.5 * number)).isoformat()
    walled = tmp_path / "d" / source.name
    walled.parent.mkdir()
    with walled.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows([*rows[:2], *rows[2:][::-1]])
    (fourth,) = import_psychopy(protocol, [walled], tmp_path / "out_d")
    assert fourth.csv.read_bytes() == first.csv.read_bytes()


def test_an_instructions_row_with_a_trial_value_is_named_not_imported_as_a_trial(
    simulated, tmp_path
):
    """An instructions row that recorded the mapped response time became trial 1 with its
    other cells empty (16 trials of 15); only the analysis refused, at the imported lines."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="key_resp.rt")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    rows[1][rows[0].index("key_resp.rt")] = "1.2"  # the instructions' key press, timed
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, [source], tmp_path / "out", mapping={"key_resp.rt": "time_s"})
    (problem,) = refused.value.problems
    # named by its line and the value that made it a trial row (as docs/analysis.md says),
    # not by the 19 columns it lacks
    assert problem.startswith(
        f"{source}, line 2: key_resp.rt='1.2' makes it a trial row, but it has no "
    ), problem
    assert "more, which every trial records" in problem and "outside the trial loop" in problem
    assert not (tmp_path / "out").exists()


def test_an_instructions_row_without_the_experiment_info_names_its_trial_value(
    simulated, tmp_path
):
    """An instructions row without participant or session, but with the mapped response time,
    was refused as 'line 2: no session', not saying what made it a trial row."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="key_resp.rt")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    header = rows[0]
    rows[1][header.index("key_resp.rt")] = "1.5"
    rows[1][header.index("session")] = ""
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    mapping = {"key_resp.rt": "time_s"}
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, [source], tmp_path / "out", mapping=mapping)
    assert refused.value.problems == [
        f"{source}, line 2: no session, which every trial records, but key_resp.rt='1.5' "
        "makes it a trial row: a row outside the trial loop (instructions) with a value in a "
        "trial column? Leave that row's trial columns empty, or remove it"
    ]
    for row in rows[1:]:  # the experiment's info dialog left empty: said once, not per row
        row[header.index("session")] = ""
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, [source], tmp_path / "out", mapping=mapping)
    assert refused.value.problems == [
        f"{source}: no session on any trial row (column 'session' empty: the experiment's "
        "info dialog left empty?); write the session into the column"
    ]
    # a session the experiment did not record is given with --set
    rows[1][header.index("key_resp.rt")] = ""
    at = header.index("session")
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows([row[:at] + row[at + 1 :] for row in rows])
    (imported,) = import_psychopy(
        protocol, [source], tmp_path / "out", mapping=mapping, values={"session": "2"}
    )
    assert imported.session == 2 and imported.trials == len(rows) - 2


def test_trials_recorded_as_another_study_are_refused_at_import(simulated, tmp_path):
    """A file whose study cells say spencer1995 imported as a yoshida2008 session without a
    word (sidecar yoshida2008, rows spencer1995); only the analysis refused it, every row."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="time_s")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    at = rows[0].index("study")
    for row in rows[2:]:  # the trial rows (the instructions' row records no study)
        row[at] = "spencer1995"
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, [source], tmp_path / "out")
    assert refused.value.problems == [
        f"{source}, lines 3, 4, 5, 6, 7, 8, 9, 10 …, column 'study': 'spencer1995', not "
        "'yoshida2008': trials of another study? Import a file with the protocol of the study "
        "it records"
    ]
    assert not (tmp_path / "out").exists()


def test_a_session_glarelab_ran_is_refused_not_imported_as_psychopys(simulated, tmp_path):
    """A pilot, simulated or aborted session of glarelab's own, given to import-psychopy, was
    written as pilot false, simulated false, completed: the analysis then counted it."""
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    with pytest.raises(DataError, match=r"a glarelab session file \(its sidecar .*\.json is"):
        import_psychopy(protocol, [own], tmp_path / "out")
    alone = tmp_path / "copied" / own.name  # the CSV copied without its sidecar
    alone.parent.mkdir()
    alone.write_bytes(own.read_bytes())
    with pytest.raises(DataError, match=r"a glarelab session file's columns, exactly"):
        import_psychopy(protocol, [alone], tmp_path / "out")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("study", STUDIES)
def test_a_reports_table_of_trials_is_refused_not_imported_as_psychopys(reports, study, tmp_path):
    """A report's trials.csv (simulated observers' rows, with the session file of each) was
    imported as PsychoPy's: its sessions said simulated false, and the analysis of them spoke of
    participants where simulated observers had been run."""
    protocol = load_protocol(study)
    table = reports[study] / "trials.csv"
    named = pd.read_csv(table, keep_default_na=False)["file"].unique()
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, [table], tmp_path / "out")
    (problem,) = refused.value.problems
    assert problem.startswith(f"{table}: a glarelab report's table of trials")
    assert named[0] in problem
    assert "give glarelab analyse the session files it names" in problem
    moved = tmp_path / "moved.csv"  # out of its report folder, its columns reordered
    frame = pd.read_csv(table, dtype=str, keep_default_na=False)
    frame[list(reversed(frame.columns))].to_csv(moved, index=False)
    with pytest.raises(DataError, match=r"a glarelab report's table of trials"):
        import_psychopy(protocol, [moved], tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_a_file_and_its_resave_are_not_two_participants(simulated, tmp_path):
    """A participant's file and its spreadsheet re-save (participant 001 became 1) imported
    as two participants with the same trials: 11 participants in the report where 10 ran."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path / "a", rt_name="time_s")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    at = rows[0].index("participant")
    for row in rows[1:]:
        row[at] = "resaved"
        for i, cell in enumerate(row):  # a spreadsheet keeps 15 digits: 7000.0 is 7000
            if re.fullmatch(r"-?\d+\.\d+", cell):
                row[i] = f"{float(cell):.15g}"
    copy = tmp_path / "b" / "resaved.csv"
    copy.parent.mkdir()
    with copy.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    with pytest.raises(
        DataError, match=r"resaved\.csv: its trials are those of .*, cell for cell"
    ):
        import_psychopy(protocol, [source, copy], tmp_path / "out")
    assert not (tmp_path / "out").exists()
    import_psychopy(protocol, [source], tmp_path / "out")
    with pytest.raises(DataError, match=r"its trials are those of .*_yoshida2008_s1_.*\.csv"):
        import_psychopy(protocol, [copy], tmp_path / "out")  # in a later import too
    # imported into a folder of its own, the analysis of both folders names the pair
    (second,) = import_psychopy(protocol, [copy], tmp_path / "elsewhere")
    first = next((tmp_path / "out").glob("*.csv"))
    with pytest.raises(DataError) as refused:
        load_sessions(protocol, [first, second.csv])
    (problem,) = refused.value.problems
    assert problem.startswith(f"{second.csv}: its trials are those of {first}, cell for cell")


def test_the_end_of_block_rows_of_an_outer_loop_are_no_trials(simulated, tmp_path):
    """Builder's outer loop of blocks ends each block with a row of its own (the block and
    its loop's bookkeeping): refused as an instructions row holding a trial value."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("yoshida2008")
    own = sorted(simulated.glob("*_yoshida2008_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path / "a", rt_name="time_s")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    block = rows[0].index("block")
    nested = [rows[0], rows[1]]
    for row in rows[2:]:
        nested.append(row)
        if row[block] == "training":  # after each training trial, as a small outer loop
            end = [""] * len(row)
            end[block] = "training"
            nested.append(end)
    target = tmp_path / "b" / source.name
    target.parent.mkdir()
    with target.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(nested)
    (plain,) = import_psychopy(protocol, [source], tmp_path / "out_a")
    (blocked,) = import_psychopy(protocol, [target], tmp_path / "out_b")
    assert blocked.csv.read_bytes() == plain.csv.read_bytes()
    assert len(blocked.dropped_rows) > len(plain.dropped_rows)


@pytest.mark.parametrize(
    ("column", "value", "named"),
    [("rating", "4.5", "'4.5'"), ("rating", "9", "9"), ("category", "Glare Appearence",
     "Glare Appearence")],
)  # fmt: skip
def test_a_session_the_analysis_would_refuse_is_refused_at_import(
    column, value, named, simulated, tmp_path
):
    """A rating of 4.5 or 9 (of 1-7), a misspelt category: imported without a word, and
    refused only by the analysis one command later; now named at the import, at the source's
    line, and nothing written."""
    pytest.importorskip("psychopy.data")
    protocol = load_protocol("luidolt2020")
    own = sorted(simulated.glob("*_luidolt2020_s1_*.csv"))[0]
    source = write_psychopy(own, protocol, tmp_path, rt_name="time_s")
    rows = list(csv.reader(source.open(encoding="utf-8")))
    at = rows[0].index(column)
    line = next(n for n, row in enumerate(rows[1:], start=2) if len(row) > at and row[at])
    rows[line - 1][at] = value
    with source.open("w", encoding="utf-8", newline="") as handle:
        csv.writer(handle).writerows(rows)
    with pytest.raises(DataError) as refused:
        import_psychopy(protocol, [source], tmp_path / "out")
    problems = [p for p in refused.value.problems if named in p]
    assert problems, refused.value.problems
    assert f"{source}, line {line}" in problems[0], problems[0]
    assert "the analysis would refuse it" in problems[0]
    assert "glarelab-import-" not in str(refused.value)  # the temporary copy is never named
    assert not (tmp_path / "out").exists()
