"""A live night scene in a PsychoPy window: each refresh rendered for the tracker's gaze and pupil.

:func:`run_live` opens a window the size of the scene, starts an ioHub eye tracker
(:class:`~glarelab.frontend.eyetracker.IoHubEyeTracker`), and on every refresh takes the
tracker's last sample through the fault filter
(:class:`~glarelab.frontend.eyetracker.GazeFilter`), renders the frame for that gaze and pupil
(:class:`~glarelab.glare.night.live.LiveNight`), turns it into the display's codes and shows
it. Every frame is one row of the ``_frames.tsv`` record, written and flushed before the next
frame (:data:`FRAME_COLUMNS`); Escape ends the run as aborted, keeping every row written.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from glarelab.display.calibration import synthetic_calibration
from glarelab.files.atomic import write_text
from glarelab.frontend.eyetracker import (
    GazeFilter,
    IoHubEyeTracker,
    PupilCalibration,
    calibrate_pupil,
)
from glarelab.glare.night.live import LiveNight
from glarelab.glare.rendering.display import display_codes

__all__ = ["DROPPED_FACTOR", "FRAME_COLUMNS", "run_live"]

FRAME_COLUMNS = (
    "frame",
    "time_s",
    "gaze_x_px",
    "gaze_y_px",
    "pupil_mm",
    "target_cd_m2",
    "adaptation_cd_m2",
    "render_ms",
    "dropped",
    "valid_gaze",
    "valid_pupil",
    "clamped",
    "new_bank_entries",
)
DROPPED_FACTOR = 1.5  # a flip later than 1.5 refresh periods after the previous one lost a frame


def run_live(
    scene_cd_m2: np.ndarray,
    *,
    pixel_deg: float,
    frames_path: Path,
    tracker: str = "mouse",
    calibration: PupilCalibration | None = None,
    calibrate: bool = False,
    scotopic: bool = False,
    display_max_cd_m2: float = 100.0,
    adapted_display_cd_m2: float = 10.0,
    bits: int = 8,
    refresh_hz: float = 60.0,
    duration_s: float | None = None,
    fullscreen: bool = False,
) -> dict:
    """Show a scene live for an eye tracker's gaze and pupil until Escape (or ``duration_s``).

    Parameters
    ----------
    scene_cd_m2
        ``(H, W, 3)`` linear RGB (or ``(H, W)``), cd/m²; the window is ``W × H`` pixels.
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    frames_path
        The per-frame record, a ``..._frames.tsv`` file (its folder must exist); a
        ``..._live.json`` beside it holds the window's position, the tracker, the calibration
        and, at the end, the counts.
    tracker
        An ioHub eye tracker name (:data:`~glarelab.frontend.eyetracker.TRACKERS`) or class
        path; default ``'mouse'``.
    calibration
        Luidolt's pupil range, or None: the tracker's pupil in mm, clamped to 2-8 mm.
    calibrate
        Measure the pupil range first (:func:`~glarelab.frontend.eyetracker.calibrate_pupil`,
        a white and a black screen of 5 s), in place of ``calibration``; default False.
    scotopic
        Also Luidolt's scotopic colour of the adapted luminance (§5.4); default False.
    display_max_cd_m2, adapted_display_cd_m2
        The display's white and the adapting luminance's display luminance, cd/m².
    bits
        Bits per channel of the display's codes; default 8.
    refresh_hz
        The display's refresh rate, Hz, for counting dropped frames; default 60.
    duration_s
        End after this long, s; None (default): only Escape ends the run.
    fullscreen
        Whether the window fills the screen (the scene centred); default False.

    Returns
    -------
    dict
        ``frames``, ``dropped``, ``aborted`` (Escape), ``render_ms_median`` and the tracker's
        fault counts.

    Raises
    ------
    ValueError
        For a bad scene, number or tracker name.
    RuntimeError
        When ioHub cannot start the tracker.
    """
    from psychopy import core, event, visual

    from glarelab.frontend.window import open_window

    frames_path = Path(frames_path)
    if not frames_path.name.endswith("_frames.tsv"):
        raise ValueError(f"frames_path must end in _frames.tsv; got {frames_path.name!r}")
    live = LiveNight(
        scene_cd_m2, pixel_deg=pixel_deg, display_max_cd_m2=display_max_cd_m2,
        adapted_display_cd_m2=adapted_display_cd_m2, scotopic=scotopic,
    )  # fmt: skip
    height, width = live.shape
    lut = synthetic_calibration(
        max_cd_m2=display_max_cd_m2, black_cd_m2=display_max_cd_m2 / 1000, bit_depth=bits
    ).lut
    top = 2**bits - 1
    window, _ = open_window(bits=bits, fullscreen=fullscreen, size=(width, height))
    sidecar = frames_path.with_name(frames_path.name[: -len("_frames.tsv")] + "_live.json")
    source = None
    try:
        source = IoHubEyeTracker(window, tracker=tracker)
        if calibrate:
            source.start()
            calibration = calibrate_pupil(window, source)
        window_pos = [int(v) for v in getattr(window, "pos", (0, 0))]
        facts = {
            "tracker": tracker,
            "window_px": [width, height],
            "window_pos_px": window_pos,
            "pupil_calibration": None if calibration is None else calibration.as_dict(),
        }
        write_text(sidecar, json.dumps(facts, indent=1))
        stim = visual.ImageStim(
            window, size=(width, height), units="pix", interpolate=False, colorSpace="rgb"
        )
        gaze_filter = GazeFilter((width, height), calibration=calibration)
        source.start()
        clock = core.Clock()
        period = 1.0 / refresh_hz
        rows = dropped = 0
        times: list[float] = []
        aborted = False
        last_flip = last_now = None
        with frames_path.open("w", encoding="utf-8") as handle:
            handle.write("\t".join(FRAME_COLUMNS) + "\n")
            handle.flush()
            while duration_s is None or clock.getTime() < duration_s:
                if event.getKeys(keyList=["escape"]):
                    aborted = True
                    break
                now = clock.getTime()
                state = gaze_filter.update(now, *source.sample())
                elapsed = 0.0 if last_now is None else now - last_now  # one frame's time
                last_now = now
                frame = live.frame(
                    gaze_px=(state.gaze_y_px, state.gaze_x_px),
                    pupil_mm=state.pupil_mm,
                    frame_time_s=elapsed,
                )
                codes = np.rint(display_codes(frame.image, lut))
                # a colour array is shown as it is in [0, 1] (ImageBank.levels), rows bottom-up
                stim.image = np.flipud(codes / top)
                stim.draw()
                window.flip()
                flipped = clock.getTime()
                if last_flip is not None and flipped - last_flip < period:
                    # a screen without vertical sync (Xvfb) flips at once: never run faster
                    # than the refresh, which would starve the ioHub process of the CPU
                    core.wait(period - (flipped - last_flip), hogCPUperiod=0)
                    flipped = clock.getTime()
                lost = last_flip is not None and flipped - last_flip > DROPPED_FACTOR * period
                dropped += lost
                last_flip = flipped
                times.append(frame.render_ms)
                values = (
                    rows, f"{now:.6f}", f"{state.gaze_x_px:.2f}", f"{state.gaze_y_px:.2f}",
                    f"{state.pupil_mm:.4f}", f"{frame.target_cd_m2:.6g}",
                    f"{frame.adaptation_cd_m2:.6g}", f"{frame.render_ms:.3f}", int(lost),
                    int(state.valid_gaze), int(state.valid_pupil), int(state.clamped),
                    frame.new_entries,
                )  # fmt: skip
                handle.write("\t".join(map(str, values)) + "\n")
                handle.flush()  # the record of every frame shown survives an abort
                rows += 1
        summary = {
            "frames": rows,
            "dropped": dropped,
            "aborted": aborted,
            "render_ms_median": float(np.median(times)) if times else None,
            "disconnects": source.disconnects,
            **gaze_filter.counts(),
        }
        write_text(sidecar, json.dumps({**facts, "summary": summary}, indent=1))
        return summary
    finally:
        if source is not None:
            source.close()
        window.close()
