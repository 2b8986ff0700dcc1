"""The PsychoPy front-end: a device for :class:`glarelab.experiments.loop.SessionLoop` on a real
screen.

Only this module (and :mod:`glarelab.stimuli.psychopy_window`,
:mod:`glarelab.stimuli.measure_psychopy`) imports PsychoPy.

**Images.** Luminance images (cd/m²) from the stimulus set are turned into display codes
through the calibration (the set's own when the session runs uncalibrated), rounded to the
window's bits here (not by the graphics card), and drawn pixel for pixel (``units='pix'``, no
interpolation, rows flipped to PsychoPy's bottom-up order) with every edge on a whole screen
pixel (:mod:`glarelab.experiments.layout`), so each image pixel is one screen pixel for odd and
even sizes alike; :meth:`PsychoPyFrontend.check_presentation` reads a screen's images back from
the frame buffer to prove it. Every
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

**Keys.** One :class:`glarelab.stimuli.psychopy_window.KeyReader` for the session, never cleared
after the first screen. Psychtoolbox names keys by their position on a US keyboard on Linux and
macOS (a French keyboard's unshifted ``&`` key is ``1``), so a rating is its key's digit in any
layout; the keypad's digits count too. Comments are read from the window system's text events (the
keyboard's layout, case, punctuation and accents as typed, Backspace and the arrows as editing):
what was typed after the rating key's own character and before the Enter that ends the comment,
even before the comment box appeared; Shift+Enter is a new line in it. During a presentation
the keyboard is read after every frame: Escape ends it at once (the trial is logged as aborted,
the session as aborted by that Escape); other presses wait, in order, for the session loop.
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from pathlib import Path

import numpy as np
from glarelab.experiments.display import ScreenFacts
from glarelab.experiments.engine import Press
from glarelab.experiments.layout import Placement, row_layout
from glarelab.experiments.loop import Shown, count_dropped_frames
from glarelab.stimuli.calibration import Calibration, synthetic_calibration
from glarelab.stimuli.psychopy_window import (
    KeyReader,
    TextCapture,
    dispatch_events,
    grab_screen,
    key_symbols,
    measure_frame_intervals,
    measure_refresh,
    open_window,
    read_codes,
    screen_resolution,
    typed_text,
)
from glarelab.stimuli.stimulus_set import StimulusSet
from glarelab.stimuli.stimulus_set import read_codes as read_set_codes

__all__ = ["PsychoPyFrontend", "ScriptedKeys", "codes_at_bits"]

TEXT_RGB = (0.5, 0.5, 0.5)  # instructions and prompts: a mid grey on black
DIM_RGB = (-0.4, -0.4, -0.4)  # labels next to the stimuli: dim, to leave the judgement alone
MARKER_RGB = (0.2, 0.2, 0.2)  # the bar under the selected target
PAUSE_KINDS = ("instructions", "block", "break", "continue", "end")


def codes_at_bits(codes: np.ndarray, bits: int, window_bits: int) -> np.ndarray:
    """``bits``-bit codes as the nearest codes of a ``window_bits``-bit window:
    ``round(code × (2^window_bits − 1) / (2^bits − 1))``; the same codes when the bits agree.

    Examples
    --------
    >>> codes_at_bits(np.array([0, 43, 255]), 8, 10).tolist()
    [0, 173, 1023]
    >>> codes_at_bits(np.array([0, 2, 1023]), 10, 8).tolist()
    [0, 0, 255]
    """
    codes = np.asarray(codes)
    if bits == window_bits:
        return codes.astype(np.int64)
    return np.rint(codes * ((2**window_bits - 1) / (2**bits - 1))).astype(np.int64)


def _box(placement: Placement) -> tuple[int, int, int, int]:
    return placement.left_px, placement.bottom_px, placement.width_px, placement.height_px


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
    pilot
        A pilot run (PsychoPy's piloting mode): a window, never full screen, with "PILOT" in
        its top-left corner on every frame, and the log's run line says so.
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
        pilot: bool = False,
    ):
        self.protocol = protocol
        self.pilot = pilot
        fullscreen = fullscreen and not pilot
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
        self._held: list[tuple[str, float]] = []  # presses read during a presentation

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
        if self.pilot:  # drawn on every flip: no screen of a pilot passes for a session's
            width, height = self.window.size
            visual.TextStim(
                self.window,
                text="PILOT",
                height=20,
                pos=(-width / 2 + 12, height / 2 - 10),
                anchorHoriz="left",
                anchorVert="top",
                alignText="left",
                color=(0.6, -0.6, -0.6),
                colorSpace="rgb",
                autoLog=False,
            ).autoDraw = True
        self.typing = TextCapture(self.window)
        self._returns_seen = 0  # Enter presses Psychtoolbox reported (see _without_shift_enter)
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
        (the log's times restart at zero in every run); from now on every key press counts."""
        from psychopy import logging

        self.refresh_hz = refresh_hz
        self.pace = pace
        self.frames_path = frames_path
        marker = (
            f"run {run} started {started}; log time 0 = Unix time {self.clock_epoch_s():.3f} s"
            + ("; PILOT run, not a session's data" if self.pilot else "")
        )
        if log_path is not None:
            self._logfile = logging.LogFile(str(log_path), level=logging.EXP, filemode="a")
            logging.exp(marker)
            logging.exp(
                f"session log: timing at {refresh_hz:g} Hz, flips paced by "
                f"{'the clock' if pace else 'vertical sync'}; screen {self.facts}"
            )
        if frames_path is not None:
            try:
                with frames_path.open("a", encoding="utf-8") as handle:
                    if handle.tell() == 0:
                        handle.write("what\tframe\tinterval_ms\n")
                    handle.write(f"{marker}\t\t\n")
                    for index, interval in enumerate(self._refresh_intervals, start=1):
                        handle.write(f"window opened\t{index}\t{1000 * interval:.3f}\n")
            except OSError as error:
                self._warn(f"frame intervals not written to {frames_path}", error)
                self.frames_path = None
        self.keys.clear()
        dispatch_events(self.window)  # Enter pressed before now is not counted by either
        self._returns_seen = len(self.typing.returns)

    def close(self) -> None:
        if self.window is not None:
            self.window.close()
            self.window = None
        if self._logfile is not None:
            self._flush_log()
            self._close_log()

    # --- images -----------------------------------------------------------------------------

    @property
    def window_bits(self) -> int:
        """Bits per channel of the open window (the calibration's before it opens)."""
        if self.facts is not None:
            return self.facts.bits_per_channel
        return self.calibration.bit_depth if self.calibration else self.display_bits

    def _codes(self, luminance: np.ndarray) -> np.ndarray:
        """The codes the window shows for ``luminance`` (cd/m²): the calibration's, rounded to
        the window's bits here (:func:`codes_at_bits`), not by the graphics card, which
        rounds a value near a tie either way."""
        if self.calibration is None:
            self.calibration = synthetic_calibration(
                max_cd_m2=self.protocol["display"]["max_cd_m2"],
                black_cd_m2=self.protocol["display"]["black_cd_m2"],
                bit_depth=self.display_bits,
            )
        codes, _ = self.calibration.encode(luminance)
        return codes_at_bits(codes, self.calibration.bit_depth, self.window_bits)

    def _levels(self, luminance: np.ndarray) -> np.ndarray:
        level = self._codes(luminance).astype(np.float64) / (2**self.window_bits - 1) * 2.0 - 1.0
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
        self._lay_out(stims)
        return stims

    def _place(self, screen: dict) -> list:
        """The screen's images, uploaded and laid out in a row, centred, the set's gap apart."""
        stims = [self._stim(image) for image in screen.get("images", [])]
        self._lay_out(stims)
        return stims

    def _lay_out(self, stims: list) -> list[Placement]:
        """Put ``stims`` in a row on whole pixels (:func:`glarelab.experiments.layout.row_layout`):
        each image pixel on one screen pixel."""
        gap = self.set.geometry.get("gap_px", 40) if self.set else 0
        placements = row_layout(
            tuple(int(v) for v in self.window.size),
            [(int(s.size[0]), int(s.size[1])) for s in stims],
            gap_px=gap,
        )
        for stim, placement in zip(stims, placements, strict=True):
            stim.pos = placement.pos
        return placements

    # --- what the screen shows --------------------------------------------------------------

    def image_stim(self, terms):
        """The stimulus a session draws for an image ``[(name, weight), …]`` of the set."""
        return self._stim({"role": "read back", "terms": [tuple(t) for t in terms]})

    def image_size(self, image: dict) -> tuple[int, int]:
        """(width, height) in pixels of a screen's image."""
        stim = self._stim(image)
        return int(stim.size[0]), int(stim.size[1])

    def expected_codes(self, terms) -> tuple[np.ndarray, str]:
        """The codes the window must show for an image, (height, width, 3), top row first, at
        the window's bits, and where they come from: a set image as it is, encoded with the
        set's own calibration, has the codes of its PNG; any other image the calibration's
        encoding of its luminance."""
        terms = [tuple(t) for t in terms]
        set_image = len(terms) == 1 and float(terms[0][1]) == 1.0
        png = self.set.folder / f"{terms[0][0]}.png"
        if set_image and self._set_calibration_used() and png.is_file():
            codes, bits = read_set_codes(png)
            source = f"{png.name} (the set's codes)"
        else:
            codes, _ = self.calibration.encode(self.set.compose(terms))
            bits = self.calibration.bit_depth
            source = "the calibration's codes of its luminance"
        codes = codes_at_bits(codes, bits, self.window_bits)
        if codes.ndim == 2:
            codes = np.repeat(codes[..., None], 3, axis=-1)
        return codes, source

    def _set_calibration_used(self) -> bool:
        self._codes(np.zeros((1, 1)))  # the calibration of an uncalibrated session, if none yet
        return self.calibration.to_json() == self.set.manifest["calibration"]

    def read_back(self, stim, placement: Placement) -> np.ndarray:
        """Draw ``stim`` alone at ``placement`` and read its pixels back from the frame buffer
        (codes at the window's bits, top row first); the back buffer is cleared after."""
        self.window.clearBuffer()
        stim.pos = placement.pos
        stim.draw()
        shown = read_codes(self.window, _box(placement), bits=self.window_bits)
        self.window.clearBuffer()
        return shown

    def check_presentation(self, screen: dict | None) -> dict | None:
        """Draw ``screen``'s images as a session places them, read them back from the frame
        buffer and compare each with its codes (:meth:`expected_codes`); None without images.
        The back buffer is cleared after."""
        if screen is None or self.set is None or not screen.get("images"):
            return None
        stims = self._place(screen)
        placements = self._lay_out(stims)
        self.window.clearBuffer()
        for stim in stims:
            stim.draw()
        images = []
        for image, placement in zip(screen["images"], placements, strict=True):
            expected, source = self.expected_codes(image["terms"])
            if not placement.inside:
                images.append({"role": image["role"], "exact_fraction": 0.0, "off_window": True})
                continue
            shown = read_codes(self.window, _box(placement), bits=self.window_bits)
            equal = np.all(shown == expected, axis=-1)
            images.append(
                {
                    "role": image["role"],
                    "terms": [[str(n), float(w)] for n, w in image["terms"]],
                    "size_px": [placement.width_px, placement.height_px],
                    "left_bottom_px": [placement.left_px, placement.bottom_px],
                    "exact_fraction": float(equal.mean()),
                    "worst_code_difference": int(np.abs(shown - expected).max()),
                    "expected": source,
                }
            )
        self.window.clearBuffer()
        size = [int(v) for v in self.window.size]
        framebuffer = [int(v) for v in getattr(self.window, "frameBufferSize", size)]
        return {
            "screen": f"{screen['kind']} of trial {screen.get('trial')}",
            "window_px": size,
            "framebuffer_px": framebuffer,
            "window_bits": self.window_bits,
            "images": images,
            "exact": framebuffer == size and all(i["exact_fraction"] == 1.0 for i in images),
        }

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
        """Where the comment begins: after the rating key's press and its own character (in
        the keyboard's layout: ``(`` for the 5 of a French keyboard), typed since the rating
        screen appeared; characters typed before the box showed are kept."""
        dispatch_events(self.window)
        events = self.typing.events
        rating = str(screen.get("rating", ""))
        symbols = {str(s) for s in key_symbols(self.window, (rating, f"num_{rating}"))}
        for index in range(self._typing_mark, len(events)):
            if events[index][0] == "key" and events[index][1] in symbols:
                index += 1
                if index < len(events) and events[index][0] == "text":
                    index += 1  # the rating key's own character
                self._comment_start = index
                return
        for index in range(self._typing_mark, len(events)):  # no key events: by its text
            if events[index] == ("text", rating):
                self._comment_start = index + 1
                return
        self._comment_start = len(events)

    def _flip(self, *, capture: bool = False) -> float:
        if capture and self.screenshot is not None and not self._screenshot_taken:
            from glarelab.protocols.atomic import atomic_path
            from PIL import Image

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

    def _read(self, *, text_entry: bool) -> list[tuple[str, float]]:
        """New presses; on a text-entry screen without those of Shift+Enter."""
        presses = self.keys.read()
        if self.scripted is not None or not any(
            name in ("return", "num_enter") for name, _ in presses
        ):
            return presses
        kept = self._without_shift_enter(presses)
        return kept if text_entry else presses

    def _without_shift_enter(self, presses: list[tuple[str, float]]) -> list:
        """A comment's presses without an Enter pressed with Shift: that is a new line in the
        comment (its text event), not its end. Psychtoolbox does not report modifiers, so the
        n-th Enter it reports is the window system's n-th Enter key event, whose modifiers
        say."""
        if self.scripted is not None:
            return presses
        kept = []
        for name, t in presses:
            if name not in ("return", "num_enter"):
                kept.append((name, t))
                continue
            index = self._returns_seen
            self._returns_seen += 1
            deadline = time.monotonic() + 0.2
            while len(self.typing.returns) <= index and time.monotonic() < deadline:
                dispatch_events(self.window)  # its key event, a moment behind Psychtoolbox's
                time.sleep(0.001)
            if index < len(self.typing.returns) and self.typing.returns[index]:
                self._log(f"key {name} with shift at {t:.4f}: a new line in the comment")
            else:
                kept.append((name, t))
        return kept

    def _escape_during(self, screen: dict, flips: list[float]) -> None:
        """After each frame of a presentation: Escape ends it now (the trial is logged as
        aborted); other presses wait for the loop, in order."""
        if self.scripted is not None:  # a dry run's keys answer screens, one per read
            return
        self._held += self._read(text_entry=False)
        escape = next((t for name, t in self._held if name == "escape"), None)
        if escape is None:
            return
        from glarelab.experiments.loop import SessionAborted

        self.window.clearBuffer()
        end = self.window.flip()
        self._write_intervals(f"trial {screen['trial']} flash (aborted)", [*flips, end])
        self._log(
            f"trial {screen['trial']} aborted: escape at {escape:.4f} during its presentation, "
            f"ended at {end:.4f} after {len(flips)} of {screen['frames']} frames "
            f"({sum(flip > escape for flip in flips)} shown after the escape)"
        )
        self._flush_log()
        raise SessionAborted(f"escape during the presentation of trial {screen['trial']}")

    def wait_keys(self, anchor_s: float) -> list[Press]:
        self._flush_log()
        text_entry = bool((self._screen or {}).get("text_entry"))
        while True:
            if self.should_stop is not None:
                self.should_stop()
            presses, self._held = self._held + self._read(text_entry=text_entry), []
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
        while end < len(self.typing.events) and self.typing.events[end] != ("text", "\r"):
            end += 1
        self._typing_mark = min(end + 1, len(self.typing.events))  # the next screen's typing
        self._comment_start = None
        return text

    # --- records ----------------------------------------------------------------------------

    def _wait_until(self, deadline: float, *, during=None) -> None:
        from psychopy import logging

        while True:
            left = deadline - logging.defaultClock.getTime()
            if left <= 0:
                return
            if during is not None:
                during()
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
