"""PsychoPy front-end of the photometer session: full-field patches and typed readings.

Only this module imports PsychoPy. It shows each drive code of a
:class:`~stimuli.measure.MeasurementSession` as a full-field patch, with a small prompt in a
corner (away from the photometer's spot) where the operator types the reading: digits, ``.``,
Backspace, Enter to record, Escape to stop (everything entered so far is already saved). A
``photometer`` callable can stand in for the operator (tests, dry runs).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .measure import MeasurementSession

__all__ = ["run_measurement"]


def _level(code: int, bit_depth: int) -> float:
    """A drive code as PsychoPy's rgb value in [-1, 1] (exact for 8-bit frame buffers)."""
    return 2.0 * code / (2**bit_depth - 1) - 1.0


def run_measurement(
    session: MeasurementSession,
    *,
    photometer: Callable[[int], float] | None = None,
    fullscr: bool = True,
    size: tuple[int, int] = (800, 600),
    screen: int = 0,
    frames_per_patch: int = 2,
) -> dict:
    """Run a session in a PsychoPy window until done or Escape.

    Returns
    -------
    dict
        ``status`` of the calibration (or ``'stopped'``), ``flags``, and ``shown``: the
        ``(code, pixel value read back from the frame)`` of each patch.
    """
    from psychopy import event, visual

    window = visual.Window(
        size=size,
        fullscr=fullscr,
        screen=screen,
        units="norm",
        color=(-1, -1, -1),
        colorSpace="rgb",
        allowGUI=False,
        useFBO=False,
        checkTiming=False,
    )
    patch = visual.Rect(
        window,
        width=2,
        height=2,
        units="norm",
        lineColor=None,
        colorSpace="rgb",
        fillColor=(-1, -1, -1),
    )
    prompt = visual.TextStim(
        window,
        text="",
        pos=(-0.95, -0.9),
        height=0.04,
        alignText="left",
        anchorHoriz="left",
        color=(0.2, 0.2, 0.2),
    )
    shown = []
    typed = ""
    try:
        while session.phase != "done":
            step = session.current()
            level = _level(step["code"], session.bit_depth)
            patch.fillColor = (level, level, level)
            what = f"target {step['target_cd_m2']:.4g} cd/m²" if step["phase"] == "verify" else ""
            prompt.text = (
                f"{step['phase']} code {step['code']} ({step['remaining']} left) {what}\n"
                f"reading (cd/m²): {typed}_"
            )
            for frame_index in range(frames_per_patch):
                patch.draw()
                if frame_index == frames_per_patch - 1:  # what this frame shows, before the prompt
                    frame = np.asarray(window.getMovieFrame(buffer="back"))
                    shown.append(
                        (step["code"], int(frame[frame.shape[0] // 2, frame.shape[1] // 2, 0]))
                    )
                prompt.draw()
                window.flip()
            if photometer is not None:
                session.record(photometer(step["code"]))
                continue
            keys = event.waitKeys()
            for key in keys:
                if key == "escape":
                    return {"status": "stopped", "flags": session.flags, "shown": shown}
                if key in ("return", "num_enter") and typed:
                    try:
                        session.record(float(typed))
                    except ValueError:
                        pass  # not a number: keep the patch, let the operator retype
                    typed = ""
                elif key == "backspace":
                    typed = typed[:-1]
                elif key in ("period", "num_decimal"):
                    typed += "."
                elif key.removeprefix("num_").isdigit():
                    typed += key.removeprefix("num_")
    finally:
        window.close()
    return {
        "status": session.calibration.status if session.calibration else "failed",
        "flags": session.flags,
        "shown": shown,
    }
