"""The analysis of matching by adjustment (Yoshida et al. 2008, §5), for any glare methods.

- **Match**: the mean of the darker and brighter settings (``settings = "bounds"``), or the
  one setting (the dependent variable).
- **Levels × methods repeated-measures ANOVA** (Yoshida: 6 × 2), levels as ordinal positions
  shared by the methods (A-F ≡ a-f, ``level_index``), Greenhouse–Geisser corrected, and the
  follow-up ANOVAs on the subsets of levels the protocol names (Yoshida: {A, B, C} and
  {D, E, F}).
- **Methods at chosen levels** (Yoshida: D, E, F): t-tests between every pair of methods. The
  paper reports ``t(14)``; with 10 observers a paired test has 9 df, so the 14 df point to
  Welch's (unpaired) test. Its p-values (.05, .05, < .05 for t = 1.71, 1.73, 1.96) are
  consistent with one-sided tests: two-sided p for t(14) = 1.71 is .109, one-sided .055 (a
  one-sided Student test with 18 df fits them too). We report paired and Welch, two- and
  one-sided (H1: the method listed first in the protocol is the brighter); **Welch,
  one-sided** is consistent with the paper, **paired, two-sided** is the test that fits the
  repeated-measures design.
- **Pairwise contrasts** between levels within each method (paired t-tests, Holm) and the
  similarity groups they imply (compact letter display; Figure 6).
- **Boost** over the displayed disk luminance ``min(L_disk, L_dmax)`` (Yoshida: 220 cd/m²) in
  per cent with SEM (Figure 5); **settings and match** with SEM per level (Figure 4); the
  **questionnaire**: per cent "yes" per question (Table 1).
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
from scipy import stats as sps

from .figures import plt, png
from .load import Dataset, where
from .methods import display_text
from .stats import (
    apa_anova,
    apa_t,
    pairwise_tests,
    rm_anova,
    similarity_groups,
    ttest_paired,
    ttest_welch,
)

__all__ = ["analyse", "check", "design", "methods"]

MARKERS = "osD^v<>p*"
ONE_PARTICIPANT = (
    "one participant: the tables describe their settings; no ANOVA, t-test or contrast, as "
    "each tests differences between participants' means and needs at least two participants"
)


def design(protocol) -> tuple[list[str], list[tuple], str | None]:
    """Within factors, the cells every participant needs, and the block analysed (main)."""
    cells = [
        (m["name"], index)
        for m in protocol["glare"]["methods"]
        for index in range(1, len(m["labels"]) + 1)
    ]
    return ["method", "level_index"], cells, "main"


def check(trials: pd.DataFrame, protocol) -> list[str]:
    """Values no session of this protocol can write: a level label or disk luminance that is
    not the protocol's at that level, a setting outside the display's range (a match above its
    maximum cannot be shown), a match that is not the mean of its settings."""
    display = protocol["display"]
    low, high = display["black_cd_m2"], display["max_cd_m2"]
    methods = {m["name"]: m for m in protocol["glare"]["methods"]}
    bounds = protocol["trials"]["settings"] == "bounds"
    settings = ["darker_cd_m2", "brighter_cd_m2", "match_cd_m2"] if bounds else ["match_cd_m2"]
    problems = []
    for _, row in trials.iterrows():
        method = methods[row["method"]]
        index = int(row["level_index"])
        if index > len(method["labels"]):
            problems.append(
                f"{where(row)}: level_index {index}: method {row['method']} has "
                f"{len(method['labels'])} levels"
            )
            continue
        label, level = method["labels"][index - 1], method["levels_cd_m2"][index - 1]
        if row["level"] != label:
            problems.append(
                f"{where(row)}, column level: {row['level']!r} at level_index {index} of "
                f"method {row['method']}; the protocol's label there is {label!r}"
            )
        if not np.isclose(row["l_disk_cd_m2"], level, rtol=1e-6):
            problems.append(
                f"{where(row)}, column l_disk_cd_m2: {row['l_disk_cd_m2']!r} cd/m²; the "
                f"protocol's level {label} is {level:g} cd/m²"
            )
        for column in settings:
            value = row[column]
            if not low * (1 - 1e-9) <= value <= high * (1 + 1e-9):
                problems.append(
                    f"{where(row)}, column {column}: {value!r} cd/m² cannot be shown on the "
                    f"protocol's display ({low:g}-{high:g} cd/m²)"
                )
        if bounds:
            mean = (row["darker_cd_m2"] + row["brighter_cd_m2"]) / 2
            if not np.isclose(row["match_cd_m2"], mean, rtol=1e-9, atol=1e-12):
                problems.append(
                    f"{where(row)}, column match_cd_m2: {row['match_cd_m2']!r} is not the mean "
                    f"of the settings ({mean!r})"
                )
    return problems


def methods(protocol, participants: int, who: str) -> str:
    """Methods text naming the protocol's actual parameters."""
    s, g, t = protocol["stimulus"], protocol["glare"], protocol["trials"]
    background = protocol["background"]
    described = {
        "sky": lambda b: f"a cloudy sky (mean {b['mean_cd_m2']:g} cd/m²)",
        "uniform": lambda b: f"a uniform field of {b['cd_m2']:g} cd/m²",
        "lamp": lambda b: "a lamp scene",
        "exr": lambda b: f"the image {b['path']}",
    }[background["kind"]](background)
    glare = "; ".join(
        f"{m['title'] or m['name']}: {m['model']}"
        + (
            f" ({', '.join(f'{k} = {v}' for k, v in m['parameters'].items())})"
            if m["parameters"]
            else ""
        )
        + f", levels {m['labels'][0]}-{m['labels'][-1]} = "
        + ", ".join(f"{v:g}" for v in m["levels_cd_m2"])
        + " cd/m²"
        for m in g["methods"]
    )
    task = (
        "set a darker and a brighter target to look slightly but visibly darker and brighter than"
        if t["settings"] == "bounds"
        else "set a target to look as bright as"
    )
    references = sum(len(m["labels"]) for m in g["methods"])
    return (
        f"{who} {task} a {s['disk_deg']:g}° disk on {described} ({s['size_deg']:g}°) shown on "
        f"{display_text(protocol)}. Glare was added above L_dmax = {g['l_dmax_cd_m2']:g} cd/m² "
        f"({glare}), rendered at {s['supersample']}× resolution. The targets started at "
        f"{', '.join(f'{x:g}' for x in s['target_start_cd_m2'])} cd/m²; "
        f"{t['training_trials']} training trials preceded the {references} references, shown "
        f"once each in {t['order']} order."
    )


