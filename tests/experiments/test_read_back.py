"""The read-back proof as a lab runs it: ``glarelab check-display PROTOCOL --stimuli SET``
lists every image with its exact pixels and worst code difference and writes them next to the
calibration; a session records its first trial's read-back in its sidecar; and the check finds
an image drawn half a pixel off (it is not a check that cannot fail).
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from .xscreen import XScreen, sidecar_of

ROOT = Path(__file__).parents[2]
XVFB_MISMATCH = ("--accept-mismatch", "resolution", "refresh", "--allow-unmeasured-refresh")


@pytest.fixture(scope="module")
def yoshida_set():
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    return cached_stimulus_set(load_protocol("yoshida2008"), progress=None)


@pytest.fixture
def screen30(tmp_path):
    x = XScreen(tmp_path, depth=30)
    x.env["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    yield x
    x.close()


def test_check_display_lists_every_image_read_back_next_to_the_calibration(
    screen30, yoshida_set, tmp_path
):
    manifest = json.loads((yoshida_set / "manifest.json").read_text())
    calibration = tmp_path / "lab-display.json"
    calibration.write_text(json.dumps(manifest["calibration"]))  # the set's own calibration
    done = screen30.glarelab(
        "check-display", "yoshida2008", "--stimuli", yoshida_set, "--calibration", calibration,
        "--frames", "30", "--windowed",
    )  # fmt: skip
    assert done.returncode == 1, done.stderr[-3000:]  # Xvfb is not the protocol's display
    assert "ok   bit-depth: protocol 10 bits per channel, display 10 bits" in done.stdout
    shown = sorted(n for n, r in manifest["images"].items() if r["kind"] != "component")
    assert len(shown) == 14
    for name in shown:
        assert (
            f"ok   {name}: 100.000 % of 73441 px exact in 3 place(s), worst difference 0 codes"
            in done.stdout
        ), done.stdout
    result = json.loads((tmp_path / "lab-display.display-check.json").read_text())
    assert result["images_exact"] is True
    assert [r["image"] for r in result["images"]] == shown
    for record in result["images"]:
        assert record["exact_fraction"] == 1.0 and record["worst_code_difference"] == 0
        assert record["window_bits"] == 10 and record["expected"].endswith("(the set's codes)")


def test_a_session_records_its_first_trials_read_back(screen30, yoshida_set, tmp_path):
    keys = tmp_path / "keys.txt"
    keys.write_text("space up up return y n y escape\n")
    out = tmp_path / "data"
    done = screen30.glarelab(
        "run", "yoshida2008", "--participant", "dry", "--stimuli", yoshida_set,
        "--allow-uncalibrated", "--scripted-keys", keys, "--out", out, *XVFB_MISMATCH,
    )  # fmt: skip
    assert done.returncode == 3, done.stderr[-3000:]  # aborted by the key script's Escape
    assert "does not show the stimulus set's codes" not in done.stderr
    (csv,) = out.glob("dry_yoshida2008_s1_*.csv")
    check = sidecar_of(csv)["runs"][-1]["presentation_check"]
    assert check["exact"] is True and check["window_bits"] == 10
    assert check["screen"] == "adjust of trial 1"
    assert [image["role"] for image in check["images"]] == ["left", "reference", "right"]
    for image in check["images"]:
        assert image["exact_fraction"] == 1.0 and image["worst_code_difference"] == 0
        assert image["size_px"] == [271, 271]
    assert check["images"][1]["expected"].endswith("(the set's codes)")  # a set image as is
    lefts = [image["left_bottom_px"][0] for image in check["images"]]
    assert [lefts[1] - lefts[0], lefts[2] - lefts[1]] == [271 + 34] * 2  # Yoshida's gap


HALF_PIXEL = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path

    from glarelab.experiments import layout
    from glarelab.frontend.check_display import check_display
    from glarelab.protocols import load_protocol

    whole = layout.Placement.pos.fget
    # the old placement: the row centred at whole pixels, edges on half pixels
    layout.Placement.pos = property(lambda p: (whole(p)[0] + 0.5, whole(p)[1] + 0.5))
    result = check_display(load_protocol("yoshida2008"), stimuli=Path(sys.argv[1]), frames=10,
                           fullscreen=False, log=lambda *a: None)
    print("RESULT " + json.dumps(result["images"]))
    """
)


