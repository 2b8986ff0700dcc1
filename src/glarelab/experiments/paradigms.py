"""The paradigms the experiments run: for each, its engine and its simulated observer.

One registry for the layer; a new paradigm adds its module (engine and observer) and a line
here (see docs/extending.md).
"""

from __future__ import annotations

from dataclasses import dataclass

from glarelab.experiments.engine import Engine
from glarelab.experiments.matching import MatchingEngine, MatchingObserver
from glarelab.experiments.rating import RatingEngine, RatingObserver
from glarelab.experiments.staircase import StaircaseEngine, StaircaseObserver

__all__ = ["PARADIGMS", "Paradigm"]


@dataclass(frozen=True)
class Paradigm:
    """How a paradigm is run: the engine's class and the simulated observer's.

    Attributes
    ----------
    engine
        The engine's class, made with ``(protocol, participant, *, session,
        counterbalance, refresh_hz)``.
    observer
        The simulated observer's class, made with ``(protocol, participant, *, seed,
        stimuli)``; None where the paradigm has none.
    """

    engine: type[Engine]
    observer: type | None = None


PARADIGMS: dict[str, Paradigm] = {
    "matching": Paradigm(MatchingEngine, MatchingObserver),
    "staircase": Paradigm(StaircaseEngine, StaircaseObserver),
    "rating": Paradigm(RatingEngine, RatingObserver),
}
