"""PsychoPy opens a window on this machine and shows exactly the pixel values it is given.

The experiments (PsychoPy front-ends) rely on this. ``make test`` runs pytest under Xvfb; run
on its own without a display, the check starts its own virtual screen with ``xvfb-run``.
"""

import json
import os
import shutil
import subprocess
import sys
import textwrap

WINDOW_SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from psychopy import core, visual

    win = visual.Window(size=(64, 64), units="pix", color=(-1, -1, -1), colorSpace="rgb",
                        fullscr=False, useFBO=False, allowGUI=False, checkTiming=False)
    levels = np.tile(np.linspace(-1, 1, 64), (64, 1))  # a horizontal ramp, PsychoPy's -1..1
    stim = visual.ImageStim(win, image=levels, size=(64, 64), units="pix",
                            colorSpace="rgb", interpolate=False)
    stim.draw()
    frame = np.asarray(win.getMovieFrame(buffer="back"))
    win.close()
    row = frame[32, :, 0].astype(int)
    expected = np.round((levels[0] + 1) / 2 * 255).astype(int)
    print("MAXDIFF", int(np.abs(row - expected).max()))
    core.quit()
    """
)


def test_psychopy_window_shows_the_given_levels(tmp_path):
    script = tmp_path / "window.py"
    script.write_text(WINDOW_SCRIPT)
    command = [sys.executable, str(script)]
    if not os.environ.get("DISPLAY"):
        xvfb = shutil.which("xvfb-run")
        assert xvfb, "no DISPLAY and no xvfb-run: run `make test`, which installs Xvfb"
        command = [xvfb, "-a", "-s", "-screen 0 1024x768x24", *command]
    done = subprocess.run(command, capture_output=True, text=True, timeout=180, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("MAXDIFF")]
    assert lines, f"PsychoPy window failed:\n{done.stdout}\n{done.stderr[-3000:]}"
    assert int(lines[0].split()[1]) <= 1  # at most one 8-bit step of rounding


BANK_SCRIPT = textwrap.dedent(
    """
    import numpy as np
    from glarelab.display.calibration import synthetic_calibration
    from glarelab.frontend.images import ImageBank
    from glarelab.frontend.window import open_window

    win, bits = open_window(bits=8, fullscreen=False, size=(200, 120))
    calibration = synthetic_calibration(max_cd_m2=200.0, black_cd_m2=0.2, bit_depth=8)
    bank = ImageBank(None, calibration, display=None, display_bits=8)

    class Facts:
        bits_per_channel = bits

    bank.attach(win, Facts())
    rng = np.random.default_rng(1)
    colour = rng.uniform(0.0, 220.0, size=(40, 60, 3))  # every code, in each channel
    grey = rng.uniform(0.0, 220.0, size=(40, 60))
    worst = []
    for luminance in (colour, grey):
        stim = bank.image_stim(luminance)
        stim.pos = (0, 0)
        win.clearBuffer()
        stim.draw()
        frame = np.asarray(win.getMovieFrame(buffer="back")).astype(int)  # PsychoPy's read
        top = (frame.shape[0] - 40) // 2
        left = (frame.shape[1] - 60) // 2
        shown = frame[top : top + 40, left : left + 60]
        expected = bank.codes(luminance)
        if expected.ndim == 2:
            expected = np.repeat(expected[..., None], 3, axis=-1)
        worst.append(int(np.abs(shown - expected).max()))
    win.close()
    print("WORST", *worst)
    """
)


def test_colour_and_grey_images_are_shown_code_for_code(tmp_path):
    # a colour frame is an RGB texture shown as it is (in [0, 1]); a grey one a luminance
    # texture shown as (v + 1) / 2: each must land on the calibration's codes exactly
    script = tmp_path / "bank.py"
    script.write_text(BANK_SCRIPT)
    command = [sys.executable, str(script)]
    if not os.environ.get("DISPLAY"):
        xvfb = shutil.which("xvfb-run")
        assert xvfb, "no DISPLAY and no xvfb-run: run `make test`, which installs Xvfb"
        command = [xvfb, "-a", "-s", "-screen 0 1024x768x24", *command]
    done = subprocess.run(command, capture_output=True, text=True, timeout=180, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("WORST")]
    assert lines, f"PsychoPy window failed:\n{done.stdout}\n{done.stderr[-3000:]}"
    assert lines[0].split()[1:] == ["0", "0"]  # colour, grey: worst code difference


COMMENT_SCRIPT = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from PIL import Image
    from glarelab.frontend.screens import ScreenText
    from glarelab.frontend.window import grab_screen, open_window

    win, _ = open_window(bits=8, fullscreen=False, size=(1280, 800))
    text = ScreenText(win, pilot=False)
    screen = {"kind": "comment", "text": "Overall: rated 5", "text_entry": True, "keys": {}}
    found = []
    words = "the glare looked like a real lamp at night, but the halo was too wide " * 60
    for length in (30, 400, len(words)):
        typed = words[:length] + "END"
        win.clearBuffer()
        text.draw(screen, [], comment=(typed, len(typed)))
        frame = grab_screen(win)
        Image.fromarray(frame).save(sys.argv[1] + f"/comment_{length}.png")
        lit = np.argwhere(frame.max(axis=2) > 90)  # the typed text (the box's line is dim)
        below = lit[lit[:, 0] > 400 - 40]  # under the box's top (the question is above it)
        found.append({"length": length, "box": float(text.box.height),
                      "lowest_text_row": int(below[:, 0].max()),
                      "shown": text.typed_stim.text[-4:], "starts": text.typed_stim.text[:1]})
    win.close()
    print("FOUND " + json.dumps(found))
    """
)


def test_the_comment_box_grows_with_the_comment_and_then_scrolls(tmp_path):
    script = tmp_path / "comment.py"
    script.write_text(COMMENT_SCRIPT)
    command = [sys.executable, str(script), str(tmp_path)]
    if not os.environ.get("DISPLAY"):
        xvfb = shutil.which("xvfb-run")
        assert xvfb, "no DISPLAY and no xvfb-run: run `make test`, which installs Xvfb"
        command = [xvfb, "-a", "-s", "-screen 0 1920x1080x24", *command]
    done = subprocess.run(command, capture_output=True, text=True, timeout=180, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("FOUND ")]
    assert lines, f"PsychoPy window failed:\n{done.stdout}\n{done.stderr[-3000:]}"
    short, longer, longest = json.loads(lines[0].removeprefix("FOUND "))
    assert short["box"] == 160 and longer["box"] > 160  # grown with the text
    assert longest["box"] <= 400 + 40 - 20  # to the window's bottom, no further
    for found in (short, longer, longest):
        assert found["shown"] == "END|"  # what was typed last, and the cursor, in view
        assert found["lowest_text_row"] < 800 - 20  # every line inside the window
    assert longest["starts"] == "…" and short["starts"] == "t"  # the beginning scrolled out
