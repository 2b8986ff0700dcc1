"""The analysis of a rating questionnaire. Luidolt (2020, §7.2.1) reports the mean rating of
each category (five participants) and shows the distributions as diverging stacked bars
(Figures 7.1-7.7); he ran no test. This analysis gives those means and bars, with SD, median,
IQR and the count of each rating, and adds what a paper needs beyond them: a Wilcoxon
signed-rank test of each category against the scale's midpoint (Luidolt's 1-7 scale: 4),
Holm-corrected across categories, with the rank-biserial correlation (95 % CI) and the
Hodges–Lehmann estimate of the shift from the midpoint.

A category that every participant rated at the midpoint (or, in a comparison, that no
participant rated differently) has no test: R's ``wilcox.test`` gives ``NaN``; its p is NaN,
the Holm family holds only the computed tests (as R's ``p.adjust`` leaves ``NA`` out), and the
results say which tests could not be computed and why.

A study that shows conditions (the night-vision pipeline with and without each effect) is
summarised per condition and category; each condition is compared with the first (the
reference: the full pipeline) category by category, by a Wilcoxon signed-rank test of the
participants' paired differences against 0, Holm-corrected across all comparisons. Its figure
shows each condition's ratings; given the stimulus set, the report's Method section shows each
condition's frames as the display showed them (:func:`stimulus_figures`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import matplotlib.colors
import numpy as np
import pandas as pd

from glarelab.analysis.apa import (
    apa_p,
    confidence_interval,
    fixed,
    percent,
    series,
    unit_interval,
)
from glarelab.analysis.dataset import Dataset, Design, no_flags
from glarelab.analysis.effects import hodges_lehmann, rank_biserial
from glarelab.analysis.export import participants_wide
from glarelab.analysis.figures import Figure, png, subplots
from glarelab.analysis.methods import display_text
from glarelab.analysis.stats import holm, holm_confidence, wilcoxon_signed_rank

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["analyse", "check", "design", "flags", "methods", "stimulus_figures", "tests"]

ALPHA = 0.05  # the significance level the results text uses
NEUTRAL = "#9e9e9e"  # the scale's middle category: a grey that shows on white


def _conditions(protocol: Protocol) -> list[dict]:
    return protocol.data.get("conditions") or []


def design(protocol: Protocol) -> Design:
    """One rating per category (and condition), in the questionnaire block.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    glarelab.analysis.dataset.Design
        The factors, the cells each participant needs and the blocks.
    """
    categories = protocol["questionnaire"]["categories"]
    conditions = _conditions(protocol)
    if conditions:
        factors = ("condition", "category")
        cells = tuple((c["name"], k) for c in conditions for k in categories)
    else:
        factors, cells = ("category",), tuple((c,) for c in categories)
    return Design(
        factors=factors,
        cells=cells,
        block=None,
        blocks=("questionnaire",),
        one_trial_per_cell=True,
    )


flags = no_flags  # trials to list in the report though analysed as recorded: none


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


def check(trials: pd.DataFrame, protocol: Protocol) -> list[str]:
    """Values no session of this protocol can write beyond the columns' own checks (category
    and rating range): none.

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
    return []


def _summary(trials: pd.DataFrame, protocol: Protocol, conditions: list[dict]) -> pd.DataFrame:
    """Per (condition and) category: mean, SD, median, IQR, the Wilcoxon test against the
    midpoint, Holm-corrected over the tests that can be computed, the effect sizes and the
    count of each rating; the ratings in a private column (``_values``)."""
    q = protocol["questionnaire"]
    scale = range(q["scale_min"], q["scale_max"] + 1)
    midpoint = (q["scale_min"] + q["scale_max"]) / 2
    categories = [c for c in q["categories"] if (trials["category"] == c).any()]
    rows = []
    for condition in conditions or [None]:
        for category in categories:
            chosen = trials["category"] == category
            if condition is not None:
                chosen &= trials["condition"] == condition["name"]
            ratings = trials.loc[chosen, "rating"].astype(float)
            key = {"category": category}
            if condition is not None:
                key = {"condition": condition["name"]} | key
            rows.append(key | _summary_row(ratings, scale, midpoint))
    return _corrected(pd.DataFrame(rows), midpoint)


