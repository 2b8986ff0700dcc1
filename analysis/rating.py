"""The analysis of a rating questionnaire (Luidolt 2020, §7.2.1): per category mean, SD,
median, IQR and the count of each rating; the distributions as diverging stacked bars
(Figures 7.1-7.7); and a Wilcoxon signed-rank test of each category against the scale's
midpoint (Luidolt's 1-7 scale: 4), Holm-corrected across categories."""

from __future__ import annotations

import numpy as np
import pandas as pd

from .figures import plt, png
from .load import Dataset
from .stats import apa_p, holm, wilcoxon_signed_rank

__all__ = ["analyse", "check", "design", "methods"]


def design(protocol) -> tuple[list[str], list[tuple], str | None]:
    """Within factors, the cells every participant needs, and the block analysed (all)."""
    return ["category"], [(c,) for c in protocol["questionnaire"]["categories"]], None


def methods(protocol, participants: int, who: str) -> str:
    """Methods text naming the protocol's actual parameters."""
    q = protocol["questionnaire"]
    return (
        f"{who} rated {len(q['categories'])} categories ({', '.join(q['categories'])}) on a "
        f"{q['scale_min']}-{q['scale_max']} scale from “{q['anchors'][0]}” to "
        f"“{q['anchors'][1]}”{', each with an optional comment' if q['comments'] else ''}."
    )


def check(trials: pd.DataFrame, protocol) -> list[str]:
    """Values no session of this protocol can write beyond the columns' own checks (category
    and rating range): none."""
    return []


def analyse(dataset: Dataset, protocol, *, tests_only: bool = False) -> dict:
    """Per-category summaries with the Wilcoxon tests, the comments and the diverging bars:
    tables (DataFrames), figures (PNG bytes) and text.

    ``tests_only`` returns only the tables of statistical tests (no figures, no descriptive
    tables or fits), what a power analysis needs for each of thousands of simulated studies.
    """
    q = protocol["questionnaire"]
    scale = range(q["scale_min"], q["scale_max"] + 1)
    midpoint = (q["scale_min"] + q["scale_max"]) / 2
    trials = dataset.trials
    categories = [c for c in q["categories"] if (trials["category"] == c).any()]
    rows = []
    for category in categories:
        ratings = trials.loc[trials["category"] == category, "rating"].astype(float)
        q1, q3 = np.percentile(ratings, [25, 75])
        if (ratings != midpoint).any():
            test = wilcoxon_signed_rank(ratings, mu=midpoint)
            statistic, p = test["V"], test["p"]
        else:  # every rating at the midpoint: no evidence of a difference (R: V = 0, p = NA)
            statistic, p = 0.0, 1.0
        row = {
            "category": category,
            "n": int(ratings.count()),
            "mean": ratings.mean(),
            "sd": ratings.std(ddof=1),
            "median": ratings.median(),
            "iqr": q3 - q1,
            "wilcoxon_V": statistic,
            "p": p,
        }
        row.update({f"count_{k}": int((ratings == k).sum()) for k in scale})
        rows.append(row)
    summary = pd.DataFrame(rows)
    summary["p_holm"] = holm(summary["p"])
    summary["apa"] = [
        f"V = {v:g}, {apa_p(p)} (Holm)"
        for v, p in zip(summary["wilcoxon_V"], summary["p_holm"], strict=True)
    ]
    if tests_only:
        return {"tables": {"summary": summary}, "figures": {}, "text": {}}
    comments = trials.loc[
        trials["comment"].notna(), ["participant", "category", "rating", "comment"]
    ]
    return {
        "tables": {"summary": summary, "comments": comments},
        "figures": {"figure7_ratings.png": _diverging(summary, scale, q["anchors"])},
        "text": {},
    }


def _diverging(summary: pd.DataFrame, scale: range, anchors: list[str]) -> bytes:
    figure, axis = plt.subplots(figsize=(7, 0.5 * len(summary) + 1.5))
    colours = plt.cm.RdBu(np.linspace(0.1, 0.9, len(scale)))
    y = np.arange(len(summary))[::-1]
    below = len(scale) // 2  # ratings left of the middle; an odd scale has a neutral one
    for index, row in enumerate(summary.itertuples()):
        counts = np.array([getattr(row, f"count_{k}") for k in scale], float)
        share = 100 * counts / counts.sum()
        neutral = share[below] if len(scale) % 2 else 0.0
        left = -share[:below].sum() - neutral / 2  # the middle of the scale on 0
        for k in range(len(scale)):
            axis.barh(
                y[index],
                share[k],
                left=left,
                color=colours[k],
                edgecolor="white",
                label=str(scale[k]) if index == 0 else None,
            )
            left += share[k]
    axis.axvline(0, color="k", lw=0.8)
    axis.set_yticks(y, summary["category"])
    axis.set_xlabel(f"% of participants ({scale[0]} = {anchors[0]} … {scale[-1]} = {anchors[1]})")
    axis.legend(
        ncol=len(scale), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.25), frameon=False
    )
    return png(figure)
