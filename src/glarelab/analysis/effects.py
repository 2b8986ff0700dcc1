"""Effect sizes with confidence intervals, within-subject error bars and marginal means: what a
results section reports next to its tests (the tests and their assumption checks:
:mod:`glarelab.analysis.stats`).

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

R's ``effectsize`` finds the noncentrality parameters with ``optim`` (Nelder–Mead, absolute
tolerance 1e-9 on the probabilities), which leaves its interval limits a few 1e-5 from the
roots; here the roots are found to machine precision with Brent's method (``brentq``), and the
reference in ``tests/analysis/R`` solves the same equations with ``uniroot``.

References
----------
Steiger (2004), Psychological Methods 9, 164-182; Cumming & Finch (2001), Educ. Psychol. Meas.
61, 532-574 (noncentral t intervals of d); Kerby (2014), Compr. Psychol. 3; Hodges & Lehmann
(1963), Ann. Math. Stat. 34, 598-611; Cousineau (2005), Tutor. Quant. Methods Psychol. 1,
42-45; Morey (2008), same journal 4, 61-64;
Olejnik & Algina (2003), Psychological Methods 8, 434-447; Lenth, emmeans (R package).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import optimize
from scipy import stats as sps

from glarelab.analysis.stats import (
    WILCOXON_EXACT_BELOW_N,
    _sample,
    corrected_df,
    signed_rank_counts,
)
from glarelab.files.values import is_real

__all__ = [
    "eta2_partial_ci",
    "hodges_lehmann",
    "marginal_means",
    "paired_effect",
    "rank_biserial",
    "with_eta2_ci",
    "within_subject_ci",
    "zeroin",
]

ETA2_CONFIDENCE = 0.90  # Steiger (2004): the interval that matches the F test at α = .05
CONFIDENCE = 0.95


def _confidence(level: float, caller: str) -> float:
    if not (is_real(level) and 0 < level < 1):  # a string or a bool is no level
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
        The F statistic and the degrees of freedom of its test (corrected ones, ``ε df1`` and
        ``ε df2``, where the test is corrected: :func:`with_eta2_ci`).
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
    if not (is_real(f_value) and math.isfinite(f_value) and f_value >= 0):
        raise ValueError(f"eta2_partial_ci: f_value must be a finite number ≥ 0; got {f_value!r}")
    for name, df in (("df1", df1), ("df2", df2)):
        if not (is_real(df) and math.isfinite(df) and df > 0):
            raise ValueError(
                f"eta2_partial_ci: {name} must be a finite number > 0 (degrees of freedom); "
                f"got {df!r}"
            )
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
    """``a - b`` (or ``a`` as ``x``) as a 1-D float array of finite numbers, refusing as the
    t-tests do a masked array (its mask would be dropped), a string, a bool or None."""
    x = _sample(a, "x" if b is None else "a", caller)
    if b is not None:
        y = _sample(b, "b", caller)
        if x.shape != y.shape:
            raise ValueError(f"{caller}: a and b must have the same size; got {x.size}, {y.size}")
        x = x - y
    if not np.isfinite(x).all():
        raise ValueError(f"{caller}: the values must be finite numbers in one dimension")
    return x


def _mu(mu: float, caller: str) -> float:
    if not (is_real(mu) and math.isfinite(mu)):
        raise ValueError(f"{caller}: mu must be a finite number; got {mu!r}")
    return float(mu)


def paired_effect(
    a: Sequence[float],
    b: Sequence[float],
    *,
    confidence: float = CONFIDENCE,
    dz_interval: bool = True,
) -> dict:
    """The mean difference ``a - b`` with its t interval, and Cohen's d_z with its interval.

    Parameters
    ----------
    a, b
        The paired values, same length >= 2, in the measure's unit.
    confidence
        The interval's confidence level, in (0, 1); default :data:`CONFIDENCE` (0.95).
    dz_interval
        Whether to compute d_z's interval; default True.

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
    TypeError
        For a masked array (its mask would be dropped), or a string, bool or None among the
        values.

    Examples
    --------
    >>> result = paired_effect([5.1, 6.0, 5.8, 6.4, 5.5], [4.2, 5.1, 5.9, 5.0, 4.8])  # R: n5
    >>> round(result["d_z"], 3), round(result["dz_ci_low"], 3), round(result["dz_ci_high"], 3)
    (1.392, 0.081, 2.635)
    """
    confidence = _confidence(confidence, "paired_effect")
    if not isinstance(dz_interval, bool | np.bool_):  # 'no' is true to `if`
        raise ValueError(f"paired_effect: dz_interval must be True or False; got {dz_interval!r}")
    if b is None:  # _pairs would take a alone: a one-sample effect, not the pairs' one
        raise TypeError("paired_effect: b must be the values paired with a; got None")
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

    Parameters
    ----------
    x
        The values (ratings), in the measure's unit.
    mu
        The value the differences are taken from (a scale's midpoint); default 0.
    confidence
        The interval's confidence level, in (0, 1); default :data:`CONFIDENCE` (0.95).

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

    Raises
    ------
    ValueError
        For a value or ``mu`` that is NaN or infinite, or a confidence outside (0, 1).
    TypeError
        For a masked array (its mask would be dropped), or a string, bool or None among the
        values.

    Examples
    --------
    >>> result = rank_biserial([5, 5, 4, 6, 3, 5, 6, 4, 5, 7], mu=4)
    >>> round(result["r_rb"], 4)
    0.8333
    """
    confidence = _confidence(confidence, "rank_biserial")
    d = _pairs(x, None, "rank_biserial") - _mu(mu, "rank_biserial")
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


