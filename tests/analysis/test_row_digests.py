"""Every row the analysis counts is the one its session wrote: a session records each row's
digest in its sidecar (``row_sha256``, :func:`glarelab.protocols.row_digest`), and a row
changed afterwards (a value edited in a spreadsheet, an answer flipped, a label swapped) is
named with its file, line and trial, while rows re-ordered or columns moved change nothing."""

import json
import re
import shutil

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.protocols import load_protocol, row_digest

from .test_load_and_report import csvs

EDITED = "the row is not the one the session wrote"
FINISHED = ("trials_after", "ended_by", "ignored_key_presses")  # what a run's end writes


def copy(source, folder, frame=None, **sidecar):
    """A copy of a session (``frame``: its rows as strings, changed) with sidecar keys set."""
    target = folder / source.name
    if frame is None:
        shutil.copy(source, target)
    else:
        frame.to_csv(target, index=False, lineterminator="\n")
    data = json.loads(source.with_suffix(".json").read_text()) | sidecar
    target.with_suffix(".json").write_text(json.dumps(data))
    return target


def rows(source):
    return pd.read_csv(source, keep_default_na=False, dtype=str)


def test_a_session_records_the_digest_of_every_row_it_wrote(simulated):
    for source in sorted(simulated.glob("sim0[12]_*.csv")):
        frame = rows(source)
        recorded = json.loads(source.with_suffix(".json").read_text())["row_sha256"]
        assert recorded == [row_digest(row) for row in frame.itertuples(index=False)]


def shift_match(frame):  # a main-block match moved by 5 cd/m², still within the display
    row = frame.index[frame["block"] == "main"][0]
    frame.at[row, "match_cd_m2"] = repr(float(frame.at[row, "match_cd_m2"]) + 5.0)
    return [row + 2]


def last_answer_neither(frame):  # what a replay of the staircase alone cannot tell
    frame.at[len(frame) - 1, "response"] = "neither"
    return [len(frame) + 1]


def other_rating(frame):
    frame.at[0, "rating"] = "5" if frame.at[0, "rating"] != "5" else "3"
    return [2]


def swap_categories(frame):  # two questions' labels swapped, their ratings kept
    frame.loc[[0, 1], "category"] = frame.loc[[1, 0], "category"].to_list()
    return [2, 3]


@pytest.mark.parametrize(
    "study, edit",
    [
        ("yoshida2008", shift_match),
        ("spencer1995", last_answer_neither),
        ("luidolt2020", other_rating),
        ("luidolt2020", swap_categories),
    ],
)
def test_a_row_changed_after_the_session_is_named_by_line_and_trial(
    simulated, tmp_path, study, edit
):
    source = csvs(simulated, study)[0]
    frame = rows(source)
    lines = edit(frame)
    target = copy(source, tmp_path, frame)
    with pytest.raises(DataError) as refused:
        load_sessions(load_protocol(study), [target])
    named = [p for p in refused.value.problems if EDITED in p]
    assert [re.search(r"line (\d+) \(trial", p)[1] for p in named] == [str(n) for n in lines]
    assert all(f"trial {n - 1}" in p for n, p in zip(lines, named, strict=True))


def test_rows_reordered_and_columns_moved_are_read_as_written(simulated, tmp_path):
    protocol = load_protocol("yoshida2008")
    source = csvs(simulated, "yoshida2008")[0]
    frame = rows(source).sample(frac=1.0, random_state=3)  # a spreadsheet's sort
    frame = frame[[*frame.columns[1:], frame.columns[0]]]  # the first column moved last
    target = copy(source, tmp_path, frame)
    shown = load_sessions(protocol, [target]).trials.drop(columns=["_file", "_line"])
    expected = load_sessions(protocol, [source]).trials.drop(columns=["_file", "_line"])
    pd.testing.assert_frame_equal(shown, expected)


def test_a_sidecar_without_row_digests_is_refused_unless_of_an_older_format(simulated, tmp_path):
    protocol = load_protocol("luidolt2020")
    source = csvs(simulated, "luidolt2020")[0]
    target = copy(source, tmp_path)
    sidecar = json.loads(target.with_suffix(".json").read_text())
    del sidecar["row_sha256"]
    target.with_suffix(".json").write_text(json.dumps(sidecar))
    with pytest.raises(DataError, match="no row_sha256, which every session of data format"):
        load_sessions(protocol, [target])
    target.with_suffix(".json").write_text(json.dumps(sidecar | {"data_format": "0.4"}))
    with pytest.warns(UserWarning, match=r"1 session\(s\) of a data format before 0\.5"):
        assert len(load_sessions(protocol, [target]).trials) == len(rows(source))
    # a sidecar made to look older keeps its digests: they are checked all the same
    frame = rows(source)
    frame.at[0, "rating"] = "5" if frame.at[0, "rating"] != "5" else "3"
    (tmp_path / "older").mkdir()
    older = copy(source, tmp_path / "older", frame, data_format="0.4")
    with pytest.raises(DataError, match=r"predates row_sha256(.|\n)*line 2 \(trial 1\): the row"):
        load_sessions(protocol, [older])
    for bad in (["ABC"], "digests", [1]):
        target.with_suffix(".json").write_text(json.dumps(sidecar | {"row_sha256": bad}))
        with pytest.raises(DataError, match=r"row_sha256 .*a list of row digests"):
            load_sessions(protocol, [target])