def _corrected(table: pd.DataFrame, mu: float) -> pd.DataFrame:
    """A table of Wilcoxon tests Holm-corrected over the computed ones, each with the
    Hodges–Lehmann shift and its interval at the level that agrees with the corrected test
    (:func:`glarelab.analysis.stats.holm_confidence`)."""
    table["p_holm"] = holm(table["p"], missing="omit")
    table["confidence"] = holm_confidence(table["p"], alpha=ALPHA)
    shifts = [
        hodges_lehmann(row["_values"], mu=mu, confidence=row["confidence"])
        if np.isfinite(row["p"])
        else dict.fromkeys(("hl_shift", "hl_ci_low", "hl_ci_high", "hl_confidence"), np.nan)
        for _, row in table.iterrows()
    ]
    at = list(table.columns).index("rb_ci_high") + 1  # the shift beside the other effect size
    for offset, column in enumerate(("hl_shift", "hl_ci_low", "hl_ci_high", "hl_confidence")):
        table.insert(at + offset, column, [shift[column] for shift in shifts])
    table["apa"] = [_apa(row) for _, row in table.iterrows()]
    return table


def _comparisons(trials: pd.DataFrame, conditions: list[dict]) -> pd.DataFrame:
    """Each condition against the first, category by category: the participants' paired
    differences, Wilcoxon signed-rank test against 0, Holm-corrected over the computed
    comparisons."""
    categories = list(dict.fromkeys(trials["category"]))
    reference = conditions[0]["name"]
    wide = trials.pivot_table(
        index="participant", columns=["condition", "category"], values="rating", aggfunc="mean"
    )
    rows = []
    for condition in conditions[1:]:
        for category in categories:
            difference = (
                wide[(condition["name"], category)] - wide[(reference, category)]
            ).dropna()
            rows.append(
                {
                    "condition": condition["name"],
                    "reference": reference,
                    "category": category,
                    "n": int(difference.size),
                    "mean_difference": float(difference.mean()),
                    "median_difference": float(difference.median()),
                }
                | _wilcoxon(difference, 0.0, NO_DIFFERENCE)
            )
    compared = pd.DataFrame(rows)
    return _corrected(compared, 0.0) if not compared.empty else compared


def _public(table: pd.DataFrame) -> pd.DataFrame:
    return table.drop(columns=[c for c in table.columns if str(c).startswith("_")])