def hodges_lehmann(x: Sequence[float], *, mu: float = 0.0, confidence: float = CONFIDENCE) -> dict:
    """The Hodges–Lehmann estimate of the shift of ``x`` from ``mu`` with its confidence
    interval, as R's ``wilcox.test(x, mu = mu, conf.int = TRUE, conf.level = confidence)``
    computes them (its estimate minus ``mu``): on the same data as the signed-rank test.

    Parameters
    ----------
    x
        The sample (finite numbers; paired differences, or ratings).
    mu
        The value the shift is measured from (a scale's midpoint; 0 for differences).
    confidence
        The interval's level (default .95); R lowers it where the sample cannot reach it.

    Returns
    -------
    dict
        ``hl_shift`` (the estimate), ``hl_ci_low``, ``hl_ci_high``, ``hl_confidence`` (the
        level R reports: the one asked for, or the highest the sample allows) and
        ``hl_method`` (``"exact"``: the median of the Walsh averages and their order
        statistics; ``"normal"``: R's root of the asymptotic signed-rank statistic). NaN
        where every value equals ``mu`` (no test, no estimate) and, for the interval, where
        every other value is tied (R: "cannot compute confidence interval").

    Raises
    ------
    ValueError
        For an empty sample, a value or ``mu`` that is NaN or infinite, or a confidence
        outside (0, 1).
    TypeError
        For a masked array (its mask would be dropped), or a string, bool or None among the
        values.

    Notes
    -----
    The differences ``d = x - mu`` of zero are dropped first, as the test drops them. With
    fewer than 50 left, no ties and no zeros, R's exact method: the estimate is the median of
    the Walsh averages ``(d_i + d_j) / 2, i ≤ j``, the interval their ``q``-th smallest and
    ``q``-th largest, ``q`` the ``(1 - confidence) / 2`` quantile of the signed-rank
    distribution (R's ``qsignrank``; at least 1). Otherwise R's asymptotic method: with
    ``W(s)`` the continuity-corrected normal score of the signed-rank statistic of the
    non-zero ``d - s`` (mid-ranks, the tie correction of the variance), the interval's limits
    are the roots of ``W(s) = ±z`` and the estimate the root of the uncorrected ``W(s) = 0``,
    each found by R's ``uniroot`` (Brent's method as R's ``zeroin``, tolerance 1e-4) between
    the smallest and the largest ``d``: the numbers are R's to rounding. The estimate is then
    not the median of the Walsh averages (which keeps zeros and ignores ties): for ratings
    7, 5, 3, 6, 6, 6, 6, 4 against 4, R gives 2.0, the Walsh median 1.5.

    References
    ----------
    Hodges & Lehmann (1963), Ann. Math. Stat. 34, 598-611; Bauer (1972), J. Am. Stat. Assoc.
    67, 687-690 (the interval); R's ``wilcox.test`` (stats package, R 4.2); Brent (1973),
    *Algorithms for Minimization without Derivatives*, ch. 4 (``zeroin``).

    Examples
    --------
    >>> result = hodges_lehmann([7, 5, 3, 6, 6, 6, 6, 4], mu=4)  # R: 5.9999552 - 4
    >>> round(result["hl_shift"], 4), result["hl_method"]
    (2.0, 'normal')
    >>> hodges_lehmann([1.0, 2.0, 4.0])["hl_shift"]
    2.25
    """
    confidence = _confidence(confidence, "hodges_lehmann")
    d = _pairs(x, None, "hodges_lehmann") - _mu(mu, "hodges_lehmann")
    if d.size == 0:
        raise ValueError("hodges_lehmann: x is empty")
    nan = float("nan")
    zeros = bool(np.any(d == 0))
    d = d[d != 0]
    n = d.size
    if n == 0:
        return {"hl_shift": nan, "hl_ci_low": nan, "hl_ci_high": nan, "hl_confidence": nan,
                "hl_method": "none: every value equals mu"}  # fmt: skip
    ranks = sps.rankdata(np.abs(d))
    ties = np.unique(ranks).size != n
    alpha = 1 - confidence
    x = d + mu  # R computes on the original scale, the shift is its estimate minus mu
    if n < WILCOXON_EXACT_BELOW_N and not ties and not zeros:
        i, j = np.triu_indices(n)
        walsh = np.sort((x[i] + x[j]) / 2)
        counts = signed_rank_counts(n)
        cumulative = np.cumsum(counts) / 2.0**n
        # R's qsignrank(alpha / 2, n): the smallest q with P(V <= q) >= alpha / 2
        q = int(np.searchsorted(cumulative, alpha / 2 - 10 * np.finfo(float).eps))
        q = max(q, 1)
        upper = n * (n + 1) // 2 - q
        # R's 2 psignrank(q - 1, n); cumulative[k] is P(V <= k)
        achieved = 2 * float(cumulative[q - 1])
        if achieved - alpha > alpha / 2:  # R: "requested conf.level not achievable"
            confidence = 1 - float(f"{achieved:.2g}")
        return {
            "hl_shift": float(np.median(walsh)) - mu,
            "hl_ci_low": float(walsh[q - 1]) - mu,
            "hl_ci_high": float(walsh[upper]) - mu,
            "hl_confidence": confidence,
            "hl_method": "exact",
        }
    low, high = float(x.min()), float(x.max())

    def score(location: float, correct: bool) -> float:
        """R's W(d): the normal score of the signed-rank statistic of x - location."""
        rest = x - location
        rest = rest[rest != 0]
        m = rest.size
        r = sps.rankdata(np.abs(rest))
        centred = float(r[rest > 0].sum()) - m * (m + 1) / 4
        _, sizes = np.unique(r, return_counts=True)
        sigma = math.sqrt(m * (m + 1) * (2 * m + 1) / 24 - float(np.sum(sizes**3 - sizes)) / 48)
        correction = 0.5 * np.sign(centred) if correct else 0.0
        with np.errstate(invalid="ignore", divide="ignore"):
            return float(np.float64(centred - correction) / sigma)

    at_low = score(low, True)
    at_high = score(high, True) if math.isfinite(at_low) else nan
    if not math.isfinite(at_high):  # every difference tied: R gives the midrange, no interval
        return {"hl_shift": float((low + high) / 2 - mu), "hl_ci_low": nan, "hl_ci_high": nan,
                "hl_confidence": nan, "hl_method": "normal"}  # fmt: skip
    while at_low - sps.norm.isf(alpha / 2) < 0 or at_high - sps.norm.ppf(alpha / 2) > 0:
        alpha *= 2  # R widens until the limits lie between the smallest and largest d
    if alpha >= 1 or 1 - confidence < alpha * 0.75:
        confidence = 1 - min(1.0, alpha)
    if alpha < 1:
        limits = [
            zeroin(lambda s, z=z: score(s, True) - z, low, high, at_low - z, at_high - z)
            for z in (sps.norm.isf(alpha / 2), sps.norm.ppf(alpha / 2))
        ]
    else:
        limits = [float(np.median(x))] * 2
    estimate = zeroin(lambda s: score(s, False), low, high, score(low, False), score(high, False))
    return {
        "hl_shift": float(estimate - mu),
        "hl_ci_low": float(limits[0] - mu),
        "hl_ci_high": float(limits[1] - mu),
        "hl_confidence": confidence,
        "hl_method": "normal",
    }


