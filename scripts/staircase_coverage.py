"""How often a staircase's interval holds the true match: a coverage simulation with known truth.

Each simulated staircase runs the experiment's own rules
(:class:`glarelab.experiments.staircase.Staircase`: the protocol's start, steps, reversals,
"neither" rule and intensity grid) against an observer whose point of subjective equality
``T`` is known: at disc intensity ``x`` it sees the relative difference ``2 (T - x) / (T + x)``
plus normal noise of SD ``σ``, and answers "neither" within ``±b`` (the form of the suite's
simulated observers, :meth:`glarelab.observers.noise.Observer.compare`, whose defaults
are ``σ = 0.04``, ``b = 0.02``). ``T`` is drawn uniformly from 0.3-0.9 of the display maximum.

For each staircase the candidates for a 95 % interval of its match are computed, and the table
gives, per condition, how often each held ``T`` (with its 95 % binomial interval) and how often
it could be computed (``of``: the share of staircases that have one; ``infinite``: the share of
those that reach no bound):

- ``bootstrap``: the percentile bootstrap of the reversal mean, resampling the kept reversals
  as if independent (the analysis's interval before it was withdrawn);
- ``t reversals``: the t interval of the kept reversal points' mean;
- ``t midpoints``: the t interval of the mean of successive reversal pairs' midpoints
  (Wetherill & Levitt 1965);
- ``fit (Fieller)``: Fieller's interval of the logistic fit's 50 % point ``-b0 / b1``
  (:func:`glarelab.analysis.staircase.psychometric_fit`'s model, Wald covariance), where the fit
  is estimable;
- ``reversal range``: the lowest to the highest kept reversal point, what the analysis now shows
  (:func:`glarelab.analysis.staircase.reversal_range`): a description, named as such.

A 95 % interval that means what it says covers at least 93 % here. Run from the repository's
root (about a minute on one core with the defaults)::

    python scripts/staircase_coverage.py --per-condition 100 --seed 1
"""

from __future__ import annotations

import argparse
import math
import sys
import warnings

import numpy as np
import pandas as pd
from scipy import stats as sps

from glarelab.analysis.staircase import (
    DISCARDED_REVERSALS,
    RESPONSE_CODES,
    on_grid,
    psychometric_fit,
    reversal_match,
    reversal_range,
)
from glarelab.experiments.staircase import Staircase
from glarelab.protocols import load_protocol
from glarelab.protocols.staircase import intensity_grid

CONDITIONS = [  # (σ, b): the suite's defaults (0.04, 0.02) among sharper and noisier observers
    (sigma, band) for sigma in (0.02, 0.04, 0.08) for band in (0.0, 0.02, 0.05)
]
CANDIDATES = ["bootstrap", "t reversals", "t midpoints", "fit (Fieller)", "reversal range"]
BOOTSTRAP_RESAMPLES = 2000
CONFIDENCE = 0.95


def run(protocol, truth: float, sigma: float, band: float, neither: str, rng) -> pd.DataFrame:
    """One staircase of the protocol's rules against an observer whose match is ``truth``."""
    t = protocol["trials"]
    staircase = Staircase(
        level=1,
        strength=1.0,
        fraction=t["start_fraction"],
        steps=tuple(t["step_fractions"]),
        reversals_needed=t["reversals"],
        neither=neither,
        grid=intensity_grid(t),
    )
    rows = []
    while not staircase.done:
        x = staircase.fraction
        seen = 2 * (truth - x) / (truth + x) + sigma * rng.standard_normal()
        answer = "neither" if abs(seen) < band else ("glare" if seen > 0 else "disc")
        reversal = staircase.update(answer)
        rows.append({"disc_fraction": x, "response": answer, "reversal": reversal})
    return on_grid(pd.DataFrame(rows), protocol)


def kept_reversals(staircase: pd.DataFrame) -> np.ndarray:
    points = staircase.loc[staircase["reversal"], "disc_fraction"].to_numpy(float)
    return points[DISCARDED_REVERSALS:] if points.size > DISCARDED_REVERSALS else points


def t_interval(values: np.ndarray) -> tuple[float, float]:
    if values.size < 2 or values.std(ddof=1) == 0:
        return math.nan, math.nan
    half = sps.t.ppf(0.5 + CONFIDENCE / 2, values.size - 1) * values.std(ddof=1)
    half /= math.sqrt(values.size)
    return values.mean() - half, values.mean() + half


