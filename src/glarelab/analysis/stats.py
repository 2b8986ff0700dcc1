"""Statistics for the studies: repeated-measures ANOVA with sphericity and the correction each
effect is reported with, Holm, t-tests, the Wilcoxon signed-rank test, similarity groups, and
the checks of the tests' assumptions.

All functions take long-format pandas DataFrames (one row per subject × cell) or arrays, and
refuse missing or non-finite values with a ``ValueError`` instead of returning NaN.

``rm_anova`` uses statsmodels' ``AnovaRM`` for the F tests and adds what it lacks: for every
within effect, main effects and interactions alike, the Greenhouse–Geisser and Huynh–Feldt
epsilons with their corrected p-values, Mauchly's test of sphericity (for effects with more than
one degree of freedom) and partial eta squared. Epsilon and Mauchly's W come from the subjects'
scores projected on the effect's orthonormal contrasts (the product of Helmert contrasts for the
effect's factors and normalised averages for the others), ``Z = Y C``, with covariance ``S``
(``p × p``, ``p`` = the effect's df) over ``n`` subjects:

.. math::

   \\hat\\varepsilon_{GG} = \\frac{(\\operatorname{tr} S)^2}{p \\operatorname{tr}(S^2)}, \\qquad
   \\tilde\\varepsilon_{HF} = \\min\\Bigl(1,
       \\frac{n p \\hat\\varepsilon_{GG} - 2}{p (n - 1 - p \\hat\\varepsilon_{GG})}\\Bigr),

   W = \\frac{\\det S}{(\\operatorname{tr} S / p)^p}, \\qquad
   \\chi^2 = -\\Bigl(n - 1 - \\frac{2p^2 + p + 2}{6p}\\Bigr) \\ln W,
   \\; \\nu = \\frac{p (p + 1)}{2} - 1 ,

with the second-order correction of the chi-square approximation (Box 1949), as R's
``mauchly.test`` and ``car::Anova`` apply it. The Huynh–Feldt estimate is Lecoutre's (1991)
correction of Huynh & Feldt (1976), the one R's ``car::Anova``, ``stats::anova.mlm`` and afex
report: ``(N - g + 1) p ε - 2`` in the numerator where Huynh & Feldt had ``N p ε - 2``; with no
between-subject groups (``g = 1``, as here) both read ``n p ε - 2``. The estimate can exceed 1;
``car`` prints it uncapped and computes its p-value with ``min(1, ε)``, afex caps it: the
``eps_hf`` column is the capped value.

When the effect's contrast covariance is singular (fewer subjects than the effect's df + 1, as in
a 12 × 2 design with 8 subjects), neither epsilon nor Mauchly's test can be estimated: R's
``car::Anova`` gives none of them ("not available"); ``rm_anova`` gives NaN and says why in its
``sphericity`` column, and :func:`glarelab.analysis.apa.apa_anova` prints the uncorrected test
with that reason.

**Which correction** (:func:`correction`). Effects with one degree of freedom need none
(sphericity holds). For the others the degrees of freedom are corrected: with
Greenhouse–Geisser's ε when ε < .75, with Huynh–Feldt's otherwise (Girden 1992;
Greenhouse–Geisser is conservative when ε is large, Huynh–Feldt liberal when it is small).

The Wilcoxon signed-rank test (``wilcoxon_signed_rank``) is R's ``wilcox.test(x, mu = mu)`` with
R's defaults, written out so that the result does not depend on the SciPy version.

References
----------
Greenhouse & Geisser (1959), Psychometrika 24, 95-112; Huynh & Feldt (1976), J. Educ. Stat. 1,
69-82; Lecoutre (1991), J. Educ. Stat. 16, 371-372; Mauchly (1940); Box (1949); Holm (1979);
Wilcoxon (1945); Piepho (2004) for the compact letter display; Girden (1992), *ANOVA:
Repeated measures*, Sage, p. 21; Shapiro & Wilk (1965), Biometrika 52, 591-611; the F tests:
statsmodels ``AnovaRM``. Reference values: R 4.2 with car and afex (``tests/analysis/R``).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from typing import Literal

import numpy as np
import pandas as pd
from scipy import stats as sps
from statsmodels.stats.anova import AnovaRM

from glarelab.files.values import is_real, is_whole, real_array

__all__ = [
    "GG_BELOW",
    "anova_residuals",
    "assumptions",
    "corrected_df",
    "corrected_p",
    "correction",
    "group_letters",
    "holm",
    "holm_confidence",
    "natural_order",
    "normality",
    "pairwise_tests",
    "rm_anova",
    "signed_rank_counts",
    "similarity_groups",
    "ttest_one_sample",
    "ttest_paired",
    "ttest_welch",
    "wilcoxon_signed_rank",
]

ROUNDING = 1e-12  # error SD below this fraction of the data's RMS is taken as none
WILCOXON_EXACT_BELOW_N = 50  # R's wilcox.test: exact p for fewer non-zero differences, no ties


def _no_variance(variance: float, rms: float) -> bool:
    """Whether a spread is no variance but rounding: ``variance`` (in the data's unit squared)
    at most ``(ROUNDING * rms)²``, ``rms`` the data's root mean square, or NaN. The one rule
    of :func:`rm_anova` (an effect's error variance) and :func:`ttest_paired` (the
    differences'), so that the two never disagree on whether a comparison has variance."""
    return not variance > (ROUNDING * rms) ** 2


def _helmert(levels: int) -> np.ndarray:
    """Orthonormal contrasts ``(levels, levels - 1)``: columns orthogonal to 1 and each other."""
    matrix = np.zeros((levels, levels - 1))
    for j in range(1, levels):
        matrix[:j, j - 1] = 1.0
        matrix[j, j - 1] = -j
        matrix[:, j - 1] /= np.linalg.norm(matrix[:, j - 1])
    return matrix


def _finite(values: np.ndarray, name: str, where) -> None:
    """Refuse NaN and infinities, naming the first one by ``where(index)``."""
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise ValueError(
            f"{name} is {values[bad[0]]} {where(bad[0])}; every value must be a finite number "
            f"({bad.size} of {values.size} are not)"
        )


def _numeric(df: pd.DataFrame, dv: str, caller: str) -> np.ndarray:
    column = df[dv]
    if (
        not pd.api.types.is_numeric_dtype(column)
        or pd.api.types.is_bool_dtype(column)
        or pd.api.types.is_complex_dtype(column)
    ):
        raise ValueError(
            f"{caller}: column dv={dv!r} must be real numbers; got dtype {column.dtype}"
        )
    return df[dv].to_numpy(float)


def _wide(df: pd.DataFrame, dv: str, within: list[str], subject: str) -> tuple[np.ndarray, list]:
    counts = df.groupby([subject, *within], observed=True).size()
    if (counts != 1).any():
        bad = counts[counts != 1].index[0]
        raise ValueError(
            f"rm_anova needs exactly one {dv!r} per subject and cell; subject {bad[0]!r} has "
            f"{counts[bad]} at {dict(zip(within, bad[1:], strict=True))}"
        )
    values = _numeric(df, dv, "rm_anova")
    rows = df[[subject, *within]].to_numpy()

    def where(i: int) -> str:
        return f"for subject {rows[i][0]!r} at {dict(zip(within, rows[i][1:], strict=True))}"

    _finite(values, f"rm_anova: dv {dv!r}", where)
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
    values = table.reindex(full).to_numpy(float).reshape(len(subjects), len(cells))
    return values, levels


def _effect_scores(values: np.ndarray, levels: list, effect: Sequence[int]) -> np.ndarray:
    matrix = np.ones((1, 1))
    for index, factor_levels in enumerate(levels):
        k = len(factor_levels)
        part = _helmert(k) if index in effect else np.ones((k, 1)) / math.sqrt(k)
        matrix = np.kron(matrix, part)
    return values @ matrix


def _sphericity(scores: np.ndarray, conditions: int) -> dict:
    """Epsilons, Mauchly's test and a note for an effect's contrast scores ``(n, p)``.

    ``conditions`` is the number of cells of the whole design (the columns of the response
    matrix, as in R). Where the covariance of the scores is singular, nothing is estimable.
    """
    n, p = scores.shape
    if p == 1:
        return {
            "eps_gg": 1.0,
            "eps_hf": 1.0,
            "mauchly_W": float("nan"),
            "mauchly_p": float("nan"),
            "sphericity": "holds: 1 df",
        }
    if n - 1 < p:
        return _not_estimable(f"not estimable: {n} subjects for {p} df, needs at least {p + 1}")
    s = np.cov(scores, rowvar=False)
    eigenvalues = np.linalg.eigvalsh(s)
    # rank as numpy's matrix_rank decides it; relative to the largest eigenvalue, unlike car's
    # absolute threshold (1.5e-8), so that it does not depend on the unit of the data
    rank = int(np.sum(eigenvalues > eigenvalues.max() * p * np.finfo(float).eps))
    if rank < p:
        return _not_estimable(
            f"not estimable: the covariance of the {p} contrast scores has rank {rank}"
        )
    trace = float(eigenvalues.sum())
    eps = trace**2 / (p * float(np.sum(eigenvalues**2)))
    denominator = p * (n - 1 - p * eps)
    eps_hf = 1.0 if denominator <= 0 else min(1.0, (n * p * eps - 2) / denominator)
    log_w = float(np.sum(np.log(eigenvalues))) - p * math.log(trace / p)
    f = 1 - (2 * p**2 + p + 2) / (6 * p * (n - 1))
    chi2 = -(n - 1) * f * log_w
    dof = p * (p + 1) / 2 - 1
    first = sps.chi2.sf(chi2, dof)
    # second-order term (Box 1949); with the number of conditions where Anderson has p, as
    # R's mauchly.test, car and pingouin do, so that the p-values agree with theirs
    w2 = (
        (p + 2)
        * (p - 1)
        * (p - 2)
        * (2 * p**3 + 6 * p**2 + 3 * conditions + 2)
        / (288 * ((n - 1) * p * f) ** 2)
    )
    return {
        "eps_gg": eps,
        "eps_hf": eps_hf,
        "mauchly_W": math.exp(log_w),
        "mauchly_p": float(first + w2 * (sps.chi2.sf(chi2, dof + 4) - first)),
        "sphericity": "estimated",
    }


def _not_estimable(reason: str) -> dict:
    nan = float("nan")
    return {"eps_gg": nan, "eps_hf": nan, "mauchly_W": nan, "mauchly_p": nan, "sphericity": reason}


def rm_anova(
    df: pd.DataFrame,
    dv: str,
    within: str | Sequence[str],
    subject: str,
    *,
    untestable: Literal["raise", "report"] = "raise",
) -> pd.DataFrame:
    """Repeated-measures ANOVA with Greenhouse–Geisser, Huynh–Feldt and lower-bound
    corrections and Mauchly's test.

    Parameters
    ----------
    df
        Long format: one row per subject and cell of the within factors.
    dv
        Column of the dependent variable (finite numbers).
    within
        One or more within-subject factors (any column names).
    subject
        Column identifying subjects.
    untestable
        What to do with an effect that has no error variance (every subject's contrast scores
        equal, e.g. matches at the display's maximum in every cell the effect compares), whose
        F is 0/0 or effect/rounding: ``"raise"`` (default) refuses the data; ``"report"``
        gives the effect a row with NaN statistics and ``note`` saying why (R's ``car::Anova``
        gives NaN there), so that the other effects are still tested.

    Returns
    -------
    pandas.DataFrame
        One row per effect (main effects, then interactions, as ``a × b``) with columns
        ``source, df1, df2, F, MSE, p, eps_gg, p_gg, eps_hf, p_hf, eps_lb, p_lb,
        eta2_partial, eta2_generalized, mauchly_W, mauchly_p, sphericity, note`` (``MSE``:
        the effect's error mean square, ``SS_error / df2``, as afex prints it; ``eps_lb``:
        the lower bound ``1 / df1`` of ε, with its p ``p_lb``; ``note``: empty, or why the
        effect could not be tested; the interval of η²p:
        :func:`glarelab.analysis.effects.with_eta2_ci`). For effects with one degree of
        freedom sphericity holds: epsilons 1, corrected p = p, Mauchly NaN. Where sphericity
        is not estimable (fewer than df + 1 subjects, or a singular covariance of the effect's
        contrast scores) the epsilons, corrected p-values and Mauchly's test are NaN and
        ``sphericity`` says why; otherwise it reads ``estimated``.

    Raises
    ------
    ValueError
        For missing columns, a non-numeric, NaN or infinite dependent variable, a subject with
        no value (or several) in a cell, fewer than two subjects, a factor with one level,
        a factor that is also the subject or dependent variable, or (unless
        ``untestable="report"``) an effect without error variance, where F is undefined.

    Notes
    -----
    The epsilons and Mauchly's test are given in the module docstring. The corrected p-values
    use the F distribution with ``ε df1`` and ``ε df2`` degrees of freedom; the Huynh–Feldt
    ``ε`` is capped at 1 as R does for its p-value. The lower bound of ε, ``1 / df1``
    (Greenhouse & Geisser 1959), gives the most conservative test, ``F(1, df2 / df1)``,
    valid whatever the covariance: the one to decide on where ε cannot be estimated. Partial
    eta squared is ``F df1 / (F df1 + df2)``. Generalized eta squared (Olejnik & Algina
    2003; Bakeman 2005), afex's default effect size, is, in a design of within factors only,
    ``SS_effect / (SS_effect + Σ SS_error)``, the sum over the error terms of every effect and
    of the subjects (all measured factors are in its denominator), so that it compares across
    designs where η²p does not.

    Examples
    --------
    >>> data = pd.DataFrame({"s": np.repeat([1, 2, 3, 4], 3), "c": ["x", "y", "z"] * 4,
    ...                      "v": [1.0, 2.1, 3.0, 1.2, 2.0, 3.3, 0.9, 2.2, 2.8, 1.1, 1.9, 3.1]})
    >>> table = rm_anova(data, "v", "c", "s")
    >>> float(table.loc[0, "df1"]), round(float(table.loc[0, "eps_hf"]), 4)  # R, car: 0.5344
    (2.0, 0.5344)
    >>> table.loc[0, "sphericity"]
    'estimated'
    """
    if not isinstance(df, pd.DataFrame):
        raise TypeError(
            f"rm_anova: df must be a pandas DataFrame (long format), got {type(df).__name__}"
        )
    factors = [within] if isinstance(within, str) else list(within)
    if not factors:
        raise ValueError("rm_anova: within must name at least one factor; got none")
    missing = [c for c in (dv, subject, *factors) if c not in df.columns]
    if missing:
        raise ValueError(f"rm_anova: column(s) {missing} not in the data")
    for column in (subject, *factors):
        absent = df[column].isna()
        if absent.any():
            raise ValueError(
                f"rm_anova: column {column!r} has no value in {int(absent.sum())} row(s) (first "
                f"at index {df.index[absent.to_numpy()][0]!r}); every row needs its subject and "
                "levels"
            )
    names = [dv, subject, *factors]
    if len(set(names)) < len(names):
        raise ValueError(
            f"rm_anova: dv, subject and within factors must be different columns; got "
            f"dv={dv!r}, subject={subject!r}, within={factors!r}"
        )
    if untestable not in ("raise", "report"):
        raise ValueError(f"rm_anova: untestable must be 'raise' or 'report'; got {untestable!r}")
    if df[subject].nunique() < 2:
        raise ValueError("rm_anova needs at least two subjects")
    for f in factors:
        if df[f].nunique() < 2:
            raise ValueError(f"rm_anova: factor {f!r} has only one level")
    values, levels = _wide(df, dv, factors, subject)
    scale = float(np.sqrt(np.mean(values**2)))  # the data's magnitude
    # statsmodels builds formulas from the column names ('C', 'I', 'Q', spaces, digits break
    # them): fit on positional names
    safe = [f"factor{i}" for i in range(len(factors))]
    renamed = pd.DataFrame(
        {"subject": df[subject].to_numpy(), "dv": df[dv].to_numpy(float)}
        | {name: df[f].to_numpy() for name, f in zip(safe, factors, strict=True)}
    )
    effects = [
        effect
        for order in range(1, len(factors) + 1)
        for effect in itertools.combinations(range(len(factors)), order)
    ]
    # no error variance beyond rounding: F is 0/0 or effect/rounding (statsmodels gave
    # F = -2.8 for constant data, R's car NaN, and divides by the zero error)
    untestable_effects = {
        effect
        for effect in effects
        if _no_variance(
            np.var(_effect_scores(values, levels, effect), axis=0, ddof=1).mean(), scale
        )
    }
    # statsmodels divides every effect by its error: not fitted where one has none, whose
    # others' F and p follow from the contrast scores' sums of squares below
    fit = (
        None
        if untestable_effects
        else AnovaRM(renamed, "dv", "subject", within=safe).fit().anova_table
    )
    # sums of squares of the effects and their error terms from the orthonormal contrast
    # scores; the subjects' own (the scores on the grand mean) is the error of the intercept
    sums = {}
    for effect in [(), *effects]:
        scores = _effect_scores(values, levels, effect)
        centred = scores - scores.mean(axis=0)
        sums[effect] = (
            float(len(scores) * np.sum(scores.mean(axis=0) ** 2)),
            float(np.sum(centred**2)),
        )
    all_errors = sum(error for _, error in sums.values())
    rows = []
    for order in range(1, len(factors) + 1):
        for effect in itertools.combinations(range(len(factors)), order):
            scores = _effect_scores(values, levels, effect)
            source = " × ".join(str(factors[i]) for i in effect)
            # as AnovaRM's: the effect's contrasts, and as many per subject but one
            df1 = float(scores.shape[1])
            df2 = df1 * (len(scores) - 1)
            if effect in untestable_effects:
                why = (
                    f"{dv!r} has no error variance for {source}: every subject's scores on "
                    "its contrasts are equal (to rounding), so F is undefined"
                )
                if untestable == "raise":
                    raise ValueError(f"rm_anova: {why}")
                rows.append(_untestable_row(source, df1, df2, f"not testable: {why}"))
                continue
            if fit is not None:
                table_row = fit.loc[":".join(safe[i] for i in effect)]
                df1, df2 = float(table_row["Num DF"]), float(table_row["Den DF"])
                f_value = float(table_row["F Value"])
                p_value = float(table_row["Pr > F"])
            else:  # as AnovaRM computes it: (SS_effect / df1) / (SS_error / df2)
                f_value = (sums[effect][0] / df1) / (sums[effect][1] / df2)
                p_value = float(sps.f.sf(f_value, df1, df2))
            if f_value < 0:
                # an effect's sum of squares is never negative: a negative F is the rounding of
                # an effect that is exactly 0 (equal means, as settings on a coarse grid give)
                f_value, p_value = 0.0, 1.0
            sphericity = _sphericity(scores, values.shape[1])
            eps_gg, eps_hf = sphericity["eps_gg"], sphericity["eps_hf"]
            rows.append(
                {
                    "source": source,
                    "df1": df1,
                    "df2": df2,
                    "F": f_value,
                    "MSE": sums[effect][1] / df2,
                    "p": p_value,
                    "eps_gg": eps_gg,
                    "p_gg": _corrected_p(f_value, df1, df2, eps_gg, p_value),
                    "eps_hf": eps_hf,
                    "p_hf": _corrected_p(f_value, df1, df2, eps_hf, p_value),
                    "eps_lb": 1.0 / df1,
                    "p_lb": _corrected_p(f_value, df1, df2, 1.0 / df1, p_value),
                    "eta2_partial": f_value * df1 / (f_value * df1 + df2),
                    "eta2_generalized": sums[effect][0] / (sums[effect][0] + all_errors),
                    "mauchly_W": sphericity["mauchly_W"],
                    "mauchly_p": sphericity["mauchly_p"],
                    "sphericity": sphericity["sphericity"],
                    "note": "",
                }
            )
    return pd.DataFrame(rows)


def _untestable_row(source: str, df1: float, df2: float, note: str) -> dict:
    nan = float("nan")
    return {
        "source": source,
        "df1": df1,
        "df2": df2,
        **dict.fromkeys(("F", "MSE", "p", "eps_gg", "p_gg", "eps_hf", "p_hf"), nan),
        "eps_lb": 1.0 / df1,
        "p_lb": nan,
        **dict.fromkeys(("eta2_partial", "eta2_generalized", "mauchly_W", "mauchly_p"), nan),
        "sphericity": "not testable",
        "note": note,
    }


def _corrected_p(f_value: float, df1: float, df2: float, eps: float, p: float) -> float:
    if math.isnan(eps):
        return float("nan")
    if eps == 1.0:
        return p
    return float(sps.f.sf(f_value, df1 * eps, df2 * eps))


def _alpha(where: str, alpha: float) -> float:
    """``alpha`` as a float, after checking it is a number strictly between 0 and 1."""
    if not is_real(alpha):
        raise TypeError(f"{where}: alpha must be a number in (0, 1); got {alpha!r}")
    if not 0 < alpha < 1:
        raise ValueError(f"{where}: alpha must lie strictly between 0 and 1; got {alpha!r}")
    return float(alpha)


def _pvalues(where: str, pvalues: Sequence[float]) -> np.ndarray:
    """``pvalues`` as a 1-D float array, after checking each is a real number (not a string
    or a bool, which NumPy would read as a number)."""
    if isinstance(pvalues, str | bytes) or np.ndim(pvalues) != 1:
        raise TypeError(
            f"{where}: pvalues must be a sequence of numbers (one per test); got {pvalues!r}"
        )
    for position, value in enumerate(pvalues):
        if not is_real(value):
            raise TypeError(
                f"{where}: pvalues must be numbers in [0, 1]; got {value!r} at position {position}"
            )
    return np.asarray(pvalues, dtype=float)


def holm(pvalues: Sequence[float], *, missing: Literal["raise", "omit"] = "raise") -> np.ndarray:
    """Holm-adjusted p-values (as R's ``p.adjust(p, "holm")``), in the input order.

    Parameters
    ----------
    pvalues
        The family's p-values.
    missing
        ``"raise"`` (default): a NaN is refused. ``"omit"``: a NaN marks a test that could
        not be computed (a Wilcoxon test of differences that are all zero); it stays NaN and
        is left out of the family, which holds only the computed tests, as R's ``p.adjust``
        leaves out ``NA`` (its default ``n = sum(!is.na(p))``).

    Raises
    ------
    ValueError
        For a p-value outside [0, 1], a NaN unless ``missing="omit"``, or another
        ``missing``.
    TypeError
        For ``pvalues`` that are not a flat sequence of numbers (a string or a bool among
        them, a scalar, a table).

    Examples
    --------
    >>> [round(float(p), 3) for p in holm([0.01, 0.04, 0.03])]
    [0.03, 0.06, 0.06]
    >>> holm([float("nan"), 0.0192, 0.3], missing="omit").round(4).tolist()  # R: NA .0384 .3
    [nan, 0.0384, 0.3]
    """
    if missing not in ("raise", "omit"):
        raise ValueError(f"holm: missing must be 'raise' or 'omit'; got {missing!r}")
    p = _pvalues("holm", pvalues)
    if p.size == 0:
        return p
    computed = ~np.isnan(p) if missing == "omit" else np.ones(p.shape, bool)
    bad = np.flatnonzero(computed & ~((p >= 0) & (p <= 1)))
    if bad.size:
        raise ValueError(
            f"holm: pvalues must be numbers in [0, 1]; got {p[bad[0]]} at position {bad[0]}"
        )
    adjusted = np.full(p.shape, np.nan)
    if computed.any():
        # Holm (1979), as R's p.adjust: the k-th smallest of m times (m - k + 1), made
        # non-decreasing, at most 1 (statsmodels' multipletests gives the same numbers, and
        # runs the garbage collector on every call: 0.2 s in a loaded process)
        kept = p[computed]
        order = np.argsort(kept, kind="stable")
        steps = (kept.size - np.arange(kept.size)) * kept[order]
        result = np.empty(kept.size)
        result[order] = np.minimum(1.0, np.maximum.accumulate(steps))
        adjusted[computed] = result
    return adjusted


def holm_confidence(pvalues: Sequence[float], *, alpha: float = 0.05) -> np.ndarray:
    """The confidence level of each test's interval that agrees with its Holm-corrected
    decision: the interval excludes the null value exactly when the Holm-adjusted p is below
    ``alpha``; NaN for a NaN p (a test left out of the family, as :func:`holm` with
    ``missing="omit"``).

    Parameters
    ----------
    pvalues
        The family's unadjusted p-values (NaN: not computed).
    alpha
        The family's significance level.

    Returns
    -------
    numpy.ndarray
        ``1 - x_i``, where ``x_i`` is the smallest unadjusted p at which test ``i`` is no
        longer rejected by Holm's procedure, the other tests' p-values as they are.

    Notes
    -----
    With the other p-values fixed, test ``i``'s Holm-adjusted p is a continuous,
    non-decreasing function ``f_i(x)`` of its own p-value ``x``: ``max(A_r, (m - r + 1) x)``
    while ``x`` ranks ``r``-th among the ``m`` tests, ``A_r`` the largest ``(m - k + 1)
    p_(k)`` of the tests ranked before it. So ``f_i(p_i) < alpha`` exactly when ``p_i <
    x_i = min{x : f_i(x) ≥ alpha}``, and a two-sided interval at level ``1 - x_i`` (whose
    test has the same p) excludes the null value exactly when the Holm-corrected test
    rejects it. For the smallest p this is Bonferroni's level ``1 - alpha / m``; for the
    others it lies between that and ``1 - alpha``. The interval is the set of values the
    corrected test would not reject, each test in its family (not a simultaneous region).

    Examples
    --------
    >>> holm_confidence([0.01, 0.04, 0.03]).round(4).tolist()  # α/3, then α/2 twice
    [0.9833, 0.975, 0.975]
    >>> holm_confidence([0.001, float("nan")]).tolist()  # a family of one
    [0.95, nan]
    """
    alpha = _alpha("holm_confidence", alpha)
    p = _pvalues("holm_confidence", pvalues)
    holm(p, missing="omit")  # the same checks
    levels = np.full(p.shape, np.nan)
    computed = np.flatnonzero(~np.isnan(p))
    m = computed.size
    for i in computed:
        others = np.sort(p[computed[computed != i]])
        reached = 0.0  # A_r: the largest adjusted value of the tests ranked before
        bounds = [0.0, *others.tolist(), 1.0]
        for rank in range(1, m + 1):
            low, high = bounds[rank - 1], bounds[rank]
            if reached >= alpha:
                critical = low
                break
            candidate = alpha / (m - rank + 1)
            if candidate <= high:
                critical = max(candidate, low)
                break
            reached = max(reached, (m - rank + 1) * high)
        else:
            critical = 1.0
        levels[i] = 1.0 - critical
    return levels


def _sample(values: Sequence[float], name: str, caller: str) -> np.ndarray:
    """``values`` as a 1-D float array of finite numbers (a masked array, a string, a bool or
    a NaN refused, naming ``caller``, ``name`` and the position)."""
    array = real_array(values, f"{caller}: {name}")
    if array.ndim != 1:
        raise ValueError(f"{caller}: {name} must be one-dimensional; got shape {array.shape}")
    _finite(array, f"{caller}: {name}", lambda i: f"at position {i}")
    return array


CONSTANT = 10 * np.finfo(float).eps  # R's t.test: SE below this fraction of |mean| is "constant"


def _confidence_level(confidence: float, caller: str) -> float:
    if not is_real(confidence):
        raise TypeError(f"{caller}: confidence must be a number in (0, 1); got {confidence!r}")
    if not 0 < confidence < 1:
        raise ValueError(
            f"{caller}: confidence must lie strictly between 0 and 1; got {confidence!r}"
        )
    return float(confidence)


def _unit(*values: np.ndarray | float) -> float:
    """The power of two at the magnitude of ``values`` (1 for all zeros): the t-tests work on
    the values divided by it, so that squares neither overflow (1e300² is inf) nor underflow.
    Dividing by a power of two is exact, so ordinary data give the same bits as unscaled."""
    largest = max(float(np.max(np.abs(v), initial=0.0)) for v in values)
    return math.ldexp(1.0, math.frexp(largest)[1] - 1) if largest > 0 else 1.0


def _t_result(
    estimate: float,
    se: float,
    dof: float,
    confidence: float,
    scale: float,
    what: str,
    unit: float = 1.0,
    caller: str = "",
    shift: float = 0.0,
) -> dict:
    """t, df, two-sided p and the interval of ``estimate``; where the standard error is zero
    or below R's threshold (``10 ε`` of ``scale``), no test, and ``note`` says why.
    ``estimate``, ``se`` and ``scale`` are in units of ``unit`` (see :func:`_unit`); the
    estimate and interval (shifted by ``shift``, in the same units) are returned in the
    data's unit, and refused (``caller`` named) where they lie beyond float64's range."""
    nan = float("nan")
    result = {"t": nan, "df": float(dof), "p": nan, "estimate": float(estimate) * unit}
    if se == 0 and estimate == 0:
        return result | {"ci_low": nan, "ci_high": nan, "note": f"not testable: {what} are all 0"}
    if se <= CONSTANT * scale:
        return result | {
            "ci_low": nan,
            "ci_high": nan,
            "note": f"not testable: {what} are essentially constant "
            f"(each {result['estimate']:.6g}): "
            "no variance to test against (R's t.test: data are essentially constant)",
        }
    t = estimate / se
    half = float(sps.t.ppf(0.5 + confidence / 2, dof)) * se
    result |= {
        "t": float(t),
        "p": float(2 * sps.t.sf(abs(t), dof)),
        "ci_low": float(estimate - half + shift) * unit,
        "ci_high": float(estimate + half + shift) * unit,
        "note": "",
    }
    _representable(result, caller)
    return result


def _representable(result: dict, caller: str) -> None:
    """Refuse a t-test whose estimate or interval lies beyond float64 (about 1.8e308)."""
    names = {
        "estimate": "difference",
        "mean": "mean",
        "ci_low": "interval's lower end",
        "ci_high": "interval's upper end",
    }
    for key, name in names.items():
        if key in result and math.isinf(result[key]):
            raise ValueError(
                f"{caller}: the values are too large to compute with: the {name} lies beyond "
                f"float64's range (about 1.8e308); express them in a larger unit"
            )


def ttest_one_sample(x: Sequence[float], *, mu: float = 0.0, confidence: float = 0.95) -> dict:
    """One-sample t-test of ``x`` against ``mu`` (two-sided), as R's ``t.test(x, mu = mu,
    conf.level = confidence)``.

    Parameters
    ----------
    x
        The values, at least 2, in the measure's unit.
    mu
        The value tested against, same unit; default 0.
    confidence
        The interval's confidence level, in (0, 1); default 0.95.

    Returns
    -------
    dict
        ``t``, ``df`` (n - 1), ``p``, ``mean``, ``ci_low``, ``ci_high`` (the t interval of the
        mean) and ``note``: empty, or why there is no test (every value equal: R stops with
        "data are essentially constant"; t, p and the interval are then NaN).

    Raises
    ------
    ValueError
        For fewer than 2 values, a value (or ``mu``) that is NaN or infinite, a
        confidence outside (0, 1), or a mean or interval beyond float64's range (about
        1.8e308; values of any smaller magnitude are tested as in a unit near their own).

    Examples
    --------
    >>> result = ttest_one_sample([12.0, 30.5, 22.1, 8.4, 19.0], mu=0)  # R: 4.740 [7.62, 29.18]
    >>> round(result["t"], 3), round(result["ci_low"], 2), round(result["ci_high"], 2)
    (4.74, 7.62, 29.18)
    """
    x = _sample(x, "x", "ttest_one_sample")
    confidence = _confidence_level(confidence, "ttest_one_sample")
    if not (is_real(mu) and math.isfinite(mu)):
        raise ValueError(f"ttest_one_sample: mu must be a finite number; got {mu!r}")
    if x.size < 2:
        raise ValueError(f"ttest_one_sample needs at least 2 values; got {x.size}")
    unit = _unit(x, mu)
    x = x / unit
    mean = float(x.mean())
    se = float(x.std(ddof=1)) / math.sqrt(x.size)
    result = _t_result(
        mean - mu / unit,
        se,
        x.size - 1,
        confidence,
        abs(mean),
        "the values" if mu == 0 else f"the values minus mu = {mu:g}",
        unit,
        "ttest_one_sample",
        shift=mu / unit,  # the interval of the mean, not of mean - mu
    )
    result["mean"] = mean * unit
    del result["estimate"]
    _representable(result, "ttest_one_sample")
    return result


def ttest_paired(a: Sequence[float], b: Sequence[float], *, confidence: float = 0.95) -> dict:
    """Paired t-test, as R's ``t.test(a, b, paired = TRUE, conf.level = confidence)``.

    Parameters
    ----------
    a, b
        The paired values, same length >= 2, in the measure's unit.
    confidence
        The interval's confidence level, in (0, 1); default 0.95.

    Returns
    -------
    dict
        ``t``, ``df`` (n - 1), two-sided ``p``, ``mean_difference`` (``a - b``), ``ci_low``,
        ``ci_high`` (its t interval) and ``note``: empty, or why there is no test: every
        difference 0 (R gives NaN) or all equal (R stops: "data are essentially constant");
        t, p and the interval are then NaN. Differences whose standard deviation is below
        ``ROUNDING`` (1e-12) of the values' RMS count as equal, as in :func:`rm_anova`, so
        that the two never disagree on whether a comparison has variance.

    Raises
    ------
    ValueError
        For samples of different sizes, fewer than 2 pairs, a value that is NaN or infinite
        (drop incomplete pairs first: R's ``t.test`` drops them silently), a confidence
        outside (0, 1), or a difference or interval beyond float64's range (about 1.8e308).

    Examples
    --------
    >>> ttest_paired([423.0, 423.0, 423.0], [423.0, 423.0, 423.0])["note"]
    'not testable: the differences are all 0'
    """
    a = _sample(a, "a", "ttest_paired")
    b = _sample(b, "b", "ttest_paired")
    confidence = _confidence_level(confidence, "ttest_paired")
    if a.shape != b.shape or a.size < 2:
        raise ValueError(
            f"ttest_paired needs two samples of the same size, at least 2; got {a.size} and "
            f"{b.size}"
        )
    unit = _unit(a, b)
    a, b = a / unit, b / unit
    d = a - b
    mean = float(d.mean())
    sd = float(d.std(ddof=1))
    values_rms = float(np.sqrt((np.mean(a**2) + np.mean(b**2)) / 2))
    if 0 < sd and _no_variance(sd**2, values_rms):
        # the rule rm_anova applies to the same data: a spread of the differences at the
        # values' rounding is no variance (R's t.test would test a 1-ulp difference)
        sd = 0.0
    se = sd / math.sqrt(d.size)
    result = _t_result(
        mean, se, d.size - 1, confidence, abs(mean), "the differences", unit, "ttest_paired"
    )
    result["mean_difference"] = result.pop("estimate")
    return result


def ttest_welch(a: Sequence[float], b: Sequence[float], *, confidence: float = 0.95) -> dict:
    """Welch's unpaired t-test, as R's ``t.test(a, b, conf.level = confidence)``.

    Parameters
    ----------
    a, b
        The two samples, at least 2 values each, in the measure's unit.
    confidence
        The interval's confidence level, in (0, 1); default 0.95.

    Returns
    -------
    dict
        ``t``, Welch–Satterthwaite ``df``, two-sided ``p``, ``mean_difference`` (mean of
        ``a`` minus mean of ``b``), ``ci_low``, ``ci_high`` (Welch's interval of it: the
        difference ± t(df) times its standard error) and ``note`` (as :func:`ttest_paired`:
        both samples without variance: no test).

    Raises
    ------
    ValueError
        For fewer than 2 values in a sample, a value that is NaN or infinite, a
        confidence outside (0, 1), or a difference or interval beyond float64's range
        (about 1.8e308).
    """
    a = _sample(a, "a", "ttest_welch")
    b = _sample(b, "b", "ttest_welch")
    confidence = _confidence_level(confidence, "ttest_welch")
    if a.size < 2 or b.size < 2:
        raise ValueError(
            f"ttest_welch needs at least 2 values in each sample; got {a.size} and {b.size}"
        )
    unit = _unit(a, b)
    a, b = a / unit, b / unit
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    se = math.sqrt(va + vb)
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1)) if se > 0 else math.nan
    scale = max(abs(float(a.mean())), abs(float(b.mean())))
    difference = float(a.mean() - b.mean())
    result = _t_result(
        difference, se, dof, confidence, scale, "both samples' values", unit, "ttest_welch"
    )
    if result["note"]:  # R: "data are essentially constant" whatever the difference
        result["note"] = (
            "not testable: neither sample varies (R's t.test: data are essentially constant)"
        )
    result["mean_difference"] = result.pop("estimate")
    return result


