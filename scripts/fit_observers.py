"""Fit the simulated observers' few parameters to Yoshida 2008 §5 / Table 1 and Spencer 1995 §4.1.

Run it from a clone of the repository:

    python scripts/fit_observers.py                    # fit, then report; writes out/observers
    python scripts/fit_observers.py --no-fit           # report the module's fitted defaults

The two stimulus sets are built on first use into the cache (``$GLARELAB_CACHE`` or
``~/.cache/glarelab``; synthetic calibration, as ``glarelab demo`` builds them), or read from
``--yoshida`` / ``--spencer`` folders built with ``glarelab stimuli build``. A reduced fit
(``--glow-bands 0.16 --fit-studies 40 --max-evaluations 20 --studies 100``) runs in seconds
and is what ``tests/test_fit_observers.py`` runs.

What it does, deterministically (fixed seeds, common random numbers), in 2-3 minutes on 2
shared cores (``--no-fit`` under half a minute):

1. **Perceives every image once** with :class:`glarelab.observers.brightness.BrightnessModel`:
the 12
   Yoshida references, glare-free targets on a grid of disk luminances (composed from the set's
   background and coverage images, as the experiment shows them), Spencer's 24 glare images and
   the comparison images on a grid of disc intensities. The glow, ring, apparent size and disk
   luminance of an image do not depend on the fitted parameters, so each image is looked at once
   per glow band and only the brightness equation is re-evaluated during the fit.
2. **Simulates 10-observer Yoshida studies** with the decisions of
   :class:`glarelab.observers.noise.Observer`, the same functions on arrays
   (:func:`glarelab.observers.noise.target_settings` and its neighbours; the staircase's
   comparisons likewise): each observer draws a gain, sets
   the darker and brighter targets, inverted through the targets' own percepts, rounded to the
   1 cd/m² fine step and bounded by the display; the match is their mean. The 6 × 2
   repeated-measures ANOVA, the {A, B, C} and {D, E, F} ANOVAs and Welch's t at D, E, F are
   computed for every study (checked against :func:`glarelab.analysis.stats.rm_anova`).
3. **Fits** the glow band ``w`` (on a grid) and, within each band, ``β`` (glow gain),
   ``G_50``, ``α`` (size exponent), the gain SD and the setting SD by Nelder–Mead. The misfit
   is the sum of the squared z-scores of the paper's statistics among the simulated studies'
   (ln F for the five F values of §5, t for Welch's t at D, E, F), the largest boost of each
   method outside "20 – 35 %" and Method II above Method I (§5), and Spencer's strongest glare
   matching less than 5 points above the 75 % line. The Table 1 criteria are then fitted by
   binomial maximum likelihood of the 36 printed percentages (10 observers per cell), and the
   between-block shift as the smallest on a grid under which Spencer's non-significant context
   effect is at least as likely as a significant one. No number is fitted per level, label or
   method: every image goes through the same equations with the same parameters.
4. **Reports** with fresh seeds: F values over many studies (median and 10-90 % range), boost
   per level, Table 1 per cell, Figure 6 similarity groups, Spencer's matches (7 observers, the
   staircases as the protocol runs them) and the rate of significant context effects (200
   studies per block shift, ``--spencer-studies``); writes
   ``fit.json``, ``report.md`` and PNG figures to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# scipy.stats, pandas, the figures and the EXR reader are imported where they are used, so that
# the report's formatting (markdown) loads fast for tests/observers/test_shipped_fit.py

from glarelab.observers.brightness import BrightnessModel  # noqa: E402
from glarelab.observers.noise import (  # noqa: E402
    ObserverNoise,
    comparison_answers,
    observer_gains,
    perceived_brightness,
    relative_difference,
    target_settings,
)

# --- the papers' numbers ----------------------------------------------------------------------
YOSHIDA_F = {  # Yoshida 2008 §5
    "level": 23.68,  # F(5, 45), L_disk main effect
    "method": 1.64,  # F(1, 9), n.s.
    "interaction": 7.77,  # F(5, 45)
    "method_ABC": 1.4,  # F(1, 9), n.s.
    "method_DEF": 11.96,  # F(1, 9), p < .01
}
YOSHIDA_SUB_INTERACTION = {"ABC": 1.34, "DEF": 0.28}  # F(2, 18), both n.s. (reported only)
YOSHIDA_T = (1.71, 1.73, 1.96)  # t(14) Gaussian > Vos at D, E, F (Welch, one-sided p ~ .05)
BOOST_RANGE = (20.0, 35.0)  # §5: glare "can raise the perceived luminance by 20 - 35%"
BOOST_SCALE = 5.0  # percentage points outside the range counted as one unit of misfit
TABLE1 = {  # Yoshida 2008 Table 1, % "yes" of 10 observers, levels A-F / a-f
    ("gaussian", "q1_glow"): [0, 60, 90, 100, 100, 100],
    ("gaussian", "q2_ring"): [0, 10, 20, 50, 80, 90],
    ("gaussian", "q3_same_size"): [90, 100, 30, 10, 0, 0],
    ("vos", "q1_glow"): [0, 100, 90, 100, 100, 100],
    ("vos", "q2_ring"): [0, 70, 80, 80, 80, 90],
    ("vos", "q3_same_size"): [90, 80, 30, 0, 0, 0],
}
YOSHIDA_OBSERVERS = 10  # §4
SPENCER_OBSERVERS = 7  # §4.1
SPENCER_PEAK = 0.75  # §4: the glare image's peak, 75 % of the display maximum
SPENCER_RISE = 0.05  # the strongest glare must match at least 5 points above the 75 % line
BLOCK_SDS = (0.0, 0.01, 0.02, 0.03, 0.05, 0.1)  # observers' shifts between blocks (grid)
METHODS = ("gaussian", "vos")
FITTED = ("glow_gain", "glow_half", "size_exponent", "gain_sd", "setting_sd")
GLOW_BANDS_DEG = (0.1, 0.12, 0.14, 0.16, 0.18, 0.2, 0.25)  # the glow band, fitted on this grid


# --- images -----------------------------------------------------------------------------------


def _manifest(folder: Path) -> dict:
    path = folder / "manifest.json"
    if not path.exists():
        raise SystemExit(
            f"{path} not found: build the set first (glarelab stimuli build protocols/"
            f"{folder.name}.toml --out {folder})"
        )
    return json.loads(path.read_text())


def _labels(protocol: dict) -> dict:
    """The level labels of each of the protocol's methods, checked against :data:`METHODS`."""
    labels = {m["name"]: m["labels"] for m in protocol["glare"]["methods"]}
    if tuple(labels) != METHODS or any(len(v) != 6 for v in labels.values()):
        raise SystemExit(
            f"the Yoshida set must have the methods {', '.join(METHODS)} with 6 levels each; "
            f"got {labels}"
        )
    return labels


