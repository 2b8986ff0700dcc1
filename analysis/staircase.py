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
from matplotlib.ticker import MaxNLocator
from scipy.optimize import minimize
from scipy.special import expit
from threadpoolctl import threadpool_limits

from .apa import anova_effect, corrected_p, series, unit_interval
from .figures import Figure, plt, png, small_multiples
from .load import Dataset, where
from .methods import display_text
from .stats import apa_anova, rm_anova

__all__ = [
    "analyse",
    "check",
    "design",
    "methods",
    "psychometric_match",
    "reversal_match",
    "stimulus_figures",
]

DISCARDED_REVERSALS = 2
MARKERS = "osD^v<>"
ALPHA = 0.05  # the significance level the results text uses
EFFECT_NAMES = {
    "glare_level": "the main effect of glare level",
    "context": "the main effect of context",
    "glare_level × context": "the glare level × context interaction",
}


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
    the trial's glare level, a presentation time or a step it does not have, a failed
    presentation counted; and a participant none of whose trials counted."""
    strengths = protocol["glare"]["strengths"]
    durations = protocol["trials"]["presentation_ms"]
    steps = protocol["trials"]["step_fractions"]
    problems = []
    for _, row in trials.iterrows():
        expected = strengths[int(row["glare_level"]) - 1]
        if not np.isclose(row["strength"], expected, rtol=1e-6):
            problems.append(
                f"{where(row)}, column strength: {row['strength']!r}; the protocol's glare "
                f"level {int(row['glare_level'])} has strength {expected:g}"
            )
        if not np.isclose(durations, row["duration_ms"]).any():
            problems.append(
                f"{where(row)}, column duration_ms: {row['duration_ms']!r}; the protocol "
                f"presents for {', '.join(f'{d:g}' for d in durations)} ms"
            )
        if not np.isclose(steps, row["step_fraction"]).any():
            problems.append(
                f"{where(row)}, column step_fraction: {row['step_fraction']!r}; the protocol's "
                f"steps are {', '.join(f'{s:g}' for s in steps)}"
            )
        failed = pd.notna(row["presentation_ok"]) and not bool(row["presentation_ok"])
        if bool(row["counted"]) and failed:  # (files before format 0.2 have no presentation_ok)
            problems.append(
                f"{where(row)}: counted, but its presentation failed (presentation_ok false); "
                "a failed flash never moves a staircase"
            )
    counted = trials.groupby("participant")["counted"].apply(lambda c: c.astype(bool).any())
    for participant in counted.index[~counted.to_numpy()]:
        problems.append(
            f"participant {participant}: none of their trials counted (every presentation "
            "failed?); leave their files out of the analysis, or the report cannot show them"
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


def _staircase_row(
    participant, context, level, staircase: pd.DataFrame, *, tests_only: bool
) -> dict:
    return {
        "participant": participant,
        "context": context,
        "glare_level": int(level),
        "strength": staircase["strength"].iloc[0],
        "trials": len(staircase),
        "reversals": int(staircase["reversal"].astype(bool).sum()),
        "match_reversals": reversal_match(staircase),
        "match_psychometric": float("nan") if tests_only else psychometric_match(staircase),
    }


def analyse(dataset: Dataset, protocol, *, tests_only: bool = False) -> dict:
    """Matched intensities, their summary, the ANOVA and Figure 13: tables (DataFrames),
    figures (PNG bytes) and text.

    ``tests_only`` returns only the tables of statistical tests (no figures, no descriptive
    tables or fits), what a power analysis needs for each of thousands of simulated studies.
    """
    every = dataset.trials
    trials = every[every["counted"].astype(bool)]  # repeated flashes did not move a staircase
    # one BLAS thread: the fits are tiny, and on a busy machine OpenBLAS's idle threads made
    # scipy's L-BFGS-B 30x slower (0.1 s a fit instead of 3 ms, measured with scipy 1.17)
    with threadpool_limits(limits=1, user_api="blas"):
        rows = [
            _staircase_row(participant, context, level, staircase, tests_only=tests_only)
            for (participant, context, level), staircase in trials.groupby(
                ["participant", "context", "glare_level"]
            )
        ]
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
        text |= {row["source"]: anova_effect(row) for _, row in anova.iterrows()}
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
    contexts = [c["name"] for c in protocol["contexts"]]
    n = matches["participant"].nunique()
    peak = protocol["glare"]["peak_fraction"]
    return {
        "tables": tables,
        "figures": {
            "figure13_matches.png": Figure(
                _figure13(summary, contexts, peak),
                "Matched disc intensity at each glare level",
                "The disc intensity matched to the glare image (per cent of the display "
                f"maximum; each staircase's mean over its reversals after the first "
                f"{DISCARDED_REVERSALS}), mean ± SEM over n = {n} participants, one line per "
                f"context; the dashed line is the glare image's actual peak "
                f"({100 * peak:g} %). Above it the glare looked brighter than the source "
                "was.",
            ),
            "participants_matches.png": Figure(
                _participants(matches, contexts),
                "Every participant's matches",
                "The matched disc intensity (% of the display maximum) of each participant at "
                f"each glare level, one line per context, one panel per participant (n = {n});"
                " the pale wide lines are the means over all participants, so a participant "
                "who matched differently stands out.",
            ),
        },
        "text": text,
        "results": _results(tables, summary, matches, protocol, repeated, len(every))
        + ([text["unconverged_staircases"]] if "unconverged_staircases" in text else []),
        "captions": {
            k: v
            for k, v in {
                "matches": "Matched disc intensity of every staircase (fraction of the display "
                "maximum)",
                "summary": "Matched disc intensity per context and glare level (fraction of "
                "the display maximum, mean and SEM)",
                "anova": "Repeated-measures ANOVA on the matched disc intensity",
            }.items()
            if k in tables
        },
    }


def _results(
    tables: dict,
    summary: pd.DataFrame,
    matches: pd.DataFrame,
    protocol,
    repeated: int,
    flashes: int,
) -> list[str]:
    """The results section as paragraphs, generated from the tables."""
    n = matches["participant"].nunique()
    contexts = [c["name"] for c in protocol["contexts"]]
    levels = len(protocol["glare"]["strengths"])
    paragraphs = []
    if "anova" in tables:
        anova = tables["anova"]
        design = f"{levels} × {len(contexts)}" if len(contexts) > 1 else f"one-way ({levels})"
        factors = "glare level × context" if len(contexts) > 1 else "glare level"
        effects = "; ".join(
            f"{EFFECT_NAMES[row['source']]} "
            f"{'was' if corrected_p(row) < ALPHA else 'was not'} significant, "
            f"{anova_effect(row)}"
            for _, row in anova.iterrows()
        )
        paragraphs.append(
            f"The matched disc intensity of the {n} participants (each staircase's mean over "
            f"its reversals after the first {DISCARDED_REVERSALS}) was analysed with a "
            f"{design} repeated-measures ANOVA ({factors}): {effects}. Effects with more than "
            "one degree of freedom are reported with Greenhouse–Geisser corrected degrees of "
            "freedom where its ε < .75 and Huynh–Feldt corrected ones otherwise; "
            f"α = {unit_interval(ALPHA)}."
        )
    else:
        paragraphs.append(
            f"With {n} participant{'s' if n != 1 else ''} no inferential statistics can be "
            "computed; the figures and tables describe the matches."
        )
    peak = protocol["glare"]["peak_fraction"]
    weakest, strongest = summary["glare_level"].min(), summary["glare_level"].max()
    ranges = []
    for context in contexts:
        part = summary[summary["context"] == context].set_index("glare_level")
        if part.empty:
            continue
        ranges.append(
            f"from {100 * part.loc[weakest, 'match_mean']:.1f} % "
            f"(SEM {100 * part.loc[weakest, 'match_sem']:.1f}) to "
            f"{100 * part.loc[strongest, 'match_mean']:.1f} % "
            f"(SEM {100 * part.loc[strongest, 'match_sem']:.1f}) in context {context}"
        )
    identified = int(matches["match_psychometric"].notna().sum())
    paragraphs.append(
        "From the weakest to the strongest glare the matched intensity (per cent of the "
        f"display maximum) rose {series(ranges)}; the glare image's actual peak was "
        f"{100 * peak:g} %. The "
        f"logistic fits located the match inside the tested range for {identified} of "
        f"{len(matches)} staircases. {repeated} of {flashes} flashes missed their frames or "
        "timing and were shown again; the staircases use only the counted ones."
    )
    return paragraphs


def stimulus_figures(protocol, shown) -> list[Figure]:
    """The stimuli as the display showed them: the glare images of every strength in each
    context with the comparison at full intensity, and their glare profiles. ``shown`` is an
    :class:`analysis.stimulus_figures.DisplayedSet`."""
    from .stimulus_figures import image_grid, profiles, radial_profile

    g = protocol["glare"]
    geometry = shown.geometry
    pixel_deg = geometry["pixel_deg"]
    size = geometry["window_px"]
    where = (
        f"Each window is {size} px square ({size * pixel_deg:.1f}°, "
        f"{60 * pixel_deg:.2f} arcmin per pixel), shown here pixel for pixel: the luminance "
        f"the {shown.describe_display()} showed, decode(encode(image)) through the set's "
        "calibration, relative to its maximum and encoded for an sRGB screen."
    )
    figures, rows = [], {}
    for context in protocol["contexts"]:
        name = context["name"]
        glare = sorted(
            (n for n, i in shown.images.items() if i["kind"] == "glare" and i["context"] == name),
            key=lambda n: shown.images[n]["level"],
        )
        comparison = [
            n
            for n, i in shown.images.items()
            if i["kind"] == "comparison" and i["context"] == name
        ]
        panels = [
            (
                shown.picture(n),
                f"level {shown.images[n]['level']}: strength {shown.images[n]['strength']:g}",
            )
            for n in glare
        ] + [(shown.picture(n), "comparison, disc at 100 %") for n in comparison]
        figures.append(
            Figure(
                image_grid(panels),
                f"The glare images of context {name} as the display showed them",
                f"The light source with glare ({g['model']} model) at each of the "
                f"{len(glare)} strengths, peak at {100 * g['peak_fraction']:g} % of the display "
                "maximum, and the comparison (disc and annulus) at full intensity. "
                f"{where}",
            )
        )
        rows[f"context {name}"] = [
            (
                str(shown.images[n]["level"]),
                *radial_profile(shown.luminance(n), geometry["centre_px"], pixel_deg),
            )
            for n in glare
        ]
    maximum = shown.calibration.max_cd_m2
    figures.append(
        Figure(
            profiles(
                rows,
                log=True,
                lines={
                    "display maximum": maximum,
                    "actual peak": g["peak_fraction"] * maximum,
                },
            ),
            "Glare profiles of the glare images",
            "The displayed luminance (cd/m², logarithmic) against the distance from the "
            "source's centre, averaged over all directions (one-pixel rings), one curve per "
            "glare level (1 = weakest), one panel per context; the dashed lines are the "
            "display's maximum and the glare image's actual peak.",
        )
    )
    return figures


def _participants(matches: pd.DataFrame, contexts: list[str]) -> bytes:
    participants = sorted(matches["participant"].unique())
    figure, axes = small_multiples(len(participants))
    means = matches.groupby(["context", "glare_level"])["match_reversals"].mean()
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for axis, participant in zip(axes, participants, strict=True):
        part = matches[matches["participant"] == participant]
        for index, (context, marker) in enumerate(zip(contexts, MARKERS, strict=False)):
            if context not in means.index.get_level_values(0):
                continue
            colour = colours[index % len(colours)]
            mean = means.loc[context]
            axis.plot(mean.index, 100 * mean.to_numpy(), color=colour, alpha=0.3, lw=3)
            own = part[part["context"] == context].sort_values("glare_level")
            axis.plot(
                own["glare_level"],
                100 * own["match_reversals"],
                marker=marker,
                ms=3,
                lw=1.2,
                color=colour,
                label=f"context: {context}",
            )
        axis.set_title(participant, fontsize=9)
        axis.tick_params(labelsize=7)
    axes[0].xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0].set_ylabel("match (% of max)", fontsize=8)
    axes[0].legend(fontsize=7, frameon=False)
    figure.supxlabel("glare level (1 = weakest glare)", fontsize=9)
    return png(figure)


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