def wilcoxon_signed_rank(x: Sequence[float], *, mu: float = 0.0) -> dict:
    """Wilcoxon signed-rank test of ``x`` against ``mu``, two-sided, as R's
    ``wilcox.test(x, mu = mu)`` with its defaults.

    Parameters
    ----------
    x
        The sample (finite numbers, e.g. Likert ratings).
    mu
        The value tested against (e.g. a scale's midpoint); default 0.

    Returns
    -------
    dict
        ``V`` (the sum of the ranks of the positive differences ``x - mu``, R's statistic),
        ``p`` (two-sided), ``n`` (non-zero differences), ``zeros`` (dropped differences) and
        ``method`` (``"exact"`` or ``"normal, continuity-corrected"``).

    Raises
    ------
    ValueError
        For a value of ``x`` or ``mu`` that is NaN or infinite, an empty sample, or a sample
        whose every value equals ``mu`` (R gives ``V = 0`` and ``p = NA`` there).

    Notes
    -----
    Differences ``d = x - mu`` of zero are dropped (Wilcoxon 1945); the others are ranked by
    ``|d|`` with mid-ranks for ties. With fewer than 50 non-zero differences, no ties and no
    zeros, ``p`` is exact: twice the smaller tail of the null distribution of ``V`` (the
    number of subsets of ``1 … n`` with each sum, counted exactly), at most 1. Otherwise the
    normal approximation with the tie and continuity corrections:

    .. math::

       z = \\frac{V - n(n+1)/4 - \\tfrac12 \\operatorname{sign}(V - n(n+1)/4)}
                {\\sqrt{n(n+1)(2n+1)/24 - \\sum_j (t_j^3 - t_j)/48}},

    with ``t_j`` the sizes of the tie groups, and ``p = 2 min(Φ(z), 1 - Φ(z))``. This is
    R's default (R 4.2 ``wilcox.test``: ``exact = NULL, correct = TRUE``), written out here
    because ``scipy.stats.wilcoxon`` chooses between its exact and normal variants, and
    reports the smaller rank sum instead of ``V``, differently across SciPy versions.

    References
    ----------
    Wilcoxon (1945), Biometrics Bulletin 1, 80-83; Hollander, Wolfe & Chicken (2014),
    Nonparametric Statistical Methods, 3rd ed., §3.1 (the null distribution, ties and the
    normal approximation); R's ``wilcox.test`` (stats package).

    Examples
    --------
    >>> result = wilcoxon_signed_rank([4.8, 5.6, 3.1, 6.2, 4.45, 5.9, 7.3], mu=4)
    >>> result["V"], result["p"], result["method"]
    (25.0, 0.078125, 'exact')
    >>> result = wilcoxon_signed_rank([5, 5, 4, 6, 3, 5, 6, 4, 5, 7], mu=4)
    >>> result["V"], round(result["p"], 4), result["n"], result["zeros"]
    (33.0, 0.0371, 8, 2)
    """
    values = _sample(x, "x", "wilcoxon_signed_rank")
    if not (is_real(mu) and math.isfinite(mu)):
        raise ValueError(f"wilcoxon_signed_rank: mu must be a finite number; got {mu!r}")
    if values.size == 0:
        raise ValueError("wilcoxon_signed_rank: x is empty; it needs at least one value")
    differences = values - mu
    nonzero = differences[differences != 0]
    n = nonzero.size
    if n == 0:
        raise ValueError(
            f"wilcoxon_signed_rank: all {values.size} values of x equal mu={mu!r}; the test "
            "needs at least one value different from mu"
        )
    ranks = sps.rankdata(np.abs(nonzero))  # mid-ranks for ties
    statistic = float(ranks[nonzero > 0].sum())
    _, tie_sizes = np.unique(ranks, return_counts=True)
    ties = bool((tie_sizes > 1).any())
    zeros = int(values.size - n)
    if n < WILCOXON_EXACT_BELOW_N and not ties and not zeros:
        counts = signed_rank_counts(n)
        v = round(statistic)
        tail = counts[v:].sum() if statistic > n * (n + 1) / 4 else counts[: v + 1].sum()
        p = min(1.0, 2 * float(tail) / 2.0**n)
        method = "exact"
    else:
        centred = statistic - n * (n + 1) / 4
        sigma = math.sqrt(n * (n + 1) * (2 * n + 1) / 24 - np.sum(tie_sizes**3 - tie_sizes) / 48)
        z = (centred - math.copysign(0.5, centred) * (centred != 0)) / sigma
        p = float(2 * min(sps.norm.cdf(z), sps.norm.sf(z)))
        method = "normal, continuity-corrected"
    return {"V": statistic, "p": p, "n": int(n), "zeros": zeros, "method": method}


