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
- with a photometer (``photometer``, :func:`glarelab.display.photometer.open_photometer`), the
  luminance of black and white, full-field, against the protocol's ``max_cd_m2``, and with a
  calibration, of five codes across its range and the codes of the luminances the protocol
  names (:func:`glarelab.display.measure.protocol_luminances`: Yoshida's targets at 100 and 400
  cd/m², its background's mean) against the luminance the calibration gives
  them (its verification pass, repeated: a display that changed since it was calibrated
  fails); every reading is kept in the findings, and a photometer fault is one of them;
- with a stimulus set, what the screen shows of it: every image a session shows as it is
  (references, targets, glare and comparison images, scenes, every frame of a night scene's
  sequences, grey or colour), drawn by the session's own
  front-end in each place of the first trial's row (:mod:`glarelab.experiments.layout`), read back
  from the frame buffer (:func:`glarelab.frontend.window.read_framebuffer_codes`, at 16 bits per
  channel, so a 10-bit window's codes come back whole) and compared with the set's codes rounded to
  the window's bits: the share of pixels exactly equal and the worst difference in codes, per
  image (:func:`read_back_images`);
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
from typing import TYPE_CHECKING

import numpy as np

from glarelab.display.checks import check_screen, refuse_other_display, timing_rate_hz
from glarelab.experiments.engine import first_screen
from glarelab.experiments.layout import row_layout
from glarelab.experiments.loop import DROPPED_INTERVAL
from glarelab.files.atomic import write_text
from glarelab.frontend.session import PsychoPyFrontend
from glarelab.frontend.window import measure_frame_intervals
from glarelab.stimuli.stimulus_set import check_set_protocol, prove_stimulus_set

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["check_display", "read_back_images", "write_check"]

# the kinds of image a session shows as they are (a night scene's frames are shown once each, in
# its sequence); a set's components are parts the sessions compose images from, never shown alone
SHOWN_KINDS = ("reference", "target", "glare", "comparison", "scene", "night")
SEQUENCE_KINDS = ("night",)  # read from their files when shown, not kept
PART_KINDS = ("component",)


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
    protocol: Protocol,
    *,
    stimuli: Path | None = None,
    calibration=None,
    frames: int = 600,
    fullscreen: bool = True,
    photometer=None,
    patch_protocol=None,
    log=print,
    monitor=None,
    accept_mismatch: bool = False,
) -> dict:
    """Measure the display a protocol's sessions will run on; return the findings.

    Parameters
    ----------
    protocol
        The protocol whose display is checked (its ``[display]`` table).
    stimuli
        A stimulus set of the protocol (its manifest names the protocol it was built from):
        read its images back, and for a flashing protocol also measure a frame of its flash.
    calibration
        The calibration the sessions will use (recorded; its images are encoded with it): one
        of the protocol's display, its bit depth and white
        (:func:`glarelab.display.checks.refuse_other_display`).
    frames
        Flips per measurement; default 600 (10 s at 60 Hz).
    fullscreen
        Measure a full-screen window (as a session runs); default True.
    photometer
        An open :class:`~glarelab.display.photometer.Photometer`: also measure luminances.
    patch_protocol
        How the photometer reads each patch (:class:`~glarelab.display.photometer.PatchProtocol`).
    log
        Called with each finding's line as it is measured; default :func:`print`.
    monitor
        The PsychoPy Monitor Center monitor of the window (``--monitor``); default the
        protocol's display.
    accept_mismatch
        Check although the calibration's white is not the protocol display's (recorded in the
        findings' ``calibration`` check); default False.

    Returns
    -------
    dict
        The findings, as :func:`write_check` records them.

    Raises
    ------
    ValueError
        Before the window opens: for a protocol without a display, ``frames`` below 10, a
        stimulus set built from another protocol, or a calibration of another display (a bit
        depth not the protocol's, or a white not its own unless ``accept_mismatch``).
    """
    if not protocol.data.get("display"):
        raise ValueError(f"the {protocol.study} protocol describes no display to check")
    if frames < 10:
        raise ValueError(f"frames must be at least 10; got {frames!r}")
    if stimuli is not None:  # a set of another protocol: named as such, not by a missing image
        check_set_protocol(protocol, Path(stimuli))
        # a file swapped or edited in the set: named as the set's, not read back as the
        # screen's fault (a swapped PNG gave "0.667 % exact, worst difference 201 codes")
        problems = prove_stimulus_set(Path(stimuli))
        if problems:
            raise ValueError(
                f"the stimulus set {stimuli} fails its manifest: " + "; ".join(problems[:5])
            )
    fits = []
    if calibration is not None:  # the check is filed as this display's, under its calibration
        fits = [
            refuse_other_display(
                protocol,
                calibration,
                accept_mismatch=accept_mismatch,
                codes="the check would be recorded under that display's calibration",
                encoded="the check would be recorded under another display's calibration",
                anyway="check anyway with --accept-mismatch calibration (recorded in the check)",
            )
        ]
    device = PsychoPyFrontend(
        protocol,
        stimuli=stimuli,
        calibration=calibration,
        fullscreen=fullscreen,
        scripted_keys=[],
        monitor=monitor,
    )
    log("opening the window and measuring the refresh rate")
    facts = device.open()
    try:
        window = device.window
        checks = fits + check_screen(protocol, facts)
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
        if photometer is not None:
            result["photometer"] = _photometer_check(
                protocol, window, photometer, calibration, patch_protocol, records, log
            )
        if stimuli is not None:
            log("drawing every image of the stimulus set and reading the screen back")
            screen = first_screen(_engine(protocol, 1.0 / period))
            result["images"] = read_back_images(device, screen)
            result["images_exact"] = bool(result["images"]) and all(
                r["exact_fraction"] == 1.0 for r in result["images"]
            )
        flash = _first_flash(protocol, 1.0 / period) if stimuli is not None else None
        if flash is not None:
            result["flash"] = _flash_cost(device, flash, frames, period, log)
        return result
    finally:
        device.close()


PHOTOMETER_TOLERANCE = 0.03  # as the calibration's verification pass (glarelab.display.measure)


def _photometer_check(
    protocol: Protocol, window, meter, calibration, patch_protocol, records, log
) -> dict:
    """Black, white and (with a calibration) five codes across its range, read by the
    photometer; adds its checks to ``records``."""
    from glarelab.display.checks import Check
    from glarelab.display.photometer import PhotometerError
    from glarelab.frontend.measure import read_code_luminances

    bits = calibration.bit_depth if calibration is not None else protocol["display"]["bit_depth"]
    top = 2**bits - 1
    codes = [0, top]
    if calibration is not None:
        from glarelab.display.measure import protocol_luminances

        black, white = calibration.black_cd_m2, calibration.max_cd_m2
        targets = np.geomspace(max(2 * black, 0.01 * white), 0.9 * white, 5).tolist()
        targets += [t for t in protocol_luminances(protocol) if 2 * black < t < white]
        codes += sorted({int(c) for c in calibration.encode(np.array(targets))[0]} - set(codes))
    kept: list[dict] = []
    found = {"instrument": meter.describe(), "readings": kept, "fault": None}
    log(f"reading {len(codes)} patches with the {meter.model}")
    try:
        read = read_code_luminances(
            window, meter, codes, bit_depth=bits, patch_protocol=patch_protocol, keep=kept.append
        )
    except PhotometerError as fault:
        found["fault"] = str(fault)
        records.append(Check("photometer", "readings", f"fault: {fault}", False).__dict__)
        return found
    found["patches"] = read
    found["black_cd_m2"], found["white_cd_m2"] = read[0]["cd_m2"], read[1]["cd_m2"]
    wanted = float(protocol["display"]["max_cd_m2"])
    records.append(
        Check(
            "white luminance",
            f">= {wanted:g} cd/m²",
            f"{read[1]['cd_m2']:.4g} cd/m²",
            read[1]["cd_m2"] >= (1 - PHOTOMETER_TOLERANCE) * wanted,
        ).__dict__
    )
    if calibration is not None:
        for patch in read:
            expected = float(calibration.decode(np.array([patch["code"]]))[0])
            patch["calibration_cd_m2"] = expected
            patch["relative_error"] = abs(patch["cd_m2"] - expected) / max(expected, 1e-12)
        worst = max(patch["relative_error"] for patch in read)
        found["max_relative_error"] = worst
        records.append(
            Check(
                "luminance against the calibration",
                f"within {100 * PHOTOMETER_TOLERANCE:g} %",
                f"worst {100 * worst:.2f} %",
                worst <= PHOTOMETER_TOLERANCE,
            ).__dict__
        )
    return found


def _flash_cost(device, screen: dict, frames: int, period: float, log) -> dict:
    """Draw time and flip-to-flip time of a frame of a flash (``screen``'s images)."""
    stims = device.images.place(screen)
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


def _engine(protocol: Protocol, refresh_hz: float):
    from glarelab.experiments.paradigms import paradigm_run

    return paradigm_run(protocol).engine(
        protocol, "check1", counterbalance=0, refresh_hz=refresh_hz
    )


def _first_flash(protocol: Protocol, refresh_hz: float) -> dict | None:
    """The first timed presentation a session of this protocol shows, if any."""
    engine = _engine(protocol, refresh_hz)
    engine.press("space", 0.0)
    screen = engine.screen()
    return screen if screen.get("frames") else None


def read_back_images(device, screen: dict | None, *, names: list[str] | None = None) -> list[dict]:
    """Draw each image of the device's stimulus set in each place of ``screen``'s row, read it
    back from the frame buffer and compare it with the set's codes.

    Parameters
    ----------
    device
        An open :class:`glarelab.frontend.session.PsychoPyFrontend` with a stimulus
        set.
    screen
        The screen whose row gives the places (the first trial's,
        :func:`glarelab.experiments.engine.first_screen`); None: each image alone at the centre.
    names
        The set's images to draw; default every image a session shows as it is (not the
        components it composes images from).

    Returns
    -------
    list of dict
        Per image: ``image``, ``places`` (how many it was drawn in), ``pixels`` (per place),
        ``exact_fraction`` (the share of pixels whose three channels equal the expected codes,
        the lowest over the places), ``worst_code_difference`` (at the window's bits),
        ``first_difference`` (``[row, column, shown, expected]`` of the first pixel that
        differs, in the image's own coordinates, or None), ``expected`` (what the codes were
        compared with) and ``window_bits``.
    """
    images = device.set.manifest["images"]
    records = []
    if names is None:
        names = sorted(n for n, r in images.items() if r["kind"] in SHOWN_KINDS)
        for name in sorted(images):  # a kind this check cannot show is not passed over
            kind = images[name]["kind"]
            if kind not in SHOWN_KINDS and kind not in PART_KINDS:
                records.append(_not_shown(name, kind, device.facts.bits_per_channel))
    slots = [] if screen is None else [device.image_size(i) for i in screen["images"]]
    gap = device.set.geometry.get("gap_px", 40)
    window = device.window
    size = tuple(int(v) for v in window.size)
    framebuffer = tuple(int(v) for v in getattr(window, "frameBufferSize", size))
    for name in names:
        terms = [(name, 1.0)]
        if images[name]["kind"] in SEQUENCE_KINDS:  # as a sequence shows it: read, not kept
            stim = device.images.image_stim(device.set.read(name))
        else:
            stim = device.image_stim(terms)
        expected, source = device.expected_codes(terms)
        own = (int(stim.size[0]), int(stim.size[1]))
        places = [[*slots[:i], own, *slots[i + 1 :]] for i in range(len(slots))] or [[own]]
        record = {
            "image": name,
            "places": len(places),
            "pixels": own[0] * own[1],
            "exact_fraction": 1.0,
            "worst_code_difference": 0,
            "first_difference": None,
            "expected": source,
            "window_bits": device.facts.bits_per_channel,
        }
        for index, sizes in enumerate(places):
            placement = row_layout(size, sizes, gap_px=gap)[index]
            if framebuffer != size:  # a HiDPI scale: the window's pixels are not the screen's
                record |= {
                    "exact_fraction": 0.0,
                    "first_difference": None,
                    "problem": f"the {size[0]} × {size[1]} px window has {framebuffer[0]} × "
                    f"{framebuffer[1]} frame-buffer pixels: images are scaled, not drawn 1:1",
                }
                break
            if not placement.inside:
                record |= {
                    "exact_fraction": 0.0,
                    "problem": f"place {index + 1} of the row is off the {size[0]} × {size[1]} "
                    "px window",
                }
                break
            shown = device.read_back(stim, placement)
            equal = np.all(shown == expected, axis=-1)
            worst = int(np.abs(shown - expected).max())
            if equal.mean() < record["exact_fraction"]:
                record["exact_fraction"] = float(equal.mean())
            record["worst_code_difference"] = max(record["worst_code_difference"], worst)
            if record["first_difference"] is None and not equal.all():
                row, column = (int(v) for v in np.argwhere(~equal)[0])
                record["first_difference"] = [
                    row,
                    column,
                    shown[row, column].tolist(),
                    expected[row, column].tolist(),
                ]
        records.append(record)
    return records


def _not_shown(name: str, kind: str, bits: int) -> dict:
    """The record of a set image whose kind this check cannot show: a failure, never exact."""
    return {
        "image": name,
        "places": 0,
        "pixels": 0,
        "exact_fraction": 0.0,
        "worst_code_difference": None,
        "first_difference": None,
        "expected": None,
        "window_bits": bits,
        "problem": f"its kind {kind!r} is not one check-display can show "
        f"({', '.join(SHOWN_KINDS)}): not read back",
    }


def write_check(result: dict, path: Path) -> Path:
    """Write the findings as JSON (a new file; an existing one is kept as ``.previous``).

    Parameters
    ----------
    result
        The findings (:func:`check_display`).
    path
        The JSON file, written whole or not at all.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    if path.exists():
        path.replace(path.with_suffix(".previous.json"))
    write_text(path, json.dumps(result, indent=2) + "\n")
    return path
