"""What every protocol engine shares: the interface, key presses, seeded randomness.

An engine is a plain state machine. ``screen()`` says what to show now: a dict with ``kind``,
``keys`` (the key names this screen takes, each with what it does, for the key legend) and what
the front-end needs to draw it; screens of a trial carry its number in ``trial``. ``press(key,
t)`` takes a key press at ``t`` seconds after the onset of the current trial's stimulus (the
flip that first showed it) and returns the finished trial's row (a dict of
:mod:`glarelab.protocols.columns` columns) when that key ended a trial, else None.
``presented(ok)`` tells the engine whether the last timed presentation kept its frames.
``done`` says the session is over. ``replay(rows)`` rebuilds the state after the rows already
on disk, to resume.

The session loop (:mod:`glarelab.experiments.loop`) is the only caller: it decides which key
presses reach the engine (those made after the onset, on keys the screen takes) and adds the timing
columns to each row.
"""

from __future__ import annotations

import hashlib
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = [
    "Engine",
    "LookingObserver",
    "Press",
    "first_screen",
    "normalise_key",
    "participant_rng",
]

# a keypad key is a digit with Num Lock on and an arrow or page key with it off; Psychtoolbox
# names it by its position (num_8) either way, so a screen takes whichever meaning it uses
KEYPAD = {
    "num_0": ("0", "insert"),
    "num_1": ("1", "end"),
    "num_2": ("2", "down"),
    "num_3": ("3", "pagedown"),
    "num_4": ("4", "left"),
    "num_5": ("5",),
    "num_6": ("6", "right"),
    "num_7": ("7", "home"),
    "num_8": ("8", "up"),
    "num_9": ("9", "pageup"),
    "num_enter": ("return",),
    "num_decimal": ("period", "delete"),
    "num_subtract": ("minus",),
}


def normalise_key(name: str, taken=()) -> str:
    """A key name as a screen takes it: a keypad key becomes the main-block key the screen
    takes (a digit, or an arrow or page key), else its first meaning.

    Parameters
    ----------
    name
        The key's name as the keyboard reports it (``'num_8'``, ``'up'``).
    taken
        The keys the screen takes (its ``keys``); default none.

    Returns
    -------
    str
        The name the screen takes.

    Examples
    --------
    >>> normalise_key("num_8", {"up": "brighter"}), normalise_key("num_8", {"8": "rate 8"})
    ('up', '8')
    """
    meanings = KEYPAD.get(name)
    if meanings is None:
        return name
    return next((m for m in meanings if m in taken), meanings[0])


@dataclass(frozen=True)
class Press:
    """One key press: its name and the time it went down (s, on the session clock).

    Attributes
    ----------
    name
        The key's name.
    t_s
        When it went down, s on the session clock.
    """

    name: str
    t_s: float


class Engine(ABC):
    """Base of the protocol engines: the interface, and defaults where one fits all."""

    study: str = ""
    counterbalanced: bool = False
    """Whether the engine orders its blocks by ``counterbalance`` (otherwise a given
    ``counterbalance`` is refused: there is nothing for it to order)."""

    @classmethod
    def ordered(cls, protocol) -> str | None:
        """How the engine orders a session's trials, said when a ``counterbalance`` is refused
        (:func:`glarelab.experiments.session.check_counterbalance`).

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol, of the engine's paradigm.

        Returns
        -------
        str or None
            A clause such as "its categories are always asked in the protocol's order"; None
            (this default): not said.
        """
        return None

    @property
    @abstractmethod
    def done(self) -> bool:
        """The session is over."""

    @abstractmethod
    def screen(self) -> dict:
        """What to show now."""

    @abstractmethod
    def press(self, key: str, t: float = 0.0) -> dict | None:
        """Take a key press ``t`` s after the trial's onset; the finished row, or None.

        Parameters
        ----------
        key
            The key's name as the screen takes it (:func:`normalise_key`).
        t
            When it went down, s after the onset of the current trial's stimulus; default 0.

        Returns
        -------
        dict or None
            The finished trial's row (column → value) when the press ended a trial, else None.
        """

    @abstractmethod
    def replay(self, rows: list[dict]) -> None:
        """Continue after the rows already recorded.

        Parameters
        ----------
        rows
            The rows already on disk, in order, as :func:`glarelab.experiments.data.read_rows`
            reads them.
        """

    def presented(self, ok: bool) -> None:  # noqa: B027 - a hook most engines ignore
        """The last timed presentation kept its frames (``ok``) or not; default: no effect.

        Parameters
        ----------
        ok
            Whether the last timed presentation kept its frames.
        """

    @property
    def total_trials(self) -> int | None:
        """Trials in the session when known in advance (None for adaptive procedures)."""
        return None

    def key_legend(self) -> list[tuple[str, str]]:
        """``(keys, what they do)`` for the instructions screen."""
        return []


