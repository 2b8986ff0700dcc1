"""``glarelab run`` of a live scene: the options that make no sense together, refused in a line."""

from __future__ import annotations

from pathlib import Path

import pytest

from glarelab.cli import main
from glarelab.frontend.eyetracker import tracker_config
from glarelab.protocols import ProtocolError, load_protocol


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["luidolt2020", "--participant", "P1", "--eyetracker", "mouse"],
            "--eyetracker mouse: the luidolt2020 protocol shows no live scene",
        ),
        (
            ["luidolt2020-live", "--participant", "P1"],
            "shows its scene live for the gaze: give --eyetracker mouse",
        ),
        (
            ["luidolt2020-live", "--simulate", "--eyetracker", "mouse"],
            "--eyetracker with --simulate",
        ),
        (
            ["luidolt2020", "--participant", "P1", "--pupil-calibration-s", "0.5"],
            "--pupil-calibration-s 0.5: the pupil calibration runs with an eye tracker",
        ),
        (
            ["luidolt2020-live", "--participant", "P1", "--eyetracker", "eyelinx"],
            "--eyetracker 'eyelinx': must be one of eyelink, gazepoint, mouse",
        ),
    ],
)
def test_options_that_make_no_sense_together_are_refused(tmp_path, capsys, args, message):
    assert main(["run", *args, "--out", str(tmp_path / "data")]) == 2
    stderr = capsys.readouterr().err
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], stderr
    assert not (tmp_path / "data").exists()


def test_a_tracker_yaml_names_one_ioHub_eye_tracker(tmp_path):
    good = tmp_path / "pupil.yaml"
    good.write_text(
        "eyetracker.hw.pupil_labs.pupil_core.EyeTracker:\n"
        "  runtime_settings:\n    gaze_confidence_threshold: 0.6\n"
    )
    device, settings = tracker_config(str(good))
    assert device == "eyetracker.hw.pupil_labs.pupil_core.EyeTracker"
    assert settings == {"runtime_settings": {"gaze_confidence_threshold": 0.6}}
    listed = tmp_path / "listed.yaml"
    listed.write_text("monitor_devices:\n  - eyetracker.hw.tobii.EyeTracker:\n      name: t\n")
    assert tracker_config(str(listed))[0] == "eyetracker.hw.tobii.EyeTracker"
    none = tmp_path / "none.yaml"
    none.write_text("Keyboard: {}\n")
    with pytest.raises(ValueError, match="exactly one ioHub eye tracker"):
        tracker_config(str(none))


def test_a_live_scene_renders_what_a_live_frame_can(tmp_path):
    text = Path(load_protocol("luidolt2020-live").source).read_text()
    bad = text.replace(
        'effects = ["adaptation", "glare", "acuity", "scotopic"]', 'effects = ["glare", "acuity"]'
    )
    bad = bad.replace('sequence = "still"', 'sequence = "gaze"')
    path = tmp_path / "bad.toml"
    path.write_text(bad)
    with pytest.raises(ProtocolError) as error:
        load_protocol(path)
    problems = str(error.value)
    assert "scene.sequence = 'gaze'" in problems
    assert "missing adaptation" in problems