SIGNED_RANK_MAX_N = 62  # 2^63 overflows int64: the counts are exact up to n = 62


def signed_rank_counts(n: int) -> np.ndarray:
    """How many subsets of ``{1, …, n}`` have each sum ``0 … n(n+1)/2`` (exact for n < 63).

    Parameters
    ----------
    n
        The number of non-zero differences, >= 0.

    Returns
    -------
    numpy.ndarray
        int64 counts, index = the signed-rank sum ``V``; they sum to ``2^n``.

    Raises
    ------
    ValueError
        For an ``n`` that is not a whole number (a bool, a float) in ``[0, 62]`` (above 62 the
        counts overflow int64).

    Examples
    --------
    >>> signed_rank_counts(3).tolist()
    [1, 1, 1, 2, 1, 1, 1]
    """
    if not (is_whole(n) and 0 <= n <= SIGNED_RANK_MAX_N):
        raise ValueError(
            f"signed_rank_counts: n must be a whole number in [0, {SIGNED_RANK_MAX_N}] (the "
            f"number of non-zero differences); got {n!r}"
        )
    counts = np.zeros(n * (n + 1) // 2 + 1, dtype=np.int64)
    counts[0] = 1
    for k in range(1, n + 1):
        counts[k:] = counts[k:] + counts[:-k]
    return counts


def pairwise_tests(
    df: pd.DataFrame, dv: str, factor: str, subject: str, *, alpha: float = 0.05
) -> pd.DataFrame:
    """Paired t-tests between every pair of levels of ``factor``, Holm-adjusted, each with the
    interval of its mean difference that agrees with its corrected decision.

    A pair whose differences have no variance (every participant the same at both levels,
    e.g. matches at the display's maximum) has no test, as R's ``pairwise.t.test`` gives NA
    there; it is left out of the Holm family (``p.adjust`` leaves out NA) and its ``note``
    says why.

    Parameters
    ----------
    df
        Long data, one row per subject and level.
    dv
        The dependent variable's column.
    factor
        The within factor's column.
    subject
        The subject's column.
    alpha
        The familywise level the intervals agree with; default 0.05.

    Returns
    -------
    pandas.DataFrame
        One row per pair ``a, b`` (levels in their natural order): ``t, df, p,
        mean_difference`` (``a - b``), ``note`` (:func:`ttest_paired`), ``p_holm``,
        ``confidence`` (:func:`holm_confidence` at ``alpha``) and ``ci_low, ci_high``: the t
        interval of the mean difference at that level, which excludes 0 exactly when
        ``p_holm < alpha``.

    Raises
    ------
    ValueError
        For missing columns, a non-numeric, NaN or infinite ``dv``, a subject without
        exactly one value at every level, or ``alpha`` outside (0, 1).
    TypeError
        For an ``alpha`` that is not a number (a string, a bool).
    """
    alpha = _alpha("pairwise_tests", alpha)  # before the tests, named as this function's
    missing = [c for c in (dv, factor, subject) if c not in df.columns]
    if missing:
        raise ValueError(f"pairwise_tests: column(s) {missing} not in the data")
    values = _numeric(df, dv, "pairwise_tests")
    rows = df[[subject, factor]].to_numpy()
    _finite(
        values,
        f"pairwise_tests: dv {dv!r}",
        lambda i: f"for subject {rows[i][0]!r} at {factor}={rows[i][1]!r}",
    )
    levels = natural_order(df[factor].unique())
    counts = (
        df.groupby([subject, factor], observed=True)
        .size()
        .unstack(factor)
        .reindex(columns=levels)
        .fillna(0)
    )
    bad = counts[(counts != 1).any(axis=1)]
    if len(bad):
        who = bad.index[0]
        level = next(lev for lev in levels if bad.loc[who, lev] != 1)
        raise ValueError(
            f"pairwise_tests needs exactly one {dv!r} per subject and level of {factor!r}; "
            f"subject {who!r} has {int(bad.loc[who, level])} at {factor}={level!r}"
        )
    wide = df.pivot(index=subject, columns=factor, values=dv)
    pairs = list(itertools.combinations(levels, 2))
    tests = [ttest_paired(wide[a], wide[b]) for a, b in pairs]
    p = np.array([t["p"] for t in tests], dtype=float)
    confidence = holm_confidence(p, alpha=alpha)
    rows = []
    for (a, b), test, p_holm, level in zip(
        pairs, tests, holm(p, missing="omit"), confidence, strict=True
    ):
        interval = ttest_paired(wide[a], wide[b], confidence=level) if test["note"] == "" else test
        rows.append(
            {"a": a, "b": b}
            | {k: test[k] for k in ("t", "df", "p", "mean_difference", "note")}
            | {"p_holm": p_holm, "confidence": level}
            | {"ci_low": interval["ci_low"], "ci_high": interval["ci_high"]}
        )
    columns = ["a", "b", "t", "df", "p", "mean_difference", "note", "p_holm", "confidence",
               "ci_low", "ci_high"]  # fmt: skip
    return pd.DataFrame(rows, columns=columns)


def natural_order(values) -> list:
    """Levels in their natural order: numbers as numbers (1, 2, …, 10, 11), anything else as
    text.

    Parameters
    ----------
    values
        The levels.

    Returns
    -------
    list
        Sorted.

    Examples
    --------
    >>> natural_order([10, 2, 1]), natural_order(["b", "a"]), natural_order(["10", "9"])
    ([1, 2, 10], ['a', 'b'], ['9', '10'])
    """
    values = list(values)
    try:
        return sorted(values, key=float)
    except (TypeError, ValueError):
        return sorted(values, key=str)


def similarity_groups(
    means: dict,
    p_adjusted: dict,
    alpha: float = 0.05,
    *,
    missing: Literal["raise", "omit"] = "raise",
) -> dict:
    """Compact letter display: levels sharing a letter are not significantly different.

    Parameters
    ----------
    means
        Level → mean (letters are given in order of decreasing mean).
    p_adjusted
        ``(level_a, level_b)`` → adjusted p-value for every pair; NaN for a pair that could
        not be tested, with ``missing="omit"`` only.
    alpha
        Significance level, in (0, 1); default .05.
    missing
        What a NaN p-value means: ``"raise"`` (default) refuses it, naming the pair, so that a
        p-value lost upstream never joins two levels unnoticed; ``"omit"`` leaves the pair out
        (it does not separate the two levels: no test says they differ), as :func:`holm`'s
        ``missing="omit"`` leaves an untested p-value out of the family.

    Returns
    -------
    dict
        Level → letters (e.g. ``'ab'``).

    Raises
    ------
    TypeError
        For ``means`` or ``p_adjusted`` not a dict, or a mean, a p-value or ``alpha`` that
        is not a number (a string, a bool).
    ValueError
        For ``alpha`` outside (0, 1), no level, a non-finite mean, a p-value outside [0, 1],
        a NaN or absent p-value unless ``missing="omit"``, an unknown ``missing``, a key of
        ``p_adjusted`` that is not a pair of two levels of ``means``, or a pair given twice
        (in either order).

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
    alpha = _alpha("similarity_groups", alpha)
    if missing not in ("raise", "omit"):
        raise ValueError(f"similarity_groups: missing must be 'raise' or 'omit'; got {missing!r}")
    for name, value in (("means", means), ("p_adjusted", p_adjusted)):
        if not isinstance(value, Mapping):
            raise TypeError(
                f"similarity_groups: {name} must be a dict, got {type(value).__name__}"
            )
    if not means:
        raise ValueError("similarity_groups: means must hold at least one level; got {}")
    for level, mean in means.items():
        if not is_real(mean):
            raise TypeError(
                f"similarity_groups: means must map each level to a number; got {mean!r} for "
                f"{level!r}"
            )
        if not math.isfinite(mean):
            raise ValueError(
                f"similarity_groups: means must be finite; got {mean!r} for {level!r}"
            )
    for pair, p in p_adjusted.items():
        if not (isinstance(pair, tuple) and len(pair) == 2 and set(pair) <= means.keys()):
            raise ValueError(
                f"similarity_groups: p_adjusted must be keyed by pairs (level_a, level_b) of "
                f"levels in means; got {pair!r} (levels: {', '.join(map(repr, means))})"
            )
        if not is_real(p):
            raise TypeError(
                f"similarity_groups: p_adjusted values must be numbers in [0, 1] or NaN; got "
                f"{p!r} for {pair!r}"
            )
        if math.isnan(p) and missing == "raise":
            raise ValueError(
                f"similarity_groups: p_adjusted is NaN for {pair!r} (position "
                f"{list(p_adjusted).index(pair)}); every p-value must be a number in [0, 1] "
                "(give missing='omit' to leave untested pairs out)"
            )
        if not (math.isnan(p) or 0.0 <= p <= 1.0):
            raise ValueError(
                f"similarity_groups: p_adjusted values must be in [0, 1] or NaN; got {p!r} for "
                f"{pair!r}"
            )
    seen: dict[frozenset, tuple] = {}
    for pair in p_adjusted:
        if pair[0] == pair[1]:
            raise ValueError(
                f"similarity_groups: p_adjusted has a level paired with itself: {pair!r}"
            )
        key = frozenset(pair)
        if key in seen:
            raise ValueError(
                f"similarity_groups: p_adjusted has the pair {seen[key]!r} twice (also as "
                f"{pair!r}); give each pair once"
            )
        seen[key] = pair
    if missing == "raise":
        absent = [
            (a, b)
            for i, a in enumerate(means)
            for b in list(means)[i + 1 :]
            if frozenset((a, b)) not in seen
        ]
        if absent:
            raise ValueError(
                f"similarity_groups: p_adjusted has no p-value for {len(absent)} pair(s) of "
                f"levels, e.g. {absent[0]!r}; give every pair (missing='omit' leaves untested "
                "pairs out)"
            )
    levels = sorted(means, key=lambda k: -means[k])
    groups = [set(levels)]
    for (a, b), p in p_adjusted.items():
        if not p < alpha:  # not significant, or omitted as untested (NaN): no evidence they differ
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
    names = group_letters(len(order))
    return {
        level: "".join(name for name, group in zip(names, order, strict=True) if level in group)
        for level in levels
    }


LETTERS = tuple("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ.")  # multcompView's


def group_letters(count: int, letters: Sequence[str] = LETTERS) -> list[str]:
    """The names of ``count`` letter groups, as R's ``multcompView::multcompLetters`` gives
    them: ``a … z, A … Z``, then the last letter as a prefix (``.a … .Z``, ``..a`` …).

    Parameters
    ----------
    count
        The number of groups, >= 0.
    letters
        The alphabet; default ``a … z, A … Z``.

    Returns
    -------
    list of str
        ``count`` names.

    Raises
    ------
    ValueError
        For a count that is not a whole number >= 0 (a bool, a float, a negative number).

    Examples
    --------
    >>> group_letters(3)
    ['a', 'b', 'c']
    >>> group_letters(54)[50:]
    ['Y', 'Z', '.a', '.b']
    """
    if not (is_whole(count) and count >= 0):
        raise ValueError(f"group_letters: count must be a whole number >= 0; got {count!r}")
    letters = list(letters)
    names: list[str] = []
    while count >= len(letters):  # multcompView's makeLtrs, unrolled
        names += letters[:-1]
        count -= len(letters) - 1
        letters = [letters[-1] + letter for letter in letters[:-1]] + [letters[-1]]
    return names + letters[:count]


GG_BELOW = 0.75  # Girden (1992): Greenhouse–Geisser's ε below .75, Huynh–Feldt's above


Correction = Literal["none", "GG", "HF", "LB"]


def _anova_row(row, keys: tuple[str, ...], function: str) -> None:
    """``row`` is a row of :func:`rm_anova`'s table (a pandas Series) with ``keys``."""
    if not isinstance(row, pd.Series):
        raise TypeError(
            f"{function}: row must be a row of rm_anova's table (a pandas Series), got "
            f"{type(row).__name__}"
        )
    missing = [k for k in keys if k not in row.index]
    if missing:
        raise ValueError(
            f"{function}: row lacks {', '.join(missing)}; give a row of rm_anova's table"
        )


def correction(row) -> Correction:
    """The correction an ``rm_anova`` row is reported with and decided on (module docstring).

    ``"none"`` for an effect with one degree of freedom (or that could not be tested);
    ``"GG"`` or ``"HF"`` by Greenhouse–Geisser's ε; ``"LB"``, the lower bound ``ε = 1 / df1``,
    where sphericity is not estimable: the uncorrected test assumes a sphericity nobody can
    check there, and the lower bound is the correction valid whatever the covariance
    (Greenhouse & Geisser 1959).

    Parameters
    ----------
    row
        A row of :func:`rm_anova`'s table (``df1``, ``df2``, ``p`` and each correction's
        ``eps_*`` and ``p_*``).

    Returns
    -------
    {'none', 'GG', 'HF', 'LB'}
        The correction.

    Examples
    --------
    >>> correction(pd.Series({"df1": 5.0, "eps_gg": 0.42, "eps_hf": 0.47}))
    'GG'
    >>> correction(pd.Series({"df1": 5.0, "eps_gg": 0.81, "eps_hf": 1.0}))
    'HF'
    >>> correction(pd.Series({"df1": 1.0, "eps_gg": 1.0, "eps_hf": 1.0}))
    'none'
    >>> correction(pd.Series({"df1": 11.0, "eps_gg": float("nan"), "eps_hf": float("nan")}))
    'LB'
    """
    _anova_row(row, ("df1", "eps_gg"), "correction")
    if float(row["df1"]) <= 1 or ("F" in row.index and math.isnan(float(row["F"]))):
        return "none"
    if math.isnan(float(row["eps_gg"])):
        return "LB"
    return "GG" if float(row["eps_gg"]) < GG_BELOW else "HF"


def corrected_p(row) -> float:
    """The p-value of the correction :func:`correction` chooses: the one to decide on.

    Parameters
    ----------
    row
        A row of :func:`rm_anova`'s table (``df1``, ``df2``, ``p`` and each correction's
        ``eps_*`` and ``p_*``).

    Returns
    -------
    float
        The p-value.
    """
    _anova_row(row, ("df1", "eps_gg"), "corrected_p")
    chosen = correction(row)
    key = "p" if chosen == "none" else f"p_{chosen.lower()}"
    _anova_row(row, (key,), "corrected_p")
    return float(row[key])


def corrected_df(row) -> tuple[float, float]:
    """The degrees of freedom of the test :func:`correction` chooses, ``(ε df1, ε df2)``.

    Parameters
    ----------
    row
        A row of :func:`rm_anova`'s table (``df1``, ``df2``, ``p`` and each correction's
        ``eps_*`` and ``p_*``).

    Returns
    -------
    tuple of float
        ``(ε df1, ε df2)``.
    """
    chosen = correction(row)
    eps = 1.0 if chosen == "none" else float(row[f"eps_{chosen.lower()}"])
    return float(row["df1"]) * eps, float(row["df2"]) * eps


def normality(values: Sequence[float]) -> dict:
    """Shapiro–Wilk test (``W``, ``p``; scipy's port of Royston's algorithm, as R's
    ``shapiro.test``) of residuals or differences; NaN for fewer than 3 values or values
    without variance, where it is undefined.

    Parameters
    ----------
    values
        The residuals or differences.

    Returns
    -------
    dict
        ``W``, ``p`` and ``n``.

    Raises
    ------
    TypeError
        For a masked array, or a string, bool or ``None`` among the values.
    ValueError
        For values that are not one-dimensional or hold NaN or an infinity (the test would
        be NaN).

    Examples
    --------
    >>> result = normality([2.1, 3.4, 1.9, 5.6, 4.4, 3.0, 2.8, 3.9])
    >>> round(result["W"], 3)
    0.96
    """
    x = _sample(values, "values", "normality")
    if x.size < 3 or not np.ptp(x) > 1e-12 * max(1.0, float(np.abs(x).max())):
        return {"W": float("nan"), "p": float("nan"), "n": int(x.size)}
    result = sps.shapiro(x)
    return {"W": float(result.statistic), "p": float(result.pvalue), "n": int(x.size)}


def anova_residuals(data: pd.DataFrame, dv: str, within: Sequence[str], subject: str):
    """The residuals of the additive subject + cell model of a within-subject ANOVA:
    ``y - subject mean - cell mean + grand mean`` (every effect's error term pooled).

    Parameters
    ----------
    data
        Long data, one row per subject and cell.
    dv
        The dependent variable's column.
    within
        The within factors' columns.
    subject
        The subject's column.

    Returns
    -------
    numpy.ndarray
        The residuals, one per subject and cell, in the dependent variable's unit.

    Raises
    ------
    ValueError
        For a ``dv`` column that is not numeric (strings, bools), a value that is NaN or
        infinite (naming its row), or a subject without a value in some cell.
    """
    column = _numeric(data, dv, "anova_residuals")
    _finite(column, f"anova_residuals: dv {dv!r}", lambda i: f"in row {data.index[i]!r}")
    wide = data.pivot_table(index=subject, columns=list(within), values=dv, aggfunc="first")
    values = wide.to_numpy(float)
    if np.isnan(values).any():
        s, c = np.argwhere(np.isnan(values))[0]
        cell = wide.columns[c] if isinstance(wide.columns[c], tuple) else (wide.columns[c],)
        cell = tuple(v.item() if isinstance(v, np.generic) else v for v in cell)
        raise ValueError(
            f"anova_residuals needs a balanced design: subject {wide.index[s]} has no "
            f"{dv!r} at {dict(zip(within, cell, strict=True))}"
        )
    residuals = (
        values - values.mean(axis=1, keepdims=True) - values.mean(axis=0, keepdims=True)
    ) + values.mean()
    return residuals.ravel()


def assumptions(
    anova: pd.DataFrame, residuals: Sequence[float], differences: Sequence[tuple] = ()
) -> pd.DataFrame:
    """The assumption report of an analysis: for each ANOVA effect the sphericity correction it
    is reported with and why (:func:`correction`, with Mauchly's test), then
    Shapiro–Wilk of the ANOVA's residuals and of each ``(name, paired differences)``.

    Parameters
    ----------
    anova
        The table of :func:`rm_anova`.
    residuals
        The ANOVA's residuals (:func:`anova_residuals`).
    differences
        ``(name, paired differences)`` of the t-tests reported; default none.

    Returns
    -------
    pandas.DataFrame
        ``check, of, decision, mauchly_W, mauchly_p, shapiro_W, shapiro_p, n``.
    """
    nan = float("nan")
    rows = []
    for _, row in anova.iterrows():
        chosen = correction(row)
        if str(row.get("note") or "").startswith("not testable"):
            why = row["note"]
        elif chosen == "none":
            why = "none needed: 1 df, sphericity holds"
        elif chosen == "LB":
            why = (
                f"lower-bound corrected (ε = 1/{row['df1']:.0f}), the conclusion rests on it: "
                f"sphericity {row['sphericity']}"
            )
        elif chosen == "GG":
            why = f"Greenhouse–Geisser corrected: ε (GG) = {row['eps_gg']:.3f} < {GG_BELOW:g}"
        else:
            why = f"Huynh–Feldt corrected: ε (GG) = {row['eps_gg']:.3f} ≥ {GG_BELOW:g}"
        where = f"{row['analysis']}: " if "analysis" in row.index else ""
        rows.append(
            {
                "check": "sphericity",
                "of": f"{where}{row['source']}",
                "decision": why,
                "mauchly_W": row["mauchly_W"],
                "mauchly_p": row["mauchly_p"],
                "shapiro_W": nan,
                "shapiro_p": nan,
                "n": nan,
            }
        )
    checks = [("residuals of the ANOVA (participant + cell model)", residuals)]
    checks += [(f"paired differences {name}", values) for name, values in differences]
    for name, values in checks:
        test = normality(np.asarray(values, dtype=float))
        rows.append(
            {
                "check": "normality",
                "of": name,
                "decision": "Shapiro–Wilk",
                "mauchly_W": nan,
                "mauchly_p": nan,
                "shapiro_W": test["W"],
                "shapiro_p": test["p"],
                "n": float(test["n"]),
            }
        )
    return pd.DataFrame(rows)