def _sem(x: pd.Series) -> float:
    return float(x.std(ddof=1) / np.sqrt(x.count())) if x.count() > 1 else float("nan")


def _anova(data: pd.DataFrame, label: str) -> pd.DataFrame:
    factors = ["L_disk", "method"] if data["method"].nunique() > 1 else ["L_disk"]
    table = rm_anova(data, "match_cd_m2", factors, "participant")
    table.insert(0, "analysis", label)
    table["apa"] = apa_anova(table, correction="none")
    table["apa_gg"] = apa_anova(table, correction="GG")
    table["apa_hf"] = apa_anova(table, correction="HF")
    return table


def analyse(dataset: Dataset, protocol, *, tests_only: bool = False) -> dict:
    """Every analysis of Yoshida §5 for the protocol's methods and levels: tables (DataFrames),
    figures (PNG bytes) and text.

    ``tests_only`` returns only the tables of statistical tests (no figures, no descriptive
    tables or fits), what a power analysis needs for each of thousands of simulated studies.
    """
    g = protocol["glare"]
    names = [m["name"] for m in g["methods"]]
    titles = {m["name"]: m["title"] or m["name"] for m in g["methods"]}
    bounds = protocol["trials"]["settings"] == "bounds"
    questions = [q["column"] for q in protocol["questionnaire"]["questions"]]
    trials = dataset.trials[dataset.trials["block"] == "main"].copy()
    trials["L_disk"] = trials["level_index"].astype(int)
    labels = {
        (m["name"], i + 1): label for m in g["methods"] for i, label in enumerate(m["labels"])
    }
    n_levels = len(g["methods"][0]["labels"])
    several = trials["participant"].nunique() > 1
    tables: dict[str, pd.DataFrame] = {}
    text: dict[str, str] = {}
    if several:
        anovas = [_anova(trials, f"{n_levels} × {len(names)} (all levels)")]
        for followup in protocol["analysis"]["followups"]:
            subset = trials[trials["L_disk"].isin(followup["levels"])]
            anovas.append(_anova(subset, f"{len(followup['levels'])} × {len(names)} "
                                         f"({followup['name']})"))  # fmt: skip
        tables["anova"] = pd.concat(anovas, ignore_index=True)
        main = tables["anova"][tables["anova"]["analysis"] == anovas[0]["analysis"].iloc[0]]
        main = main.set_index("source")
        text["main_effect_level"] = main.loc["L_disk", "apa_gg"]
        if len(names) > 1:
            text["main_effect_method"] = main.loc["method", "apa_gg"]
            text["interaction"] = main.loc["L_disk × method", "apa_gg"]
    else:
        text["inference"] = ONE_PARTICIPANT

    wide = trials.pivot_table(
        index="participant", columns=["method", "L_disk"], values="match_cd_m2"
    )
    rows = []
    for level in protocol["analysis"]["compare_methods_at"] if several else []:
        for first, second in itertools.combinations(names, 2):
            a, b = wide[(first, level)], wide[(second, level)]
            for name, result in (("paired", ttest_paired(a, b)), ("Welch", ttest_welch(a, b))):
                one_sided = sps.t.sf(result["t"], result["df"])  # H1: the first is brighter
                rows.append(
                    {
                        "level": f"{labels[(first, level)]}/{labels[(second, level)]}",
                        "methods": f"{first} > {second}",
                        "test": name,
                        "t": result["t"],
                        "df": result["df"],
                        "p_two_sided": result["p"],
                        "p_one_sided": one_sided,
                        "apa": apa_t(result["df"], result["t"], result["p"]),
                        "apa_one_sided": apa_t(result["df"], result["t"], one_sided),
                    }
                )
    if rows:
        tables["methods_at_levels"] = pd.DataFrame(rows)
    if tests_only:
        return {"tables": tables, "figures": {}, "text": text}

    if several:
        contrasts, groups = [], []
        for method in names:
            part = trials[trials["method"] == method]
            table = pairwise_tests(part, "match_cd_m2", "L_disk", "participant")
            table.insert(0, "method", method)
            table["a"] = [labels[(method, a)] for a in table["a"]]
            table["b"] = [labels[(method, b)] for b in table["b"]]
            contrasts.append(table)
            means = part.groupby("L_disk")["match_cd_m2"].mean()
            letters = similarity_groups(
                {labels[(method, k)]: v for k, v in means.items()},
                {(r.a, r.b): r.p_holm for r in table.itertuples()},
            )
            for level, value in means.items():
                label = labels[(method, level)]
                groups.append(
                    {
                        "method": method,
                        "level": label,
                        "mean_match_cd_m2": value,
                        "group": letters[label],
                    }
                )
        tables["pairwise_contrasts"] = pd.concat(contrasts, ignore_index=True)
        tables["similarity_groups"] = pd.DataFrame(groups)

    shown = np.minimum(trials["l_disk_cd_m2"], g["l_dmax_cd_m2"])
    trials["boost_percent"] = (trials["match_cd_m2"] - shown) / shown * 100
    summary = []
    for (method, level), part in trials.groupby(["method", "L_disk"], sort=False):
        row = {
            "method": method,
            "level": labels[(method, level)],
            "level_index": level,
            "l_disk_cd_m2": part["l_disk_cd_m2"].iloc[0],
            "n": part["participant"].nunique(),
        }
        if bounds:
            row |= {
                "lower_mean": part["darker_cd_m2"].mean(),
                "lower_sem": _sem(part["darker_cd_m2"]),
                "upper_mean": part["brighter_cd_m2"].mean(),
                "upper_sem": _sem(part["brighter_cd_m2"]),
            }
        row |= {
            "match_mean": part["match_cd_m2"].mean(),
            "match_sem": _sem(part["match_cd_m2"]),
            "boost_percent_mean": part["boost_percent"].mean(),
            "boost_percent_sem": _sem(part["boost_percent"]),
        }
        for column in questions:
            answers = part[column].dropna().astype(float)
            row[f"{column}_percent"] = 100 * answers.mean() if len(answers) else float("nan")
        summary.append(row)
    summary = pd.DataFrame(summary)
    summary["order"] = summary["method"].map(names.index)
    summary = summary.sort_values(["order", "level_index"]).drop(columns="order")
    summary = summary.reset_index(drop=True)
    settings = ["lower_mean", "lower_sem", "upper_mean", "upper_sem"] if bounds else []
    tables["bounds_and_match"] = summary[
        ["method", "level", "l_disk_cd_m2", "n", *settings, "match_mean", "match_sem"]
    ]
    tables["boost"] = summary[["method", "level", "boost_percent_mean", "boost_percent_sem"]]
    if questions:
        tables["questionnaire"] = summary[
            ["method", "level", *(f"{c}_percent" for c in questions)]
        ]
    figures = {
        "figure4_bounds_and_match.png": _figure4(
            summary, names, titles, g["l_dmax_cd_m2"], bounds
        ),
        "figure5_boost.png": _figure5(summary, names, titles),
    }
    return {"tables": tables, "figures": figures, "text": text}