def _contexts(protocol: dict) -> list[str]:
    """The names of the Spencer protocol's contexts (their scenes are ``scene_NAME``)."""
    return [context["name"] for context in protocol["contexts"]]


def _centre_of(coverage: np.ndarray) -> tuple[float, float]:
    """The disk's centre in pixel indices: the centroid of its coverage image."""
    rows, cols = np.indices(coverage.shape)
    total = coverage.sum()
    return float((rows * coverage).sum() / total), float((cols * coverage).sum() / total)


def _features(model: BrightnessModel, image: np.ndarray, geometry: dict) -> dict:
    p = model.percept(image, **geometry)
    return {
        "disk": p.disk_cd_m2,
        "glow": p.glow,
        "ring": p.ring,
        "ratio": p.apparent_diameter_deg / geometry["diameter_deg"],
        "diameter_deg": p.apparent_diameter_deg,
    }


def look_at_yoshida(folder: Path, model: BrightnessModel) -> dict:
    from glarelab.stimuli.exr import read_exr

    manifest = _manifest(folder)
    protocol = manifest["protocol"]
    coverage = read_exr(folder / "target_coverage.exr").astype(np.float64)
    background = read_exr(folder / "target_background.exr").astype(np.float64)
    geometry = {
        "centre_px": _centre_of(coverage),
        "diameter_deg": protocol["stimulus"]["disk_deg"],
        "pixel_deg": manifest["geometry"]["pixel_deg"],
    }
    labels = _labels(protocol)
    references = {}
    for method in METHODS:
        for label in labels[method]:
            image = read_exr(folder / f"reference_{method}_{label}.exr")
            references[(method, label)] = _features(model, image, geometry)
    display = protocol["display"]
    grid = np.unique(np.r_[np.arange(0.0, display["max_cd_m2"], 5.0), display["max_cd_m2"]])
    grid = np.maximum(grid, display["black_cd_m2"])
    targets = [_features(model, background + level * coverage, geometry) for level in grid]
    return {
        "protocol": protocol,
        "labels": labels,
        "geometry": geometry,
        "references": references,
        "target_levels": grid,
        "targets": targets,
        "l_dmax": protocol["glare"]["l_dmax_cd_m2"],
    }


def look_at_spencer(folder: Path, model: BrightnessModel) -> dict:
    from glarelab.stimuli.exr import read_exr

    manifest = _manifest(folder)
    protocol = manifest["protocol"]
    disc = read_exr(folder / "comparison_disc.exr").astype(np.float64)
    annulus = read_exr(folder / "comparison_annulus.exr").astype(np.float64)
    pixel = manifest["geometry"]["pixel_deg"]
    geometry = {
        "centre_px": _centre_of(disc),
        "diameter_deg": 2 * protocol["stimulus"]["source_radius_px"] * pixel,
        "pixel_deg": pixel,
    }
    maximum = protocol["display"]["max_cd_m2"]
    ratio = protocol["stimulus"]["annulus_ratio"]
    cover = np.clip(disc + annulus, 0.0, 1.0)
    fractions = np.linspace(0.0, 1.0, 51)[1:]
    glare, comparison = {}, {}
    contexts = _contexts(protocol)
    for context in contexts:
        scene = read_exr(folder / f"scene_{context}.exr").astype(np.float64)
        for level in range(1, len(protocol["glare"]["strengths"]) + 1):
            image = read_exr(folder / f"glare_{context}_{level:02d}.exr")
            glare[(context, level)] = _features(model, image, geometry)
        comparison[context] = [
            _features(
                model, scene * (1 - cover) + f * maximum * (disc + ratio * annulus), geometry
            )
            for f in fractions
        ]
    return {
        "protocol": protocol,
        "contexts": contexts,
        "geometry": geometry,
        "glare": glare,
        "fractions": fractions,
        "comparison": comparison,
        "maximum": maximum,
    }


# --- brightness for a parameter set ----------------------------------------------------------


def _model(theta: dict) -> BrightnessModel:
    return BrightnessModel(
        glow_gain=theta["glow_gain"],
        glow_half=theta["glow_half"],
        size_exponent=theta["size_exponent"],
        glow_band_deg=theta["glow_band_deg"],
    )


def _brightness(model: BrightnessModel, f: dict) -> float:
    return model.brightness(f["disk"], f["glow"], f["ratio"])


# --- statistics, vectorised over simulated studies -------------------------------------------


