"""The PsychoPy front-end's session start (frontend/session.py), without a window."""

from __future__ import annotations

import pytest

from glarelab.frontend.records import SessionRecords
from glarelab.frontend.session import PsychoPyFrontend

pytest.importorskip("psychopy.logging")


def test_the_logs_first_lines_are_on_disk_before_the_eye_tracker_starts(tmp_path):
    """ioHub's store of the samples filled a small disk as the tracker started, and the
    session's log, whose first lines were still in PsychoPy's queue, stayed at 0 bytes."""
    log = tmp_path / "P01.log"
    frontend = object.__new__(PsychoPyFrontend)
    frontend.pilot = False
    frontend.facts = "1920 x 1080"
    frontend._refresh_intervals = []
    frontend.eyetracker = ("mouse", {})
    frontend.records = SessionRecords()
    frontend.clock_epoch_s = lambda: 0.0
    seen = []
    frontend._start_tracker = lambda run, frames_path: seen.append(log.read_text())
    frontend.keys = type("Keys", (), {"start": lambda self: None})()
    try:
        frontend.start(refresh_hz=60.0, pace=False, frames_path=None, log_path=log)
    finally:
        frontend.records.close()
    assert "run 1 started" in seen[0] and "session log: timing at 60 Hz" in seen[0]
