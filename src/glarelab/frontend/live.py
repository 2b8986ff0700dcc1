"""A live night scene in a PsychoPy window: each refresh rendered for the tracker's gaze and pupil.

:func:`run_live` opens a window the size of the scene, starts an ioHub eye tracker
(:class:`~glarelab.frontend.eyetracker.IoHubEyeTracker`), and on every refresh takes the
tracker's last sample through the fault filter
(:class:`~glarelab.frontend.eyetracker.GazeFilter`), renders the frame for that gaze and pupil
(:class:`~glarelab.glare.night.live.LiveNight`), turns it into the display's codes and shows
it. Every frame is one row of the ``_frames.tsv`` record, written and flushed before the next
frame (:data:`FRAME_COLUMNS`); Escape ends the run as aborted, keeping every row written.

:class:`LiveView` is that loop on a window of its caller's: :func:`run_live` opens its own,
and a session's front-end (:class:`glarelab.frontend.session.PsychoPyFrontend`) shows a live
scene's free-viewing period with it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from glarelab.display.calibration import synthetic_calibration
from glarelab.files.atomic import write_text
from glarelab.frontend.eyetracker import (
    CALIBRATION_SCREEN_S,
    GazeFilter,
    IoHubEyeTracker,
    PupilCalibration,
    calibrate_pupil,
)
from glarelab.glare.night.live import LiveNight
from glarelab.glare.rendering.display import CodeTable

__all__ = ["DROPPED_FACTOR", "FRAME_COLUMNS", "LiveView", "run_live"]

FRAME_COLUMNS = (
    "frame",
    "time_s",
    "tracker_time_s",
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


class LiveView:
    """One scene shown live in a window: per refresh the tracker's last sample, through the
    fault filter, rendered, encoded, shown and recorded.

    Parameters
    ----------
    window
        The PsychoPy window (units ``'pix'``).
    live
        The scene's renderer.
    lut
        The display's 1-D look-up table, luminance fraction → code
        (:func:`~glarelab.glare.rendering.display.display_codes`).
    bits
        Bits per channel of the codes.
    calibration
        Luidolt's pupil range, or None: the tracker's pupil in mm, clamped to 2-8 mm.
    pos_px
        Centre of the scene in the window, pixels from the window's centre (PsychoPy's
        ``pos``); default the centre.
    """

    def __init__(
        self,
        window,
        live: LiveNight,
        *,
        lut: np.ndarray,
        bits: int,
        calibration: PupilCalibration | None = None,
        pos_px: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        from psychopy import visual

        height, width = live.shape
        self.window = window
        self.live = live
        self.top = 2**bits - 1
        self.encode = CodeTable(lut)  # np.rint(display_codes(...)) by a table look-up
        # each code as the texture value PsychoPy makes of code / top (float32)
        self.levels = (np.arange(lut.size) / self.top).astype(np.float32)
        self.stim = visual.ImageStim(
            window, size=(width, height), units="pix", interpolate=False, colorSpace="rgb",
            pos=pos_px, autoLog=False,
        )  # fmt: skip
        self.filter = GazeFilter((width, height), calibration=calibration)
        win_w, win_h = (int(v) for v in window.size)
        # the scene's top-left in window pixels from the window's top-left
        self.origin_px = (
            win_w / 2 + pos_px[0] - width / 2,
            win_h / 2 - pos_px[1] - height / 2,
        )
        self.frames = self.dropped = 0
        self.render_ms: list[float] = []

    def run(
        self,
        source: IoHubEyeTracker,
        *,
        clock,
        refresh_hz: float,
        write_row,
        stop,
        duration_s: float | None = None,
    ) -> list[float]:
        """Show frames until ``stop()`` is true or ``duration_s`` has passed.

        Parameters
        ----------
        source
            The tracker, recording: ``sample()``, ``time_s()``.
        clock
            The clock rows are timed on (``getTime()``, s).
        refresh_hz
            The refresh rate, Hz: flips are never faster (a screen without vertical sync), and a
            flip more than :data:`DROPPED_FACTOR` periods after the previous one lost a frame.
        write_row
            Called with each frame's values (:data:`FRAME_COLUMNS` order) and its flip
            interval, s (None for the first); it writes and flushes them.
        stop
            Called after every frame; True ends the run.
        duration_s
            End this long after the first frame's flip, s (the scene's onset: the render of
            the first frame, which builds the renderer's bank, is not viewing time); None:
            only ``stop``.

        Returns
        -------
        list of float
            The flip times, s on ``clock``.
        """
        from psychopy import core

        period = 1.0 / refresh_hz
        start = None  # the first frame's flip: the viewing runs from the scene's onset
        flips: list[float] = []
        last_now = None
        left, top = self.origin_px
        while duration_s is None or start is None or clock.getTime() - start < duration_s:
            now = clock.getTime()
            tracker_now = source.time_s()
            x, y, pupil = source.sample()
            state = self.filter.update(
                now, None if x is None else x - left, None if y is None else y - top, pupil
            )
            elapsed = 0.0 if last_now is None else now - last_now  # one frame's time
            last_now = now
            frame = self.live.frame(
                gaze_px=(state.gaze_y_px, state.gaze_x_px),
                pupil_mm=state.pupil_mm,
                frame_time_s=elapsed,
                encode=self.encode,  # encoded while the second core blurs (with acuity)
            )
            codes = frame.codes
            # a colour array is shown as it is in [0, 1] (ImageBank.levels), rows bottom-up
            self.stim.image = np.flipud(self.levels[codes])
            self.stim.draw()
            self.window.flip()
            flipped = clock.getTime()
            if flips and flipped - flips[-1] < period:
                # a screen without vertical sync (Xvfb) flips at once: never run faster
                # than the refresh, which would starve the ioHub process of the CPU
                core.wait(period - (flipped - flips[-1]), hogCPUperiod=0)
                flipped = clock.getTime()
            interval = flipped - flips[-1] if flips else None
            lost = interval is not None and interval > DROPPED_FACTOR * period
            self.dropped += lost
            flips.append(flipped)
            start = flips[0]
            self.render_ms.append(frame.render_ms)
            values = (
                self.frames, f"{now:.6f}", f"{tracker_now:.6f}",
                f"{state.gaze_x_px + left:.2f}", f"{state.gaze_y_px + top:.2f}",
                f"{state.pupil_mm:.4f}", f"{frame.target_cd_m2:.6g}",
                f"{frame.adaptation_cd_m2:.6g}", f"{frame.render_ms:.3f}", int(lost),
                int(state.valid_gaze), int(state.valid_pupil), int(state.clamped),
                frame.new_entries,
            )  # fmt: skip
            write_row(values, interval)
            self.frames += 1
            if stop():
                break
        return flips

    def summary(self, source: IoHubEyeTracker) -> dict:
        """The frames, dropped frames, median render time and the tracker's fault counts.

        Parameters
        ----------
        source
            The tracker (its disconnects).

        Returns
        -------
        dict
        """
        return {
            "frames": self.frames,
            "dropped": self.dropped,
            "render_ms_median": float(np.median(self.render_ms)) if self.render_ms else None,
            "disconnects": source.disconnects,
            **self.filter.counts(),
        }


def run_live(
    scene_cd_m2: np.ndarray,
    *,
    pixel_deg: float,
    frames_path: Path,
    tracker: str = "mouse",
    settings: dict | None = None,
    calibration: PupilCalibration | None = None,
    calibrate: bool = False,
    calibration_s: float = CALIBRATION_SCREEN_S,
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
        and, at the end, the counts; ``..._iohub.log``, the output of ioHub's server.
    tracker
        An ioHub eye tracker name (:data:`~glarelab.frontend.eyetracker.TRACKERS`) or class
        path; default ``'mouse'``.
    settings
        More of the tracker's ioHub configuration; default None.
    calibration
        Luidolt's pupil range, or None: the tracker's pupil in mm, clamped to 2-8 mm.
    calibrate
        Measure the pupil range first (:func:`~glarelab.frontend.eyetracker.calibrate_pupil`,
        a white and a black screen of ``calibration_s`` each), in place of ``calibration``;
        default False. With ``tracker='mouse'`` the pupil on the two screens is simulated
        (Moon & Spencer's of ``display_max_cd_m2`` and of a thousandth of it, the display's
        black here).
    calibration_s
        How long each calibration screen is shown, s; default 5 (Luidolt 2020 §5.2.1 ii).
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
    from psychopy import core, event

    from glarelab.frontend.window import open_window

    frames_path = Path(frames_path)
    if not frames_path.name.endswith("_frames.tsv"):
        raise ValueError(f"frames_path must end in _frames.tsv; got {frames_path.name!r}")
    live = LiveNight(
        scene_cd_m2, pixel_deg=pixel_deg, display_max_cd_m2=display_max_cd_m2,
        adapted_display_cd_m2=adapted_display_cd_m2, scotopic=scotopic,
    )  # fmt: skip
    live.prepare()  # every bank entry a gaze on the scene can need, before the first frame
    height, width = live.shape
    lut = synthetic_calibration(
        max_cd_m2=display_max_cd_m2, black_cd_m2=display_max_cd_m2 / 1000, bit_depth=bits
    ).lut
    window, _ = open_window(bits=bits, fullscreen=fullscreen, size=(width, height))
    sidecar = frames_path.with_name(frames_path.name[: -len("_frames.tsv")] + "_live.json")
    source = None
    try:
        source = IoHubEyeTracker(
            window, tracker=tracker, settings=settings,
            server_log=sidecar.with_name(sidecar.name.replace("_live.json", "_iohub.log")),
        )  # fmt: skip
        if calibrate:
            source.start()
            simulate = (
                (display_max_cd_m2, display_max_cd_m2 / 1000) if tracker == "mouse" else None
            )
            calibration = calibrate_pupil(
                window, source, screen_s=calibration_s, simulate_cd_m2=simulate
            )
        window_pos = [int(v) for v in getattr(window, "pos", (0, 0))]
        facts = {
            "tracker": tracker,
            "window_px": [width, height],
            "window_pos_px": window_pos,
            "pupil_calibration": None if calibration is None else calibration.as_dict(),
        }
        write_text(sidecar, json.dumps(facts, indent=1))
        view = LiveView(window, live, lut=lut, bits=bits, calibration=calibration)
        source.start()
        aborted = []
        with frames_path.open("w", encoding="utf-8") as handle:
            handle.write("\t".join(FRAME_COLUMNS) + "\n")
            handle.flush()

            def write_row(values, interval):
                handle.write("\t".join(map(str, values)) + "\n")
                handle.flush()  # the record of every frame shown survives an abort

            def stop():
                if event.getKeys(keyList=["escape"]):
                    aborted.append(True)
                return bool(aborted)

            view.run(
                source, clock=core.Clock(), refresh_hz=refresh_hz, write_row=write_row,
                stop=stop, duration_s=duration_s,
            )  # fmt: skip
        summary = {**view.summary(source), "aborted": bool(aborted)}
        write_text(sidecar, json.dumps({**facts, "summary": summary}, indent=1))
        return summary
    finally:
        if source is not None:
            source.close()
        window.close()
