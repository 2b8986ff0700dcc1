"""PsychoPy front-end of the photometer session: full-field patches, read by a photometer or
typed.

Only this module (and :mod:`glarelab.frontend.window`) imports PsychoPy. It shows each
drive code of a :class:`~glarelab.display.measure.MeasurementSession` as a full-field patch, with a
small prompt in a corner (away from the photometer's spot) where the operator types the reading:
digits, ``.`` or ``,`` as the decimal mark, Backspace, Enter to record, Escape to stop (everything
entered so far is already saved). Keys come from one never-cleared PsychoPy keyboard, so a reading
typed quickly, while the patch is still being drawn, keeps every character.

The window asks for the session's bits per channel; one that gets fewer refuses to measure
(its codes would be rounded, and the calibration fitted to the wrong codes) unless
``allow_fewer_bits``. A ``photometer`` callable can stand in for the operator (tests, dry runs).

With a photometer on a serial port (``meter``), each patch is read automatically
(:func:`glarelab.display.photometer.measure_patch`: settle, readings, spread check, repeats) while
the patch stays on the screen and Escape stops; a photometer fault leaves the patch up with the
message, and typing the reading stays possible there.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from glarelab.display.calibration import verification_outcome
from glarelab.display.measure import MeasurementSession
from glarelab.display.photometer import PatchProtocol, Photometer, PhotometerError, measure_patch
from glarelab.frontend.window import KeyReader, dispatch_events, grab_screen, open_window

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["read_code_luminances", "run_measurement"]

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


class _Stopped(Exception):
    """Escape during an automatic reading."""


def run_measurement(
    session: MeasurementSession,
    *,
    photometer: Callable[[int], float] | None = None,
    meter: Photometer | None = None,
    patch_protocol: PatchProtocol | None = None,
    reopen: Callable[[], Photometer] | None = None,
    fullscr: bool = True,
    size: tuple[int, int] = (800, 600),
    screen: int = 0,
    frames_per_patch: int = 2,
    allow_fewer_bits: bool = False,
    log: Callable[[str], None] = lambda line: None,
) -> dict:
    """Run a session in a PsychoPy window until done or Escape.

    Parameters
    ----------
    session
        The measurement session (new or resumed), saved after every entry.
    photometer
        A simulated photometer: the luminance of a code (tests, dry runs).
    meter
        A photometer on a serial port (:func:`glarelab.display.photometer.open_photometer`): each
        patch is read as ``patch_protocol`` says, every reading kept in the session file at once.
        On a fault the patch stays on the screen with the message: R tries the photometer again
        (``reopen`` opens it anew after a pulled cable), a typed reading and Enter enters the
        patch by hand, Escape stops (``--resume`` goes on from this patch).
    patch_protocol
        Readings per patch, settling time, spread allowed (default :class:`PatchProtocol`).
    reopen
        Opens the photometer anew after a fault (a pulled cable); default None: R retries the
        open one.
    fullscr
        Whether the window is full-screen; default True.
    size
        The window's size in pixels when not full-screen; default ``(800, 600)``.
    screen
        The screen's number; default 0.
    frames_per_patch
        Frames each patch is drawn before it is read; default 2.
    allow_fewer_bits
        Whether to measure in a window of fewer bits per channel than the session's; default
        False.
    log
        Called with each progress line; default: nothing.

    Returns
    -------
    dict
        ``status`` of the calibration (or ``'stopped'``; ``'synthetic'`` with a simulated
        ``photometer``), ``verification`` (``'passed'``, ``'failed'`` or None: what its
        verification pass gave), ``flags``, ``bits_per_channel`` the
        window gave, ``faults`` (the photometer's messages), and ``shown``: the ``(code, pixel
        value read back from the frame)`` of each patch.

    Raises
    ------
    ValueError
        If the window gives fewer bits per channel than the session measures (unless
        ``allow_fewer_bits``).
    """
    from psychopy import visual

    patch_protocol = patch_protocol or PatchProtocol()
    window, bits = open_window(
        bits=session.bit_depth, fullscreen=fullscr, size=size, units="norm", screen=screen
    )
    faults: list[str] = []
    shown: list[tuple[int, int]] = []

    def result(status: str) -> dict:
        verification = session.calibration.verification if session.calibration else {}
        worst = verification.get("max_relative_error")
        return {
            "status": status,
            "verification": None
            if worst is None
            else verification_outcome(worst, verification["tolerance_fraction"]),
            "flags": session.flags,
            "shown": shown,
            "bits_per_channel": bits,
            "faults": faults,
        }

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
            anchorVert="bottom",
            wrapWidth=1.9,
            color=(0.2, 0.2, 0.2),
            autoLog=False,
        )
        keys = KeyReader() if photometer is None else None
        if keys is not None:
            keys.clear()
        typed = ""
        pending: list[str] = []  # keys read but not yet used (typed ahead of the next patch)
        while session.phase != "done":
            step = session.current()
            level = _level(step["code"], session.bit_depth)
            patch.fillColor = (level, level, level)
            what = f"target {step['target_cd_m2']:.4g} cd/m²" if step["phase"] == "verify" else ""
            heading = f"{step['phase']} code {step['code']} ({step['remaining']} left) {what}"

            def draw(line, heading=heading):
                patch.draw()
                prompt.text = f"{heading}\n{line}"
                prompt.draw()

            for frame_index in range(frames_per_patch):
                patch.draw()
                if frame_index == frames_per_patch - 1:  # what this frame shows, before the prompt
                    frame = grab_screen(window)
                    shown.append(
                        (step["code"], int(frame[frame.shape[0] // 2, frame.shape[1] // 2, 0]))
                    )
                draw("photometer reading" if meter is not None else f"reading (cd/m²): {typed}_")
                window.flip()
            if photometer is not None:
                session.record(photometer(step["code"]), source="simulated")
                continue
            fault = None
            if meter is not None:
                try:
                    read = _read_patch(session, meter, patch_protocol, window, draw, keys)
                except _Stopped:
                    return result("stopped")
                except PhotometerError as error:
                    fault = str(error)
                    faults.append(fault)
                    session.interrupted(fault)
                    log(f"photometer fault at {step['phase']} code {step['code']}: {fault}")
                else:
                    session.record(
                        read.luminance_cd_m2,
                        readings=read.readings,
                        source="photometer",
                        flags=read.flags,
                    )
                    continue
            recorded = False
            drawn = None if fault is not None else f"reading (cd/m²): {typed}_"
            while not recorded:  # every key since the patch appeared, typed ones included
                if fault is not None:
                    line = (
                        f"PHOTOMETER: {fault}\nR: try the photometer again · type the reading and "
                        f"Enter · Escape: stop (everything is saved; --resume goes on here)\n"
                        f"reading (cd/m²): {typed}_"
                    )
                else:
                    line = f"reading (cd/m²): {typed}_"
                if line != drawn:  # what the operator typed (or the fault) changed
                    draw(line)
                    window.flip()
                    drawn = line
                if not pending:
                    pending = [key for key, _ in keys.read()]
                    if not pending:
                        dispatch_events(window)
                        time.sleep(0.002)
                        continue
                key = pending.pop(0)
                if key == "escape":
                    return result("stopped")
                if key == "r" and fault is not None and not typed:
                    try:
                        if reopen is not None:
                            meter.close()
                            meter = reopen()
                        break  # read the patch again with the photometer
                    except PhotometerError as error:
                        fault = str(error)
                        faults.append(fault)
                        session.interrupted(fault)
                        log(f"photometer fault: {fault}")
                        continue
                if key in ("return", "num_enter") and typed:
                    try:
                        session.record(float(typed), source="typed")
                        recorded = True
                    except ValueError:
                        pass  # not a number: keep the patch, let the operator retype
                    typed = ""
                else:
                    typed = type_reading(typed, key)
    finally:
        window.close()
    return result(session.calibration.status if session.calibration else "failed")


def _read_patch(session, meter, protocol: Protocol, window, draw, keys):
    """Read the patch shown through the photometer; Escape stops (raises :class:`_Stopped`)."""
    taken = [0]

    def check_keys():
        if keys is not None and any(key == "escape" for key, _ in keys.read()):
            raise _Stopped

    def hold(seconds: float) -> None:  # keep the patch on the screen while it settles
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            draw(f"settling ({protocol.settle_s:g} s), then {protocol.readings} readings")
            window.flip()
            check_keys()
            time.sleep(0.005)  # a screen without vertical sync would flip as fast as it can

    def keep(row: dict) -> None:
        taken[0] += 1
        session.keep_reading(row)
        draw(f"photometer reading {taken[0]}: {row['cd_m2']:g} cd/m²")
        window.flip()
        check_keys()

    step = session.current()
    return measure_patch(meter.read, protocol, wait=hold, keep=keep, what=f"code {step['code']}")


def read_code_luminances(
    window,
    meter: Photometer,
    codes: list[int],
    *,
    bit_depth: int,
    patch_protocol: PatchProtocol | None = None,
    keep: Callable[[dict], None] = lambda row: None,
    log: Callable[[str], None] = lambda line: None,
) -> list[dict]:
    """Show each drive code full-field in an open window and read it with the photometer.

    Parameters
    ----------
    window
        The open PsychoPy window.
    meter
        The open photometer.
    codes
        The drive codes to show, in order.
    bit_depth
        The codes' bits per channel.
    patch_protocol
        How each patch is read; default None: :class:`PatchProtocol`'s defaults.
    keep
        Called with every reading as it is taken; default: nothing.
    log
        Called with each code's line; default: nothing.

    Returns
    -------
    list of dict
        ``code``, ``cd_m2`` (the median), ``readings_cd_m2``, ``flags`` per code.

    Raises
    ------
    PhotometerError
        On a fault; ``keep`` has had every reading taken before it.
    """
    from psychopy import visual

    protocol = patch_protocol or PatchProtocol()
    patch = visual.Rect(
        window, width=2, height=2, units="norm", lineColor=None, colorSpace="rgb", autoLog=False
    )
    results = []
    for code in codes:
        level = _level(int(code), bit_depth)
        patch.fillColor = (level, level, level)

        def hold(seconds: float) -> None:
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                patch.draw()
                window.flip()
                time.sleep(0.005)

        patch.draw()
        window.flip()
        read = measure_patch(
            meter.read,
            protocol,
            wait=hold,
            keep=lambda row, code=code: keep({"code": int(code), **row}),
            what=f"code {code}",
        )
        log(f"code {code}: {read.luminance_cd_m2:.4g} cd/m²")
        results.append(
            {
                "code": int(code),
                "cd_m2": read.luminance_cd_m2,
                "readings_cd_m2": read.readings,
                "flags": read.flags,
            }
        )
    return results
