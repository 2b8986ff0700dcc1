"""The analyses of Yoshida et al. (2008, §5) from brightness-matching sessions.

- **Match**: the mean of the darker and brighter settings (the dependent variable).
- **6 (L_disk) × 2 (method) repeated-measures ANOVA**, levels as ordinal labels (A-F ≡ a-f,
  ``level_index`` 1-6), Greenhouse–Geisser corrected, and the follow-up ANOVAs for {A, B, C}
  and {D, E, F}.
- **Methods at D, E, F**: t-tests of Gaussian against Vos. The paper reports ``t(14)``; with
  10 observers a paired test has 9 df, so the paper's 14 df are Welch's (unpaired). Its
  p-values (.05, .05, < .05 for t = 1.71, 1.73, 1.96) are also one-sided: two-sided p for
  t(14) = 1.71 is .109, one-sided .055. We report paired and Welch, two- and one-sided
  (Gaussian > Vos); **Welch, one-sided** reproduces the paper, **paired, two-sided** is the
  test that fits the repeated-measures design.
- **Pairwise contrasts** between levels within each method (paired t-tests, Holm) and the
  similarity groups they imply (compact letter display; Figure 6).
- **Boost** over 220 cd/m² in per cent with SEM (Figure 5); **bounds and match** with SEM per
  level (Figure 4); **questionnaire** percentages of "yes" (Table 1).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats as sps

from .figures import plt, png
from .load import Dataset
from .stats import (
    apa_anova,
    apa_t,
    pairwise_tests,
    rm_anova,
    similarity_groups,
    ttest_paired,
    ttest_welch,
)

__all__ = ["analyse_yoshida2008"]

L_DMAX_CD_M2 = 220.0  # Yoshida 2008 §3: the reference disk's luminance after clamping
METHOD_NAMES = {"gaussian": "Method I (Gaussian)", "vos": "Method II (Vos PSF)"}


def _sem(x: pd.Series) -> float:
    return float(x.std(ddof=1) / np.sqrt(x.count())) if x.count() > 1 else float("nan")


def _anova(data: pd.DataFrame, label: str) -> pd.DataFrame:
    table = rm_anova(data, "match_cd_m2", ["L_disk", "method"], "participant")
    table.insert(0, "analysis", label)
    table["apa"] = apa_anova(table, correction="none")
    table["apa_gg"] = apa_anova(table, correction="GG")
    table["apa_hf"] = apa_anova(table, correction="HF")
    return table


def analyse_yoshida2008(dataset: Dataset) -> dict:
    """Every analysis of Yoshida §5: tables (DataFrames), figures (PNG bytes) and text."""
    trials = dataset.trials[dataset.trials["block"] == "main"].copy()
    trials["L_disk"] = trials["level_index"].astype(int)
    labels = trials.groupby(["method", "L_disk"])["level"].first()
    tables: dict[str, pd.DataFrame] = {}
    anovas = [
        _anova(trials, "6 × 2 (all levels)"),
        _anova(trials[trials["L_disk"] <= 3], "3 × 2 ({A, B, C})"),
        _anova(trials[trials["L_disk"] >= 4], "3 × 2 ({D, E, F})"),
    ]
    tables["anova"] = pd.concat(anovas, ignore_index=True)

    wide = trials.pivot_table(
        index="participant", columns=["method", "L_disk"], values="match_cd_m2"
    )
    rows = []
    for level in (4, 5, 6):
        gaussian, vos = wide[("gaussian", level)], wide[("vos", level)]
        for name, result in (
            ("paired", ttest_paired(gaussian, vos)),
            ("Welch", ttest_welch(gaussian, vos)),
        ):
            one_sided = sps.t.sf(result["t"], result["df"])  # H1: Gaussian > Vos
            rows.append(
                {
                    "level": f"{labels[('gaussian', level)]}/{labels[('vos', level)]}",
                    "test": name,
                    "t": result["t"],
                    "df": result["df"],
                    "p_two_sided": result["p"],
                    "p_one_sided": one_sided,
                    "apa": apa_t(result["df"], result["t"], result["p"]),
                    "apa_one_sided": apa_t(result["df"], result["t"], one_sided),
                }
            )
    tables["methods_at_high_levels"] = pd.DataFrame(rows)

    contrasts, groups = [], []
    for method in ("gaussian", "vos"):
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

    trials["boost_percent"] = (trials["match_cd_m2"] - L_DMAX_CD_M2) / L_DMAX_CD_M2 * 100
    summary = []
    for (method, level), part in trials.groupby(["method", "L_disk"]):
        summary.append(
            {
                "method": method,
                "level": labels[(method, level)],
                "l_disk_cd_m2": part["l_disk_cd_m2"].iloc[0],
                "n": part["participant"].nunique(),
                "lower_mean": part["darker_cd_m2"].mean(),
                "lower_sem": _sem(part["darker_cd_m2"]),
                "upper_mean": part["brighter_cd_m2"].mean(),
                "upper_sem": _sem(part["brighter_cd_m2"]),
                "match_mean": part["match_cd_m2"].mean(),
                "match_sem": _sem(part["match_cd_m2"]),
                "boost_percent_mean": part["boost_percent"].mean(),
                "boost_percent_sem": _sem(part["boost_percent"]),
                "q1_glow_percent": 100 * part["q1_glow"].mean(),
                "q2_ring_percent": 100 * part["q2_ring"].mean(),
                "q3_same_size_percent": 100 * part["q3_same_size"].mean(),
            }
        )
    summary = pd.DataFrame(summary)
    tables["bounds_and_match"] = summary[
        [
            "method",
            "level",
            "l_disk_cd_m2",
            "n",
            "lower_mean",
            "lower_sem",
            "upper_mean",
            "upper_sem",
            "match_mean",
            "match_sem",
        ]
    ]
    tables["boost"] = summary[["method", "level", "boost_percent_mean", "boost_percent_sem"]]
    tables["questionnaire"] = summary[
        ["method", "level", "q1_glow_percent", "q2_ring_percent", "q3_same_size_percent"]
    ]

    figures = {
        "figure4_bounds_and_match.png": _figure4(summary),
        "figure5_boost.png": _figure5(summary),
    }
    main = tables["anova"][tables["anova"]["analysis"] == "6 × 2 (all levels)"].set_index("source")
    text = {
        "main_effect_level": main.loc["L_disk", "apa_gg"],
        "main_effect_method": main.loc["method", "apa_gg"],
        "interaction": main.loc["L_disk × method", "apa_gg"],
    }
    return {"tables": tables, "figures": figures, "text": text}


def _figure4(summary: pd.DataFrame) -> bytes:
    figure, axes = plt.subplots(1, 2, figsize=(9, 3.8), sharey=True)
    for axis, method in zip(axes, ("gaussian", "vos"), strict=True):
        part = summary[summary["method"] == method]
        x = np.arange(len(part))
        for column, style, name in (
            ("upper", "-o", "upper bound"),
            ("lower", "-s", "lower bound"),
            ("match", "--^", "match (mean)"),
        ):
            axis.errorbar(
                x,
                part[f"{column}_mean"],
                yerr=part[f"{column}_sem"],
                fmt=style,
                capsize=3,
                label=name,
            )
        axis.axhline(L_DMAX_CD_M2, color="k", ls="--", lw=0.8)
        axis.set_xticks(
            x,
            [
                f"{lab}\n{lum:g}"
                for lab, lum in zip(part["level"], part["l_disk_cd_m2"], strict=True)
            ],
        )
        axis.set_title(METHOD_NAMES[method])
        axis.set_xlabel("L_disk (cd/m²)")
    axes[0].set_ylabel("perceived luminance (cd/m²), mean ± SEM")
    axes[0].legend(fontsize=8)
    return png(figure)


def _figure5(summary: pd.DataFrame) -> bytes:
    figure, axis = plt.subplots(figsize=(5.5, 3.8))
    for method, marker in (("gaussian", "o"), ("vos", "s")):
        part = summary[summary["method"] == method]
        axis.errorbar(
            np.arange(1, len(part) + 1),
            part["boost_percent_mean"],
            yerr=part["boost_percent_sem"],
            marker=marker,
            capsize=3,
            label=METHOD_NAMES[method],
        )
    axis.axhline(0, color="k", lw=0.8)
    axis.set_xticks(range(1, 7), ["A/a", "B/b", "C/c", "D/d", "E/e", "F/f"])
    axis.set_ylabel("boost over 220 cd/m² (%), mean ± SEM")
    axis.set_xlabel("level of L_disk")
    axis.legend(fontsize=8)
    return png(figure)
