"""The PsychoPy front-end: a device for :class:`experiments.loop.SessionLoop` on a real screen.

Only this module (and :mod:`stimuli.psychopy_window`, :mod:`stimuli.measure_psychopy`) imports
PsychoPy.

**Images.** Luminance images (cd/m²) from the stimulus set are turned into display codes
through the calibration (the set's own when the session runs uncalibrated) and drawn pixel for
pixel (``units='pix'``, no interpolation, rows flipped to PsychoPy's bottom-up order). Every
image is encoded and uploaded once: the set's images when first needed, a target when its
setting changes, Spencer's comparison once per trial before its first frame. Frames only draw.

**Timing.** ``show`` returns the time of the flip that showed a screen; ``present`` shows a
blank for ``blank_before_ms``, then the flash for exactly ``frames`` flips, then the answer
prompt, and returns the onset and offset flip times and the frames dropped (counted from the
flip times). On a display whose refresh was verified, flips follow its vertical sync; on one
that was not (``--accept-mismatch refresh``, ``--allow-unmeasured-refresh``), flips are paced by
the clock at the protocol's nominal rate. The frame intervals of each flash are appended to the
session's ``_frames.tsv``, and every onset, offset and key press goes to its PsychoPy log.

**Keys.** One :class:`stimuli.psychopy_window.KeyReader` for the session, never cleared after
the first screen; comments are typed into a ``TextBox2``, which keeps case and punctuation.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from stimuli.calibration import Calibration, synthetic_calibration
from stimuli.exr import read_exr
from stimuli.psychopy_window import (
    KeyReader,
    dispatch_events,
    grab_screen,
    measure_frame_intervals,
    measure_refresh,
    open_window,
    screen_resolution,
)
from stimuli.spencer1995 import compose_comparison
from stimuli.yoshida2008 import compose_target

from .display import ScreenFacts
from .engine import Press
from .loop import Shown, count_dropped_frames

__all__ = ["PsychoPyFrontend", "ScriptedKeys"]

GAP_PX = 40  # between Yoshida's reference and targets
TEXT_RGB = (0.5, 0.5, 0.5)  # instructions and prompts: a mid grey on black
DIM_RGB = (-0.4, -0.4, -0.4)  # labels next to the stimuli: dim, to leave the judgement alone
MARKER_RGB = (0.2, 0.2, 0.2)  # the bar under the selected target
ARROWS = {"left": "←", "right": "→", "up": "↑", "down": "↓"}


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
        self.display_bits = protocol["display"]["bit_depth"] if "display" in protocol.data else 8
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
        self._logfile = None
        self.keys = None
        self.refresh_hz = protocol["display"]["refresh_hz"] if "display" in protocol.data else 60.0
        self.pace = False
        self.facts: ScreenFacts | None = None
        self.frames_path: Path | None = None
        self._exr_cache: dict[str, np.ndarray] = {}
        self._stims: dict[str, object] = {}
        self._targets: dict[str, tuple[float, object]] = {}
        self._screen: dict | None = None
        self._screenshot_taken = False
        self.shown_codes: dict[str, np.ndarray] = {}

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
        self.textbox = None
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
            with frames_path.open("a", encoding="utf-8") as handle:
                if handle.tell() == 0:
                    handle.write("what\tframe\tinterval_ms\n")
                for index, interval in enumerate(self._refresh_intervals, start=1):
                    handle.write(f"window opened\t{index}\t{1000 * interval:.3f}\n")
        self.keys.clear()

    def close(self) -> None:
        from psychopy import logging

        if self.window is not None:
            self.window.close()
            self.window = None
        if getattr(self, "_logfile", None) is not None:
            logging.flush()
            logging.root.removeTarget(self._logfile)
            self._logfile.stream.close()
            self._logfile = None

    # --- images -----------------------------------------------------------------------------

    def _exr(self, name: str) -> np.ndarray:
        if name not in self._exr_cache:
            self._exr_cache[name] = read_exr(self.stimuli / f"{name}.exr").astype(np.float64)
        return self._exr_cache[name]

    def _levels(self, luminance: np.ndarray, label: str) -> np.ndarray:
        if self.calibration is None:
            self.calibration = synthetic_calibration(
                max_cd_m2=self.protocol["display"]["max_cd_m2"],
                black_cd_m2=self.protocol["display"]["black_cd_m2"],
                bit_depth=self.display_bits,
            )
        codes, _ = self.calibration.encode(luminance)
        self.shown_codes[label] = codes
        level = codes.astype(np.float64) / (2**self.calibration.bit_depth - 1) * 2.0 - 1.0
        return np.flipud(level)

    def _image_stim(self, luminance: np.ndarray, label: str):
        from psychopy import visual

        levels = self._levels(luminance, label)
        h, w = levels.shape
        return visual.ImageStim(
            self.window,
            image=levels,
            size=(w, h),
            units="pix",
            interpolate=False,
            colorSpace="rgb",
            autoLog=False,
        )

    def _set_image(self, name: str):
        """The stimulus of a set image, encoded and uploaded on first use."""
        if name not in self._stims:
            self._stims[name] = self._image_stim(self._exr(name), name)
        return self._stims[name]

    def _target(self, side: str, disk_cd_m2: float):
        """A Yoshida target at ``disk_cd_m2``, re-encoded only when its setting changed."""
        value, stim = self._targets.get(side, (None, None))
        if value != disk_cd_m2:
            image = compose_target(
                self._exr("target_background"), self._exr("target_coverage"), disk_cd_m2
            )
            if stim is None:
                stim = self._image_stim(image, side)
            else:
                stim.image = self._levels(image, side)
            self._targets[side] = (disk_cd_m2, stim)
        return stim

    def _comparison(self, screen: dict):
        """Spencer's disc-and-annulus comparison for this trial, encoded once."""
        scene = self._exr(f"scene_{screen['context']}")
        disc, annulus = self._exr("comparison_disc"), self._exr("comparison_annulus")
        image = compose_comparison(
            scene,
            disc,
            annulus,
            screen["disc_fraction"] * self.protocol["display"]["max_cd_m2"],
            self.protocol["stimulus"]["annulus_ratio"],
        )
        if "comparison" not in self._stims:
            self._stims["comparison"] = self._image_stim(image, "comparison")
        else:
            self._stims["comparison"].image = self._levels(image, "comparison")
        return self._stims["comparison"]

    # --- screens ----------------------------------------------------------------------------

    def _draw_text(self, text: str, *, pos=(0, 0)) -> None:
        self.text.text = text
        self.text.pos = pos
        self.text.draw()

    def _draw(self, screen: dict) -> None:
        kind = screen["kind"]
        if kind in ("instructions", "block", "break", "continue", "end"):
            text = screen["text"].strip()
            legend = screen.get("legend")
            if legend:
                lines = [f"{keys}: {what}" if keys else what for keys, what in legend]
                text += "\n\nKeys\n" + "\n".join(lines) + "\nEsc: end the session"
            if "space" in screen.get("keys", {}):
                text += "\n\nPress SPACE to continue."
            self._draw_text(text)
        elif kind == "adjust":
            self._draw_adjust(screen)
        elif kind == "question":
            self._draw_text(
                f"Question {screen['number']}\n\n{screen['question']}\n\nY = yes     N = no"
            )
        elif kind == "rate":
            low, high = screen["scale"]
            self._draw_text(
                f"{screen['category']}\n\n{screen['prompt']}\n\n{low} = {screen['anchors'][0]}"
                f"   …   {high} = {screen['anchors'][1]}\n\nPress a number key from {low} to "
                f"{high}."
            )
        elif kind == "comment":
            self._draw_text(
                f"{screen['category']}: rated {screen['rating']}\n\nComment (optional); press "
                "Enter when done:",
                pos=(0, 120),
            )
            self._comment_box().draw()
        elif kind == "present":
            self._draw_text(
                f"{ARROWS['left']} left brighter      {ARROWS['down']} neither      "
                f"right brighter {ARROWS['right']}",
                pos=(0, -self.protocol["stimulus"]["window_px"]),
            )
        else:
            raise ValueError(f"no drawing for a {kind!r} screen")

    def _draw_adjust(self, screen: dict) -> None:
        reference = self._set_image(screen["reference"])
        w, h = reference.size
        offset = w + GAP_PX
        reference.pos = (0, 0)
        reference.draw()
        for side, x in (("left", -offset), ("right", offset)):
            target = self._target(side, screen[f"{side}_cd_m2"])
            target.pos = (x, 0)
            target.draw()
            self.label.text = "slightly darker" if side == "left" else "slightly brighter"
            self.label.pos = (x, -h / 2 - 36)
            self.label.draw()
        x = -offset if screen["selected"] == "left" else offset
        self.marker.width, self.marker.pos = w, (x, -h / 2 - 14)
        self.marker.draw()

    def _comment_box(self):
        from psychopy import visual

        if self.textbox is None:
            self.textbox = visual.TextBox2(
                self.window,
                text="",
                editable=True,
                size=(900, 160),
                pos=(0, -40),
                units="pix",
                letterHeight=24,
                color=TEXT_RGB,
                colorSpace="rgb",
                borderColor=DIM_RGB,
                fillColor=None,
                alignment="top-left",
                autoLog=False,
            )
        return self.textbox

    def _flip(self, *, capture: bool = False) -> float:
        if capture and self.screenshot is not None and not self._screenshot_taken:
            from PIL import Image

            self.screenshot.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(grab_screen(self.window)).save(self.screenshot)
            self._screenshot_taken = True
        return self.window.flip()

    # --- the device interface ---------------------------------------------------------------

    def show(self, screen: dict) -> float:
        if screen["kind"] == "comment" and (self._screen or {}).get("kind") != "comment":
            dispatch_events(self.window)  # characters typed before the box opened stay out
            box = self._comment_box()
            box.text = ""
            box.hasFocus = True
        self._screen = screen
        self._draw(screen)
        onset = self._flip(capture="trial" in screen)
        if "trial" in screen:
            self._log(f"screen {screen['kind']} of trial {screen['trial']} at {onset:.4f}")
        return onset

    def present(self, screen: dict) -> Shown:
        self._screen = screen
        glare = self._set_image(screen["glare_image"])
        comparison = self._comparison(screen)  # encoded and uploaded before the first frame
        w = glare.size[0]
        offset = (w + self.protocol["stimulus"]["window_gap_px"]) / 2
        left, right = (
            (glare, comparison) if screen["glare_side"] == "left" else (comparison, glare)
        )
        left.pos, right.pos = (-offset, 0), (offset, 0)
        period = 1.0 / self.refresh_hz
        left.draw()  # a first draw outside the flash: textures on the GPU before frame one
        right.draw()
        self.window.clearBuffer()
        blank = self.window.flip()
        self._wait_until(blank + screen["blank_before_ms"] / 1000.0 - (0 if self.pace else period))
        flips = []
        for frame in range(screen["frames"]):
            left.draw()
            right.draw()
            if self.pace and flips:
                self._wait_until(flips[0] + frame * period)
            flips.append(self._flip(capture=frame == 0))
        self._draw(screen)  # the answer prompt on black
        if self.pace:
            self._wait_until(flips[0] + screen["frames"] * period)
        flips.append(self.window.flip())
        shown = Shown(
            onset_s=flips[0],
            offset_s=flips[-1],
            frames=screen["frames"],
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
        from psychopy import logging

        logging.flush()
        text_entry = bool((self._screen or {}).get("text_entry"))
        while True:
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
            text = None
            if text_entry and name in ("return", "num_enter"):
                dispatch_events(self.window)  # the characters typed before Enter
                typed = self._comment_box().text.replace("\r", "")
                text = typed.rstrip("\n").replace("\n", " ")
            result.append(Press(name, t, text))
        return result

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
        with self.frames_path.open("a", encoding="utf-8") as handle:
            for index, interval in enumerate(np.diff(flips), start=1):
                handle.write(f"{what}\t{index}\t{1000 * interval:.3f}\n")

    def log(self, message: str) -> None:
        """A line in the session's PsychoPy log (written when the loop waits for keys)."""
        from psychopy import logging

        logging.exp(message)

    _log = log
