"""The PsychoPy front-end: draws what an engine asks for and reads keys. Only this module (and
the calibration helper) imports PsychoPy.

Luminance images (cd/m²) from the stimulus set are turned into display codes through the
calibration (the set's own when the session runs uncalibrated) and drawn pixel for pixel
(``units='pix'``, no interpolation, rows flipped to PsychoPy's bottom-up order). The window
asks for 10 bits per channel; where it cannot have them it says so at start-up and the session
records the bits actually given. The refresh rate is measured at start; frames dropped during
each trial are counted into the row.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from stimuli.calibration import Calibration, synthetic_calibration
from stimuli.exr import read_exr
from stimuli.spencer1995 import compose_comparison
from stimuli.yoshida2008 import compose_target

from .session import SessionAborted

__all__ = ["PsychoPyFrontend"]

GAP_PX = 40


class PsychoPyFrontend:
    """Draws an engine's screens in a PsychoPy window.

    Parameters
    ----------
    protocol
        The session's protocol.
    stimuli
        The stimulus set folder (Yoshida, Spencer).
    calibration
        The display calibration; None uses the set's (an uncalibrated session).
    fullscreen
        Full-screen window (lab sessions); default a 1280 × 800 window.
    scripted_keys
        Key names to use instead of the keyboard (dry runs, tests), consumed in order.
    screenshot
        Save the first trial screen here (PNG of the back buffer, before the flip).
    """

    def __init__(
        self,
        protocol,
        *,
        stimuli=None,
        calibration=None,
        fullscreen=False,
        scripted_keys=None,
        screenshot=None,
        size=(1280, 800),
    ):
        self.protocol = protocol
        self.stimuli = Path(stimuli) if stimuli else None
        self.fullscreen = fullscreen
        self.size = size
        self.scripted = list(scripted_keys) if scripted_keys is not None else None
        self.screenshot = Path(screenshot) if screenshot else None
        self.refresh_hz = 60.0
        self.bit_depth = None
        self.window = None
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
        self.display_bits = protocol["display"]["bit_depth"] if "display" in protocol.data else 8
        self._cache: dict[str, np.ndarray] = {}
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

    def open(self) -> None:
        from psychopy import visual

        common = dict(
            size=self.size,
            fullscr=self.fullscreen,
            units="pix",
            color=(-1, -1, -1),
            colorSpace="rgb",
            allowGUI=False,
            useFBO=False,
            checkTiming=False,
        )
        try:
            self.window = visual.Window(bpc=(10, 10, 10), **common)
        except RuntimeError:
            self.window = visual.Window(**common)
        self.bit_depth = self._red_bits()
        if self.bit_depth < self.display_bits:
            print(
                f"[glarelab] the window gives {self.bit_depth} bits per channel, not the "
                f"display's {self.display_bits}: codes are rounded to {self.bit_depth} bits "
                "(recorded in the session sidecar)",
                file=sys.stderr,
            )
        rate = self.window.getActualFrameRate(nIdentical=10, nMaxFrames=120, nWarmUpFrames=10)
        self.refresh_hz = float(rate) if rate else 60.0
        self.window.recordFrameIntervals = True
        self.text = visual.TextStim(
            self.window,
            text="",
            height=22,
            wrapWidth=1000,
            color=(0.6, 0.6, 0.6),
            colorSpace="rgb",
        )

    def _red_bits(self) -> int:
        import ctypes

        from pyglet import gl

        value = ctypes.c_int()
        gl.glGetIntegerv(gl.GL_RED_BITS, ctypes.byref(value))
        return int(value.value) or 8

    def close(self) -> None:
        if self.window is not None:
            self.window.close()
            self.window = None

    # --- drawing --------------------------------------------------------------------------

    def _exr(self, name: str) -> np.ndarray:
        if name not in self._cache:
            self._cache[name] = read_exr(self.stimuli / f"{name}.exr").astype(np.float64)
        return self._cache[name]

    def _image(self, luminance: np.ndarray, pos: tuple[float, float], label: str):
        from psychopy import visual

        if self.calibration is None:
            self.calibration = synthetic_calibration(
                max_cd_m2=self.protocol["display"]["max_cd_m2"],
                black_cd_m2=self.protocol["display"]["black_cd_m2"],
                bit_depth=self.display_bits,
            )
        codes, _ = self.calibration.encode(luminance)
        self.shown_codes[label] = codes
        level = codes.astype(np.float64) / (2**self.calibration.bit_depth - 1) * 2.0 - 1.0
        h, w = level.shape
        return visual.ImageStim(
            self.window,
            image=np.flipud(level),
            size=(w, h),
            pos=pos,
            units="pix",
            interpolate=False,
            colorSpace="rgb",
        )

    def _draw(self, screen: dict) -> None:
        from psychopy import visual

        kind = screen["kind"]
        if kind in ("instructions", "question", "rate", "comment"):
            if kind == "instructions":
                self.text.text = screen["text"].strip() + "\n\n(space to start)"
            elif kind == "question":
                self.text.text = f"{screen['question']}\n\n y = yes    n = no"
            elif kind == "rate":
                low, high = screen["scale"]
                self.text.text = (
                    f"{screen['category']}\n\n{screen['prompt']}\n\n{low} = "
                    f"{screen['anchors'][0]} … {high} = {screen['anchors'][1]}"
                )
            else:
                self.text.text = (
                    f"{screen['category']}: {screen['rating']}\n\nComment "
                    f"(optional, Enter to finish):\n{screen['typed']}_"
                )
            self.text.draw()
        elif kind == "adjust":
            reference = self._exr(screen["reference"])
            background = self._exr("target_background")
            coverage = self._exr("target_coverage")
            w = reference.shape[1]
            offset = w + GAP_PX
            self._image(
                compose_target(background, coverage, screen["left_cd_m2"]), (-offset, 0), "left"
            ).draw()
            self._image(reference, (0, 0), "reference").draw()
            self._image(
                compose_target(background, coverage, screen["right_cd_m2"]), (offset, 0), "right"
            ).draw()
            x = -offset if screen["selected"] == "left" else offset
            visual.Line(
                self.window,
                start=(x - w / 2, -w / 2 - 12),
                end=(x + w / 2, -w / 2 - 12),
                lineColor=(-1, -1, -1),
                lineWidth=3,
                units="pix",
            ).draw()
        elif kind == "present":
            glare = self._exr(screen["glare_image"])
            scene = self._exr(f"scene_{screen['context']}")
            disc, annulus = self._exr("comparison_disc"), self._exr("comparison_annulus")
            maximum = self.protocol["display"]["max_cd_m2"]
            comparison = compose_comparison(
                scene,
                disc,
                annulus,
                screen["disc_fraction"] * maximum,
                self.protocol["stimulus"]["annulus_ratio"],
            )
            w = glare.shape[1]
            offset = (w + self.protocol["stimulus"]["window_gap_px"]) / 2
            left, right = (
                (glare, comparison) if screen["glare_side"] == "left" else (comparison, glare)
            )
            self._image(left, (-offset, 0), "left").draw()
            self._image(right, (offset, 0), "right").draw()

    def _save_screenshot(self) -> None:
        if self.screenshot is not None and not self.screenshot.exists():
            from PIL import Image

            frame = np.asarray(self.window.getMovieFrame(buffer="back"))
            self.screenshot.parent.mkdir(parents=True, exist_ok=True)
            Image.fromarray(frame).save(self.screenshot)

    def _keys(self) -> list[tuple[str, float]]:
        from psychopy import core, event

        if self.scripted is not None:
            if not self.scripted:
                return [("escape", 0.0)]
            return [(self.scripted.pop(0), 0.1)]
        clock = core.Clock()
        return [(k, t) for k, t in event.waitKeys(timeStamped=clock)]

    # --- the loop -------------------------------------------------------------------------

    def run(self, engine, on_row) -> None:
        if self.window is None:
            self.open()
        try:
            while not engine.done:
                screen = engine.screen()
                dropped_before = self.window.nDroppedFrames
                if screen["kind"] == "present":  # an exact number of frames, then blank
                    for frame in range(screen["frames"]):
                        self._draw(screen)
                        if frame == 0:
                            self._save_screenshot()
                        self.window.flip()
                    self.text.text = "left brighter ←    neither ↓    → right brighter"
                    self.text.draw()
                    self.window.flip()
                else:
                    self._draw(screen)
                    if screen["kind"] == "adjust":
                        self._save_screenshot()
                    self.window.flip()
                for key, t in self._keys():
                    if key == "escape":
                        raise SessionAborted()
                    row = engine.press(key, t)
                    if row is not None:
                        row["dropped_frames"] = self.window.nDroppedFrames - dropped_before
                        on_row(row)
        finally:
            self.close()
