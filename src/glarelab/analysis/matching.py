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
from typing import TYPE_CHECKING, NamedTuple

import matplotlib
import numpy as np
import pandas as pd
from scipy import stats as sps

from glarelab.analysis.apa import (
    anova_effect,
    apa_anova,
    apa_p,
    apa_t,
    confidence_interval,
    fixed,
    unit_interval,
)
from glarelab.analysis.dataset import Dataset, Design, where
from glarelab.analysis.effects import (
    marginal_means,
    paired_effect,
    with_eta2_ci,
    within_subject_ci,
)
from glarelab.analysis.export import participants_wide
from glarelab.analysis.figures import Figure, png, small_multiples, subplots
from glarelab.analysis.methods import display_text
from glarelab.analysis.stats import (
    anova_residuals,
    assumptions,
    corrected_p,
    correction,
    holm,
    holm_confidence,
    pairwise_tests,
    rm_anova,
    similarity_groups,
    ttest_one_sample,
    ttest_paired,
    ttest_welch,
)

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["analyse", "check", "design", "flags", "methods", "stimulus_figures", "tests"]

MARKERS = "osD^v<>p*"
LEVEL_POSITION = "level_position"
"""The trials' column of a level's position among its method's levels (1 = first): an index,
beside ``l_disk_cd_m2``, the level's luminance."""
L_DISK = "L_disk"
"""The level factor's name in the ANOVA tables, as Yoshida et al. 2008 §5 name it."""
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


def design(protocol: Protocol) -> Design:
    """One match per method and level, the main block analysed after the training block.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    glarelab.analysis.dataset.Design
        The factors, the cells each participant needs and the blocks.
    """
    cells = tuple(
        (m["name"], index)
        for m in protocol["glare"]["methods"]
        for index in range(1, len(m["labels"]) + 1)
    )
    return Design(
        factors=("method", "level_index"),
        cells=cells,
        block="main",
        blocks=("training", "main"),
        one_trial_per_cell=True,
    )


def check(trials: pd.DataFrame, protocol: Protocol) -> list[str]:
    """Values no session of this protocol can write: a level label or disk luminance that is
    not the protocol's at that level, a setting outside the display's range (a match above its
    maximum cannot be shown), a match that is not the mean of its settings.

    Parameters
    ----------
    trials
        The trials read, typed by the protocol's columns (``_file`` and ``_line`` name each).
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    list of str
        One problem per line, naming the file, line and value.
    """
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
    problems += _adjustments(trials, protocol)
    return problems


def _adjustments(trials: pd.DataFrame, protocol: Protocol) -> list[str]:
    """Rows whose ``adjustments`` cannot have produced their settings: each adjustment moves
    one target (its disk, by a step), so a trial whose ``k`` targets left their start
    luminances (``stimulus.target_start_cd_m2``) needs at least ``k`` adjustments."""
    starts = protocol["stimulus"]["target_start_cd_m2"]
    bounds = protocol["trials"]["settings"] == "bounds"
    targets = (
        list(zip(("darker_cd_m2", "brighter_cd_m2"), starts, strict=True))
        if bounds
        else [("match_cd_m2", starts[-1])]
    )
    problems = []
    for _, row in trials.iterrows():
        moved = [
            f"{column} {row[column]!r} (started at {start:g})"
            for column, start in targets
            if not np.isclose(row[column], start, rtol=1e-9, atol=1e-12)
        ]
        if int(row["adjustments"]) < len(moved):
            problems.append(
                f"{where(row)} (trial {row['trial']}), column adjustments: "
                f"{row['adjustments']!r}, but {' and '.join(moved)} moved from the start: "
                f"at least {len(moved)} adjustment(s) (each moves one target)"
            )
    return problems


def flags(trials: pd.DataFrame, protocol: Protocol) -> list[str]:
    """Trials a session can record but that contradict the task, analysed as recorded and
    listed in the report: a darker target set above the brighter one (the participant set
    the two the wrong way round, or confirmed before finishing; the experiment does not
    stop them).

    Parameters
    ----------
    trials
        The trials read, typed by the protocol's columns (``_file`` and ``_line`` name each).
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    list of str
        One line per trial, naming its file and line.
    """
    if protocol["trials"]["settings"] != "bounds":
        return []
    main = trials[trials["block"] == "main"]
    wrong = main[main["darker_cd_m2"] > main["brighter_cd_m2"]]
    return [
        f"{where(row)}: participant {row['participant']}, {row['method']} {row['level']}: the "
        f"darker target ({row['darker_cd_m2']:g} cd/m²) set above the brighter one "
        f"({row['brighter_cd_m2']:g} cd/m²); its match, their mean, is analysed as recorded"
        for _, row in wrong.iterrows()
    ]