def test_rows_cut_from_an_aborted_session_are_named_and_a_killed_runs_last_rows_read(
    simulated, tmp_path
):
    protocol = load_protocol("luidolt2020")
    source = csvs(simulated, "luidolt2020")[0]
    frame = rows(source)
    sidecar = json.loads(source.with_suffix(".json").read_text())
    cut = len(frame) - 2
    runs = [sidecar["runs"][-1] | {"status": "aborted", "trials_after": cut, "ended_by": "escape"}]
    target = copy(source, tmp_path, frame.iloc[:cut], status="aborted", trials=cut, runs=runs)
    with pytest.raises(DataError, match=rf"trials {cut + 1}, {cut + 2} of the {len(frame)} the"):
        load_sessions(protocol, [target], include_aborted=True)
    # resumed, and killed after writing its last trial's row, before its digest: the sidecar
    # still says running and has the digests of all rows but that one
    started = {k: v for k, v in sidecar["runs"][-1].items() if k not in FINISHED}
    killed = [*runs, started | {"status": "running", "ended": None, "trials_before": cut}]
    copy(source, tmp_path, frame, status="running", trials=cut, runs=killed, resumed=1,
         row_sha256=sidecar["row_sha256"][: cut + 1])  # fmt: skip
    read = load_sessions(protocol, [target], include_aborted=True)
    assert len(read.trials) == len(frame)
    # two rows without digests: a session records each row's digest right after it, so the
    # second was added by hand (or the sidecar is an earlier one)
    copy(source, tmp_path, frame, status="running", trials=cut, runs=killed, resumed=1,
         row_sha256=sidecar["row_sha256"][:cut])  # fmt: skip
    with pytest.raises(DataError, match=rf"\(trial {cut + 2}\): beyond the {cut} rows the "
                       rf"session recorded .* by more than the one row \(trial {cut + 1}\)"):  # fmt: skip
        load_sessions(protocol, [target], include_aborted=True)
    # the same rows in a session that says it completed are rows added after it
    copy(source, tmp_path, frame, row_sha256=sidecar["row_sha256"][:cut])
    with pytest.raises(DataError, match=rf"line {cut + 2} \(trial {cut + 1}\): not among the"):
        load_sessions(protocol, [target])


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(
    study=st.sampled_from(["yoshida2008", "spencer1995", "luidolt2020"]),
    where=st.tuples(st.floats(0, 1, exclude_max=True), st.floats(0, 1, exclude_max=True)),
    other=st.floats(0, 1, exclude_max=True),
)
def test_any_cell_changed_to_another_columns_value_is_named(
    simulated, tmp_path_factory, study, where, other
):
    """A cell of any row and column given a value the column holds elsewhere (what a
    spreadsheet's fill or a hand's copy does), or text where every cell is alike: the row is
    named."""
    source = csvs(simulated, study)[1]
    frame = rows(source)
    row, column = int(where[0] * len(frame)), frame.columns[int(where[1] * frame.shape[1])]
    values = sorted(set(frame[column]) - {frame.at[row, column]}) or ["a word typed in"]
    frame.at[row, column] = values[int(other * len(values))]
    target = copy(source, tmp_path_factory.mktemp("cell"), frame)
    with pytest.raises(DataError) as refused:
        load_sessions(load_protocol(study), [target])
    assert any(re.search(rf"line {row + 2}\b", p) for p in refused.value.problems), refused.value


def test_a_session_of_an_older_format_edited_since_is_analysed_with_a_word(simulated, tmp_path):
    """A sidecar made to look like data format 0.4 (its digests removed) let an edited rating
    through without a word: now analyse warns, and the report lists its rows as unchecked."""
    from glarelab.analysis.report import write_report

    protocol = load_protocol("luidolt2020")
    sources = csvs(simulated, "luidolt2020")
    frame = rows(sources[0])
    frame.at[0, "rating"] = "1" if frame.at[0, "rating"] != "1" else "2"
    (tmp_path / "data").mkdir()
    edited = copy(sources[0], tmp_path / "data", frame, data_format="0.4")
    sidecar = json.loads(edited.with_suffix(".json").read_text())
    del sidecar["row_sha256"]
    edited.with_suffix(".json").write_text(json.dumps(sidecar))
    others = [copy(s, tmp_path / "data") for s in sources[1:]]
    with pytest.warns(UserWarning, match=rf"an edit of their rows .*: {edited.name}"):
        report = write_report(protocol, [edited, *others], tmp_path / "report")
    page = report.read_text()
    assert "Sessions whose rows are not checked" in page and edited.name in page
    assert ",," not in page
