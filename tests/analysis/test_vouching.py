"""The analysis vouches for each session it counts: pilots left out (and listed), sessions of
another protocol, set, calibration or participant refused with the reason, row order
irrelevant, trials missing or given twice named, impossible values refused with file and line,
two sessions of one participant named; and a property test that shuffles, duplicates and
truncates the rows of real session files: the analysis gives the untouched result or refuses
naming the row."""

import json
import random
import re
import shutil
import tempfile
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.analysis.paradigms import PARADIGMS
from glarelab.analysis.report import write_report
from glarelab.protocols import DATA_FORMAT, load_protocol
from tests.conftest import reseal


def csvs(folder, study):
    return sorted(folder.glob(f"*_{study}_s*.csv"))


def copy_session(source: Path, folder: Path, *, name=None, rows=None, sidecar=None) -> Path:
    """A copy of a session's CSV and sidecar in ``folder``: ``name`` its new file name,
    ``rows`` changes its text lines (the rows' digests recorded anew, as a session that wrote
    them would have), ``sidecar`` its sidecar's keys."""
    target = folder / (name or source.name)
    lines = source.read_text().splitlines(keepends=True)
    target.write_text("".join(rows(lines) if rows else lines))
    data = json.loads(source.with_suffix(".json").read_text())
    if sidecar is not None:
        data |= sidecar
    target.with_suffix(".json").write_text(json.dumps(data))
    if rows is not None:
        reseal(target)
    return target


def renamed(lines, old, new):
    return [line.replace(f",{old},", f",{new},") for line in lines]


def tables(protocol, files):
    return PARADIGMS[protocol.paradigm].tests(load_sessions(protocol, files), protocol)


@pytest.fixture
def yoshida(simulated):
    return load_protocol("yoshida2008"), csvs(simulated, "yoshida2008")


def test_a_pilot_is_left_out_listed_and_analysed_only_when_asked(yoshida, tmp_path):
    protocol, files = yoshida
    source = files[0]
    runs = json.loads(source.with_suffix(".json").read_text())["runs"]
    pilot = copy_session(
        source,
        tmp_path,
        name=source.name.replace("sim01", "pil01").replace(".csv", "_pilot.csv"),
        # another person's times: sim01's trials under another id are refused as one
        # person's session counted twice
        rows=lambda lines: _set_cell(renamed(lines, "sim01", "pil01"), 2, "time_s", "9.5"),
        # a pilot's sidecar says it at the top and in each run, as a --pilot run writes it
        sidecar={
            "pilot": True,
            "participant": "pil01",
            "runs": [r | {"pilot": True} for r in runs],
        },
    )
    dataset = load_sessions(protocol, [*files, pilot])
    assert "pil01" not in set(dataset.trials["participant"])
    assert [Path(s["file"]).name for s in dataset.pilots] == [pilot.name]
    included = load_sessions(protocol, [*files, pilot], include_pilots=True)
    assert "pil01" in set(included.trials["participant"]) and included.pilots_included
    report = write_report(protocol, [*files, pilot], tmp_path / "report")
    html = report.read_text()
    assert "Pilot sessions, left out of the analysis (--include-pilots analyses them)" in html
    assert pilot.name in html
    assert "Analysis of 10 " in html  # the ten participants, not the pilot
    with pytest.raises(DataError, match="every session given is a pilot"):
        load_sessions(protocol, [pilot])
    # a pilot's file renamed to look like a participant's is still a pilot (its sidecar)
    hidden = copy_session(pilot, tmp_path, name=pilot.name.replace("_pilot", ""))
    with pytest.raises(DataError, match="the file name says not a pilot, its sidecar says pilot"):
        load_sessions(protocol, [*files, hidden])


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"protocol_sha256": "0" * 64}, "ran with protocol sha256 000000000000…"),
        ({"study": "spencer1995"}, "study 'spencer1995', but the data are analysed as"),
        ({"participant": "sim07"}, "participant 'sim07', but its CSV's rows say sim01"),
        (
            {"images_encoded_with": {"readings_sha256": "a" * 64, "source": "session"},
             "calibration": {"calibrated": True, "status": "passed",
                             "readings_sha256": "b" * 64}},
            "the session's calibration (readings bbbbbbbbbbbb…) is not the one its images",
        ),
        ({"trials": 16}, "trial 16 of the 16 the completed session recorded missing"),
        ({"runs": [{"pilot": True}]}, "pilot is false, but run(s) 1 say pilot true"),
        ({"data_format": 0.4}, 'data_format is 0.4, not text: a session writes it as a string'),
        (
            {"simulated": True, "runs": [{"keyboard": "psychtoolbox"}]},
            "simulated is true, but its runs' keyboard is psychtoolbox, not the simulated",
        ),
    ],
)  # fmt: skip
def test_a_sidecar_that_disagrees_is_refused_with_the_reason(yoshida, tmp_path, change, named):
    protocol, files = yoshida
    bad = copy_session(files[0], tmp_path, sidecar=change)
    with pytest.raises(DataError, match=re.escape(named)):
        load_sessions(protocol, [bad, *files[1:]])


