"""Under Xvfb with real X events: the mouse (ioHub's MouseGaze) moves, the frame log's gaze follows.

The live loop runs in its own process on a private X screen; ``xdotool`` moves the pointer
through the X server, and the test reads what the loop recorded per frame (``_frames.tsv``),
never how fast it ran.
"""

from __future__ import annotations

import csv
import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from glarelab.display.calibration import synthetic_calibration
from glarelab.glare import VosGlare, render_night
from glarelab.glare.models.eye import regime
from glarelab.glare.night.pipeline import eye_state_model
from glarelab.glare.rendering.display import display_codes
from glarelab.stimuli.night import night_street
from tests.experiments.xscreen import XScreen, _need

SCRIPT = """
import sys, numpy as np
from pathlib import Path
from glarelab.frontend.live import run_live
from glarelab.stimuli.night import night_street
scene = night_street((160, 100), pixel_deg=0.1, rng=np.random.default_rng(3))["img"]
run_live(scene, pixel_deg=0.1, frames_path=Path(sys.argv[1]), duration_s=60.0)
"""


def rows(path):
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle, delimiter="\t"))


def wait_for_gaze(screen, path, x, y, timeout=30.0):
    """The first recorded row whose gaze is (x, y), waiting for it."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        for row in rows(path)[:-1]:  # the last line may be half written
            if (float(row["gaze_x_px"]), float(row["gaze_y_px"])) == (x, y):
                return row
        assert screen.process.poll() is None, screen.stderr[-3000:]
        time.sleep(0.05)
    raise AssertionError(f"the gaze never reached {(x, y)}: last {rows(path)[-2:]}")


def wait_for_row(screen, path, test, timeout=30.0):
    """The first recorded row for which ``test`` holds, waiting for it."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        for row in rows(path)[:-1]:
            if test(row):
                return row
        assert screen.process.poll() is None, screen.stderr[-3000:]
        time.sleep(0.05)
    raise AssertionError(f"no such row: last {rows(path)[-2:]}")


