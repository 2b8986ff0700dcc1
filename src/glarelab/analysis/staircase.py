"""The analysis of three-way staircase sessions (Spencer et al. 1995, §4.1).

**Matched intensity** of each staircase (participant × context × glare level): the mean disc
intensity at its reversals after the first two (the first reversals still carry the start
value's bias), as a fraction of the display maximum; with fewer than three reversals, the mean
of all reversal points. As an alternative, a **psychometric fit**: a logistic function of the
disc intensity fitted by maximum likelihood to the answers "glare brighter" (1), "disc
brighter" (0) and "neither" (½), as R's ``glm`` fits it (:func:`psychometric_fit`); its 50 %
point is the match where the data locate one, and the matches table says why not elsewhere
(``psychometric_identified`` counts the staircases with one). Each staircase's reversal match
is shown with the range of the reversal points it averages (:func:`reversal_range`), a
description: no interval per staircase covered the true match at its nominal rate in
simulations with known truth (``scripts/staircase_coverage.py``, docs/analysis.md). The
intensities are compared on the staircase's grid (:func:`on_grid`).

**Figure 13** (Spencer's): matched intensity against glare level, per context, mean over
participants with 95 % Cousineau–Morey within-subject intervals, with the line of the glare
image's actual peak (Spencer: 75 %). **The context
effect**: a level × context repeated-measures ANOVA on the matched intensity (with one
context, a one-way ANOVA over the levels).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.ticker import MaxNLocator
from scipy import stats as sps
from threadpoolctl import threadpool_limits

from glarelab.analysis.apa import anova_effect, apa_anova, apa_p, fixed, series, unit_interval
from glarelab.analysis.dataset import Dataset, Design, no_flags, where
from glarelab.analysis.effects import (
    marginal_means,
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
    rm_anova,
)
from glarelab.protocols import format_value
from glarelab.protocols.columns import Column
from glarelab.protocols.staircase import Staircase, answer_limit, flash_frames, intensity_grid

if TYPE_CHECKING:
    from pathlib import Path

    from glarelab.protocols import Protocol

__all__ = [
    "analyse",
    "check",
    "check_session",
    "design",
    "methods",
    "on_grid",
    "psychometric_fit",
    "psychometric_match",
    "reversal_match",
    "reversal_range",
    "stimulus_figures",
    "tests",
]

DISCARDED_REVERSALS = 2
MARKERS = "osD^v<>"
ALPHA = 0.05  # the significance level the results text uses
EFFECT_NAMES = {
    "glare_level": "the main effect of glare level",
    "context": "the main effect of context",
    "glare_level × context": "the glare level × context interaction",
}


def design(protocol: Protocol) -> Design:
    """One staircase (many trials) per context and glare level; the blocks are the contexts.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    glarelab.analysis.dataset.Design
        The factors, the cells each participant needs and the blocks.
    """
    levels = range(1, len(protocol["glare"]["strengths"]) + 1)
    cells = tuple((c["name"], level) for c in protocol["contexts"] for level in levels)
    return Design(
        factors=("context", "glare_level"),
        cells=cells,
        block=None,
        blocks=tuple(c["name"] for c in protocol["contexts"]),
        one_trial_per_cell=False,
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


def check(trials: pd.DataFrame, protocol: Protocol) -> list[str]:
    """Values no session of this protocol can write: a strength that is not the protocol's at
    the trial's glare level, a presentation time or a step it does not have, a disc intensity
    off the staircase's grid, a block that is not the trial's context; flags that contradict
    each other (a flash that did not count although it was shown right or the protocol counts
    every flash, a reversal on a flash that did not count, a failed flash counted before the
    protocol's repeat limit); and a participant none of whose trials counted.

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
    t = protocol["trials"]
    strengths = protocol["glare"]["strengths"]
    durations = t["presentation_ms"]
    steps = t["step_fractions"]
    grid = intensity_grid(t)
    problems = []
    repeated = 0  # failed flashes shown again in a row before this trial (one participant)
    previous = None
    for _, row in trials.iterrows():
        if row["participant"] != previous:
            repeated, previous = 0, row["participant"]
        expected = written(strengths[int(row["glare_level"]) - 1])
        if row["strength"] != expected:
            problems.append(
                f"{where(row)} (trial {row['trial']}), column strength: recorded "
                f"{row['strength']!r}; the protocol's glare level {int(row['glare_level'])} has "
                f"strength {expected!r} (a session writes it exactly; a cell edited?)"
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
        if (
            grid is not None
            and abs(row["disc_fraction"] * grid - round(row["disc_fraction"] * grid))
            > GRID_TOLERANCE
        ):
            problems.append(
                f"{where(row)}, column disc_fraction: {row['disc_fraction']!r} is not on the "
                f"staircase's grid (whole multiples of 1/{grid}: its start and steps)"
            )
        if row["block"] != row["context"]:
            problems.append(
                f"{where(row)}, column block: {row['block']!r}, but the trial's context is "
                f"{row['context']!r} (the blocks are the contexts)"
            )
        counted = bool(row["counted"])
        ok = None if pd.isna(row["presentation_ok"]) else bool(row["presentation_ok"])
        # (files before format 0.2 have no presentation_ok: nothing to compare)
        if not counted and ok:
            problems.append(
                f"{where(row)}: not counted, but its presentation succeeded (presentation_ok "
                "true); only a failed flash is shown again"
            )
        if not counted and bool(row["reversal"]):
            problems.append(
                f"{where(row)}: a reversal on a flash that did not count (counted false); only "
                "a counted answer moves a staircase"
            )
        if not counted and not t["repeat_failed_presentations"]:
            problems.append(
                f"{where(row)}: not counted, but the protocol counts every flash "
                "(trials.repeat_failed_presentations false)"
            )
        if (
            counted
            and ok is False
            and t["repeat_failed_presentations"]
            and repeated < t["repeat_limit"]
        ):
            problems.append(
                f"{where(row)}: counted, but its presentation failed (presentation_ok false) "
                f"after {repeated} repeat(s); a failed flash moves a staircase only after "
                f"{t['repeat_limit']} repeats (trials.repeat_limit)"
            )
        repeated = 0 if counted else repeated + 1
    counted = trials.groupby("participant")["counted"].apply(lambda c: c.astype(bool).any())
    for participant in counted.index[~counted.to_numpy()]:
        problems.append(
            f"participant {participant}: none of their trials counted (every presentation "
            "failed?); leave their files out of the analysis, or the report cannot show them"
        )
    return problems


STRENGTH_COLUMN = Column("strength", float, "source excess over the displayed peak")


def written(value: float) -> float:
    """A protocol's float as a session's CSV holds it, read back: the text the session writes
    (:func:`glarelab.protocols.columns.format_value`) parsed as the analysis parses it.

    Parameters
    ----------
    value
        The protocol's value.

    Returns
    -------
    float
        The value read back from its cell.

    Examples
    --------
    >>> written(2.68), written(0.0254)
    (2.68, 0.0254)
    """
    return float(format_value(value, STRENGTH_COLUMN))


def check_session(
    path: Path, rows: list[dict], sidecar: dict | None, protocol: Protocol
) -> list[str]:
    """One session's staircases replayed from the protocol's rules, and its flashes' frames.

    Each staircase (a context's glare level) is run again with the session's own staircase
    (:class:`glarelab.protocols.staircase.Staircase`: ``trials.start_fraction``, the next step of
    ``trials.step_fractions`` at each reversal, ``trials.neither``, ending after
    ``trials.reversals``) on the recorded responses in trial order: every row's
    ``disc_fraction`` must be where the answers before it put the disc, its ``reversal`` and
    ``step_fraction`` what its own answer gave (a flash that did not count moves nothing), and
    no row may follow the staircase's end. In a session whose sidecar status is ``completed``
    every staircase of the protocol must have ended by that rule. The first disagreement of a
    staircase is named (the later rows of that staircase follow from it). ``frames`` must be
    the whole frames of ``duration_ms`` at a refresh rate the sidecar records
    (:func:`glarelab.protocols.staircase.flash_frames`).

    Parameters
    ----------
    path
        The session's CSV (named in the problems).
    rows
        Its trials, typed by the protocol's columns (``_file`` and ``_line`` name each), with
        trial numbers unique; in any order.
    sidecar
        Its sidecar, or None (then ``frames`` is not checked).
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    list of str
        One problem per line: file, line, trial, column, the recorded and the expected value.
    """
    t = protocol["trials"]
    grid = intensity_grid(t)
    strengths = protocol["glare"]["strengths"]
    staircases: dict[tuple[str, int], Staircase] = {}
    broken: set[tuple[str, int]] = set()
    problems = []

    def same(recorded: float, expected: float) -> bool:
        if grid is not None:
            return abs(recorded * grid - expected * grid) <= GRID_TOLERANCE
        return bool(np.isclose(recorded, expected, rtol=1e-9, atol=1e-12))

    def text(value) -> str:
        if isinstance(value, bool):
            return "true" if value else "false"
        return f"{value!r}"

    for row in sorted(rows, key=lambda r: r["trial"]):
        key = (row["context"], int(row["glare_level"]))
        if key in broken:
            continue
        if key not in staircases:
            staircases[key] = Staircase(
                level=key[1],
                strength=strengths[key[1] - 1],
                fraction=t["start_fraction"],
                steps=tuple(t["step_fractions"]),
                reversals_needed=t["reversals"],
                neither=t["neither"],
                grid=grid,
            )
        s = staircases[key]
        label = f"{where(row)} (trial {row['trial']}, context {key[0]}, glare level {key[1]})"
        if s.done:
            problems.append(
                f"{label}: the staircase had ended before it ({s.reversals} reversals after "
                f"{s.trials} answers; trials.reversals = {t['reversals']}): no session shows "
                "it again"
            )
            broken.add(key)
            continue
        found = []
        if not same(row["disc_fraction"], s.fraction):
            found.append(("disc_fraction", row["disc_fraction"], s.fraction))
        reversal = s.update(row["response"]) if bool(row["counted"]) else False
        if bool(row["reversal"]) != reversal:
            found.append(("reversal", bool(row["reversal"]), reversal))
        if not np.isclose(row["step_fraction"], s.step, rtol=1e-9, atol=0.0):
            found.append(("step_fraction", row["step_fraction"], s.step))
        if found:
            column, recorded, expected = found[0]
            problems.append(
                f"{label}, column {column}: recorded {text(recorded)}, the staircase replayed "
                f"from the responses gives {text(expected)} (start {t['start_fraction']:g}, "
                f"steps {', '.join(f'{x:g}' for x in t['step_fractions'])} by reversals, "
                "counted responses in trial order): a cell edited, or a response changed?"
            )
            broken.add(key)
    if (sidecar or {}).get("status") == "completed":
        # a completed session ran every staircase to its end (an aborted one may stop anywhere)
        cap = answer_limit(t["reversals"])
        for context in protocol["contexts"]:
            for level in range(1, len(strengths) + 1):
                key = (context["name"], level)
                if key in broken:
                    continue
                s = staircases.get(key)
                reached = (0, 0) if s is None else (s.reversals, s.trials)
                if s is None or not s.done:
                    problems.append(
                        f"{path}: staircase context {key[0]}, glare level {key[1]} ended with "
                        f"{reached[0]} reversals after {reached[1]} answers, but the sidecar's "
                        f"status is completed: a staircase ends after trials.reversals = "
                        f"{t['reversals']} reversals or {cap} answers (rows deleted, or a "
                        "response changed?)"
                    )
    problems += _frames(rows, sidecar)
    return problems


def _frames(rows: list[dict], sidecar: dict | None) -> list[str]:
    """Rows whose ``frames`` are not ``duration_ms`` at a refresh rate of the session's runs."""
    rates = []
    for value in [
        (sidecar or {}).get("refresh_hz"),
        *(
            run.get("timing_refresh_hz")
            for run in (sidecar or {}).get("runs") or []
            if isinstance(run, dict)
        ),
    ]:
        if isinstance(value, int | float) and not isinstance(value, bool) and value > 0:
            rates.append(float(value))
    if not rates:
        return []
    problems = []
    for row in sorted(rows, key=lambda r: r["trial"]):
        expected = sorted({flash_frames(row["duration_ms"], rate) for rate in rates})
        if row["frames"] not in expected:
            problems.append(
                f"{where(row)} (trial {row['trial']}), column frames: recorded "
                f"{row['frames']!r}; {row['duration_ms']:g} ms at the session's "
                f"{' or '.join(f'{r:g}' for r in sorted(set(rates)))} Hz (its sidecar's "
                f"refresh_hz) is {' or '.join(map(str, expected))} frame(s)"
            )
    return problems


def on_grid(trials: pd.DataFrame, protocol: Protocol) -> pd.DataFrame:
    """The trials with each disc intensity at its point of the staircase's grid
    (:func:`glarelab.protocols.staircase.intensity_grid`): files written before the grid hold
    sums of steps that drift in the last bits (0.84, 0.8399999999999999), which the fits must
    see as one intensity.

    Parameters
    ----------
    trials
        The trials, ``disc_fraction`` a fraction of the display maximum.
    protocol : glarelab.protocols.Protocol
        The study's protocol (its ``[trials]`` give the grid).

    Returns
    -------
    pandas.DataFrame
        The trials, ``disc_fraction`` rounded to the grid (unchanged without one).
    """
    grid = intensity_grid(protocol["trials"])
    if grid is None:
        return trials
    return trials.assign(disc_fraction=(trials["disc_fraction"] * grid).round() / grid)


def reversal_match(staircase: pd.DataFrame) -> float:
    """Mean disc fraction at the reversals after the first two (or all, if fewer than 3).

    Parameters
    ----------
    staircase
        One staircase's trials in order: ``disc_fraction`` (of the display maximum),
        ``response`` and ``reversal``.

    Returns
    -------
    float
        The match, a fraction of the display maximum; the last intensity without reversals.
    """
    reversals = staircase.loc[staircase["reversal"].astype(bool), "disc_fraction"].to_numpy(float)
    if reversals.size == 0:
        return float(staircase["disc_fraction"].iloc[-1])
    kept = reversals[DISCARDED_REVERSALS:] if reversals.size > DISCARDED_REVERSALS else reversals
    return float(kept.mean())


PSYCHOMETRIC_SLOPE_ALPHA = 0.05  # a slope whose likelihood-ratio test gives p above: none
GRID_TOLERANCE = 1e-6  # of a grid step: an intensity farther from the grid is not the staircase's
SCORE_TOLERANCE = 1e-6  # |∂ log L / ∂b| at the fit's maximum (answers are 0, ½, 1)
RESPONSE_CODES = {"glare": 1.0, "disc": 0.0, "neither": 0.5}


def psychometric_fit(staircase: pd.DataFrame) -> dict:
    """A logistic psychometric function of the disc intensity fitted by maximum likelihood,
    with its 50 % point where the data locate one, and why not where they do not.

    The model is R's ``glm(y ~ disc_fraction, family = binomial)``: ``P(glare brighter) =
    1 / (1 + exp(-(b0 + b1 x)))`` with the answers "glare brighter" 1, "disc brighter" 0 and
    "neither" ½ (a fractional response, as R takes it with a warning); the match is
    ``-b0 / b1``. It is fitted by iteratively reweighted least squares (statsmodels ``GLM``,
    the algorithm of R's ``glm``). The logistic log-likelihood is concave in ``(b0, b1)``, so
    a maximum it converges to is the only one and no other starting point can find a better
    one; what can go wrong is that there is none: where the answers are separated by the disc
    intensity (every "glare" below every "disc"), the likelihood grows without bound as the
    slope steepens, and a bounded optimiser stops on its bound. That is checked before the
    fit (Albert & Anderson 1984), and the fit's score is checked to vanish afterwards.

    Parameters
    ----------
    staircase
        One staircase's trials: ``disc_fraction`` (of the display maximum) and
        ``response`` (``'glare'``, ``'disc'`` or ``'neither'``).

    Returns
    -------
    dict
        ``match`` (NaN where not estimable), ``slope`` (``b1``, per unit of the display
        maximum), ``slope_p`` (likelihood-ratio test of ``b1 = 0``) and ``status``:
        ``"estimated"`` (or ``"estimated: the answers change at one disc intensity"``, where
        only "neither" answers at one intensity keep them from being separated: the slope is
        unbounded and the match is that intensity, the limit of the fit) or ``"not
        estimable: …"`` naming why: the answers never change; they are separated (no finite
        maximum; the interval the match lies in is named); a slope of the wrong sign (the
        glare looks brighter as the disc brightens) or none (likelihood-ratio p ≥ .05); the
        50 % point outside the tested range 0-1.

    Notes
    -----
    psignifit (Schütt et al. 2016) fits psychometric functions with guess and lapse rates by
    Bayesian inference; it is not used here because the staircase's three answers, "neither"
    as ½, are not the binomial counts it models, and the match is the point of subjective
    equality of a two-alternative judgement without a guess rate, which is the logistic
    regression that R's ``glm`` and this function fit, and the check against R can be exact.

    References
    ----------
    Albert & Anderson (1984), Biometrika 71, 1-10 (existence of the maximum likelihood
    estimate); McCullagh & Nelder (1989), Generalized Linear Models, §4.4 (IRLS).

    Examples
    --------
    >>> staircase = pd.DataFrame({"disc_fraction": [0.2, 0.4, 0.6, 0.5, 0.45, 0.55, 0.3, 0.7],
    ...     "response": ["glare", "glare", "disc", "glare", "disc", "disc", "glare", "disc"]})
    >>> fit = psychometric_fit(staircase)
    >>> fit["status"], round(fit["match"], 3), round(fit["slope"], 1)  # R's glm: .473, -23.6
    ('estimated', 0.473, -23.6)
    """
    import statsmodels.api as sm

    x = staircase["disc_fraction"].to_numpy(float)
    y = staircase["response"].map(RESPONSE_CODES).to_numpy(float)
    nan = float("nan")

    def result(status: str, match=nan, slope=nan, slope_p=nan) -> dict:
        return {"match": match, "slope": slope, "slope_p": slope_p, "status": status}

    if np.all(y == y[0]) or np.ptp(x) == 0:
        return result("not estimable: the answers never change (a bound, not a threshold)")
    some_glare, some_disc = y > 0, y < 1  # "neither" (½) is both
    # separation (Albert & Anderson 1984): where no "glare" answer lies above a "disc" answer,
    # the likelihood grows without bound as the slope steepens
    highest_glare, lowest_disc = x[some_glare].max(), x[some_disc].min()
    if x[some_glare].min() >= x[some_disc].max():
        return result("not estimable: the slope has the wrong sign (every \"glare\" answer "
                      "at a brighter disc than every \"disc\" answer)")  # fmt: skip
    if highest_glare < lowest_disc:
        return result(
            'not estimable: the answers are separated (every "glare brighter" below every '
            f'"disc brighter"): the likelihood has no maximum; the match lies between '
            f"{highest_glare:.4g} and {lowest_disc:.4g}"
        )
    if highest_glare == lowest_disc:
        # quasi-complete separation: separated but for "neither" answers at one intensity;
        # the slope is unbounded and the 50 % point is that intensity (the limit of the fit)
        return result(
            "estimated: the answers change at one disc intensity (the slope is unbounded)",
            match=float(highest_glare),
            slope=float("-inf"),
            slope_p=0.0,
        )
    design = sm.add_constant(x, prepend=True)
    model = sm.GLM(y, design, family=sm.families.Binomial())
    with warnings.catch_warnings():  # restored on leaving: no filter left changed
        # statsmodels warns of "perfect separation" wherever a fitted probability reaches
        # 1e-10 of 0 or 1 (a steep slope), and of overflow in exp there; separation itself
        # is tested above
        warnings.simplefilter("ignore")
        fit = model.fit(method="IRLS", tol=1e-14, maxiter=200)
        score = model.score(fit.params)
        deviance_drop = float(fit.null_deviance - fit.deviance)  # (lazy: fits the null model)
    b0, b1 = (float(v) for v in fit.params)
    # at the maximum the score (the gradient of the log-likelihood) vanishes; statsmodels'
    # own convergence flag (relative change of the deviance < 1e-14) can miss it by rounding
    if not np.all(np.isfinite(fit.params)) or not np.all(np.abs(score) < SCORE_TOLERANCE):
        return result("not estimable: the fit did not converge", slope=b1)
    slope_p = float(sps.chi2.sf(max(0.0, deviance_drop), 1))
    if b1 >= 0:  # "glare brighter" more often as the disc brightens
        return result(
            f"not estimable: the slope has the wrong sign (b1 = {b1:.3g})",
            slope=b1,
            slope_p=slope_p,
        )
    if slope_p >= PSYCHOMETRIC_SLOPE_ALPHA:
        return result(
            f"not estimable: no slope (b1 = {b1:.3g} per unit of the maximum, "
            f"likelihood-ratio p = {slope_p:.2g})",
            slope=b1,
            slope_p=slope_p,
        )
    centre = -b0 / b1
    if not 0.0 <= centre <= 1.0:
        return result(
            f"not estimable: the 50 % point {centre:.3g} lies outside the tested range 0-1",
            slope=b1,
            slope_p=slope_p,
        )
    return result("estimated", match=centre, slope=b1, slope_p=slope_p)


def psychometric_match(staircase: pd.DataFrame) -> float:
    """The 50 % point of :func:`psychometric_fit`; NaN where it is not estimable.

    Parameters
    ----------
    staircase
        One staircase's trials in order: ``disc_fraction`` (of the display maximum),
        ``response`` and ``reversal``.

    Returns
    -------
    float
        The match, a fraction of the display maximum, or NaN.
    """
    return psychometric_fit(staircase)["match"]


def reversal_range(staircase: pd.DataFrame) -> tuple[float, float]:
    """The lowest and the highest disc intensity at the reversals :func:`reversal_match`
    averages: the range the staircase oscillated over. A description, not a confidence
    interval: a staircase of a dozen answers locates its match too poorly for one that covers
    at its nominal rate (docs/analysis.md: a bootstrap of the reversal points covered the
    true match in 59 % of 1,800 simulated staircases, this range in 75 %). NaN without
    reversals.

    Parameters
    ----------
    staircase
        One staircase's trials in order: ``disc_fraction`` (of the display maximum),
        ``response`` and ``reversal``.

    Returns
    -------
    low, high : float
        Fractions of the display maximum.
    """
    reversals = staircase.loc[staircase["reversal"].astype(bool), "disc_fraction"].to_numpy(float)
    kept = reversals[DISCARDED_REVERSALS:] if reversals.size > DISCARDED_REVERSALS else reversals
    if kept.size == 0:
        return float("nan"), float("nan")
    return float(kept.min()), float(kept.max())


def _counted(dataset: Dataset, protocol: Protocol) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every trial, and the counted ones (repeated flashes did not move a staircase), with
    their intensities on the staircase's grid."""
    every = on_grid(dataset.trials, protocol)
    return every, every[every["counted"].astype(bool)]


def _matches(trials: pd.DataFrame, protocol: Protocol, *, fits: bool) -> pd.DataFrame:
    """One row per staircase: its reversal match, and with ``fits`` the range of its kept
    reversals and the psychometric fit."""
    rows = []
    # one BLAS thread: the fits are tiny, and on a busy machine OpenBLAS's idle threads made
    # scipy's L-BFGS-B 30x slower (0.1 s a fit instead of 3 ms, measured with scipy 1.17)
    with threadpool_limits(limits=1, user_api="blas"):
        for (participant, context, level), staircase in trials.groupby(
            ["participant", "context", "glare_level"]
        ):
            row = {
                "participant": participant,
                "context": context,
                "glare_level": int(level),
                "strength": staircase["strength"].iloc[0],
                "trials": len(staircase),
                "reversals": int(staircase["reversal"].astype(bool).sum()),
                "match_reversals": reversal_match(staircase),
            }
            if fits:
                low, high = reversal_range(staircase)
                fit = psychometric_fit(staircase)
                row |= {
                    "reversals_low": low,
                    "reversals_high": high,
                    "match_psychometric": fit["match"],
                    "psychometric_slope": fit["slope"],
                    "psychometric": fit["status"],
                }
            rows.append(row)
    matches = pd.DataFrame(rows)
    matches["converged"] = matches["reversals"] >= protocol["trials"]["reversals"]
    return matches


def _anova(matches: pd.DataFrame) -> pd.DataFrame | None:
    """The glare level × context ANOVA on the reversal matches (one-way with one context);
    None with one participant."""
    if matches["participant"].nunique() < 2:
        return None
    factors = ["glare_level", "context"] if matches["context"].nunique() > 1 else ["glare_level"]
    data = matches.rename(columns={"match_reversals": "match"})
    anova = rm_anova(data, "match", factors, "participant", untestable="report")
    anova["apa_gg"] = apa_anova(anova, correction="GG")
    anova["apa_hf"] = apa_anova(anova, correction="HF")
    return anova


def tests(dataset: Dataset, protocol: Protocol) -> dict[str, pd.DataFrame]:
    """The statistical tests alone (what a power analysis runs on thousands of simulated
    studies; :func:`analyse` reports the same): the ANOVA on the reversal matches, none with
    one participant.

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
    _, trials = _counted(dataset, protocol)
    anova = _anova(_matches(trials, protocol, fits=False))
    return {} if anova is None else {"anova": anova}


def analyse(dataset: Dataset, protocol: Protocol) -> dict:
    """Matched intensities, their summary, the ANOVA and Figure 13: tables (DataFrames),
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
    every, trials = _counted(dataset, protocol)
    matches = _matches(trials, protocol, fits=True)
    needed = protocol["trials"]["reversals"]
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
    several = matches["participant"].nunique() > 1
    if several:  # Cousineau–Morey, over every context × level cell
        within = within_subject_ci(
            matches, "match_reversals", ["context", "glare_level"], "participant"
        ).set_index(["context", "glare_level"])["ci_half"]
        summary["match_ci_within"] = [
            within[key] for key in zip(summary["context"], summary["glare_level"], strict=True)
        ]
    else:
        summary["match_ci_within"] = float("nan")
    tables = {"matches": matches, "summary": summary}
    text = {}
    anova = _anova(matches)
    factors = ["glare_level", "context"] if matches["context"].nunique() > 1 else ["glare_level"]
    shown = {}
    if anova is not None:
        tables["anova"] = anova
        # the η²p intervals (ms each) from the df of the test each effect is decided on
        shown["anova"] = with_eta2_ci(anova)
        means = marginal_means(matches, "match_reversals", factors, "participant")
        means["factor"] = (
            means["factor"].map({"glare_level": "glare level"}).fillna(means["factor"])
        )
        tables["marginal_means"] = means.rename(
            columns={"emmean": "match_mean", "se": "match_se", "ci_low": "match_ci_low",
                     "ci_high": "match_ci_high"}
        )  # fmt: skip
        tables["assumptions"] = assumptions(
            anova, anova_residuals(matches, "match_reversals", factors, "participant")
        )
        text |= {row["source"]: anova_effect(row) for _, row in shown["anova"].iterrows()}
        tables["effect_sizes"] = shown["anova"][
            ["source", "eta2_partial", "eta2p_ci_low", "eta2p_ci_high", "eta2_generalized"]
        ]
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
        # for JASP's repeated-measures ANOVA: a participant's reversal match in each cell
        "wide": participants_wide(matches, "match_reversals", ["context", "glare_level"]),
        "figures": {
            "matches_by_glare_level.png": Figure(
                _figure13(summary, contexts, peak),
                "Matched disc intensity at each glare level",
                "The disc intensity matched to the glare image (per cent of the display "
                f"maximum; each staircase's mean over its reversals after the first "
                f"{DISCARDED_REVERSALS}), mean over n = {n} participants with 95 % "
                "within-subject confidence intervals (Cousineau 2005 with Morey's 2008 "
                "correction, over every context × level cell), one line per "
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
        "results": _results(tables | shown, summary, matches, protocol, repeated, len(every))
        + ([text["unconverged_staircases"]] if "unconverged_staircases" in text else []),
        "captions": {k: v for k, v in CAPTIONS.items() if k in tables},
    }


CAPTIONS = {
    "matches": "Matched disc intensity of every staircase (fraction of the display maximum): "
    "the reversal mean with the lowest and highest reversal point it averages (the range the "
    "staircase oscillated over: a description, not a confidence interval), and the "
    "psychometric fit's 50 % point, or why it is not estimable",
    "summary": "Matched disc intensity per context and glare level (fraction of the display "
    "maximum, mean, SEM and half the 95 % within-subject CI)",
    "anova": "Repeated-measures ANOVA on the matched disc intensity (MSE: the effect's error "
    "mean square; the correction each effect is decided on: the assumptions table)",
    "marginal_means": "Estimated marginal means of the matched disc intensity (fraction of "
    "the maximum) per level of each factor, with 95 % CIs",
    "effect_sizes": "Effect sizes of the ANOVA effects: η²p with its 90 % CI (Steiger "
    "2004, from the df of the test reported) and η²G",
    "assumptions": "Assumptions: the sphericity correction of each effect and why, and "
    "Shapiro–Wilk of the ANOVA's residuals",
}


def _verdict(row) -> str:
    if not np.isfinite(row["F"]):
        return "could not be tested"
    return "was significant" if corrected_p(row) < ALPHA else "was not significant"


def _results(
    tables: dict,
    summary: pd.DataFrame,
    matches: pd.DataFrame,
    protocol: Protocol,
    repeated: int,
    flashes: int,
) -> list[str]:
    """The results section as paragraphs, generated from the tables: the ANOVA, the matches
    at the weakest and the strongest glare (described, the ANOVA tests them), the fits, and a
    word on any assumption that failed."""
    n = matches["participant"].nunique()
    contexts = [c["name"] for c in protocol["contexts"]]
    levels = len(protocol["glare"]["strengths"])
    paragraphs = []
    if "anova" in tables:
        anova = tables["anova"]
        design = f"{levels} × {len(contexts)}" if len(contexts) > 1 else f"one-way ({levels})"
        factors = "glare level × context" if len(contexts) > 1 else "glare level"
        effects = "; ".join(
            f"{EFFECT_NAMES[row['source']]} {_verdict(row)}, {anova_effect(row)}"
            for _, row in anova.iterrows()
        )
        lower_bound = (anova.apply(correction, axis=1) == "LB").any()
        paragraphs.append(
            f"The matched disc intensity of the {n} participants (each staircase's mean over "
            f"its reversals after the first {DISCARDED_REVERSALS}) was analysed with a "
            f"{design} repeated-measures ANOVA ({factors}): {effects}. Effects with more than "
            "one degree of freedom are reported with Greenhouse–Geisser corrected degrees of "
            "freedom where its ε < .75 and Huynh–Feldt corrected ones otherwise"
            + (
                "; where sphericity cannot be estimated (fewer participants than the effect's "
                "degrees of freedom + 1), with the lower bound ε = 1/df, the correction valid "
                "whatever the covariance, and the conclusion rests on it (the uncorrected "
                "test is given beside it)"
                if lower_bound
                else ""
            )
            + f"; α = {unit_interval(ALPHA)}."
        )
    else:
        paragraphs.append(
            f"With {n} participant{'s' if n != 1 else ''} no inferential statistics can be "
            "computed; the figures and tables describe the matches."
        )
    peak = protocol["glare"]["peak_fraction"]
    weakest, strongest = summary["glare_level"].min(), summary["glare_level"].max()
    ranges = []

    def sem(value: float) -> str:  # one participant's matches have no SEM
        return f" (SEM {fixed(100 * value, 1)})" if np.isfinite(value) else ""

    for context in contexts:
        part = summary[summary["context"] == context].set_index("glare_level")
        if part.empty:
            continue
        ranges.append(
            f"{fixed(100 * part.loc[weakest, 'match_mean'], 1)} %"
            f"{sem(part.loc[weakest, 'match_sem'])} at the weakest and "
            f"{fixed(100 * part.loc[strongest, 'match_mean'], 1)} %"
            f"{sem(part.loc[strongest, 'match_sem'])} at the strongest glare in context {context}"
        )
    identified = int(matches["match_psychometric"].notna().sum())
    reasons = (
        matches.loc[matches["match_psychometric"].isna(), "psychometric"]
        .str.removeprefix("not estimable: ")
        .str.split(r" \(|:", regex=True)
        .str[0]
        .value_counts()
    )
    why = (
        " (not estimable: "
        + series([f"{count} {reason}" for reason, count in reasons.items()])
        + "; the matches table gives each staircase's reason)"
        if len(reasons)
        else ""
    )
    paragraphs.append(
        "The matched intensity (per cent of the display maximum; "
        + ("mean over participants" if n > 1 else "one participant, no SEM")
        + ") was "
        f"{series(ranges)}; the glare image's actual peak was {100 * peak:g} %. The "
        f"logistic fits (maximum likelihood, as R's glm) located the match for {identified} "
        f"of {len(matches)} staircases{why}. {repeated} of {flashes} flashes missed their "
        "frames or timing and were shown again; the staircases use only the counted ones."
    )
    if "assumptions" in tables:
        checks = tables["assumptions"]
        failed = checks[(checks["check"] == "normality") & (checks["shapiro_p"] < ALPHA)]
        if not failed.empty:
            row = failed.iloc[0]
            paragraphs.append(
                f"A Shapiro–Wilk test rejected normality of the {row['of']} (W = "
                f"{unit_interval(row['shapiro_W'], 3)}, {apa_p(row['shapiro_p'])}): the F tests "
                "above assume normally distributed residuals, so their p-values are "
                "approximate; the assumptions table gives every check."
            )
    return paragraphs


def stimulus_figures(protocol: Protocol, shown) -> list[Figure]:
    """The stimuli as the display showed them: the glare images of every strength in each
    context with the comparison at full intensity, and their glare profiles. ``shown`` is an
    :class:`glarelab.analysis.stimulus_figures.VerifiedSet`.

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
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
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
    handles, names = axes[0].get_legend_handles_labels()
    # below the panels (in the first panel it covered that participant's lines)
    figure.legend(handles, names, loc="upper center", bbox_to_anchor=(0.5, 0.0),
                  ncol=len(names), fontsize=8, frameon=False)  # fmt: skip
    figure.supxlabel("glare level (1 = weakest glare)", fontsize=9)
    return png(figure)


def _figure13(summary: pd.DataFrame, contexts: list[str], peak_fraction: float) -> bytes:
    figure, axis = subplots(figsize=(6, 4))
    for context, marker in zip(contexts, MARKERS, strict=False):
        part = summary[summary["context"] == context]
        if part.empty:
            continue
        axis.errorbar(
            part["glare_level"],
            100 * part["match_mean"],
            yerr=100 * part["match_ci_within"],
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
    axis.set_ylabel("matched disc intensity (% of max)\nmean, 95 % within-subject CI")
    axis.legend(fontsize=8, loc="upper left", bbox_to_anchor=(0, -0.2), ncol=3, frameon=False)
    return png(figure)