def _check_seed(name: str, value: int) -> int:
    """``value`` if it is an integer >= 0 (a seed of :func:`numpy.random.default_rng`), else
    ``ValueError`` naming ``name`` (a float seed 1.5 would name another stream silently)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise ValueError(f"{name} must be an integer >= 0 (a random seed), got {value!r}")
    return int(value)


def _check_text(name: str, value: object) -> str:
    """``value`` if it is a non-empty string, else ``ValueError`` naming ``name``."""
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} must be a non-empty string (an id), got {value!r}")
    return value


def participant_rng(seed: int, participant: str, purpose: str) -> np.random.Generator:
    """A generator fixed by the protocol seed, the participant and what it is for, so that a
    participant's trial order is the same in every run and resumed session.

    Parameters
    ----------
    seed
        The protocol's seed.
    participant
        The participant's id.
    purpose
        What the draws are for (``'conditions'``, ``'observer 1'``, ...): each purpose has
        a stream of its own.

    Returns
    -------
    numpy.random.Generator
        The generator.

    Raises
    ------
    ValueError
        For a seed that is not an integer >= 0 (a float, a bool), or a participant or purpose
        that is not a non-empty string (participant 7 and "7" would share a stream).
    """
    seed = _check_seed("seed", seed)
    _check_text("participant", participant)
    _check_text("purpose", purpose)
    digest = hashlib.sha256(f"{participant}/{purpose}".encode()).digest()
    return np.random.default_rng([seed, int.from_bytes(digest[:8], "little")])


class LookingObserver(ABC):
    """What the simulated observers that look at a stimulus set share: the brightness model
    and noise of the protocol's ``[observer]`` table, this participant's draw of the noise,
    and the set as its display shows it (:class:`glarelab.observers.looking.ObservedSet`, which
    observers given the same one share percepts through).

    A paradigm's observer says what it judges (:meth:`judged`), against which the stimuli are
    checked for the range the observers were fitted on: an observer that does not say cannot be
    made.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, with an ``[observer]`` table.
    participant
        The simulated participant's id.
    seed
        The simulated observers' seed: with the protocol's seed and the participant, it fixes
        this observer's draw of the noise.
    stimuli
        The stimulus set (:class:`glarelab.stimuli.stimulus_set.StimulusSet`), or the set
        as displayed (:class:`glarelab.observers.looking.ObservedSet`) to share.
    """

    @staticmethod
    @abstractmethod
    def judged(protocol: Protocol | Mapping[str, Any], geometry: dict):
        """The glare methods, the disk's luminance and its diameter, the backgrounds, the pixel
        size, the display's bit depth and the room's light the observers judge
        (:class:`glarelab.observers.fitted_range.JudgedStimuli`), from the protocol and its
        stimulus set's ``geometry``.

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol (or its data as a mapping).
        geometry
            The stimulus set's geometry (its manifest's ``geometry``).

        Returns
        -------
        glarelab.observers.fitted_range.JudgedStimuli
            What the observers judge.
        """

    #: The :class:`glarelab.observers.noise.ObserverNoise` parameters this paradigm's
    #: observers read; ``None``: all of them. An ``[observer]`` key of the others is refused.
    NOISE_KEYS: ClassVar[frozenset[str] | None] = None

    @classmethod
    def check(cls, protocol: Protocol) -> None:
        """Refuse an ``[observer]`` table the model and the noise do not take, or that sets
        noise this paradigm's observers do not read (ValueError).

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol.

        Raises
        ------
        ValueError
            Naming the key of ``[observer]`` that is wrong.
        """
        from glarelab.observers.noise import ObserverNoise, observer_parameters

        table = protocol["observer"]
        observer_parameters(table, source=protocol.source)
        if cls.NOISE_KEYS is None:
            return
        noise = {f.name for f in fields(ObserverNoise)}
        idle = sorted(k for k in table if k in noise and k not in cls.NOISE_KEYS)
        if idle:
            raise ValueError(
                f"{protocol.source}: observer.{idle[0]} = {table[idle[0]]!r}: the "
                f"{protocol.paradigm} paradigm's observers do not read it (noise of another "
                f"paradigm's); they read {', '.join(sorted(cls.NOISE_KEYS))}"
            )

    def __init__(self, protocol: Protocol, participant: str, *, seed: int, stimuli):
        self.participant = _check_text("participant", participant)
        self.seed = _check_seed("seed", seed)
        # imported here: the model and the set's images are needed only by a simulation
        from glarelab.observers.fitted_range import warn_outside_fitted_range
        from glarelab.observers.looking import ObservedSet
        from glarelab.observers.noise import observer_parameters

        self.protocol = protocol
        self.check(protocol)
        self.model, self.noise = observer_parameters(protocol["observer"], source=protocol.source)
        self.observer = self.noise.draw(
            participant_rng(protocol.seed, participant, f"observer {seed}")
        )
        self.display = stimuli if isinstance(stimuli, ObservedSet) else ObservedSet(stimuli)
        # once per observer: the stimuli it will be asked about, against what it was fitted on
        self.departures = warn_outside_fitted_range(
            protocol.study, self.judged(protocol, self.display.geometry)
        )


def first_screen(engine, *, presses: int = 50) -> dict | None:
    """The first screen with images an engine shows, Space pressed through the screens before
    it (instructions, a block's start); None if it shows none (a questionnaire). The engine is
    used up: give it one of its own.

    Parameters
    ----------
    engine
        A new engine of its own.
    presses
        The most Space presses to try; default 50.

    Returns
    -------
    dict or None
        The screen, or None.
    """
    for _ in range(presses):
        screen = engine.screen()
        if screen.get("images"):
            return screen
        if "space" not in screen.get("keys", {}):
            return None
        engine.press("space", 0.0)
    return None