def rm_f(y: np.ndarray) -> dict:
    """F of the two-way repeated-measures ANOVA for ``y[study, subject, a, b]``: the main
    effects of ``a`` and ``b`` and their interaction (the sums of squares of a fully within
    design; equal to :func:`glarelab.analysis.stats.rm_anova`, see
    :func:`check_against_rm_anova`)."""
    _, n, a, b = y.shape
    m = y.mean((1, 2, 3), keepdims=True)
    s = y.mean((2, 3), keepdims=True)
    ya = y.mean((1, 3), keepdims=True)
    yb = y.mean((1, 2), keepdims=True)
    sa = y.mean(3, keepdims=True)
    sb = y.mean(2, keepdims=True)
    ab = y.mean(1, keepdims=True)
    ss_a = n * b * ((ya - m) ** 2).sum((1, 2, 3))
    ss_as = b * ((sa - s - ya + m) ** 2).sum((1, 2, 3))
    ss_b = n * a * ((yb - m) ** 2).sum((1, 2, 3))
    ss_bs = a * ((sb - s - yb + m) ** 2).sum((1, 2, 3))
    ss_ab = n * ((ab - ya - yb + m) ** 2).sum((1, 2, 3))
    ss_abs = ((y - sa - sb - ab + s + ya + yb - m) ** 2).sum((1, 2, 3))
    with np.errstate(divide="ignore", invalid="ignore"):
        return {
            "a": (ss_a / (a - 1)) / (ss_as / ((a - 1) * (n - 1))),
            "b": (ss_b / (b - 1)) / (ss_bs / ((b - 1) * (n - 1))),
            "ab": (ss_ab / ((a - 1) * (b - 1))) / (ss_abs / ((a - 1) * (b - 1) * (n - 1))),
        }


