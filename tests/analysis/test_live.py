"""The analysis of a live session's frames: dropped frames and tracker loss per session."""

from __future__ import annotations

import json
import re
import shutil

import pandas as pd
import pytest

from glarelab.analysis.live import LIVE_HEADER, live_frames
from glarelab.analysis.report import write_report
from glarelab.cli import main
from glarelab.frontend.live import FRAME_COLUMNS
from glarelab.protocols import load_protocol
from tests.conftest import reseal

HEADER = "\t".join(("what", "frame", "interval_ms", *FRAME_COLUMNS[1:]))


def frame_row(frame: int, *, dropped: int = 0, gaze: int = 1, pupil: int = 1) -> str:
    values = (
        "trial 1 live", frame, "16.667", f"{frame / 60:.6f}", f"{frame / 60:.6f}", "10.00",
        "20.00", "5.0000", "0.5", "0.5", "8.000", dropped, gaze, pupil, 0, 0,
    )  # fmt: skip
    return "\t".join(map(str, values))


def as_on_a_screen(csv_path) -> None:
    """Edit a simulated session's sidecar to what a session on a screen writes (a live scene
    shown, its frames recorded), the simulated observer's answers kept."""
    sidecar_path = csv_path.with_suffix(".json")
    sidecar = json.loads(sidecar_path.read_text())
    sidecar["simulated"] = False
    sidecar["calibration"]["status"] = "not needed"
    sidecar["participant_info"].pop("simulated_observer_seed", None)
    for run in sidecar["runs"]:
        run["keyboard"] = "keyboard"
        run["frame_intervals"] = csv_path.stem + "_frames.tsv"
    sidecar_path.write_text(json.dumps(sidecar))


@pytest.fixture(scope="module")
def two_sessions(tmp_path_factory):
    data = tmp_path_factory.mktemp("live") / "data"
    assert (
        main(["run", "luidolt2020-live", "--simulate", "--participants", "2", "--out", str(data)])
        == 0
    )
    return data


def test_the_report_counts_dropped_frames_and_tracker_loss_per_session(tmp_path, two_sessions):
    data = tmp_path / "data"
    shutil.copytree(two_sessions, data)
    first, second = sorted(data.glob("*.csv"))
    as_on_a_screen(first)  # the first session showed the scene live; the second simulated
    # the first session: 200 frames, 3 dropped, 10 without gaze (a blink: no pupil either)
    rows = [
        frame_row(i, dropped=int(i in (5, 6, 7)), gaze=int(not 50 <= i < 60),
                  pupil=int(not 50 <= i < 60))
        for i in range(200)
    ]  # fmt: skip
    lines = [HEADER, "run 1 started 2026-01-01T00:00:00+00:00\t\t", "window opened\t1\t16.7"]
    first.with_name(first.stem + "_frames.tsv").write_text("\n".join([*lines, *rows]) + "\n")
    with pytest.raises(
        ValueError, match=r"line 2, column dropped_frames: 0, but its frame record"
    ):
        live_frames([first, second])  # the session counted the dropped frames in its CSV too
    written = first.read_text().splitlines()
    column = written[0].split(",").index("dropped_frames")
    cells = written[1].split(",")
    cells[column] = "3"
    first.write_text("\n".join([written[0], ",".join(cells), *written[2:]]) + "\n")
    reseal(first)  # as the session would have written it
    table = live_frames([first, second])  # the second session has no frame record
    assert table.to_dict("records") == [
        {
            "session": first.stem, "frames": 200, "dropped": 3, "dropped_pct": 1.5,
            "gaze_lost": 10, "gaze_lost_pct": 5.0, "pupil_lost": 10, "off_scene": 0,
            "render_ms_median": 8.0,
        }
    ]  # fmt: skip
    report = write_report(load_protocol("luidolt2020-live"), [first, second], tmp_path / "rep")
    assert pd.read_csv(report.parent / "live_frames.csv")["dropped"].tolist() == [3]
    text = report.read_text()
    assert "200 frames over 1 session: 3 dropped (1.5 %" in text
    assert "10 without a gaze from the tracker (5.0 %" in text


