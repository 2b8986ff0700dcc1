"""Statistics for the studies: repeated-measures ANOVA with sphericity, Holm, t-tests, groups.

All functions take long-format pandas DataFrames (one row per subject × cell).

``rm_anova`` uses statsmodels' ``AnovaRM`` for the F tests and adds what it lacks: for every
within effect, main effects and interactions alike, the Greenhouse–Geisser epsilon with its
corrected p-value, Mauchly's test of sphericity (for effects with more than one degree of
freedom) and partial eta squared. Epsilon and Mauchly's W come from the subjects' scores
projected on the effect's orthonormal contrasts (the product of Helmert contrasts for the
effect's factors and normalised averages for the others), ``Z = Y C``, with covariance ``S``
(``p × p``, ``p`` = the effect's df):

.. math::

   \\hat\\varepsilon_{GG} = \\frac{(\\operatorname{tr} S)^2}{p \\operatorname{tr}(S^2)}, \\qquad
   W = \\frac{\\det S}{(\\operatorname{tr} S / p)^p}, \\qquad
   \\chi^2 = -\\Bigl(n - 1 - \\frac{2p^2 + p + 2}{6p}\\Bigr) \\ln W,
   \\; \\nu = \\frac{p (p + 1)}{2} - 1 ,

with the second-order correction of the chi-square approximation (Box 1949), as R's
``mauchly.test`` and pingouin apply it.

References
----------
Greenhouse & Geisser (1959); Mauchly (1940); Holm (1979); Piepho (2004) for the compact letter
display; the F tests: statsmodels ``AnovaRM``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import stats as sps
from statsmodels.stats.anova import AnovaRM
from statsmodels.stats.multitest import multipletests

__all__ = [
    "apa_F",
    "apa_p",
    "apa_t",
    "holm",
    "pairwise_tests",
    "rm_anova",
    "similarity_groups",
    "ttest_paired",
    "ttest_welch",
]


def _helmert(levels: int) -> np.ndarray:
    """Orthonormal contrasts ``(levels, levels - 1)``: columns orthogonal to 1 and each other."""
    matrix = np.zeros((levels, levels - 1))
    for j in range(1, levels):
        matrix[:j, j - 1] = 1.0
        matrix[j, j - 1] = -j
        matrix[:, j - 1] /= np.linalg.norm(matrix[:, j - 1])
    return matrix


def _wide(df: pd.DataFrame, dv: str, within: list[str], subject: str) -> tuple[np.ndarray, list]:
    counts = df.groupby([subject, *within], observed=True).size()
    if (counts != 1).any():
        bad = counts[counts != 1].index[0]
        raise ValueError(
            f"rm_anova needs exactly one {dv!r} per subject and cell; subject {bad[0]!r} has "
            f"{counts[bad]} at {dict(zip(within, bad[1:], strict=True))}"
        )
    levels = [sorted(df[f].unique(), key=str) for f in within]
    subjects = sorted(df[subject].unique(), key=str)
    table = df.set_index([subject, *within])[dv]
    cells = list(itertools.product(*levels))
    full = pd.MultiIndex.from_tuples([(s, *c) for s in subjects for c in cells])
    missing = full.difference(table.index)
    if len(missing):
        s, *cell = missing[0]
        raise ValueError(
            f"rm_anova needs a balanced design: subject {s!r} has no {dv!r} at "
            f"{dict(zip(within, cell, strict=True))}"
        )
    values = table.reindex(full).to_numpy().reshape(len(subjects), len(cells))
    return values, levels


def _effect_scores(values: np.ndarray, levels: list, effect: Sequence[int]) -> np.ndarray:
    matrix = np.ones((1, 1))
    for index, factor_levels in enumerate(levels):
        k = len(factor_levels)
        part = _helmert(k) if index in effect else np.ones((k, 1)) / math.sqrt(k)
        matrix = np.kron(matrix, part)
    return values @ matrix


def _sphericity(scores: np.ndarray, conditions: int) -> tuple[float, float, float]:
    """``(eps_gg, W, p)`` for an effect's contrast scores ``(n, p)``; ``conditions`` is the
    number of cells of the whole design (the columns of the response matrix, as in R)."""
    n, p = scores.shape
    if p == 1:
        return 1.0, float("nan"), float("nan")
    s = np.cov(scores, rowvar=False)
    trace = np.trace(s)
    eps = float(trace**2 / (p * np.trace(s @ s)))
    sign, logdet = np.linalg.slogdet(s)
    if sign <= 0 or n - 1 < p:
        return eps, 0.0, float("nan")
    log_w = logdet - p * math.log(trace / p)
    f = 1 - (2 * p**2 + p + 2) / (6 * p * (n - 1))
    chi2 = -(n - 1) * f * log_w
    dof = p * (p + 1) / 2 - 1
    first = sps.chi2.sf(chi2, dof)
    # second-order term (Box 1949); with the number of conditions where Anderson has p, as
    # R's mauchly.test and pingouin do, so that the p-values agree with theirs
    w2 = (
        (p + 2)
        * (p - 1)
        * (p - 2)
        * (2 * p**3 + 6 * p**2 + 3 * conditions + 2)
        / (288 * ((n - 1) * p * f) ** 2)
    )
    return eps, math.exp(log_w), float(first + w2 * (sps.chi2.sf(chi2, dof + 4) - first))


def rm_anova(df: pd.DataFrame, dv: str, within: str | Sequence[str], subject: str) -> pd.DataFrame:
    """Repeated-measures ANOVA with Greenhouse–Geisser correction and Mauchly's test.

    Parameters
    ----------
    df
        Long format: one row per subject and cell of the within factors.
    dv
        Column of the dependent variable.
    within
        One or more within-subject factors.
    subject
        Column identifying subjects.

    Returns
    -------
    pandas.DataFrame
        One row per effect (main effects, then interactions, as ``a × b``) with columns
        ``source, df1, df2, F, p, eps_gg, p_gg, eta2_partial, mauchly_W, mauchly_p``
        (Mauchly NaN for effects with one degree of freedom, where sphericity holds).

    Raises
    ------
    ValueError
        For missing columns, a subject with no value (or several) in a cell, fewer than two
        subjects, or a factor with one level.

    Examples
    --------
    >>> data = pd.DataFrame({"s": np.repeat([1, 2, 3, 4], 3), "c": ["x", "y", "z"] * 4,
    ...                      "v": [1.0, 2.1, 3.0, 1.2, 2.0, 3.3, 0.9, 2.2, 2.8, 1.1, 1.9, 3.1]})
    >>> float(rm_anova(data, "v", "c", "s").loc[0, "df1"])
    2.0
    """
    factors = [within] if isinstance(within, str) else list(within)
    missing = [c for c in (dv, subject, *factors) if c not in df.columns]
    if missing:
        raise ValueError(f"rm_anova: column(s) {missing} not in the data")
    if df[subject].nunique() < 2:
        raise ValueError("rm_anova needs at least two subjects")
    for f in factors:
        if df[f].nunique() < 2:
            raise ValueError(f"rm_anova: factor {f!r} has only one level")
    values, levels = _wide(df, dv, factors, subject)
    fit = AnovaRM(df, dv, subject, within=factors).fit().anova_table
    rows = []
    for order in range(1, len(factors) + 1):
        for effect in itertools.combinations(range(len(factors)), order):
            name = ":".join(factors[i] for i in effect)
            table_row = fit.loc[name]
            df1, df2 = float(table_row["Num DF"]), float(table_row["Den DF"])
            f_value = float(table_row["F Value"])
            eps, w, p_w = _sphericity(_effect_scores(values, levels, effect), values.shape[1])
            rows.append(
                {
                    "source": " × ".join(factors[i] for i in effect),
                    "df1": df1,
                    "df2": df2,
                    "F": f_value,
                    "p": float(table_row["Pr > F"]),
                    "eps_gg": eps,
                    "p_gg": float(sps.f.sf(f_value, df1 * eps, df2 * eps)),
                    "eta2_partial": f_value * df1 / (f_value * df1 + df2),
                    "mauchly_W": w,
                    "mauchly_p": p_w,
                }
            )
    return pd.DataFrame(rows)


def holm(pvalues: Sequence[float]) -> np.ndarray:
    """Holm-adjusted p-values (statsmodels ``multipletests``), in the input order.

    Examples
    --------
    >>> [round(float(p), 3) for p in holm([0.01, 0.04, 0.03])]
    [0.03, 0.06, 0.06]
    """
    p = np.asarray(pvalues, dtype=float)
    if p.size == 0:
        return p
    if np.isnan(p).any() or (p < 0).any() or (p > 1).any():
        raise ValueError("holm: p-values must be numbers in [0, 1]")
    return multipletests(p, method="holm")[1]


def ttest_paired(a: Sequence[float], b: Sequence[float]) -> dict:
    """Paired t-test: ``t``, ``df`` (n - 1), two-sided ``p``, mean difference."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape or a.size < 2:
        raise ValueError("ttest_paired needs two samples of the same size, at least 2")
    result = sps.ttest_rel(a, b)
    return {
        "t": float(result.statistic),
        "df": float(a.size - 1),
        "p": float(result.pvalue),
        "mean_difference": float(np.mean(a - b)),
    }


