"""PsychoPy front-end of the photometer session: full-field patches and typed readings.

Only this module (and :mod:`stimuli.psychopy_window`) imports PsychoPy. It shows each drive code
of a :class:`~stimuli.measure.MeasurementSession` as a full-field patch, with a small prompt in
a corner (away from the photometer's spot) where the operator types the reading: digits, ``.``
or ``,`` as the decimal mark, Backspace, Enter to record, Escape to stop (everything entered so
far is already saved). Keys come from one never-cleared PsychoPy keyboard, so a reading typed
quickly, while the patch is still being drawn, keeps every character.

The window asks for the session's bits per channel; one that gets fewer refuses to measure
(its codes would be rounded, and the calibration fitted to the wrong codes) unless
``allow_fewer_bits``. A ``photometer`` callable can stand in for the operator (tests, dry runs).
"""

from __future__ import annotations

import time
from collections.abc import Callable

from .measure import MeasurementSession
from .psychopy_window import KeyReader, dispatch_events, grab_screen, open_window

__all__ = ["run_measurement"]

DECIMAL_KEYS = ("period", "comma", "num_decimal")


def _level(code: int, bit_depth: int) -> float:
    """A drive code as PsychoPy's rgb value in [-1, 1] (exact for 8-bit frame buffers)."""
    return 2.0 * code / (2**bit_depth - 1) - 1.0


def type_reading(typed: str, key: str) -> str:
    """The reading after one more key: digits and one decimal mark; Backspace deletes.

    Examples
    --------
    >>> reading = ""
    >>> for key in ["1", "2", "3", "comma", "4", "period", "num_5", "backspace", "6"]:
    ...     reading = type_reading(reading, key)
    >>> reading
    '123.46'
    """
    if key == "backspace":
        return typed[:-1]
    if key in DECIMAL_KEYS:
        return typed if "." in typed else typed + "."
    digit = key.removeprefix("num_")
    if len(digit) == 1 and digit.isdigit():
        return typed + digit
    return typed


def run_measurement(
    session: MeasurementSession,
    *,
    photometer: Callable[[int], float] | None = None,
    fullscr: bool = True,
    size: tuple[int, int] = (800, 600),
    screen: int = 0,
    frames_per_patch: int = 2,
    allow_fewer_bits: bool = False,
    log: Callable[[str], None] = lambda line: None,
) -> dict:
    """Run a session in a PsychoPy window until done or Escape.

    Returns
    -------
    dict
        ``status`` of the calibration (or ``'stopped'``), ``flags``, ``bits_per_channel`` the
        window gave, and ``shown``: the ``(code, pixel value read back from the frame)`` of
        each patch.

    Raises
    ------
    ValueError
        If the window gives fewer bits per channel than the session measures (unless
        ``allow_fewer_bits``).
    """
    from psychopy import visual

    window, bits = open_window(
        bits=session.bit_depth, fullscreen=fullscr, size=size, units="norm", screen=screen
    )
    try:
        if bits < session.bit_depth:
            message = (
                f"the window gives {bits} bits per channel, the calibration is for "
                f"{session.bit_depth}: the patches would show {bits}-bit codes and the "
                f"calibration would be fitted to the wrong ones; measure on a "
                f"{session.bit_depth}-bit display, or at --bit-depth {bits}"
            )
            if not allow_fewer_bits:
                raise ValueError(message)
            log(f"warning: {message} (measuring anyway, as asked)")
        patch = visual.Rect(
            window,
            width=2,
            height=2,
            units="norm",
            lineColor=None,
            colorSpace="rgb",
            fillColor=(-1, -1, -1),
            autoLog=False,
        )
        prompt = visual.TextStim(
            window,
            text="",
            pos=(-0.95, -0.9),
            height=0.04,
            alignText="left",
            anchorHoriz="left",
            color=(0.2, 0.2, 0.2),
            autoLog=False,
        )
        keys = KeyReader() if photometer is None else None
        if keys is not None:
            keys.clear()
        shown = []
        typed = ""
        pending: list[str] = []  # keys read but not yet used (typed ahead of the next patch)
        while session.phase != "done":
            step = session.current()
            level = _level(step["code"], session.bit_depth)
            patch.fillColor = (level, level, level)
            what = f"target {step['target_cd_m2']:.4g} cd/m²" if step["phase"] == "verify" else ""

            def draw(typed, step=step, what=what):
                patch.draw()
                prompt.text = (
                    f"{step['phase']} code {step['code']} ({step['remaining']} left) {what}\n"
                    f"reading (cd/m²): {typed}_"
                )
                prompt.draw()

            for frame_index in range(frames_per_patch):
                patch.draw()
                if frame_index == frames_per_patch - 1:  # what this frame shows, before the prompt
                    frame = grab_screen(window)
                    shown.append(
                        (step["code"], int(frame[frame.shape[0] // 2, frame.shape[1] // 2, 0]))
                    )
                draw(typed)
                window.flip()
            if photometer is not None:
                session.record(photometer(step["code"]))
                continue
            recorded = False
            while not recorded:  # every key since the patch appeared, typed ones included
                if not pending:
                    pending = [key for key, _ in keys.read()]
                    if not pending:
                        dispatch_events(window)
                        time.sleep(0.002)
                        continue
                key = pending.pop(0)
                if key == "escape":
                    return {
                        "status": "stopped",
                        "flags": session.flags,
                        "shown": shown,
                        "bits_per_channel": bits,
                    }
                if key in ("return", "num_enter") and typed:
                    try:
                        session.record(float(typed))
                        recorded = True
                    except ValueError:
                        pass  # not a number: keep the patch, let the operator retype
                    typed = ""
                else:
                    typed = type_reading(typed, key)
                if not recorded and not pending:
                    draw(typed)
                    window.flip()
    finally:
        window.close()
    return {
        "status": session.calibration.status if session.calibration else "failed",
        "flags": session.flags,
        "shown": shown,
        "bits_per_channel": bits,
    }
