"""The session data format: one CSV per session, one row per trial, and a JSON sidecar.

Defined once, here, for the experiments that write it and the analysis that reads it. This
module imports nothing of the suite and never PsychoPy.

Every CSV begins with the columns of :data:`COMMON`; each study adds its own. Types are one of
``str``, ``int``, ``float``, ``bool`` (written ``true``/``false``); an empty cell is a missing
value and is allowed only where the column says so (``optional=True``). ``since`` names the
data-format version that added a column: files written before it lack the column, and the
analysis reads them with the column missing (``counted`` as true).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["COMMON", "DATA_FORMAT", "STUDY_COLUMNS", "Column", "columns", "format_value"]

DATA_FORMAT = "0.2"  # the version of the session files written now (recorded in the sidecar)


@dataclass(frozen=True)
class Column:
    """One CSV column: name, type, unit and meaning; ``choices`` limits a string column."""

    name: str
    kind: type
    doc: str
    unit: str = ""
    optional: bool = False
    choices: tuple[str, ...] | None = None
    low: float | None = None
    high: float | None = None
    since: str = "0.1"  # the data-format version that added the column


COMMON = (
    Column("study", str, "study name", choices=("yoshida2008", "spencer1995", "luidolt2020")),
    Column("participant", str, "participant id"),
    Column("session", int, "session number", low=1),
    Column("trial", int, "trial number within the session, from 1", low=1),
    Column("block", str, "block of the trial"),
    Column(
        "onset_s",
        float,
        "onset of the trial's stimulus: the flip that first showed it, on the clock of the run "
        "that recorded the trial (the PsychoPy log's time base; the sidecar's runs give each "
        "run's clock epoch and trials)",
        unit="s",
        low=0.0,
        since="0.2",
    ),
    Column(
        "time_s",
        float,
        "response time: from the onset flip of the trial's stimulus to the key press that "
        "ended the trial (Yoshida: Enter confirming both settings; Spencer: the answer; "
        "Luidolt: the rating)",
        unit="s",
        low=0.0,
    ),
    Column(
        "dropped_frames",
        int,
        "frames dropped while the trial's stimulus was on a timed presentation (Spencer's "
        "flash); static screens are drawn once per change and drop none",
        low=0,
    ),
    Column(
        "ignored_keys",
        str,
        "key presses not taken as input during the trial or before its onset, as "
        "name@seconds from the onset (negative: before it), separated by ';'",
        optional=True,
        since="0.2",
    ),
)

YOSHIDA2008 = (
    Column("method", str, "glare method of the reference", choices=("gaussian", "vos")),
    Column("level", str, "level label: A-F (Gaussian) or a-f (Vos)"),
    Column(
        "level_index", int, "level position 1-6, the ordinal scale shared by A-F and a-f", low=1
    ),
    Column("l_disk_cd_m2", float, "input disk luminance of the reference", unit="cd/m²", low=0.0),
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
    Column(
        "match_cd_m2",
        float,
        "mean of the two settings: the perceived luminance",
        unit="cd/m²",
        low=0.0,
    ),
    Column("adjustments", int, "key presses that changed a target", low=0),
    Column(
        "q1_glow",
        bool,
        "Does the reference image glow? (empty: the protocol asks no questions)",
        optional=True,
    ),
    Column(
        "q2_ring",
        bool,
        "Do you see a bright ring (a.k.a. Mach-band)? (empty: the protocol asks no questions)",
        optional=True,
    ),
    Column(
        "q3_same_size",
        bool,
        "Are the sizes of reference and target disks the same? (empty: the protocol asks "
        "no questions)",
        optional=True,
    ),
)

SPENCER1995 = (
    Column("context", str, "context of the block", choices=("none", "lamp")),
    Column("glare_level", int, "glare level 1-12 (the staircase)", low=1),
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

LUIDOLT2020 = (
    Column("category", str, "questionnaire category"),
    Column(
        "rating",
        int,
        "Likert rating (1 = completely different, 7 = exactly the same)",
        low=1,
        high=7,
    ),
    Column("comment", str, "optional comment", optional=True),
)

STUDY_COLUMNS = {
    "yoshida2008": YOSHIDA2008,
    "spencer1995": SPENCER1995,
    "luidolt2020": LUIDOLT2020,
}


def columns(study: str) -> tuple[Column, ...]:
    """All columns of a study's CSV, in file order."""
    if study not in STUDY_COLUMNS:
        raise ValueError(f"study must be one of {', '.join(STUDY_COLUMNS)}; got {study!r}")
    return COMMON + STUDY_COLUMNS[study]


def format_value(value: object, column: Column) -> str:
    """A value as written in the CSV (floats with full precision, booleans as true/false)."""
    if value is None or value == "":
        if not column.optional:
            raise ValueError(f"column {column.name} needs a value")
        return ""
    if column.kind is bool:
        return "true" if value else "false"
    if column.kind is float:
        return repr(float(value))
    return str(value)
