"""The paradigms the experiments run: for each, its engine and its simulated observer.

One registry for the layer; a new paradigm adds its module (engine and observer) and an entry
here, through :func:`register_paradigm` (see docs/extending.md). Code outside the paradigms'
modules finds a paradigm's entry through :func:`paradigm_run`, which names the registry when
the entry is missing.
"""

from __future__ import annotations

from dataclasses import dataclass

from glarelab.experiments.engine import Engine
from glarelab.experiments.matching import MatchingEngine, MatchingObserver
from glarelab.experiments.rating import RatingEngine, RatingObserver
from glarelab.experiments.staircase import StaircaseEngine, StaircaseObserver
from glarelab.protocols import Protocol

__all__ = ["PARADIGMS", "Paradigm", "paradigm_run", "register_paradigm"]


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


PARADIGMS: dict[str, Paradigm] = {}


def register_paradigm(name: str, paradigm: Paradigm) -> None:
    """Register how the paradigm ``name`` is run.

    Parameters
    ----------
    name
        The paradigm's name, as a protocol's ``paradigm`` gives it (not yet registered).
    paradigm
        Its engine (a subclass of :class:`glarelab.experiments.engine.Engine`) and its
        simulated observer's class (with ``check(protocol)``), or None for no observer.

    Raises
    ------
    ValueError
        For a name already registered, an engine that is not an :class:`Engine` subclass, or an
        observer class without ``check(protocol)``.
    """
    if name in PARADIGMS:
        raise ValueError(f"paradigm {name!r}: already registered in experiments")
    if not isinstance(paradigm, Paradigm):
        raise ValueError(f"paradigm {name!r}: expected a Paradigm entry; got {paradigm!r}")
    if not (isinstance(paradigm.engine, type) and issubclass(paradigm.engine, Engine)):
        raise ValueError(
            f"paradigm {name!r}: engine must be a subclass of glarelab.experiments.engine."
            f"Engine; got {paradigm.engine!r}"
        )
    if paradigm.observer is not None and not callable(getattr(paradigm.observer, "check", None)):
        raise ValueError(
            f"paradigm {name!r}: observer {paradigm.observer!r} has no check(protocol) (the "
            "check of the protocol's [observer] table before a simulation)"
        )
    PARADIGMS[name] = paradigm


def paradigm_run(protocol: Protocol) -> Paradigm:
    """The entry of ``protocol``'s paradigm.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol; its ``paradigm`` names the entry.

    Returns
    -------
    Paradigm
        The engine and the observer registered by :func:`register_paradigm`.

    Raises
    ------
    ValueError
        When the paradigm is not registered here.
    """
    try:
        return PARADIGMS[protocol.paradigm]
    except KeyError:
        raise ValueError(
            f"paradigm {protocol.paradigm!r} has no engine registered in "
            f"glarelab.experiments.paradigms.PARADIGMS ({', '.join(sorted(PARADIGMS))})"
        ) from None


register_paradigm("matching", Paradigm(MatchingEngine, MatchingObserver))
register_paradigm("staircase", Paradigm(StaircaseEngine, StaircaseObserver))
register_paradigm("rating", Paradigm(RatingEngine, RatingObserver))
