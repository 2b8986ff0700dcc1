"""``glarelab run luidolt2020-live --pilot --eyetracker mouse`` under Xvfb with real X events.

The session runs in its own process on a private X screen; ``xdotool`` presses its keys and
moves the pointer, which ioHub's MouseGaze takes as the gaze. The test reads what the session
recorded: its ``_frames.tsv`` (one row per frame, with the tracker's clock at the frame's start)
and ioHub's own hdf5 store of the tracker's samples (each with its time on that clock), never
how fast the machine ran.
"""

from __future__ import annotations

import csv
import json
import re
import shlex
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from glarelab.display.calibration import synthetic_calibration
from glarelab.frontend.eyetracker import PupilCalibration
from glarelab.glare import VosGlare, render_night
from glarelab.glare.models.eye import pupil_diameter_mm, regime
from glarelab.glare.night.pipeline import eye_state_model
from glarelab.glare.rendering.display import display_codes
from glarelab.protocols import load_protocol
from glarelab.protocols.common import glare_model
from glarelab.stimuli.night import night_scene
from tests.experiments.xscreen import XScreen, _need


def live_rows(path):
    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle, delimiter="\t"))
    return [r for r in rows[:-1] if r["what"].endswith(" live")]  # the last may be half written


def wait_for(screen, path, test, timeout=40.0):
    """The first live row for which ``test`` holds, waiting for it."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        for row in live_rows(path):
            if test(row):
                return row
        screen._alive()
        time.sleep(0.05)
    raise AssertionError(f"no such row: last {live_rows(path)[-2:]}")


def gaze(row):
    return float(row["gaze_x_px"]), float(row["gaze_y_px"])


@pytest.fixture
def screen(tmp_path):
    screen = XScreen(tmp_path)
    yield screen
    if screen.process is not None and screen.process.poll() is None:
        screen.process.terminate()
        try:
            screen.process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            screen.process.kill()
    screen.close()


def test_a_live_session_follows_the_mouse_survives_blinks_and_a_lost_tracker(screen, tmp_path):
    data = tmp_path / "data"
    screen.run(
        "run", "luidolt2020-live", "--pilot", "--eyetracker", "mouse", "--participant", "P1",
        "--out", data, "--pupil-calibration-s", "0.3",
    )  # fmt: skip
    # Luidolt's pupil range (§5.2.1 ii), MouseGaze's pupil simulated: Moon & Spencer's of the
    # display's white and black; the scene's 5 mm samples then map through it
    protocol = load_protocol("luidolt2020-live")
    display = protocol["display"]
    simulated = PupilCalibration(
        white_raw=float(pupil_diameter_mm(display["max_cd_m2"])),
        black_raw=float(pupil_diameter_mm(display["black_cd_m2"])),
    )
    mapped = f"{simulated.to_mm(5.0):.4f}"
    assert mapped != "5.0000"
    screen.wait_for_log(data, r"instructions screen onset")
    screen.focus_window()
    screen.key("space")
    found = screen.wait_for_log(
        data, r"trial 1 live: scene (\d+) x (\d+) px at window pixels (\d+), (\d+)"
    )
    width, height, left, top = (int(v) for v in found.groups())
    what = "trial 1 live"
    window = screen.wait_for_window("PsychoPy")
    shell = subprocess.run(
        [_need("xdotool"), "getwindowgeometry", "--shell", window],
        env=screen.env, capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    geometry = dict(line.split("=") for line in shell.split())
    win_x, win_y = int(geometry["X"]), int(geometry["Y"])
    win_w, win_h = int(geometry["WIDTH"]), int(geometry["HEIGHT"])
    frames = screen.wait_for_file("*_frames.tsv", data)
    wait_for(screen, frames, lambda r: True)
    # three moves: inside the scene and to its two far corners (window pixels)
    targets = [(left + 20.0, top + 30.0), (left + width - 1.0, top + height - 1.0)]
    targets.append((float(left), float(top)))
    moves = []
    for x, y in targets:
        subprocess.run(
            [_need("xdotool"), "mousemove", "--sync", str(int(win_x + x)), str(int(win_y + y))],
            env=screen.env, check=True,
        )  # fmt: skip
        row = wait_for(screen, frames, lambda r, x=x, y=y: gaze(r) == (x, y))
        assert row["valid_gaze"] == "1" and row["pupil_mm"] == mapped  # MouseGaze's 5 mm
        moves.append((x, y, row))
    # a blink (MouseGaze: both buttons held): the gaze lost, the last gaze and pupil held
    xdotool = [_need("xdotool")]
    held = int(moves[-1][2]["frame"])
    subprocess.run([*xdotool, "mousedown", "1", "mousedown", "3"], env=screen.env, check=True)
    blink = wait_for(screen, frames, lambda r: int(r["frame"]) > held and r["valid_gaze"] == "0")
    subprocess.run([*xdotool, "mouseup", "1", "mouseup", "3"], env=screen.env, check=True)
    assert gaze(blink) == (float(left), float(top)) and blink["pupil_mm"] == mapped
    back = wait_for(
        screen, frames, lambda r: int(r["frame"]) > int(blink["frame"]) and r["valid_gaze"] == "1"
    )
    # the screen, read back from the X server once the eye has adapted to the corner, shows
    # render_night of that gaze, pupil and adaptation (8-bit codes, ±1 for the little
    # adaptation left between the row read and the screen read)
    row = wait_for(
        screen, frames,
        lambda r: int(r["frame"]) > int(back["frame"])
        and abs(float(r["adaptation_cd_m2"]) / float(r["target_cd_m2"]) - 1) < 1e-4,
    )  # fmt: skip
    shown = screen.codes((win_x + left, win_y + top, width, height))
    scene = protocol["scene"]
    street = night_scene(protocol)
    assert glare_model(scene["glare_model"], scene["glare_parameters"]) == VosGlare()
    settings = dict(
        pixel_deg=street["pixel_deg"], effects=("adaptation", "glare", "acuity", "scotopic"),
        glare_model=eye_state_model(  # the frame's pupil and the regime of its L_i
            VosGlare(), pupil_mm=float(mapped), regime=regime(float(row["adaptation_cd_m2"]))
        ),
        pupil_from_adaptation=False,
        display_max_cd_m2=display["max_cd_m2"],
        adapted_display_cd_m2=scene["adapted_display_cd_m2"], tolerance_codes=0.0,
    )  # fmt: skip
    offline = render_night(
        street["img"], gaze_px=(0.0, 0.0), frame_time_s=0.0,
        initial_adaptation_cd_m2=float(row["adaptation_cd_m2"]), **settings,
    )  # fmt: skip
    lut = synthetic_calibration(
        max_cd_m2=display["max_cd_m2"], black_cd_m2=display["black_cd_m2"], bit_depth=8
    ).lut
    assert np.abs(shown - np.rint(display_codes(offline.frames, lut))).max() <= 1
    # and not the adaptation of a gaze at a lamp: the screen tells the two apart
    other = render_night(street["img"], gaze_px=street["lamps_px"][1], **settings)
    assert np.abs(shown - np.rint(display_codes(other.frames, lut))).max() > 5
    # a lost tracker: ioHub's server ends; the scene goes on, the last gaze held, counted
    import psutil

    from glarelab.frontend.iohub_guard import SERVER_SCRIPT  # the server, not its guard

    session = psutil.Process(screen.process.pid)
    server = next(
        p for p in session.children(recursive=True) if SERVER_SCRIPT in " ".join(p.cmdline())
    )
    last = int(live_rows(frames)[-1]["frame"])
    server.kill()
    lost = wait_for(screen, frames, lambda r: int(r["frame"]) > last + 8)
    assert lost["valid_gaze"] == "0" and gaze(lost) == (float(left), float(top))
    screen.focus_window()
    screen.key("Escape")
    assert screen.wait(timeout=60) == 3, screen.stderr[-3000:]  # aborted, as any Escape
    sidecar = json.loads(next(data.glob("*.json")).read_text())
    assert sidecar["status"] == "aborted"
    # the calibration recorded with the run: the raw means, the mapping, how it was made
    recorded_calibration = sidecar["runs"][-1]["pupil_calibration"]
    for name in ("white_raw", "black_raw"):
        assert recorded_calibration[name] == pytest.approx(getattr(simulated, name), rel=1e-9)
    assert recorded_calibration["range_mm"] == [2.0, 8.0]
    assert (
        recorded_calibration["screen_s"] == 0.3 and min(recorded_calibration["valid_samples"]) > 0
    )
    slope, offset = recorded_calibration["slope_mm_per_unit"], recorded_calibration["offset_mm"]
    assert f"{offset + slope * 5.0:.4f}" == mapped
    assert "Moon & Spencer" in recorded_calibration["simulated"]
    log = next(data.glob("*_pilot.log")).read_text()  # not ioHub's _iohub.log
    assert re.search(r"pupil calibration: white 2\.299, black 5\.26 mm \(\d+, \d+ samples\)", log)
    counts = re.search(
        r"trial 1 live: (\d+) frames, (\d+) dropped.*?(\d+) lost samples, (\d+) blinks, "
        r"(\d+) off the scene, (\d+) disconnects",
        log,
    )
    with frames.open(newline="") as handle:  # complete now: its last row too
        recorded = [r for r in csv.DictReader(handle, delimiter="\t") if r["what"] == what]
    assert counts is not None, log[-2000:]
    n, dropped, lost_n, blinks, _, disconnects = (int(v) for v in counts.groups())
    assert n == len(recorded) and dropped == sum(r["dropped"] == "1" for r in recorded)
    assert lost_n == sum(r["valid_gaze"] == "0" for r in recorded) and blinks >= 1
    assert disconnects > 0
    # the bank was made before the first frame: no frame froze to make an entry (the gaze
    # visited the scene's corners and its inside)
    prepared = re.search(r"trial 1 live: (\d+) bank entries prepared in", log)
    assert prepared is not None and int(prepared.group(1)) > 0, log[-2000:]
    assert {r["new_bank_entries"] for r in recorded} == {"0"}
    # the gaze followed each move within one frame of the tracker's sample: the first frame
    # whose recorded gaze is the new place is at most one frame after the first frame that
    # began after the tracker's first sample there (ioHub's clock, in its hdf5 store)
    import tables

    with tables.open_file(next(data.glob("*_iohub.hdf5"))) as store:
        samples = store.get_node(
            "/data_collection/events/eyetracker/MonocularEyeSampleEvent"
        ).read()
    starts = np.array([float(r["tracker_time_s"]) for r in recorded])
    for x, y, _ in moves:
        # ioHub's gaze: pixels from the window's centre, y up
        at = (samples["gaze_x"] == x - win_w / 2) & (samples["gaze_y"] == win_h / 2 - y)
        first_sample = samples["time"][at & (samples["status"] == 0)].min()
        began_after = int(np.argmax(starts > first_sample))
        first_new = next(int(r["frame"]) for r in recorded if gaze(r) == (x, y))
        assert first_new <= began_after + 1, (x, y, first_new, began_after)


def test_a_killed_live_session_leaves_no_iohub_server_holding_its_output(screen, tmp_path):
    """SIGKILL of a live session once ioHub's server is up: a caller capturing the session's
    output gets its end (the server writes to the session's _iohub.log, not to the caller's
    pipe), and the server ends (PsychoPy's own watch of the process that launched it shuts its
    devices down but leaves it serving its port; glarelab's guard stops it)."""
    from glarelab.frontend.iohub_guard import STOP_GRACE_S, servers_of

    data, pid_file, servers_file = tmp_path / "data", tmp_path / "pid", tmp_path / "servers"
    command = [
        sys.executable, "-m", "glarelab", "run", "luidolt2020-live", "--pilot", "--eyetracker",
        "mouse", "--participant", "P1", "--out", str(data), "--pupil-calibration-s", "30",
    ]  # fmt: skip
    script = (  # the session in the background, killed once ioHub's server has made its store
        f"{shlex.join(command)} & pid=$!; echo $pid > {pid_file}; for i in $(seq 1800); do "
        f"ls {data}/*_iohub.hdf5 >/dev/null 2>&1 && break; sleep 0.1; done; sleep 1; "
        f"pgrep -f 'start_iohub_process.py .* '$pid'$' > {servers_file}; kill -KILL $pid; wait $pid"
    )
    started = time.time() - 1.0
    try:
        done = subprocess.run(
            ["bash", "-c", script], env=screen.env, capture_output=True, text=True, timeout=240
        )  # waits for the end of the output: every process holding the pipe gone
        pid = int(pid_file.read_text())
        deadline = time.time() + STOP_GRACE_S + 10.0
        while servers_of(pid, since=started) and time.time() < deadline:
            time.sleep(0.1)
        left = servers_of(pid, since=started)
        assert not left, [server.cmdline() for server in left]
    finally:  # not to leave a server behind when the test fails
        if pid_file.exists():
            for server in servers_of(int(pid_file.read_text()), since=started):
                server.kill()
    assert done.returncode == 128 + signal.SIGKILL, done.stderr[-3000:]
    assert servers_file.read_text().split()  # killed with ioHub's server up
    assert next(data.glob("*_iohub.log")).is_file()  # where the server wrote


def _during_the_pupil_calibration(screen, data):
    """A live session started, now showing Luidolt's pupil calibration (ioHub recording)."""
    screen.run(
        "run", "luidolt2020-live", "--pilot", "--eyetracker", "mouse", "--participant", "P1",
        "--out", data, "--pupil-calibration-s", "30",
    )  # fmt: skip
    screen.wait_for_log(data, r"pupil calibration: a white screen")
    time.sleep(1.0)


def test_a_signal_during_the_pupil_calibration_keeps_the_session_as_aborted(screen, tmp_path):
    """SIGTERM while the pupil range was measured removed every file of the session, ioHub's
    store of the samples recorded with them: they are kept, the sidecar says aborted."""
    data = tmp_path / "data"
    _during_the_pupil_calibration(screen, data)
    screen.signal(signal.SIGTERM)
    assert screen.wait(timeout=60) == 3, screen.stderr[-3000:]
    names = {p.name.split("_pilot")[-1] for p in data.iterdir() if not p.name.startswith(".")}
    assert {".csv", ".json", ".log", "_frames.tsv", "_iohub.log"} <= names, names
    assert any(p.name.endswith(".hdf5") for p in data.iterdir())
    sidecar = json.loads(next(data.glob("*.json")).read_text())
    assert sidecar["status"] == "aborted" and sidecar["runs"][-1]["ended_by"] == "SIGTERM"


def test_escape_during_the_pupil_calibration_ends_the_session(screen, tmp_path):
    """Escape while the pupil range was measured was lost: the calibration ran on and the
    instructions waited; it ends the session as aborted, as on every screen."""
    data = tmp_path / "data"
    _during_the_pupil_calibration(screen, data)
    screen.focus_window()
    screen.key("Escape")
    assert screen.wait(timeout=20) == 3, screen.stderr[-3000:]
    # ioHub's words on its server's end go to its log, not the session's terminal
    assert "ioHub Server" not in screen.stdout + screen.stderr, screen.stdout
    assert "ioHub Server Process Completed" in next(data.glob("*_iohub.log")).read_text()
    sidecar = json.loads(next(data.glob("*.json")).read_text())
    assert sidecar["status"] == "aborted"
    assert sidecar["runs"][-1]["ended_by"] == "escape during the pupil calibration"
    assert "pupil calibration aborted: escape at" in next(data.glob("*_pilot.log")).read_text()


def test_a_screenshot_of_a_live_session_is_its_scene(screen, tmp_path):
    """--screenshot saved the first comment box of a live session, its scene black, not the
    first trial's screen: it is the scene's first frame, saved while the scene is viewed."""
    from PIL import Image

    data, shot = tmp_path / "data", tmp_path / "shot.png"
    screen.run(
        "run", "luidolt2020-live", "--pilot", "--eyetracker", "mouse", "--participant", "P1",
        "--out", data, "--pupil-calibration-s", "0.3", "--screenshot", shot,
    )  # fmt: skip
    screen.wait_for_log(data, r"instructions screen onset")
    screen.focus_window()
    screen.key("space")
    found = screen.wait_for_log(
        data, r"trial 1 live: scene (\d+) x (\d+) px at window pixels (\d+), (\d+)"
    )
    width, height, left, top = (int(v) for v in found.groups())
    frames = screen.wait_for_file("*_frames.tsv", data)
    wait_for(screen, frames, lambda r: True)
    assert shot.is_file()  # before any question
    image = np.asarray(Image.open(shot).convert("L"), dtype=float)
    scene = image[top : top + height, left : left + width]
    assert scene.max() > 100 and scene.std() > 5, (scene.max(), scene.std())
    screen.key("Escape")
    assert screen.wait(timeout=60) == 3, screen.stderr[-3000:]


def test_a_signal_during_the_live_scene_logs_its_frames_so_far(screen, tmp_path):
    """SIGTERM while the scene was viewed was recorded as the end, but the log had no line of
    the scene's frames and tracker faults, which a scene that ends otherwise has."""
    data = tmp_path / "data"
    screen.run(
        "run", "luidolt2020-live", "--pilot", "--eyetracker", "mouse", "--participant", "P1",
        "--out", data, "--pupil-calibration-s", "0.3",
    )  # fmt: skip
    screen.wait_for_log(data, r"instructions screen onset")
    screen.focus_window()
    screen.key("space")
    screen.wait_for_log(data, r"trial 1 live: scene")  # its bank made: 29 s on a slow machine
    frames = screen.wait_for_file("*_frames.tsv", data)
    wait_for(screen, frames, lambda r: int(r["frame"]) > 5)
    screen.signal(signal.SIGTERM)
    assert screen.wait(timeout=60) == 3, screen.stderr[-3000:]
    log = next(data.glob("*_pilot.log")).read_text()
    found = re.search(r"trial 1 live: (\d+) frames \(cut short\), \d+ dropped.*disconnects", log)
    assert found and int(found.group(1)) > 5, log[-2000:]
    sidecar = json.loads(next(data.glob("*.json")).read_text())
    assert sidecar["status"] == "aborted" and sidecar["runs"][-1]["ended_by"] == "SIGTERM"