def test_a_live_session_without_its_frames_or_a_simulated_one_with_frames_is_refused(
    tmp_path, two_sessions
):
    data = tmp_path / "data"
    shutil.copytree(two_sessions, data)
    first, second = sorted(data.glob("*.csv"))
    protocol = load_protocol("luidolt2020-live")
    frames = first.with_name(first.stem + "_frames.tsv")
    rows = [frame_row(i) for i in range(5)]
    frames.write_text("\n".join([HEADER, *rows]) + "\n")  # given to a simulated session
    with pytest.raises(ValueError, match=r"_frames\.tsv: live frame rows, but the session showed "
                       "no live scene: it is a simulated observer's"):  # fmt: skip
        write_report(protocol, [first, second], tmp_path / "rep")
    as_on_a_screen(first)
    sidecar = json.loads(first.with_suffix(".json").read_text())
    sidecar["runs"][0]["frame_intervals"] = second.stem + "_frames.tsv"
    first.with_suffix(".json").write_text(json.dumps(sidecar))
    with pytest.raises(ValueError, match=r"its runs' frame_intervals name .*, but a live session"):
        write_report(protocol, [first, second], tmp_path / "rep")
    as_on_a_screen(first)
    for text, named in [
        (HEADER + "\n", "no live frame rows"),
        (f"{HEADER}\nrun 1 started 2026-01-01T00:00:00+00:00\t\t\nwindow opened\t1\t16.7\n",
         "no live frame rows"),
        (None, "missing; the session showed a live scene"),
    ]:  # fmt: skip
        if text is None:
            frames.unlink()
        else:
            frames.write_text(text)
        with pytest.raises(ValueError, match=re.escape(f"{frames.name}: {named}")):
            write_report(protocol, [first, second], tmp_path / "rep")
    assert not (tmp_path / "rep").exists()


def test_sessions_without_live_frames_add_nothing(tmp_path):
    (tmp_path / "a.csv").write_text("x\n")
    (tmp_path / "a_frames.tsv").write_text("what\tframe\tinterval_ms\nwindow opened\t1\t16.7\n")
    assert live_frames([tmp_path / "a.csv"]) is None


def _edited(rows: list[str], edit) -> str:
    lines = [HEADER, "run 1 started 2026-01-01T00:00:00+00:00\t\t", *edit(list(rows))]
    return "\n".join(lines) + "\n"


