"""The analysis of each paradigm: one registry for the layer (see docs/extending.md).

Each module gives ``analyse(dataset, protocol, *, tests_only=False)`` (tables, figures, text;
``tests_only``: the tables of statistical tests alone), ``design(protocol)`` (the within factors
and the cells every participant needs), ``check(trials, protocol)`` (the problems of values no
session of the protocol can write, each naming file and line) and ``methods(protocol,
participants, who)`` (the methods paragraph).
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
