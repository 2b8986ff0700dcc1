"""Timing contenders side by side: one run of each in turn, round after round, so that a busy
moment of a shared machine falls on every contender alike."""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

__all__ = ["BATCH_SECONDS", "round_ratio", "timed"]

# A call shorter than this is timed again as a batch filling it, right after: one call of a
# 1 ms render just after a 17 ms one (its caches evicted) put the same renderer at 0.89 and
# at 1.56 times the float32 spectrum peer in one run (Yoshida's disk, the default and the
# FFT path forced, which plan alike within 0.02 ms)
BATCH_SECONDS = 0.05


def timed(
    variants: dict[str, Callable[[], np.ndarray]], repeats: int, *, rounds: dict | None = None
) -> dict:
    """Best time and last result of each variant, the variants run in turn ``repeats``
    times (so that a busy moment of a shared machine does not fall on one of them), each
    round starting one variant later. A variant whose call takes less than
    :data:`BATCH_SECONDS` is called again right away as many times as fill it, and its time
    in the round is the mean of those calls (the first, after the others' work, warms it).

    Parameters
    ----------
    variants
        Name → a function of no arguments that does the work and returns its result.
    repeats
        Rounds, >= 1.
    rounds
        If given, each variant's time in every round is put there too (name → seconds).

    Returns
    -------
    dict
        Name → ``(seconds, result)``: the fastest time and the last result.
    """
    times = {name: [] for name in variants}
    results = {}
    names = list(variants)
    for index in range(repeats):
        # each round starts one variant later: the first of a round runs after the slowest
        # of the last (its caches evicted), and that place goes round
        shift = index % len(names)
        for name in names[shift:] + names[:shift]:
            function = variants[name]
            start = time.perf_counter()
            results[name] = function()
            elapsed = time.perf_counter() - start
            if elapsed < BATCH_SECONDS:
                calls = math.ceil(BATCH_SECONDS / max(elapsed, 1e-6))
                start = time.perf_counter()
                for _ in range(calls):
                    results[name] = function()
                elapsed = (time.perf_counter() - start) / calls
            times[name].append(elapsed)
    if rounds is not None:
        rounds.update(times)
    return {name: (min(times[name]), results[name]) for name in variants}


def round_ratio(rounds: dict, numerator: str, denominator: str) -> float:
    """The median over the rounds of ``numerator``'s time over ``denominator``'s, both
    measured in the same round (``rounds`` as :func:`timed` fills it).

    Parameters
    ----------
    rounds
        Variant name → its time in each round, seconds, as :func:`timed` fills it; the two
        lists must be equally long (one entry per round).
    numerator
        The name of the variant whose times are divided (a key of ``rounds``).
    denominator
        The name of the variant whose times divide (a key of ``rounds``).

    Returns
    -------
    float
        The median of the per-round ratios (dimensionless; > 1: ``numerator`` is slower).
    """
    ratios = np.asarray(rounds[numerator], float) / np.asarray(rounds[denominator], float)
    return float(np.median(ratios))