def zeroin(f, low: float, high: float, f_low: float, f_high: float, *, tol: float = 1e-4) -> float:
    """A root of ``f`` between ``low`` and ``high`` (``f_low``, ``f_high``: its values there,
    of opposite signs) by Brent's method, step for step as R's ``uniroot`` (its C routine
    ``zeroin2``, at most 1000 iterations), so that a root of a step function, which any
    point within ``tol`` of the step satisfies, is the point R returns.

    Parameters
    ----------
    f
        The function, of one float.
    low, high
        The interval's ends.
    f_low, f_high
        ``f(low)`` and ``f(high)``, of opposite signs.
    tol
        The root's tolerance, as ``uniroot``'s ``tol``; default 1e-4.

    Returns
    -------
    float
        The root.

    References
    ----------
    Brent (1973), *Algorithms for Minimization without Derivatives*, Prentice-Hall, ch. 4;
    Forsythe, Malcolm & Moler (1977), *Computer Methods for Mathematical Computations*,
    §7.2 (``zeroin``).

    Examples
    --------
    >>> round(zeroin(lambda x: x * x - 2, 0.0, 2.0, -2.0, 2.0, tol=1e-12), 10)
    1.4142135624
    """
    eps = np.finfo(float).eps
    a, b, fa, fb = low, high, f_low, f_high
    c, fc = a, fa
    if fa == 0:
        return a
    if fb == 0:
        return b
    for _ in range(1001):
        previous = b - a
        if abs(fc) < abs(fb):  # b the best approximation so far
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tolerance = 2 * eps * abs(b) + tol / 2
        step = (c - b) / 2
        if abs(step) <= tolerance or fb == 0:
            return b
        if abs(previous) >= tolerance and abs(fa) > abs(fb):  # try interpolation
            cb = c - b
            if a == c:  # two points: the secant
                t1 = fb / fa
                p = cb * t1
                q = 1.0 - t1
            else:  # inverse quadratic interpolation
                q = fa / fc
                t1 = fb / fc
                t2 = fb / fa
                p = t2 * (cb * q * (q - t1) - (b - a) * (t1 - 1.0))
                q = (q - 1.0) * (t1 - 1.0) * (t2 - 1.0)
            if p > 0:
                q = -q
            else:
                p = -p
            if p < (0.75 * cb * q - abs(tolerance * q) / 2) and p < abs(previous * q / 2):
                step = p / q
        if abs(step) < tolerance:
            step = tolerance if step > 0 else -tolerance
        a, fa = b, fb
        b += step
        fb = f(b)
        if (fb > 0 and fc > 0) or (fb < 0 and fc < 0):
            c, fc = a, fa
    return b


