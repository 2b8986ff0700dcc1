"""The analysis of three-way staircase sessions (Spencer et al. 1995, §4.1).

**Matched intensity** of each staircase (participant × context × glare level): the mean disc
intensity at its reversals after the first two (the first reversals still carry the start
value's bias), as a fraction of the display maximum; with fewer than three reversals, the mean
of all reversal points. As an alternative, a **psychometric fit**: a logistic function of the
disc intensity fitted by maximum likelihood to the answers "glare brighter" (1), "disc
brighter" (0) and "neither" (½); its 50 % point is the match, reported only where it lies
inside the tested range (``psychometric_identified`` counts those staircases).

**Figure 13**: matched intensity against glare level, per context, mean ± SEM over
participants, with the line of the glare image's actual peak (Spencer: 75 %). **The context
effect**: a level × context repeated-measures ANOVA on the matched intensity (with one
context, a one-way ANOVA over the levels).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from scipy.special import expit

from .figures import plt, png
from .load import Dataset, where
from .methods import display_text
from .stats import apa_anova, rm_anova

__all__ = ["analyse", "check", "design", "methods", "psychometric_match", "reversal_match"]

DISCARDED_REVERSALS = 2
MARKERS = "osD^v<>"


def design(protocol) -> tuple[list[str], list[tuple], str | None]:
    """Within factors, the cells every participant needs, and the block analysed (all)."""
    levels = range(1, len(protocol["glare"]["strengths"]) + 1)
    cells = [(c["name"], level) for c in protocol["contexts"] for level in levels]
    return ["context", "glare_level"], cells, None


def methods(protocol, participants: int, who: str) -> str:
    """Methods text naming the protocol's actual parameters."""
    s, g, t = protocol["stimulus"], protocol["glare"], protocol["trials"]
    parameters = ", ".join(f"{k} = {v}" for k, v in g["parameters"].items())
    return (
        f"{who} compared a light source with glare ({g['model']} model"
        f"{'; ' + parameters if parameters else ''}; peak {100 * g['peak_fraction']:g} % of "
        f"the maximum; {len(g['strengths'])} strengths from {g['strengths'][0]:g} to "
        f"{g['strengths'][-1]:g}) with a disc and an annulus at {s['annulus_ratio']:.3g} of its "
        f"intensity, in {s['window_px']} × {s['window_px']} px windows on "
        f"{display_text(protocol)}, shown for "
        f"{' or '.join(f'{x:g}' for x in t['presentation_ms'])} ms, in contexts "
        f"{', '.join(c['name'] for c in protocol['contexts'])}. Interleaved staircases "
        f"({t['reversals']} reversals, steps {', '.join(f'{x:g}' for x in t['step_fractions'])} "
        f"of the maximum; 'neither': {t['neither']}) set the disc."
    )


def check(trials: pd.DataFrame, protocol) -> list[str]:
    """Values no session of this protocol can write: a strength that is not the protocol's at
    the trial's glare level."""
    strengths = protocol["glare"]["strengths"]
    problems = []
    for _, row in trials.iterrows():
        expected = strengths[int(row["glare_level"]) - 1]
        if not np.isclose(row["strength"], expected, rtol=1e-6):
            problems.append(
                f"{where(row)}, column strength: {row['strength']!r}; the protocol's glare "
                f"level {int(row['glare_level'])} has strength {expected:g}"
            )
    return problems


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


def analyse(dataset: Dataset, protocol, *, tests_only: bool = False) -> dict:
    """Matched intensities, their summary, the ANOVA and Figure 13: tables (DataFrames),
    figures (PNG bytes) and text.

    ``tests_only`` returns only the tables of statistical tests (no figures, no descriptive
    tables or fits), what a power analysis needs for each of thousands of simulated studies.
    """
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
                "match_psychometric": float("nan")
                if tests_only
                else psychometric_match(staircase),
            }
        )
    matches = pd.DataFrame(rows)
    needed = protocol["trials"]["reversals"]
    matches["converged"] = matches["reversals"] >= needed
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
    data = matches.rename(columns={"match_reversals": "match"}).astype({"glare_level": str})
    factors = ["glare_level", "context"] if matches["context"].nunique() > 1 else ["glare_level"]
    if data["participant"].nunique() > 1:
        anova = rm_anova(data, "match", factors, "participant")
        anova["apa_gg"] = apa_anova(anova, correction="GG")
        anova["apa_hf"] = apa_anova(anova, correction="HF")
        tables["anova"] = anova
        text |= {row.source: row.apa_gg for row in anova.itertuples()}
    else:
        text["inference"] = (
            "one participant: the tables describe their staircases; no ANOVA, which tests "
            "differences between participants' means and needs at least two participants"
        )
    unconverged = matches[~matches["converged"]]
    if len(unconverged):
        none = unconverged[unconverged["reversals"] == 0]
        listed = "; ".join(
            f"{r.participant} {r.context} level {r.glare_level} ({r.reversals} reversals, "
            f"{r.trials} trials)"
            for r in unconverged.itertuples()
        )
        text["unconverged_staircases"] = (
            f"{len(unconverged)} of {len(matches)} staircases ended before their {needed} "
            f"reversals (at the trial cap or with the session){': ' + listed}. "
            + (
                f"{len(none)} had no reversal at all: their match is the last disc intensity, "
                "a bound (the staircase ran into the end of its range), not a threshold. "
                if len(none)
                else ""
            )
            + "They are in the means and the ANOVA; the matches table marks them "
            "(converged = false)."
        )
    if tests_only:
        tested = {"anova": tables["anova"]} if "anova" in tables else {}
        return {"tables": tested, "figures": {}, "text": text}
    repeated = len(every) - len(trials)
    text["repeated_presentations"] = (
        f"{repeated} of {len(every)} flashes missed their frames or timing and were shown "
        "again; the staircases use only the counted ones"
    )
    return {
        "tables": tables,
        "figures": {
            "figure13_matches.png": _figure13(
                summary,
                [c["name"] for c in protocol["contexts"]],
                protocol["glare"]["peak_fraction"],
            )
        },
        "text": text,
    }


def _figure13(summary: pd.DataFrame, contexts: list[str], peak_fraction: float) -> bytes:
    figure, axis = plt.subplots(figsize=(6, 4))
    for context, marker in zip(contexts, MARKERS, strict=False):
        part = summary[summary["context"] == context]
        if part.empty:
            continue
        axis.errorbar(
            part["glare_level"],
            100 * part["match_mean"],
            yerr=100 * part["match_sem"],
            marker=marker,
            capsize=3,
            label=f"context: {context}",
        )
    axis.axhline(
        100 * peak_fraction,
        color="k",
        ls="--",
        lw=0.8,
        label=f"actual peak ({100 * peak_fraction:g} %)",
    )
    axis.set_xlabel("glare level (1 = weakest glare)")
    axis.set_ylabel("matched disc intensity (% of max), mean ± SEM")
    axis.legend(fontsize=8)
    return png(figure)
