"""``glarelab check-display`` is run again after any change of driver, cable or display
settings, as docs/workflow.md asks: its own earlier result next to the calibration is
replaced (and kept as ``.previous.json``), a file glarelab did not write there is not."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import glarelab.frontend.check_display as check_display_module
from glarelab.cli import main

ROOT = Path(__file__).parents[2]


def _measured(protocol, **options) -> dict:
    """What a screen gave: the findings the command prints and writes (no window opened)."""
    return {
        "resolution_px": [1920, 1080],
        "refresh_hz_measured": 60.0,
        "frame_intervals_empty": {
            "median_ms": 16.7, "sd_ms": 0.1, "max_ms": 17.0, "late_fraction": 0.0
        },
        "bits_per_channel": 10,
        "framebuffer_levels": 1024,
        "framebuffer_levels_asked": 1024,
        "checks": [{"name": "bit-depth", "passed": True, "expected": 10, "actual": 10}],
    }  # fmt: skip


def test_check_display_runs_again_over_its_own_result(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(check_display_module, "check_display", _measured)
    readings = ROOT / "calibrations" / "example-readings.csv"
    calibration = tmp_path / "calibrations" / "my-display.json"
    calibration.parent.mkdir()
    assert main(["calibrate", "fit", str(readings), "--out", str(calibration)]) == 0
    check = ["check-display", "yoshida2008", "--calibration", str(calibration)]
    written = calibration.with_suffix(".display-check.json")
    assert main(check) == 0, capsys.readouterr().err
    first = written.read_text()
    assert main(check) == 0, capsys.readouterr().err  # after a driver change: again
    assert written.read_text() == first
    assert json.loads(written.with_suffix(".previous.json").read_text())["checks"]
    # a file of that name that glarelab did not write is still kept
    foreign = tmp_path / "calibrations" / "other.json"
    shutil.copy(calibration, foreign)
    foreign.with_suffix(".display-check.json").write_text("my notes\n")
    capsys.readouterr()
    assert main([*check[:3], str(foreign)]) == 2
    assert "glarelab did not write it there" in capsys.readouterr().err
    assert foreign.with_suffix(".display-check.json").read_text() == "my notes\n"
    assert main([*check[:3], str(foreign), "--force"]) == 0  # as the message offers
    assert json.loads(foreign.with_suffix(".display-check.json").read_text())["checks"]


@pytest.fixture(autouse=True)
def _no_window(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)  # nothing here may open one


def test_a_calibration_of_another_display_files_no_check_under_it(tmp_path, capsys, monkeypatch):
    """``check-display yoshida2008 --calibration`` of Spencer's 8-bit display filed its check
    next to that calibration, the display's own check pushed to ``.previous.json``."""
    readings = ROOT / "calibrations" / "example-readings-spencer1995.csv"
    calibration = tmp_path / "sp.json"
    argv = ["calibrate", "fit", str(readings), "--out", str(calibration), "--bit-depth", "8"]
    assert main(argv) == 0
    with monkeypatch.context() as patched:  # the Spencer display's own check
        patched.setattr(check_display_module, "check_display", _measured)
        assert main(["check-display", "spencer1995", "--calibration", str(calibration)]) == 0
    written = calibration.with_suffix(".display-check.json")
    own = written.read_text()
    capsys.readouterr()
    argv = ["check-display", "yoshida2008", "--calibration", str(calibration), "--windowed"]
    assert main([*argv, "--frames", "30"]) == 2
    err = capsys.readouterr().err
    assert "the calibration is for a 8-bit display, the protocol's display is 10-bit" in err
    assert written.read_text() == own
    assert not written.with_suffix(".previous.json").exists()
    assert main(["check-display", "yoshida2008", "--out", str(tmp_path / "c.json"),
                 "--accept-mismatch", "calibration"]) == 2  # fmt: skip
    assert "--accept-mismatch calibration without --calibration" in capsys.readouterr().err
