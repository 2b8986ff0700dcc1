"""The session loop: screens from an engine, key presses from a device, rows to disk.

One loop serves the lab (a PsychoPy window), dry runs (scripted keys) and simulated observers,
so their data take one path. A *device* draws screens and collects key presses; it never
clears them. The loop decides what each press means:

- every press is handled once, in the order pressed, however many arrive between two redraws
  (three quick ↑ are three steps);
- a press counts only from the onset of the trial's stimulus (the flip that first showed it;
  for a screen that is not part of a trial, its own onset; for a presentation whose screen
  says ``answer_after_presentation``, the flip that ended it) and only on a key the screen
  takes;
  every other press is recorded in the next row's ``ignored_keys``, with its time from that
  trial's onset (negative: before it), so no press is lost without a trace;
- ``time_s`` is the time from the trial's onset to the press, on the device's clock
  (key-down time stamps, not the time the loop got to them);
- a timed presentation (Spencer's flash) is judged from its flip times: frames dropped, the
  measured duration against its frames; the engine is told, and the row records it;
- Escape ends the session at once (:class:`SessionAborted`); what was recorded stays;
- every screen that waits for the space bar (instructions, blocks, breaks) logs its onset and
  the press that ended it;
- a break screen after every ``break_every`` trials, a "continue" screen when a session is
  resumed, an end screen when it is complete.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol as TypingProtocol

import numpy as np

from glarelab.experiments.engine import Engine, Press, normalise_key

__all__ = [
    "Device",
    "SessionAborted",
    "SessionLoop",
    "Shown",
    "count_dropped_frames",
    "presentation_ok",
]

PAUSE_KINDS = ("instructions", "block", "break", "continue", "end")
DROPPED_INTERVAL = 1.5  # an interval over 1.5 frames lost at least one frame


class SessionAborted(BaseException):
    """The participant or experimenter ended the session (Escape, SIGINT, SIGTERM).

    A BaseException, as KeyboardInterrupt is, so that no ``except Exception`` in a library the
    session calls (PsychoPy opening its window) can swallow it."""


@dataclass(frozen=True)
class Shown:
    """When a device showed a screen: the onset flip, and for a timed presentation the flip
    that ended it, the frames asked for and the frames dropped.

    Attributes
    ----------
    onset_s
        The flip that first showed the screen, s on the session clock.
    offset_s
        The flip that ended a timed presentation, s; None for a static screen.
    frames
        The frames a timed presentation asked for; None for a static screen.
    dropped_frames
        Frames dropped while it was on (:func:`count_dropped_frames`); default 0.
    """

    onset_s: float
    offset_s: float | None = None
    frames: int | None = None
    dropped_frames: int = 0

    @property
    def shown_ms(self) -> float | None:
        return None if self.offset_s is None else 1000.0 * (self.offset_s - self.onset_s)


class Device(TypingProtocol):
    """What the loop needs of a front-end."""

    def show(self, screen: dict) -> float:
        """Draw a screen; return the time of the flip that showed it (s, session clock).

        Parameters
        ----------
        screen
            The engine's screen (``kind``, ``keys``, images and what the front-end needs).

        Returns
        -------
        float
            The onset flip's time, s.
        """

    def present(self, screen: dict) -> Shown:
        """Show a timed presentation (``screen['frames']`` frames after a blank of
        ``screen['blank_before_ms']``), then its answer prompt; return its flip times.

        Parameters
        ----------
        screen
            The engine's timed screen: ``frames`` and ``blank_before_ms`` besides its
            ``kind``, ``keys`` and images.

        Returns
        -------
        Shown
            Its onset and offset flips and the frames dropped.
        """

    def wait_keys(self, anchor_s: float) -> list[Press]:
        """Block until at least one key press is available; return every press not yet
        returned, in the order pressed. ``anchor_s`` is the onset the loop times from.

        Parameters
        ----------
        anchor_s
            The onset the loop times the presses from, s on the session clock.

        Returns
        -------
        list of Press
            The presses, at least one.
        """

    def typed(self) -> str:
        """The text typed on the current text-entry screen, up to its Enter."""


def count_dropped_frames(flip_times_s, refresh_hz: float) -> int:
    """Frames lost between consecutive flips: an interval of ``k`` frame periods (over 1.5)
    lost ``k - 1`` frames.

    Parameters
    ----------
    flip_times_s
        The flips' times, s, in order.
    refresh_hz
        The display's refresh rate, Hz.

    Returns
    -------
    int
        Frames lost.

    Examples
    --------
    >>> count_dropped_frames([0.0, 0.0167, 0.0333, 0.0667, 0.0833], 60.0)
    1
    """
    intervals = np.diff(np.asarray(flip_times_s, dtype=float)) * refresh_hz
    late = intervals[intervals > DROPPED_INTERVAL]
    return int(np.sum(np.rint(late) - 1))


def presentation_ok(shown: Shown, *, refresh_hz: float, tolerance_ms: float) -> bool:
    """No frame dropped, and the measured duration within ``tolerance_ms`` of its frames.

    Parameters
    ----------
    shown
        A timed presentation's flips (``frames`` and ``offset_s`` set).
    refresh_hz
        The display's refresh rate, Hz.
    tolerance_ms
        The largest difference allowed between its measured and planned durations, ms.

    Returns
    -------
    bool
        Whether the presentation kept its frames.
    """
    planned_ms = 1000.0 * shown.frames / refresh_hz
    return shown.dropped_frames == 0 and abs(shown.shown_ms - planned_ms) <= tolerance_ms


def _pause_screen(kind: str, text: str) -> dict:
    return {"kind": kind, "text": text, "keys": {"space": "continue"}}


class SessionLoop:
    """Runs an engine against a device until the engine is done.

    Parameters
    ----------
    device
        Draws screens and collects key presses.
    on_row
        Called with each finished row (already holding its timing columns); it must make the
        row durable before returning.
    refresh_hz
        The frame rate presentations are timed at.
    timing_tolerance_ms
        Largest difference between a presentation's measured duration and its frames.
    break_every
        A break screen after every this many trials (0: none).
    log
        Called with a line for each notable event (the session log).
    """

    def __init__(
        self,
        device: Device,
        on_row: Callable[[dict], None],
        *,
        refresh_hz: float,
        timing_tolerance_ms: float = 10.0,
        break_every: int = 0,
        log: Callable[[str], None] = lambda line: None,
    ):
        self.device = device
        self.on_row = on_row
        self.refresh_hz = refresh_hz
        self.timing_tolerance_ms = timing_tolerance_ms
        self.break_every = break_every
        self.log = log
        self.pending: list[Press] = []
        self.ignored: list[tuple[str, float]] = []  # (key, time) not taken since the last row
        self.total_ignored = 0

    # --- presses ------------------------------------------------------------------------

    def _next_press(self, anchor_s: float) -> Press:
        if not self.pending:
            self.pending = list(self.device.wait_keys(anchor_s))
            if not self.pending:
                raise RuntimeError("the device returned no key press")
        press = self.pending.pop(0)
        if press.name == "escape":
            self.log(f"escape at {press.t_s:.4f}")
            raise SessionAborted()
        return press

    def _ignore(self, name: str, t_s: float, why: str) -> None:
        self.ignored.append((name, t_s))
        self.total_ignored += 1
        self.log(f"key {name} at {t_s:.4f} not taken ({why})")

    def pause(self, screen: dict) -> None:
        """Show a screen that waits for one of its keys (presses before it are not taken).

        Parameters
        ----------
        screen
            The engine's screen (``kind``, ``keys``, images and what the front-end needs).
            Presses of other keys are recorded as ignored.
        """
        anchor = self.device.show(screen)
        self.log(f"{screen['kind']} screen onset at {anchor:.4f}")
        while True:
            press = self._next_press(anchor)
            if press.t_s >= anchor and normalise_key(press.name, screen["keys"]) in screen["keys"]:
                self.log(f"{screen['kind']} screen offset at {press.t_s:.4f} ({press.name})")
                return
            self._ignore(press.name, press.t_s, f"on the {screen['kind']} screen")

    # --- the session --------------------------------------------------------------------

    def run(self, engine: Engine, *, resumed_after: int = 0) -> None:
        """Run ``engine`` to its end; ``resumed_after`` trials were recorded before.

        Parameters
        ----------
        engine
            The session's engine, replayed to where it stopped when resumed.
        resumed_after
            Trials recorded before this run; default 0 (a new session). A resumed session
            starts with a welcome-back screen.
        """
        if resumed_after:
            total = engine.total_trials
            of = f" of {total}" if total else ""
            self.pause(
                self._with_legend(
                    engine,
                    _pause_screen(
                        "continue",
                        f"Welcome back. The session continues with trial {resumed_after + 1}{of}.",
                    ),
                )
            )
        onset_trial = None
        anchor = shown = None
        drawn = None
        while not engine.done:
            screen = engine.screen()
            trial = screen.get("trial")
            if trial is None:
                if screen["kind"] in PAUSE_KINDS:
                    self.pause(self._with_legend(engine, screen))
                    engine.press("space", 0.0)
                    drawn = None
                    continue
                raise ValueError(f"a {screen['kind']!r} screen outside a trial")
            if trial != onset_trial:
                if screen["kind"] == "present":
                    shown = self.device.present(screen)
                    engine.presented(
                        presentation_ok(
                            shown,
                            refresh_hz=self.refresh_hz,
                            tolerance_ms=self.timing_tolerance_ms,
                        )
                    )
                else:
                    shown = Shown(onset_s=self.device.show(screen))
                onset_trial, anchor, drawn = trial, shown.onset_s, screen
                self.log(f"trial {trial} onset at {anchor:.4f}")
            elif screen != drawn and (not self.pending or screen.get("text_entry")):
                self.device.show(screen)  # presses read already go first, but typed text
                drawn = screen  # needs its screen to begin
            press = self._next_press(anchor)
            name = normalise_key(press.name, screen["keys"])
            t = press.t_s - anchor
            if t < 0:
                self._ignore(press.name, press.t_s, "before the trial's onset")
                continue
            if (
                screen.get("answer_after_presentation")
                and shown.offset_s is not None
                and press.t_s < shown.offset_s
            ):
                self._ignore(press.name, press.t_s, "during the presentation")
                continue
            if name not in screen["keys"]:
                if not screen.get("text_entry"):
                    self._ignore(
                        press.name, press.t_s, f"not a key of the {screen['kind']} screen"
                    )
                continue
            if screen.get("text_entry") and name == "return":
                engine.type_text(self.device.typed())
            row = engine.press(name, t)
            if row is not None:
                self._finish_row(row, shown, anchor)
                if self.break_every and row["trial"] % self.break_every == 0 and not engine.done:
                    self.pause(
                        _pause_screen(
                            "break",
                            f"Time for a short break ({row['trial']} "
                            f"{'trial' if row['trial'] == 1 else 'trials'} done).",
                        )
                    )

    def _finish_row(self, row: dict, shown: Shown, anchor: float) -> None:
        row["onset_s"] = shown.onset_s
        row["dropped_frames"] = shown.dropped_frames
        row["ignored_keys"] = (
            ";".join(f"{name}@{t - anchor:.3f}" for name, t in self.ignored) or None
        )
        if shown.offset_s is not None:
            row["offset_s"] = shown.offset_s
            row["shown_ms"] = shown.shown_ms
        self.ignored = []
        self.on_row(row)
        self.log(f"trial {row['trial']} recorded (response at {row['time_s']:.4f} s)")

    @staticmethod
    def _with_legend(engine: Engine, screen: dict) -> dict:
        """The keys repeated on the screens after which trials start: the instructions, a
        block's start and the continue screen of a resumed session."""
        if screen["kind"] not in ("instructions", "block", "continue"):
            return screen
        return {**screen, "legend": engine.key_legend()}
