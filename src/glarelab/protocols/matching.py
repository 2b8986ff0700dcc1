"""Matching by adjustment (Yoshida et al. 2008): the protocol's keys, rules and CSV columns.

A reference image shows a disk with glare (one per glare method and level); glare-free target
disks beside it are adjusted until they look slightly darker and slightly brighter than the
reference (``settings = "bounds"``, Yoshida §4; the match is their mean) or as bright
(``"single"``). Any number of glare methods, each a registered glare model with its
parameters, labels and levels; a background (procedural sky, uniform field, lamp scene or a
linear EXR); optional yes/no questions after each trial, each with the CSV column it fills;
follow-up analyses named by level positions.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.protocols.columns import COMMON, Column
from glarelab.protocols.common import (
    BREAK_EVERY,
    DISPLAY,
    INSTRUCTIONS,
    METHOD,
    VIEWING,
    check_background,
    check_display,
    check_methods,
    display_pixel_deg,
)
from glarelab.protocols.keys import Key, Schema, Tables

if TYPE_CHECKING:
    from glarelab.protocols.core import Protocol

__all__ = ["SCHEMA", "SESSION_ORDER", "check", "columns", "reference_name"]

QUESTION: Schema = {
    "column": Key(str, "the CSV column of the answers (true/false)", token=True),
    "text": Key(str, "the question as shown"),
    "simulated_by": Key(
        str,
        "what a simulated observer answers it from: the reference's glow, its bright ring, "
        "the disks' sizes being the same, or nothing (a coin flip)",
        choices=("glow", "ring", "same_size", "none"),
        default="none",
    ),
}
FOLLOWUP: Schema = {
    "name": Key(str, "the follow-up analysis's name in the report"),
    "levels": Key(
        list,
        "level positions (1 = first label) it is run on",
        item=int,
        length=(2, 26),
        low=1,
        unique=True,
    ),
}
SESSION_ORDER = ("trial_order",)
"""The sidecar fields in which a session records its participant's order: ``trial_order``, the
trials as ``block:method:level`` (seeded per participant); its ``counterbalance`` is null."""

SCHEMA: Schema = {
    "display": DISPLAY,
    "viewing": VIEWING,
    "stimulus": {
        "size_deg": Key(float, "side of the square image", unit="deg", low=0.1, high=60.0),
        "disk_deg": Key(float, "disk diameter", unit="deg", low=0.01, high=10.0),
        "supersample": Key(
            int,
            "render at this multiple of the display resolution, then box-filter",
            low=1,
            high=8,
        ),
        "target_start_cd_m2": Key(
            list,
            "start luminance of the target disks (darker and brighter, or the one target)",
            unit="cd/m²",
            item=float,
            length=(1, 2),
            low=0.0,
            high=1e5,
        ),
        "gap_deg": Key(float, "gap between reference and targets", unit="deg", low=0.0, high=30.0),
    },
    "background": Key(
        dict, "the background: kind = 'sky', 'uniform', 'lamp' or 'exr' and its keys"
    ),
    "glare": {
        "l_dmax_cd_m2": Key(
            float,
            "the 'typical display' maximum glare is added above (Yoshida eq. 1)",
            unit="cd/m²",
            low=1.0,
            high=1e5,
        ),
        "methods": Tables(METHOD, "glare methods, each a model with its levels", (1, 12)),
    },
    "trials": {
        "settings": Key(
            str,
            "'bounds': a slightly darker and a slightly brighter target (the match is their "
            "mean); 'single': one target set to look as bright",
            choices=("bounds", "single"),
            default="bounds",
        ),
        "training_trials": Key(int, "training trials before the main block", low=0, high=100),
        "order": Key(str, "order of the references per participant", choices=("random", "fixed")),
        "coarse_step_cd_m2": Key(
            float, "coarse adjustment step", unit="cd/m²", low=0.01, high=1000.0
        ),
        "fine_step_cd_m2": Key(
            float, "fine adjustment step", unit="cd/m²", low=0.001, high=1000.0
        ),
        "break_every": BREAK_EVERY,
    },
    "instructions": INSTRUCTIONS,
    "questionnaire": {
        "questions": Tables(QUESTION, "yes/no questions after each trial", (0, 20), default=[]),
    },
    "analysis": {
        "followups": Tables(
            FOLLOWUP,
            "methods × levels ANOVAs on subsets of the levels (Yoshida: {A, B, C}, {D, E, F})",
            (0, 10),
            default=[],
        ),
        "compare_methods_at": Key(
            list,
            "level positions where the methods are compared by t-tests (Yoshida: D, E, F)",
            item=int,
            length=(0, 26),
            low=1,
            default=[],
            unique=True,
        ),
        "quote_welch_tests": Key(
            bool,
            "also quote the methods' comparisons as Yoshida et al. 2008 §5 print them (Welch's "
            "unpaired one-sided t, uncorrected), labelled as the paper's; conclusions follow the "
            "paired, Holm-corrected tests either way",
            default=False,
        ),
    },
    "observer": Key(
        dict,
        "simulated observers' parameters (glarelab.observers); empty: the fitted defaults",
        default={},
    ),
}


def reference_name(method: str, label: str) -> str:
    """The stimulus-set image of a method's level (the contract between set and session).

    Parameters
    ----------
    method
        The glare method's ``name``.
    label
        The level's label (``labels`` of the method).

    Returns
    -------
    str
        The image's name in the set, ``reference_METHOD_LABEL``.

    Examples
    --------
    >>> reference_name("yoshida", "A")
    'reference_yoshida_A'
    """
    return f"reference_{method}_{label}"


MAX_RENDER_PX = 16384  # a side rendered (with supersampling) beyond this needs > 20 GB
# the disk is drawn as the render's pixels whose centres lie within its radius: their light
# must be the disk's (π r² × its luminance) to within this fraction, its effective diameter
# within 2.5 % (a disk of a few pixels is not: 0.85 px across holds 1.78 × its light, 0.2 px
# none). Every disk of 8 display pixels or more at supersample 2 is within it; at 1 % a
# fifth of the disks of 12-20 px (0.3° on a lab's 1080p monitor: 2.4 %) would be refused
DISK_LIGHT_TOLERANCE = 0.05


def disk_light_ratio(
    disk_deg: float, size_deg: float, pixel_deg: float, supersample: int
) -> float:
    """The light of the disk as :func:`glarelab.stimuli.matching.build_matching` draws it,
    as a multiple of the disk's own (``π (disk_deg / 2)²`` times its luminance).

    Parameters
    ----------
    disk_deg
        The disk's diameter, degrees.
    size_deg
        The image's side, degrees (an odd number of display pixels, the disk on the middle
        one).
    pixel_deg
        A display pixel, degrees.
    supersample
        Render pixels per display pixel along each axis.

    Returns
    -------
    float
        The render pixels whose centres lie within the radius, times their area, over the
        disk's area; 1 for a disk drawn exactly.

    Examples
    --------
    >>> round(disk_light_ratio(0.3, 3.2, 0.01182, 2), 4)
    0.9962
    >>> round(disk_light_ratio(0.01, 3.2, 0.01182, 2), 2)
    1.78
    """
    sides = round(size_deg / pixel_deg)
    n = (sides + 1 - sides % 2) * supersample
    fine = pixel_deg / supersample
    radius = disk_deg / 2.0
    centre = (n - 1) / 2.0
    count = 0
    for row in range(n):
        y = (row - centre) * fine
        if abs(y) > radius:
            continue
        half = math.sqrt(radius * radius - y * y) / fine  # in render pixels
        low, high = max(0, math.ceil(centre - half)), min(n - 1, math.floor(centre + half))
        count += max(0, high - low + 1)
    return count * fine * fine / (math.pi * radius * radius)


def _check_layout(p: dict, problems: list[str]) -> None:
    """The reference and its targets, side by side, must fit the display's pixels; the
    supersampled render must fit in memory."""
    display, s = p["display"], p["stimulus"]
    width_px, height_px = display["resolution_px"]
    try:
        deg = display_pixel_deg(display, p["viewing"]["distance_m"])
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        return  # the display's own problems are reported by check_display
    side = s["size_deg"] / deg
    width = (3 * s["size_deg"] + 2 * s["gap_deg"]) / deg
    if width > width_px or side > height_px:
        problems.append(
            f"stimulus.size_deg = {s['size_deg']!r} with gap_deg = {s['gap_deg']!r}: the three "
            f"images take {width:.0f} × {side:.0f} px at viewing.distance_m = "
            f"{p['viewing']['distance_m']!r} ({deg:.4g}°/px), more than the display's "
            f"{width_px} × {height_px}"
        )
    if side * s["supersample"] > MAX_RENDER_PX:
        problems.append(
            f"stimulus.size_deg = {s['size_deg']!r} at supersample = {s['supersample']!r}: "
            f"{side * s['supersample']:.0f} px a side to render, above {MAX_RENDER_PX}"
        )
        return
    if s["disk_deg"] >= s["size_deg"]:
        return  # named by the caller
    ratio = disk_light_ratio(s["disk_deg"], s["size_deg"], deg, s["supersample"])
    if abs(ratio - 1.0) > DISK_LIGHT_TOLERANCE:
        problems.append(
            f"stimulus.disk_deg = {s['disk_deg']!r}: {s['disk_deg'] / deg:.2f} display pixels "
            f"across at {deg:.4g}°/px, so drawn in pixels (supersample = "
            f"{s['supersample']!r}) the disk holds {ratio:.3f} × its light (allowed: within "
            f"{DISK_LIGHT_TOLERANCE:.0%}); give a larger disk_deg, a larger supersample or a "
            "display of smaller pixels"
        )


def check(p: dict, problems: list[str], folder: Path | None) -> None:
    """Rules between keys: geometry, display limits, methods, questions, analyses.

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
    display = p["display"]
    check_display(display, problems)
    s, g = p["stimulus"], p["glare"]
    maximum = display["max_cd_m2"]
    if g["l_dmax_cd_m2"] > maximum:
        problems.append(
            f"glare.l_dmax_cd_m2 = {g['l_dmax_cd_m2']!r}: above what the display shows "
            f"(display.max_cd_m2 = {maximum!r})"
        )
    starts = s["target_start_cd_m2"]
    expected = 2 if p["trials"]["settings"] == "bounds" else 1
    if len(starts) != expected:
        problems.append(
            f"stimulus.target_start_cd_m2 has {len(starts)} entries: trials.settings = "
            f"{p['trials']['settings']!r} has {expected} target(s)"
        )
    for i, start in enumerate(starts):
        if start > maximum:
            problems.append(
                f"stimulus.target_start_cd_m2[{i}] = {start!r}: above what the display "
                f"shows (display.max_cd_m2 = {maximum!r})"
            )
        elif start < display["black_cd_m2"]:
            problems.append(
                f"stimulus.target_start_cd_m2[{i}] = {start!r}: below what the display "
                f"shows (display.black_cd_m2 = {display['black_cd_m2']!r}); must be in "
                f"[{display['black_cd_m2']:g}, {maximum:g}] cd/m²"
            )
    if len(starts) == 2 and starts[0] >= starts[1]:
        problems.append(
            f"stimulus.target_start_cd_m2 = {starts!r}: the darker target must start below "
            "the brighter one"
        )
    if s["disk_deg"] >= s["size_deg"]:
        problems.append("stimulus.disk_deg: must be smaller than stimulus.size_deg")
    _check_layout(p, problems)
    background = check_background(
        p["background"], "background", problems, folder, display_max_cd_m2=maximum
    )
    if background is not None:
        p["background"] = background
        if background["kind"] == "sky" and background["mean_cd_m2"] > g["l_dmax_cd_m2"]:
            problems.append(
                f"background.mean_cd_m2 = {background['mean_cd_m2']!r}: above "
                f"glare.l_dmax_cd_m2 = {g['l_dmax_cd_m2']!r}, so the sky itself would glare"
            )
    methods = g["methods"] or []
    check_methods(methods, "glare.methods", problems)
    counts = {len(m["labels"]) for m in methods if m.get("labels")}
    if len(counts) > 1:
        problems.append(
            "glare.methods: every method needs the same number of levels (the level positions "
            f"are one factor of the analysis); found {sorted(counts)}"
        )
    t = p["trials"]
    if t["fine_step_cd_m2"] > t["coarse_step_cd_m2"]:
        problems.append("trials.fine_step_cd_m2: must not exceed trials.coarse_step_cd_m2")
    questions = p["questionnaire"]["questions"] or []
    # every question writes two columns (its answer and its response time), so a question
    # named like another's time column would repeat a header name: compared ignoring case, as
    # a spreadsheet or a case-insensitive reader would
    taken = {c.name.casefold() for c in COMMON + _fixed_columns(p)}  # the CSV's own columns
    for i, question in enumerate(questions):
        column = question.get("column")
        if not isinstance(column, str):
            continue  # the question's own check names it
        own = (column.casefold(), f"{column}_time_s".casefold())
        clash = [name for name in own if name in taken]
        if clash:
            problems.append(
                f"questionnaire.questions[{i}].column = {column!r}: already a column of the "
                f"session CSV ({clash[0]!r}, counting each question's '<column>_time_s'); "
                "each question needs columns of its own"
            )
        taken.update(own)
    n_levels = max(counts) if counts else 0
    a = p["analysis"]
    names = [followup.get("name") for followup in a["followups"] or []]
    for name in sorted({n for n in names if names.count(n) > 1}, key=str):
        problems.append(f"analysis.followups: the name {name!r} is used twice; must be unique")
    for i, followup in enumerate(a["followups"] or []):
        for level in followup.get("levels") or []:
            if level > n_levels:
                problems.append(
                    f"analysis.followups[{i}].levels: {level} is beyond the {n_levels} levels"
                )
    for level in a["compare_methods_at"] or []:
        if level > n_levels:
            problems.append(
                f"analysis.compare_methods_at: {level} is beyond the {n_levels} levels"
            )
    if a["compare_methods_at"] and len(methods) < 2:
        problems.append("analysis.compare_methods_at: needs at least two glare methods")
    if a.get("quote_welch_tests") and not a["compare_methods_at"]:
        problems.append(
            "analysis.quote_welch_tests = true without analysis.compare_methods_at: it quotes "
            "the methods' comparisons, and with none to quote it would be ignored"
        )


