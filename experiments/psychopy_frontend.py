"""The PsychoPy front-end: a device for :class:`experiments.loop.SessionLoop` on a real screen.

Only this module (and :mod:`stimuli.psychopy_window`, :mod:`stimuli.measure_psychopy`) imports
PsychoPy.

**Images.** Luminance images (cd/m²) from the stimulus set are turned into display codes
through the calibration (the set's own when the session runs uncalibrated) and drawn pixel for
pixel (``units='pix'``, no interpolation, rows flipped to PsychoPy's bottom-up order). Every
image is encoded and uploaded once: the set's images when first needed, a target when its
setting changes, Spencer's comparison once per trial before its first frame. Frames only draw.

**Timing.** ``show`` returns the time of the flip that showed a screen; ``present`` shows a
blank for ``blank_before_ms``, then the flash for exactly ``frames`` flips (or a sequence of
images, each for its own number of flips: a night scene as the eye adapts), then the answer
prompt, and returns the onset and offset flip times and the frames dropped (counted from the
flip times). On a display whose refresh was verified, flips follow its vertical sync; on one
that was not (``--accept-mismatch refresh``, ``--allow-unmeasured-refresh``), flips are paced by
the clock at the protocol's nominal rate. The frame intervals of each flash are appended to the
session's ``_frames.tsv``, and every onset, offset and key press goes to its PsychoPy log.

**Keys.** One :class:`stimuli.psychopy_window.KeyReader` for the session, never cleared after
the first screen. Comments are read from the window system's text events (the keyboard's layout,
case, punctuation and accents as typed, Backspace and the arrows as editing): what was typed
after the rating key and before the Enter that ends the comment, even before the comment box
appeared.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from pathlib import Path

import numpy as np

from stimuli.calibration import Calibration, synthetic_calibration
from stimuli.psychopy_window import (
    KeyReader,
    TextCapture,
    dispatch_events,
    grab_screen,
    measure_frame_intervals,
    measure_refresh,
    open_window,
    screen_resolution,
    typed_text,
)
from stimuli.stimulus_set import StimulusSet

from .display import ScreenFacts
from .engine import Press
from .loop import Shown, count_dropped_frames

__all__ = ["PsychoPyFrontend", "ScriptedKeys"]

TEXT_RGB = (0.5, 0.5, 0.5)  # instructions and prompts: a mid grey on black
DIM_RGB = (-0.4, -0.4, -0.4)  # labels next to the stimuli: dim, to leave the judgement alone
MARKER_RGB = (0.2, 0.2, 0.2)  # the bar under the selected target
PAUSE_KINDS = ("instructions", "block", "break", "continue", "end")


class ScriptedKeys:
    """Key names read from a list instead of the keyboard (dry runs): one press per read, at
    the time it is read; ``escape`` when the list is used up."""

    def __init__(self, names: list[str]):
        self.names = list(names)

    def read(self) -> list[tuple[str, float]]:
        from psychopy import logging

        name = self.names.pop(0) if self.names else "escape"
        return [(name, logging.defaultClock.getTime())]

    def clear(self) -> None:
        pass


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
        Save the first trial's screen here (PNG of the back buffer, before its flip).
    size
        Window size in pixels when not full screen; default (1280, 800).
    """

    def __init__(
        self,
        protocol,
        *,
        stimuli=None,
        calibration: Calibration | None = None,
        fullscreen: bool = False,
        scripted_keys: list[str] | None = None,
        screenshot=None,
        size: tuple[int, int] = (1280, 800),
    ):
        self.protocol = protocol
        self.stimuli = Path(stimuli) if stimuli else None
        self.fullscreen = fullscreen
        self.size = size
        self.scripted = scripted_keys
        self.screenshot = Path(screenshot) if screenshot else None
        display = protocol.data.get("display")
        self.display_bits = display["bit_depth"] if display else 8
        self.calibration = calibration or self._set_calibration()
        self.calibration_used = (
            None
            if self.calibration is None
            else {
                "status": self.calibration.status,
                "label": self.calibration.label,
                "readings_sha256": self.calibration.readings_sha256,
                "source": "session" if calibration is not None else "stimulus set",
            }
        )
        self.window = None
        self.should_stop = None  # the session's check for a stop signal (raises when stopped)
        self._logfile = None
        self.keys = None
        self.refresh_hz = display["refresh_hz"] if display else 60.0
        self.pace = False
        self.facts: ScreenFacts | None = None
        self.frames_path: Path | None = None
        self.set = StimulusSet(self.stimuli) if self.stimuli else None
        self._stims: dict[tuple, object] = {}  # set images by their terms
        self._roles: dict[str, tuple[tuple, object]] = {}  # images that change: by role
        self._screen: dict | None = None
        self._screenshot_taken = False

    def _set_calibration(self) -> Calibration | None:
        if self.stimuli is None:
            return None
        manifest_path = self.stimuli / "manifest.json"
        manifest = json.loads(manifest_path.read_text())
        return Calibration.from_json(
            manifest["calibration"], source=f"{manifest_path} calibration"
        )

    # --- window ---------------------------------------------------------------------------

    def open(self) -> ScreenFacts:
        """Open the window, measure it and start reading the keyboard."""
        from psychopy import visual

        self.window, bits = open_window(
            bits=self.display_bits, fullscreen=self.fullscreen, size=self.size
        )
        self._refresh_intervals = measure_frame_intervals(self.window, frames=60)
        self.facts = ScreenFacts(
            resolution_px=screen_resolution(self.window),
            refresh_hz=measure_refresh(self.window),
            bits_per_channel=bits,
        )
        self.keys = ScriptedKeys(self.scripted) if self.scripted is not None else KeyReader()
        self.text = visual.TextStim(
            self.window,
            text="",
            height=22,
            wrapWidth=1100,
            color=TEXT_RGB,
            colorSpace="rgb",
            autoLog=False,
        )
        self.label = visual.TextStim(
            self.window, text="", height=16, color=DIM_RGB, colorSpace="rgb", autoLog=False
        )
        self.marker = visual.Rect(
            self.window,
            width=10,
            height=6,
            units="pix",
            fillColor=MARKER_RGB,
            lineColor=None,
            colorSpace="rgb",
            autoLog=False,
        )
        self.typing = TextCapture(self.window)
        self._typing_mark = 0  # where the current screen's typing began
        self._comment_start: int | None = None
        self.box = visual.Rect(
            self.window,
            width=900,
            height=160,
            pos=(0, -40),
            units="pix",
            fillColor=None,
            lineColor=DIM_RGB,
            colorSpace="rgb",
            autoLog=False,
        )
        self.typed_stim = visual.TextStim(
            self.window,
            text="",
            height=24,
            wrapWidth=880,
            pos=(-440, 30),
            anchorHoriz="left",
            anchorVert="top",
            alignText="left",
            color=TEXT_RGB,
            colorSpace="rgb",
            autoLog=False,
        )
        return self.facts

    @property
    def keyboard(self) -> str:
        return "scripted keys" if self.scripted is not None else "psychtoolbox"

    def clock_epoch_s(self) -> float:
        """Unix time at zero of the session clock (onset_s + this = wall-clock time)."""
        from psychopy import logging

        return float(logging.defaultClock.getLastResetTime())

    def start(
        self, *, refresh_hz: float, pace: bool, frames_path: Path | None, log_path: Path | None
    ) -> None:
        """Time presentations at ``refresh_hz`` (pacing flips by the clock if ``pace``); log
        to ``log_path`` and frame intervals to ``frames_path``; from now on every key press
        counts."""
        from psychopy import logging

        self.refresh_hz = refresh_hz
        self.pace = pace
        self.frames_path = frames_path
        if log_path is not None:
            self._logfile = logging.LogFile(str(log_path), level=logging.EXP, filemode="a")
            logging.exp(
                f"session log: timing at {refresh_hz:g} Hz, flips paced by "
                f"{'the clock' if pace else 'vertical sync'}; screen {self.facts}"
            )
        if frames_path is not None:
            try:
                with frames_path.open("a", encoding="utf-8") as handle:
                    if handle.tell() == 0:
                        handle.write("what\tframe\tinterval_ms\n")
                    for index, interval in enumerate(self._refresh_intervals, start=1):
                        handle.write(f"window opened\t{index}\t{1000 * interval:.3f}\n")
            except OSError as error:
                self._warn(f"frame intervals not written to {frames_path}", error)
                self.frames_path = None
        self.keys.clear()

    def close(self) -> None:
        if self.window is not None:
            self.window.close()
            self.window = None
        if self._logfile is not None:
            self._flush_log()
            self._close_log()

    # --- images -----------------------------------------------------------------------------

    def _levels(self, luminance: np.ndarray) -> np.ndarray:
        if self.calibration is None:
            self.calibration = synthetic_calibration(
                max_cd_m2=self.protocol["display"]["max_cd_m2"],
                black_cd_m2=self.protocol["display"]["black_cd_m2"],
                bit_depth=self.display_bits,
            )
        codes, _ = self.calibration.encode(luminance)
        level = codes.astype(np.float64) / (2**self.calibration.bit_depth - 1) * 2.0 - 1.0
        return np.flipud(level)

    def _image_stim(self, luminance: np.ndarray):
        from psychopy import visual

        levels = self._levels(luminance)  # (H, W), or (H, W, 3) for a colour image
        h, w = levels.shape[:2]
        return visual.ImageStim(
            self.window,
            image=levels,
            size=(w, h),
            units="pix",
            interpolate=False,
            colorSpace="rgb",
            autoLog=False,
        )

    def _stim(self, image: dict):
        """The stimulus of a screen's image, encoded and uploaded once: a set image on first
        use, an image that depends on a setting (a target, a comparison) when it changes."""
        terms = tuple((name, float(weight)) for name, weight in image["terms"])
        role = image["role"]
        if len(terms) == 1 and terms[0][1] == 1.0:  # a set image as it is
            if terms not in self._stims:
                self._stims[terms] = self._image_stim(self.set.image(terms[0][0]))
            return self._stims[terms]
        shown, stim = self._roles.get(role, (None, None))
        if shown != terms:
            luminance = self.set.compose(terms)
            if stim is None:
                stim = self._image_stim(luminance)
            else:
                stim.image = self._levels(luminance)
            self._roles[role] = (terms, stim)
        return stim

    def _frame_stims(self, step: dict) -> list:
        """A sequence frame's images, centred, uploaded now and not cached."""
        stims = []
        for image in step["images"]:
            ((name, weight),) = image["terms"]
            stims.append(self._image_stim(self.set.read(name) * float(weight)))
        return stims

    def _place(self, screen: dict) -> list:
        """The screen's images, uploaded and laid out in a row, centred, the set's gap apart."""
        stims = [self._stim(image) for image in screen.get("images", [])]
        gap = self.set.geometry.get("gap_px", 40) if self.set else 0
        width = sum(s.size[0] for s in stims) + gap * max(len(stims) - 1, 0)
        x = -width / 2
        for stim in stims:
            stim.pos = (x + stim.size[0] / 2, 0)
            x += stim.size[0] + gap
        return stims

    # --- screens ----------------------------------------------------------------------------

    def _draw_text(self, text: str, *, pos=(0, 0)) -> None:
        self.text.text = text
        self.text.pos = pos
        self.text.draw()

    def _draw(self, screen: dict, *, prompt: bool = True) -> None:
        """Images with their labels and marker; the screen's text, or its answer prompt; the
        text box of a typed answer."""
        stims = self._place(screen)
        roles = [image["role"] for image in screen.get("images", [])]
        for stim in stims:
            stim.draw()
        bottom = -max((s.size[1] for s in stims), default=0) / 2
        for role, stim in zip(roles, stims, strict=True):
            label = screen.get("labels", {}).get(role)
            if label:
                self.label.text = label
                self.label.pos = (stim.pos[0], bottom - 36)
                self.label.draw()
            if screen.get("marker") == role:
                self.marker.width, self.marker.pos = stim.size[0], (stim.pos[0], bottom - 14)
                self.marker.draw()
        text = screen.get("text", "").strip()
        if screen["kind"] in PAUSE_KINDS:
            legend = screen.get("legend")
            if legend:
                lines = [f"{keys}: {what}" if keys else what for keys, what in legend]
                text += "\n\nKeys\n" + "\n".join(lines) + "\nEsc: end the session"
            if "space" in screen.get("keys", {}):
                text += "\n\nPress SPACE to continue."
        if text:
            self._draw_text(text, pos=(0, 120) if screen.get("text_entry") else (0, 0))
        if prompt and screen.get("prompt"):
            self._draw_text(screen["prompt"], pos=(0, bottom - 60))
        if screen.get("text_entry"):
            text, cursor, _ = typed_text(self.typing.events, self._comment_start or 0)
            self.typed_stim.text = text[:cursor] + "|" + text[cursor:]
            self.box.draw()
            self.typed_stim.draw()

    def _start_comment(self, screen: dict) -> None:
        """Where the comment begins: after the rating key's own character, typed since the
        rating screen appeared (characters typed before the box showed are kept)."""
        dispatch_events(self.window)
        events = self.typing.events
        rating = str(screen.get("rating", ""))
        for index in range(self._typing_mark, len(events)):
            if events[index] == ("text", rating):
                self._comment_start = index + 1
                return
        self._comment_start = len(events)

    def _flip(self, *, capture: bool = False) -> float:
        if capture and self.screenshot is not None and not self._screenshot_taken:
            from PIL import Image

            from protocols.atomic import atomic_path

            self.screenshot.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(self.screenshot) as temporary:
                Image.fromarray(grab_screen(self.window)).save(temporary, format="PNG")
            self._screenshot_taken = True
        return self.window.flip()

    # --- the device interface ---------------------------------------------------------------

    def show(self, screen: dict) -> float:
        if screen.get("text_entry") and self._comment_start is None:
            self._start_comment(screen)
        elif not screen.get("text_entry"):
            self._typing_mark = max(self._typing_mark, len(self.typing.events))
        self._screen = screen
        self._draw(screen)
        onset = self._flip(capture="trial" in screen)
        if "trial" in screen:
            self._log(f"screen {screen['kind']} of trial {screen['trial']} at {onset:.4f}")
        return onset

    def present(self, screen: dict) -> Shown:
        """A still for ``frames`` flips, or a sequence (``screen['sequence']``: images, each for
        its ``frames`` flips), after a blank of ``blank_before_ms``; then the answer prompt."""
        self._screen = screen
        sequence = screen.get("sequence")
        steps = sequence or [{"images": screen["images"], "frames": screen["frames"]}]
        placed = []
        for step in steps:  # encoded and uploaded before the first frame
            # a sequence's frames are shown once: uploaded for it, not kept for the session
            stims = self._place(step) if not sequence else self._frame_stims(step)
            for stim in stims:  # a first draw: textures on the GPU before frame one
                stim.draw()
            placed.append((stims, step["frames"]))
        total = sum(frames for _, frames in placed)
        period = 1.0 / self.refresh_hz
        self.window.clearBuffer()
        blank = self.window.flip()
        self._wait_until(blank + screen["blank_before_ms"] / 1000.0 - (0 if self.pace else period))
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
        height = max(s.size[1] for stims, _ in placed for s in stims)
        self._draw_text(screen.get("prompt", ""), pos=(0, -height / 2 - 60))
        if self.pace:
            self._wait_until(flips[0] + total * period)
        flips.append(self.window.flip())
        shown = Shown(
            onset_s=flips[0],
            offset_s=flips[-1],
            frames=total,
            dropped_frames=count_dropped_frames(flips, self.refresh_hz),
        )
        self._write_intervals(f"trial {screen['trial']} flash", flips)
        self._log(
            f"trial {screen['trial']} flash: onset {shown.onset_s:.4f}, offset "
            f"{shown.offset_s:.4f}, {shown.shown_ms:.1f} ms for {shown.frames} frames, "
            f"{shown.dropped_frames} dropped"
        )
        return shown

    def wait_keys(self, anchor_s: float) -> list[Press]:
        self._flush_log()
        text_entry = bool((self._screen or {}).get("text_entry"))
        while True:
            if self.should_stop is not None:
                self.should_stop()
            presses = self.keys.read()
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
            self._log(f"key {name} down at {t:.4f}")
            result.append(Press(name, t))
        return result

    def typed(self) -> str:
        """The comment typed since the comment screen's rating key, up to its Enter."""
        dispatch_events(self.window)  # the characters typed before Enter
        start = self._comment_start if self._comment_start is not None else len(self.typing.events)
        text, _, _ = typed_text(self.typing.events, start)
        end = start
        while end < len(self.typing.events) and self.typing.events[end] not in (
            ("text", "\r"),
            ("text", "\n"),
        ):
            end += 1
        self._typing_mark = min(end + 1, len(self.typing.events))  # the next screen's typing
        self._comment_start = None
        return text

    # --- records ----------------------------------------------------------------------------

    def _wait_until(self, deadline: float) -> None:
        from psychopy import logging

        while True:
            left = deadline - logging.defaultClock.getTime()
            if left <= 0:
                return
            time.sleep(min(left, 0.002) if left > 0.003 else 0)

    def _write_intervals(self, what: str, flips: list[float]) -> None:
        if self.frames_path is None:
            return
        try:
            with self.frames_path.open("a", encoding="utf-8") as handle:
                for index, interval in enumerate(np.diff(flips), start=1):
                    handle.write(f"{what}\t{index}\t{1000 * interval:.3f}\n")
        except OSError as error:  # the trials matter more than the frame intervals
            self._warn(f"frame intervals no longer written to {self.frames_path}", error)
            self.frames_path = None

    def _flush_log(self) -> None:
        from psychopy import logging

        try:
            logging.flush()
        except OSError as error:  # the trials matter more than the log
            self._warn("the session log is no longer written", error)
            self._close_log()

    def _close_log(self) -> None:
        from psychopy import logging

        if self._logfile is not None:
            logging.root.removeTarget(self._logfile)
            with contextlib.suppress(OSError):
                self._logfile.stream.close()
            self._logfile = None

    @staticmethod
    def _warn(what: str, error: OSError) -> None:
        print(f"[glarelab] {what} ({error.strerror or error})", file=sys.stderr, flush=True)

    def log(self, message: str) -> None:
        """A line in the session's PsychoPy log (written when the loop waits for keys)."""
        from psychopy import logging

        logging.exp(message)

    _log = log