def _cut(rows):
    rows[-1] = rows[-1][: len(rows[-1]) // 2]
    return rows


def _field(rows, index, column, value):
    fields = rows[index].split("\t")
    fields[HEADER.split("\t").index(column)] = value
    rows[index] = "\t".join(fields)
    return rows


@pytest.mark.parametrize(
    ("edit", "named"),
    [
        (lambda r: r[:3] + r[4:], "line 6, column frame: frame 4 of trial 1 live where frame 3"),
        (lambda r: [*r[:4], r[3], *r[4:]], "line 7, column frame: frame 3 of trial 1 live"),
        (lambda r: r[::-1], "line 3, column frame: frame 9 of trial 1 live where frame 0"),
        (lambda r: r + r, "line 13, column frame: frame 0 of trial 1 live where frame 10"),
        (
            lambda r: r + [x.replace("trial 1", "trial 2") for x in r[:2]] + r[:1],
            "line 15: trial 1 live begins a second time in run 1",
        ),
        (lambda r: _field(r, 2, "dropped", "2"), "line 5, column dropped: '2' is not 0 or 1"),
        (
            lambda r: _field(r, 2, "valid_gaze", "yes"),
            "line 5, column valid_gaze: 'yes' is not 0 or 1",
        ),
        (lambda r: _field(r, 2, "render_ms", "nan"), "line 5, column render_ms: 'nan'; allowed"),
        (lambda r: _field(r, 2, "render_ms", "-5"), "line 5, column render_ms: '-5'; allowed"),
        (lambda r: _field(r, 2, "pupil_mm", "-3"), "line 5, column pupil_mm: '-3'; allowed"),
        (
            lambda r: _field(r, 2, "pupil_mm", "50"),
            "line 5, column pupil_mm: '50'; allowed: a number in [2, 8] mm",
        ),
        (
            lambda r: _field(r, 2, "frame", "1.5"),
            "line 5, column frame: '1.5' is not a whole number",
        ),
        (lambda r: _field(r, 2, "what", "trial 1x live"), "line 5, column what: 'trial 1x live'"),
        (lambda r: [*r[:2], r[2] + "\t9", *r[3:]], "line 5: 17 fields, the header has 16"),
    ],
)
def test_a_frame_record_the_session_could_not_have_written_is_refused(tmp_path, edit, named):
    rows = [frame_row(i) for i in range(10)]
    (tmp_path / "a.csv").write_text("x\n")
    (tmp_path / "a_frames.tsv").write_text(_edited(rows, edit))
    with pytest.raises(ValueError, match=re.escape(f"a_frames.tsv, {named}")):
        live_frames([tmp_path / "a.csv"])


def test_a_cut_last_frame_row_or_a_foreign_header_is_refused(tmp_path):
    rows = [frame_row(i) for i in range(10)]
    (tmp_path / "a.csv").write_text("x\n")
    frames = tmp_path / "a_frames.tsv"
    frames.write_text(_edited(rows, _cut).rstrip("\n"))
    with pytest.raises(ValueError, match="line 12: the last line is cut"):
        live_frames([tmp_path / "a.csv"])
    frames.write_text(_edited(rows, lambda r: r).replace("\tdropped\t", "\tdrop\t"))
    with pytest.raises(ValueError, match="line 1: the header is not a live frame record's"):
        live_frames([tmp_path / "a.csv"])
    frames.write_text("")
    with pytest.raises(ValueError, match=r"a_frames\.tsv: empty"):
        live_frames([tmp_path / "a.csv"])
    frames.write_text(_edited(rows, lambda r: r).replace("\t", ","))  # a spreadsheet's save
    with pytest.raises(ValueError, match="line 3: a live frame row not separated by tabs"):
        live_frames([tmp_path / "a.csv"])
    frames.unlink()
    frames.mkdir()
    with pytest.raises(ValueError, match=r"a_frames\.tsv: not a file"):
        live_frames([tmp_path / "a.csv"])
    assert "\t".join(LIVE_HEADER) == HEADER  # the analysis reads what the front-end writes


@pytest.mark.parametrize(
    ("run_line", "named"),
    [
        ("run 1 started T; log time 0 = Unix time 200.000 s", "records its run 1 at 100.000 s"),
        ("run 2 started T; log time 0 = Unix time 100.000 s", "records 1 run(s)"),
        ("run 1 started T; log time 0 = Unix time 100.000 s; PILOT run", "is a pilot's but the"),
    ],
)
def test_a_frame_record_of_another_session_is_refused(tmp_path, run_line, named):
    # frame records swapped between sessions, or a pilot's put beside a participant's
    # session, were counted as the session's own
    rows = [frame_row(i) for i in range(3)]
    (tmp_path / "a.csv").write_text("x\n")
    (tmp_path / "a.json").write_text('{"runs": [{"clock_epoch_s": 100.0004}]}')
    frames = tmp_path / "a_frames.tsv"
    frames.write_text("\n".join([HEADER, run_line + "\t\t", *rows]) + "\n")
    with pytest.raises(ValueError, match=re.escape(named)):
        live_frames([tmp_path / "a.csv"])
    own = "run 1 started T; log time 0 = Unix time 100.000 s"
    frames.write_text("\n".join([HEADER, own + "\t\t", *rows]) + "\n")
    assert live_frames([tmp_path / "a.csv"])["frames"].tolist() == [3]


def test_a_session_file_with_a_name_near_the_longest_has_no_frame_record(tmp_path):
    """A 249-character CSV name: its ``STEM_frames.tsv`` would be longer than a file name can
    be, and looking for it ended the analysis in 'File name too long'."""
    long = tmp_path / ("x" * 245 + ".csv")
    long.write_text("study\n")
    assert live_frames([long]) is None