def methods(protocol: Protocol, participants: int, who: str) -> str:
    """Methods text naming the protocol's actual parameters.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.
    participants
        The number of participants analysed.
    who
        Who they were, as the sentence's subject (``'10 participants'``, ``'10 simulated
        observers'``; :func:`glarelab.analysis.report.methods_paragraph`).

    Returns
    -------
    str
        The paragraph.
    """
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


class _Study(NamedTuple):
    """The protocol's names and the main block's trials, as every part of the analysis uses
    them."""

    trials: pd.DataFrame  # the main block, with LEVEL_POSITION (the level's position, 1 = first)
    names: list[str]  # the methods, in the protocol's order
    titles: dict  # method → its title
    labels: dict  # (method, position) → the level's label
    several: bool  # more than one participant: tests between them are possible


def _study(dataset: Dataset, protocol: Protocol) -> _Study:
    g = protocol["glare"]
    trials = dataset.trials[dataset.trials["block"] == "main"].copy()
    trials[LEVEL_POSITION] = trials["level_index"].astype(int)
    return _Study(
        trials=trials,
        names=[m["name"] for m in g["methods"]],
        titles={m["name"]: m["title"] or m["name"] for m in g["methods"]},
        labels={
            (m["name"], i + 1): label for m in g["methods"] for i, label in enumerate(m["labels"])
        },
        several=trials["participant"].nunique() > 1,
    )


def _anova(data: pd.DataFrame, label: str) -> pd.DataFrame:
    # the level factor is Yoshida's L_disk (§5: "F(5, 45) for L_disk"), its values the levels'
    # positions
    data = data.rename(columns={LEVEL_POSITION: L_DISK})
    factors = [L_DISK, "method"] if data["method"].nunique() > 1 else [L_DISK]
    # an effect without error variance (every participant at the display's maximum in the
    # cells it compares) is reported as not testable; the others are still tested
    table = rm_anova(data, "match_cd_m2", factors, "participant", untestable="report")
    table.insert(0, "analysis", label)
    table["apa"] = apa_anova(table, correction="none")
    table["apa_gg"] = apa_anova(table, correction="GG")
    table["apa_hf"] = apa_anova(table, correction="HF")
    return table


def _anovas(study: _Study, protocol: Protocol) -> pd.DataFrame:
    """The levels × methods ANOVA and the follow-ups on the protocol's subsets of levels."""
    n_levels = len(protocol["glare"]["methods"][0]["labels"])
    methods_ = len(study.names)
    anovas = [_anova(study.trials, f"{n_levels} × {methods_} (all levels)")]
    for followup in protocol["analysis"]["followups"]:
        subset = study.trials[study.trials[LEVEL_POSITION].isin(followup["levels"])]
        label = f"{len(followup['levels'])} × {methods_} ({followup['name']})"
        anovas.append(_anova(subset, label))
    return pd.concat(anovas, ignore_index=True)


def _wide(study: _Study, column: str = "match_cd_m2") -> pd.DataFrame:
    return study.trials.pivot_table(
        index="participant", columns=["method", LEVEL_POSITION], values=column
    )


def _values(a: pd.Series, b: pd.Series | None, unit: str) -> str:
    """Who gave which values, grouped: ``sim01, sim02: 423 and 423 cd/m²``."""
    groups: dict[tuple, list[str]] = {}
    for participant in a.index:
        key = (a[participant],) if b is None else (a[participant], b[participant])
        groups.setdefault(tuple(float(f"{v:.6g}") for v in key), []).append(str(participant))
    if len(groups) == 1:
        (key,) = groups
        return f"all {len(a)}: {' and '.join(f'{v:g}' for v in key)} {unit}"
    return "; ".join(
        f"{', '.join(who)}: {' and '.join(f'{v:g}' for v in key)} {unit}"
        for key, who in groups.items()
    )


