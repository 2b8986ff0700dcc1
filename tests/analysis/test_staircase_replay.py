"""The analysis replays each staircase session from the protocol's rules (Spencer et al. 1995,
§4; glarelab.protocols.staircase.Staircase, the session's own staircase) and refuses a record
the responses cannot have produced: reversal flags, disc intensities, step fractions, frames
and strengths that a spreadsheet edit changed are named with file, line, trial, column, the
recorded and the expected value. A Yoshida row whose adjustments cannot have moved its
settings is refused likewise."""

import csv
import io
import json
import re
from pathlib import Path

import pytest

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.analysis.staircase import check_session
from glarelab.protocols import load_protocol


def first(folder: Path, study: str) -> Path:
    return sorted(folder.glob(f"sim01_{study}_s*.csv"))[0]


def edited(source: Path, folder: Path, edit) -> Path:
    """A copy of a session (CSV and sidecar) whose rows ``edit`` changed (a list of dicts)."""
    text = source.read_text()
    reader = csv.DictReader(io.StringIO(text))
    rows = list(reader)
    edit(rows)
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=reader.fieldnames, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    target = folder / source.name
    target.write_text(out.getvalue())
    target.with_suffix(".json").write_text(source.with_suffix(".json").read_text())
    return target


def first_where(rows, **cells):
    return next(r for r in rows if all(r[k] == v for k, v in cells.items()))


def flip_reversal(value):
    def edit(rows):
        row = first_where(rows, reversal=value)
        row["reversal"] = "false" if value == "true" else "true"

    return edit


def flip_response(rows):  # a counted glare/disc answer turned into the other
    row = first_where(rows, response="glare")
    row["response"] = "disc"


def move_disc(rows):  # one grid step of 1/50 up, still on the grid, not where the answers put it
    row = next(r for r in rows if float(r["disc_fraction"]) < 0.9)
    row["disc_fraction"] = repr(round(float(row["disc_fraction"]) * 50 + 1) / 50)


def steps_erased(rows):
    for row in rows:
        row["step_fraction"] = "0.16"


def one_frame_more(rows):
    rows[0]["frames"] = str(int(rows[0]["frames"]) + 1)


def strength_round_off(rows):  # a spreadsheet's round-off, 1e-8 relative
    rows[0]["strength"] = repr(float(rows[0]["strength"]) * (1 + 1e-8))


@pytest.mark.parametrize(
    ("edit", "column"),
    [
        (flip_reversal("true"), "reversal"),
        (flip_reversal("false"), "reversal"),
        (flip_response, "(reversal|disc_fraction)"),
        (move_disc, "disc_fraction"),
        (steps_erased, "step_fraction"),
        (one_frame_more, "frames"),
        (strength_round_off, "strength"),
    ],
    ids=[
        "reversal-dropped",
        "reversal-invented",
        "response",
        "disc",
        "steps",
        "frames",
        "strength",
    ],
)
def test_an_edited_staircase_record_is_refused_naming_trial_and_column(
    simulated, tmp_path, edit, column
):
    protocol = load_protocol("spencer1995")
    path = edited(first(simulated, "spencer1995"), tmp_path, edit)
    with pytest.raises(DataError) as raised:
        load_sessions(protocol, [path])
    message = str(raised.value)
    assert re.search(
        rf"{re.escape(path.name)}, line \d+ \(trial \d+[^)]*\), column {column}: recorded ",
        message,
    ), message


def test_every_single_reversal_flag_flipped_is_refused_at_its_trial(simulated):
    """Each row's flag follows from the responses: flipping one (every 15th row tried) is
    named at that trial."""
    protocol = load_protocol("spencer1995")
    path = first(simulated, "spencer1995")
    rows = load_sessions(protocol, [path]).trials.to_dict("records")
    sidecar = json.loads(path.with_suffix(".json").read_text())
    assert check_session(path, rows, sidecar, protocol) == []
    for i in range(0, len(rows), 15):
        changed = [dict(r) for r in rows]
        changed[i]["reversal"] = not changed[i]["reversal"]
        problems = check_session(path, changed, sidecar, protocol)
        assert problems, f"trial {rows[i]['trial']}: flipped flag accepted"
        assert f"(trial {rows[i]['trial']}," in problems[0]
        assert "column reversal" in problems[0]


def test_yoshida_adjustments_that_cannot_move_the_settings_are_refused(simulated, tmp_path):
    protocol = load_protocol("yoshida2008")
    starts = protocol["stimulus"]["target_start_cd_m2"]

    def none_made(rows):
        row = next(
            r
            for r in rows
            if float(r["darker_cd_m2"]) != starts[0] and float(r["brighter_cd_m2"]) != starts[1]
        )
        row["adjustments"] = "1"

    path = edited(first(simulated, "yoshida2008"), tmp_path, none_made)
    with pytest.raises(DataError, match=r"\(trial \d+\), column adjustments: 1, but darker_cd_m2"):
        load_sessions(protocol, [path])


def test_a_completed_session_with_an_unfinished_staircase_is_refused(simulated):
    """A completed session ran every staircase to its end (trials.reversals reversals or the
    trial cap): a staircase's last row gone leaves it unfinished and is named, with what it
    reached and what ending needs; an aborted session may stop anywhere."""
    protocol = load_protocol("spencer1995")
    path = first(simulated, "spencer1995")
    rows = load_sessions(protocol, [path]).trials.to_dict("records")
    sidecar = json.loads(path.with_suffix(".json").read_text())
    assert sidecar["status"] == "completed"
    last = max(rows, key=lambda r: r["trial"])
    key = (last["context"], last["glare_level"])
    kept = [r for r in rows if r is not last]
    problems = check_session(path, kept, sidecar, protocol)
    assert len(problems) == 1, problems
    assert f"staircase context {key[0]}, glare level {key[1]} ended with " in problems[0]
    assert "status is completed" in problems[0]
    assert f"trials.reversals = {protocol['trials']['reversals']}" in problems[0]
    assert check_session(path, kept, {**sidecar, "status": "aborted"}, protocol) == []


def test_yoshida_rows_against_their_recorded_trial_order_are_refused(simulated, tmp_path):
    """The sidecar's trial_order is each trial's block:method:level, trial 1 first: two main
    trials relabelled with each other's reference are named; the first trials alone (an
    aborted session) follow it."""
    from glarelab.analysis.load import _trial_order
    from glarelab.analysis.matching import design as matching_design

    protocol = load_protocol("yoshida2008")
    source = first(simulated, "yoshida2008")
    swapped = ("method", "level", "level_index", "l_disk_cd_m2")

    def relabel(rows):
        main = [r for r in rows if r["block"] == "main"]
        a = main[0]
        b = next(r for r in main if (r["method"], r["level"]) != (a["method"], a["level"]))
        for key in swapped:
            a[key], b[key] = b[key], a[key]

    path = edited(source, tmp_path, relabel)
    with pytest.raises(DataError) as raised:
        load_sessions(protocol, [path])
    message = str(raised.value)
    assert re.search(
        rf"{re.escape(path.name)}, line \d+ \(trial \d+\): block:method:level is main:\S+, but "
        r"the sidecar's trial_order has main:\S+ at trial \d+",
        message,
    ), message
    rows = load_sessions(protocol, [source]).trials.to_dict("records")
    sidecar = json.loads(source.with_suffix(".json").read_text())
    design = matching_design(protocol)
    assert _trial_order(source, sidecar, rows, design) == []
    assert _trial_order(source, sidecar, rows[:5], design) == []
