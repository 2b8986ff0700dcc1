"""Statistics for the studies: repeated-measures ANOVA with sphericity, Holm, t-tests, groups.

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
``sphericity`` column, and ``apa_anova`` prints the uncorrected test with that reason.

The Wilcoxon signed-rank test (``wilcoxon_signed_rank``) is R's ``wilcox.test(x, mu = mu)`` with
R's defaults, written out so that the result does not depend on the SciPy version.

References
----------
Greenhouse & Geisser (1959), Psychometrika 24, 95-112; Huynh & Feldt (1976), J. Educ. Stat. 1,
69-82; Lecoutre (1991), J. Educ. Stat. 16, 371-372; Mauchly (1940); Box (1949); Holm (1979);
Wilcoxon (1945); Piepho (2004) for the compact letter display; the F tests: statsmodels
``AnovaRM``. Reference values: R 4.2 with car and afex (``tests/analysis/R``).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Literal, get_args

import numpy as np
import pandas as pd
from glarelab.analysis.effects import eta2_partial_ci
from scipy import stats as sps
from statsmodels.stats.anova import AnovaRM
from statsmodels.stats.multitest import multipletests

__all__ = [
    "apa_F",
    "apa_anova",
    "apa_p",
    "apa_t",
    "group_letters",
    "holm",
    "pairwise_tests",
    "rm_anova",
    "similarity_groups",
    "ttest_paired",
    "ttest_welch",
    "wilcoxon_signed_rank",
]

ROUNDING = 1e-12  # error SD below this fraction of the data's RMS is taken as none
WILCOXON_EXACT_BELOW_N = 50  # R's wilcox.test: exact p for fewer non-zero differences, no ties


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
    if not pd.api.types.is_numeric_dtype(df[dv]) or pd.api.types.is_bool_dtype(df[dv]):
        raise ValueError(f"{caller}: column dv={dv!r} must be numeric; got dtype {df[dv].dtype}")
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
    eta2_ci: bool = False,
) -> pd.DataFrame:
    """Repeated-measures ANOVA with Greenhouse–Geisser and Huynh–Feldt corrections and
    Mauchly's test.

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
    eta2_ci
        Add the 90 % interval of η²p (about 7 ms an effect, so off by default: a power
        analysis of thousands of simulated studies does without).

    Returns
    -------
    pandas.DataFrame
        One row per effect (main effects, then interactions, as ``a × b``) with columns
        ``source, df1, df2, F, p, eps_gg, p_gg, eps_hf, p_hf, eta2_partial,
        eta2_generalized, eta2p_ci_low, eta2p_ci_high`` (the 90 % interval of η²p,
        :func:`glarelab.analysis.effects.eta2_partial_ci`; only with ``eta2_ci``), ``mauchly_W,
        mauchly_p, sphericity``. For effects with one degree of freedom sphericity holds:
        epsilons 1, corrected p = p, Mauchly NaN. Where sphericity is not estimable (fewer
        than df + 1 subjects, or a singular covariance of the effect's contrast scores) the
        epsilons, corrected p-values and Mauchly's test are NaN and ``sphericity`` says why;
        otherwise it reads ``estimated``.

    Raises
    ------
    ValueError
        For missing columns, a non-numeric, NaN or infinite dependent variable, a subject with
        no value (or several) in a cell, fewer than two subjects, a factor with one level,
        a factor that is also the subject or dependent variable, or an effect without error
        variance (every subject's contrast scores equal, e.g. data without noise), where F is
        undefined.

    Notes
    -----
    The epsilons and Mauchly's test are given in the module docstring. The corrected p-values
    use the F distribution with ``ε df1`` and ``ε df2`` degrees of freedom; the Huynh–Feldt
    ``ε`` is capped at 1 as R does for its p-value. Partial eta squared is
    ``F df1 / (F df1 + df2)``. Generalized eta squared (Olejnik & Algina 2003; Bakeman 2005),
    afex's default effect size, is, in a design of within factors only,
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
    factors = [within] if isinstance(within, str) else list(within)
    if not factors:
        raise ValueError("rm_anova: within must name at least one factor; got none")
    missing = [c for c in (dv, subject, *factors) if c not in df.columns]
    if missing:
        raise ValueError(f"rm_anova: column(s) {missing} not in the data")
    names = [dv, subject, *factors]
    if len(set(names)) < len(names):
        raise ValueError(
            f"rm_anova: dv, subject and within factors must be different columns; got "
            f"dv={dv!r}, subject={subject!r}, within={factors!r}"
        )
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
    fit = AnovaRM(renamed, "dv", "subject", within=safe).fit().anova_table
    effects = [
        effect
        for order in range(1, len(factors) + 1)
        for effect in itertools.combinations(range(len(factors)), order)
    ]
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
            table_row = fit.loc[":".join(safe[i] for i in effect)]
            df1, df2 = float(table_row["Num DF"]), float(table_row["Den DF"])
            f_value = float(table_row["F Value"])
            p_value = float(table_row["Pr > F"])
            scores = _effect_scores(values, levels, effect)
            source = " × ".join(str(factors[i]) for i in effect)
            # no error variance beyond rounding: F is 0/0 or effect/rounding (statsmodels gave
            # F = -2.8 for constant data, R's car NaN)
            if not np.var(scores, axis=0, ddof=1).mean() > (ROUNDING * scale) ** 2:
                raise ValueError(
                    f"rm_anova: {dv!r} has no error variance for {source}: every subject's "
                    "scores on its contrasts are equal (to rounding), so F is undefined"
                )
            sphericity = _sphericity(scores, values.shape[1])
            eps_gg, eps_hf = sphericity["eps_gg"], sphericity["eps_hf"]
            rows.append(
                {
                    "source": source,
                    "df1": df1,
                    "df2": df2,
                    "F": f_value,
                    "p": p_value,
                    "eps_gg": eps_gg,
                    "p_gg": _corrected_p(f_value, df1, df2, eps_gg, p_value),
                    "eps_hf": eps_hf,
                    "p_hf": _corrected_p(f_value, df1, df2, eps_hf, p_value),
                    "eta2_partial": f_value * df1 / (f_value * df1 + df2),
                    "eta2_generalized": sums[effect][0] / (sums[effect][0] + all_errors),
                    **(
                        dict(
                            zip(
                                ("eta2p_ci_low", "eta2p_ci_high"),
                                eta2_partial_ci(f_value, df1, df2),
                                strict=True,
                            )
                        )
                        if eta2_ci
                        else {}
                    ),
                    "mauchly_W": sphericity["mauchly_W"],
                    "mauchly_p": sphericity["mauchly_p"],
                    "sphericity": sphericity["sphericity"],
                }
            )
    return pd.DataFrame(rows)


def _corrected_p(f_value: float, df1: float, df2: float, eps: float, p: float) -> float:
    if math.isnan(eps):
        return float("nan")
    if eps == 1.0:
        return p
    return float(sps.f.sf(f_value, df1 * eps, df2 * eps))


def holm(pvalues: Sequence[float], *, missing: Literal["raise", "omit"] = "raise") -> np.ndarray:
    """Holm-adjusted p-values (statsmodels ``multipletests``), in the input order.

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

    Examples
    --------
    >>> [round(float(p), 3) for p in holm([0.01, 0.04, 0.03])]
    [0.03, 0.06, 0.06]
    >>> holm([float("nan"), 0.0192, 0.3], missing="omit").round(4).tolist()  # R: NA .0384 .3
    [nan, 0.0384, 0.3]
    """
    if missing not in ("raise", "omit"):
        raise ValueError(f"holm: missing must be 'raise' or 'omit'; got {missing!r}")
    p = np.asarray(pvalues, dtype=float)
    if p.size == 0:
        return p
    computed = ~np.isnan(p) if missing == "omit" else np.ones(p.shape, bool)
    bad = np.flatnonzero(computed & ~((p >= 0) & (p <= 1)))
    if bad.size:
        raise ValueError(
            f"holm: p-values must be numbers in [0, 1]; got {p[bad[0]]} at position {bad[0]}"
        )
    adjusted = np.full(p.shape, np.nan)
    if computed.any():
        adjusted[computed] = multipletests(p[computed], method="holm")[1]
    return adjusted


def _sample(values: Sequence[float], name: str, caller: str) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.ndim != 1:
        raise ValueError(f"{caller}: {name} must be one-dimensional; got shape {array.shape}")
    _finite(array, f"{caller}: {name}", lambda i: f"at position {i}")
    return array


def ttest_paired(a: Sequence[float], b: Sequence[float]) -> dict:
    """Paired t-test: ``t``, ``df`` (n - 1), two-sided ``p``, mean difference.

    Raises
    ------
    ValueError
        For samples of different sizes, fewer than 2 pairs, or a value that is NaN or infinite
        (drop incomplete pairs first: R's ``t.test`` drops them silently).
    """
    a = _sample(a, "a", "ttest_paired")
    b = _sample(b, "b", "ttest_paired")
    if a.shape != b.shape or a.size < 2:
        raise ValueError(
            f"ttest_paired needs two samples of the same size, at least 2; got {a.size} and "
            f"{b.size}"
        )
    result = sps.ttest_rel(a, b)
    return {
        "t": float(result.statistic),
        "df": float(a.size - 1),
        "p": float(result.pvalue),
        "mean_difference": float(np.mean(a - b)),
    }


def ttest_welch(a: Sequence[float], b: Sequence[float]) -> dict:
    """Welch's unpaired t-test: ``t``, Welch–Satterthwaite ``df``, two-sided ``p``.

    Raises
    ------
    ValueError
        For fewer than 2 values in a sample, or a value that is NaN or infinite.
    """
    a = _sample(a, "a", "ttest_welch")
    b = _sample(b, "b", "ttest_welch")
    if a.size < 2 or b.size < 2:
        raise ValueError(
            f"ttest_welch needs at least 2 values in each sample; got {a.size} and {b.size}"
        )
    result = sps.ttest_ind(a, b, equal_var=False)
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    return {
        "t": float(result.statistic),
        "df": float(dof),
        "p": float(result.pvalue),
        "mean_difference": float(a.mean() - b.mean()),
    }


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
    if not math.isfinite(mu):
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
        counts = _signed_rank_counts(n)
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


def _signed_rank_counts(n: int) -> np.ndarray:
    """How many subsets of ``{1, …, n}`` have each sum ``0 … n(n+1)/2`` (exact for n < 63)."""
    counts = np.zeros(n * (n + 1) // 2 + 1, dtype=np.int64)
    counts[0] = 1
    for k in range(1, n + 1):
        counts[k:] = counts[k:] + counts[:-k]
    return counts


def pairwise_tests(df: pd.DataFrame, dv: str, factor: str, subject: str) -> pd.DataFrame:
    """Paired t-tests between every pair of levels of ``factor``, Holm-adjusted.

    Raises
    ------
    ValueError
        For missing columns, a non-numeric, NaN or infinite ``dv``, or a subject without
        exactly one value at every level.
    """
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
    levels = sorted(df[factor].unique(), key=str)
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
    names = group_letters(len(order))
    return {
        level: "".join(name for name, group in zip(names, order, strict=True) if level in group)
        for level in levels
    }


LETTERS = tuple("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ.")  # multcompView's


def group_letters(count: int, letters: Sequence[str] = LETTERS) -> list[str]:
    """The names of ``count`` letter groups, as R's ``multcompView::multcompLetters`` gives
    them: ``a … z, A … Z``, then the last letter as a prefix (``.a … .Z``, ``..a`` …).

    Examples
    --------
    >>> group_letters(3)
    ['a', 'b', 'c']
    >>> group_letters(54)[50:]
    ['Y', 'Z', '.a', '.b']
    """
    if count < 0:
        raise ValueError(f"group_letters: count must be 0 or more; got {count}")
    letters = list(letters)
    names: list[str] = []
    while count >= len(letters):  # multcompView's makeLtrs, unrolled
        names += letters[:-1]
        count -= len(letters) - 1
        letters = [letters[-1] + letter for letter in letters[:-1]] + [letters[-1]]
    return names + letters[:count]


def apa_p(p: float) -> str:
    """``p < .001``, ``p = .034`` or ``p > .999`` (APA: three decimals, no leading zero).

    Raises
    ------
    ValueError
        For a p that is NaN or outside [0, 1] (a test that could not be computed has no p to
        print; say why instead).

    Examples
    --------
    >>> apa_p(0.0341), apa_p(0.0004), apa_p(0.9996)
    ('p = .034', 'p < .001', 'p > .999')
    """
    try:
        value = float(p)
    except (TypeError, ValueError):
        value = float("nan")
    if not 0 <= value <= 1:
        shown = value if isinstance(p, int | float | np.floating) else repr(p)
        raise ValueError(f"apa_p: p must be a number in [0, 1]; got {shown}")
    if value < 0.001:
        return "p < .001"
    text = f"{value:.3f}"
    if text == "1.000":  # p >= .9995 would round to 1
        return "p > .999"
    return f"p = {text[1:]}"


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


Correction = Literal["none", "GG", "HF"]


def apa_anova(table: pd.DataFrame, *, correction: Correction) -> list[str]:
    """APA strings for the rows of an ``rm_anova`` table, uncorrected or corrected.

    Parameters
    ----------
    table
        The result of ``rm_anova``.
    correction
        ``"none"``, ``"GG"`` (Greenhouse–Geisser) or ``"HF"`` (Huynh–Feldt): the corrected
        tests give ``ε df1``, ``ε df2`` and the corrected p. Where sphericity is not
        estimable, the uncorrected test followed by the reason.

    Raises
    ------
    ValueError
        For another ``correction``.

    Examples
    --------
    >>> table = pd.DataFrame({"df1": [2.0, 11.0], "df2": [18.0, 77.0], "F": [2.98, 0.66],
    ...     "p": [0.076, 0.772], "eps_gg": [0.943, float("nan")],
    ...     "p_gg": [0.080, float("nan")], "eps_hf": [1.0, float("nan")],
    ...     "p_hf": [0.076, float("nan")],
    ...     "sphericity": ["estimated", "not estimable: 8 subjects for 11 df"]})
    >>> apa_anova(table, correction="GG")
    ['F(1.89, 16.97) = 2.98, p = .080',
     'F(11, 77) = 0.66, p = .772 (uncorrected; sphericity not estimable: 8 subjects for 11 df)']
    """
    if correction == "none":
        return [apa_F(r.df1, r.df2, r.F, r.p) for r in table.itertuples()]
    elif correction in ("GG", "HF"):
        suffix = correction.lower()
        strings = []
        for row in table.itertuples():
            eps, p = getattr(row, f"eps_{suffix}"), getattr(row, f"p_{suffix}")
            if math.isnan(eps):
                strings.append(
                    f"{apa_F(row.df1, row.df2, row.F, row.p)} (uncorrected; sphericity "
                    f"{row.sphericity})"
                )
            else:
                strings.append(apa_F(row.df1 * eps, row.df2 * eps, row.F, p))
        return strings
    else:
        raise ValueError(
            f"apa_anova: correction must be one of {', '.join(get_args(Correction))}; "
            f"got {correction!r}"
        )


def apa_t(dof: float, t: float, p: float) -> str:
    """``t(14) = 1.71, p = .054``."""
    d = f"{dof:.0f}" if float(dof).is_integer() else f"{dof:.1f}"
    return f"t({d}) = {t:.2f}, {apa_p(p)}"
