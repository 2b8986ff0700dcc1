"""A three-way forced-choice staircase (Spencer et al. 1995, §4): keys, rules and CSV columns.

Two windows flash side by side: a light source with glare (one of several glare strengths,
rendered with any registered glare model) and a comparison disc with an annulus, whose
intensity one interleaved staircase per glare strength adjusts; the answer is "left
brighter", "right brighter" or "neither". Blocks are contexts: the source on a background of
its own (uniform black, a procedural lamp scene, or a linear EXR).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from itertools import pairwise
from math import gcd, lcm
from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.protocols.columns import Column
from glarelab.protocols.common import (
    BREAK_EVERY,
    DISPLAY,
    INSTRUCTIONS,
    VIEWING,
    check_background,
    check_display,
    check_glare_model,
    repeated_names,
)
from glarelab.protocols.keys import Key, Schema, Tables

if TYPE_CHECKING:
    from glarelab.protocols.core import Protocol

__all__ = [
    "SCHEMA",
    "SESSION_ORDER",
    "Staircase",
    "answer_limit",
    "check",
    "columns",
    "comparison_terms",
    "flash_frames",
    "glare_name",
    "intensity_grid",
]

CONTEXT: Schema = {
    "name": Key(str, "the context's name in the data (a block)", token=True),
    "background": Key(dict, "the scene around the source: kind and its keys"),
}
SESSION_ORDER = ("counterbalance",)
"""The sidecar fields in which a session records its participant's order: ``counterbalance``,
0 (the protocol's order of the contexts) or 1 (reversed); its ``trial_order`` is null."""

SCHEMA: Schema = {
    "display": DISPLAY,
    "viewing": VIEWING,
    "stimulus": {
        "window_px": Key(
            int, "side of each square presentation window", unit="px", low=16, high=4096
        ),
        "window_gap_px": Key(int, "gap between the two windows", unit="px", low=0, high=4096),
        "source_radius_px": Key(
            float, "radius of the light source", unit="px", low=0.5, high=100.0
        ),
        "pixel_deg": Key(
            float,
            "visual angle of a pixel (overrides the display geometry)",
            unit="deg",
            low=0.0,
            high=1.0,
            default=0.0,
        ),
        "disc_radius_px": Key(
            float, "radius of the comparison disc", unit="px", low=0.5, high=100.0
        ),
        "annulus_outer_px": Key(
            float, "outer radius of the comparison annulus", unit="px", low=1.0, high=200.0
        ),
        "annulus_ratio": Key(float, "annulus intensity / disc intensity", low=0.0, high=1.0),
    },
    "contexts": Tables(CONTEXT, "the blocks: the source on each background", (1, 10)),
    "glare": {
        "model": Key(str, "a glare model registered in glare.GLARE_MODELS"),
        "parameters": Key(dict, "the model's parameters", default={}),
        "peak_fraction": Key(
            float,
            "peak of the glare image as a fraction of the display maximum",
            low=0.01,
            high=1.0,
        ),
        "strengths": Key(
            list,
            "source excess over the peak, one per glare level (glare_level 1 the weakest)",
            item=float,
            length=(1, 50),
            low=0.0,
            high=1e9,
            unique=True,
            ascending=True,
        ),
    },
    "trials": {
        "presentation_ms": Key(
            list,
            "presentation times",
            unit="ms",
            item=float,
            length=(1, 4),
            low=10.0,
            high=10_000.0,
            unique=True,
        ),
        "start_fraction": Key(
            float, "disc intensity the staircases start at (fraction of max)", low=0.0, high=1.0
        ),
        "step_fractions": Key(
            list,
            "staircase step sizes, coarse to fine",
            item=float,
            length=(1, 10),
            low=0.0001,
            high=1.0,
        ),
        "reversals": Key(int, "reversals per staircase", low=1, high=100),
        "neither": Key(
            str,
            "how a 'neither brighter' answer moves the staircase",
            choices=("hold", "alternate"),
        ),
        "inter_trial_ms": Key(
            float,
            "blank screen before each flash",
            unit="ms",
            low=0.0,
            high=60_000.0,
            default=500.0,
        ),
        "timing_tolerance_ms": Key(
            float,
            "largest difference between the measured flash and its frames (Spencer §4: ±10 ms)",
            unit="ms",
            low=0.0,
            high=1000.0,
            default=10.0,
        ),
        "repeat_failed_presentations": Key(
            bool,
            "a flash that dropped frames or missed its timing does not move its staircase and "
            "is shown again",
            default=True,
        ),
        "repeat_limit": Key(
            int,
            "a failed flash is shown again at most this many times in a row; then its answer "
            "counts (flagged presentation_ok = false), so a display that keeps failing cannot "
            "stall the session",
            low=0,
            high=100,
            default=3,
        ),
        "break_every": BREAK_EVERY,
    },
    "instructions": INSTRUCTIONS,
    "observer": Key(
        dict,
        "simulated observers' parameters (glarelab.observers); empty: the fitted defaults",
        default={},
    ),
}


GRID_DENOMINATOR_LIMIT = 1_000_000  # finer grids are not kept: intensities are plain floats


def intensity_grid(trials: dict) -> int | None:
    """The grid of the disc intensities a staircase can take, ``k / N`` for whole ``k`` from 0
    to ``N``: ``1 / N`` is the greatest common divisor of the start, the steps and 1 (the
    staircase is clamped to 0 and 1), so every intensity it reaches is on the grid. The
    experiment computes them as ``k / N`` (no drift in the last bits from adding steps) and
    the analysis compares them there. None where a value is not a fraction with a
    denominator of at most a million (such a grid is not kept).

    Parameters
    ----------
    trials
        The ``[trials]`` table: ``start_fraction`` and ``step_fractions``, fractions of the
        display's maximum luminance.

    Returns
    -------
    int or None
        ``N``, or None where there is no grid of at most a million steps.

    Examples
    --------
    >>> intensity_grid({"start_fraction": 1.0, "step_fractions": [0.16, 0.08, 0.04, 0.02]})
    50
    >>> intensity_grid({"start_fraction": 0.5, "step_fractions": [0.1, 0.03]})
    100
    >>> intensity_grid({"start_fraction": 1 / 3, "step_fractions": [0.1]})
    30
    >>> intensity_grid({"start_fraction": 0.123456789, "step_fractions": [0.1]}) is None
    True
    """
    values = [1.0, float(trials["start_fraction"]), *map(float, trials["step_fractions"])]
    fractions = []
    for value in values:
        fraction = Fraction(repr(value)).limit_denominator(GRID_DENOMINATOR_LIMIT)
        if abs(float(fraction) - value) > 1e-12 * max(1.0, abs(value)):
            return None
        fractions.append(fraction)
    denominator = lcm(*(f.denominator for f in fractions))
    unit = Fraction(gcd(*(int(f * denominator) for f in fractions)), denominator)
    grid = unit.denominator if unit.numerator == 1 else None
    return grid if grid is not None and grid <= GRID_DENOMINATOR_LIMIT else None


@dataclass
class Staircase:
    """One staircase on the disc intensity (fraction of the display maximum).

    Attributes
    ----------
    level
        The glare level it belongs to, from 1.
    strength
        That level's source excess over the displayed peak (``glare.strengths``).
    fraction
        The disc's intensity now, a fraction of the display maximum, 0-1.
    steps
        The step sizes, fractions of the maximum: the first until the first reversal, and so
        on; the last is kept.
    reversals_needed
        The reversals after which it is done.
    neither
        How a "neither brighter" answer moves it: ``'hold'`` or ``'alternate'``.
    grid
        ``N`` of the intensities ``k / N`` it moves on
        (:func:`glarelab.protocols.staircase.intensity_grid`); None: plain floats.
    direction
        Its last move: +1 up, -1 down, 0 not moved yet.
    reversals
        Reversals so far.
    trials
        Trials so far.
    history
        ``(response, reversal)`` of each trial.
    """

    level: int
    strength: float
    fraction: float
    steps: tuple[float, ...]
    reversals_needed: int
    neither: str
    grid: int | None = None  # intensities k / grid (glarelab.protocols.staircase.intensity_grid)
    direction: int = 0  # +1 up, -1 down, 0 not moved yet
    reversals: int = 0
    trials: int = 0
    history: list = field(default_factory=list)

    @property
    def step(self) -> float:
        return self.steps[min(self.reversals, len(self.steps) - 1)]

    @property
    def done(self) -> bool:
        return self.reversals >= self.reversals_needed or self.trials >= answer_limit(
            self.reversals_needed
        )

    def update(self, response: str) -> bool:
        """Apply a response ('glare', 'disc', 'neither'); return whether it was a reversal.

        Parameters
        ----------
        response
            ``'glare'`` (the glare image looked brighter: up), ``'disc'`` (down) or
            ``'neither'``.

        Returns
        -------
        bool
            Whether it was a reversal (a "neither" always is).

        Raises
        ------
        ValueError
            For another response.
        """
        self.trials += 1
        if response == "glare":
            move = +1
        elif response == "disc":
            move = -1
        elif response == "neither":
            move = 0 if self.neither == "hold" else (-self.direction or +1)
        else:
            raise ValueError(f"response must be 'glare', 'disc' or 'neither'; got {response!r}")
        reversal = response == "neither" or (self.direction != 0 and move == -self.direction)
        if reversal:  # as PsychoPy's StairHandler: the reversing move already takes the next step
            self.reversals += 1
        if move:
            if self.grid is None:
                self.fraction = min(max(self.fraction + move * self.step, 0.0), 1.0)
            else:  # whole steps of the grid: 0.84 stays 0.84, never 0.8400000000000001
                k = round(self.fraction * self.grid) + move * round(self.step * self.grid)
                self.fraction = min(max(k, 0), self.grid) / self.grid
            self.direction = move
        self.history.append((response, reversal))
        return reversal


def answer_limit(reversals_needed: int) -> int:
    """The answers after which a staircase ends even if it has not reversed
    ``reversals_needed`` times (an observer who never changes their answer):
    ``4 × reversals_needed + 20``, a safeguard of this suite, not Spencer et al.'s.

    Parameters
    ----------
    reversals_needed
        The reversals after which the staircase is done (``trials.reversals``).

    Returns
    -------
    int
        The most answers a staircase is given.

    Examples
    --------
    >>> answer_limit(8)
    52
    """
    return 4 * reversals_needed + 20


def flash_frames(duration_ms: float, refresh_hz: float) -> int:
    """The whole frames a flash of ``duration_ms`` takes at ``refresh_hz`` (at least one): the
    ``frames`` a staircase session records.

    Parameters
    ----------
    duration_ms
        The presentation time asked for, ms.
    refresh_hz
        The display's refresh rate, Hz, > 0.

    Returns
    -------
    int
        ``max(1, round(duration_ms · refresh_hz / 1000))``.

    Examples
    --------
    >>> flash_frames(400.0, 76.0), flash_frames(700.0, 76.0), flash_frames(1.0, 60.0)
    (30, 53, 1)
    """
    return max(1, round(duration_ms * refresh_hz / 1000.0))


def glare_name(context: str, level: int) -> str:
    """The stimulus-set image of a context's glare level (1-based).

    Parameters
    ----------
    context
        The context's name.
    level
        The glare level, from 1.

    Returns
    -------
    str
        The image's name in the set, ``glare_CONTEXT_NN``.

    Examples
    --------
    >>> glare_name("dark", 3)
    'glare_dark_03'
    """
    return f"glare_{context}_{level:02d}"


def comparison_terms(context: str, intensity_cd_m2: float, ratio: float) -> list:
    """The comparison image as a sum of set images: the scene outside the disc and annulus,
    the disc at ``intensity`` and the annulus at ``ratio × intensity``.

    Parameters
    ----------
    context
        The context's name: the scene around the disc and annulus.
    intensity_cd_m2
        The disc's luminance, cd/m² (the staircase's fraction times the display's maximum).
    ratio
        The annulus's luminance as a multiple of the disc's (``stimulus.annulus_ratio``).

    Returns
    -------
    list of tuple of (str, float)
        ``(image, weight)`` pairs: the set's images (the disc and annulus images are their
        coverage, 0-1) and the factor each is summed with, cd/m² for the disc and annulus.
    """
    return [
        (f"scene_{context}_outside", 1.0),
        ("comparison_disc", intensity_cd_m2),
        ("comparison_annulus", ratio * intensity_cd_m2),
    ]


def check(p: dict, problems: list[str], folder: Path | None) -> None:
    """Rules between keys: geometry, contexts, the glare model.

    Parameters
    ----------
    p
        The protocol's tables, each validated against the paradigm's :data:`SCHEMA` (defaults
        filled in); called only when that found no problem.
    problems
        The list each problem is appended to, one line naming the keys and their values.
    folder
        The protocol file's folder, which relative paths in it are read from; ``None``: the
        working folder.
    """
    check_display(p["display"], problems)
    steps = p["trials"]["step_fractions"] or []
    reversals = p["trials"]["reversals"]
    if len(steps) > reversals:  # step k is taken after k reversals
        problems.append(
            f"trials.step_fractions = {steps!r}: {len(steps)} steps for trials.reversals = "
            f"{reversals}; a staircase takes step k after k reversals, so "
            f"{steps[reversals:]!r} would never be used"
        )
    if p["trials"]["repeat_limit"] != 0 and not p["trials"]["repeat_failed_presentations"]:
        limit = p["trials"]["repeat_limit"]
        default = SCHEMA["trials"]["repeat_limit"].default
        if limit != default:
            problems.append(
                f"trials.repeat_limit = {limit}: failed flashes are not shown again "
                "(trials.repeat_failed_presentations = false), so it would be ignored"
            )
    if any(b >= a for a, b in pairwise(steps)):
        problems.append(
            f"trials.step_fractions = {steps!r}: must run from coarse to fine (each smaller "
            "than the one before)"
        )
    s = p["stimulus"]
    if s["annulus_outer_px"] <= s["disc_radius_px"]:
        problems.append("stimulus.annulus_outer_px: must exceed stimulus.disc_radius_px")
    half = s["window_px"] / 2
    for key in ("source_radius_px", "disc_radius_px", "annulus_outer_px"):
        if s[key] > half:
            problems.append(
                f"stimulus.{key} = {s[key]:g}: must fit its window (at most half of "
                f"stimulus.window_px = {s['window_px']}, {half:g} px); it would be cut off"
            )
    width, height = p["display"]["resolution_px"]
    if 2 * s["window_px"] + s["window_gap_px"] > width or s["window_px"] > height:
        problems.append(
            f"stimulus.window_px = {s['window_px']}, window_gap_px = {s['window_gap_px']}: two "
            f"windows and their gap ({2 * s['window_px'] + s['window_gap_px']} × "
            f"{s['window_px']} px) do not fit the display ({width} × {height} px)"
        )
    refresh_hz = p["display"]["refresh_hz"]
    frame_ms = 1000.0 / refresh_hz
    tolerance_ms = p["trials"]["timing_tolerance_ms"]
    shown_as: dict[int, float] = {}  # frames → the first duration shown as that many
    for i, shown_ms in enumerate(p["trials"]["presentation_ms"]):
        frames = round(shown_ms / frame_ms)
        where = f"trials.presentation_ms[{i}] = {shown_ms:g}"
        if frames >= 1 and frames in shown_as:
            problems.append(
                f"{where}: {frames} frames at {refresh_hz:g} Hz, as {shown_as[frames]:g} ms is: "
                "the two durations would show the same flash; make them differ by a frame "
                f"({frame_ms:.2f} ms) or more"
            )
        shown_as.setdefault(frames, shown_ms)
        if shown_ms < frame_ms:
            problems.append(
                f"{where}: shorter than one frame of the {refresh_hz:g} Hz display "
                f"({frame_ms:.2f} ms); the flash would last a whole frame"
            )
        elif abs(frames * frame_ms - shown_ms) > tolerance_ms:
            problems.append(
                f"{where}: not a whole number of {frame_ms:.2f} ms frames at "
                f"{refresh_hz:g} Hz within trials.timing_tolerance_ms = {tolerance_ms:g} "
                f"(nearest: {frames} frames, {frames * frame_ms:.2f} ms)"
            )
    contexts = p["contexts"] or []
    names = [c["name"] for c in contexts if c.get("name")]
    repeated = repeated_names(names)
    if repeated:
        problems.append(
            f"contexts: names repeat {repeated}: each must be different (ignoring case)"
        )
    for i, context in enumerate(contexts):
        background = check_background(
            context.get("background"),
            f"contexts[{i}].background",
            problems,
            folder,
            display_max_cd_m2=p["display"]["max_cd_m2"],
        )
        if background is not None:
            context["background"] = background
    g = p["glare"]
    check_glare_model(g["model"], g["parameters"], "glare", problems)


def columns(protocol: Protocol) -> tuple[Column, ...]:
    """The paradigm's CSV columns for this protocol (after the common ones).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        A loaded protocol of this paradigm.

    Returns
    -------
    tuple of glarelab.protocols.columns.Column
        The columns, in file order.
    """
    p = protocol.data if hasattr(protocol, "data") else protocol
    return (
        Column(
            "context",
            str,
            "context of the block",
            choices=tuple(c["name"] for c in p["contexts"]),
        ),
        Column(
            "glare_level",
            int,
            "glare level (the staircase), from 1",
            low=1,
            high=len(p["glare"]["strengths"]),
        ),
        Column("strength", float, "source excess over the displayed peak", low=0.0),
        Column("duration_ms", float, "presentation time asked for", unit="ms", low=0.0),
        Column("frames", int, "frames shown", low=1),
        Column("glare_side", str, "side of the glare image", choices=("left", "right")),
        Column(
            "disc_fraction",
            float,
            "comparison disc intensity, fraction of the maximum",
            low=0.0,
            high=1.0,
        ),
        Column("response", str, "which looked brighter", choices=("glare", "disc", "neither")),
        Column("reversal", bool, "this response reversed the staircase's direction"),
        Column("step_fraction", float, "step size the staircase used after this trial", low=0.0),
        Column(
            "offset_s",
            float,
            "the flip that ended the flash, on the session clock",
            unit="s",
            low=0.0,
            since="0.2",
        ),
        Column(
            "shown_ms",
            float,
            "measured presentation: offset flip minus onset flip",
            unit="ms",
            low=0.0,
            since="0.2",
        ),
        Column(
            "presentation_ok",
            bool,
            "no frame dropped and shown_ms within trials.timing_tolerance_ms of the frames asked",
            since="0.2",
        ),
        Column(
            "counted",
            bool,
            "the answer moved its staircase (false: the presentation failed and the protocol "
            "repeats such trials, trials.repeat_failed_presentations)",
            since="0.2",
        ),
    )