@pytest.mark.parametrize(
    "key",
    ["protocol_sha256", "status", "study", "participant", "simulated", "pilot", "started"],
)
def test_a_sidecar_key_every_session_writes_is_missed_by_name(yoshida, tmp_path, key):
    # a protocol_sha256 deleted let a session of another protocol be counted, and a status
    # deleted was reported as a session that "did not complete (unknown)"
    protocol, files = yoshida
    bad = copy_session(files[0], tmp_path)
    data = json.loads(bad.with_suffix(".json").read_text())
    del data[key]
    bad.with_suffix(".json").write_text(json.dumps(data))
    with pytest.raises(DataError, match=re.escape(f".json: no {key}: every session and import")):
        load_sessions(protocol, [bad, *files[1:]])


def test_a_session_of_another_stimulus_set_is_refused(yoshida):
    protocol, files = yoshida
    other = {"manifest_sha256": "c" * 64, "readings_sha256": None}
    with pytest.raises(DataError, match=r"ran on the stimulus set with manifest sha256 .* the "
                       r"analysis is given cccccccccccc…"):  # fmt: skip
        load_sessions(protocol, files, stimuli=other)


def test_a_file_renamed_to_another_participant_is_refused(yoshida, tmp_path):
    protocol, files = yoshida
    moved = copy_session(files[0], tmp_path, name=files[0].name.replace("sim01", "sim11"))
    with pytest.raises(
        DataError, match="the file name says participant sim11, its rows say sim01"
    ):
        load_sessions(protocol, [moved, *files[1:]])


@pytest.mark.parametrize(
    "name",
    [
        "sim11_yoshida2008_s1.csv",
        "sim11_yoshida2008_s1_2026-12-04.csv",
        "sim11_yoshida2008_s1 copy.csv",
    ],
)
def test_a_file_renamed_to_another_participant_without_its_date_is_refused(
    yoshida, tmp_path, name
):
    # only whole PARTICIPANT_STUDY_sN_DATE_TIME names were checked
    protocol, files = yoshida
    moved = copy_session(files[0], tmp_path, name=name)
    with pytest.raises(
        DataError, match="the file name says participant sim11, its rows say sim01"
    ):
        load_sessions(protocol, [moved, *files[1:]])


def test_a_sidecar_that_is_a_folder_is_refused(yoshida, tmp_path):
    protocol, files = yoshida
    target = tmp_path / files[0].name
    shutil.copy(files[0], target)
    target.with_suffix(".json").mkdir()
    with pytest.raises(DataError, match=r"\.json: not a file \(a folder\?\)"):
        load_sessions(protocol, [target])


def test_rows_in_any_order_give_the_same_analysis(yoshida, tmp_path):
    protocol, files = yoshida
    rng = random.Random(3)

    def shuffled(lines):
        body = lines[1:]
        rng.shuffle(body)
        return [lines[0], *body]

    mixed = [copy_session(f, tmp_path, rows=shuffled) for f in files]
    before, after = tables(protocol, files), tables(protocol, list(reversed(mixed)))
    for name in before:
        pd.testing.assert_frame_equal(before[name], after[name], check_exact=True)


@pytest.mark.parametrize(
    ("edit", "named"),
    [
        (lambda lines: [*lines, lines[5]], r"line 17: duplicated trial .*trial 5\), also on line 6"),
        (lambda lines: lines[:6] + lines[7:], r"trial 6 of 15 missing"),
        (lambda lines: lines[1:] + lines[:1], r"line 16: the header is on line 16, not the first"),
        (lambda lines: [*lines[:8], lines[0], *lines[8:]], r"line 9: the header repeated"),
        (lambda lines: [*lines[:-1], lines[-1].rstrip("\n")], r"line 16: the file ends inside"),
    ],
)  # fmt: skip
def test_rows_deleted_repeated_or_moved_are_named(yoshida, tmp_path, edit, named):
    protocol, files = yoshida
    bad = copy_session(files[0], tmp_path, rows=edit)
    with pytest.raises(DataError, match=named):
        load_sessions(protocol, [bad, *files[1:]])