def tests(dataset: Dataset, protocol: Protocol) -> dict[str, pd.DataFrame]:
    """The statistical tests alone (what a power analysis runs on thousands of simulated
    studies; :func:`analyse` reports the same): each category's Wilcoxon test against the
    midpoint (``summary``) and, with conditions, each condition against the first
    (``comparisons``).

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
    conditions = [
        c for c in _conditions(protocol) if (dataset.trials["condition"] == c["name"]).any()
    ]
    tables = {"summary": _public(_summary(dataset.trials, protocol, conditions))}
    if conditions:
        tables["comparisons"] = _public(_comparisons(dataset.trials, conditions))
    return tables


def analyse(dataset: Dataset, protocol: Protocol) -> dict:
    """Per-category summaries with the Wilcoxon tests, the comments and the diverging bars:
    tables (DataFrames), figures (PNG bytes), statements (``text``) and the results section
    (``results``); with ``[[conditions]]``, each condition against the first. Its tests are
    those of :func:`tests`.

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
    if _conditions(protocol):
        return _analyse_conditions(dataset, protocol)
    q = protocol["questionnaire"]
    scale = range(q["scale_min"], q["scale_max"] + 1)
    midpoint = (q["scale_min"] + q["scale_max"]) / 2
    trials = dataset.trials
    categories = [c for c in q["categories"] if (trials["category"] == c).any()]
    summary = _public(_summary(trials, protocol, []))
    comments = trials.loc[
        trials["comment"].notna(), ["participant", "category", "rating", "comment"]
    ]
    n = trials["participant"].nunique()
    neutral = f" (grey: the neutral {scale[len(scale) // 2]})" if len(scale) % 2 else ""
    return {
        "wide": participants_wide(trials, "rating", ["category"]),
        "tables": {"summary": summary, "comments": comments},
        "figures": {
            "ratings.png": Figure(
                _diverging(summary, scale, q["anchors"]),
                "Ratings per category",
                f"The share of the {n} participants giving each rating from {scale[0]} "
                f"({q['anchors'][0]}) to {scale[-1]} ({q['anchors'][1]}), as diverging bars: "
                f"ratings below the middle of the scale extend left of 0, ratings above it "
                f"right{neutral}, the middle category split across 0.",
            ),
            "participants_ratings.png": Figure(
                _participants(trials, categories, scale),
                "Every participant's ratings",
                f"The rating of each participant (rows, n = {n}) in each category (columns), "
                f"coloured as in the diverging bars; a participant whose row differs from "
                f"the others stands out.",
            ),
        },
        "text": dict(zip(summary["category"], summary["apa"], strict=True)),
        "results": _results(summary, midpoint, n),
        "captions": {
            "summary": "Ratings per category: mean, SD, median, IQR (Luidolt reports the means), "
            f"and this suite's Wilcoxon signed-rank test against the midpoint {midpoint:g} "
            "(Holm-corrected over the computed tests) with the rank-biserial r (its 95 % CI "
            "as effectsize gives it: it describes r_rb and is not adjusted) and the "
            "Hodges–Lehmann shift as R's wilcox.test computes it, with its interval at the "
            "level that agrees with the Holm-corrected test (confidence), and the count of "
            "each rating",
            "comments": "The participants' comments",
        },
    }


def _count(n: int, one: str, many: str | None = None) -> str:
    """``the 1 category``, ``the 3 categories``."""
    return f"the {n} {one if n == 1 else many or one + 's'}"


def _not_computed(table: pd.DataFrame, name) -> str:
    """The sentence naming the tests that could not be computed, or nothing."""
    missing = table[table["p"].isna()]
    if missing.empty:
        return ""
    listed = series([name(r) for _, r in missing.iterrows()])
    why = missing["test"].iloc[0].removeprefix("not computed: ")
    return (
        f" No test could be computed for {listed} ({why}"
        f"{'' if missing['test'].nunique() == 1 else ', or as the table says'}; R's "
        "wilcox.test gives no p either); the Holm family holds "
        + _count(int(table["p"].notna().sum()), "computed test")
        + "."
    )


def _side(row) -> str:
    """Which side of the midpoint (or of 0) the signed ranks put a category: the sign of the
    rank-biserial correlation, the positive ranks' sum minus the negative ones' (the test's
    own statistic; the median can sit on the midpoint while every other rating is above)."""
    return "above" if row["r_rb"] > 0 else "below"


