"""The effects of a study: each statistical test its analysis reports, with its p-values and
an effect size, read from the analysis's tables.

One registry for the layer (:data:`PARADIGMS`, as every layer has): each paradigm's reader
takes the tables of the analysis's ``tests(dataset, protocol)`` and returns one row per
test:

- **ANOVA** (matching, staircase): every row of the ``anova`` table (the main analysis and the
  protocol's follow-ups), named ``"ANALYSIS: SOURCE"``, with ``F``, its degrees of freedom, the
  uncorrected, Greenhouse–Geisser and Huynh–Feldt p and ``ε_GG``; effect size: partial eta
  squared.
- **t-tests** (matching, the methods at the levels the protocol names): the paired two-sided
  test (the one that fits the repeated-measures design) and Welch's one-sided test (the one
  consistent with Yoshida 2008's ``t(14)``), as :mod:`glarelab.analysis.matching` reports them;
  effect size Cohen's ``d`` (paired: ``d_z = t / √n``; Welch with two groups of ``n``:
  ``d = t √(2 / n)``).
- **Wilcoxon signed-rank tests** (rating, each category against the scale's midpoint,
  Holm-corrected across categories, as :mod:`glarelab.analysis.rating` reports them); effect size
  the matched-pairs rank-biserial correlation ``r = 4 V / (m (m + 1)) − 1`` over the ``m`` ratings
  that differ from the midpoint (Kerby 2014).

Which p an ANOVA effect is judged by is chosen later (:func:`chosen_p`), so one simulation
serves every correction.

References
----------
Greenhouse & Geisser (1959). On methods in the analysis of profile data. Psychometrika 24.
Girden (1992). ANOVA: Repeated measures. Sage.
Kerby (2014). The simple difference formula: an approach to teaching nonparametric
correlation. Comprehensive Psychology 3.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Literal

import pandas as pd
from scipy import stats as sps

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = [
    "CORRECTIONS",
    "GIRDEN_EPSILON",
    "PARADIGMS",
    "WITHOUT_F_TESTS",
    "SphericityChoice",
    "anova_effects",
    "chosen_p",
    "effects",
]

SphericityChoice = Literal["gg", "hf", "girden", "none"]
CORRECTIONS: tuple[str, ...] = ("gg", "hf", "girden", "none")
GIRDEN_EPSILON = 0.75
"""Girden (1992): Greenhouse–Geisser when ``ε_GG < 0.75``, Huynh–Feldt otherwise."""


def _number(value) -> float | None:
    """A float for JSON (None for NaN)."""
    value = float(value)
    return None if math.isnan(value) else value


def anova_effects(table: pd.DataFrame, *, prefix: str | None = None) -> list[dict]:
    """The rows of an ANOVA table (:func:`glarelab.analysis.stats.rm_anova`, optionally with an
    ``analysis`` column) as effects.

    Parameters
    ----------
    table
        The ANOVA table: ``source``, ``F``, ``df1``, ``df2``, ``p``, ``p_gg``, ``p_hf``,
        ``eps_gg``, ``eta2_partial``, and optionally ``analysis``.
    prefix
        The analysis's name for rows without an ``analysis`` column (``"ANALYSIS: SOURCE"``);
        default None: the source alone.

    Returns
    -------
    list of dict
        One row per test: ``effect`` (its name), ``test`` (``'F'``, ``'t'``, ...),
        ``statistic``, ``df1`` (and ``df2``), ``p`` (and for F ``p_gg``, ``p_hf``, ``eps_gg``,
        None where sphericity cannot be estimated), ``size`` and ``size_name``.
    """
    rows = []
    for row in table.itertuples(index=False):
        analysis = getattr(row, "analysis", None) or prefix
        rows.append(
            {
                "effect": f"{analysis}: {row.source}" if analysis else str(row.source),
                "test": "F",
                "statistic": float(row.F),
                "df1": float(row.df1),
                "df2": float(row.df2),
                "p": float(row.p),
                "p_gg": _number(row.p_gg),
                "p_hf": _number(row.p_hf),
                "eps_gg": _number(row.eps_gg),
                "size": float(row.eta2_partial),
                "size_name": "partial eta squared",
            }
        )
    return rows


def _t_effects(table: pd.DataFrame, participants: int) -> list[dict]:
    rows = []
    for row in table.itertuples(index=False):
        if row.test == "paired":
            p, sided, size = row.p_two_sided, "two-sided", row.t / math.sqrt(participants)
        elif row.test == "Welch":
            p, sided, size = row.p_one_sided, "one-sided", row.t * math.sqrt(2 / participants)
        else:
            raise ValueError(f"t-test kind {row.test!r}: expected 'paired' or 'Welch'")
        rows.append(
            {
                "effect": f"t-test {row.level}: {row.methods} ({row.test}, {sided})",
                "test": "t",
                "statistic": float(row.t),
                "df1": float(row.df),
                "p": float(p),
                "size": float(size),
                "size_name": "Cohen's d",
            }
        )
    return rows


def _matching(
    tables: Mapping[str, pd.DataFrame], protocol: Protocol, participants: int
) -> list[dict]:
    rows = anova_effects(tables["anova"]) if "anova" in tables else []
    if "methods_at_levels" in tables:
        rows += _t_effects(tables["methods_at_levels"], participants)
    return rows


def _staircase(
    tables: Mapping[str, pd.DataFrame], protocol: Protocol, participants: int
) -> list[dict]:
    return anova_effects(tables["anova"], prefix="ANOVA") if "anova" in tables else []


def _rating(
    tables: Mapping[str, pd.DataFrame], protocol: Protocol, participants: int
) -> list[dict]:
    q = protocol["questionnaire"]
    midpoint = (q["scale_min"] + q["scale_max"]) / 2
    rows = []
    for row in tables["summary"].to_dict("records"):
        at_midpoint = row.get(f"count_{midpoint:g}", 0) if midpoint.is_integer() else 0
        differing = row["n"] - at_midpoint
        size = 4 * row["wilcoxon_V"] / (differing * (differing + 1)) - 1 if differing else math.nan
        rows.append(
            {
                "effect": f"Wilcoxon {row['category']} vs {midpoint:g} (Holm)",
                "test": "V",
                "statistic": float(row["wilcoxon_V"]),
                "p": float(row["p_holm"]),
                "size": _number(size),
                "size_name": "rank-biserial r",
            }
        )
    return rows


WITHOUT_F_TESTS = frozenset({"rating"})
"""The paradigms whose analysis runs no F test (:func:`_rating`: Wilcoxon tests): a sphericity
correction has nothing to judge there."""

PARADIGMS: dict[str, Callable[[Mapping[str, pd.DataFrame], object, int], list[dict]]] = {
    "matching": _matching,
    "staircase": _staircase,
    "rating": _rating,
}


def effects(
    protocol: Protocol, tables: Mapping[str, pd.DataFrame], participants: int
) -> list[dict]:
    """Every test of the protocol's analysis as an effect row (module docstring), from the
    tables of the analysis's ``tests(dataset, protocol)`` on ``participants``.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol; its paradigm selects the reader (:data:`PARADIGMS`).
    tables
        The analysis's tables by name (``'anova'``, ``'ttests'``, ...).
    participants
        The number of participants the tables are of (for the t-tests' effect sizes).

    Returns
    -------
    list of dict
        One row per test: ``effect`` (its name), ``test`` (``'F'``, ``'t'``, ...),
        ``statistic``, ``df1`` (and ``df2``), ``p`` (and for F ``p_gg``, ``p_hf``, ``eps_gg``,
        None where sphericity cannot be estimated), ``size`` and ``size_name``.
    """
    reader = PARADIGMS.get(protocol.paradigm)
    if reader is None:
        raise ValueError(
            f"paradigm {protocol.paradigm!r} has no effects reader registered in "
            f"glarelab.planning.effects.PARADIGMS ({', '.join(sorted(PARADIGMS))}): a power "
            "analysis cannot name its tests"
        )
    return reader(tables, protocol, participants)


def chosen_p(row: Mapping, correction: SphericityChoice) -> tuple[float, str]:
    """The p-value an effect is judged by, and which it is.

    For an F test: ``"gg"`` Greenhouse–Geisser, ``"hf"`` Huynh–Feldt, ``"girden"`` GG when
    ``ε_GG < 0.75`` else HF (Girden 1992), ``"none"`` uncorrected. Where sphericity cannot be
    estimated (fewer participants than the effect's df + 1) the conservative lower bound
    ``ε = 1 / df1`` is used (Greenhouse & Geisser 1959): ``F`` on ``1`` and ``df2 / df1``
    degrees of freedom. Other tests: their p as the analysis reports it.

    Parameters
    ----------
    row
        An effect row (:func:`effects`).
    correction
        ``'gg'``, ``'hf'``, ``'girden'`` or ``'none'`` (:data:`CORRECTIONS`).

    Returns
    -------
    p : float
        The p-value.
    how : str
        ``'GG'``, ``'HF'``, ``'lower bound'``, ``'uncorrected'`` or ``'as tested'``.

    Raises
    ------
    ValueError
        For a correction that is not one of :data:`CORRECTIONS`.

    Examples
    --------
    >>> row = {"test": "F", "statistic": 4.0, "df1": 5.0, "df2": 20.0, "p": 0.011,
    ...        "p_gg": None, "p_hf": None, "eps_gg": None}
    >>> p, how = chosen_p(row, "gg")
    >>> round(p, 4), how
    (0.1161, 'lower bound')
    """
    if correction not in CORRECTIONS:
        raise ValueError(f"correction must be one of {', '.join(CORRECTIONS)}; got {correction!r}")
    if row["test"] != "F" or correction == "none":
        return float(row["p"]), "uncorrected" if row["test"] == "F" else "as tested"
    if row["eps_gg"] is None:
        df1 = row["df1"]
        return float(sps.f.sf(row["statistic"], 1.0, row["df2"] / df1)), "lower bound"
    if correction == "gg" or (correction == "girden" and row["eps_gg"] < GIRDEN_EPSILON):
        return float(row["p_gg"]), "GG"
    if correction in ("hf", "girden"):
        return float(row["p_hf"]), "HF"
    raise ValueError(f"correction must be one of {', '.join(CORRECTIONS)}; got {correction!r}")