def _fixed_columns(p: dict) -> tuple[Column, ...]:
    methods = p["glare"]["methods"] or []
    labels = tuple(dict.fromkeys(label for m in methods for label in (m.get("labels") or [])))
    levels = max((len(m.get("labels") or []) for m in methods), default=1)
    bounds = p["trials"]["settings"] == "bounds"
    settings = (
        (
            Column(
                "darker_cd_m2",
                float,
                "setting of the left, 'slightly darker' target",
                unit="cd/m²",
                low=0.0,
            ),
            Column(
                "brighter_cd_m2",
                float,
                "setting of the right, 'slightly brighter' target",
                unit="cd/m²",
                low=0.0,
            ),
        )
        if bounds
        else ()
    )
    return (
        Column(
            "method",
            str,
            "glare method of the reference",
            choices=tuple(m["name"] for m in methods),
        ),
        Column("level", str, "level label of the reference", choices=labels or None),
        Column(
            "level_index",
            int,
            "level position, the ordinal scale the methods share",
            low=1,
            high=levels,
        ),
        Column(
            "l_disk_cd_m2", float, "input disk luminance of the reference", unit="cd/m²", low=0.0
        ),
        *settings,
        Column(
            "match_cd_m2",
            float,
            "the perceived luminance: the mean of the two settings"
            if bounds
            else "the perceived luminance: the target's setting",
            unit="cd/m²",
            low=0.0,
        ),
        Column("adjustments", int, "key presses that changed a target", low=0),
    )


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
    asked = p["questionnaire"]["questions"] or []
    answers = tuple(Column(q["column"], bool, q["text"]) for q in asked)
    times = tuple(
        Column(
            f"{q['column']}_time_s",
            float,
            f"response time of {q['column']}: from the key press that brought up the question "
            "(the Enter confirming the settings, or the previous question's answer) to the Y "
            "or N key",
            unit="s",
            low=0.0,
            since="0.4",
        )
        for q in asked
    )
    questions = answers + times
    return _fixed_columns(p) + questions