def _figure4(
    summary: pd.DataFrame, names: list[str], titles: dict, l_dmax: float, bounds: bool
) -> bytes:
    figure, axes = plt.subplots(
        1, len(names), figsize=(4.5 * len(names), 3.8), sharey=True, squeeze=False
    )
    curves = (
        [("upper", "-o", "upper bound"), ("lower", "-s", "lower bound"), ("match", "--^", "match")]
        if bounds
        else [("match", "-o", "match")]
    )
    for axis, method in zip(axes[0], names, strict=True):
        part = summary[summary["method"] == method]
        x = np.arange(len(part))
        for column, style, name in curves:
            axis.errorbar(
                x,
                part[f"{column}_mean"],
                yerr=part[f"{column}_sem"],
                fmt=style,
                capsize=3,
                label=name,
            )
        axis.axhline(l_dmax, color="k", ls="--", lw=0.8)
        axis.set_xticks(
            x,
            [
                f"{lab}\n{lum:g}"
                for lab, lum in zip(part["level"], part["l_disk_cd_m2"], strict=True)
            ],
        )
        axis.set_title(titles[method])
        axis.set_xlabel("L_disk (cd/m²)")
    axes[0, 0].set_ylabel("perceived luminance (cd/m²), mean ± SEM")
    axes[0, 0].legend(fontsize=8)
    return png(figure)


def _figure5(summary: pd.DataFrame, names: list[str], titles: dict) -> bytes:
    figure, axis = plt.subplots(figsize=(5.5, 3.8))
    for method, marker in zip(names, MARKERS, strict=False):
        part = summary[summary["method"] == method]
        axis.errorbar(
            part["level_index"],
            part["boost_percent_mean"],
            yerr=part["boost_percent_sem"],
            marker=marker,
            capsize=3,
            label=titles[method],
        )
    axis.axhline(0, color="k", lw=0.8)
    positions = sorted(summary["level_index"].unique())
    ticks = [
        "/".join(summary.loc[summary["level_index"] == k, "level"].astype(str)) for k in positions
    ]
    axis.set_xticks(positions, ticks)
    axis.set_ylabel("boost over the displayed disk (%), mean ± SEM")
    axis.set_xlabel("level of L_disk")
    axis.legend(fontsize=8)
    return png(figure)
