"""The PsychoPy front-end: a device for :class:`glarelab.experiments.loop.SessionLoop` on a real
screen, made of one part per job:

- :mod:`glarelab.frontend.images`: the images, code for code, and their proof read back from
  the frame buffer;
- :mod:`glarelab.frontend.screens`: the text around them (instructions, labels, prompts, the
  comment box, the PILOT mark);
- :mod:`glarelab.frontend.keys`: key presses and typed comments;
- :mod:`glarelab.frontend.records`: the PsychoPy log and the frame intervals;
- here: the window, and the timing of screens and presentations.

**Timing.** ``show`` returns the time of the flip that showed a screen; ``present`` shows a
blank for ``blank_before_ms``, then the flash for exactly ``frames`` flips (or a sequence of
images, each for its own number of flips: a night scene as the eye adapts), then the answer
prompt, and returns the onset and offset flip times and the frames dropped (counted from the
flip times). On a display whose refresh was verified, flips follow its vertical sync; on one
that was not (``--accept-mismatch refresh``, ``--allow-unmeasured-refresh``), flips are paced by
the clock at the protocol's nominal rate. The frame intervals of each flash are appended to the
session's ``_frames.tsv``, and every onset, offset and key press goes to its PsychoPy log.
During a presentation the keyboard is read after every frame: Escape ends it at once (the
trial is logged as aborted, the session as aborted by that Escape); other presses wait, in
order, for the session loop.
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from glarelab.display.calibration import Calibration
from glarelab.display.checks import ScreenFacts
from glarelab.experiments.engine import Press
from glarelab.experiments.layout import Placement
from glarelab.experiments.loop import Shown, count_dropped_frames
from glarelab.files.inputs import loads_json
from glarelab.frontend.images import ImageBank
from glarelab.frontend.keys import SessionKeys
from glarelab.frontend.records import SessionRecords
from glarelab.frontend.screens import ScreenText
from glarelab.frontend.window import (
    dispatch_events,
    grab_screen,
    measure_frame_intervals,
    measure_refresh,
    on_display_lost,
    open_window,
    screen_resolution,
)
from glarelab.stimuli.stimulus_set import StimulusSet

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["PsychoPyFrontend"]


class PsychoPyFrontend:
    """Draws an engine's screens in a PsychoPy window and reads the keyboard.

    Parameters
    ----------
    protocol
        The session's protocol.
    stimuli
        The stimulus set folder (Yoshida, Spencer); None for a questionnaire.
    calibration
        The display calibration; None uses the set's (an uncalibrated session).
    fullscreen
        Full-screen window (lab sessions); default a ``size`` window.
    scripted_keys
        Key names to use instead of the keyboard (dry runs), consumed in order.
    screenshot
        Save the first trial's screen here (PNG of the back buffer, before its flip; a live
        scene's first frame).
    size
        Window size in pixels when not full screen; default (1280, 800).
    pilot
        A pilot run (PsychoPy's piloting mode): a window, never full screen, with "PILOT" in
        its top-left corner on every frame, and the log's run line says so.
    monitor
        A PsychoPy Monitor Center monitor (``--monitor``): the window's monitor (its size,
        width and distance; never its gamma); default the protocol's display.
    eyetracker
        The eye tracker of a live scene (``scene.live``): ``(device, settings)`` as
        :func:`glarelab.frontend.eyetracker.tracker_config` gives them; default None.
    pupil_calibration_s
        How long each screen of Luidolt's pupil range calibration is shown when the tracker
        starts (:func:`glarelab.frontend.eyetracker.calibrate_pupil`), s, > 0; default 5
        (Luidolt 2020 §5.2.1 ii). With ``MouseGaze`` the pupil of the two screens is
        simulated (Moon & Spencer's of the display's white and black).
    """

    def __init__(
        self,
        protocol: Protocol,
        *,
        stimuli=None,
        calibration: Calibration | None = None,
        fullscreen: bool = False,
        scripted_keys: list[str] | None = None,
        screenshot=None,
        size: tuple[int, int] = (1280, 800),
        pilot: bool = False,
        monitor=None,
        eyetracker: tuple[str, dict] | None = None,
        pupil_calibration_s: float | None = None,
    ):
        from glarelab.frontend.eyetracker import CALIBRATION_SCREEN_S

        self.protocol = protocol
        self.eyetracker = eyetracker
        self.tracker = None  # the ioHub eye tracker, started with the session
        if pupil_calibration_s is None:
            pupil_calibration_s = CALIBRATION_SCREEN_S
        if not (math.isfinite(pupil_calibration_s) and pupil_calibration_s > 0):
            raise ValueError(
                f"pupil_calibration_s must be a duration > 0 s; got {pupil_calibration_s!r}"
            )
        self.pupil_calibration_s = float(pupil_calibration_s)
        self.pupil_calibration = None  # Luidolt's pupil range, measured when the tracker starts
        self.monitor = monitor
        self.pilot = pilot
        fullscreen = fullscreen and not pilot
        self.stimuli = Path(stimuli) if stimuli else None
        self.fullscreen = fullscreen
        self.size = size
        self.scripted = scripted_keys
        self.screenshot = Path(screenshot) if screenshot else None
        display = protocol.data.get("display")
        self.display_bits = display["bit_depth"] if display else 8
        used = calibration or self._set_calibration()
        self.calibration_used = (
            None
            if used is None
            else {
                "status": used.status,
                "label": used.label,
                "readings_sha256": used.readings_sha256,
                "source": "session" if calibration is not None else "stimulus set",
            }
        )
        self.images = ImageBank(
            StimulusSet(self.stimuli) if self.stimuli else None,
            used,
            display=display,
            display_bits=self.display_bits,
        )
        self.records = SessionRecords()
        self.window = None
        self.should_stop = None  # the session's check for a stop signal (raises when stopped)
        self.keys: SessionKeys | None = None
        self.screen_text: ScreenText | None = None
        self.refresh_hz = display["refresh_hz"] if display else 60.0
        self.pace = False
        self.facts: ScreenFacts | None = None
        self._screen: dict | None = None
        self._screenshot_taken = False
        self.collecting = False  # the eye tracker has recorded: the session's files are kept
        self.display_lost = None  # the session's record of its end, should the display go

    def _set_calibration(self) -> Calibration | None:
        if self.stimuli is None:
            return None
        manifest_path = self.stimuli / "manifest.json"
        manifest = loads_json(manifest_path.read_text(encoding="utf-8"), source=manifest_path)
        return Calibration.from_json(
            manifest["calibration"], source=f"{manifest_path} calibration"
        )

    # --- window ---------------------------------------------------------------------------

    def open(self) -> ScreenFacts:
        """Open the window, measure it and start reading the keyboard."""
        from glarelab.frontend.monitors import window_monitor

        monitor = window_monitor(
            self.protocol.data.get("display"),
            self.protocol.data.get("viewing"),
            monitor=self.monitor,
        )
        self.window, bits = open_window(
            bits=self.display_bits, fullscreen=self.fullscreen, size=self.size, monitor=monitor
        )
        on_display_lost(self.window, lambda: self.display_lost and self.display_lost())
        self._refresh_intervals = measure_frame_intervals(self.window, frames=60)
        self.facts = ScreenFacts(
            resolution_px=screen_resolution(self.window),
            refresh_hz=measure_refresh(self.window),
            bits_per_channel=bits,
        )
        self.images.attach(self.window, self.facts)
        self.keys = SessionKeys(self.window, self.scripted, log=self.log)
        self.screen_text = ScreenText(self.window, pilot=self.pilot)
        return self.facts

    @property
    def keyboard(self) -> str:
        return "scripted keys" if self.scripted is not None else "psychtoolbox"

    def clock_epoch_s(self) -> float:
        """Unix time at zero of the session clock (onset_s + this = wall-clock time)."""
        from psychopy import logging

        return float(logging.defaultClock.getLastResetTime())

    def start(
        self,
        *,
        run: int = 1,
        started: str = "",
        refresh_hz: float,
        pace: bool,
        frames_path: Path | None,
        log_path: Path | None,
    ) -> None:
        """Time presentations at ``refresh_hz`` (pacing flips by the clock if ``pace``); log
        to ``log_path`` and frame intervals to ``frames_path``, each from a line that names the
        session's ``run`` (1, or the resume's number) and the wall-clock time it ``started``
        (the log's times restart at zero in every run); from now on every key press counts.

        Parameters
        ----------
        run
            The session's run: 1, or the resume's number; default 1.
        started
            The wall-clock time the run started, as the marker line gives it; default empty.
        refresh_hz
            The refresh rate presentations are timed at, Hz.
        pace
            Whether flips are paced by the clock instead of vertical sync.
        frames_path
            The frame-interval file; None: not written.
        log_path
            The PsychoPy log file; None: not written.
        """
        self.refresh_hz = refresh_hz
        self.pace = pace
        marker = (
            f"run {run} started {started}; log time 0 = Unix time {self.clock_epoch_s():.3f} s"
            + ("; PILOT run, not a session's data" if self.pilot else "")
        )
        from glarelab.frontend.live import FRAME_COLUMNS

        self.records.start(
            marker,
            frames_path=frames_path,
            log_path=log_path,
            log_lines=[
                f"session log: timing at {refresh_hz:g} Hz, flips paced by "
                f"{'the clock' if pace else 'vertical sync'}; screen {self.facts}"
            ],
            window_intervals=self._refresh_intervals,
            live_columns=FRAME_COLUMNS[1:] if self.eyetracker is not None else (),
        )
        if self.eyetracker is not None:
            # the run's first lines on disk before ioHub's store of the samples can fill it
            self.records.flush()
            self._start_tracker(run, frames_path)
        self.keys.start()

    def _start_tracker(self, run: int, frames_path: Path | None) -> None:
        """Launch ioHub with the eye tracker, its hdf5 store beside the session's files, the
        tracker's own calibration (not MouseGaze's), start recording, and measure Luidolt's
        pupil range (§5.2.1 ii; MouseGaze's pupil simulated), logged and kept in
        ``pupil_calibration``."""
        from glarelab.experiments.data import tracker_store_name
        from glarelab.frontend.eyetracker import IoHubEyeTracker, calibrate_pupil

        device, settings = self.eyetracker
        store = server_log = None
        if frames_path is not None:  # ioHub's server's own output (its errors) beside them
            server_log = frames_path.with_name(
                frames_path.name[: -len("_frames.tsv")] + "_iohub.log"
            )
        if frames_path is None:
            self.log("eye tracker: ioHub's hdf5 store not kept (the session writes no files)")
        else:
            try:
                import tables  # noqa: F401  (ioHub's hdf5 store is written with PyTables)
            except ImportError:
                self.log(
                    "eye tracker: ioHub's hdf5 store of the raw samples not kept: PyTables is "
                    "not installed (pip install 'glarelab[eyetracker]')"
                )
            else:
                stem = frames_path.name[: -len("_frames.tsv")]  # a store per run: ioHub
                store = frames_path.with_name(tracker_store_name(stem, run))  # rewrites one
        self.tracker = IoHubEyeTracker(
            self.window, tracker=device, settings=settings, datastore=store,
            session_code=f"run{run}", server_log=server_log,
        )  # fmt: skip
        if device != "mouse":  # the tracker's own calibration (MouseGaze needs none)
            self.tracker.device_handle.runSetupProcedure()
        self.tracker.start()
        self.collecting = True
        self.log(
            f"eye tracker {device} recording"
            + (f"; ioHub's raw events kept in {store.name} (session run{run})" if store else "")
        )
        display = self.protocol.data.get("display") or {}
        simulate = None
        if device == "mouse":  # MouseGaze's pupil is a constant 5 mm: a simulated eye's
            simulate = (float(display["max_cd_m2"]), float(display["black_cd_m2"]))
        self.log(
            f"pupil calibration: a white screen, then a black one, {self.pupil_calibration_s:g} "
            "s each (Luidolt 2020 §5.2.1 ii)"
        )
        self.records.flush()  # on disk before the screens: where a stop then came from

        def escape() -> None:  # Escape ends the session here too, as on every screen
            if self.scripted is not None:  # a dry run's keys answer screens, one per read
                return
            presses = self.keys.read(text_entry=False)
            pressed = next((t for name, t in presses if name == "escape"), None)
            if pressed is not None:
                from glarelab.experiments.loop import SessionAborted

                self.log(f"pupil calibration aborted: escape at {pressed:.4f}")
                self.records.flush()
                raise SessionAborted("escape during the pupil calibration")

        calibration = calibrate_pupil(
            self.window, self.tracker, screen_s=self.pupil_calibration_s,
            simulate_cd_m2=simulate, stop=escape,
        )  # fmt: skip
        self.pupil_calibration = calibration
        record = calibration.as_dict()
        self.log(
            f"pupil calibration: white {record['white_raw']:.4g}, black {record['black_raw']:.4g} "
            f"{record['unit']} ({record['valid_samples'][0]}, {record['valid_samples'][1]} "
            f"samples) → {record['range_mm'][0]:g}-{record['range_mm'][1]:g} mm: pupil_mm = "
            f"{record['offset_mm']:.6g} + {record['slope_mm_per_unit']:.6g} × raw, clamped"
            + (f"; simulated: {record['simulated']}" if record["simulated"] else "")
        )
        self.records.flush()

    @property
    def frames_path(self) -> Path | None:
        """The session's frame-interval file (None when not, or no longer, written)."""
        return self.records.frames_path

    def close(self) -> None:
        if self.tracker is not None:
            tracker, self.tracker = self.tracker, None
            tracker.close()
        if self.window is not None:
            self.window.close()
            self.window = None
        if self.records.logging:
            self.records.flush()
            self.records.close()

    # --- images (:mod:`glarelab.frontend.images`) --------------------------------------------

    @property
    def set(self) -> StimulusSet | None:
        """The session's stimulus set."""
        return self.images.set

    @property
    def window_bits(self) -> int:
        """Bits per channel of the open window (the calibration's before it opens)."""
        return self.images.window_bits

    @property
    def calibration(self) -> Calibration | None:
        """The calibration the images are encoded with (the protocol display's synthetic one
        once an image was encoded without one)."""
        return self.images.calibration

    def image_stim(self, terms):
        """The stimulus a session draws for an image ``[(name, weight), …]`` of the set.

        Parameters
        ----------
        terms
            The image as ``[(name, weight)]`` of the set's images.

        Returns
        -------
        psychopy.visual.ImageStim
            The stimulus.
        """
        return self.images.stim({"role": "read back", "terms": [tuple(t) for t in terms]})

    def image_size(self, image: dict) -> tuple[int, int]:
        """(width, height) in pixels of a screen's image.

        Parameters
        ----------
        image
            A screen's image (its ``terms`` and ``role``).

        Returns
        -------
        tuple of int
            ``(width, height)``, pixels.
        """
        return self.images.image_size(image)

    def expected_codes(self, terms) -> tuple[np.ndarray, str]:
        """The codes the window must show for an image (:meth:`ImageBank.expected_codes`).

        Parameters
        ----------
        terms
            The image as ``[(name, weight)]`` of the set's images.

        Returns
        -------
        codes : numpy.ndarray
            ``(height, width, 3)`` codes at the window's bits.
        source : str
            Where they come from.
        """
        return self.images.expected_codes(terms)

    def read_back(self, stim, placement: Placement) -> np.ndarray:
        """Draw ``stim`` alone at ``placement`` and read its pixels back
        (:meth:`ImageBank.read_back`).

        Parameters
        ----------
        stim
            The stimulus.
        placement : glarelab.experiments.layout.Placement
            Where to draw it.

        Returns
        -------
        numpy.ndarray
            The codes read back, top row first.
        """
        return self.images.read_back(stim, placement)

    def check_presentation(self, screen: dict | None) -> dict | None:
        """``screen``'s images drawn as a session places them and read back
        (:meth:`ImageBank.check_presentation`); None without images.

        Parameters
        ----------
        screen
            The screen to check; None: nothing.

        Returns
        -------
        dict or None
            Each image's comparison with its expected codes, or None.
        """
        return self.images.check_presentation(screen)

    # --- screens ----------------------------------------------------------------------------

    def _draw(self, screen: dict) -> None:
        """Images with their labels and marker; the screen's text, or its answer prompt; the
        text box of a typed answer."""
        stims = self.images.place(screen)
        for stim in stims:
            stim.draw()
        comment = self.keys.comment_so_far() if screen.get("text_entry") else None
        self.screen_text.draw(screen, stims, comment=comment)

    def _save_screenshot(self) -> None:
        """Save the back buffer, the pilot mark drawn on it, as ``--screenshot`` (once)."""
        from PIL import Image

        from glarelab.files.atomic import atomic_path

        mark = self.screen_text.pilot_mark  # drawn by the flip: here before the grab
        if mark is not None:
            mark.draw()
        self.screenshot.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(self.screenshot) as temporary:
            Image.fromarray(grab_screen(self.window)).save(temporary, format="PNG")
        self._screenshot_taken = True

    def _flip(self, *, capture: bool = False) -> float:
        if capture and self.screenshot is not None and not self._screenshot_taken:
            mark = self.screen_text.pilot_mark
            if mark is not None:  # not drawn twice
                mark.autoDraw = False
            self._save_screenshot()
            shown = self.window.flip()
            if mark is not None:
                mark.autoDraw = True
            return shown
        return self.window.flip()

    # --- the device interface ---------------------------------------------------------------

    def show(self, screen: dict) -> float:
        """Draw a screen and flip; a trial screen's frame is captured for the record.

        Parameters
        ----------
        screen
            The engine's screen.

        Returns
        -------
        float
            The onset flip's time, s on the session clock.
        """
        self.keys.showing(screen)
        self._screen = screen
        self._draw(screen)
        onset = self._flip(capture="trial" in screen)
        if "trial" in screen:
            self.log(f"screen {screen['kind']} of trial {screen['trial']} at {onset:.4f}")
        return onset

    def present(self, screen: dict) -> Shown:
        """A still for ``frames`` flips, or a sequence (``screen['sequence']``: images, each for
        its ``frames`` flips), after a blank of ``blank_before_ms``; then the answer prompt.

        Parameters
        ----------
        screen
            The engine's timed screen: ``frames`` (or ``sequence``) and ``blank_before_ms``.

        Returns
        -------
        glarelab.experiments.loop.Shown
            Its onset and offset flips, the frames asked for and the frames dropped.
        """
        self._screen = screen
        if screen.get("live"):
            return self._present_live(screen)
        sequence = screen.get("sequence")
        steps = sequence or [{"images": screen["images"], "frames": screen["frames"]}]
        placed = []
        for step in steps:  # encoded and uploaded before the first frame
            # a sequence's frames are shown once: uploaded for it, not kept for the session
            stims = self.images.place(step) if not sequence else self.images.frame_stims(step)
            for stim in stims:  # a first draw: textures on the GPU before frame one
                stim.draw()
            placed.append((stims, step["frames"]))
        total = sum(frames for _, frames in placed)
        period = 1.0 / self.refresh_hz
        self.window.clearBuffer()
        blank = self.window.flip()
        self._wait_until(
            blank + screen["blank_before_ms"] / 1000.0 - (0 if self.pace else period),
            during=lambda: self._escape_during(screen, []),
        )
        flips = []
        frame = 0
        for stims, frames in placed:
            for _ in range(frames):
                for stim in stims:
                    stim.draw()
                if self.pace and flips:
                    self._wait_until(flips[0] + frame * period)
                flips.append(self._flip(capture=frame == 0))
                frame += 1
                self._escape_during(screen, flips)
        height = max(s.size[1] for stims, _ in placed for s in stims)
        self.screen_text.draw_text(screen.get("prompt", ""), pos=(0, -height / 2 - 60))
        if self.pace:
            self._wait_until(flips[0] + total * period)
        flips.append(self.window.flip())
        shown = Shown(
            onset_s=flips[0],
            offset_s=flips[-1],
            frames=total,
            dropped_frames=count_dropped_frames(flips, self.refresh_hz),
        )
        self.records.write_intervals(f"trial {screen['trial']} flash", flips)
        self.log(
            f"trial {screen['trial']} flash: onset {shown.onset_s:.4f}, offset "
            f"{shown.offset_s:.4f}, {shown.shown_ms:.1f} ms for {shown.frames} frames, "
            f"{shown.dropped_frames} dropped"
        )
        return shown

    def _present_live(self, screen: dict) -> Shown:
        """A live scene's free-viewing period: every refresh rendered for the tracker's gaze
        and pupil (:class:`glarelab.frontend.live.LiveView`), each frame a row of the
        session's ``_frames.tsv``; Escape ends it, and the session, at once."""
        from psychopy import logging

        from glarelab.display.calibration import synthetic_calibration
        from glarelab.experiments.loop import SessionAborted
        from glarelab.frontend.live import LiveView
        from glarelab.glare.night.live import LiveNight
        from glarelab.protocols.rating import scene_glare_model
        from glarelab.stimuli.night import night_scene

        if self.tracker is None:
            raise ValueError(
                f"the {self.protocol.study} scene is live: run it with --eyetracker (mouse, or "
                "the ioHub configuration of a tracker)"
            )
        scene, display = self.protocol["scene"], self.protocol["display"]
        street = night_scene(self.protocol)
        live = LiveNight(
            street["img"], pixel_deg=street["pixel_deg"],
            glare_model=scene_glare_model(scene),
            display_max_cd_m2=display["max_cd_m2"],
            adapted_display_cd_m2=min(scene["adapted_display_cd_m2"], display["max_cd_m2"]),
            acuity="acuity" in screen["live"]["effects"],
            scotopic="scotopic" in screen["live"]["effects"],
        )  # fmt: skip
        self._prepare_live(live, screen)
        bits = self.window_bits
        calibration = self.calibration
        if calibration is None or len(calibration.lut) != 2**bits:
            calibration = synthetic_calibration(
                max_cd_m2=display["max_cd_m2"], black_cd_m2=display["black_cd_m2"], bit_depth=bits
            )
        view = LiveView(
            self.window, live, lut=calibration.lut, bits=bits, calibration=self.pupil_calibration
        )
        what = f"trial {screen['trial']} live"
        self.log(
            f"{what}: scene {live.shape[1]} x {live.shape[0]} px at window pixels "
            f"{view.origin_px[0]:g}, {view.origin_px[1]:g} (top-left), codes through the "
            f"{'session' if calibration is self.calibration else 'synthetic'} calibration"
        )
        if not view.fits:  # a pilot's window smaller than the scene
            cut = (
                f"the live scene ({live.shape[1]} x {live.shape[0]} px) does not fit the window "
                f"({view.window_px[0]} x {view.window_px[1]} px): its edges are not shown"
            )
            self.log(f"{what}: {cut}")
            print(f"[glarelab] warning: {cut}", file=sys.stderr, flush=True)
        self.records.flush()  # the scene's place is known before its first frame
        clock = logging.defaultClock
        period = 1.0 / self.refresh_hz
        self.window.clearBuffer()
        blank = self.window.flip()
        self._wait_until(
            blank + screen["blank_before_ms"] / 1000.0 - period,
            during=lambda: self._escape_during(screen, []),
        )
        escape: list[float] = []

        def stop() -> bool:
            if self.screenshot is not None and not self._screenshot_taken:
                view.stim.draw()  # the first frame, drawn again for --screenshot
                self._save_screenshot()
                self.window.clearBuffer()
            if self.scripted is None:
                self.keys.held += self.keys.read(text_entry=False)
                escape.extend(t for name, t in self.keys.held if name == "escape")
            return bool(escape)

        handle = self.records.open_live()
        flips = None
        try:
            flips = view.run(
                self.tracker, clock=clock, refresh_hz=self.refresh_hz,
                write_row=lambda values, interval: self.records.write_live_row(
                    handle, what, values, interval
                ),
                stop=stop, duration_s=screen["live"]["seconds"],
            )  # fmt: skip
        finally:
            if handle is not None:
                handle.close()
            if flips is None:  # a signal or a fault mid-scene: its frames so far, logged
                with contextlib.suppress(Exception):
                    self._log_live_summary(what, view, cut=True)
                    self.records.flush()
        summary = self._log_live_summary(what, view)
        if escape:
            self.window.clearBuffer()
            end = self.window.flip()
            self.log(
                f"trial {screen['trial']} aborted: escape at {escape[0]:.4f} during its live "
                f"scene, ended at {end:.4f} after {len(flips)} frames"
            )
            self.records.flush()
            raise SessionAborted(f"escape during the live scene of trial {screen['trial']}")
        height = live.shape[0]
        self.screen_text.draw_text(screen.get("prompt", ""), pos=(0, -height / 2 - 60))
        flips.append(self.window.flip())
        return Shown(
            onset_s=flips[0],
            offset_s=flips[-1],
            frames=screen["frames"],
            dropped_frames=summary["dropped"],
        )

    def _log_live_summary(self, what: str, view, *, cut: bool = False) -> dict:
        """The live scene's frames and the tracker's faults, a line of the log."""
        summary = view.summary(self.tracker)
        self.log(
            f"{what}: {summary['frames']} frames{' (cut short)' if cut else ''}, "
            f"{summary['dropped']} dropped, median render "
            f"{summary['render_ms_median']:.2f} ms; tracker faults: {summary['lost']} lost "
            f"samples, {summary['blinks']} blinks, {summary['off_screen']} off the scene, "
            f"{summary['disconnects']} disconnects"
        )
        return summary

    def _prepare_live(self, live, screen: dict) -> None:
        """Make the live scene's bank before its first frame (:meth:`LiveNight.prepare`), the
        progress on the screen; Escape ends the session between two entries."""
        from glarelab.experiments.loop import SessionAborted

        what = f"trial {screen['trial']} live"

        def preparing(made: int, total: int) -> None:
            self.screen_text.draw_text(f"Preparing the scene: {made} of {total}")
            self.window.flip()
            if self.scripted is None:
                self.keys.held += self.keys.read(text_entry=False)
                if any(name == "escape" for name, _ in self.keys.held):
                    self.log(f"trial {screen['trial']} aborted: escape while its live scene "
                             f"was prepared ({made} of {total} bank entries made)")  # fmt: skip
                    self.records.flush()
                    raise SessionAborted(f"escape while the live scene of trial "
                                         f"{screen['trial']} was prepared")  # fmt: skip

        prepared = live.prepare(progress=preparing)
        low, high = prepared.adaptation_cd_m2
        self.log(
            f"{what}: {prepared.entries} bank entries prepared in {prepared.seconds:.1f} s "
            f"({prepared.bytes / 2**20:.0f} MiB) for adapted luminances {low:.4g}-{high:.4g} "
            "cd/m²"
        )

    def _escape_during(self, screen: dict, flips: list[float]) -> None:
        """After each frame of a presentation: Escape ends it now (the trial is logged as
        aborted); other presses wait for the loop, in order."""
        if self.scripted is not None:  # a dry run's keys answer screens, one per read
            return
        self.keys.held += self.keys.read(text_entry=False)
        escape = next((t for name, t in self.keys.held if name == "escape"), None)
        if escape is None:
            return
        from glarelab.experiments.loop import SessionAborted

        self.window.clearBuffer()
        end = self.window.flip()
        self.records.write_intervals(f"trial {screen['trial']} flash (aborted)", [*flips, end])
        self.log(
            f"trial {screen['trial']} aborted: escape at {escape:.4f} during its presentation, "
            f"ended at {end:.4f} after {len(flips)} of {screen['frames']} frames "
            f"({sum(flip > escape for flip in flips)} shown after the escape)"
        )
        self.records.flush()
        raise SessionAborted(f"escape during the presentation of trial {screen['trial']}")

    def wait_keys(self, anchor_s: float) -> list[Press]:
        """Block until a key is pressed; every press not yet returned.

        Parameters
        ----------
        anchor_s
            The onset the presses are timed from, s on the session clock.

        Returns
        -------
        list of glarelab.experiments.engine.Press
            Every press not yet returned, in order, at least one.
        """
        self.records.flush()
        text_entry = bool((self._screen or {}).get("text_entry"))
        while True:
            if self.should_stop is not None:
                self.should_stop()
            presses = self.keys.held + self.keys.read(text_entry=text_entry)
            self.keys.held = []
            if presses:
                break
            if text_entry:  # the box shows what is typed: redraw it every frame
                self._draw(self._screen)
                self.window.flip()
            else:
                dispatch_events(self.window)
                time.sleep(0.001)
        result = []
        for name, t in presses:
            self.log(f"key {name} down at {t:.4f}")
            result.append(Press(name, t))
        return result

    def typed(self) -> str:
        """The comment typed since the comment screen's rating key, up to its Enter."""
        return self.keys.typed()

    # --- timing -----------------------------------------------------------------------------

    def _wait_until(self, deadline: float, *, during=None) -> None:
        from psychopy import logging

        while True:
            left = deadline - logging.defaultClock.getTime()
            if left <= 0:
                return
            if during is not None:
                during()
            time.sleep(min(left, 0.002) if left > 0.003 else 0)

    def log(self, message: str) -> None:
        """A line in the session's PsychoPy log (written when the loop waits for keys).

        Parameters
        ----------
        message
            The line.
        """
        self.records.log(message)