@pytest.mark.parametrize(
    "ending", ["\n", "\n\n\n", "\r\n", ",,,,\n", ",,,,\n,,,,"], ids=repr
)  # fmt: skip
def test_empty_lines_a_spreadsheet_leaves_at_the_end_change_nothing(yoshida, tmp_path, ending):
    protocol, files = yoshida
    width = files[0].read_text().splitlines()[0].count(",")
    ending = ending.replace(",,,,", "," * width)
    edited = tmp_path / files[0].name
    edited.write_text(files[0].read_text() + ending)
    shutil.copy(files[0].with_suffix(".json"), edited.with_suffix(".json"))
    before, after = tables(protocol, files), tables(protocol, [edited, *files[1:]])
    for name in before:
        pd.testing.assert_frame_equal(before[name], after[name], check_exact=True)


def test_an_empty_line_among_the_rows_is_named(yoshida, tmp_path):
    protocol, files = yoshida
    bad = copy_session(files[0], tmp_path, rows=lambda lines: [*lines[:6], "\n", *lines[6:]])
    with pytest.raises(DataError, match=r"line 7: an empty line among the data rows"):
        load_sessions(protocol, [bad, *files[1:]])


def _set_cell(lines, line, column, value):
    header = lines[0].rstrip("\n").split(",")
    cells = lines[line - 1].rstrip("\n").split(",")
    cells[header.index(column)] = value
    lines[line - 1] = ",".join(cells) + "\n"
    return lines


@pytest.mark.parametrize(
    ("column", "value", "named"),
    [
        ("time_s", "inf", "line 5, column time_s: 'inf' is not a finite number"),
        ("onset_s", "inf", "line 5, column onset_s: 'inf' is not a finite number"),
        ("block", "Training", "line 5, column block: 'Training' is not a block of this protocol"),
        # no analysed number read it, but the docs promise no value a session cannot write
        ("ignored_keys", "hello world",
         "line 5, column ignored_keys: 'hello world' is not the key presses a session records"),
        ("ignored_keys", "space@0.5", "'space@0.5' is not the key presses"),
    ],
)  # fmt: skip
def test_impossible_values_are_refused_with_file_and_line(yoshida, tmp_path, column, value, named):
    protocol, files = yoshida
    bad = copy_session(files[0], tmp_path, rows=lambda lines: _set_cell(lines, 5, column, value))
    with pytest.raises(DataError, match=re.escape(named)):
        load_sessions(protocol, [bad, *files[1:]])


def test_a_last_row_cut_inside_its_comment_is_refused(simulated, tmp_path):
    protocol = load_protocol("luidolt2020")
    files = csvs(simulated, "luidolt2020")

    def cut(lines):
        lines[-1] = lines[-1].rstrip("\n") + '"a comment, cut in the'
        return lines

    bad = copy_session(files[0], tmp_path, rows=cut)
    with pytest.raises(DataError, match=r"line 7: not readable as CSV .*a row cut short"):
        load_sessions(protocol, [bad, *files[1:]])


def test_a_file_of_a_format_that_has_counted_must_have_it(simulated, tmp_path):
    protocol = load_protocol("spencer1995")
    source = csvs(simulated, "spencer1995")[0]
    frame = pd.read_csv(source, keep_default_na=False, dtype=str).drop(columns="counted")
    frame.to_csv(tmp_path / source.name, index=False)
    shutil.copy(source.with_suffix(".json"), (tmp_path / source.name).with_suffix(".json"))
    with pytest.raises(
        DataError,
        match=re.escape(f"missing ['counted'] (its sidecar says data format {DATA_FORMAT}, whose"),
    ):
        load_sessions(protocol, [tmp_path / source.name])
    sidecar = json.loads(source.with_suffix(".json").read_text()) | {"data_format": "0.1"}
    del sidecar["row_sha256"]  # a file of the first data format, which had no row digests
    (tmp_path / source.name).with_suffix(".json").write_text(json.dumps(sidecar))
    assert load_sessions(protocol, [tmp_path / source.name]).trials["counted"].all()


