"""PsychoPy opens a window on this machine and shows exactly the pixel values it is given.

The experiments (PsychoPy front-ends) rely on this. ``make test`` runs pytest under Xvfb; run
on its own without a display, the check starts its own virtual screen with ``xvfb-run``.
"""

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