def result_on_screen(tmp_path: Path, script: str, *args, depth: int = 24):
    """Run ``script`` with ``args`` on an X screen of its own; the JSON it prints after
    ``RESULT``."""
    path = tmp_path / "on_screen.py"
    path.write_text(script)
    x = XScreen(tmp_path, depth=depth)
    try:
        env = {
            **x.env,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        }
        done = subprocess.run(
            [sys.executable, str(path), *map(str, args)],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    finally:
        x.close()
    lines = [line for line in done.stdout.splitlines() if line.startswith("RESULT ")]
    assert lines, done.stderr[-3000:]
    return json.loads(lines[0].removeprefix("RESULT "))


def test_the_read_back_finds_images_drawn_half_a_pixel_off(tmp_path, yoshida_set):
    images = result_on_screen(tmp_path, HALF_PIXEL, yoshida_set)
    assert len(images) == 14
    for image in images:  # each resampled: rows and columns doubled and dropped
        assert image["exact_fraction"] < 0.99 and image["worst_code_difference"] > 0
        assert image["first_difference"] is not None


# --- colour frames: the night study ----------------------------------------------------------

CHECK_NIGHT = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path

    import numpy as np

    from glarelab.frontend import images
    from glarelab.frontend.check_display import check_display
    from glarelab.protocols import load_protocol

    if sys.argv[3] == "broken":  # the old colour path: RGB passed in [-1, 1] like grey
        def levels(self, luminance):
            fraction = self.codes(luminance) / (2**self.window_bits - 1)
            return np.flipud(fraction * 2.0 - 1.0)
        images.ImageBank.levels = levels
    result = check_display(load_protocol(Path(sys.argv[1])), stimuli=Path(sys.argv[2]),
                           frames=10, fullscreen=False, log=lambda *a: None)
    print("RESULT " + json.dumps({k: result[k] for k in ("images", "images_exact")}))
    """
)


@pytest.fixture(scope="module")
def night_set(tmp_path_factory):
    from glarelab.cli import main
    from tests.conftest import small_night_protocol

    folder = tmp_path_factory.mktemp("night")
    protocol = folder / "night_small.toml"
    protocol.write_text(small_night_protocol())
    assert main(["stimuli", "build", str(protocol), "--out", str(folder / "set")]) == 0
    return protocol, folder / "set"


def check_night(tmp_path, night_set, how: str, depth: int = 30) -> dict:
    protocol, folder = night_set
    return result_on_screen(tmp_path, CHECK_NIGHT, protocol, folder, how, depth=depth)


def test_check_display_reads_every_colour_frame_of_a_night_scene(tmp_path, night_set):
    _, folder = night_set
    manifest = json.loads((folder / "manifest.json").read_text())
    frames = sorted(n for n, r in manifest["images"].items() if r["kind"] == "night")
    assert len(frames) == 5 * 3  # five conditions of three frames
    result = check_night(tmp_path, night_set, "as shipped")
    assert [r["image"] for r in result["images"]] == frames
    for record in result["images"]:
        assert record["exact_fraction"] == 1.0 and record["worst_code_difference"] == 0
        assert record["window_bits"] == 10 and record["pixels"] == 64 * 48
    assert result["images_exact"] is True


def test_check_display_fails_when_the_colour_path_is_broken(tmp_path, night_set):
    result = check_night(tmp_path, night_set, "broken", depth=24)
    assert result["images_exact"] is False
    # every code below mid-range is shown black: no frame is exact (the black ones stay black)
    assert all(r["exact_fraction"] < 1.0 for r in result["images"])
    assert max(r["worst_code_difference"] for r in result["images"]) > 50


def test_a_kind_check_display_cannot_show_is_a_failure(tmp_path, yoshida_set):
    from types import SimpleNamespace

    import glarelab.frontend.check_display as check
    from glarelab.stimuli.stimulus_set import StimulusSet

    stimuli = StimulusSet(yoshida_set)  # with an image of a kind no session of today shows
    stimuli.manifest = {**stimuli.manifest, "images": {"hologram_1": {"kind": "hologram"}}}
    device = SimpleNamespace(
        set=stimuli,
        facts=SimpleNamespace(bits_per_channel=10),
        window=SimpleNamespace(size=(1920, 1080)),
    )
    (record,) = check.read_back_images(device, None)
    assert record["image"] == "hologram_1" and record["exact_fraction"] == 0.0
    assert record["problem"].startswith("its kind 'hologram' is not one check-display can show")