def welch_t(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Welch's t of ``x`` against ``y`` along axis 1 (subjects), per study."""
    vx, vy = x.var(1, ddof=1) / x.shape[1], y.var(1, ddof=1) / y.shape[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        return (x.mean(1) - y.mean(1)) / np.sqrt(vx + vy)


def yoshida_statistics(match: np.ndarray) -> dict:
    """Every §5 statistic of ``match[study, observer, level, method]`` (method 0 Gaussian)."""
    full = rm_f(match)
    abc, def_ = rm_f(match[:, :, :3]), rm_f(match[:, :, 3:])
    return {
        "level": full["a"],
        "method": full["b"],
        "interaction": full["ab"],
        "method_ABC": abc["b"],
        "method_DEF": def_["b"],
        "interaction_ABC": abc["ab"],
        "interaction_DEF": def_["ab"],
        "t_D": welch_t(match[:, :, 3, 0], match[:, :, 3, 1]),
        "t_E": welch_t(match[:, :, 4, 0], match[:, :, 4, 1]),
        "t_F": welch_t(match[:, :, 5, 0], match[:, :, 5, 1]),
    }


def check_against_rm_anova(match: np.ndarray, studies: int = 3) -> None:
    """The vectorised F values equal :func:`glarelab.analysis.stats.rm_anova` on the same data."""
    import pandas as pd

    from glarelab.analysis.stats import rm_anova

    mine = yoshida_statistics(match[:studies])
    for k in range(studies):
        rows = [
            {"participant": s, "L_disk": level + 1, "method": METHODS[m], "match": v}
            for (s, level, m), v in np.ndenumerate(match[k])
        ]
        table = rm_anova(pd.DataFrame(rows), "match", ["L_disk", "method"], "participant")
        table = table.set_index("source")["F"]
        for key, source in (
            ("level", "L_disk"),
            ("method", "method"),
            ("interaction", "L_disk × method"),
        ):
            if not math.isclose(mine[key][k], table[source], rel_tol=1e-9):
                raise AssertionError(f"F({source}) {mine[key][k]} != rm_anova {table[source]}")


# --- Yoshida: simulated studies -------------------------------------------------------------


class YoshidaSimulation:
    """Simulated 10-observer studies on the rendered images, with common random numbers."""

    def __init__(self, seen: dict, studies: int, seed: int):
        self.seen = seen
        rng = np.random.default_rng(seed)
        n = YOSHIDA_OBSERVERS
        self.z_gain = rng.standard_normal((studies, n, 1, 1))
        self.z_set = rng.standard_normal((studies, n, 6, 2, 2))
        self.z_questions = rng.standard_normal((studies, n, 6, 2, 3))
        display = seen["protocol"]["display"]
        self.low, self.high = display["black_cd_m2"], display["max_cd_m2"]
        self.fine = seen["protocol"]["trials"]["fine_step_cd_m2"]
        self.references = [
            [seen["references"][(m, seen["labels"][m][i])] for m in METHODS] for i in range(6)
        ]

    def run(self, theta: dict) -> dict:
        """``match``, ``darker``, ``brighter`` (study, observer, level, method) and the model's
        boost per reference."""
        model = _model(theta)
        seen = self.seen
        brightness = np.array([[_brightness(model, f) for f in row] for row in self.references])
        disk = np.array([[f["disk"] for f in row] for row in self.references])
        # the targets as the observer sees them: brightness against disk luminance, made
        # monotone (turning a key further never makes the target look darker)
        target = np.maximum.accumulate([_brightness(model, f) for f in seen["targets"]])
        # the observers' decisions, the functions glarelab.observers.Observer applies per trial
        gain = observer_gains(self.z_gain, theta["gain_sd"])
        perceived = perceived_brightness(disk, brightness, gain)
        wanted = target_settings(
            perceived, self.z_set, margin=ObserverNoise().margin, setting_sd=theta["setting_sd"]
        )
        setting = np.interp(wanted, target, seen["target_levels"])
        setting = np.clip(np.round(setting / self.fine) * self.fine, self.low, self.high)
        return {
            "darker": setting[..., 0],
            "brighter": setting[..., 1],
            "match": setting.mean(-1),
            "boost_model": brightness / disk - 1,
            "wanted": wanted,
            "gain": gain,
        }


def boost_percent(match: np.ndarray, l_dmax: float) -> np.ndarray:
    """Mean boost over 220 cd/m² per level and method, averaged over studies (Figure 5)."""
    return 100 * (match.mean((0, 1)) / l_dmax - 1)


def yoshida_loss(result: dict, seen: dict) -> tuple[float, dict]:
    """Misfit: for each printed statistic, its squared z-score within the simulated studies'
    distribution (of ln F, or of t), i.e. how unusual the paper's value would be among studies
    simulated with these parameters; plus the boost range and order of §5."""
    stats = yoshida_statistics(result["match"])
    parts = {}
    for key, value in YOSHIDA_F.items():
        x = np.log(stats[key][np.isfinite(stats[key]) & (stats[key] > 0)])
        parts[key] = ((math.log(value) - x.mean()) / x.std()) ** 2
    for key, value in zip(("t_D", "t_E", "t_F"), YOSHIDA_T, strict=True):
        x = stats[key][np.isfinite(stats[key])]
        parts[key] = ((value - x.mean()) / x.std()) ** 2
    boost = boost_percent(result["match"], seen["l_dmax"])
    largest = boost.max(0)
    for j, method in enumerate(METHODS):  # each method's largest boost inside 20 - 35 %
        low, high = BOOST_RANGE
        outside = max(low - largest[j], largest[j] - high, 0.0)
        parts[f"boost_{method}"] = (outside / BOOST_SCALE) ** 2
    # "Method I boosts the perceived luminance more than Method II" (§5)
    parts["boost_order"] = (max(largest[1] - largest[0], 0.0) / BOOST_SCALE) ** 2
    return sum(parts.values()), parts


# --- Table 1: criteria by binomial maximum likelihood ----------------------------------------


def _q_measure(seen: dict, model: BrightnessModel, question: str, method: str) -> np.ndarray:
    labels = seen["labels"][method]
    features = [seen["references"][(method, label)] for label in labels]
    if question == "q1_glow":
        return np.array([f["glow"] for f in features])
    if question == "q2_ring":
        return np.array([f["ring"] for f in features])
    if question == "q3_same_size":
        # the targets are glare-free disks set near the reference's brightness
        sizes = [t["diameter_deg"] for t in seen["targets"]]
        looks = np.maximum.accumulate([_brightness(model, t) for t in seen["targets"]])
        out = []
        for f in features:
            level = np.interp(_brightness(model, f), looks, seen["target_levels"])
            target = np.interp(level, seen["target_levels"], sizes)
            out.append(abs(math.log(f["diameter_deg"] / target)))
        return np.array(out)
    raise ValueError(f"unknown question {question!r}")


def fit_table1(seen: dict, model: BrightnessModel) -> dict:
    """``(criterion, sd)`` per question maximising the binomial likelihood of Table 1."""
    from scipy import stats as sps
    from scipy.optimize import minimize

    fitted = {}
    for question, sign in (("q1_glow", 1), ("q2_ring", 1), ("q3_same_size", -1)):
        x = np.concatenate([_q_measure(seen, model, question, m) for m in METHODS])
        k = np.concatenate([TABLE1[(m, question)] for m in METHODS]) / 10

        def nll(params, x=x, k=k, sign=sign):
            criterion, log_sd = params
            p = sps.norm.cdf(sign * (x - criterion) / math.exp(log_sd))
            p = np.clip(p, 1e-9, 1 - 1e-9)
            return -np.sum(k * np.log(p) + (10 - k) * np.log(1 - p))

        start = (float(np.median(x)), math.log(max(float(np.std(x)), 1e-3)))
        best = minimize(nll, start, method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-9})
        fitted[question] = (float(best.x[0]), float(math.exp(best.x[1])))
    return fitted


def table1_expected(seen: dict, model: BrightnessModel, criteria: dict) -> dict:
    from scipy import stats as sps

    out = {}
    for question, sign in (("q1_glow", 1), ("q2_ring", 1), ("q3_same_size", -1)):
        criterion, sd = criteria[question]
        for method in METHODS:
            x = _q_measure(seen, model, question, method)
            out[(method, question)] = 100 * sps.norm.cdf(sign * (x - criterion) / sd)
    return out


# --- Spencer: simulated staircases ------------------------------------------------------------


def spencer_brightness(seen: dict, model: BrightnessModel) -> tuple[np.ndarray, np.ndarray]:
    """Glare images ``(context, level)`` and comparisons ``(context, fraction)``: brightness
    and disk luminance, stacked as ``[..., 0]`` brightness and ``[..., 1]`` disk."""
    contexts = seen["contexts"]
    levels = len(seen["protocol"]["glare"]["strengths"])
    glare = np.array(
        [
            [
                (_brightness(model, seen["glare"][(c, k)]), seen["glare"][(c, k)]["disk"])
                for k in range(1, levels + 1)
            ]
            for c in contexts
        ]
    )
    comparison = np.array(
        [[(_brightness(model, f), f["disk"]) for f in seen["comparison"][c]] for c in contexts]
    )
    return glare, comparison


def spencer_pse(seen: dict, theta: dict) -> np.ndarray:
    """Noise-free matched fraction per (context, level) for an observer of gain 1."""
    glare, comparison = spencer_brightness(seen, _model(theta))
    out = np.empty(glare.shape[:2])
    for c in range(glare.shape[0]):
        curve = np.maximum.accumulate(comparison[c, :, 0])
        out[c] = np.interp(glare[c, :, 0], curve, seen["fractions"], right=1.0)
    return out


def simulate_spencer(seen: dict, theta: dict, noise: ObserverNoise, studies: int, seed: int):
    """Staircase matches ``[study, observer, level, context]`` as the protocol runs them."""
    glare, comparison = spencer_brightness(seen, _model(theta))
    trials = seen["protocol"]["trials"]
    steps = np.array(trials["step_fractions"])
    needed = trials["reversals"]
    if trials["neither"] != "hold":
        raise SystemExit("this simulation implements the 'hold' rule for 'neither' only")
    rng = np.random.default_rng(seed)
    contexts, levels = glare.shape[:2]
    shape = (studies, SPENCER_OBSERVERS, contexts, levels)
    gain = observer_gains(rng.standard_normal(shape[:2]), theta["gain_sd"])[:, :, None, None]
    shift = noise.block_sd * rng.standard_normal((*shape[:3], 1))  # per observer and block
    g_b, g_d = glare[..., 0], glare[..., 1]
    seen_glare = perceived_brightness(g_d, g_b, gain)
    fractions = np.r_[0.0, seen["fractions"]]
    comp_b = np.concatenate([np.zeros((contexts, 1)), comparison[..., 0]], axis=1)
    comp_d = np.concatenate([np.zeros((contexts, 1)), comparison[..., 1]], axis=1)
    fraction = np.full(shape, trials["start_fraction"], dtype=float)
    direction = np.zeros(shape)
    reversals = np.zeros(shape, dtype=int)
    count = np.zeros(shape, dtype=int)
    points = np.full((*shape, needed), np.nan)
    limit = 4 * needed + 20
    for _ in range(limit):
        active = (reversals < needed) & (count < limit)
        if not active.any():
            break
        b = np.empty(shape)
        d = np.empty(shape)
        for c in range(contexts):
            b[:, :, c] = np.interp(fraction[:, :, c], fractions, comp_b[c])
            d[:, :, c] = np.interp(fraction[:, :, c], fractions, comp_d[c])
        seen_disc = perceived_brightness(d, b, gain)
        diff = relative_difference(
            seen_glare,
            seen_disc,
            rng.standard_normal(shape),
            comparison_sd=noise.comparison_sd,
            shift=shift,
        )
        move = comparison_answers(diff, noise.neither_band)
        neither = move == 0
        reversal = active & (neither | ((direction != 0) & (move == -direction)))
        where = np.nonzero(reversal)
        points[(*where, reversals[where])] = fraction[where]  # the disc shown at the reversal
        reversals = reversals + reversal
        step = steps[np.minimum(reversals, len(steps) - 1)]
        moving = active & (move != 0)
        fraction = np.where(moving, np.clip(fraction + move * step, 0.0, 1.0), fraction)
        direction = np.where(moving, move, direction)
        count = count + active
    # as analysis.spencer1995.reversal_match: the mean after the first two reversals, or of
    # all of them when there are fewer than three, or the last disc shown when there are none
    found = ~np.isnan(points)
    later = found & (np.arange(needed) >= 2)
    total, count = np.where(found, points, 0).sum(-1), found.sum(-1)
    total_later, count_later = np.where(later, points, 0).sum(-1), later.sum(-1)
    match = np.where(
        count > 2,
        total_later / np.maximum(count_later, 1),
        np.where(count > 0, total / np.maximum(count, 1), fraction),
    )
    return np.moveaxis(match, 2, 3)  # study, observer, level, context


# --- the fit ----------------------------------------------------------------------------------

START = {
    "glow_gain": 0.45,
    "glow_half": 0.1,
    "size_exponent": 0.06,
    "gain_sd": 0.2,
    "setting_sd": 0.1,
}


def _pack(theta: dict) -> np.ndarray:
    return np.log([theta[k] for k in FITTED])


def _unpack(x: np.ndarray, band: float) -> dict:
    return dict(zip(FITTED, np.exp(x).tolist(), strict=True), glow_band_deg=band)


def fit_band(
    yoshida: dict,
    spencer: dict,
    band: float,
    studies: int,
    seed: int,
    *,
    max_evaluations: int = 800,
):
    """Nelder–Mead over :data:`FITTED` for one glow band (images already looked at with it),
    from :data:`START` and from it with half its ``G_50``; the better of the two."""
    from scipy.optimize import minimize

    simulation = YoshidaSimulation(yoshida, studies, seed)

    def loss(x):
        theta = _unpack(x, band)
        if theta["size_exponent"] > 1 or theta["glow_gain"] > 10:
            return 1e6
        value, _ = yoshida_loss(simulation.run(theta), yoshida)
        rise = spencer_pse(spencer, theta)[:, -1].min() - (SPENCER_PEAK + SPENCER_RISE)
        return value + (min(rise, 0.0) / 0.02) ** 2

    best = None
    for scale in (1.0, 0.5):
        start = dict(START, glow_half=START["glow_half"] * scale)
        result = minimize(
            loss,
            _pack(start),
            method="Nelder-Mead",
            options={"maxiter": max_evaluations, "xatol": 1e-3, "fatol": 1e-5},
        )
        if best is None or result.fun < best.fun:
            best = result
    theta = _unpack(best.x, band)
    _, parts = yoshida_loss(simulation.run(theta), yoshida)
    return theta, {
        "loss": float(best.fun),
        "loss_at_start": float(loss(_pack(START))),
        "parts": parts,
        "evaluations": int(best.nfev),
    }


def fit(
    yoshida_dir: Path,
    spencer_dir: Path,
    studies: int,
    seed: int,
    *,
    bands: tuple[float, ...] = GLOW_BANDS_DEG,
    max_evaluations: int = 800,
) -> tuple[dict, dict]:
    """The glow band on ``bands`` (each band changes what the model sees, so the images are
    looked at again), the other parameters by Nelder–Mead within each band."""
    started = time.time()
    results = []
    for band in bands:
        model = BrightnessModel(glow_band_deg=band)
        yoshida = look_at_yoshida(yoshida_dir, model)
        spencer = look_at_spencer(spencer_dir, model)
        theta, info = fit_band(
            yoshida, spencer, band, studies, seed, max_evaluations=max_evaluations
        )
        results.append((info["loss"], band, theta, info))
        print(
            f"  glow band {band:.2f} deg: loss {info['loss']:.3f} ({time.time() - started:.0f} s)",
            flush=True,
        )
    _, band, theta, info = min(results, key=lambda item: item[0])
    info["bands"] = {f"{b:.2f}": float(value) for value, b, _, _ in results}
    return theta, info


# --- report -----------------------------------------------------------------------------------


def _quantiles(x: np.ndarray) -> dict:
    x = x[np.isfinite(x)]
    return {
        "median": float(np.median(x)),
        "p10": float(np.percentile(x, 10)),
        "p90": float(np.percentile(x, 90)),
    }


def similarity_letters(result: dict, seen: dict, studies: int) -> dict:
    """The modal Figure 6 similarity groups over the first ``studies`` simulated studies."""
    import pandas as pd

    from glarelab.analysis.stats import pairwise_tests, similarity_groups

    found: dict = {m: {} for m in METHODS}
    for k in range(studies):
        for j, method in enumerate(METHODS):
            labels = seen["labels"][method]
            rows = [
                {"participant": s, "level": labels[i], "match": result["match"][k, s, i, j]}
                for s in range(YOSHIDA_OBSERVERS)
                for i in range(6)
            ]
            frame = pd.DataFrame(rows)
            table = pairwise_tests(frame, "match", "level", "participant")
            means = frame.groupby("level")["match"].mean().to_dict()
            letters = similarity_groups(means, {(r.a, r.b): r.p_holm for r in table.itertuples()})
            key = " ".join(f"{label}:{letters[label]}" for label in labels)
            found[method][key] = found[method].get(key, 0) + 1
    return {m: sorted(v.items(), key=lambda item: -item[1])[:3] for m, v in found.items() if v}


def report(
    yoshida: dict,
    spencer: dict,
    theta: dict,
    criteria: dict,
    studies: int,
    seed: int,
    *,
    similarity_studies: int = 200,
    spencer_studies: int = 200,
) -> dict:
    import pandas as pd
    from scipy import stats as sps

    from glarelab.analysis.stats import rm_anova

    noise = ObserverNoise(
        gain_sd=theta["gain_sd"],
        setting_sd=theta["setting_sd"],
        glow_criterion=criteria["q1_glow"][0],
        glow_criterion_sd=criteria["q1_glow"][1],
        ring_criterion=criteria["q2_ring"][0],
        ring_criterion_sd=criteria["q2_ring"][1],
        size_tolerance=criteria["q3_same_size"][0],
        size_tolerance_sd=criteria["q3_same_size"][1],
    )
    model = _model(theta)
    result = YoshidaSimulation(yoshida, studies, seed).run(theta)
    check_against_rm_anova(result["match"])
    stats = yoshida_statistics(result["match"])
    df1 = {"level": 5, "method": 1, "interaction": 5, "method_ABC": 1, "method_DEF": 1}
    significant = {
        key: float(np.mean(sps.f.sf(stats[key], df1[key], df1[key] * 9) < 0.05)) for key in df1
    }
    boost = boost_percent(result["match"], yoshida["l_dmax"])
    sem = 100 * (
        result["match"].std(1, ddof=1) / math.sqrt(YOSHIDA_OBSERVERS) / yoshida["l_dmax"]
    ).mean(0)
    table1 = table1_expected(yoshida, model, criteria)
    # Spencer §4.1: "no significant influence" of the context: the smallest shift between
    # blocks on the grid under which a non-significant context effect is at least as likely
    # as a significant one
    with_blocks = {}
    for block_sd in BLOCK_SDS:
        shifted = replace(noise, block_sd=block_sd)
        f = rm_f(simulate_spencer(spencer, theta, shifted, spencer_studies, seed + 2))["b"]
        with_blocks[f"{block_sd:g}"] = float(np.mean(sps.f.sf(f, 1, SPENCER_OBSERVERS - 1) < 0.05))
    block_sd = min((b for b in BLOCK_SDS if with_blocks[f"{b:g}"] <= 0.5), default=BLOCK_SDS[-1])
    noise = replace(noise, block_sd=block_sd)
    spencer_match = simulate_spencer(spencer, theta, noise, spencer_studies, seed + 1)
    context_f = rm_f(spencer_match)["b"]
    context_significant = float(np.mean(sps.f.sf(context_f, 1, SPENCER_OBSERVERS - 1) < 0.05))
    # the vectorised context F equals rm_anova's
    rows = [
        {"participant": s, "level": k + 1, "context": c, "match": spencer_match[0, s, k, c]}
        for s in range(SPENCER_OBSERVERS)
        for k in range(spencer_match.shape[2])
        for c in range(spencer_match.shape[3])
    ]
    table = rm_anova(pd.DataFrame(rows), "match", ["level", "context"], "participant")
    if not math.isclose(table.set_index("source").loc["context", "F"], context_f[0], rel_tol=1e-9):
        raise AssertionError("the vectorised context F differs from rm_anova")
    return {
        "theta": theta,
        "criteria": criteria,
        "block_sd": block_sd,
        "studies": studies,
        "F": {key: _quantiles(stats[key]) for key in stats},
        "significant_rate": significant,
        "boost_percent": {m: boost[:, j].tolist() for j, m in enumerate(METHODS)},
        "boost_sem_percent": {m: sem[:, j].tolist() for j, m in enumerate(METHODS)},
        "boost_model_percent": {
            m: (100 * result["boost_model"][:, j]).tolist() for j, m in enumerate(METHODS)
        },
        "bounds": {
            "darker": result["darker"].mean((0, 1)).tolist(),
            "brighter": result["brighter"].mean((0, 1)).tolist(),
        },
        "table1": {f"{m} {q}": v.tolist() for (m, q), v in table1.items()},
        "features": {
            f"{m} {label}": f
            for (m, label), f in yoshida["references"].items()
            for f in [{k: v for k, v in f.items() if k != "diameter_deg"}]
        },
        "similarity_groups": similarity_letters(result, yoshida, min(studies, similarity_studies)),
        "spencer": {
            "contexts": spencer["contexts"],
            "strengths": spencer["protocol"]["glare"]["strengths"],
            "match_mean": spencer_match.mean((0, 1)).T.tolist(),
            "match_sem": (spencer_match.std(1, ddof=1) / math.sqrt(SPENCER_OBSERVERS))
            .mean(0)
            .T.tolist(),
            "pse_noise_free": spencer_pse(spencer, theta).tolist(),
            "context_F": _quantiles(context_f),
            "context_significant_rate": context_significant,
            "context_significant_rate_by_block_sd": with_blocks,
            "studies": int(spencer_match.shape[0]),
            "features": {f"{c} {k}": f for (c, k), f in spencer["glare"].items()},
            "comparison_full": {c: spencer["comparison"][c][-1] for c in spencer["contexts"]},
        },
    }


def figures(out: Path, summary: dict, yoshida: dict) -> None:
    from glarelab.analysis.figures import png, subplots

    labels = {m: yoshida["labels"][m] for m in METHODS}
    figure, axis = subplots(figsize=(5.5, 3.8))
    for method, marker in zip(METHODS, "os", strict=True):
        axis.errorbar(
            np.arange(1, 7),
            summary["boost_percent"][method],
            yerr=summary["boost_sem_percent"][method],
            marker=marker,
            capsize=3,
            label=f"{method} (simulated, mean ± typical SEM)",
        )
    axis.axhspan(20, 35, color="0.85", zorder=0, label="Yoshida §5: 20-35 %")
    axis.axhline(0, color="k", lw=0.8)
    axis.set_xticks(range(1, 7), [f"{a}/{b}" for a, b in zip(*labels.values(), strict=True)])
    axis.set_xlabel("level of L_disk")
    axis.set_ylabel("boost over 220 cd/m² (%)")
    axis.legend(fontsize=7)
    _write(out / "figure5_simulated_boost.png", png(figure))

    figure, axes = subplots(1, 5, figsize=(13, 2.8))
    for axis, key in zip(axes, YOSHIDA_F, strict=True):
        q = summary["F"][key]
        axis.errorbar(
            [0],
            [q["median"]],
            yerr=[[q["median"] - q["p10"]], [q["p90"] - q["median"]]],
            fmt="o",
            capsize=4,
            label="simulated (median, 10-90 %)",
        )
        axis.plot([0], [YOSHIDA_F[key]], "r*", ms=12, label="Yoshida §5")
        axis.set_yscale("log")
        axis.set_xticks([])
        axis.set_title(key.replace("_", " "), fontsize=9)
    axes[0].legend(fontsize=7)
    _write(out / "yoshida_f_values.png", png(figure))

    s = summary["spencer"]
    figure, axis = subplots(figsize=(5.5, 3.8))
    for c, context in enumerate(s["contexts"]):
        axis.errorbar(
            range(1, len(s["strengths"]) + 1),
            s["match_mean"][c],
            yerr=s["match_sem"][c],
            marker="os"[c % 2],
            capsize=3,
            label=f"context: {context}",
        )
    axis.axhline(SPENCER_PEAK, color="k", ls="--", lw=0.8, label="75 % (no effect of glare)")
    axis.set_xlabel("glare level (strength rises)")
    axis.set_ylabel("matched disc intensity (fraction of max)")
    axis.legend(fontsize=8)
    _write(out / "figure13_simulated.png", png(figure))


def markdown(summary: dict, yoshida: dict) -> str:
    lines = [
        "| statistic | Yoshida 2008 | simulated median [10 %, 90 %] | p < .05 |",
        "|---|---|---|---|",
    ]
    names = {
        "level": "L_disk, F(5, 45)",
        "method": "method, F(1, 9)",
        "interaction": "L_disk × method, F(5, 45)",
        "method_ABC": "method in {A, B, C}, F(1, 9)",
        "method_DEF": "method in {D, E, F}, F(1, 9)",
        "interaction_ABC": "interaction in {A, B, C}, F(2, 18)",
        "interaction_DEF": "interaction in {D, E, F}, F(2, 18)",
        "t_D": "Gaussian − Vos at D, Welch t",
        "t_E": "Gaussian − Vos at E, Welch t",
        "t_F": "Gaussian − Vos at F, Welch t",
    }
    paper = {
        **YOSHIDA_F,
        "interaction_ABC": YOSHIDA_SUB_INTERACTION["ABC"],
        "interaction_DEF": YOSHIDA_SUB_INTERACTION["DEF"],
        "t_D": YOSHIDA_T[0],
        "t_E": YOSHIDA_T[1],
        "t_F": YOSHIDA_T[2],
    }
    for key, name in names.items():
        q = summary["F"][key]
        rate = summary["significant_rate"].get(key)
        lines.append(
            f"| {name} | {paper[key]:g} | {q['median']:.2f} [{q['p10']:.2f}, {q['p90']:.2f}] | "
            f"{'' if rate is None else f'{rate:.2f}'} |"
        )
    lines += ["", "| level | Gaussian boost % | Vos boost % |", "|---|---|---|"]
    labels = {m: yoshida["labels"][m] for m in METHODS}
    for i in range(6):
        lines.append(
            f"| {labels['gaussian'][i]}/{labels['vos'][i]} | "
            f"{summary['boost_percent']['gaussian'][i]:.1f} | "
            f"{summary['boost_percent']['vos'][i]:.1f} |"
        )
    lines += ["", "| question | method | " + " | ".join("ABCDEF") + " |", "|---|---|" + "---|" * 6]
    for question in ("q1_glow", "q2_ring", "q3_same_size"):
        for method in METHODS:
            sim = summary["table1"][f"{method} {question}"]
            cells = [
                f"{p} / {s:.0f}" for p, s in zip(TABLE1[(method, question)], sim, strict=True)
            ]
            lines.append(f"| {question} | {method} | " + " | ".join(cells) + " |")
    s = summary["spencer"]
    lines += ["", "| level | strength | " + " | ".join(s["contexts"]) + " |", "|---|---|---|---|"]
    for k, strength in enumerate(s["strengths"]):
        lines.append(
            f"| {k + 1} | {strength:g} | "
            + " | ".join(f"{s['match_mean'][c][k]:.3f}" for c in range(len(s["contexts"])))
            + " |"
        )
    q = s["context_F"]
    lines += [
        "",
        f"| Spencer 1995 §4.1, {s['studies']} studies of {SPENCER_OBSERVERS} | paper | "
        "simulated median [10 %, 90 %] | p < .05 |",
        "|---|---|---|---|",
        f"| context, F(1, {SPENCER_OBSERVERS - 1}), σ_b = {summary['block_sd']:g} | "
        f"no significant influence | {q['median']:.2f} [{q['p10']:.2f}, {q['p90']:.2f}] | "
        f"{s['context_significant_rate']:.2f} |",
        "",
        "| block shift σ_b | " + " | ".join(s["context_significant_rate_by_block_sd"]) + " |",
        "|---|" + "---|" * len(s["context_significant_rate_by_block_sd"]),
        "| context p < .05 | "
        + " | ".join(f"{r:.2f}" for r in s["context_significant_rate_by_block_sd"].values())
        + " |",
    ]
    return "\n".join(lines) + "\n"


def _stimuli(folder: Path | None, study: str) -> Path:
    """The given set's folder, or the study's set built once into the cache with the synthetic
    calibration ``glarelab demo`` uses
    (:func:`glarelab.stimuli.stimulus_set.cached_stimulus_set`)."""
    if folder is not None:
        return folder
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    print(f"the {study} stimulus set (built once into the cache) ...", flush=True)
    return cached_stimulus_set(load_protocol(study))


def _write(path: Path, data: bytes) -> None:
    """Write to a temporary name and rename when complete."""
    partial = path.with_name(f".{path.name}.partial")
    partial.write_bytes(data)
    partial.replace(path)


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1; got {text}")
    return value


def _band(text: str) -> float:
    value = float(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(
            f"a glow band must be a number of degrees > 0; got {text}"
        )
    return value


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--yoshida", type=Path, default=None, help="a built Yoshida set (default: the cache's)"
    )
    parser.add_argument(
        "--spencer", type=Path, default=None, help="a built Spencer set (default: the cache's)"
    )
    parser.add_argument("--out", type=Path, default=Path("out/observers"))
    parser.add_argument(
        "--fit-studies", type=_positive, default=300, help="studies per evaluation"
    )
    parser.add_argument("--studies", type=_positive, default=2000, help="studies in the report")
    parser.add_argument(
        "--similarity-studies",
        type=_positive,
        default=200,
        help="studies whose Figure 6 similarity groups are counted",
    )
    parser.add_argument(
        "--spencer-studies",
        type=_positive,
        default=200,
        help="simulated Spencer studies per block shift in the report",
    )
    parser.add_argument(
        "--glow-bands",
        type=_band,
        nargs="+",
        default=list(GLOW_BANDS_DEG),
        help="the grid of glow bands (deg) the fit tries",
    )
    parser.add_argument(
        "--max-evaluations",
        type=_positive,
        default=800,
        help="Nelder-Mead iterations per start and band",
    )
    parser.add_argument("--seed", type=int, default=2008)
    parser.add_argument(
        "--no-fit", action="store_true", help="report the module's defaults without fitting"
    )
    args = parser.parse_args(argv)
    started = time.time()
    yoshida_dir = _stimuli(args.yoshida, "yoshida2008")
    spencer_dir = _stimuli(args.spencer, "spencer1995")
    if args.no_fit:
        defaults, noise = BrightnessModel(), ObserverNoise()
        theta = {
            k: getattr(defaults, k) if hasattr(defaults, k) else getattr(noise, k) for k in FITTED
        }
        theta["glow_band_deg"] = defaults.glow_band_deg
        info: dict = {}
    else:
        print(
            f"fitting the glow band and {', '.join(FITTED)} "
            f"({args.fit_studies} simulated studies per evaluation) ...",
            flush=True,
        )
        theta, info = fit(
            yoshida_dir,
            spencer_dir,
            args.fit_studies,
            args.seed,
            bands=tuple(args.glow_bands),
            max_evaluations=args.max_evaluations,
        )
    print("looking at the images with the fitted glow band ...", flush=True)
    model = BrightnessModel(glow_band_deg=theta["glow_band_deg"])
    yoshida = look_at_yoshida(yoshida_dir, model)
    spencer = look_at_spencer(spencer_dir, model)
    criteria = fit_table1(yoshida, _model(theta))
    print("reporting with fresh seeds ...", flush=True)
    summary = report(
        yoshida,
        spencer,
        theta,
        criteria,
        args.studies,
        args.seed + 1000,
        similarity_studies=args.similarity_studies,
        spencer_studies=args.spencer_studies,
    )
    summary["fit"] = info
    summary["seconds"] = time.time() - started
    args.out.mkdir(parents=True, exist_ok=True)
    _write(args.out / "fit.json", json.dumps(summary, indent=1, default=float).encode())
    text = markdown(summary, yoshida)
    _write(args.out / "report.md", text.encode())
    figures(args.out, summary, yoshida)
    print(
        json.dumps(
            {"theta": theta, "criteria": criteria, "block_sd": summary["block_sd"]}, indent=1
        )
    )
    print(text)
    print(f"done in {summary['seconds']:.0f} s; wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