def test_two_sessions_of_one_participant_are_named(yoshida, tmp_path):
    protocol, files = yoshida
    second = copy_session(
        files[0],
        tmp_path,
        name=files[0].name.replace("_s1_", "_s2_"),
        rows=lambda lines: (
            [lines[0]] + [line.replace(",sim01,1,", ",sim01,2,") for line in lines[1:]]
        ),
        sidecar={"session": 2},
    )
    with pytest.raises(DataError, match=r"participant sim01: 2 sessions in 2 files: .*\(session "
                       r"1\), .*_s2_.*\(session 2\); the analysis takes one session per"):  # fmt: skip
        load_sessions(protocol, [*files, second])


def _as_resaved(lines, old, new, *, times=None, digits=15, time=None):
    """A session's lines as a spreadsheet re-saves them under participant ``new`` (15
    significant digits: 1.0020008087158203 becomes 1.00200080871582, or ``digits``);
    ``times`` puts that text in every time column instead (an experiment that timed
    nothing), ``time`` rewrites each time's value."""
    header = lines[0].rstrip("\n").split(",")
    timed = [i for i, n in enumerate(header) if n == "onset_s" or n.endswith("time_s")]
    out = [lines[0]]
    for line in renamed(lines[1:], old, new):
        cells = line.rstrip("\n").split(",")
        cells = [f"{float(c):.{digits}g}" if re.fullmatch(r"-?\d+\.\d+", c) else c for c in cells]
        for i in timed:
            if times is not None:
                cells[i] = times
            elif time is not None and cells[i]:
                cells[i] = repr(time(float(cells[i])))
        out.append(",".join(cells) + "\n")
    return out


def test_one_persons_session_under_two_participant_ids_is_refused(yoshida, tmp_path):
    """A participant's PsychoPy file and its spreadsheet re-save (participant P10), imported
    in two runs into two folders, were analysed as two participants: N inflated, no word."""
    protocol, files = yoshida
    twin = copy_session(
        files[1],
        tmp_path,
        name=files[1].name.replace("sim02", "P10"),
        rows=lambda lines: _as_resaved(lines, "sim02", "P10"),
        sidecar={"participant": "P10"},
    )
    with pytest.raises(DataError) as refused:
        load_sessions(protocol, [*files, twin])
    (problem,) = refused.value.problems
    assert problem.startswith(f"{twin}: its trials are those of {files[1]}, cell for cell")
    assert "participant P10's session 1 and participant sim02's session 1" in problem
    assert problem.endswith("give one of the two files")
    # answers alike, but no time that tells two people apart: two participants
    (tmp_path / "timeless").mkdir()
    timeless = [
        copy_session(
            files[1],
            tmp_path / "timeless",
            name=files[1].name.replace("sim02", who),
            rows=lambda lines, who=who: _as_resaved(lines, "sim02", who, times="0.0"),
            sidecar={"participant": who},
        )
        for who in ("P10", "P11")
    ]
    dataset = load_sessions(protocol, [files[0], *timeless])
    assert set(dataset.trials["participant"]) == {"sim01", "P10", "P11"}


@pytest.mark.parametrize(
    ("how", "resave"),
    [
        ("10 significant digits", {"digits": 10}),
        ("times to the millisecond", {"time": lambda t: round(t, 3)}),
        ("times to the millisecond, sorted by time", {"time": lambda t: round(t, 3)}),
    ],
)
def test_a_resave_with_fewer_digits_is_the_same_person(yoshida, tmp_path, how, resave):
    """A re-save that keeps 10 significant digits (or rounds the times to the millisecond)
    was not the same trials to 12 digits: one person's file and its re-save were two
    participants."""
    protocol, files = yoshida

    def rows(lines):
        out = _as_resaved(lines, "sim02", "P10", **resave)
        if "sorted" in how:  # a spreadsheet's sort by another column keeps each row whole
            out[1:] = sorted(out[1:], key=lambda line: line.split(",")[::-1])
        return out

    twin = copy_session(
        files[1],
        tmp_path,
        name=files[1].name.replace("sim02", "P10"),
        rows=rows,
        sidecar={"participant": "P10", "trial_order": None},
    )
    with pytest.raises(DataError) as refused:
        load_sessions(protocol, [*files, twin])
    (problem,) = refused.value.problems
    assert problem.startswith(f"{twin}: its trials are those of {files[1]}, cell for cell")


def test_times_10_ms_apart_are_two_people(yoshida, tmp_path):
    """The same answers with every time 10 ms later are not one file re-saved: two
    participants, whom the analysis takes (the tolerance is the millisecond)."""
    protocol, files = yoshida
    other = copy_session(
        files[1],
        tmp_path,
        name=files[1].name.replace("sim02", "P10"),
        rows=lambda lines: _as_resaved(lines, "sim02", "P10", time=lambda t: t + 0.01),
        sidecar={"participant": "P10", "trial_order": None},
    )
    dataset = load_sessions(protocol, [*files, other])
    assert "P10" in set(dataset.trials["participant"])