def _results(summary: pd.DataFrame, midpoint: float, n: int) -> list[str]:
    """The results section as one paragraph, generated from the summary table."""
    if n < 2:
        described = "; ".join(
            f"{row['category']} {row['median']:g}" for _, row in summary.iterrows()
        )
        return [
            "One participant's ratings (no test: a signed-rank test compares participants' "
            f"ratings with the midpoint, {midpoint:g}, and one participant gives nothing to "
            f"test against): {described}."
        ]
    parts = []
    for _, row in summary.iterrows():
        if np.isnan(row["p"]):
            verdict = "was not tested (every rating at the midpoint)"
        elif row["p_holm"] < ALPHA:
            verdict = f"differed from the midpoint ({_side(row)} it)"
        else:
            verdict = "did not differ from the midpoint"
        parts.append(
            f"{row['category']} (Mdn = {row['median']:g}, IQR = {row['iqr']:g}; M = "
            f"{fixed(row['mean'], 2)}, SD = {fixed(row['sd'], 2)}) {verdict}"
            + ("" if np.isnan(row["p"]) else f", {row['apa']}")
        )
    tested = int(summary["p"].notna().sum())
    if tested == 0:
        return [
            f"The {n} participants' ratings of each category were not compared with the "
            f"scale's midpoint, {midpoint:g}: every rating of every category was at it. "
            + "; ".join(parts)
            + "."
        ]
    return [
        f"Luidolt (2020, §7.2.1) reports the mean rating of each category; as an addition to "
        f"his analysis, the {n} participants' ratings of each category were compared with "
        f"the scale's midpoint, {midpoint:g}, by Wilcoxon signed-rank tests, Holm-corrected "
        f"across {_count(tested, 'category', 'categories')} that could be tested "
        f"(α = {unit_interval(ALPHA)}), "
        "with the matched-pairs rank-biserial correlation r_rb and the Hodges–Lehmann (HL) "
        "shift from the midpoint as effect sizes (HL as R's wilcox.test computes it, on the "
        "ratings off the midpoint the test ranks, with its interval at the level that agrees "
        "with the Holm-corrected test; which side of the midpoint, from the signed ranks): "
        + "; ".join(parts[:-1])
        + ("; and " if len(parts) > 1 else "")
        + parts[-1]
        + "."
        + _not_computed(summary, lambda r: r["category"])
        + _unreached(summary, lambda r: r["category"])
    ]


NOT_COMPUTED = "not computed: every rating at the midpoint"
ONE_PARTICIPANT = "not computed: one participant gives nothing to test against"
UNREACHED = "see below"


def _unreached(table: pd.DataFrame, name) -> str:
    """The sentence on the HL intervals R cannot give at the level of the corrected test."""
    lowered = table[
        table["hl_ci_low"].notna() & ~np.isclose(table["hl_confidence"], table["confidence"])
    ]
    if lowered.empty:
        return ""
    listed = series(
        [
            f"{name(r)} ({percent(r['hl_confidence'])} % of {percent(r['confidence'])} %)"
            for _, r in lowered.iterrows()
        ]
    )
    return (
        f" No HL interval is given for {listed}: with so few distinct ratings R's wilcox.test "
        "cannot reach the level their Holm-corrected tests need (it lowers it to the level in "
        "parentheses, which the table gives), and an interval at a lower level could "
        "contradict the test beside it."
    )


NO_DIFFERENCE = "not computed: no participant rated the two conditions differently"


def _wilcoxon(values: pd.Series, mu: float, reason: str) -> dict:
    """The Wilcoxon test of ``values`` against ``mu`` with the rank-biserial correlation; NaN
    and the reason where every value equals ``mu`` (R's ``wilcox.test`` gives NaN there). The
    values stay in ``_values`` for the Hodges–Lehmann shift (:func:`_corrected`). One
    participant's value is not tested (the results say so; the table printed V and p = 1)."""
    if values.count() < 2:
        reason = ONE_PARTICIPANT
    if values.count() >= 2 and (values != mu).any():
        test = wilcoxon_signed_rank(values, mu=mu)
        effect = rank_biserial(values, mu=mu)
        return {
            "wilcoxon_V": test["V"],
            "p": test["p"],
            "test": test["method"]
            + (f", {test['zeros']} zero(s) dropped" if test["zeros"] else ""),
            **effect,
            "_values": values.to_numpy(float),
        }
    nan = float("nan")
    return {
        "wilcoxon_V": nan,
        "p": nan,
        "test": reason,
        "r_rb": nan,
        "rb_ci_low": nan,
        "rb_ci_high": nan,
        "_values": values.to_numpy(float),
    }


