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
- optionally ``stimulus_figures(protocol, shown)``: the stimuli as the display showed them.

Nothing outside these modules branches on a paradigm's name, so a new paradigm is one module
here and one entry in :data:`PARADIGMS`.
"""

from __future__ import annotations

from types import ModuleType

from glarelab.analysis import matching, rating, staircase

__all__ = ["PARADIGMS"]

PARADIGMS: dict[str, ModuleType] = {
    "matching": matching,
    "staircase": staircase,
    "rating": rating,
}
