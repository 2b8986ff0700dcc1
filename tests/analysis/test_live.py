"""The analysis of a live session's frames: dropped frames and tracker loss per session."""

from __future__ import annotations

import pandas as pd

from glarelab.analysis.live import live_frames
from glarelab.analysis.report import write_report
from glarelab.cli import main
from glarelab.frontend.live import FRAME_COLUMNS
from glarelab.protocols import load_protocol

HEADER = "\t".join(("what", "frame", "interval_ms", *FRAME_COLUMNS[1:]))


def frame_row(frame: int, *, dropped: int = 0, gaze: int = 1, pupil: int = 1) -> str:
    values = (
        "trial 1 live", frame, "16.667", f"{frame / 60:.6f}", f"{frame / 60:.6f}", "10.00",
        "20.00", "5.0000", "0.5", "0.5", "8.000", dropped, gaze, pupil, 0, 0,
    )  # fmt: skip
    return "\t".join(map(str, values))


def test_the_report_counts_dropped_frames_and_tracker_loss_per_session(tmp_path):
    data = tmp_path / "data"
    assert (
        main(["run", "luidolt2020-live", "--simulate", "--participants", "2", "--out", str(data)])
        == 0
    )
    first, second = sorted(data.glob("*.csv"))
    # the first session: 200 frames, 3 dropped, 10 without gaze (a blink: no pupil either)
    rows = [
        frame_row(i, dropped=int(i in (5, 6, 7)), gaze=int(not 50 <= i < 60),
                  pupil=int(not 50 <= i < 60))
        for i in range(200)
    ]  # fmt: skip
    lines = [HEADER, "run 1 started 2026-01-01T00:00:00+00:00\t\t", "window opened\t1\t16.7"]
    first.with_name(first.stem + "_frames.tsv").write_text("\n".join([*lines, *rows]) + "\n")
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


def test_sessions_without_live_frames_add_nothing(tmp_path):
    (tmp_path / "a.csv").write_text("x\n")
    (tmp_path / "a_frames.tsv").write_text("what\tframe\tinterval_ms\nwindow opened\t1\t16.7\n")
    assert live_frames([tmp_path / "a.csv"]) is None