def _apa(row) -> str:
    """The test and its effect sizes: V, the Holm-corrected p, r_rb, and the HL shift with
    its interval at the level that agrees with the corrected test."""
    if np.isnan(row["p"]):
        return f"no test ({row['test'].removeprefix('not computed: ')})"
    if np.isfinite(row["hl_ci_low"]) and np.isclose(row["hl_confidence"], row["confidence"]):
        shift = (
            f"HL shift = {fixed(row['hl_shift'], 2)}, "
            f"{confidence_interval(row['hl_ci_low'], row['hl_ci_high'], 2, row['hl_confidence'])}"
            + (" (Holm-adjusted)" if not np.isclose(row["confidence"], 1 - ALPHA) else "")
        )
    elif np.isfinite(row["hl_ci_low"]):  # R lowers the level where the ratings cannot reach it
        shift = f"HL shift = {fixed(row['hl_shift'], 2)} (no interval: {UNREACHED})"
    else:
        shift = f"HL shift = {fixed(row['hl_shift'], 2)} (no interval: the ratings are tied)"
    return (
        f"V = {row['wilcoxon_V']:g}, {apa_p(row['p_holm'])} (Holm), r_rb = "
        f"{unit_interval(row['r_rb'])}, {shift}"
    )


def _summary_row(ratings: pd.Series, scale: range, midpoint: float) -> dict:
    q1, q3 = np.percentile(ratings, [25, 75])
    row = {
        "n": int(ratings.count()),
        "mean": ratings.mean(),
        "sd": ratings.std(ddof=1),
        "median": ratings.median(),
        "iqr": q3 - q1,
    } | _wilcoxon(ratings, midpoint, NOT_COMPUTED)
    row.update({f"count_{k}": int((ratings == k).sum()) for k in scale})
    return row


def _analyse_conditions(dataset: Dataset, protocol: Protocol) -> dict:
    q = protocol["questionnaire"]
    scale = range(q["scale_min"], q["scale_max"] + 1)
    midpoint = (q["scale_min"] + q["scale_max"]) / 2
    trials = dataset.trials
    conditions = [c for c in _conditions(protocol) if (trials["condition"] == c["name"]).any()]
    categories = [c for c in q["categories"] if (trials["category"] == c).any()]
    summary = _public(_summary(trials, protocol, conditions))
    reference = conditions[0]["name"]
    compared = _public(_comparisons(trials, conditions))
    comments = trials.loc[
        trials["comment"].notna(), ["participant", "condition", "category", "rating", "comment"]
    ]
    text = {}
    for _, row in compared.iterrows() if not compared.empty else []:
        if row["p_holm"] < ALPHA:
            text[f"{row['condition']}, {row['category']}"] = (
                f"rated {'higher' if row['r_rb'] > 0 else 'lower'} than {row['reference']} "
                f"({row['apa']})"
            )
    n = trials["participant"].nunique()
    figure = Figure(
        _by_condition(summary, conditions, categories, scale, q["anchors"]),
        "Ratings per category in each condition",
        f"The share of the {n} participants giving each rating from {scale[0]} "
        f"({q['anchors'][0]}) to {scale[-1]} ({q['anchors'][1]}) in each condition (rows: the "
        "effects of the pipeline shown), as diverging bars; the number at the right of each "
        "bar is the mean rating. The stimulus each condition showed is in the Stimuli figures "
        "(given the stimulus set).",
    )
    results = [_compared_text(compared, reference)]
    return {
        "wide": participants_wide(trials, "rating", ["condition", "category"]),
        "tables": {"summary": summary, "comparisons": compared, "comments": comments},
        "figures": {"ratings_by_condition.png": figure},
        "text": text,
        "results": results,
        "captions": {
            "summary": "Ratings per condition and category: mean, SD, median, IQR, Wilcoxon "
            f"signed-rank test against the midpoint {midpoint:g} (Holm-corrected) and the count "
            "of each rating",
            "comparisons": f"Each condition against {reference}: the participants' paired "
            "differences, Wilcoxon signed-rank test against 0 (Holm-corrected over the "
            "computed comparisons) with the rank-biserial r (its 95 % CI as effectsize gives "
            "it, unadjusted) and the Hodges–Lehmann shift as R's wilcox.test computes it, with "
            "its interval at the level that agrees with the Holm-corrected test (confidence)",
            "comments": "The participants' comments",
        },
    }


