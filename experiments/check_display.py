"""``glarelab check-display``: measure the lab's display as a session will use it.

What a session checks only briefly before its first trial, measured at length and written down
(a JSON file next to the calibration), so a lab knows its display before the first
participant:

- the screen's resolution, against the protocol's display;
- the refresh rate (PsychoPy's ``getActualFrameRate``), and the frame intervals of
  ``frames`` consecutive flips with nothing drawn: median, standard deviation, the worst, and
  the share longer than 1.5 periods (a dropped frame); with vertical sync they sit at one
  period;
- the bits per channel the window was given, and what the frame buffer really holds: a ramp of
  every code of the protocol's bit depth is drawn and read back at 16 bits, and the distinct
  levels found give the effective bits;
- with a stimulus set of a protocol that flashes its stimuli (a staircase), the cost of one
  frame of the first flash a session shows:
  the time to draw its images (CPU) and the flip-to-flip time while drawing them, against the
  frame period a session would time its flashes at (the measured one when it matches the
  protocol's, else the protocol's).

A virtual screen (Xvfb) has no vertical sync: its intervals show the cost of a frame, not the
display's refresh; the numbers are only meaningful on the lab's own display.
"""

from __future__ import annotations

import ctypes
import json
import platform
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from protocols.atomic import write_text
from stimuli.psychopy_window import measure_frame_intervals

from .display import check_screen, timing_rate_hz
from .loop import DROPPED_INTERVAL
from .psychopy_frontend import PsychoPyFrontend

__all__ = ["check_display", "write_check"]


def _interval_summary(intervals_s: np.ndarray, period_s: float) -> dict:
    ms = 1000.0 * np.asarray(intervals_s, dtype=float)
    return {
        "frames": int(ms.size),
        "median_ms": float(np.median(ms)),
        "sd_ms": float(np.std(ms, ddof=1)) if ms.size > 1 else 0.0,
        "min_ms": float(ms.min()),
        "max_ms": float(ms.max()),
        "late_fraction": float(np.mean(ms > DROPPED_INTERVAL * 1000.0 * period_s)),
    }


def _framebuffer_levels(window, bits: int) -> int:
    """Distinct levels of a ramp of every ``bits``-bit code, read back from the frame buffer
    at 16 bits per channel."""
    from psychopy import visual
    from pyglet import gl

    codes = 2**bits
    width = min(codes, window.size[0])
    ramp = np.linspace(-1.0, 1.0, codes)
    # as many codes as fit across the window, several rows of each
    levels = ramp[np.linspace(0, codes - 1, width).round().astype(int)]
    image = np.tile(levels, (8, 1))
    stim = visual.ImageStim(
        window,
        image=image,
        size=(width, 8),
        units="pix",
        interpolate=False,
        colorSpace="rgb",
        autoLog=False,
    )
    stim.draw()
    x0 = int(window.size[0] // 2 - width // 2)
    y0 = int(window.size[1] // 2)
    buffer = (ctypes.c_ushort * (width * 3))()
    gl.glReadBuffer(gl.GL_BACK)
    gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
    gl.glReadPixels(x0, y0, width, 1, gl.GL_RGB, gl.GL_UNSIGNED_SHORT, buffer)
    window.clearBuffer()
    red = np.frombuffer(buffer, dtype=np.uint16)[0::3]
    return int(np.unique(red).size)


def check_display(
    protocol,
    *,
    stimuli: Path | None = None,
    calibration=None,
    frames: int = 600,
    fullscreen: bool = True,
    log=print,
) -> dict:
    """Measure the display a protocol's sessions will run on; return the findings.

    Parameters
    ----------
    protocol
        The protocol whose display is checked (its ``[display]`` table).
    stimuli
        A stimulus set of a flashing protocol: also measure a frame of its flash.
    calibration
        The calibration the sessions will use (recorded; its images are encoded with it).
    frames
        Flips per measurement; default 600 (10 s at 60 Hz).
    fullscreen
        Measure a full-screen window (as a session runs); default True.
    """
    if not protocol.data.get("display"):
        raise ValueError(f"the {protocol.study} protocol describes no display to check")
    if frames < 10:
        raise ValueError(f"frames must be at least 10; got {frames!r}")
    device = PsychoPyFrontend(
        protocol,
        stimuli=stimuli,
        calibration=calibration,
        fullscreen=fullscreen,
        scripted_keys=[],
    )
    log("opening the window and measuring the refresh rate")
    facts = device.open()
    try:
        window = device.window
        checks = check_screen(protocol, facts)
        records = [check.__dict__ for check in checks]
        period = 1.0 / timing_rate_hz(protocol, facts, records)
        log(f"flipping {frames} empty frames")
        idle = measure_frame_intervals(window, frames=frames)
        bits = protocol["display"]["bit_depth"]
        levels = _framebuffer_levels(window, bits)
        result = {
            "checked": datetime.now().astimezone().isoformat(timespec="seconds"),
            "host": platform.node(),
            "protocol": protocol.source,
            "protocol_sha256": protocol.sha256,
            "resolution_px": list(facts.resolution_px),
            "refresh_hz_measured": facts.refresh_hz,
            "bits_per_channel": facts.bits_per_channel,
            "framebuffer_levels": levels,
            "framebuffer_levels_asked": min(2**bits, window.size[0]),
            "effective_bits": float(np.log2(levels)) if levels > 1 else 0.0,
            "frame_intervals_empty": _interval_summary(idle, period),
            "timing_refresh_hz": 1.0 / period,
            "checks": records,
            "calibration": None
            if calibration is None
            else {"label": calibration.label, "status": calibration.status},
        }
        flash = _first_flash(protocol, 1.0 / period) if stimuli is not None else None
        if flash is not None:
            result["flash"] = _flash_cost(device, flash, frames, period, log)
        return result
    finally:
        device.close()


def _flash_cost(device, screen: dict, frames: int, period: float, log) -> dict:
    """Draw time and flip-to-flip time of a frame of a flash (``screen``'s images)."""
    stims = device._place(screen)
    log(f"drawing {frames} frames of the flash")
    draw_s, flips = [], []
    for _ in range(frames + 1):
        start = time.perf_counter()
        for stim in stims:
            stim.draw()
        draw_s.append(time.perf_counter() - start)
        flips.append(device.window.flip())
    draw_ms = 1000.0 * np.asarray(draw_s[1:])
    return {
        "draw_median_ms": float(np.median(draw_ms)),
        "draw_p99_ms": float(np.percentile(draw_ms, 99)),
        "draw_fraction_of_frame": float(np.median(draw_ms) / (1000.0 * period)),
        "frame_intervals_drawing": _interval_summary(np.diff(flips), period),
        "frame_period_ms": 1000.0 * period,
    }


def _first_flash(protocol, refresh_hz: float) -> dict | None:
    """The first timed presentation a session of this protocol shows, if any."""
    from .paradigms import PARADIGMS

    engine = PARADIGMS[protocol.paradigm].engine(
        protocol, "check1", counterbalance=0, refresh_hz=refresh_hz
    )
    engine.press("space", 0.0)
    screen = engine.screen()
    return screen if screen.get("frames") else None


def write_check(result: dict, path: Path) -> Path:
    """Write the findings as JSON (a new file; an existing one is kept as ``.previous``)."""
    path = Path(path)
    if path.exists():
        path.replace(path.with_suffix(".previous.json"))
    write_text(path, json.dumps(result, indent=2) + "\n")
    return path
