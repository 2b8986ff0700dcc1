"""The analysis of a rating questionnaire (Luidolt 2020, §7.2.1): per category mean, SD,
median, IQR and the count of each rating; the distributions as diverging stacked bars
(Figures 7.1-7.7); and a Wilcoxon signed-rank test of each category against the scale's
midpoint (Luidolt's 1-7 scale: 4), Holm-corrected across categories.

A study that shows conditions (the night-vision pipeline with and without each effect) is
summarised per condition and category; each condition is compared with the first (the
reference: the full pipeline) category by category, by a Wilcoxon signed-rank test of the
participants' paired differences against 0, Holm-corrected across all comparisons. Its figure
shows each condition's ratings next to the stimulus that was rated (the set's preview of the
frames: first, …, last), when the stimulus set is given."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from .figures import plt, png
from .load import Dataset
from .methods import display_text
from .stats import apa_p, holm, wilcoxon_signed_rank

__all__ = ["analyse", "check", "design", "methods"]


def _conditions(protocol) -> list[dict]:
    return protocol.data.get("conditions") or []


def design(protocol) -> tuple[list[str], list[tuple], str | None]:
    """Within factors, the cells every participant needs, and the block analysed (all)."""
    categories = protocol["questionnaire"]["categories"]
    conditions = _conditions(protocol)
    if conditions:
        cells = [(c["name"], k) for c in conditions for k in categories]
        return ["condition", "category"], cells, None
    return ["category"], [(c,) for c in categories], None


def methods(protocol, participants: int, who: str) -> str:
    """Methods text naming the protocol's actual parameters."""
    q = protocol["questionnaire"]
    conditions = _conditions(protocol)
    shown = ""
    if conditions:
        scene = protocol["scene"]
        listed = "; ".join(
            f"{c['name']}: {', '.join(c['effects']) or 'no effect'}" for c in conditions
        )
        shown = (
            f" Before each condition's questions a procedural night {scene['kind']} "
            f"({scene['size_px'][0]} × {scene['size_px'][1]} px, {scene['lamps']} lamps of "
            f"{scene['lamp_cd_m2']:g} cd/m², ambient {scene['ambient_cd_m2']:g} cd/m²) was shown "
            f"on {display_text(protocol)} for {scene['seconds']:g} s "
            + {
                "still": "as a still, ",
                "enter_dark": f"as the eye adapts after leaving {scene['start_cd_m2']:g} cd/m² "
                f"({scene['frame_rate_hz']:g} frames/s), ",
                "gaze": "with the gaze moving from the road to a lamp and back "
                f"({scene['frame_rate_hz']:g} frames/s), ",
            }[scene["sequence"]]
            + "rendered through the night-vision pipeline with the condition's effects "
            f"({listed}), "
            "the conditions in an order of each participant's own; each condition was compared "
            f"with {conditions[0]['name']} by a Wilcoxon signed-rank test of the paired "
            "differences, Holm-corrected."
        )
    return (
        f"{who} rated {len(q['categories'])} categories ({', '.join(q['categories'])}) on a "
        f"{q['scale_min']}-{q['scale_max']} scale from “{q['anchors'][0]}” to "
        f"“{q['anchors'][1]}”{', each with an optional comment' if q['comments'] else ''}." + shown
    )


def check(trials: pd.DataFrame, protocol) -> list[str]:
    """Values no session of this protocol can write beyond the columns' own checks (category
    and rating range): none."""
    return []


def analyse(dataset: Dataset, protocol, *, stimuli: str | Path | None = None) -> dict:
    """Summaries, tests and figures; ``stimuli`` (the set's folder) puts the stimulus next to
    its ratings."""
    if _conditions(protocol):
        return _analyse_conditions(dataset, protocol, stimuli)
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
    comments = trials.loc[
        trials["comment"].notna(), ["participant", "category", "rating", "comment"]
    ]
    return {
        "tables": {"summary": summary, "comments": comments},
        "figures": {"figure7_ratings.png": _diverging(summary, scale, q["anchors"])},
        "text": {},
    }


def _summary_row(ratings: pd.Series, scale: range, midpoint: float) -> dict:
    q1, q3 = np.percentile(ratings, [25, 75])
    if (ratings != midpoint).any():
        test = wilcoxon_signed_rank(ratings, mu=midpoint)
        statistic, p = test["V"], test["p"]
    else:
        statistic, p = 0.0, 1.0
    row = {
        "n": int(ratings.count()),
        "mean": ratings.mean(),
        "sd": ratings.std(ddof=1),
        "median": ratings.median(),
        "iqr": q3 - q1,
        "wilcoxon_V": statistic,
        "p": p,
    }
    row.update({f"count_{k}": int((ratings == k).sum()) for k in scale})
    return row