def _numeric_column(data: object, dv: str, caller: str) -> None:
    """Refuse a ``data`` that is not a DataFrame with a column ``dv`` of finite real numbers
    (strings would be averaged as text or read as numbers, bools as 0 and 1)."""
    if not isinstance(data, pd.DataFrame):
        raise ValueError(f"{caller}: data must be a pandas DataFrame; got {type(data).__name__}")
    if dv not in data.columns:
        raise ValueError(f"{caller}: dv {dv!r} is not a column of data ({list(data.columns)})")
    column = data[dv]
    kind = column.dtype.kind
    if kind not in "iuf":
        raise ValueError(
            f"{caller}: the dv column {dv!r} must hold real numbers; got dtype {column.dtype}"
        )
    if not np.isfinite(column.to_numpy(float)).all():
        raise ValueError(f"{caller}: the dv column {dv!r} holds NaN or infinite values")


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

    Parameters
    ----------
    data
        The trials or cell means, long format: one row per subject and cell.
    dv
        The dependent variable's column.
    within
        The within factors' columns.
    subject
        The subject's column.
    confidence
        The interval's confidence level, in (0, 1); default :data:`CONFIDENCE` (0.95).

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
    _numeric_column(data, dv, "within_subject_ci")
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

    Parameters
    ----------
    data
        The trials or cell means, long format: one row per subject and cell.
    dv
        The dependent variable's column.
    within
        The within factors' columns.
    subject
        The subject's column.
    confidence
        The interval's confidence level, in (0, 1); default :data:`CONFIDENCE` (0.95).

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
    _numeric_column(data, dv, "marginal_means")
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


