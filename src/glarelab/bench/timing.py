"""Timing contenders side by side: one run of each in turn, round after round, so that a busy
moment of a shared machine falls on every contender alike."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

__all__ = ["timed"]


def timed(variants: dict[str, Callable[[], np.ndarray]], repeats: int) -> dict:
    """Best time and last result of each variant, the variants run in turn ``repeats``
    times (so that a busy moment of a shared machine does not fall on one of them).

    Parameters
    ----------
    variants
        Name → a function of no arguments that does the work and returns its result.
    repeats
        Rounds, >= 1.

    Returns
    -------
    dict
        Name → ``(seconds, result)``: the fastest time and the last result.
    """
    times = {name: [] for name in variants}
    results = {}
    for _ in range(repeats):
        for name, function in variants.items():
            start = time.perf_counter()
            results[name] = function()
            times[name].append(time.perf_counter() - start)
    return {name: (min(times[name]), results[name]) for name in variants}