def _analyse_conditions(dataset: Dataset, protocol, stimuli) -> dict:
    q = protocol["questionnaire"]
    scale = range(q["scale_min"], q["scale_max"] + 1)
    midpoint = (q["scale_min"] + q["scale_max"]) / 2
    trials = dataset.trials
    conditions = [c for c in _conditions(protocol) if (trials["condition"] == c["name"]).any()]
    categories = [c for c in q["categories"] if (trials["category"] == c).any()]
    rows = []
    for condition in conditions:
        for category in categories:
            chosen = (trials["condition"] == condition["name"]) & (trials["category"] == category)
            cell = trials[chosen]
            ratings = cell["rating"].astype(float)
            rows.append(
                {"condition": condition["name"], "category": category}
                | _summary_row(ratings, scale, midpoint)
            )
    summary = pd.DataFrame(rows)
    summary["p_holm"] = holm(summary["p"])
    reference = conditions[0]["name"]
    wide = trials.pivot_table(
        index="participant", columns=["condition", "category"], values="rating", aggfunc="mean"
    )
    comparisons = []
    for condition in conditions[1:]:
        for category in categories:
            difference = (
                wide[(condition["name"], category)] - wide[(reference, category)]
            ).dropna()
            if (difference != 0).any():
                test = wilcoxon_signed_rank(difference, mu=0.0)
                statistic, p = test["V"], test["p"]
            else:  # no participant rated them differently
                statistic, p = 0.0, 1.0
            comparisons.append(
                {
                    "condition": condition["name"],
                    "reference": reference,
                    "category": category,
                    "n": int(difference.size),
                    "mean_difference": float(difference.mean()),
                    "median_difference": float(difference.median()),
                    "wilcoxon_V": statistic,
                    "p": p,
                }
            )
    compared = pd.DataFrame(comparisons)
    if not compared.empty:
        compared["p_holm"] = holm(compared["p"])
        compared["apa"] = [
            f"V = {v:g}, {apa_p(p)} (Holm)"
            for v, p in zip(compared["wilcoxon_V"], compared["p_holm"], strict=True)
        ]
    comments = trials.loc[
        trials["comment"].notna(), ["participant", "condition", "category", "rating", "comment"]
    ]
    text = {}
    for row in compared.itertuples() if not compared.empty else []:
        if row.p_holm < 0.05:
            text[f"{row.condition}, {row.category}"] = (
                f"rated {abs(row.mean_difference):.2f} points "
                f"{'lower' if row.mean_difference < 0 else 'higher'} than {row.reference} "
                f"({row.apa})"
            )
    figure = _by_condition(summary, conditions, categories, scale, q["anchors"], stimuli)
    return {
        "tables": {"summary": summary, "comparisons": compared, "comments": comments},
        "figures": {"ratings_by_condition.png": figure},
        "text": text,
    }


def _by_condition(summary, conditions, categories, scale, anchors, stimuli) -> bytes:
    """One row per condition: the stimulus rated (its preview strip) and the ratings of each
    category as diverging stacked bars."""
    rows = len(conditions)
    figure, axes = plt.subplots(
        rows,
        2,
        figsize=(12, (0.32 * len(categories) + 0.9) * rows + 0.8),
        gridspec_kw={"width_ratios": [1.25, 1.0]},
        squeeze=False,
    )
    colours = plt.cm.RdBu(np.linspace(0.1, 0.9, len(scale)))
    for index, condition in enumerate(conditions):
        picture, bars = axes[index]
        name = condition["name"]
        preview = Path(stimuli) / f"preview_{name}.png" if stimuli is not None else None
        if preview is not None and preview.is_file():
            picture.imshow(plt.imread(preview), interpolation="lanczos")
        else:
            picture.text(0.5, 0.5, "(stimulus set not given)", ha="center", va="center")
        picture.set_axis_off()
        picture.set_title(
            f"{name}: {', '.join(condition['effects']) or 'no effect'}", fontsize=9, loc="left"
        )
        part = summary[summary["condition"] == name].set_index("category")
        _bars(bars, part.loc[categories], scale, colours)
        if index == rows - 1:
            bars.set_xlabel(f"% ({scale[0]} = {anchors[0]} … {scale[-1]} = {anchors[1]})")
            bars.legend(
                ncol=len(scale), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.45),
                frameon=False,
            )  # fmt: skip
    figure.suptitle("Ratings per category, next to the stimulus rated (first … last frame)")
    return png(figure)


def _bars(axis, summary: pd.DataFrame, scale: range, colours) -> None:
    y = np.arange(len(summary))[::-1]
    below = len(scale) // 2
    for index, (_category, row) in enumerate(summary.iterrows()):
        counts = np.array([row[f"count_{k}"] for k in scale], float)
        share = 100 * counts / counts.sum()
        neutral = share[below] if len(scale) % 2 else 0.0
        left = -share[:below].sum() - neutral / 2
        for k in range(len(scale)):
            axis.barh(
                y[index], share[k], left=left, color=colours[k], edgecolor="white",
                label=str(scale[k]) if index == 0 else None,
            )  # fmt: skip
            left += share[k]
        axis.text(104, y[index], f"{row['mean']:.1f}", va="center", fontsize=7)
    axis.axvline(0, color="k", lw=0.8)
    axis.set_xlim(-100, 115)
    axis.set_yticks(y, list(summary.index), fontsize=8)


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