def fieller(staircase: pd.DataFrame) -> tuple[float, float]:
    """Fieller's interval of ``-b0 / b1`` from the logistic fit's Wald covariance; infinite
    where the slope is not significantly different from 0 at the level."""
    import statsmodels.api as sm

    fit = psychometric_fit(staircase)
    if fit["status"] != "estimated":
        return math.nan, math.nan
    x = staircase["disc_fraction"].to_numpy(float)
    y = staircase["response"].map(RESPONSE_CODES).to_numpy(float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = sm.GLM(y, sm.add_constant(x), family=sm.families.Binomial()).fit(tol=1e-14)
    (b0, b1), v = result.params, result.cov_params()
    z2 = sps.norm.ppf(0.5 + CONFIDENCE / 2) ** 2
    # the matches m = -b0 / b1 not rejected: (b0 + m b1)^2 <= z^2 (v00 + 2 m v01 + m^2 v11)
    a = b1 * b1 - z2 * v[1, 1]
    b = 2 * (b0 * b1 - z2 * v[0, 1])
    c = b0 * b0 - z2 * v[0, 0]
    if a <= 0 or b * b - 4 * a * c < 0:  # the slope not significant: no bounded interval
        return -math.inf, math.inf
    root = math.sqrt(b * b - 4 * a * c)
    low, high = sorted([(-b - root) / (2 * a), (-b + root) / (2 * a)])
    return low, high


def intervals(staircase: pd.DataFrame, rng) -> dict[str, tuple[float, float]]:
    kept = kept_reversals(staircase)
    result = {name: (math.nan, math.nan) for name in CANDIDATES}
    if kept.size >= 2:
        means = rng.choice(kept, size=(BOOTSTRAP_RESAMPLES, kept.size)).mean(axis=1)
        tail = 100 * (1 - CONFIDENCE) / 2
        result["bootstrap"] = tuple(np.percentile(means, [tail, 100 - tail]))
        result["t reversals"] = t_interval(kept)
    if kept.size >= 4:
        pairs = kept[: kept.size // 2 * 2].reshape(-1, 2).mean(axis=1)
        result["t midpoints"] = t_interval(pairs)
    result["fit (Fieller)"] = fieller(staircase)
    result["reversal range"] = reversal_range(staircase)
    return result


def simulate(protocol, per_condition: int, seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = []
    neither_rules = ("hold", "alternate")
    total = len(CONDITIONS) * len(neither_rules) * per_condition
    for sigma, band in CONDITIONS:
        for neither in neither_rules:
            for _ in range(per_condition):
                truth = float(rng.uniform(0.3, 0.9))
                staircase = run(protocol, truth, sigma, band, neither, rng)
                row = {"sigma": sigma, "band": band, "neither": neither, "truth": truth,
                       "trials": len(staircase), "match": reversal_match(staircase)}  # fmt: skip
                for name, (low, high) in intervals(staircase, rng).items():
                    row[f"{name}_low"], row[f"{name}_high"] = low, high
                rows.append(row)
                if len(rows) % 200 == 0:
                    print(f"  {len(rows)}/{total} staircases", file=sys.stderr)
    return pd.DataFrame(rows)


def coverage(data: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    rows = []
    for key, part in data.groupby(by, sort=False) if by else [((), data)]:
        row = dict(zip(by, key if isinstance(key, tuple) else (key,), strict=True))
        row["staircases"] = len(part)
        row["trials (mean)"] = round(float(part["trials"].mean()), 1)
        for name in CANDIDATES:
            low, high = part[f"{name}_low"], part[f"{name}_high"]
            available = low.notna()
            held = int(((low <= part["truth"]) & (part["truth"] <= high))[available].sum())
            n = int(available.sum())
            interval = sps.binomtest(held, n).proportion_ci(0.95) if n else None
            infinite = int((np.isinf(low) | np.isinf(high))[available].sum())
            row[name] = (
                f"{100 * held / n:.0f} % [{100 * interval.low:.1f}, {100 * interval.high:.1f}]"
                + (f" of {100 * n / len(part):.0f} %" if n < len(part) else "")
                + (f", {100 * infinite / n:.0f} % infinite" if infinite else "")
                if n
                else "—"
            )
        rows.append(row)
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--protocol", default="spencer1995", help="the staircase protocol")
    parser.add_argument("--per-condition", type=int, default=100, help="staircases per cell")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default=None, help="also write every staircase as a CSV")
    args = parser.parse_args(argv)
    if args.per_condition < 1:
        parser.error(f"--per-condition must be at least 1; got {args.per_condition}")
    protocol = load_protocol(args.protocol)
    data = simulate(protocol, args.per_condition, args.seed)
    if args.out:
        data.to_csv(args.out, index=False, float_format="%.17g")
    print(coverage(data, []).to_markdown(index=False, floatfmt="g"))
    print()
    print(coverage(data, ["sigma", "band", "neither"]).to_markdown(index=False, floatfmt="g"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