def with_eta2_ci(anova: pd.DataFrame, *, confidence: float = ETA2_CONFIDENCE) -> pd.DataFrame:
    """An ``rm_anova`` table with the interval of each η²p (:func:`eta2_partial_ci`) in
    ``eta2p_ci_low`` and ``eta2p_ci_high``, from the degrees of freedom of the test the effect
    is reported and decided with (:func:`glarelab.analysis.stats.corrected_df`: ``ε df1, ε
    df2`` of its sphericity correction), so that the 90 % interval excludes 0 exactly when
    that test is significant at α = .05 (Steiger 2004, p. 171); NaN for an effect that could
    not be tested.

    η²p itself, ``F df1 / (F df1 + df2)``, is the same whatever ε; its interval is not: from
    the uncorrected df it can exclude 0 beside a corrected test that is not significant.

    Parameters
    ----------
    anova
        A table of :func:`glarelab.analysis.stats.rm_anova`.
    confidence
        The intervals' level; default :data:`ETA2_CONFIDENCE` (0.90, Steiger 2004).

    Returns
    -------
    pandas.DataFrame
        A copy with ``eta2p_ci_low`` and ``eta2p_ci_high``.

    Examples
    --------
    >>> row = {"df1": 2.0, "df2": 12.0, "F": 4.0, "p": 0.046, "eps_gg": 0.5, "eps_hf": 0.52,
    ...        "p_gg": 0.092, "p_hf": 0.088, "eps_lb": 0.5, "p_lb": 0.092}
    >>> shown = with_eta2_ci(pd.DataFrame([row]))  # GG: F(1, 6), p = .092: includes 0
    >>> float(shown["eta2p_ci_low"].iloc[0])
    0.0
    """
    limits = []
    for _, row in anova.iterrows():
        if not math.isfinite(float(row["F"])):
            limits.append((float("nan"), float("nan")))
            continue
        df1, df2 = corrected_df(row)
        limits.append(eta2_partial_ci(float(row["F"]), df1, df2, confidence=confidence))
    return anova.assign(
        eta2p_ci_low=[low for low, _ in limits], eta2p_ci_high=[high for _, high in limits]
    )