def wait_for_adapted(screen, path, timeout=30.0):
    """The last row once the adaptation is within 0.01 % of its target."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        row = rows(path)[-2]
        if abs(float(row["adaptation_cd_m2"]) / float(row["target_cd_m2"]) - 1) < 1e-4:
            return row
        time.sleep(0.05)
    raise AssertionError(f"the adaptation never settled: {rows(path)[-2]}")


@pytest.fixture
def screen(tmp_path):
    screen = XScreen(tmp_path)
    yield screen
    if screen.process is not None and screen.process.poll() is None:
        # Ctrl-C lets the loop stop its ioHub server, which a kill would leave running
        screen.process.send_signal(signal.SIGINT)
        try:
            screen.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            pass
    screen.close()


def test_the_frame_log_gaze_follows_the_mouse_and_escape_ends_as_aborted(screen, tmp_path):
    frames = tmp_path / "p01_frames.tsv"
    screen.stderr_file = screen.stderr_path.open("w")
    screen.process = subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(frames)], env=screen.env,
        stdout=subprocess.DEVNULL, stderr=screen.stderr_file,
    )  # fmt: skip
    sidecar = screen.wait_for_file("p01_live.json", tmp_path)
    left, top = json.loads(sidecar.read_text())["window_pos_px"]
    screen.wait_for_file(frames.name, tmp_path)
    targets = [(20.0, 30.0), (159.0, 99.0), (0.0, 0.0)]  # inside, the two far corners
    seen = []
    for x, y in targets:
        before = len(rows(frames)) if frames.exists() else 0
        subprocess.run(
            [_need("xdotool"), "mousemove", str(int(left + x)), str(int(top + y))],
            env=screen.env, check=True,
        )  # fmt: skip
        row = wait_for_gaze(screen, frames, x, y)
        assert int(row["frame"]) >= before - 1  # a frame after the move, not an old one
        assert row["valid_gaze"] == "1" and float(row["pupil_mm"]) == 5.0  # MouseGaze: 5 mm
        seen.append(float(row["target_cd_m2"]))
    assert len(set(seen)) == 3  # each gaze adapted to its own window of the street
    # a blink (MouseGaze: both buttons held) is recorded as a lost gaze, the last one held
    xdotool = [_need("xdotool")]
    start = len(rows(frames))
    subprocess.run([*xdotool, "mousedown", "1", "mousedown", "3"], env=screen.env, check=True)
    blink = wait_for_row(
        screen, frames, lambda r: int(r["frame"]) >= start and r["valid_gaze"] == "0"
    )
    subprocess.run([*xdotool, "mouseup", "1", "mouseup", "3"], env=screen.env, check=True)
    assert (blink["gaze_x_px"], blink["gaze_y_px"], blink["pupil_mm"]) == (
        "0.00",
        "0.00",
        "5.0000",
    )
    after = wait_for_row(
        screen, frames, lambda r: int(r["frame"]) > int(blink["frame"]) and r["valid_gaze"] == "1"
    )
    # a second blink, counted apart from the first
    subprocess.run([*xdotool, "mousedown", "1", "mousedown", "3"], env=screen.env, check=True)
    second = wait_for_row(
        screen, frames, lambda r: int(r["frame"]) > int(after["frame"]) and r["valid_gaze"] == "0"
    )
    subprocess.run([*xdotool, "mouseup", "1", "mouseup", "3"], env=screen.env, check=True)
    wait_for_row(
        screen, frames, lambda r: int(r["frame"]) > int(second["frame"]) and r["valid_gaze"] == "1"
    )
    # the screen, read back from the X server once the eye has adapted to the last gaze,
    # shows render_night of that gaze, pupil and adaptation (8-bit codes, ±1 for the little
    # adaptation left between the row read and the screen read)
    row = wait_for_adapted(screen, frames)
    shown = screen.codes((left, top, 160, 100))
    scene = night_street((160, 100), pixel_deg=0.1, rng=np.random.default_rng(3))["img"]
    eye = eye_state_model(  # the frame's pupil and the regime of its L_i
        VosGlare(), pupil_mm=5.0, regime=regime(float(row["adaptation_cd_m2"]))
    )
    offline = render_night(
        scene, pixel_deg=0.1, effects=("adaptation", "glare"), glare_model=eye,
        pupil_from_adaptation=False, gaze_px=(0.0, 0.0), frame_time_s=0.0,
        initial_adaptation_cd_m2=float(row["adaptation_cd_m2"]), tolerance_codes=0.0,
    )  # fmt: skip
    lut = synthetic_calibration(max_cd_m2=100.0, black_cd_m2=0.1, bit_depth=8).lut
    expected = np.rint(display_codes(offline.frames, lut))
    assert np.abs(shown - expected).max() <= 1
    # and not the adaptation of the first gaze: the screen tells the two apart
    other = render_night(
        scene, pixel_deg=0.1, effects=("adaptation", "glare"), glare_model=eye,
        pupil_from_adaptation=False, gaze_px=(30.0, 20.0), tolerance_codes=0.0,
    )  # fmt: skip
    assert np.abs(shown - np.rint(display_codes(other.frames, lut))).max() > 5
    screen.focus_window()
    screen.key("Escape")
    assert screen.wait(timeout=60) == 0, screen.stderr[-3000:]
    summary = json.loads(sidecar.read_text())["summary"]
    recorded = rows(frames)
    assert summary["aborted"] is True and summary["frames"] == len(recorded)
    assert summary["lost"] == sum(r["valid_gaze"] == "0" for r in recorded) > 1  # the blink
    # two blinks of many samples each, each counted once (they were 0, the start-up frame 1)
    assert summary["blinks"] == 2
    assert [int(r["frame"]) for r in recorded] == list(range(len(recorded)))