def test_a_design_cell_given_twice_is_named_with_plain_values(yoshida, tmp_path):
    """A participant's two trials at one cell were named "at ('vos', np.int64(4))"."""
    protocol, files = yoshida

    def one_cell_twice(lines):
        header = lines[0].rstrip("\n").split(",")
        rows = [line.rstrip("\n").split(",") for line in lines]
        main = [r for r in rows[1:] if r[header.index("block")] == "main"]
        for name in ("method", "level", "level_index", "l_disk_cd_m2"):
            main[1][header.index(name)] = main[0][header.index(name)]
        return [",".join(r) + "\n" for r in rows]

    # as imported from PsychoPy: no trial_order recorded to name the row by
    twice = copy_session(files[0], tmp_path, rows=one_cell_twice, sidecar={"trial_order": None})
    text = twice.read_text().splitlines()
    header = text[0].split(",")
    first = next(line.split(",") for line in text[1:] if ",main," in line)
    cell = {"method": first[header.index("method")],
            "level_index": int(first[header.index("level_index")])}  # fmt: skip
    with pytest.raises(DataError) as refused:
        load_sessions(protocol, [twice, *files[1:]])
    assert f"participant sim01 has 2 trials at {cell}: unbalanced design" in (
        refused.value.problems
    )


# ------------------------------------------------------------------ the property test
STUDIES = ("yoshida2008", "spencer1995", "luidolt2020")
NAMED = re.compile(r"line \d+|trials? \d+")


@pytest.fixture(scope="module")
def baselines(simulated):
    """Three participants of each study and the tests of their untouched files."""
    chosen = {}
    for study in STUDIES:
        protocol = load_protocol(study)
        files = csvs(simulated, study)[:3]
        chosen[study] = (protocol, files, tables(protocol, files))
    return chosen


edits = st.lists(
    st.tuples(st.sampled_from(["shuffle", "duplicate", "truncate"]), st.randoms()),
    min_size=1,
    max_size=3,
)


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(study=st.sampled_from(STUDIES), which=st.integers(0, 2), operations=edits)
def test_shuffled_duplicated_or_truncated_rows_give_the_result_or_a_named_refusal(
    baselines, study, which, operations
):
    protocol, files, expected = baselines[study]
    text = files[which].read_text()
    for operation, rng in operations:
        lines = text.splitlines(keepends=True)
        header, body = lines[:1], lines[1:]
        if operation == "shuffle":  # a spreadsheet's sort: the header stays first
            rng.shuffle(body)
            text = "".join(header + body)
        elif operation == "duplicate" and body:
            row = rng.choice(body)
            body.insert(rng.randrange(len(body) + 1), row if row.endswith("\n") else row + "\n")
            text = "".join(header + body)
        elif text:  # a copy cut short: at any byte, the header's too
            text = text[: rng.randrange(len(text))]
    with tempfile.TemporaryDirectory() as folder:
        edited = Path(folder) / files[which].name
        edited.write_text(text)
        shutil.copy(files[which].with_suffix(".json"), edited.with_suffix(".json"))
        given_files = [edited if i == which else f for i, f in enumerate(files)]
        try:
            result = tables(protocol, given_files)
        except DataError as error:
            assert all(NAMED.search(p) or "empty file" in p for p in error.problems), error
            return
    for name, table in expected.items():  # untouched: the same analysis, to the last digit
        pd.testing.assert_frame_equal(result[name], table, check_exact=True)


@pytest.mark.parametrize(
    ("column", "value", "named"),
    [
        ("offset_s", "0.5", "line 5, column offset_s: 0.5 is before onset_s"),
        ("shown_ms", "100.0", "line 5, column shown_ms: 100.0 is not offset_s - onset_s"),
        ("offset_s", "", " without an offset_s: a session writes"),  # shown, no end
    ],
)
def test_a_presentation_that_ends_before_it_begins_or_lasts_another_time_is_refused(
    simulated, tmp_path, column, value, named
):
    protocol = load_protocol("spencer1995")
    files = csvs(simulated, "spencer1995")
    bad = copy_session(files[0], tmp_path, rows=lambda lines: _set_cell(lines, 5, column, value))
    with pytest.raises(DataError, match=re.escape(named)):
        load_sessions(protocol, [bad, *files[1:]])
