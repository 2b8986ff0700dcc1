"""A pilot run (``--pilot``, as PsychoPy's piloting mode) on a screen that is not the
protocol's, with an unverified calibration, driven with real keys: its mark, its files, a break
screen's onset and offset in the log, Escape during a flash; the refusals a real session makes
instead; and which protocol ``run`` takes."""

import json
import re
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from glarelab.display.calibration import fit_calibration

from .xscreen import SCREEN, XScreen, sidecar_of

ROOT = Path(__file__).parents[2]
WINDOW = (1280, 800)  # a pilot runs in a window, centred on the screen
CORNER = ((SCREEN[0] - WINDOW[0]) // 2, (SCREEN[1] - WINDOW[1]) // 2)
CENTRE = (SCREEN[0] // 2, SCREEN[1] // 2)


@pytest.fixture(scope="module")
def spencer(tmp_path_factory):
    """Spencer 1995 with a break after every trial and 1.5-1.8 s flashes, its stimulus set, and
    an unverified calibration of its display (8 bits, white 50 cd/m² as §1 and the protocol say:
    fitted readings, no verification)."""
    from glarelab.cli import main

    folder = tmp_path_factory.mktemp("spencer")
    text = (ROOT / "src" / "glarelab" / "protocols" / "spencer1995.toml").read_text()
    protocol = folder / "spencer_breaks.toml"
    text = re.sub(r"(?m)^break_every = \d+", "break_every = 1", text)
    # flashes long enough for a key sent by xdotool to land in them on a loaded machine
    text = re.sub(r"(?m)^presentation_ms = .*$", "presentation_ms = [1500.0, 1800.0]", text)
    protocol.write_text(text)
    assert main(["stimuli", "build", str(protocol), "--out", str(folder / "set")]) == 0
    readings = [(c, 0.1 + 49.9 * (c / 255) ** 2.2) for c in range(0, 255, 17)] + [(255, 50.0)]
    calibration = fit_calibration(readings, bit_depth=8, label="a CRT, 50 cd/m²")
    assert calibration.status == "unverified"
    return protocol, folder / "set", calibration.save(folder / "crt.json")


def _flash_visible(screen: XScreen) -> bool:
    strip = (CENTRE[0] - 200, CENTRE[1] - 6, CENTRE[0] + 200, CENTRE[1] + 6)
    return screen.screenshot(strip).max() > 40


def _wait_for_flash(screen: XScreen, timeout: float = 15.0) -> None:
    """Wait for the screen to go dark (the text before), then for the flash."""
    deadline = time.time() + timeout
    while _flash_visible(screen):
        assert time.time() < deadline, "the screen never went dark"
        time.sleep(0.002)
    while not _flash_visible(screen):
        assert time.time() < deadline, "no flash appeared"
        time.sleep(0.002)


@pytest.fixture
def screen(tmp_path):
    x = XScreen(tmp_path)
    yield x
    x.close()


def test_a_real_session_refuses_an_unverified_calibration(spencer, tmp_path, capsys):
    from glarelab.cli import main

    protocol, stimuli, calibration = spencer
    out = tmp_path / "data"
    code = main(
        ["run", str(protocol), "--participant", "P01", "--stimuli", str(stimuli),
         "--calibration", str(calibration), "--out", str(out)]
    )  # fmt: skip
    refused = capsys.readouterr().err
    assert code == 2
    # the command prints a warning as one line
    assert "warning (UserWarning): the display calibration has not been verified" in refused
    assert "the display calibration is unverified" in refused
    assert "--pilot" in refused and "--allow-uncalibrated" in refused
    assert not out.exists() or not [p for p in out.iterdir() if not p.name.startswith(".")]


def test_a_pilot_runs_marked_and_recorded_its_breaks_logged_and_escape_ends_a_flash(
    screen, spencer, tmp_path
):
    protocol, stimuli, calibration = spencer
    out = tmp_path / "data"
    shot = tmp_path / "dry_run.png"
    screen.run(
        "run", protocol, "--participant", "P01", "--stimuli", stimuli,
        "--calibration", calibration, "--pilot", "--out", out, "--screenshot", shot,
    )  # fmt: skip
    screen.wait_for_log(out, r"instructions screen onset")
    time.sleep(0.3)
    shown = screen.screenshot()
    Image.fromarray(shown).save(tmp_path / "pilot_instructions.png")
    # the PILOT mark, red, in the window's top-left corner (Spencer's images and text are grey)
    corner = shown[CORNER[1] : CORNER[1] + 40, CORNER[0] : CORNER[0] + 120].astype(int)
    red = (corner[..., 0] - corner[..., 1] > 60) & (corner[..., 0] - corner[..., 2] > 60)
    assert red.sum() > 50, red.sum()
    everywhere = shown.astype(int)
    assert ((everywhere[..., 0] - everywhere[..., 1]) > 60).sum() == red.sum()  # only there
    screen.key("space")
    _wait_for_flash(screen)
    time.sleep(0.1)
    screen.key("Left")  # during the first flash
    screen.wait_for_log(out, r"break screen onset at")
    time.sleep(0.3)
    Image.fromarray(screen.screenshot()).save(tmp_path / "break.png")
    screen.key("space")  # (the log is written when the session waits for keys: not now)
    _wait_for_flash(screen)
    screen.key("Escape")  # during the second flash
    assert screen.wait() == 3, screen.stderr[-2000:]

    # the dry run's own screenshot (the first flash, as drawn) carries the PILOT mark too
    drawn = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    mark = (drawn[..., 0] - drawn[..., 1] > 60) & (drawn[..., 0] - drawn[..., 2] > 60)
    rows, columns = np.nonzero(mark)
    assert mark.sum() > 50 and rows.max() < 40 and columns.max() < 120, mark.sum()
    files = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert len(files) == 4 and all(
        name.split(".")[0].removesuffix("_frames").endswith("_pilot") for name in files
    ), files
    (csv,) = out.glob("*.csv")
    assert len(csv.read_text().splitlines()) == 2  # the header and the first trial
    sidecar = sidecar_of(csv)
    assert sidecar["pilot"] is True and sidecar["runs"][0]["pilot"] is True
    assert sidecar["calibration"]["accepted_unverified_by"] == "--pilot"
    assert {"resolution"} <= set(sidecar["runs"][0]["accepted_mismatches"])
    assert sidecar["status"] == "aborted"
    assert sidecar["runs"][0]["ended_by"] == "escape during the presentation of trial 2"
    log = csv.with_suffix(".log").read_text()
    assert "PILOT run" in log
    assert "PILOT run" in (out / (csv.stem + "_frames.tsv")).read_text()
    onset, offset = (
        float(re.search(rf"break screen {what} at ([\d.]+)", log).group(1))
        for what in ("onset", "offset")
    )
    assert offset > onset
    aborted = re.search(
        r"trial 2 aborted: escape at ([\d.]+) during its presentation, ended at ([\d.]+) "
        r"after (\d+) of (\d+) frames \((\d+) shown after the escape\)",
        log,
    )
    assert aborted, log[-2000:]
    escape, ended, frames, planned, after = map(float, aborted.groups())
    # the flash ends at the first read of the keys after Escape (after every frame), then the
    # screen goes black: on a display, the frame being drawn is the last. Xvfb's flips are not
    # paced by a refresh, so how many come before the X server hands the key over is the
    # machine's load (2 in a loaded run), not the session's: what was recorded is asserted
    assert ended > escape and frames < planned and 0 <= after <= frames

    # a pilot resumes only as a pilot
    again = screen.glarelab(
        "run", protocol, "--participant", "P01", "--stimuli", stimuli,
        "--calibration", calibration, "--allow-uncalibrated", "--resume", "--out", out,
        "--accept-mismatch", "resolution", "refresh", "--allow-unmeasured-refresh",
    )  # fmt: skip
    assert again.returncode == 2 and "is a pilot session: resume it with --pilot" in again.stderr


def test_a_pilot_is_never_full_screen(capsys):
    from glarelab.cli import main

    assert main(["run", "luidolt2020", "--participant", "P01", "--pilot", "--fullscreen"]) == 2
    assert "--pilot runs in a window" in capsys.readouterr().err


def test_run_takes_study_or_protocol_and_refuses_two_studies(tmp_path, capsys):
    from glarelab.cli import main

    spencer = str(ROOT / "src" / "glarelab" / "protocols" / "spencer1995.toml")
    assert main(["run", "yoshida2008", "--protocol", spencer, "--participant", "P01"]) == 2
    both = capsys.readouterr().err
    assert "STUDY 'yoshida2008' and --protocol" in both and "'spencer1995'" in both
    assert main(["run", "--participant", "P01"]) == 2
    assert "give the study" in capsys.readouterr().err
    luidolt = str(ROOT / "src" / "glarelab" / "protocols" / "luidolt2020.toml")
    simulate = ["--simulate", "--participants", "1", "--out", str(tmp_path)]
    assert main(["run", "--protocol", luidolt, *simulate]) == 0
    (csv,) = tmp_path.glob("sim01_luidolt2020_s1_*.csv")
    assert json.loads(csv.with_suffix(".json").read_text())["study"] == "luidolt2020"
    assert main(["run", "luidolt2020", "--protocol", luidolt, "--session", "2", *simulate]) == 0
    assert len(list(tmp_path.glob("*.csv"))) == 2
