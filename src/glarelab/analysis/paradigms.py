"""The analysis of each paradigm: one registry for the layer (see docs/extending.md).

Each module gives

- ``design(protocol)``: the :class:`glarelab.analysis.dataset.Design` (the within factors, the
  cells every participant needs, the block analysed, the blocks a session writes, and whether a
  cell holds one trial or many), from which :func:`glarelab.analysis.load.load_sessions` checks
  the data;
- ``check(trials, protocol)``: the problems of values no session of the protocol can write,
  each naming file and line;
- ``flags(trials, protocol)``: trials a session can record but that contradict the task
  (analysed as recorded, listed in the report), each naming file and line;
- ``tests(dataset, protocol)``: the tables of the statistical tests alone (name → DataFrame),
  what a power analysis needs for each of thousands of simulated studies;
- ``analyse(dataset, protocol)``: everything the report shows (tables, figures, text,
  results; :mod:`glarelab.analysis.report`), its tests those of ``tests``;
- ``methods(protocol, participants, who)``: the methods paragraph;
- ``stimulus_figures(protocol, shown)``: the stimuli as the display showed them, or None
  for a paradigm whose report shows none.

Nothing outside these modules branches on a paradigm's name, so a new paradigm is one module
here and one entry in :data:`PARADIGMS` (:func:`register_paradigm`, which refuses a module that
lacks one of these names, so that no part of a report is left out silently).
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

from glarelab.analysis import matching, rating, staircase
from glarelab.protocols import Protocol

__all__ = ["PARADIGMS", "REQUIRED", "paradigm_analysis", "register_paradigm"]

REQUIRED = ("design", "check", "flags", "tests", "analyse", "methods", "stimulus_figures")
"""What every paradigm's analysis names (``stimulus_figures`` may be None)."""

PARADIGMS: dict[str, Any] = {}


def register_paradigm(name: str, analysis: ModuleType | Any) -> None:
    """Register the analysis of the paradigm ``name``: a module (or any object) with every
    name of :data:`REQUIRED`.

    Parameters
    ----------
    name
        The paradigm's name, as a protocol's ``paradigm`` gives it (not yet registered).
    analysis
        Its analysis: an object with every name of :data:`REQUIRED` callable
        (``stimulus_figures`` may be None).

    Raises
    ------
    ValueError
        For a name already registered, or an analysis that lacks one of :data:`REQUIRED` (or
        whose function is not callable).
    """
    if name in PARADIGMS:
        raise ValueError(f"paradigm {name!r}: already registered in analysis ({PARADIGMS[name]})")
    missing = []
    for key in REQUIRED:
        value = getattr(analysis, key, missing)
        if not (callable(value) or (key == "stimulus_figures" and value is None)):
            missing.append(key)
    if missing:
        raise ValueError(
            f"paradigm {name!r}: its analysis {analysis!r} lacks {', '.join(missing)} (every "
            f"paradigm's analysis names {', '.join(REQUIRED)}; stimulus_figures may be None)"
        )
    PARADIGMS[name] = analysis


def paradigm_analysis(protocol: Protocol) -> Any:
    """The analysis registered for ``protocol``'s paradigm.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol; its ``paradigm`` names the analysis.

    Returns
    -------
    object
        The analysis registered by :func:`register_paradigm` (a module with every name of
        :data:`REQUIRED`).

    Raises
    ------
    ValueError
        When the paradigm has no analysis registered.
    """
    try:
        return PARADIGMS[protocol.paradigm]
    except KeyError:
        raise ValueError(
            f"paradigm {protocol.paradigm!r} has no analysis registered in "
            f"glarelab.analysis.paradigms.PARADIGMS ({', '.join(sorted(PARADIGMS))})"
        ) from None


for _name, _module in (("matching", matching), ("staircase", staircase), ("rating", rating)):
    register_paradigm(_name, _module)
