"""Study protocols: TOML files that say everything a study needs, validated on load.

A protocol names the display, the viewing geometry, the stimulus, the glare model and its
levels, the trial structure, timing, instructions and questionnaire. :func:`load_protocol`
checks every key against the study's schema: a missing key, a value of the wrong type or out
of range, and an unknown key (a typo must not fall back to a default) are all reported at once,
each with its key, value and what is allowed.

The schemas below are the protocol file format's reference: every key with its unit, default
and allowed range (``glarelab protocol keys`` prints them).
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = [
    "SCHEMAS",
    "Key",
    "Protocol",
    "ProtocolError",
    "describe_schema",
    "load_protocol",
    "parse_protocol",
    "pixel_deg",
]


class ProtocolError(ValueError):
    """A protocol file that does not validate; ``problems`` lists every finding."""

    def __init__(self, source: str, problems: list[str]):
        self.source = source
        self.problems = problems
        lines = "\n".join(f"  - {p}" for p in problems)
        super().__init__(f"{source}: {len(problems)} problem(s) in the protocol:\n{lines}")


@dataclass(frozen=True)
class Key:
    """One key of a protocol schema.

    ``kind`` is ``float``, ``int``, ``str``, ``bool`` or ``list``; lists give ``item`` (the kind
    of their elements) and optionally ``length``. Numbers may have ``low``/``high`` bounds
    (inclusive); strings and numbers may have ``choices``. A key with ``default`` is optional.
    """

    kind: type
    doc: str
    unit: str = ""
    low: float | None = None
    high: float | None = None
    choices: tuple | None = None
    default: Any = ...
    item: type | None = None
    length: int | tuple[int, int] | None = None

    @property
    def required(self) -> bool:
        return self.default is ...

    def allowed(self) -> str:
        parts = []
        if self.kind is list:
            what = f"a list of {self.item.__name__}" if self.item else "a list"
            if isinstance(self.length, int):
                what += f" of length {self.length}"
            elif self.length:
                what += f" of length {self.length[0]}-{self.length[1]}"
            parts.append(what)
        else:
            parts.append(self.kind.__name__)
        if self.choices:
            parts.append("one of " + ", ".join(repr(c) for c in self.choices))
        if self.low is not None or self.high is not None:
            low = "-inf" if self.low is None else f"{self.low:g}"
            high = "inf" if self.high is None else f"{self.high:g}"
            parts.append(f"in [{low}, {high}]{' ' + self.unit if self.unit else ''}")
        return ", ".join(parts)


Schema = Mapping[str, "Key | Schema"]


def _check_scalar(value: Any, kind: type, key: Key, path: str, problems: list[str]) -> Any:
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            problems.append(f"{path} = {value!r}: must be a number ({key.allowed()})")
            return None
        value = float(value)
        if not math.isfinite(value):
            problems.append(f"{path} = {value!r}: must be finite ({key.allowed()})")
            return None
    elif kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            problems.append(f"{path} = {value!r}: must be an integer ({key.allowed()})")
            return None
    elif kind is bool:
        if not isinstance(value, bool):
            problems.append(f"{path} = {value!r}: must be true or false")
            return None
    elif kind is str:
        if not isinstance(value, str):
            problems.append(f"{path} = {value!r}: must be a string ({key.allowed()})")
            return None
    if key.choices is not None and value not in key.choices:
        problems.append(f"{path} = {value!r}: must be {key.allowed()}")
        return None
    if kind in (int, float):
        if (key.low is not None and value < key.low) or (
            key.high is not None and value > key.high
        ):
            problems.append(f"{path} = {value!r}: must be {key.allowed()}")
            return None
    return value


def _check_key(value: Any, key: Key, path: str, problems: list[str]) -> Any:
    if key.kind is not list:
        return _check_scalar(value, key.kind, key, path, problems)
    if not isinstance(value, list):
        problems.append(f"{path} = {value!r}: must be {key.allowed()}")
        return None
    n = len(value)
    if isinstance(key.length, int) and n != key.length:
        problems.append(f"{path} has {n} entries: must be {key.allowed()}")
        return None
    if isinstance(key.length, tuple) and not key.length[0] <= n <= key.length[1]:
        problems.append(f"{path} has {n} entries: must be {key.allowed()}")
        return None
    items = [
        _check_scalar(v, key.item, key, f"{path}[{i}]", problems) if key.item else v
        for i, v in enumerate(value)
    ]
    return None if any(i is None for i in items) and key.item else items


def _validate(data: Mapping[str, Any], schema: Schema, path: str, problems: list[str]) -> dict:
    result: dict[str, Any] = {}
    for name in data:
        if name not in schema:
            where = f"{path}.{name}" if path else name
            known = ", ".join(sorted(schema))
            problems.append(f"{where}: unknown key (known here: {known})")
    for name, spec in schema.items():
        where = f"{path}.{name}" if path else name
        if isinstance(spec, Mapping):
            table = data.get(name)
            if table is None:
                problems.append(f"[{where}]: missing table")
                continue
            if not isinstance(table, Mapping):
                problems.append(f"{where} = {table!r}: must be a table [{where}]")
                continue
            result[name] = _validate(table, spec, where, problems)
        elif name in data:
            result[name] = _check_key(data[name], spec, where, problems)
        elif spec.required:
            problems.append(f"{where}: missing ({spec.doc}; {spec.allowed()})")
        else:
            result[name] = spec.default
    return result


# --- the schemas -----------------------------------------------------------------------

DISPLAY: Schema = {
    "name": Key(str, "display model, for the record"),
    "resolution_px": Key(list, "pixels (width, height)", item=int, length=2, low=1, high=16384),
    "diagonal_in": Key(float, "visible diagonal", unit="in", low=1.0, high=400.0, default=None),
    "pixel_pitch_mm": Key(float, "pixel pitch", unit="mm", low=0.01, high=10.0, default=None),
    "max_cd_m2": Key(float, "maximum luminance", unit="cd/m²", low=1.0, high=1e5),
    "black_cd_m2": Key(float, "black level", unit="cd/m²", low=0.0, high=100.0, default=0.0),
    "bit_depth": Key(int, "bits per channel of the display", choices=(8, 10, 12, 16)),
    "refresh_hz": Key(
        float, "nominal refresh rate", unit="Hz", low=20.0, high=1000.0, default=60.0
    ),
    "white_tolerance": Key(
        float,
        "largest relative difference between a session's calibration white and max_cd_m2",
        low=0.0,
        high=1.0,
        default=0.1,
    ),
}
VIEWING: Schema = {
    "distance_m": Key(float, "eye-screen distance", unit="m", low=0.1, high=20.0),
    "room_lux": Key(float, "room illumination at the eye", unit="lx", low=0.0, high=1e5),
}
LEVEL_LABELS = Key(list, "level labels", item=str, length=(1, 26))
LEVELS_CD_M2 = Key(
    list,
    "input disk luminances L_disk",
    unit="cd/m²",
    item=float,
    length=(1, 26),
    low=0.0,
    high=1e9,
)
BREAK_EVERY = Key(
    int,
    "a break screen after every this many trials (0: no breaks)",
    low=0,
    high=100_000,
    default=0,
)
OBSERVER_SD = Key(float, "between-observer SD of the boost gain", low=0.0, high=2.0)
REGIME = Key(str, "Vos PSF regime", choices=("photopic", "mesopic", "scotopic"))
INSTRUCTIONS: Schema = {"text": Key(str, "written instruction")}
STUDY: Schema = {
    "name": Key(str, "study", choices=("yoshida2008", "spencer1995", "luidolt2020")),
    "title": Key(str, "title for reports"),
    "seed": Key(int, "seed of every random choice in stimuli and trial orders", low=0),
}

YOSHIDA2008: Schema = {
    "study": STUDY,
    "display": DISPLAY,
    "viewing": VIEWING,
    "stimulus": {
        "background_deg": Key(
            float, "side of the square sky background", unit="deg", low=0.1, high=60.0
        ),
        "disk_deg": Key(float, "disk diameter", unit="deg", low=0.01, high=10.0),
        "background_mean_cd_m2": Key(
            float, "mean luminance of the sky", unit="cd/m²", low=0.0, high=1e4
        ),
        "cloud_min_deg": Key(float, "smallest cloud structure", unit="deg", low=0.001, high=60.0),
        "cloud_max_deg": Key(float, "largest cloud structure", unit="deg", low=0.001, high=600.0),
        "cloud_spectrum_slope": Key(
            float, "amplitude spectrum ∝ f^-slope between the cloud sizes", low=0.0, high=4.0
        ),
        "cloud_contrast": Key(float, "RMS contrast of the sky (SD / mean)", low=0.0, high=1.0),
        "supersample": Key(
            int,
            "render at this multiple of the display resolution, then box-filter",
            low=1,
            high=8,
        ),
        "target_start_cd_m2": Key(
            list,
            "start luminance of the darker and brighter target disks",
            unit="cd/m²",
            item=float,
            length=2,
            low=0.0,
            high=1e5,
        ),
        "target_gap_deg": Key(
            float, "gap between reference and target images", unit="deg", low=0.0, high=30.0
        ),
    },
    "glare": {
        "l_dmax_cd_m2": Key(
            float,
            "the 'typical display' maximum glare is added above",
            unit="cd/m²",
            low=1.0,
            high=1e5,
        ),
        "gaussian": {
            "sigma_deg": Key(
                float, "Gaussian σ (Yoshida eq. 2)", unit="deg", low=0.001, high=10.0
            ),
            "labels": LEVEL_LABELS,
            "levels_cd_m2": LEVELS_CD_M2,
        },
        "vos": {
            "regime": REGIME,
            "labels": LEVEL_LABELS,
            "levels_cd_m2": LEVELS_CD_M2,
        },
    },
    "trials": {
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
    "instructions": {"text": Key(str, "written instruction shown before training")},
    "observer": {
        "boost_gaussian": Key(
            float, "simulated observers: largest brightness boost, Method I", low=0.0, high=5.0
        ),
        "boost_vos": Key(
            float, "simulated observers: largest brightness boost, Method II", low=0.0, high=5.0
        ),
        "saturation": Key(
            float,
            "relative excess (L_disk - L_dmax) / L_dmax at which the boost reaches 63 %",
            low=0.001,
            high=1000.0,
        ),
        "margin": Key(
            float, "'slightly but visibly' darker/brighter, as a fraction", low=0.0, high=1.0
        ),
        "observer_sd": OBSERVER_SD,
        "setting_sd": Key(
            float, "within-observer SD of each setting, as a fraction", low=0.0, high=1.0
        ),
    },
    "questionnaire": {
        "questions": Key(
            list,
            "yes/no questions after each trial (Yoshida Table 1): none, or three, one per CSV "
            "column q1_glow, q2_ring, q3_same_size",
            item=str,
            length=(0, 3),
        ),
    },
}

SPENCER1995: Schema = {
    "study": STUDY,
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
        "context": Key(list, "context conditions", item=str, length=(1, 2), choices=None),
    },
    "glare": {
        "regime": REGIME,
        "flare_lines": Key(bool, "ciliary-corona flare lines (Spencer §3.2)"),
        "peak_fraction": Key(
            float,
            "peak of the glare image as a fraction of the display maximum",
            low=0.01,
            high=1.0,
        ),
        "strengths": Key(
            list,
            "source excess over the peak, one per glare level",
            item=float,
            length=(1, 50),
            low=0.0,
            high=1e9,
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
        "break_every": BREAK_EVERY,
    },
    "instructions": INSTRUCTIONS,
    "observer": {
        "boost": Key(
            float,
            "simulated observers: largest brightness boost of the glare image",
            low=0.0,
            high=5.0,
        ),
        "saturation": Key(
            float, "glare strength at which the boost reaches 63 %", low=0.001, high=1e6
        ),
        "observer_sd": OBSERVER_SD,
        "noise_sd": Key(
            float, "SD of the comparison noise, fraction of the maximum", low=0.0, high=1.0
        ),
        "neither_band": Key(
            float,
            "differences below this (fraction of max) are answered 'neither'",
            low=0.0,
            high=1.0,
        ),
        "context_gain": Key(float, "boost multiplier in the lamp context", low=0.0, high=5.0),
    },
}

LUIDOLT2020: Schema = {
    "study": STUDY,
    "instructions": INSTRUCTIONS,
    "questionnaire": {
        "scale_min": Key(int, "lowest rating (a number key; the CSV holds 1-7)", low=1, high=6),
        "scale_max": Key(int, "highest rating (a number key; the CSV holds 1-7)", low=2, high=7),
        "anchors": Key(list, "labels of the lowest and highest rating", item=str, length=2),
        "categories": Key(list, "category names", item=str, length=(1, 30)),
        "prompts": Key(list, "one question per category", item=str, length=(1, 30)),
        "comments": Key(bool, "ask for an optional comment per category"),
    },
    "observer": {
        "means": Key(
            list,
            "simulated observers: mean rating per category",
            item=float,
            length=(1, 30),
            low=1.0,
            high=100.0,
        ),
        "sd": Key(float, "SD of a rating", low=0.0, high=10.0),
    },
}

SCHEMAS: dict[str, Schema] = {
    "yoshida2008": YOSHIDA2008,
    "spencer1995": SPENCER1995,
    "luidolt2020": LUIDOLT2020,
}


def _cross_checks(study: str, p: dict, problems: list[str]) -> None:
    """Rules between keys: geometry, display limits, level lists."""
    display = p.get("display")
    if display:
        if (display["diagonal_in"] is None) == (display["pixel_pitch_mm"] is None):
            problems.append("display: give exactly one of diagonal_in and pixel_pitch_mm")
        if display["black_cd_m2"] >= display["max_cd_m2"]:
            problems.append(
                f"display.black_cd_m2 = {display['black_cd_m2']!r}: must be below "
                f"display.max_cd_m2 = {display['max_cd_m2']!r}"
            )
    if study == "yoshida2008":
        s, g = p["stimulus"], p["glare"]
        maximum = display["max_cd_m2"] if display else math.inf
        if g["l_dmax_cd_m2"] > maximum:
            problems.append(
                f"glare.l_dmax_cd_m2 = {g['l_dmax_cd_m2']!r}: above what the display shows "
                f"(display.max_cd_m2 = {maximum!r})"
            )
        for i, start in enumerate(s["target_start_cd_m2"] or []):
            if start > maximum:
                problems.append(
                    f"stimulus.target_start_cd_m2[{i}] = {start!r}: above what the display "
                    f"shows (display.max_cd_m2 = {maximum!r})"
                )
        if (
            s["background_mean_cd_m2"] is not None
            and s["background_mean_cd_m2"] > g["l_dmax_cd_m2"]
        ):
            problems.append(
                f"stimulus.background_mean_cd_m2 = {s['background_mean_cd_m2']!r}: above "
                f"glare.l_dmax_cd_m2 = {g['l_dmax_cd_m2']!r}, so the sky itself would glare"
            )
        if (
            s["disk_deg"] is not None
            and s["background_deg"] is not None
            and s["disk_deg"] >= s["background_deg"]
        ):
            problems.append("stimulus.disk_deg: must be smaller than stimulus.background_deg")
        if (
            s["cloud_min_deg"] is not None
            and s["cloud_max_deg"] is not None
            and s["cloud_min_deg"] >= s["cloud_max_deg"]
        ):
            problems.append("stimulus.cloud_min_deg: must be below stimulus.cloud_max_deg")
        for method in ("gaussian", "vos"):
            labels, levels = g[method]["labels"], g[method]["levels_cd_m2"]
            if labels is not None and levels is not None and len(labels) != len(levels):
                problems.append(
                    f"glare.{method}: {len(labels)} labels for {len(levels)} levels_cd_m2"
                )
        questions = p["questionnaire"]["questions"]
        if questions is not None and len(questions) not in (0, 3):
            problems.append(
                f"questionnaire.questions has {len(questions)} entries: must be none or three "
                "(the session CSV has one column per question: q1_glow, q2_ring, q3_same_size)"
            )
        t = p["trials"]
        if (
            t["fine_step_cd_m2"] is not None
            and t["coarse_step_cd_m2"] is not None
            and t["fine_step_cd_m2"] > t["coarse_step_cd_m2"]
        ):
            problems.append("trials.fine_step_cd_m2: must not exceed trials.coarse_step_cd_m2")
    elif study == "spencer1995":
        s = p["stimulus"]
        if (
            s["annulus_outer_px"] is not None
            and s["disc_radius_px"] is not None
            and s["annulus_outer_px"] <= s["disc_radius_px"]
        ):
            problems.append("stimulus.annulus_outer_px: must exceed stimulus.disc_radius_px")
        for i, c in enumerate(s["context"] or []):
            if c not in ("none", "lamp"):
                problems.append(f"stimulus.context[{i}] = {c!r}: must be 'none' or 'lamp'")
        if display and s["window_px"] is not None:
            width, height = display["resolution_px"] or (math.inf, math.inf)
            if 2 * s["window_px"] + (s["window_gap_px"] or 0) > width or s["window_px"] > height:
                problems.append(
                    "stimulus.window_px: two windows and their gap do not fit the display"
                )
    elif study == "luidolt2020":
        q = p["questionnaire"]
        if (
            q["scale_min"] is not None
            and q["scale_max"] is not None
            and q["scale_min"] >= q["scale_max"]
        ):
            problems.append("questionnaire.scale_min: must be below questionnaire.scale_max")
        if (
            q["categories"] is not None
            and q["prompts"] is not None
            and len(q["categories"]) != len(q["prompts"])
        ):
            problems.append("questionnaire.prompts: one prompt per category is needed")
        means = p["observer"]["means"]
        if (
            q["categories"] is not None
            and means is not None
            and len(means) != len(q["categories"])
        ):
            problems.append(
                f"observer.means has {len(means)} entries for {len(q['categories'])} "
                "categories: one mean per category is needed"
            )


@dataclass(frozen=True)
class Protocol:
    """A validated protocol: ``data`` mirrors the file with defaults filled in."""

    study: str
    data: dict
    source: str
    sha256: str

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def seed(self) -> int:
        return self.data["study"]["seed"]


def parse_protocol(data: Mapping[str, Any], *, source: str = "<protocol>") -> Protocol:
    """Validate a protocol given as a mapping (the parsed TOML).

    Raises
    ------
    ProtocolError
        Listing every problem: unknown and missing keys, wrong types, values out of range.
    """
    study_table = data.get("study")
    study = study_table.get("name") if isinstance(study_table, Mapping) else None
    if study not in SCHEMAS:
        raise ProtocolError(
            source,
            [f"study.name = {study!r}: must be one of {', '.join(repr(s) for s in SCHEMAS)}"],
        )
    problems: list[str] = []
    validated = _validate(data, SCHEMAS[study], "", problems)
    if not problems:
        _cross_checks(study, validated, problems)
    if problems:
        raise ProtocolError(source, problems)
    canonical = json.dumps(validated, sort_keys=True, separators=(",", ":"))
    return Protocol(
        study=study,
        data=validated,
        source=source,
        sha256=hashlib.sha256(canonical.encode()).hexdigest(),
    )


def load_protocol(path: str | Path) -> Protocol:
    """Read and validate a protocol TOML file.

    Raises
    ------
    ProtocolError
        For a file that is not valid TOML or does not follow its study's schema.
    FileNotFoundError
        If there is no such file.

    Examples
    --------
    >>> p = load_protocol(Path(__file__).parents[1] / "protocols" / "yoshida2008.toml")
    >>> p.study, p["glare"]["gaussian"]["labels"][0]
    ('yoshida2008', 'A')
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no protocol file at {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as error:
        raise ProtocolError(str(path), [f"not valid TOML: {error}"]) from None
    return parse_protocol(data, source=str(path))


def pixel_deg(protocol: Protocol) -> float:
    """Visual angle of one display pixel at the viewing distance, degrees."""
    display = protocol["display"]
    width, height = display["resolution_px"]
    if display["pixel_pitch_mm"] is not None:
        pitch_mm = display["pixel_pitch_mm"]
    else:
        pitch_mm = display["diagonal_in"] * 25.4 / math.hypot(width, height)
    return math.degrees(math.atan(pitch_mm / (protocol["viewing"]["distance_m"] * 1000.0)))


def describe_schema(study: str) -> list[tuple[str, str, str, str, str]]:
    """Rows ``(key, unit, default, allowed, description)`` of a study's schema, for docs."""
    rows = []

    def walk(schema: Schema, prefix: str) -> None:
        for name, spec in schema.items():
            path = f"{prefix}.{name}" if prefix else name
            if isinstance(spec, Mapping):
                walk(spec, path)
            else:
                default = "required" if spec.required else repr(spec.default)
                rows.append((path, spec.unit, default, spec.allowed(), spec.doc))

    walk(SCHEMAS[study], "")
    return rows
