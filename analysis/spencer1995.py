"""The analysis of Spencer et al. (1995, §4.1) from staircase sessions.

**Matched intensity** of each staircase (participant × context × glare level): the mean disc
intensity at its reversals after the first two (the first reversals still carry the start
value's bias), as a fraction of the display maximum; with fewer than three reversals, the mean
of all reversal points. As an alternative, a **psychometric fit**: a logistic function of the
disc intensity fitted by maximum likelihood to the answers "glare brighter" (1), "disc
brighter" (0) and "neither" (½); its 50 % point is the match, reported only where it lies
inside the tested range (``psychometric_identified`` counts those staircases).

**Figure 13**: matched intensity against glare level, with and without context, mean ± SEM
over participants, with the 75 % line (the glare image's actual peak). **The context effect**:
a 12 (level) × 2 (context) repeated-measures ANOVA on the matched intensity.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from scipy.special import expit

from .figures import plt, png
from .load import Dataset
from .stats import apa_anova, rm_anova

__all__ = ["analyse_spencer1995", "psychometric_match", "reversal_match"]

DISCARDED_REVERSALS = 2
PEAK_FRACTION = 0.75  # Spencer §4: the glare image's peak


def reversal_match(staircase: pd.DataFrame) -> float:
    """Mean disc fraction at the reversals after the first two (or all, if fewer than 3)."""
    reversals = staircase.loc[staircase["reversal"].astype(bool), "disc_fraction"].to_numpy(float)
    if reversals.size == 0:
        return float(staircase["disc_fraction"].iloc[-1])
    kept = reversals[DISCARDED_REVERSALS:] if reversals.size > DISCARDED_REVERSALS else reversals
    return float(kept.mean())


def psychometric_match(staircase: pd.DataFrame) -> float:
    """50 % point of a logistic fit of P('glare brighter') against the disc intensity.

    NaN when it is not identified inside the tested range (0-1 of the maximum): a staircase
    whose answers never change (at the ceiling, the glare image looks brighter than the
    brightest disc) bounds the match but does not locate it.
    """
    x = staircase["disc_fraction"].to_numpy(float)
    y = staircase["response"].map({"glare": 1.0, "disc": 0.0, "neither": 0.5}).to_numpy(float)
    if np.all(y == y[0]):
        return float("nan")

    def negative_log_likelihood(params):
        centre, log_scale = params
        p = np.clip(expit((centre - x) / np.exp(log_scale)), 1e-9, 1 - 1e-9)
        return -np.sum(y * np.log(p) + (1 - y) * np.log(1 - p))

    result = minimize(
        negative_log_likelihood,
        [float(np.mean(x)), np.log(0.05)],
        method="L-BFGS-B",
        bounds=[(-1.0, 2.0), (np.log(1e-3), np.log(1.0))],
    )
    centre = float(result.x[0])
    return centre if 0.0 <= centre <= 1.0 else float("nan")


def analyse_spencer1995(dataset: Dataset) -> dict:
    every = dataset.trials
    trials = every[every["counted"].astype(bool)]  # repeated flashes did not move a staircase
    rows = []
    for (participant, context, level), staircase in trials.groupby(
        ["participant", "context", "glare_level"]
    ):
        rows.append(
            {
                "participant": participant,
                "context": context,
                "glare_level": int(level),
                "strength": staircase["strength"].iloc[0],
                "trials": len(staircase),
                "reversals": int(staircase["reversal"].astype(bool).sum()),
                "match_reversals": reversal_match(staircase),
                "match_psychometric": psychometric_match(staircase),
            }
        )
    matches = pd.DataFrame(rows)
    summary = (
        matches.groupby(["context", "glare_level"])
        .agg(
            strength=("strength", "first"),
            n=("participant", "nunique"),
            match_mean=("match_reversals", "mean"),
            match_sem=("match_reversals", lambda s: s.std(ddof=1) / np.sqrt(s.count())),
            psychometric_mean=("match_psychometric", "mean"),
            psychometric_identified=("match_psychometric", "count"),
        )
        .reset_index()
    )
    tables = {"matches": matches, "summary": summary}
    text = {}
    if matches["context"].nunique() == 2:
        data = matches.rename(columns={"match_reversals": "match"}).astype({"glare_level": str})
        anova = rm_anova(data, "match", ["glare_level", "context"], "participant")
        anova["apa_gg"] = apa_anova(anova, correction="GG")
        anova["apa_hf"] = apa_anova(anova, correction="HF")
        tables["anova"] = anova
        text = {row.source: row.apa_gg for row in anova.itertuples()}
    repeated = len(every) - len(trials)
    text["repeated_presentations"] = (
        f"{repeated} of {len(every)} flashes missed their frames or timing and were shown "
        "again; the staircases use only the counted ones"
    )
    return {
        "tables": tables,
        "figures": {"figure13_matches.png": _figure13(summary)},
        "text": text,
    }


def _figure13(summary: pd.DataFrame) -> bytes:
    figure, axis = plt.subplots(figsize=(6, 4))
    for context, marker in (("none", "o"), ("lamp", "s")):
        part = summary[summary["context"] == context]
        if part.empty:
            continue
        axis.errorbar(
            part["glare_level"],
            100 * part["match_mean"],
            yerr=100 * part["match_sem"],
            marker=marker,
            capsize=3,
            label="with context" if context == "lamp" else "without context",
        )
    axis.axhline(100 * PEAK_FRACTION, color="k", ls="--", lw=0.8, label="actual peak (75 %)")
    axis.set_xlabel("glare level (1 = slightly blurry dot … 12 = unbelievable flare)")
    axis.set_ylabel("matched disc intensity (% of max), mean ± SEM")
    axis.legend(fontsize=8)
    return png(figure)