def _methods_at_levels(study: _Study, protocol: Protocol) -> pd.DataFrame | None:
    """The methods compared at the levels the protocol names: paired and Welch t-tests, the
    paired ones Holm-corrected (those that can be tested), with the mean difference's interval
    at the level that agrees with the corrected test (Welch's: 95 %, its own)."""
    levels = protocol["analysis"]["compare_methods_at"] if study.several else []
    wide = _wide(study)
    rows = []
    for level in levels:
        for first, second in itertools.combinations(study.names, 2):
            a, b = wide[(first, level)], wide[(second, level)]
            where_ = f"{study.labels[(first, level)]}/{study.labels[(second, level)]}"
            for name, result in (("paired", ttest_paired(a, b)), ("Welch", ttest_welch(a, b))):
                # H1: the first is brighter
                one_sided = sps.t.sf(result["t"], result["df"]) if not result["note"] else np.nan
                note = result["note"]
                if note:
                    note += f" (the participants' matches: {_values(a, b, 'cd/m²')})"
                d = a - b
                sd = float(d.std(ddof=1))
                rows.append(
                    {
                        "level": where_,
                        "methods": f"{first} > {second}",
                        "test": name,
                        "t": result["t"],
                        "df": result["df"],
                        "p_two_sided": result["p"],
                        "p_one_sided": one_sided,
                        "mean_difference": result["mean_difference"],
                        "md_ci_low": result["ci_low"],
                        "md_ci_high": result["ci_high"],
                        "confidence": 0.95 if not note else np.nan,
                        "d_z": float(d.mean()) / sd if name == "paired" and not note else np.nan,
                        "note": note,
                        "apa": apa_t(result["df"], result["t"], result["p"]) if not note else "",
                        "apa_one_sided": (
                            apa_t(result["df"], result["t"], one_sided) if not note else ""
                        ),
                        "_a": a.to_numpy(float),
                        "_b": b.to_numpy(float),
                    }
                )
    if not rows:
        return None
    compared = pd.DataFrame(rows)
    # the family the conclusions follow: the paired two-sided tests that can be computed,
    # Holm-corrected over every level and pair compared (R's p.adjust leaves NA out); Welch's
    # tests are the paper's, shown uncorrected
    paired = compared["test"] == "paired"
    compared["p_holm"] = np.nan
    compared.loc[paired, "p_holm"] = holm(compared.loc[paired, "p_two_sided"], missing="omit")
    compared.loc[paired, "confidence"] = holm_confidence(
        compared.loc[paired, "p_two_sided"], alpha=ALPHA
    )
    for index in compared.index[paired & (compared["note"] == "")]:
        row = compared.loc[index]
        result = ttest_paired(row["_a"], row["_b"], confidence=row["confidence"])
        compared.loc[index, ["md_ci_low", "md_ci_high"]] = result["ci_low"], result["ci_high"]
    return compared


def _boost_tests(study: _Study, protocol: Protocol) -> pd.DataFrame:
    """The boost at each method's highest level against 0: one-sample t-tests of the
    participants' boosts (a between-participant test: one mean against a fixed value, where
    a within-subject interval does not apply), Holm-corrected over the methods, each with the
    interval of the mean boost that agrees with its corrected test."""
    shown = np.minimum(study.trials["l_disk_cd_m2"], protocol["glare"]["l_dmax_cd_m2"])
    boosts = (study.trials["match_cd_m2"] - shown) / shown * 100
    top = study.trials.assign(boost=boosts)
    top = top[top[LEVEL_POSITION] == top[LEVEL_POSITION].max()]
    maximum = float(protocol["display"]["max_cd_m2"])
    rows = []
    for method in study.names:
        part = top[top["method"] == method].set_index("participant")
        result = ttest_one_sample(part["boost"].to_numpy(float), mu=0.0)
        note = result["note"]
        if note:
            note += f" (the participants' boosts: {_values(part['boost'], None, '%')})"
        rows.append(
            {
                "method": method,
                "level": study.labels[(method, int(top[LEVEL_POSITION].max()))],
                "l_disk_cd_m2": float(part["l_disk_cd_m2"].iloc[0]),
                "n": len(part),
                # matches at the display's maximum bound the boost: the report says how many
                "n_at_display_max": int(
                    np.sum(part["match_cd_m2"].to_numpy(float) >= maximum * (1 - 1e-9))
                ),
                "display_max_cd_m2": maximum,
                "boost_percent_mean": result["mean"],
                "t": result["t"],
                "df": result["df"],
                "p": result["p"],
                "note": note,
                "_values": part["boost"].to_numpy(float),
            }
        )
    table = pd.DataFrame(rows)
    table["p_holm"] = holm(table["p"], missing="omit")
    table["confidence"] = holm_confidence(table["p"], alpha=ALPHA)
    limits = [
        ttest_one_sample(row["_values"], confidence=row["confidence"])
        if not row["note"]
        else {"ci_low": np.nan, "ci_high": np.nan}
        for _, row in table.iterrows()
    ]
    table["ci_low"] = [x["ci_low"] for x in limits]
    table["ci_high"] = [x["ci_high"] for x in limits]
    return table


def _test_tables(study: _Study, protocol: Protocol) -> dict[str, pd.DataFrame]:
    """The tests, with the data of each comparison in private columns (``_a``, ``_b``)."""
    if not study.several:
        return {}
    tables = {"anova": _anovas(study, protocol)}
    compared = _methods_at_levels(study, protocol)
    if compared is not None:
        tables["methods_at_levels"] = compared
    tables["boost_test"] = _boost_tests(study, protocol)
    return tables


