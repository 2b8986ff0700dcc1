"""Effect sizes with confidence intervals, within-subject error bars, marginal means and the
assumption checks a results section reports next to its tests.

- :func:`eta2_partial_ci`: the confidence interval of partial eta squared by inverting the
  noncentral F distribution (Steiger 2004), as R's ``effectsize::F_to_eta2`` does; 90 % by
  default, the interval that matches a test at α = .05 (Steiger 2004, p. 171).
- :func:`paired_effect`: for a paired comparison, the mean difference with its t interval,
  Cohen's ``d_z`` (mean difference / SD of the differences) with its interval from the
  noncentral t distribution (as ``effectsize::cohens_d(paired = TRUE)``).
- :func:`rank_biserial` and :func:`hodges_lehmann`: the matched-pairs rank-biserial correlation
  (Kerby 2014) with ``effectsize::rank_biserial``'s Fisher-z interval, and the Hodges–Lehmann
  estimate of the shift (the median of the Walsh averages) for a Wilcoxon signed-rank test.
- :func:`within_subject_ci`: Cousineau (2005) normalised means with Morey's (2008)
  correction, the error bars of within-subject designs.
- :func:`marginal_means`: each level's mean over the other within factors with its t interval,
  as ``emmeans`` gives them for an ``afex`` repeated-measures model (its default
  multivariate model).
- :func:`normality`: Shapiro–Wilk of the ANOVA's residuals or of paired differences.

R's ``effectsize`` finds the noncentrality parameters with ``optim`` (Nelder–Mead, absolute
tolerance 1e-9 on the probabilities), which leaves its interval limits a few 1e-5 from the
roots; here the roots are found to machine precision with Brent's method (``brentq``), and the
reference in ``tests/analysis/R`` solves the same equations with ``uniroot``.

References
----------
Steiger (2004), Psychological Methods 9, 164-182; Cumming & Finch (2001), Educ. Psychol. Meas.
61, 532-574 (noncentral t intervals of d); Kerby (2014), Compr. Psychol. 3; Hodges & Lehmann
(1963), Ann. Math. Stat. 34, 598-611; Cousineau (2005), Tutor. Quant. Methods Psychol. 1,
42-45; Morey (2008), same journal 4, 61-64; Shapiro & Wilk (1965), Biometrika 52, 591-611;
Olejnik & Algina (2003), Psychological Methods 8, 434-447; Lenth, emmeans (R package).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import optimize
from scipy import stats as sps

__all__ = [
    "anova_residuals",
    "assumptions",
    "eta2_partial_ci",
    "hodges_lehmann",
    "marginal_means",
    "normality",
    "paired_effect",
    "rank_biserial",
    "with_eta2_ci",
    "within_subject_ci",
]

ETA2_CONFIDENCE = 0.90  # Steiger (2004): the interval that matches the F test at α = .05
CONFIDENCE = 0.95


def _confidence(level: float, caller: str) -> float:
    if not 0 < level < 1:
        raise ValueError(f"{caller}: confidence must lie strictly between 0 and 1; got {level!r}")
    return float(level)


def _ncp_root(cdf, statistic: float, probability: float, low: float, high: float) -> float:
    """The noncentrality ``λ`` with ``cdf(statistic, λ) = probability`` (decreasing in λ)."""
    while cdf(statistic, high) > probability:
        high = 2 * high + 1
    return float(optimize.brentq(lambda x: cdf(statistic, x) - probability, low, high, xtol=1e-14))


def eta2_partial_ci(
    f_value: float, df1: float, df2: float, *, confidence: float = ETA2_CONFIDENCE
) -> tuple[float, float]:
    """The two-sided confidence interval of partial eta squared for ``F(df1, df2)``.

    Parameters
    ----------
    f_value, df1, df2
        The F statistic and its degrees of freedom (uncorrected, as η²p itself).
    confidence
        Default .90 (Steiger 2004).

    Returns
    -------
    tuple
        ``(low, high)``, each ``λ / (λ + df2)`` for the noncentrality ``λ`` at which the
        observed F is the ``(1 ± confidence) / 2`` quantile; a limit is 0 where the observed F
        lies below the corresponding quantile of the central F (as ``effectsize`` sets it).

    Raises
    ------
    ValueError
        For a negative or non-finite F, non-positive df, or a confidence outside (0, 1).

    Examples
    --------
    >>> low, high = eta2_partial_ci(20.077, 5, 45)
    >>> round(low, 3), round(high, 3)
    (0.545, 0.768)
    """
    confidence = _confidence(confidence, "eta2_partial_ci")
    if not (math.isfinite(f_value) and f_value >= 0):
        raise ValueError(f"eta2_partial_ci: F must be a finite number ≥ 0; got {f_value!r}")
    if not (df1 > 0 and df2 > 0 and math.isfinite(df1) and math.isfinite(df2)):
        raise ValueError(f"eta2_partial_ci: df must be positive; got {df1!r}, {df2!r}")
    alpha = 1 - confidence

    def cdf(x, ncp):
        return sps.ncf.cdf(x, df1, df2, ncp) if ncp > 0 else sps.f.cdf(x, df1, df2)

    limits = []
    for probability in (1 - alpha / 2, alpha / 2):
        if f_value <= sps.f.ppf(probability, df1, df2):
            limits.append(0.0)
        else:
            limits.append(_ncp_root(cdf, f_value, probability, 0.0, max(10.0, 2 * f_value * df1)))
    return tuple(float(ncp / (ncp + df2)) for ncp in limits)


def _pairs(a: Sequence[float], b: Sequence[float] | None, caller: str) -> np.ndarray:
    x = np.asarray(a, dtype=float)
    if b is not None:
        y = np.asarray(b, dtype=float)
        if x.shape != y.shape:
            raise ValueError(f"{caller}: a and b must have the same size; got {x.size}, {y.size}")
        x = x - y
    if x.ndim != 1 or not np.isfinite(x).all():
        raise ValueError(f"{caller}: the values must be finite numbers in one dimension")
    return x


def paired_effect(
    a: Sequence[float],
    b: Sequence[float],
    *,
    confidence: float = CONFIDENCE,
    dz_interval: bool = True,
) -> dict:
    """The mean difference ``a - b`` with its t interval, and Cohen's d_z with its interval.

    Returns
    -------
    dict
        ``mean_difference``, ``md_ci_low``, ``md_ci_high`` (``t.test(a, b, paired = TRUE)``),
        ``d_z`` (mean / SD of the differences), ``dz_ci_low``, ``dz_ci_high`` (the noncentral
        t interval: ``λ / √n`` for the ``λ`` at which the observed t is the ``(1 ± conf) / 2``
        quantile; about 20 ms: ``dz_interval=False`` leaves it out, NaN).

    Raises
    ------
    ValueError
        For fewer than 2 pairs, unequal sizes, non-finite values, or differences without
        variance (d_z undefined).

    Examples
    --------
    >>> result = paired_effect([5.1, 6.0, 5.8, 6.4, 5.5], [4.2, 5.1, 5.9, 5.0, 4.8])  # R: n5
    >>> round(result["d_z"], 3), round(result["dz_ci_low"], 3), round(result["dz_ci_high"], 3)
    (1.392, 0.081, 2.635)
    """
    confidence = _confidence(confidence, "paired_effect")
    d = _pairs(a, b, "paired_effect")
    n = d.size
    if n < 2:
        raise ValueError(f"paired_effect needs at least 2 pairs; got {n}")
    sd = float(d.std(ddof=1))
    if not sd > 0:
        raise ValueError("paired_effect: the differences have no variance; d_z is undefined")
    mean = float(d.mean())
    half = sps.t.ppf(1 - (1 - confidence) / 2, n - 1) * sd / math.sqrt(n)
    t = mean / (sd / math.sqrt(n))
    alpha = 1 - confidence
    result = {
        "mean_difference": mean,
        "md_ci_low": mean - half,
        "md_ci_high": mean + half,
        "d_z": mean / sd,
        "dz_ci_low": float("nan"),
        "dz_ci_high": float("nan"),
    }
    if not dz_interval:
        return result

    def cdf(x, ncp):
        # scipy's noncentral t gives NaN deep in its tails (scipy 1.17, |ncp - t| > 10
        # with few df); there the probability is 1 (ncp far below t) or 0 (far above)
        value = sps.nct.cdf(x, n - 1, ncp)
        return value if math.isfinite(value) else float(ncp < x)

    # the limits lie within a few SE of t, SE ≈ √(1 + t² / (2 df)); wider brackets reach
    # where scipy's noncentral t gives NaN
    span = 12 * math.sqrt(1 + t**2 / (2 * (n - 1))) + 1
    limits = [
        float(optimize.brentq(lambda x, p=p: cdf(t, x) - p, t - span, t + span, xtol=1e-14))
        for p in (1 - alpha / 2, alpha / 2)
    ]
    return result | {"dz_ci_low": limits[0] / math.sqrt(n), "dz_ci_high": limits[1] / math.sqrt(n)}


def rank_biserial(x: Sequence[float], *, mu: float = 0.0, confidence: float = CONFIDENCE) -> dict:
    """The matched-pairs rank-biserial correlation of ``x - mu`` with its interval, as
    ``effectsize::rank_biserial(x, mu = mu)`` (0.8).

    Returns
    -------
    dict
        ``r_rb``: (the rank sum of the positive differences − that of the negative ones) /
        ``m (m + 1) / 2``, ranks of ``|x - mu|`` with mid-ranks over the ``m`` non-zero
        differences (zeros dropped, as effectsize and the test do); ``rb_ci_low``,
        ``rb_ci_high``:
        ``tanh(atanh(r) ± z SE)`` with ``SE = √((2m³ + 3m² + m) / 6) / (m (m + 1) / 2)``, ``m``
        the non-zero differences. NaN where every difference is zero (no test) or the
        interval is undefined (``|r| = 1``: the limits are then ±1 as effectsize's).

    Examples
    --------
    >>> result = rank_biserial([5, 5, 4, 6, 3, 5, 6, 4, 5, 7], mu=4)
    >>> round(result["r_rb"], 4)
    0.8333
    """
    confidence = _confidence(confidence, "rank_biserial")
    d = _pairs(x, None, "rank_biserial") - mu
    nan = float("nan")
    nonzero = d != 0
    m = int(nonzero.sum())
    if m == 0:
        return {"r_rb": nan, "rb_ci_low": nan, "rb_ci_high": nan}
    kept = d[nonzero]
    ranks = sps.rankdata(np.abs(kept))
    r = float((ranks[kept > 0].sum() - ranks[kept < 0].sum()) / (m * (m + 1) / 2))
    se = math.sqrt((2 * m**3 + 3 * m**2 + m) / 6) / (m * (m + 1) / 2)
    z = sps.norm.ppf(1 - (1 - confidence) / 2)
    with np.errstate(divide="ignore"):
        centre = np.arctanh(r)
    return {
        "r_rb": r,
        "rb_ci_low": float(np.tanh(centre - z * se)),
        "rb_ci_high": float(np.tanh(centre + z * se)),
    }


def hodges_lehmann(x: Sequence[float], *, mu: float = 0.0) -> float:
    """The Hodges–Lehmann estimate of the location of ``x - mu``: the median of the Walsh
    averages ``(d_i + d_j) / 2, i ≤ j`` — for paired differences, the shift.

    This is R's ``wilcox.test(x, conf.int = TRUE)$estimate`` where R computes the exact test
    (fewer than 50 values, no ties, no zeros); with ties R solves for the estimate numerically
    (``uniroot``, tolerance 1e-4) instead.

    Examples
    --------
    >>> hodges_lehmann([1.0, 2.0, 4.0])
    2.25
    """
    d = _pairs(x, None, "hodges_lehmann") - mu
    if d.size == 0:
        raise ValueError("hodges_lehmann: x is empty")
    i, j = np.triu_indices(d.size)
    return float(np.median((d[i] + d[j]) / 2))


def within_subject_ci(
    data: pd.DataFrame,
    dv: str,
    within: Sequence[str],
    subject: str,
    *,
    confidence: float = CONFIDENCE,
) -> pd.DataFrame:
    """Cousineau–Morey within-subject confidence intervals of each cell's mean.

    Each subject's values are centred on their own mean and moved to the grand mean
    (Cousineau 2005); the SD of the normalised values of a cell, times ``√(k / (k - 1))`` for
    ``k`` cells (Morey 2008), divided by ``√n``, is the cell's within-subject SEM; the
    interval is ``mean ± t(n - 1) SEM``.

    Returns
    -------
    pandas.DataFrame
        One row per cell: the within factors, ``n``, ``mean``, ``sem_within``, ``ci_half``
        (half the interval's width).

    Raises
    ------
    ValueError
        For a subject without exactly one value in every cell, or fewer than 2 subjects or
        cells.

    Examples
    --------
    >>> data = pd.DataFrame({"s": [1, 1, 2, 2, 3, 3], "c": ["x", "y"] * 3,
    ...                      "v": [1.0, 2.0, 3.0, 4.5, 5.0, 5.5]})
    >>> round(float(within_subject_ci(data, "v", ["c"], "s")["sem_within"].iloc[0]), 4)
    0.2041
    """
    confidence = _confidence(confidence, "within_subject_ci")
    within = list(within)
    wide = data.pivot_table(index=subject, columns=within, values=dv, aggfunc="count")
    if wide.isna().any().any() or (wide != 1).any().any():
        raise ValueError(
            f"within_subject_ci needs exactly one {dv!r} per subject and cell of {within}"
        )
    wide = data.pivot_table(index=subject, columns=within, values=dv, aggfunc="first")
    n, k = wide.shape
    if n < 2 or k < 2:
        raise ValueError(f"within_subject_ci needs 2 subjects and 2 cells; got {n} and {k}")
    values = wide.to_numpy(float)
    normalised = values - values.mean(axis=1, keepdims=True) + values.mean()
    sem = normalised.std(axis=0, ddof=1) * math.sqrt(k / (k - 1)) / math.sqrt(n)
    half = sps.t.ppf(1 - (1 - confidence) / 2, n - 1) * sem
    cells = wide.columns.to_frame(index=False)
    cells.columns = within
    return cells.assign(n=n, mean=values.mean(axis=0), sem_within=sem, ci_half=half)


def marginal_means(
    data: pd.DataFrame,
    dv: str,
    within: Sequence[str],
    subject: str,
    *,
    confidence: float = CONFIDENCE,
) -> pd.DataFrame:
    """Each level of each within factor: the mean over the other factors' cells with its
    standard error and t interval (``n - 1`` df), as ``emmeans(fit, ~ factor)`` gives them for
    an ``afex::aov_car`` fit (its multivariate model: the subjects' own marginal means).

    Returns
    -------
    pandas.DataFrame
        ``factor, level, n, emmean, se, df, ci_low, ci_high``.

    Examples
    --------
    >>> data = pd.DataFrame({"s": [1, 1, 2, 2, 3, 3], "c": ["x", "y"] * 3,
    ...                      "v": [1.0, 2.0, 3.0, 4.5, 5.0, 5.5]})
    >>> marginal_means(data, "v", ["c"], "s")["emmean"].round(3).tolist()
    [3.0, 4.0]
    """
    confidence = _confidence(confidence, "marginal_means")
    rows = []
    for factor in within:
        by = data.pivot_table(index=subject, columns=factor, values=dv, aggfunc="mean")
        n = len(by)
        t = sps.t.ppf(1 - (1 - confidence) / 2, n - 1)
        for level in by.columns:
            values = by[level].to_numpy(float)
            mean, se = float(values.mean()), float(values.std(ddof=1) / math.sqrt(n))
            rows.append(
                {
                    "factor": factor,
                    "level": level,
                    "n": n,
                    "emmean": mean,
                    "se": se,
                    "df": float(n - 1),
                    "ci_low": mean - t * se,
                    "ci_high": mean + t * se,
                }
            )
    return pd.DataFrame(rows)


def normality(values: Sequence[float]) -> dict:
    """Shapiro–Wilk test (``W``, ``p``; scipy's port of Royston's algorithm, as R's
    ``shapiro.test``) of residuals or differences; NaN for fewer than 3 values or values
    without variance, where it is undefined.

    Examples
    --------
    >>> result = normality([2.1, 3.4, 1.9, 5.6, 4.4, 3.0, 2.8, 3.9])
    >>> round(result["W"], 3)
    0.96
    """
    x = np.asarray(values, dtype=float)
    if x.size < 3 or not np.ptp(x) > 1e-12 * max(1.0, float(np.abs(x).max())):
        return {"W": float("nan"), "p": float("nan"), "n": int(x.size)}
    result = sps.shapiro(x)
    return {"W": float(result.statistic), "p": float(result.pvalue), "n": int(x.size)}


def anova_residuals(data: pd.DataFrame, dv: str, within: Sequence[str], subject: str):
    """The residuals of the additive subject + cell model of a within-subject ANOVA:
    ``y - subject mean - cell mean + grand mean`` (every effect's error term pooled)."""
    wide = data.pivot_table(index=subject, columns=list(within), values=dv, aggfunc="first")
    values = wide.to_numpy(float)
    residuals = (
        values - values.mean(axis=1, keepdims=True) - values.mean(axis=0, keepdims=True)
    ) + values.mean()
    return residuals.ravel()


def assumptions(
    anova: pd.DataFrame, residuals: Sequence[float], differences: Sequence[tuple] = ()
) -> pd.DataFrame:
    """The assumption report of an analysis: for each ANOVA effect the sphericity correction it
    is reported with and why (:func:`glarelab.analysis.apa.correction`, with Mauchly's test), then
    Shapiro–Wilk of the ANOVA's residuals and of each ``(name, paired differences)``.

    Returns
    -------
    pandas.DataFrame
        ``check, of, decision, mauchly_W, mauchly_p, shapiro_W, shapiro_p, n``.
    """
    from glarelab.analysis.apa import GG_BELOW, correction

    nan = float("nan")
    rows = []
    for _, row in anova.iterrows():
        chosen = correction(row)
        if chosen == "none":
            why = (
                "none needed: 1 df, sphericity holds"
                if row["df1"] <= 1
                else f"uncorrected: sphericity {row['sphericity']}"
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


def with_eta2_ci(anova: pd.DataFrame, *, confidence: float = ETA2_CONFIDENCE) -> pd.DataFrame:
    """An ``rm_anova`` table with the interval of each η²p (:func:`eta2_partial_ci`) in
    ``eta2p_ci_low`` and ``eta2p_ci_high``."""
    limits = [
        eta2_partial_ci(r.F, r.df1, r.df2, confidence=confidence) for r in anova.itertuples()
    ]
    return anova.assign(
        eta2p_ci_low=[low for low, _ in limits], eta2p_ci_high=[high for _, high in limits]
    )
