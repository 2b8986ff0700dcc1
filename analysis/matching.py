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
  repeated-measures design, and the one the conclusions follow: Holm-corrected over every
  level and pair compared, with the mean difference and Cohen's d_z, each with its 95 % CI.
  The results text quotes the paper's test, labelled as the paper's, where the protocol asks
  for it (``analysis.quote_welch_tests``; yoshida2008 does).
- **Pairwise contrasts** between levels within each method (paired t-tests, Holm) and the
  similarity groups they imply (compact letter display; Figure 6).
- **Boost** over the displayed disk luminance ``min(L_disk, L_dmax)`` (Yoshida: 220 cd/m²) in
  per cent (Yoshida's Figure 5); **settings and match** per level (Yoshida's Figure 4), each
  with SEM and, in the figures, 95 % Cousineau–Morey within-subject intervals; the
  **questionnaire**: per cent "yes" per question (Table 1).
- **Estimated marginal means** of each factor's levels with 95 % CIs, and the **assumptions**:
  the sphericity correction of each effect and why, Shapiro–Wilk of the ANOVA's residuals and
  of the paired differences.
"""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
from glarelab.analysis.apa import anova_effect, corrected_p, series, unit_interval
from glarelab.analysis.effects import (
    anova_residuals,
    assumptions,
    marginal_means,
    paired_effect,
    with_eta2_ci,
    within_subject_ci,
)
from glarelab.analysis.figures import Figure, plt, png, small_multiples
from glarelab.analysis.load import Dataset, where
from glarelab.analysis.methods import display_text
from glarelab.analysis.stats import (
    apa_anova,
    apa_p,
    apa_t,
    holm,
    pairwise_tests,
    rm_anova,
    similarity_groups,
    ttest_paired,
    ttest_welch,
)
from scipy import stats as sps

__all__ = ["analyse", "check", "design", "methods", "stimulus_figures"]

MARKERS = "osD^v<>p*"
ALPHA = 0.05  # the significance level the results text uses
ERROR_BARS = (
    "95 % within-subject confidence intervals (Cousineau 2005 with Morey's 2008 correction, "
    "over every method × level cell): the spread left after each participant's own mean is "
    "removed, which is what the repeated-measures tests compare"
)
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
            label = f"{len(followup['levels'])} × {len(names)} ({followup['name']})"
            anovas.append(_anova(subset, label))
        tables["anova"] = pd.concat(anovas, ignore_index=True)
        main = tables["anova"][tables["anova"]["analysis"] == anovas[0]["analysis"].iloc[0]]
        main = main.set_index("source")
        text["main_effect_level"] = anova_effect(main.loc["L_disk"])
        if len(names) > 1:
            text["main_effect_method"] = anova_effect(main.loc["method"])
            text["interaction"] = anova_effect(main.loc["L_disk × method"])
    else:
        text["inference"] = ONE_PARTICIPANT

    wide = trials.pivot_table(
        index="participant", columns=["method", "L_disk"], values="match_cd_m2"
    )
    rows, differences, pairs = [], [], []
    for level in protocol["analysis"]["compare_methods_at"] if several else []:
        for first, second in itertools.combinations(names, 2):
            a, b = wide[(first, level)], wide[(second, level)]
            effect = paired_effect(a, b, dz_interval=False)
            where = f"{labels[(first, level)]}/{labels[(second, level)]}"
            differences.append((f"{first} − {second} at {where}", a - b))
            pairs.append((where, f"{first} > {second}", a, b))
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
                        "mean_difference": effect["mean_difference"],
                        "md_ci_low": effect["md_ci_low"],
                        "md_ci_high": effect["md_ci_high"],
                        "d_z": effect["d_z"] if name == "paired" else float("nan"),
                        "apa": apa_t(result["df"], result["t"], result["p"]),
                        "apa_one_sided": apa_t(result["df"], result["t"], one_sided),
                    }
                )
    if rows:
        compared = pd.DataFrame(rows)
        # the family the conclusions follow: the paired two-sided tests, Holm-corrected over
        # every level and pair compared; Welch's tests are the paper's, shown uncorrected
        paired = compared["test"] == "paired"
        compared["p_holm"] = float("nan")
        compared.loc[paired, "p_holm"] = holm(compared.loc[paired, "p_two_sided"])
        tables["methods_at_levels"] = compared
    if tests_only:
        return {"tables": tables, "figures": {}, "text": text}
    # the intervals of the effect sizes (root finding on noncentral distributions, ms each):
    # in the full analysis only, so that a power analysis's tests are the report's tests
    intervals_shown = dict(tables)
    if several:
        intervals_shown["anova"] = with_eta2_ci(tables["anova"])
        main = intervals_shown["anova"][
            intervals_shown["anova"]["analysis"] == anovas[0]["analysis"].iloc[0]
        ]
        main = main.set_index("source")
        text["main_effect_level"] = anova_effect(main.loc["L_disk"])
        if len(names) > 1:
            text["main_effect_method"] = anova_effect(main.loc["method"])
            text["interaction"] = anova_effect(main.loc["L_disk × method"])
    if rows:
        intervals = {
            (where, pair): paired_effect(a, b) for where, pair, a, b in pairs
        }  # fmt: skip
        compared = tables["methods_at_levels"].copy()
        for column in ("dz_ci_low", "dz_ci_high"):
            compared[column] = [
                intervals[(r.level, r.methods)][column] if r.test == "paired" else float("nan")
                for r in compared.itertuples()
            ]
        intervals_shown["methods_at_levels"] = compared
    if several:
        tables["effect_sizes"] = _effect_sizes(intervals_shown)

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
    # Cousineau–Morey 95 % within-subject intervals (each over every method × level cell)
    columns = (["darker_cd_m2", "brighter_cd_m2"] if bounds else []) + ["match_cd_m2"]
    prefixes = dict(
        zip(columns, ["lower", "upper", "match"] if bounds else ["match"], strict=True)
    )
    prefixes["boost_percent"] = "boost_percent"
    for column, prefix in prefixes.items():
        if not several:
            summary[f"{prefix}_ci_within"] = float("nan")
            continue
        within = within_subject_ci(trials, column, ["method", "L_disk"], "participant")
        half = within.set_index(["method", "L_disk"])["ci_half"]
        summary[f"{prefix}_ci_within"] = [
            half[(m, k)] for m, k in zip(summary["method"], summary["level_index"], strict=True)
        ]
    summary["order"] = summary["method"].map(names.index)
    summary = summary.sort_values(["order", "level_index"]).drop(columns="order")
    summary = summary.reset_index(drop=True)
    settings = [
        c for c in ("lower_mean", "lower_sem", "lower_ci_within", "upper_mean", "upper_sem",
                    "upper_ci_within") if bounds
    ]  # fmt: skip
    tables["bounds_and_match"] = summary[
        ["method", "level", "l_disk_cd_m2", "n", *settings, "match_mean", "match_sem",
         "match_ci_within"]
    ]  # fmt: skip
    tables["boost"] = summary[
        ["method", "level", "boost_percent_mean", "boost_percent_sem", "boost_percent_ci_within"]
    ]
    if several:
        factors = ["L_disk", "method"] if len(names) > 1 else ["L_disk"]
        means = marginal_means(trials, "match_cd_m2", factors, "participant")
        means["level"] = [
            "/".join(labels[(m, int(v))] for m in names) if f == "L_disk" else titles[v]
            for f, v in zip(means["factor"], means["level"], strict=True)
        ]
        means["factor"] = means["factor"].map({"L_disk": "level", "method": "glare method"})
        tables["marginal_means"] = means.rename(
            columns={"emmean": "match_mean", "se": "match_se", "ci_low": "match_ci_low",
                     "ci_high": "match_ci_high"}
        )  # fmt: skip
        tables["assumptions"] = assumptions(
            tables["anova"],
            anova_residuals(trials, "match_cd_m2", factors, "participant"),
            differences,
        )
    if questions:
        tables["questionnaire"] = summary[
            ["method", "level", *(f"{c}_percent" for c in questions)]
        ]
    n = trials["participant"].nunique()
    figures = {
        "bounds_and_match.png": Figure(
            _figure4(summary, names, titles, g["l_dmax_cd_m2"], bounds),
            "Settings and matches at each level of L_disk"
            if bounds
            else "Matches at each level of L_disk",
            (
                "Lower and upper bounds (the darker and the brighter setting) and their mean, "
                "the match, "
                if bounds
                else "The matched luminance "
            )
            + f"in cd/m², mean over n = {n} participants with {ERROR_BARS}, one panel per glare "
            f"method; the dashed line is L_dmax = {g['l_dmax_cd_m2']:g} cd/m², the most the "
            "display showed of the disk.",
        ),
        "boost.png": Figure(
            _figure5(summary, names, titles),
            "Brightness boost of the glare",
            "The match above the displayed disk luminance min(L_disk, L_dmax), in per cent of "
            f"it, mean over n = {n} participants with {ERROR_BARS}, per glare method; 0 % (the "
            "line) is no boost.",
        ),
        "participants_matches.png": Figure(
            _participants(trials, names, titles, labels),
            "Every participant's matches",
            "The matched luminance (cd/m²) of each participant at each level, one line per "
            f"glare method, one panel per participant (n = {n}); the pale wide lines are the "
            "means over all participants, so a participant who matched differently stands "
            "out.",
        ),
    }
    captions = {
        "anova": "Repeated-measures ANOVAs on the matched luminance",
        "methods_at_levels": "The glare methods compared at the levels the protocol names: "
        "paired t-tests (two-sided, Holm-corrected over the comparisons; the conclusions "
        "follow these) with the mean difference (cd/m², 95 % CI) and d_z (its CI in the "
        "effect sizes), and Welch's unpaired tests, two- and one-sided, uncorrected (the "
        "paper's)",
        "pairwise_contrasts": "Paired contrasts between the levels of each method "
        "(Holm-corrected)",
        "similarity_groups": "Similarity groups: levels sharing a letter do not differ "
        "(Holm-corrected contrasts)",
        "bounds_and_match": "Settings and matches per level (cd/m², mean, SEM, and half the "
        "95 % within-subject CI of the figures)",
        "boost": "Brightness boost over the displayed disk (%, mean, SEM, half the 95 % "
        "within-subject CI)",
        "marginal_means": "Estimated marginal means of the match (cd/m²) per level of each "
        "factor, averaged over the other, with 95 % CIs (t, n − 1 df; emmeans' multivariate "
        "model)",
        "effect_sizes": "Effect sizes with their confidence intervals: η²p (90 %, Steiger "
        "2004) and η²G of every ANOVA effect, the mean difference and d_z (95 %) of every "
        "paired comparison of the methods",
        "assumptions": "Assumptions: the sphericity correction of each effect and why "
        "(Mauchly's test), and Shapiro–Wilk tests of the ANOVA's residuals and of the "
        "paired differences of the method comparisons",
        "questionnaire": "Answers to the questions (% yes)",
    }
    return {
        "tables": tables,
        "figures": figures,
        "text": text,
        "results": _results(tables | intervals_shown, summary, protocol, n),
        "captions": {k: v for k, v in captions.items() if k in tables},
    }


def _effect_sizes(shown: dict) -> pd.DataFrame:
    """Every effect size with its interval, one row each: η²p (90 % CI) and η²G of the ANOVA
    effects, the mean difference and d_z (95 % CIs) of the paired comparisons."""
    nan = float("nan")
    rows = []
    for r in shown["anova"].itertuples():
        of = f"{r.analysis}: {r.source}"
        rows += [
            {"of": of, "effect_size": "η²p", "value": r.eta2_partial,
             "ci_low": r.eta2p_ci_low, "ci_high": r.eta2p_ci_high, "confidence": 0.90},
            {"of": of, "effect_size": "η²G", "value": r.eta2_generalized,
             "ci_low": nan, "ci_high": nan, "confidence": nan},
        ]  # fmt: skip
    if "methods_at_levels" in shown:
        for r in shown["methods_at_levels"].query("test == 'paired'").itertuples():
            of = f"{r.methods} at {r.level} (paired)"
            rows += [
                {"of": of, "effect_size": "mean difference (cd/m²)", "value": r.mean_difference,
                 "ci_low": r.md_ci_low, "ci_high": r.md_ci_high, "confidence": 0.95},
                {"of": of, "effect_size": "d_z", "value": r.d_z,
                 "ci_low": r.dz_ci_low, "ci_high": r.dz_ci_high, "confidence": 0.95},
            ]  # fmt: skip
    return pd.DataFrame(rows)


def _verdict(row) -> str:
    return "was significant" if corrected_p(row) < ALPHA else "was not significant"


EFFECT_NAMES = {
    "L_disk": "the main effect of level",
    "method": "the main effect of glare method",
    "L_disk × method": "the level × method interaction",
}


def _effects(table: pd.DataFrame) -> str:
    return "; ".join(
        f"{EFFECT_NAMES[row['source']]} {_verdict(row)}, {anova_effect(row)}"
        for _, row in table.iterrows()
    )


def _results(tables: dict, summary: pd.DataFrame, protocol, n: int) -> list[str]:
    """The results section as paragraphs: the ANOVAs, the methods compared at chosen levels,
    and the boost at the highest level, generated from the tables."""
    methods_ = protocol["glare"]["methods"]
    titles = {m["name"]: m["title"] or m["name"] for m in methods_}
    if "anova" not in tables:
        return [
            f"With {n} participant{'s' if n != 1 else ''} no inferential statistics can be "
            "computed; the figures and tables describe the settings."
        ]
    anova = tables["anova"]
    analyses = list(dict.fromkeys(anova["analysis"]))
    design = "level × glare method" if len(methods_) > 1 else "level"
    first = anova[anova["analysis"] == analyses[0]]
    text = (
        f"The matched luminance of the {n} participants was analysed with a "
        f"{analyses[0].split(' (')[0]} repeated-measures ANOVA ({design}): "
        f"{_effects(first)}."
    )
    for followup, analysis in zip(protocol["analysis"]["followups"], analyses[1:], strict=True):
        part = anova[anova["analysis"] == analysis]
        name = followup["name"]
        which = f"the levels {name}" if name.startswith("{") else f"the {name}"
        text += f" On {which} alone ({analysis.split(' (')[0]}), {_effects(part)}."
    text += (
        f" Effects with more than one degree of freedom are reported with Greenhouse–Geisser "
        f"corrected degrees of freedom where its ε < .75 and Huynh–Feldt corrected ones "
        f"otherwise; α = {unit_interval(ALPHA)}."
    )
    paragraphs = [text]
    if "methods_at_levels" in tables:
        tests = tables["methods_at_levels"]
        family = int((tests["test"] == "paired").sum())
        mean = summary.set_index(["method", "level"])["match_mean"]
        sentences, papers = [], []
        for (level, pair), part in tests.groupby(["level", "methods"], sort=False):
            paired = part[part["test"] == "paired"].iloc[0]
            welch = part[part["test"] == "Welch"].iloc[0]
            first_name, second_name = pair.split(" > ")
            first_label, second_label = level.split("/")
            differ = "differed" if paired["p_holm"] < ALPHA else "did not differ"
            sentences.append(
                f"at {level} the matches under {titles[first_name]} "
                f"(M = {mean[(first_name, first_label)]:.1f} cd/m²) and "
                f"{titles[second_name]} (M = {mean[(second_name, second_label)]:.1f} cd/m²) "
                f"{differ}, t({paired['df']:.0f}) = {paired['t']:.2f}, "
                f"{apa_p(paired['p_holm'])} (Holm), M_diff = {paired['mean_difference']:.1f} "
                f"cd/m², 95 % CI [{paired['md_ci_low']:.1f}, {paired['md_ci_high']:.1f}], "
                f"d_z = {paired['d_z']:.2f}, 95 % CI [{paired['dz_ci_low']:.2f}, "
                f"{paired['dz_ci_high']:.2f}]"
            )
            papers.append(f"at {level}, {welch['apa_one_sided']}")
        paragraph = (
            "The glare methods were compared at single levels by paired t-tests (two-sided), "
            f"Holm-corrected over the {family} comparisons: " + "; ".join(sentences) + "."
        )
        if protocol["analysis"]["quote_welch_tests"]:
            paragraph += (
                " Yoshida et al. (2008) report these comparisons as t(14), uncorrected; their "
                "p-values fit Welch's unpaired one-sided test, which gives here "
                + "; ".join(papers)
                + " (the paper's test, uncorrected; it ignores that each participant saw both "
                "methods, and the conclusions above do not rest on it)."
            )
        paragraphs.append(paragraph)
    top = summary[summary["level_index"] == summary["level_index"].max()]
    boosts = [
        f"{row['boost_percent_mean']:.1f} % (95 % within-subject CI ± "
        f"{row['boost_percent_ci_within']:.1f}) with "
        f"{titles[row['method']]} at {row['level']} ({row['l_disk_cd_m2']:,.0f} cd/m²)"
        for _, row in top.iterrows()
    ]
    paragraphs.append(
        "At the highest level the matches exceeded the luminance the display showed of the "
        f"disk by {series(boosts)}."
    )
    return paragraphs


def stimulus_figures(protocol, shown) -> list[Figure]:
    """The stimuli as the display showed them: the references of each glare method, the
    targets at their start luminances, and the references' profiles through the disk centre
    (Yoshida Fig. 3). ``shown`` is an :class:`glarelab.analysis.stimulus_figures.DisplayedSet`."""
    from glarelab.analysis.stimulus_figures import image_grid, profiles, radial_profile

    g, s = protocol["glare"], protocol["stimulus"]
    geometry = shown.geometry
    pixel_deg = geometry["pixel_deg"]
    size = geometry["size_px"]
    where = (
        f"Each image is {s['size_deg']:g}° ({size} px) square at {60 * pixel_deg:.2f} arcmin "
        f"per pixel, the disk {s['disk_deg']:g}° ({geometry['disk_diameter_px']:.0f} px), shown "
        f"here pixel for pixel: the luminance the {shown.describe_display()} showed, "
        "decode(encode(image)) through the set's calibration, relative to its maximum and "
        "encoded for an sRGB screen."
    )
    by_key = {
        (info.get("method"), info.get("label")): name
        for name, info in shown.images.items()
        if info["kind"] == "reference"
    }
    figures, rows = [], {}
    for method in g["methods"]:
        title = method["title"] or method["name"]
        names = [by_key[(method["name"], label)] for label in method["labels"]]
        pictures = [
            (shown.picture(name), f"{label}: L_disk = {shown.images[name]['disk_cd_m2']:g} cd/m²")
            for name, label in zip(names, method["labels"], strict=True)
        ]
        rows[title] = [
            (label, *radial_profile(shown.luminance(name), geometry["centre_px"], pixel_deg))
            for name, label in zip(names, method["labels"], strict=True)
        ]
        figures.append(
            Figure(
                image_grid(pictures),
                f"The references of {title} as the display showed them",
                f"{title} (model {method['model']}) at its {len(names)} levels "
                f"{method['labels'][0]}-{method['labels'][-1]} of the disk luminance L_disk; "
                f"above L_dmax = {g['l_dmax_cd_m2']:g} cd/m² the disk is clipped and the glare "
                f"added. {where}",
            )
        )
    targets = [n for n, info in shown.images.items() if info["kind"] == "target"]
    if targets:
        figures.append(
            Figure(
                image_grid(
                    [
                        (shown.picture(n), f"disk {shown.images[n]['disk_cd_m2']:g} cd/m²")
                        for n in sorted(targets, key=lambda n: shown.images[n]["disk_cd_m2"])
                    ]
                ),
                "The glare-free targets at their start luminances",
                "The targets the participants adjusted, at the luminances each trial started "
                f"from. {where}",
            )
        )
    figures.append(
        Figure(
            profiles(rows, lines={"L_dmax": g["l_dmax_cd_m2"]}),
            "Glare profiles of the references",
            "The displayed luminance (cd/m²) against the distance from the disk centre, "
            "averaged over all directions (one-pixel rings, so the background's clouds average "
            "out), one curve per level, one panel per glare method (Yoshida et al.'s Figure 3 "
            "shows one row); the dashed line is L_dmax, the most the display shows of the "
            "disk.",
        )
    )
    return figures


def _participants(trials: pd.DataFrame, names: list[str], titles: dict, labels: dict) -> bytes:
    participants = sorted(trials["participant"].unique())
    figure, axes = small_multiples(len(participants))
    means = trials.groupby(["method", "L_disk"])["match_cd_m2"].mean()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for axis, participant in zip(axes, participants, strict=True):
        part = trials[trials["participant"] == participant]
        for index, (method, marker) in enumerate(zip(names, MARKERS, strict=False)):
            colour = colours[index % len(colours)]
            levels = sorted(means.loc[method].index)
            axis.plot(
                levels, means.loc[method].to_numpy(), color=colour, alpha=0.3, lw=3, zorder=1
            )
            own = part[part["method"] == method].sort_values("L_disk")
            axis.plot(
                own["L_disk"],
                own["match_cd_m2"],
                marker=marker,
                ms=3.5,
                lw=1.2,
                color=colour,
                label=titles[method],
                zorder=2,
            )
        axis.set_title(participant, fontsize=9)
        axis.tick_params(labelsize=7)
    positions = sorted(trials["L_disk"].unique())
    ticks = ["/".join(labels[(m, k)] for m in names) for k in positions]
    axes[0].set_xticks(positions, ticks)
    for axis in axes:
        axis.tick_params(axis="x", labelrotation=45 if len(names) > 2 else 0)
    axes[0].set_ylabel("match (cd/m²)", fontsize=8)
    handles, names_ = axes[0].get_legend_handles_labels()
    # below the panels (in the first panel it covered that participant's lines)
    figure.legend(handles, names_, loc="upper center", bbox_to_anchor=(0.5, 0.0),
                  ncol=min(len(names_), 2), fontsize=8, frameon=False)  # fmt: skip
    figure.supxlabel("level of L_disk", fontsize=9)
    return png(figure)


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
                yerr=part[f"{column}_ci_within"],
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
    axes[0, 0].set_ylabel("perceived luminance (cd/m²)\nmean, 95 % within-subject CI")
    # below the panels: inside, it covered the error bars of the first levels
    axes[0, 0].legend(
        fontsize=8, loc="upper left", bbox_to_anchor=(0, -0.3), ncol=3, frameon=False
    )
    return png(figure)


def _figure5(summary: pd.DataFrame, names: list[str], titles: dict) -> bytes:
    figure, axis = plt.subplots(figsize=(5.5, 3.8))
    for method, marker in zip(names, MARKERS, strict=False):
        part = summary[summary["method"] == method]
        axis.errorbar(
            part["level_index"],
            part["boost_percent_mean"],
            yerr=part["boost_percent_ci_within"],
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
    axis.set_ylabel("boost over the displayed disk (%)\nmean, 95 % within-subject CI")
    axis.set_xlabel("level of L_disk")
    axis.legend(
        fontsize=8,
        loc="upper left",
        bbox_to_anchor=(0, -0.2),
        frameon=False,
        ncol=2 if len(names) <= 2 else 1,
    )  # long names: one a line, none cut off
    return png(figure)