def _public(tables: dict[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    return {
        name: table.drop(columns=[c for c in table.columns if str(c).startswith("_")])
        for name, table in tables.items()
    }


def tests(dataset: Dataset, protocol: Protocol) -> dict[str, pd.DataFrame]:
    """The statistical tests alone (what a power analysis runs on thousands of simulated
    studies; :func:`analyse` reports the same tests): the ANOVAs (``anova``), the methods
    compared at the protocol's levels (``methods_at_levels``) and the boost at the highest
    level (``boost_test``); none with one participant.

    Parameters
    ----------
    dataset
        The study's validated trials (:func:`glarelab.analysis.load.load_sessions`).
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    dict of str to pandas.DataFrame
        The tests' tables by name.
    """
    return _public(_test_tables(_study(dataset, protocol), protocol))


def analyse(dataset: Dataset, protocol: Protocol) -> dict:
    """Every analysis of Yoshida §5 for the protocol's methods and levels: tables (DataFrames),
    figures (PNG bytes), statements (``text``) and the results section (``results``); its
    tests are those of :func:`tests`.

    Parameters
    ----------
    dataset
        The study's validated trials (:func:`glarelab.analysis.load.load_sessions`).
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    dict
        ``tables``, ``figures``, ``text`` and ``results`` (and what the report shows
        besides).
    """
    study = _study(dataset, protocol)
    tables = _test_tables(study, protocol)
    text: dict[str, str] = {}
    shown: dict[str, pd.DataFrame] = {}  # the tests with their effect sizes' intervals
    if study.several:
        # the η²p intervals (root finding on noncentral F, ms each) from the df of each test
        shown["anova"] = with_eta2_ci(tables["anova"])
        first = shown["anova"]["analysis"].iloc[0]
        main = shown["anova"][shown["anova"]["analysis"] == first].set_index("source")
        for key, source in (("main_effect_level", "L_disk"), ("main_effect_method", "method"),
                            ("interaction", "L_disk × method")):  # fmt: skip
            if source in main.index:
                text[key] = anova_effect(main.loc[source])
        if "methods_at_levels" in tables:
            shown["methods_at_levels"] = _with_dz_intervals(tables["methods_at_levels"])
        tables["effect_sizes"] = _effect_sizes(shown)
        tables["pairwise_contrasts"], tables["similarity_groups"] = _contrasts(study)
    else:
        text["inference"] = ONE_PARTICIPANT
    summary = _summary(study, protocol)
    bounds = protocol["trials"]["settings"] == "bounds"
    questions = [q["column"] for q in protocol["questionnaire"]["questions"]]
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
    if study.several:
        factors = [LEVEL_POSITION, "method"] if len(study.names) > 1 else [LEVEL_POSITION]
        means = marginal_means(study.trials, "match_cd_m2", factors, "participant")
        means["level"] = [
            "/".join(study.labels[(m, int(v))] for m in study.names)
            if f == LEVEL_POSITION
            else study.titles[v]
            for f, v in zip(means["factor"], means["level"], strict=True)
        ]
        means["factor"] = means["factor"].map({LEVEL_POSITION: "level", "method": "glare method"})
        tables["marginal_means"] = means.rename(
            columns={"emmean": "match_mean", "se": "match_se", "ci_low": "match_ci_low",
                     "ci_high": "match_ci_high"}
        )  # fmt: skip
        compared = tables.get("methods_at_levels", pd.DataFrame(columns=["test"]))
        differences = [
            (f"{r['methods'].replace(' > ', ' − ')} at {r['level']}", r["_a"] - r["_b"])
            for _, r in compared[compared["test"] == "paired"].iterrows()
        ]
        tables["assumptions"] = assumptions(
            tables["anova"],
            anova_residuals(study.trials, "match_cd_m2", factors, "participant"),
            differences,
        )
    if questions:
        tables["questionnaire"] = summary[
            ["method", "level", *(f"{c}_percent" for c in questions)]
        ]
    order = [
        "anova", "methods_at_levels", "boost_test", "pairwise_contrasts", "similarity_groups",
        "bounds_and_match", "boost", "marginal_means", "effect_sizes", "assumptions",
        "questionnaire",
    ]  # fmt: skip
    tables = _public({name: tables[name] for name in order if name in tables})
    n = study.trials["participant"].nunique()
    results = _results(tables | _public(shown), summary, study, protocol, n)
    if "boost_test" in tables:
        text["boost"] = _boost_sentence(tables["boost_test"], study)
    return {
        "tables": tables,
        "figures": _figures(study, summary, protocol, n),
        "text": text,
        "results": results,
        "captions": {k: v for k, v in CAPTIONS.items() if k in tables},
        # for JASP's repeated-measures ANOVA: a participant's match in each method × level
        # (the level's position, as the ANOVA's L_disk)
        "wide": participants_wide(study.trials, "match_cd_m2", ["method", LEVEL_POSITION]),
    }


def _with_dz_intervals(compared: pd.DataFrame) -> pd.DataFrame:
    """The paired comparisons' d_z intervals (noncentral t, ms each), each at its row's
    level (the one that agrees with its Holm-corrected test)."""
    low, high = [], []
    for _, row in compared.iterrows():
        if row["test"] != "paired" or row["note"]:
            low.append(np.nan)
            high.append(np.nan)
            continue
        effect = paired_effect(row["_a"], row["_b"], confidence=row["confidence"])
        low.append(effect["dz_ci_low"])
        high.append(effect["dz_ci_high"])
    at = list(compared.columns).index("d_z") + 1
    compared = compared.copy()
    compared.insert(at, "dz_ci_high", high)
    compared.insert(at, "dz_ci_low", low)
    return compared


def _contrasts(study: _Study) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The levels of each method compared pairwise (paired t-tests, Holm), with the mean
    difference and d_z, each interval at the level that agrees with its corrected test, and
    the similarity groups they imply."""
    contrasts, groups = [], []
    for method in study.names:
        part = study.trials[study.trials["method"] == method]
        table = pairwise_tests(part, "match_cd_m2", LEVEL_POSITION, "participant", alpha=ALPHA)
        wide = part.pivot(index="participant", columns=LEVEL_POSITION, values="match_cd_m2")
        d_z, low, high = [], [], []
        for row in table.itertuples():
            if row.note:
                d_z.append(np.nan)
                low.append(np.nan)
                high.append(np.nan)
                continue
            effect = paired_effect(wide[row.a], wide[row.b], confidence=row.confidence)
            d_z.append(effect["d_z"])
            low.append(effect["dz_ci_low"])
            high.append(effect["dz_ci_high"])
        table = table.rename(columns={"ci_low": "md_ci_low", "ci_high": "md_ci_high"})
        table = table.assign(d_z=d_z, dz_ci_low=low, dz_ci_high=high)
        table["note"] = [
            f"{note} (the participants' matches: {_values(wide[a], wide[b], 'cd/m²')})"
            if note
            else ""
            for a, b, note in zip(table["a"], table["b"], table["note"], strict=True)
        ]
        table.insert(0, "method", method)
        table["a"] = [study.labels[(method, a)] for a in table["a"]]
        table["b"] = [study.labels[(method, b)] for b in table["b"]]
        columns = ["method", "a", "b", "t", "df", "p", "mean_difference", "p_holm",
                   "md_ci_low", "md_ci_high", "d_z", "dz_ci_low", "dz_ci_high", "confidence",
                   "note"]  # fmt: skip
        contrasts.append(table[columns])
        means = part.groupby(LEVEL_POSITION)["match_cd_m2"].mean()
        letters = similarity_groups(
            {study.labels[(method, k)]: v for k, v in means.items()},
            {(r.a, r.b): r.p_holm for r in table.itertuples()},
            alpha=ALPHA,
            missing="omit",  # a pair without a test (its note says why) does not separate
        )
        for level, value in means.items():
            label = study.labels[(method, level)]
            groups.append(
                {"method": method, "level": label, "mean_match_cd_m2": value,
                 "group": letters[label]}
            )  # fmt: skip
    return pd.concat(contrasts, ignore_index=True), pd.DataFrame(groups)


def _summary(study: _Study, protocol: Protocol) -> pd.DataFrame:
    """Settings, match and boost per method and level: mean, SEM and half the 95 %
    within-subject interval; the questions' per cent "yes"."""
    g = protocol["glare"]
    bounds = protocol["trials"]["settings"] == "bounds"
    questions = [q["column"] for q in protocol["questionnaire"]["questions"]]
    trials = study.trials.copy()
    shown = np.minimum(trials["l_disk_cd_m2"], g["l_dmax_cd_m2"])
    trials["boost_percent"] = (trials["match_cd_m2"] - shown) / shown * 100
    summary = []
    for (method, level), part in trials.groupby(["method", LEVEL_POSITION], sort=False):
        row = {
            "method": method,
            "level": study.labels[(method, level)],
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
        if not study.several:
            summary[f"{prefix}_ci_within"] = float("nan")
            continue
        within = within_subject_ci(trials, column, ["method", LEVEL_POSITION], "participant")
        half = within.set_index(["method", LEVEL_POSITION])["ci_half"]
        summary[f"{prefix}_ci_within"] = [
            half[(m, k)] for m, k in zip(summary["method"], summary["level_index"], strict=True)
        ]
    summary["order"] = summary["method"].map(study.names.index)
    summary = summary.sort_values(["order", "level_index"]).drop(columns="order")
    return summary.reset_index(drop=True)


def _figures(study: _Study, summary: pd.DataFrame, protocol: Protocol, n: int) -> dict:
    g = protocol["glare"]
    bounds = protocol["trials"]["settings"] == "bounds"
    return {
        "bounds_and_match.png": Figure(
            _figure4(summary, study.names, study.titles, g["l_dmax_cd_m2"], bounds),
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
            _figure5(summary, study.names, study.titles),
            "Brightness boost of the glare",
            "The match above the displayed disk luminance min(L_disk, L_dmax), in per cent of "
            f"it, mean over n = {n} participants with {ERROR_BARS}, per glare method; 0 % (the "
            "line) is no boost.",
        ),
        "participants_matches.png": Figure(
            _participants(study.trials, study.names, study.titles, study.labels),
            "Every participant's matches",
            "The matched luminance (cd/m²) of each participant at each level, one line per "
            f"glare method, one panel per participant (n = {n}); the pale wide lines are the "
            "means over all participants, so a participant who matched differently stands "
            "out.",
        ),
    }


CAPTIONS = {
    "anova": "Repeated-measures ANOVAs on the matched luminance (MSE: the effect's error mean "
    "square; the correction each effect is decided on: the assumptions table)",
    "methods_at_levels": "The glare methods compared at the levels the protocol names: "
    "paired t-tests (two-sided, Holm-corrected over the comparisons that can be tested; the "
    "conclusions follow these) with the mean difference (cd/m²) and d_z, each with the "
    "interval at the level given (confidence) that agrees with the Holm-corrected test; and "
    "Welch's unpaired tests, two- and one-sided, uncorrected (the paper's), with Welch's own "
    "95 % interval of the difference. A comparison without variance is not tested (note)",
    "boost_test": "The boost at each method's highest level against 0: one-sample t-tests "
    "of the participants' boosts (%), Holm-corrected over the methods, with the "
    "between-participant interval of the mean at the level that agrees with the corrected "
    "test (confidence)",
    "pairwise_contrasts": "Paired contrasts between the levels of each method "
    "(Holm-corrected over the pairs that can be tested), with the mean difference (cd/m²) and "
    "d_z, each interval at the level that agrees with its corrected test (confidence)",
    "similarity_groups": "Similarity groups: levels sharing a letter do not differ "
    "(Holm-corrected contrasts; a pair that could not be tested does not separate its levels)",
    "bounds_and_match": "Settings and matches per level (cd/m², mean, SEM, and half the "
    "95 % within-subject CI of the figures)",
    "boost": "Brightness boost over the displayed disk (%, mean, SEM, half the 95 % "
    "within-subject CI)",
    "marginal_means": "Estimated marginal means of the match (cd/m²) per level of each "
    "factor, averaged over the other, with 95 % CIs (t, n − 1 df; emmeans' multivariate "
    "model)",
    "effect_sizes": "Effect sizes with their confidence intervals: η²p (90 %, Steiger "
    "2004, from the df of the test reported) and η²G of every ANOVA effect, the mean "
    "difference and d_z of every paired comparison of the methods (at the level that agrees "
    "with its Holm-corrected test)",
    "assumptions": "Assumptions: the sphericity correction of each effect and why "
    "(Mauchly's test), and Shapiro–Wilk tests of the ANOVA's residuals and of the "
    "paired differences of the method comparisons",
    "questionnaire": "Answers to the questions (% yes)",
}


def _effect_sizes(shown: dict) -> pd.DataFrame:
    """Every effect size with its interval, one row each: η²p (90 % CI from the df of the
    test reported) and η²G of the ANOVA effects, the mean difference and d_z of the paired
    comparisons (at the level of their Holm-corrected tests)."""
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
        compared = shown["methods_at_levels"]
        for r in compared[compared["test"] == "paired"].itertuples():
            of = f"{r.methods} at {r.level} (paired)"
            rows += [
                {"of": of, "effect_size": "mean difference (cd/m²)", "value": r.mean_difference,
                 "ci_low": r.md_ci_low, "ci_high": r.md_ci_high, "confidence": r.confidence},
                {"of": of, "effect_size": "d_z", "value": r.d_z,
                 "ci_low": r.dz_ci_low, "ci_high": r.dz_ci_high, "confidence": r.confidence},
            ]  # fmt: skip
    return pd.DataFrame(rows)


def _verdict(row) -> str:
    if not np.isfinite(row["F"]):
        return "could not be tested"
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


def _corrections(anova: pd.DataFrame) -> str:
    """How the effects are corrected, and on which test the conclusions rest."""
    text = (
        " Effects with more than one degree of freedom are reported with Greenhouse–Geisser "
        "corrected degrees of freedom where its ε < .75 and Huynh–Feldt corrected ones "
        "otherwise"
    )
    if (anova.apply(correction, axis=1) == "LB").any():
        text += (
            "; where sphericity cannot be estimated (fewer participants than the effect's "
            "degrees of freedom + 1), with the lower bound ε = 1/df, the correction valid "
            "whatever the covariance, and the conclusion rests on it (the uncorrected test "
            "is given beside it)"
        )
    return text + f"; α = {unit_interval(ALPHA)}."


def _mean(value: float, decimals: int = 1) -> str:
    return fixed(value, decimals)


def _comparison(row, mean: pd.Series, titles: dict, family: int) -> str:
    """One paired comparison of two methods at a level, as the results text gives it."""
    first_name, second_name = row["methods"].split(" > ")
    first_label, second_label = row["level"].split("/")
    means = (
        f"the matches under {titles[first_name]} "
        f"(M = {_mean(mean[(first_name, first_label)])} cd/m²) and {titles[second_name]} "
        f"(M = {_mean(mean[(second_name, second_label)])} cd/m²)"
    )
    if row["note"]:
        return (
            f"at {row['level']} {means} could not be compared: "
            f"{row['note'].removeprefix('not testable: ')}; no test, left out of the Holm "
            "family"
        )
    differ = "differed" if row["p_holm"] < ALPHA else "did not differ"
    level = row["confidence"]
    adjusted = " (Holm-adjusted)" if family > 1 else ""
    return (
        f"at {row['level']} {means} {differ}, t({row['df']:.0f}) = {fixed(row['t'], 2)}, "
        f"{apa_p(row['p_holm'])}{' (Holm)' if family > 1 else ''}, M_diff = "
        f"{_mean(row['mean_difference'])} cd/m², "
        f"{confidence_interval(row['md_ci_low'], row['md_ci_high'], 1, level)}{adjusted}, "
        f"d_z = {fixed(row['d_z'], 2)}, "
        f"{confidence_interval(row['dz_ci_low'], row['dz_ci_high'], 2, level)}"
    )


def _boost_sentence(boost: pd.DataFrame, study: _Study) -> str:
    """The boost at the highest level, from its one-sample tests: exceeded, fell short of, or
    did not differ from the displayed disk luminance."""
    family = int(boost["p"].notna().sum())
    parts = []
    for row in boost.to_dict("records"):
        where_ = (
            f"with {study.titles[row['method']]} at {row['level']} "
            f"({row['l_disk_cd_m2']:,.0f} cd/m²)"
        )
        ceiling = ""
        if row["n_at_display_max"] > 0:
            ceiling = (
                f" ({row['n_at_display_max']} of {row['n']} participants matched at the "
                f"display's maximum, {row['display_max_cd_m2']:,.0f} cd/m², so the boost is "
                "bounded by what the display can show)"
            )
        if row["note"]:
            parts.append(
                f"{where_} the boost could not be tested: "
                f"{row['note'].removeprefix('not testable: ')}{ceiling}"
            )
            continue
        corrected = " (Holm)" if family > 1 else ""
        stats_ = (
            f"{confidence_interval(row['ci_low'], row['ci_high'], 1, row['confidence'])}"
            f"{' (Holm-adjusted)' if family > 1 else ''}, t({row['df']:.0f}) = "
            f"{fixed(row['t'], 2)}, {apa_p(row['p_holm'])}{corrected}"
        )
        mean = row["boost_percent_mean"]
        if row["p_holm"] < ALPHA and mean > 0:
            verdict = f"exceeded it by {_mean(mean)} %"
        elif row["p_holm"] < ALPHA:
            verdict = f"fell short of it by {_mean(-mean)} %"
        else:
            verdict = f"did not differ from it (M = {_mean(mean)} %)"
        parts.append(f"{where_} the matches {verdict}{ceiling}, {stats_}")
    return (
        "At the highest level, compared with the luminance the display showed of the disk "
        "(one-sample t-tests of the participants' boosts against 0"
        + (f", Holm-corrected over the {family} glare methods" if family > 1 else "")
        + f"): {'; '.join(parts)}."
    )


def _normality_note(table: pd.DataFrame) -> str:
    """A sentence on the Shapiro–Wilk tests that rejected normality, or nothing."""
    checks = table[(table["check"] == "normality") & (table["shapiro_p"] < ALPHA)]
    if checks.empty:
        return ""
    listed = "; ".join(
        f"{r.of} (W = {unit_interval(r.shapiro_W, 3)}, {apa_p(r.shapiro_p)})"
        for r in checks.itertuples()
    )
    return (
        f"Shapiro–Wilk tests rejected normality (α = {unit_interval(ALPHA)}, uncorrected) for "
        f"the {listed}: the t and F tests above assume normally distributed residuals, so "
        "their p-values there are approximate; the assumptions table gives every check."
    )


def _results(
    tables: dict, summary: pd.DataFrame, study: _Study, protocol: Protocol, n: int
) -> list[str]:
    """The results section as paragraphs: the ANOVAs, the methods compared at chosen levels,
    the boost at the highest level, and a word on any assumption that failed; every
    sentence from a test in the tables."""
    methods_ = protocol["glare"]["methods"]
    titles = study.titles
    if "anova" not in tables:
        return [
            f"With {n} participant{'s' if n != 1 else ''} no inferential statistics can be "
            "computed; the figures and tables describe the settings."
        ]
    anova = tables["anova"]
    analyses = list(dict.fromkeys(anova["analysis"]))
    design_ = "level × glare method" if len(methods_) > 1 else "level"
    first = anova[anova["analysis"] == analyses[0]]
    text = (
        f"The matched luminance of the {n} participants was analysed with a "
        f"{analyses[0].split(' (')[0]} repeated-measures ANOVA ({design_}): "
        f"{_effects(first)}."
    )
    for followup, analysis in zip(protocol["analysis"]["followups"], analyses[1:], strict=True):
        part = anova[anova["analysis"] == analysis]
        name = followup["name"]
        which = f"the levels {name}" if name.startswith("{") else f"the {name}"
        text += f" On {which} alone ({analysis.split(' (')[0]}), {_effects(part)}."
    paragraphs = [text + _corrections(anova)]
    if "methods_at_levels" in tables:
        tests_ = tables["methods_at_levels"]
        paired = tests_[tests_["test"] == "paired"]
        family = int(paired["p_two_sided"].notna().sum())
        untested = len(paired) - family
        mean = summary.set_index(["method", "level"])["match_mean"]
        sentences = [_comparison(row, mean, titles, family) for _, row in paired.iterrows()]
        papers = [
            f"at {row['level']}, {row['apa_one_sided']}"
            for _, row in tests_[(tests_["test"] == "Welch") & (tests_["note"] == "")].iterrows()
        ]
        intervals = (
            "; each interval is at the level that agrees with its Holm-corrected test "
            "(it excludes 0 exactly when the corrected test is significant)"
            if family > 1
            else ""
        )
        paragraph = (
            "The glare methods were compared at single levels by paired t-tests (two-sided)"
            + (
                f", Holm-corrected over the {family} comparisons"
                + (" that could be tested" if untested else "")
                if family > 1
                else ""
            )
            + (f" ({untested} could not be, as said below)" if untested and family > 1 else "")
            + f"{intervals}: "
            + "; ".join(sentences)
            + "."
        )
        if protocol["analysis"]["quote_welch_tests"] and papers:
            paragraph += (
                " Yoshida et al. (2008) report these comparisons as t(14), uncorrected; their "
                "p-values fit Welch's unpaired one-sided test, which gives here "
                + "; ".join(papers)
                + " (the paper's test, uncorrected; it ignores that each participant saw both "
                "methods, and the conclusions above do not rest on it)."
            )
        paragraphs.append(paragraph)
    if "boost_test" in tables:
        paragraphs.append(_boost_sentence(tables["boost_test"], study))
    if "assumptions" in tables:
        note = _normality_note(tables["assumptions"])
        if note:
            paragraphs.append(note)
    return paragraphs


def stimulus_figures(protocol: Protocol, shown) -> list[Figure]:
    """The stimuli as the display showed them: the references of each glare method, the
    targets at their start luminances, and the references' profiles through the disk centre
    (Yoshida Fig. 3). ``shown`` is an :class:`glarelab.analysis.stimulus_figures.VerifiedSet`.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.
    shown : glarelab.analysis.stimulus_figures.VerifiedSet
        The stimulus set as the display showed it.

    Returns
    -------
    list of glarelab.analysis.figures.Figure
        The figures.
    """
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
    means = trials.groupby(["method", LEVEL_POSITION])["match_cd_m2"].mean()
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for axis, participant in zip(axes, participants, strict=True):
        part = trials[trials["participant"] == participant]
        for index, (method, marker) in enumerate(zip(names, MARKERS, strict=False)):
            colour = colours[index % len(colours)]
            levels = sorted(means.loc[method].index)
            axis.plot(
                levels, means.loc[method].to_numpy(), color=colour, alpha=0.3, lw=3, zorder=1
            )
            own = part[part["method"] == method].sort_values(LEVEL_POSITION)
            axis.plot(
                own[LEVEL_POSITION],
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
    positions = sorted(trials[LEVEL_POSITION].unique())
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
    figure, axes = subplots(
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
    figure, axis = subplots(figsize=(5.5, 3.8))
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