def ttest_welch(a: Sequence[float], b: Sequence[float]) -> dict:
    """Welch's unpaired t-test: ``t``, Welch–Satterthwaite ``df``, two-sided ``p``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.size < 2 or b.size < 2:
        raise ValueError("ttest_welch needs at least 2 values in each sample")
    result = sps.ttest_ind(a, b, equal_var=False)
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    return {
        "t": float(result.statistic),
        "df": float(dof),
        "p": float(result.pvalue),
        "mean_difference": float(a.mean() - b.mean()),
    }


def pairwise_tests(df: pd.DataFrame, dv: str, factor: str, subject: str) -> pd.DataFrame:
    """Paired t-tests between every pair of levels of ``factor``, Holm-adjusted."""
    levels = sorted(df[factor].unique(), key=str)
    wide = df.pivot_table(index=subject, columns=factor, values=dv, observed=True)
    rows = []
    for a, b in itertools.combinations(levels, 2):
        result = ttest_paired(wide[a], wide[b])
        rows.append({"a": a, "b": b, **result})
    table = pd.DataFrame(rows)
    table["p_holm"] = holm(table["p"]) if len(table) else []
    return table


def similarity_groups(means: dict, p_adjusted: dict, alpha: float = 0.05) -> dict:
    """Compact letter display: levels sharing a letter are not significantly different.

    Parameters
    ----------
    means
        Level → mean (letters are given in order of decreasing mean).
    p_adjusted
        ``(level_a, level_b)`` → adjusted p-value for every pair.
    alpha
        Significance level; default .05.

    Returns
    -------
    dict
        Level → letters (e.g. ``'ab'``).

    Notes
    -----
    The insert-and-absorb algorithm of Piepho (2004): start with one group holding every
    level; for each significant pair, split every group holding both into two (one without
    each); drop groups contained in others.

    Examples
    --------
    >>> similarity_groups({"A": 1, "B": 2, "C": 3},
    ...                   {("A", "B"): .5, ("A", "C"): .01, ("B", "C"): .5})
    {'C': 'a', 'B': 'ab', 'A': 'b'}
    """
    levels = sorted(means, key=lambda k: -means[k])
    groups = [set(levels)]
    for (a, b), p in p_adjusted.items():
        if p >= alpha:
            continue
        new = []
        for group in groups:
            if a in group and b in group:
                new += [group - {a}, group - {b}]
            else:
                new.append(group)
        groups = [g for g in new if not any(g < other for other in new if other is not g)]
        unique = []
        for g in groups:
            if g and g not in unique:
                unique.append(g)
        groups = unique
    order = sorted(groups, key=lambda g: min(levels.index(x) for x in g))
    letters = {level: "" for level in levels}
    for index, group in enumerate(order):
        for level in group:
            letters[level] += "abcdefghijklmnopqrstuvwxyz"[index]
    return {level: "".join(sorted(letters[level])) for level in levels}


def apa_p(p: float) -> str:
    """``p < .001`` or ``p = .034`` (APA: no leading zero)."""
    if p < 0.001:
        return "p < .001"
    return f"p = {p:.3f}".replace("0.", ".", 1)


def apa_F(df1: float, df2: float, f_value: float, p: float) -> str:
    """``F(5, 45) = 23.68, p < .001``; non-integer df (corrected) get two decimals.

    Examples
    --------
    >>> apa_F(5, 45, 23.684, 0.00001)
    'F(5, 45) = 23.68, p < .001'
    """

    def dof(x: float) -> str:
        return f"{x:.0f}" if float(x).is_integer() else f"{x:.2f}"

    return f"F({dof(df1)}, {dof(df2)}) = {f_value:.2f}, {apa_p(p)}"


def apa_t(dof: float, t: float, p: float) -> str:
    """``t(14) = 1.71, p = .054``."""
    d = f"{dof:.0f}" if float(dof).is_integer() else f"{dof:.1f}"
    return f"t({d}) = {t:.2f}, {apa_p(p)}"