def _compared_text(compared: pd.DataFrame, reference: str) -> str:
    """The comparisons with the reference condition as one paragraph: the conclusion follows
    the Holm-corrected family and its side the signed ranks; uncorrected p-values are only
    counted."""
    if compared.empty:
        return f"Only {reference} was rated: there is nothing to compare."
    tested = compared[compared["p"].notna()]
    held = tested[tested["p_holm"] < ALPHA]
    missing = _not_computed(compared, lambda r: f"{r['condition']} in {r['category']}")
    if tested.empty:
        return f"No comparison with {reference} could be tested.{missing}"
    family = (
        f"Each condition was compared with the reference condition, {reference}, category by "
        "category (Wilcoxon "
        "signed-rank tests of the paired differences, Holm-corrected over "
        f"{_count(len(tested), 'computed comparison')}, α = {unit_interval(ALPHA)}; the side "
        "from the signed ranks)"
    )
    if held.empty:
        uncorrected = int((tested["p"] < ALPHA).sum())
        return (
            f"{family}: no condition was rated differently from {reference} in any category"
            + (
                f" ({uncorrected} comparison{'s' if uncorrected != 1 else ''} had an "
                f"uncorrected p < {unit_interval(ALPHA)}, none held after the correction)"
                if uncorrected
                else ""
            )
            + f".{missing}"
        )
    listed = "; ".join(
        f"{r['condition']} was rated {'higher' if r['r_rb'] > 0 else 'lower'} in "
        f"{r['category']} ({r['apa']})"
        for _, r in held.iterrows()
    )
    lowered = _unreached(held, lambda r: f"{r['condition']} in {r['category']}")
    return (
        f"{family}: {len(held)} of the {len(tested)} differed: {listed}; the others did not "
        f"differ after the correction.{missing}{lowered}"
    )


