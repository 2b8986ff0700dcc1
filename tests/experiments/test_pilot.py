"""A pilot run (``--pilot``, as PsychoPy's piloting mode) on a screen that is not the
protocol's, with an unverified calibration; the refusals a real session makes instead; and
which protocol ``run`` takes."""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from stimuli.calibration import fit_calibration

from .xscreen import SCREEN, XScreen, sidecar_of

ROOT = Path(__file__).parents[2]
WINDOW = (1280, 800)  # a pilot runs in a window, centred on the screen
CORNER = ((SCREEN[0] - WINDOW[0]) // 2, (SCREEN[1] - WINDOW[1]) // 2)


def glarelab(*args):
    return subprocess.run(
        [sys.executable, "-m", "glarelab", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


@pytest.fixture(scope="module")
def spencer(tmp_path_factory):
    """Spencer's stimulus set, and an unverified calibration of its display (8 bits, white
    100 cd/m²: fitted readings without a verification pass)."""
    from glarelab.cli import main

    folder = tmp_path_factory.mktemp("spencer")
    protocol = ROOT / "protocols" / "spencer1995.toml"
    assert main(["stimuli", "build", str(protocol), "--out", str(folder / "set")]) == 0
    readings = [(c, 0.1 + 99.9 * (c / 255) ** 2.2) for c in range(0, 255, 17)] + [(255, 100.0)]
    calibration = fit_calibration(readings, bit_depth=8, label="a CRT, 100 cd/m²")
    assert calibration.status == "unverified"
    return folder / "set", calibration.save(folder / "crt.json")


@pytest.fixture
def screen(tmp_path):
    x = XScreen(tmp_path)
    yield x
    x.close()


def test_a_real_session_refuses_an_unverified_calibration(spencer, tmp_path):
    stimuli, calibration = spencer
    out = tmp_path / "data"
    refused = glarelab(
        "run", "spencer1995", "--participant", "P01", "--stimuli", stimuli,
        "--calibration", calibration, "--out", out,
    )  # fmt: skip
    assert refused.returncode == 2
    assert "the display calibration is unverified" in refused.stderr
    assert "--pilot" in refused.stderr and "--allow-uncalibrated" in refused.stderr
    assert not out.exists() or not [p for p in out.iterdir() if not p.name.startswith(".")]


def test_a_pilot_runs_on_any_screen_marked_and_recorded_as_a_pilot(screen, spencer, tmp_path):
    stimuli, calibration = spencer
    out = tmp_path / "data"
    screen.run(
        "run", "spencer1995", "--participant", "P01", "--stimuli", stimuli,
        "--calibration", calibration, "--pilot", "--out", out,
    )  # fmt: skip
    screen.wait_for_log(out, r"instructions screen onset")
    time.sleep(0.3)
    shown = screen.screenshot()
    Image.fromarray(shown).save(tmp_path / "pilot_instructions.png")
    # the PILOT mark, red, in the window's top-left corner (Spencer's images and text are grey)
    corner = shown[CORNER[1] : CORNER[1] + 40, CORNER[0] : CORNER[0] + 120].astype(int)
    red = (corner[..., 0] - corner[..., 1] > 60) & (corner[..., 0] - corner[..., 2] > 60)
    assert red.sum() > 50, red.sum()
    elsewhere = shown.astype(int)
    assert ((elsewhere[..., 0] - elsewhere[..., 1]) > 60).sum() == red.sum()  # only there
    screen.key("space")
    screen.wait_for_log(out, r"trial 1 flash")
    screen.key("Left")
    screen.wait_for_log(out, r"trial 1 recorded")
    screen.key("Escape")
    assert screen.wait() == 3, screen.stderr[-2000:]
    files = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    assert len(files) == 4 and all(
        name.split(".")[0].removesuffix("_frames").endswith("_pilot") for name in files
    ), files
    (csv,) = out.glob("*.csv")
    sidecar = sidecar_of(csv)
    assert sidecar["pilot"] is True and sidecar["runs"][0]["pilot"] is True
    assert sidecar["calibration"]["accepted_unverified_by"] == "--pilot"
    assert {"resolution"} <= set(sidecar["runs"][0]["accepted_mismatches"])
    assert "PILOT run" in csv.with_suffix(".log").read_text()
    frames = (out / (csv.stem + "_frames.tsv")).read_text()
    assert "PILOT run" in frames
    # a pilot resumes only as a pilot
    again = screen.glarelab(
        "run", "spencer1995", "--participant", "P01", "--stimuli", stimuli,
        "--calibration", calibration, "--allow-uncalibrated", "--resume", "--out", out,
        "--accept-mismatch", "resolution", "refresh", "--allow-unmeasured-refresh",
    )  # fmt: skip
    assert again.returncode == 2 and "is a pilot session: resume it with --pilot" in again.stderr


def test_a_pilot_is_never_full_screen(spencer, tmp_path):
    refused = glarelab("run", "luidolt2020", "--participant", "P01", "--pilot", "--fullscreen")
    assert refused.returncode == 2 and "--pilot runs in a window" in refused.stderr


def test_run_takes_study_or_protocol_and_refuses_two_studies(tmp_path):
    spencer = ROOT / "protocols" / "spencer1995.toml"
    both = glarelab("run", "yoshida2008", "--protocol", spencer, "--participant", "P01")
    assert both.returncode == 2
    assert "STUDY 'yoshida2008' and --protocol" in both.stderr and "'spencer1995'" in both.stderr
    neither = glarelab("run", "--participant", "P01")
    assert neither.returncode == 2 and "give the study" in neither.stderr
    alone = glarelab(
        "run", "--protocol", ROOT / "protocols" / "luidolt2020.toml", "--simulate",
        "--participants", "1", "--out", tmp_path,
    )  # fmt: skip
    assert alone.returncode == 0, alone.stderr
    (csv,) = tmp_path.glob("sim01_luidolt2020_s1_*.csv")
    assert json.loads(csv.with_suffix(".json").read_text())["study"] == "luidolt2020"
    same = glarelab(
        "run", "luidolt2020", "--protocol", ROOT / "protocols" / "luidolt2020.toml",
        "--simulate", "--participants", "1", "--session", "2", "--out", tmp_path,
    )  # fmt: skip
    assert same.returncode == 0, same.stderr
    assert np.size(list(tmp_path.glob("*.csv"))) == 2
