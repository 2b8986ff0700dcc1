"""The exact power of a one-way repeated-measures ANOVA when sphericity holds, and simulated
studies of that design, to check the simulated power against it.

With ``n`` subjects measured in ``k`` conditions, ``y_ij = μ_j + s_i + e_ij``, subject effects
``s_i ~ N(0, σ_s²)`` and errors ``e_ij ~ N(0, σ²)`` independent (compound symmetry, so
sphericity holds), the F statistic of the condition effect follows the noncentral F
distribution

.. math::

   F \\sim F'\\bigl(k - 1,\\ (n - 1)(k - 1),\\ \\lambda\\bigr), \\qquad
   \\lambda = \\frac{n \\sum_j (\\mu_j - \\bar\\mu)^2}{\\sigma^2},

whatever ``σ_s``. (With orthonormal contrasts ``C``, ``λ = n μᵀC (CᵀΣC)⁻¹ Cᵀμ`` (Muller &
Barton 1989, §2); under sphericity ``CᵀΣC = σ² I`` and ``‖Cᵀμ‖² = Σ (μ_j − μ̄)²``.) The power
at level ``α`` is ``P(F' > F_{1−α}(k − 1, (n − 1)(k − 1)))``.

References
----------
Muller & Barton (1989). Approximate power for repeated-measures ANOVA lacking sphericity.
Journal of the American Statistical Association 84(406).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import stats as sps

from glarelab.files.values import is_real, is_whole, plain_array
from glarelab.planning.effects import anova_effects

__all__ = ["OneWayJob", "noncentrality", "one_way_power"]

# above this noncentrality the power is 1 to double precision for any design of up to 1,000
# conditions at alpha >= 1e-12 (scipy's ncf.sf gives 1.0 from about 1e3 on and NaN near 1e300)
SURE_NONCENTRALITY = 1e8


def _means(means_per_condition: Sequence[float]) -> np.ndarray:
    """The means as floats: at least two finite real numbers (strings, bools, complex
    numbers and masked arrays refused, not converted)."""
    given = means_per_condition
    raw = plain_array("means_per_condition", given)
    if raw.dtype.kind not in "iuf":
        raise ValueError(f"means_per_condition must be at least two finite numbers; got {given!r}")
    means = raw.astype(float)
    if means.ndim != 1 or means.size < 2 or not np.all(np.isfinite(means)):
        raise ValueError(
            f"means_per_condition must be at least two finite numbers; got {means_per_condition!r}"
        )
    return means


def _subjects(subjects: object) -> int:
    """``subjects`` as a whole number >= 2 (not a bool, not a fraction)."""
    if isinstance(subjects, bool | np.bool_) or not isinstance(subjects, int | np.integer):
        raise ValueError(f"subjects must be a whole number >= 2; got {subjects!r}")
    if subjects < 2:
        raise ValueError(f"subjects must be >= 2; got {subjects!r}")
    return int(subjects)


def _sd(name: str, value: object, *, zero: bool = False) -> float:
    """``value`` as a finite standard deviation > 0 (>= 0 with ``zero``), refused naming
    ``name``."""
    allowed = ">= 0" if zero else "> 0"
    try:
        sd = float(value) if is_real(value) else math.nan  # type: ignore[arg-type]
    except OverflowError:  # an int past a float's range
        sd = math.inf
    if not (math.isfinite(sd) and (sd >= 0 if zero else sd > 0)):
        raise ValueError(f"{name} must be a finite number {allowed}; got {value!r}")
    return sd


def _error_sd(error_sd: object) -> float:
    """``error_sd`` as a finite number > 0."""
    return _sd("error_sd", error_sd)


def noncentrality(
    means_per_condition: Sequence[float], *, error_sd: float, subjects: int
) -> float:
    """``λ = n Σ (μ_j − μ̄)² / σ²`` (module docstring).

    Parameters
    ----------
    means_per_condition
        ``μ_j``, the condition means (at least two), in the unit of the measure.
    error_sd
        ``σ``, the SD of the error within subjects, same unit, > 0.
    subjects
        ``n``, >= 2.

    Returns
    -------
    float
        ``λ``, dimensionless.

    Raises
    ------
    ValueError
        For fewer than two finite means, ``error_sd <= 0`` or fewer than two subjects.

    Examples
    --------
    >>> noncentrality([0.0, 0.5, 1.0], error_sd=1.0, subjects=10)
    5.0
    """
    means = _means(means_per_condition)
    error_sd = _error_sd(error_sd)
    subjects = _subjects(subjects)
    with np.errstate(over="ignore"):  # an effect of 1e200 σ is λ = inf: the power is 1
        centred = (means - means.mean()) / error_sd
        return float(subjects * np.sum(centred**2))


def one_way_power(
    means_per_condition: Sequence[float], *, error_sd: float, subjects: int, alpha: float = 0.05
) -> float:
    """The power of the one-way repeated-measures F test under sphericity (noncentral F).

    Parameters
    ----------
    means_per_condition
        ``μ_j``, the condition means (at least two).
    error_sd
        ``σ``, the SD of the error within subjects (> 0).
    subjects
        ``n`` (>= 2).
    alpha
        Significance level (default 0.05).

    Examples
    --------
    With no effect, the power is the significance level:

    >>> one_way_power([1.0, 1.0, 1.0], error_sd=1.0, subjects=8)
    0.05
    >>> round(one_way_power([0.0, 0.3, 0.6, 0.9], error_sd=1.0, subjects=12), 4)
    0.4246
    """
    if not is_real(alpha):  # a bool, a string, a complex number
        raise ValueError(f"alpha must be a number in (0, 1); got {alpha!r}")
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1); got {alpha!r}")
    k = _means(means_per_condition).size
    lam = noncentrality(means_per_condition, error_sd=error_sd, subjects=subjects)
    df1, df2 = k - 1, (int(subjects) - 1) * (k - 1)
    critical = sps.f.isf(alpha, df1, df2)
    if lam == 0:
        return float(alpha)
    power = float(sps.ncf.sf(critical, df1, df2, lam))
    if not np.isfinite(power) and lam > SURE_NONCENTRALITY:
        return 1.0  # the noncentral F's tail fails to compute where it is 1 to double precision
    return power


class OneWayJob:
    """Simulated studies of the one-way design of the module docstring, analysed by
    :func:`glarelab.analysis.stats.rm_anova` (the function every paradigm's ANOVA uses), as tasks
    of :func:`glarelab.planning.execute.run_tasks` whose records
    :func:`glarelab.planning.power.summarise` reads.

    Replication ``r`` draws from ``numpy.random.default_rng([seed, r])``; the sample sizes of
    one replication share their first subjects, as in :mod:`glarelab.planning.simulate`.

    Parameters
    ----------
    means_per_condition
        ``μ_j``, the condition means (at least two), in the unit of the measure.
    error_sd
        ``σ``, the SD of the error within subjects, same unit, > 0.
    subject_sd
        ``σ_s``, the SD of the subject effects, same unit, >= 0 (it does not change the
        power under sphericity).
    participants
        The sample sizes ``n`` to analyse, each >= 2.
    seed
        The seed of every replication's draws, a whole number >= 0.

    Raises
    ------
    ValueError
        For means, SDs, sample sizes or a seed out of range or not numbers, each named.
    """

    kind = "one-way"

    def __init__(
        self,
        means_per_condition: Sequence[float],
        *,
        error_sd: float,
        subject_sd: float,
        participants: Sequence[int],
        seed: int,
    ):
        self.means = _means(means_per_condition)
        self.error_sd = _error_sd(error_sd)
        self.subject_sd = _sd("subject_sd", subject_sd, zero=True)
        if (
            isinstance(participants, str | bytes)
            or not isinstance(participants, Sequence | np.ndarray)
            or len(participants) == 0
            or not all(is_whole(n) and n >= 2 for n in participants)
        ):
            raise ValueError(
                f"participants must be sample sizes, whole numbers >= 2; got {participants!r}"
            )
        self.participants = tuple(sorted({int(n) for n in participants}))
        if not (is_whole(seed) and seed >= 0):
            raise ValueError(f"seed must be a whole number >= 0; got {seed!r}")
        self.seed = int(seed)

    def run(self, replication: int) -> dict:
        """One simulated study at every sample size.

        Parameters
        ----------
        replication
            The replication's number, >= 0: with ``seed``, it seeds the draws.

        Returns
        -------
        dict
            ``replication``; ``results``: one effect record per sample size
            (:func:`glarelab.planning.effects.anova_effects`, with ``n``); ``failures``:
            none.
        """
        from glarelab.analysis.stats import rm_anova

        rng = np.random.default_rng([self.seed, replication])
        n, k = max(self.participants), self.means.size
        subject = rng.normal(0.0, self.subject_sd, size=(n, 1))
        values = self.means + subject + rng.normal(0.0, self.error_sd, size=(n, k))
        results = []
        for size in self.participants:
            data = pd.DataFrame(
                {
                    "subject": np.repeat(np.arange(size), k),
                    "condition": np.tile(np.arange(k), size),
                    "y": values[:size].ravel(),
                }
            )
            table = rm_anova(data, "y", "condition", "subject")
            results += [{"n": size, **row} for row in anova_effects(table, prefix="one-way")]
        return {"replication": replication, "results": results, "failures": []}