def stimulus_figures(protocol: Protocol, shown) -> list[Figure]:
    """Each condition's scene as the display showed it: its first, middle and last frame.
    ``shown`` is an :class:`glarelab.analysis.stimulus_figures.VerifiedSet`; a questionnaire
    without a scene shows none.

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
    from glarelab.analysis.stimulus_figures import image_grid

    conditions = _conditions(protocol)
    if not conditions:
        return []
    plan = shown.manifest["parameters"]["sequences"]
    time_s = shown.manifest["parameters"]["frame_time_s"]
    panels = []
    for condition in conditions:
        frames = plan[condition["name"]]["frames"]
        for index in sorted({0, len(frames) // 2, len(frames) - 1}):
            label = f"{condition['name']}, {index * time_s:.1f} s" if len(frames) > 1 else ""
            panels.append((shown.picture(frames[index]), label or condition["name"]))
    columns = min(3, len(plan[conditions[0]["name"]]["frames"]))
    scene = protocol["scene"]
    rows = "; ".join(f"{c['name']}: {', '.join(c['effects']) or 'no effect'}" for c in conditions)
    return [
        Figure(
            image_grid(panels, columns=columns),
            "The scene of each condition",
            f"The night {scene['kind']} each condition showed before its questions (rows: "
            f"{rows}), at its first, middle and last frame, pixel for pixel: the luminance the "
            f"{shown.describe_display()} showed, relative to its maximum and encoded for an "
            "sRGB screen.",
        )
    ]


def _by_condition(summary, conditions, categories, scale, anchors) -> bytes:
    """One row per condition: the ratings of each category as diverging stacked bars."""
    rows = len(conditions)
    figure, axes = subplots(
        rows, 1, figsize=(7, (0.32 * len(categories) + 0.9) * rows + 0.8), squeeze=False
    )
    colours = _colours(scale)
    for index, condition in enumerate(conditions):
        bars = axes[index, 0]
        name = condition["name"]
        bars.set_title(
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
    figure, axis = subplots(figsize=(7, 0.5 * len(summary) + 1.5))
    colours = _colours(scale)
    y = np.arange(len(summary))[::-1]
    below = len(scale) // 2  # ratings left of the middle; an odd scale has a neutral one
    reach = 0.0
    for index, row in enumerate(summary.itertuples()):
        counts = np.array([getattr(row, f"count_{k}") for k in scale], float)
        share = 100 * counts / counts.sum()
        neutral = share[below] if len(scale) % 2 else 0.0
        left = -share[:below].sum() - neutral / 2  # the middle of the scale on 0
        reach = max(reach, -left, left + share.sum())
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
    axis.set_xlim(-reach - 5, reach + 5)  # symmetric, no bar touching the frame
    axis.xaxis.set_major_formatter(lambda x, _: f"{abs(x):g}")  # shares, left and right
    axis.set_yticks(y, summary["category"])
    axis.set_xlabel(f"% of participants ({scale[0]} = {anchors[0]} … {scale[-1]} = {anchors[1]})")
    axis.legend(
        ncol=len(scale), fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.25), frameon=False
    )
    return png(figure)


def _colours(scale: range) -> list:
    """Reds below the middle of the scale, blues above it, and a grey middle category that
    shows against white (a diverging map's own middle is nearly white)."""
    below = len(scale) // 2
    reds = matplotlib.colormaps["RdBu"](np.linspace(0.08, 0.35, below)) if below else []
    blues = matplotlib.colormaps["RdBu"](np.linspace(0.65, 0.92, below)) if below else []
    middle = [matplotlib.colors.to_rgba(NEUTRAL)] if len(scale) % 2 else []
    return [*reds, *middle, *blues]


def _participants(trials: pd.DataFrame, categories: list[str], scale: range) -> bytes:
    participants = sorted(trials["participant"].unique())
    ratings = trials.pivot_table(
        index="participant", columns="category", values="rating", aggfunc="first"
    ).reindex(index=participants, columns=categories)
    figure, axis = subplots(figsize=(1.1 * len(categories) + 2.0, 0.32 * len(participants) + 1.6))
    cmap = matplotlib.colors.ListedColormap(_colours(scale))
    norm = matplotlib.colors.BoundaryNorm(np.arange(scale[0] - 0.5, scale[-1] + 1), cmap.N)
    axis.imshow(ratings.to_numpy(float), cmap=cmap, norm=norm, aspect="auto")
    for (row, column), value in np.ndenumerate(ratings.to_numpy(float)):
        if np.isfinite(value):
            dark = abs(value - (scale[0] + scale[-1]) / 2) >= (len(scale) - 1) / 3
            axis.text(
                column,
                row,
                f"{value:g}",
                ha="center",
                va="center",
                fontsize=8,
                color="white" if dark else "black",
            )
    axis.set_xticks(range(len(categories)), categories, rotation=30, ha="right", fontsize=8)
    axis.set_yticks(range(len(participants)), participants, fontsize=8)
    axis.set_xticks(np.arange(len(categories) + 1) - 0.5, minor=True)
    axis.set_yticks(np.arange(len(participants) + 1) - 0.5, minor=True)
    axis.grid(which="minor", color="white", lw=1.5)
    axis.tick_params(which="minor", length=0)
    return png(figure)
