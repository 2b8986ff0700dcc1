"""Likert summaries of Luidolt (2020, §7.2.1): per category mean, SD, median, IQR and the
count of each rating; the distributions as diverging stacked bars (Figures 7.1-7.7); and a
Wilcoxon signed-rank test of each category against the scale midpoint (4), Holm-corrected
across categories."""

from __future__ import annotations

import numpy as np
import pandas as pd

from .figures import plt, png
from .load import Dataset
from .stats import apa_p, holm, wilcoxon_signed_rank

__all__ = ["analyse_luidolt2020"]

SCALE = range(1, 8)
MIDPOINT = 4


def analyse_luidolt2020(dataset: Dataset) -> dict:
    trials = dataset.trials
    categories = list(dict.fromkeys(trials.sort_values("trial")["category"]))
    rows = []
    for category in categories:
        ratings = trials.loc[trials["category"] == category, "rating"].astype(float)
        q1, q3 = np.percentile(ratings, [25, 75])
        if (ratings != MIDPOINT).any():
            test = wilcoxon_signed_rank(ratings, mu=MIDPOINT)
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
        row.update({f"count_{k}": int((ratings == k).sum()) for k in SCALE})
        rows.append(row)
    summary = pd.DataFrame(rows)
    summary["p_holm"] = holm(summary["p"])
    summary["apa"] = [
        f"V = {v:g}, {apa_p(p)} (Holm)"
        for v, p in zip(summary["wilcoxon_V"], summary["p_holm"], strict=True)
    ]
    comments = trials.loc[
        trials["comment"].notna(), ["participant", "category", "rating", "comment"]
    ]
    return {
        "tables": {"summary": summary, "comments": comments},
        "figures": {"figure7_ratings.png": _diverging(summary)},
        "text": {},
    }


def _diverging(summary: pd.DataFrame) -> bytes:
    figure, axis = plt.subplots(figsize=(7, 0.5 * len(summary) + 1.5))
    colours = plt.cm.RdBu(np.linspace(0.1, 0.9, 7))
    y = np.arange(len(summary))[::-1]
    for index, row in enumerate(summary.itertuples()):
        counts = np.array([getattr(row, f"count_{k}") for k in SCALE], float)
        share = 100 * counts / counts.sum()
        left = -share[:3].sum() - share[3] / 2  # centre the neutral rating on 0
        for k in range(7):
            axis.barh(
                y[index],
                share[k],
                left=left,
                color=colours[k],
                edgecolor="white",
                label=str(k + 1) if index == 0 else None,
            )
            left += share[k]
    axis.axvline(0, color="k", lw=0.8)
    axis.set_yticks(y, summary["category"])
    axis.set_xlabel("% of participants (1 = completely different … 7 = exactly the same)")
    axis.legend(ncol=7, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.25), frameon=False)
    return png(figure)
