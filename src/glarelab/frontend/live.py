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
import math
import os
from pathlib import Path

import numpy as np

from glarelab.display.calibration import synthetic_calibration
from glarelab.files.atomic import write_text
from glarelab.frontend.eyetracker import (
    CALIBRATION_SCREEN_S,
    TRACKERS,
    GazeFilter,
    IoHubEyeTracker,
    PupilCalibration,
    calibrate_pupil,
)
from glarelab.glare._validation import check_in_range, check_positive
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


RESERVE_BYTES = 64 * 1024  # kept free beside a run's record for its last _live.json


class _Record:
    """A run's ``_frames.tsv`` and ``_live.json``: the frames file created exclusively (a
    record already there, or a run writing it now, is refused), each row written whole (a row
    the disk cannot take is cut off, never left half), and room kept for the last json."""

    def __init__(self, frames_path: Path, sidecar: Path) -> None:
        self.frames_path, self.sidecar = frames_path, sidecar
        self.reserve = frames_path.with_name(f".{frames_path.name}.reserve")
        self.rows, self.size, self._facts = 0, 0, None
        try:
            self.fd = os.open(frames_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            raise ValueError(
                f"frames_path {str(frames_path)!r} already exists (an earlier run's record, or "
                "a run writing it now): a run never writes over one; give another name or move "
                "it away"
            ) from None
        try:
            if sidecar.exists():
                raise ValueError(
                    f"{str(sidecar)!r} already exists (an earlier run's record): a run never "
                    "writes over one; give frames_path another name or move it away"
                )
            self._write(("\t".join(FRAME_COLUMNS) + "\n").encode())
            with self.reserve.open("wb") as handle:
                handle.write(bytes(RESERVE_BYTES))
        except BaseException:
            self.close(discard=True)
            raise

    def _write(self, data: bytes) -> None:
        try:
            done = 0
            while done < len(data):
                done += os.write(self.fd, data[done:])
        except OSError:
            os.ftruncate(self.fd, self.size)  # the rows written before stay whole
            raise
        self.size += len(data)

    def row(self, values) -> None:
        """Write one frame's row (on the disk before the next frame: unbuffered)."""
        self._write(("\t".join(map(str, values)) + "\n").encode())
        self.rows += 1

    def facts(self, facts: dict) -> None:
        """Write the json's facts, ``status`` ``'cut short'`` until :meth:`end`."""
        self._facts = facts
        write_text(self.sidecar, json.dumps({**facts, "status": "cut short"}, indent=1))

    def end(self, summary: dict, status: str | None = None) -> None:
        """Write the json's summary and its ``status`` (default ``'aborted'`` or ``'ended'``
        as the summary says)."""
        self.reserve.unlink(missing_ok=True)  # the room for this json on a full disk
        status = status or ("aborted" if summary.get("aborted") else "ended")
        record = {**(self._facts or {}), "status": status, "summary": summary}
        write_text(self.sidecar, json.dumps(record, indent=1))

    def close(self, *, discard: bool = False) -> None:
        """Close the frames file; ``discard``: remove the record (no frame was shown)."""
        os.close(self.fd)
        self.reserve.unlink(missing_ok=True)
        if discard:
            self.frames_path.unlink(missing_ok=True)
            if self._facts is not None:  # written by this run
                self.sidecar.unlink(missing_ok=True)


def _check_calibration(calibration: PupilCalibration | None, live: LiveNight) -> None:
    """Refuse a pupil calibration whose range leaves the renderer's bank (a frame's pupil
    beyond it would stop the viewing midway)."""
    bank = (float(live.pupils_mm[0]), float(live.pupils_mm[-1]))
    if calibration is not None and not (
        bank[0] <= calibration.range_mm[0] and calibration.range_mm[1] <= bank[1]
    ):
        raise ValueError(
            f"calibration.range_mm = {tuple(calibration.range_mm)!r} mm leaves the renderer's "
            f"pupils, {bank[0]:g}-{bank[1]:g} mm: give a range within them (Luidolt's 2-8 mm)"
        )


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
        Luidolt's pupil range, or None: the tracker's pupil in mm, clamped to 2-8 mm. Its
        ``range_mm`` must lie within the renderer's pupils (2-8 mm).
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
        _check_calibration(calibration, live)
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
        self.window_px = (win_w, win_h)
        self.frames = self.dropped = 0
        self.render_ms: list[float] = []

    @property
    def fits(self) -> bool:
        """Whether the whole scene is on the window (a smaller window cuts its edges off)."""
        height, width = self.live.shape
        left, top = self.origin_px
        return (
            left >= 0
            and top >= 0
            and left + width <= self.window_px[0]
            and top + height <= self.window_px[1]
        )

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
                now, None if x is None else x - left, None if y is None else y - top, pupil,
                blink=getattr(source, "blinking", None),
            )  # fmt: skip
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
        The per-frame record, a ``..._frames.tsv`` file (its folder must exist; neither it nor
        its ``_live.json`` may exist: a run never writes over a record, and it creates the
        file exclusively, so a second run into it at the same time is refused); a
        ``..._live.json`` beside it holds the window's position, the tracker, the calibration,
        ``status`` (``'cut short'`` until the run ends: a run killed, or whose record the disk
        could not take, keeps it; then ``'ended'`` or ``'aborted'``) and the counts;
        ``..._iohub.log``, the output of ioHub's server. A run that fails before its first
        frame leaves no record.
    tracker
        An ioHub eye tracker name (:data:`~glarelab.frontend.eyetracker.TRACKERS`) or class
        path; default ``'mouse'``.
    settings
        More of the tracker's ioHub configuration; default None.
    calibration
        Luidolt's pupil range, or None: the tracker's pupil in mm, clamped to 2-8 mm. Its
        ``range_mm`` must lie within the renderer's pupils (2-8 mm).
    calibrate
        Measure the pupil range first (:func:`~glarelab.frontend.eyetracker.calibrate_pupil`,
        a white and a black screen of ``calibration_s`` each), in place of ``calibration``;
        default False. With ``tracker='mouse'`` the pupil on the two screens is simulated
        (Moon & Spencer's of ``display_max_cd_m2`` and of a thousandth of it, the display's
        black here).
    calibration_s
        How long each calibration screen is shown, s, > 0; default 5 (Luidolt 2020 §5.2.1 ii).
    scotopic
        Also Luidolt's scotopic colour of the adapted luminance (§5.4); default False.
    display_max_cd_m2, adapted_display_cd_m2
        The display's white and the adapting luminance's display luminance, cd/m².
    bits
        Bits per channel of the display's codes; default 8.
    refresh_hz
        The display's refresh rate, Hz, > 0, for pacing and counting dropped frames; default
        60.
    duration_s
        End after this long, s, >= 0; None (default): only Escape ends the run.
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
        For a bad scene, number, tracker name, calibration range or frames path (its folder
        missing, a record there), each before the window opens.
    ~glarelab.frontend.eyetracker.TrackerError
        When ioHub cannot start the tracker.
    OSError
        When the record cannot be written (a full disk): the rows written stay whole and the
        ``_live.json`` says the run was cut short.
    """
    frames_path = Path(frames_path)
    if not frames_path.name.endswith("_frames.tsv"):
        raise ValueError(f"frames_path must end in _frames.tsv; got {frames_path.name!r}")
    if not frames_path.parent.is_dir():
        raise ValueError(
            f"frames_path {str(frames_path)!r}: its folder {str(frames_path.parent)!r} does not "
            "exist; make it first"
        )
    check_positive("refresh_hz", refresh_hz, unit="Hz")
    if duration_s is not None:
        check_in_range("duration_s", duration_s, 0.0, math.inf, unit="s")
    if calibrate:
        check_positive("calibration_s", calibration_s, unit="s")
    if not isinstance(tracker, str) or not (
        tracker in TRACKERS
        or (tracker.startswith("eyetracker.hw.") and tracker.endswith("EyeTracker"))
    ):
        raise ValueError(
            f"tracker must be one of {sorted(TRACKERS)} or an ioHub eye tracker class path; "
            f"got {tracker!r}"
        )
    if calibration is not None and not isinstance(calibration, PupilCalibration):
        raise ValueError(f"calibration must be a PupilCalibration or None; got {calibration!r}")
    live = LiveNight(
        scene_cd_m2, pixel_deg=pixel_deg, display_max_cd_m2=display_max_cd_m2,
        adapted_display_cd_m2=adapted_display_cd_m2, scotopic=scotopic,
    )  # fmt: skip
    _check_calibration(calibration, live)
    sidecar = frames_path.with_name(frames_path.name[: -len("_frames.tsv")] + "_live.json")
    record = _Record(frames_path, sidecar)  # refuses an existing record, before the window
    shown = False
    try:
        summary = _show(
            live, record, tracker=tracker, settings=settings, calibration=calibration,
            calibrate=calibrate, calibration_s=calibration_s, bits=bits, refresh_hz=refresh_hz,
            duration_s=duration_s, fullscreen=fullscreen, display_max_cd_m2=display_max_cd_m2,
        )  # fmt: skip
        shown = True
        return summary
    finally:
        record.close(discard=not shown and record.rows == 0)  # no frame shown: no record


def _show(
    live: LiveNight, record: _Record, *, tracker, settings, calibration, calibrate,
    calibration_s, bits, refresh_hz, duration_s, fullscreen, display_max_cd_m2,
) -> dict:  # fmt: skip
    """:func:`run_live` once its arguments are checked and its record claimed."""
    from psychopy import core, event

    from glarelab.frontend.window import open_window

    live.prepare()  # every bank entry a gaze on the scene can need, before the first frame
    height, width = live.shape
    lut = synthetic_calibration(
        max_cd_m2=display_max_cd_m2, black_cd_m2=display_max_cd_m2 / 1000, bit_depth=bits
    ).lut
    window, _ = open_window(bits=bits, fullscreen=fullscreen, size=(width, height))
    sidecar = record.sidecar
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
        # until the run ends, the record says it was cut short (a full disk, a kill)
        record.facts(facts)
        view = LiveView(window, live, lut=lut, bits=bits, calibration=calibration)
        source.start()
        aborted = []

        def stop():
            if event.getKeys(keyList=["escape"]):
                aborted.append(True)
            return bool(aborted)

        try:
            view.run(
                source, clock=core.Clock(), refresh_hz=refresh_hz,
                write_row=lambda values, interval: record.row(values), stop=stop,
                duration_s=duration_s,
            )  # fmt: skip
        except BaseException as error:
            reason = f"{type(error).__name__}: {error}"
            try:
                record.end(
                    {**view.summary(source), "aborted": True, "ended_by": reason}, "cut short"
                )
            except OSError:  # the json written before the first frame says 'cut short'
                pass
            if isinstance(error, OSError):
                raise OSError(
                    error.errno,
                    f"run_live could not write its record ({error.strerror or error}); it "
                    f"stopped after {view.frames} frame(s), each row whole, and "
                    f"{record.sidecar.name} says it was cut short",
                    str(record.frames_path),
                ) from error
            raise
        summary = {**view.summary(source), "aborted": bool(aborted)}
        record.end(summary)
        return summary
    finally:
        if source is not None:
            source.close()
        window.close()
