"""Reading session CSVs: every cell checked, every session vouched for, nothing dropped silently.

The columns are the protocol's (:func:`glarelab.protocols.columns`), the ones the experiments
write; files written before a column was added (its ``since``) are read with that column
missing, but only where the session's sidecar names a data format older than the column (or
there is no sidecar). A problem is reported with its file, line and column; all problems of all
files are collected and raised together (:class:`DataError`).

A session is counted only if the analysis can vouch for it:

- its sidecar (the ``.json`` beside the CSV) is a file of this study, run with this protocol
  (its sha256), with the stimulus set and calibration the report is given, and names the
  participant and session its rows and its file name name;
- its sidecar agrees with itself and its CSV: the session's status and trial count are its last
  run's, ``refresh_hz`` a rate a session of the protocol times at, its blocks in the order its
  ``counterbalance`` gives; and every session counted ran on one stimulus set;
- its rows are complete and in order by their own trial numbers (a spreadsheet's sorting does
  not change the analysis): a trial missing or given twice is named, and so are a header that
  is not on the first line, a last row cut short, values no session can write (an infinite
  time, a block the experiment does not have, contradictory flags) and a file of a data format
  that must have a column it lacks;
- its rows are the ones its session wrote: each row's digest is its sidecar's
  ``row_sha256`` entry (data format 0.5 on), so a value changed in a spreadsheet, an answer
  flipped or a label swapped is named by file, line and trial;
- it is not a pilot (sidecar ``pilot: true``): pilot sessions are left out and listed, or
  analysed and listed when the caller asks (``include_pilots``);
- it is the only session of its participant among the files, and its trials are not another
  participant's, cell for cell and times included (one person's session imported twice under
  two ids, as a file and its spreadsheet re-save).

A design with a missing cell is refused naming the participant and the cell, unless the caller
asks to exclude incomplete participants, in which case they are excluded and listed (the report
shows the list). The paradigm's own rules (its design and the values its sessions can write)
come from its module in :data:`glarelab.analysis.paradigms.PARADIGMS`, so a new paradigm needs
no change here.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import warnings
from collections.abc import Sequence
from datetime import datetime
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import pandas as pd

from glarelab.analysis.dataset import DataError, Dataset, Design, where
from glarelab.analysis.paradigms import paradigm_analysis
from glarelab.display.checks import REFRESH_TOLERANCE_FRACTION
from glarelab.files.inputs import loads_json
from glarelab.files.values import DECIMAL_TEXT, WHOLE_TEXT
from glarelab.protocols import DATA_FORMAT, ROW_DIGESTS_SINCE, columns, row_digest
from glarelab.protocols.core import ORDER_FIELDS, session_order
from glarelab.protocols.keys import TOKEN

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

# the numbers a session CSV holds, as format_value writes them (int() and float() also read
# "2_50" as 250 and surrounding spaces)
# ignored_keys as the session loop writes it: name@seconds (3 decimals), ';' between
_IGNORED_KEYS = re.compile(r"[^;@\s]+@-?\d+\.\d{3}(;[^;@\s]+@-?\d+\.\d{3})*")
_DIGEST = re.compile(r"[0-9a-f]{16}")  # a row_digest
# the name a session's files get: PARTICIPANT_STUDY_sN_YYYY-MM-DD_HHMM[_pilot].csv
_FILE_NAME = (
    r"(?P<participant>.+)_{study}_s(?P<session>\d+)_\d{{4}}-\d{{2}}-\d{{2}}_\d{{4}}"
    r"(?P<pilot>_pilot)?\.csv"
)
# a name that keeps a session's PARTICIPANT_STUDY_sN and loses or changes the rest (the date
# cut off, a note added) still names its participant and session
_NAMED_SESSION = r"(?P<participant>.+)_{study}_s(?P<session>\d+)(?:[_.\- ].*)?\.csv"

__all__ = ["DataError", "Dataset", "Design", "load_sessions", "where"]

# every data format session files were written in, oldest first: the ones before, then the
# current one (a sidecar naming another is of a newer version or edited, and is refused)
DATA_FORMATS = ("0.1", "0.2", "0.3", "0.4", DATA_FORMAT)
# the session statuses a sidecar records
STATUSES = ("running", "completed", "aborted", "interrupted")

# columns added after the first data format, as files written before them are read: every
# trial of those files counted (no presentation was repeated); the others are missing
LEGACY_DEFAULTS = {"counted": True}


def _version(text) -> tuple[int, ...] | None:
    """A data-format version as numbers (``"0.4"`` → ``(0, 4)``); None if it is not one."""
    if not isinstance(text, str) or not re.fullmatch(r"\d+(\.\d+)*", text):
        return None
    return tuple(int(part) for part in text.split("."))


def _other_delimiter(header: list[str]) -> str:
    """What a header read as one cell says of its file: separated by ``;`` or tabs (a
    spreadsheet set to another locale saves its "CSV" so), for a message; empty otherwise.

    Parameters
    ----------
    header
        The first row as the ``csv`` module read it (comma-separated).

    Returns
    -------
    str
        A clause naming the delimiter and the fix, or ``""``.

    Examples
    --------
    >>> _other_delimiter(["study;participant;session"])
    " (its first line is one cell holding ';': cells separated by ';', as a spreadsheet in a locale with a decimal comma saves CSV; save it with ',' between cells)"
    """  # noqa: E501
    if len(header) != 1:
        return ""
    for mark, name in ((";", "';'"), ("\t", "tabs")):
        if mark in header[0]:
            return (
                f" (its first line is one cell holding {name}: cells separated by {name}, as a "
                "spreadsheet in a locale with a decimal comma saves CSV; save it with ',' "
                "between cells)"
            )
    return ""


def _parse(cell: str, column, where: str, problems: list[str]):
    if cell == "":
        if not column.optional:
            problems.append(f"{where}: empty, a {column.kind.__name__} is required ({column.doc})")
        return None
    try:
        if column.kind is bool:
            if cell not in ("true", "false"):
                raise ValueError
            value = cell == "true"
        elif column.kind is int:
            if not WHOLE_TEXT.fullmatch(cell):  # int() reads "2_50" as 250 and " 7" as 7
                raise ValueError
            value = int(cell)
        elif column.kind is float:
            if not DECIMAL_TEXT.fullmatch(cell):  # float() reads "2_50" as 250.0
                raise ValueError
            value = float(cell)
        elif column.name == "ignored_keys" and not _IGNORED_KEYS.fullmatch(cell):
            problems.append(
                f"{where}: {cell!r} is not the key presses a session records (name@seconds "
                "from the onset with three decimals, separated by ';', e.g. "
                "'space@-0.120;left@0.503')"
            )
            return None
        elif column.name == "participant" and not TOKEN.match(cell):
            problems.append(
                f"{where}: {cell!r} is not a participant id (letters, digits, '_', '-', '.'; "
                "no spaces or line breaks)"
            )
            return None
        else:
            value = cell
    except ValueError:
        kind = {int: "a whole number", float: "a number", bool: "true or false"}.get(
            column.kind, f"a {column.kind.__name__}"
        )
        problems.append(f"{where}: {cell!r} is not {kind} ({column.doc})")
        return None
    if column.choices is not None and value not in column.choices:
        problems.append(f"{where}: {cell!r} is not one of {', '.join(column.choices)}")
        return None
    if isinstance(value, float) and not math.isfinite(value):
        problems.append(f"{where}: {cell!r} is not a finite number ({column.doc})")
        return None
    if isinstance(value, int | float) and not isinstance(value, bool):
        if (column.low is not None and value < column.low) or (
            column.high is not None and value > column.high
        ):
            low = "-inf" if column.low is None else column.low
            high = "inf" if column.high is None else column.high
            bounds = f"[{low}, {high}]"
            problems.append(
                f"{where}: {cell!r} is outside {bounds}{' ' + column.unit if column.unit else ''}"
            )
            return None
    return value


def _read_file(
    path: Path, protocol: Protocol, sidecar: dict | None, problems: list[str]
) -> list[dict]:
    study = protocol.study
    expected = columns(protocol)
    names = [c.name for c in expected]
    rows: list[dict] = []
    try:  # utf-8-sig: a spreadsheet's "CSV UTF-8" starts with a byte-order mark
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        problems.append(f"{path}: not UTF-8 text ({error.reason} at byte {error.start})")
        return rows
    if not text:
        problems.append(f"{path}: empty file, no header")
        return rows
    # strict: a quote left open at the end (a row cut inside its comment) is an error, not
    # a cell that silently runs to the end of the file
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    records: list[tuple[int, list[str]]] = []
    try:
        for cells in reader:
            records.append((reader.line_num, cells))
    except csv.Error as error:  # an open quote, or a cell over the csv module's size limit
        problems.append(
            f"{path}, line {reader.line_num}: not readable as CSV ({error}): a row cut short "
            "(a copy interrupted?) or a quote left open"
        )
        return rows
    cut = bool(records) and any(records[-1][1]) and not text.endswith(("\n", "\r"))
    while len(records) > 1 and not any(records[-1][1]):
        records.pop()  # empty lines (or rows of empty cells) a spreadsheet left at the end
    if cut:
        problems.append(
            f"{path}, line {records[-1][0]}: the file ends inside its last row (no line break "
            "after it): the row may be cut short (a copy interrupted?); if it is complete "
            "(an editor saved it without one), add the line break"
        )
        return rows
    header = records[0][1]
    later = [line for line, cells in records[1:] if cells == names or cells == header]
    if header != names and later:
        problems.append(
            f"{path}, line {later[0]}: the header is on line {later[0]}, not the first line "
            "(rows sorted in a spreadsheet with the header among them?)"
        )
        return rows
    if later:
        problems.append(
            f"{path}, line {later[0]}: the header repeated inside the data (files joined, or "
            "rows sorted in a spreadsheet?)"
        )
        return rows
    twice = sorted({n for n in header if header.count(n) > 1})
    if twice:
        problems.append(
            f"{path}, line 1: column(s) {', '.join(twice)} appear more than once; each "
            "column must appear once (which one holds the data?)"
        )
        return rows
    data_format = _version((sidecar or {}).get("data_format"))
    optional = {  # columns an older file may lack: added after the file's data format
        c.name
        for c in expected
        if c.since != "0.1" and (data_format is None or data_format < _version(c.since))
    }
    missing = [n for n in names if n not in header and n not in optional]
    extra = [n for n in header if n not in names]
    if missing or extra:
        first = dict(zip(header, records[1][1], strict=False)) if len(records) > 1 else {}
        other = first.get("study")
        newer = [n for n in missing if _since(expected, n) != "0.1"]
        problems.append(
            f"{path}, line 1: columns do not match the {study} schema{_other_delimiter(header)}"
            + (
                f" (its study column says {other!r}: a CSV of another study?)"
                if other and other != study
                else ""
            )
            + (f"; missing {missing}" if missing else "")
            + (f"; unexpected {extra}" if extra else "")
            + (
                f" (its sidecar says data format {sidecar.get('data_format')}, whose files "
                f"have {', '.join(newer)})"
                if sidecar is not None and newer
                else ""
            )
        )
        return rows
    for line, cells in records[1:]:
        if not any(cells):
            problems.append(
                f"{path}, line {line}: an empty line among the data rows (a row deleted in a "
                "spreadsheet?); delete the line, or put the trial's row back"
            )
            continue
        if len(cells) != len(header):
            problems.append(
                f"{path}, line {line}: {len(cells)} cells, the header has {len(header)}"
            )
            continue
        record = dict(zip(header, cells, strict=True))
        if record["study"] != study:
            problems.append(
                f"{path}, line {line}, column study: {record['study']!r}: this is not a "
                f"{study} file (a CSV from another protocol?)"
            )
            continue
        parsed = {
            c.name: _parse(record[c.name], c, f"{path}, line {line}, column {c.name}", problems)
            if c.name in record
            else LEGACY_DEFAULTS.get(c.name)
            for c in expected
        }
        parsed["_file"], parsed["_line"] = str(path), line
        parsed["_digest"] = row_digest(record.get(name, "") for name in names)
        _presentation_times(parsed, f"{path}, line {line}", problems)
        rows.append(parsed)
    return rows


SHOWN_MS_TOLERANCE = 0.01  # ms: shown_ms is written as 1000 (offset_s - onset_s), unrounded


def _presentation_times(row: dict, where: str, problems: list[str]) -> None:
    """A row's presentation as the session measured it: the flip that ended it is not before
    the one that began it, and ``shown_ms`` is their difference (docs/data.md)."""
    onset, offset, shown = row.get("onset_s"), row.get("offset_s"), row.get("shown_ms")
    if shown is not None and offset is None:
        problems.append(
            f"{where}, column shown_ms: {shown!r} without an offset_s: a session writes the "
            "time shown only with the flip that ended the presentation (a row that showed "
            "nothing new has neither)"
        )
        return
    if not all(isinstance(v, float) and math.isfinite(v) for v in (onset, offset)):
        return
    if offset < onset:
        problems.append(
            f"{where}, column offset_s: {offset!r} is before onset_s {onset!r} (the flip that "
            "ended the presentation comes after the one that began it)"
        )
    elif isinstance(shown, float) and abs(shown - 1000.0 * (offset - onset)) > SHOWN_MS_TOLERANCE:
        problems.append(
            f"{where}, column shown_ms: {shown!r} is not offset_s - onset_s "
            f"({1000.0 * (offset - onset):.3f} ms), as every session writes it"
        )


def _since(expected, name: str) -> str:
    return next(c.since for c in expected if c.name == name)


def _read_sidecar(path: Path, problems: list[str]) -> dict | None:
    """The session's sidecar (the JSON beside its CSV), or None if there is none."""
    sidecar_path = path.with_suffix(".json")
    if not sidecar_path.exists():
        return None
    if not sidecar_path.is_file():
        problems.append(
            f"{sidecar_path}: not a file (a folder?); a session's sidecar is the JSON file "
            "its run wrote beside the CSV"
        )
        return None
    try:
        sidecar = loads_json(sidecar_path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        problems.append(f"{sidecar_path}: not valid JSON ({error})")
        return None
    if not isinstance(sidecar, dict):
        problems.append(f"{sidecar_path}: a sidecar must be a JSON object")
        return None
    return sidecar


def _json(value) -> str:
    """A sidecar value as its JSON text (``true``, ``NaN``, ``"0.4"``)."""
    try:
        return json.dumps(value)
    except (TypeError, ValueError):
        return repr(value)


def _whole(low: int):
    def check(value) -> bool:
        return isinstance(value, int) and not isinstance(value, bool) and value >= low

    return check


def _text_or_null(value) -> bool:
    return value is None or isinstance(value, str)


def _object_or_null(value) -> bool:
    return value is None or isinstance(value, dict)


# the sidecar fields the analysis reads or reports, with what a session writes in them: a
# field present with another value (a hand edit: NaN, a string for a number, a counterbalance
# no engine has) is refused, naming it
_SIDECAR_FIELDS = {
    "study": (lambda v: isinstance(v, str), "a study name (text)"),
    "participant": (lambda v: isinstance(v, str), "a participant id (text)"),
    "session": (_whole(1), "a whole number ≥ 1"),
    "status": (lambda v: v in STATUSES, f"one of {', '.join(STATUSES)}"),
    "trials": (_whole(0), "a whole number ≥ 0"),
    "resumed": (_whole(0), "a whole number ≥ 0 (the runs after the first)"),
    "simulated": (lambda v: isinstance(v, bool), "true or false"),
    "pilot": (lambda v: isinstance(v, bool), "true or false"),
    "counterbalance": (
        lambda v: v is None or (isinstance(v, int) and not isinstance(v, bool) and v in (0, 1)),
        "null (no counterbalancing), 0 (the protocol's block order) or 1 (reversed)",
    ),
    "refresh_hz": (
        lambda v: (
            v is None
            or (
                isinstance(v, int | float)
                and not isinstance(v, bool)
                and math.isfinite(v)
                and v > 0
            )
        ),
        "null or a finite number > 0, Hz",
    ),
    "bit_depth": (lambda v: v is None or _whole(1)(v), "null or a whole number ≥ 1"),
    "protocol_sha256": (_text_or_null, "null or a sha256 (text)"),
    "stimulus_set_manifest_sha256": (_text_or_null, "null or a sha256 (text)"),
    "started": (_text_or_null, "null or a date and time (text)"),
    "ended": (_text_or_null, "null or a date and time (text)"),
    "participant_info": (_object_or_null, "an object"),
    "calibration": (_object_or_null, "null or an object"),
    "images_encoded_with": (_object_or_null, "null or an object"),
    "packages": (_object_or_null, "an object"),
    "runs": (lambda v: isinstance(v, list), "a list of runs"),
    "trial_order": (lambda v: v is None or isinstance(v, list), "null or a list"),
    "row_sha256": (
        lambda v: (
            isinstance(v, list) and all(isinstance(d, str) and _DIGEST.fullmatch(d) for d in v)
        ),
        "a list of row digests (16 lowercase hexadecimal digits each)",
    ),
}


# what every sidecar of data format 0.5 on holds (sessions and PsychoPy imports): one without
# them was edited, and the analysis could not vouch for it (a protocol_sha256 deleted let a
# session of another protocol be counted)
WRITTEN_SINCE_0_5 = (
    "study",
    "participant",
    "session",
    "status",
    "trials",
    "simulated",
    "pilot",
    "protocol_sha256",
    "started",
)  # and row_sha256, whose absence _row_digests names


def _sidecar_fields(path: Path, sidecar: dict) -> list[str]:
    """A sidecar's fields as a session writes them: a data format this version knows, and
    each field the analysis reads of its type and range."""
    where_ = path.with_suffix(".json")
    problems = []
    value = sidecar.get("data_format")
    if "data_format" in sidecar and not isinstance(value, str):
        problems.append(
            f"{where_}: data_format is {_json(value)}, not text: a session writes it as a "
            f"string, one of {', '.join(map(_json, DATA_FORMATS))} (edited by hand?)"
        )
    elif "data_format" in sidecar and value not in DATA_FORMATS:
        problems.append(
            f"{where_}: data_format {_json(value)} is not a format this version "
            f"of glarelab reads ({', '.join(DATA_FORMATS)}): a file of a newer version (update "
            "glarelab) or edited by hand"
        )
    if (
        isinstance(value, str)
        and value in DATA_FORMATS
        and not _version(value) < _version(ROW_DIGESTS_SINCE)
    ):
        for key in WRITTEN_SINCE_0_5:
            if key not in sidecar:
                problems.append(
                    f"{where_}: no {key}: every session and import of data format {value} "
                    "writes it (deleted by hand?); the analysis counts a session only with it"
                )
    for key, (valid, allowed) in _SIDECAR_FIELDS.items():
        if key in sidecar and not valid(sidecar[key]):
            problems.append(f"{where_}: {key} is {_json(sidecar[key])}; must be {allowed}")
    for key in ("calibration", "images_encoded_with"):
        record = sidecar.get(key)
        if isinstance(record, dict) and not _text_or_null(record.get("readings_sha256")):
            problems.append(
                f"{where_}: {key}.readings_sha256 is {_json(record['readings_sha256'])}; must "
                "be null or a sha256 (text)"
            )
    if not problems:
        problems += _sidecar_consistency(where_, sidecar)
    if sidecar.get("simulated") is False and not problems:
        problems += _simulated_signs(where_, sidecar)
    if sidecar.get("simulated") is True and not problems:
        keyboards = sorted(
            {
                run["keyboard"]
                for run in sidecar.get("runs") or []
                if isinstance(run, dict)
                and isinstance(run.get("keyboard"), str)
                and run["keyboard"] != "simulated observer"
            }
        )
        if keyboards:
            problems.append(
                f"{where_}: simulated is true, but its runs' keyboard is {', '.join(keyboards)}, "
                "not the simulated observer: a session on a screen (the sidecar edited?); a "
                "session is analysed as what it is (simulated: false)"
            )
    return problems


AGE_RANGE_YEARS = (0, 120)  # what glarelab run accepts (--age, the dialog)
# what a session records of its display's calibration (glarelab.experiments.session, through
# glarelab.display.calibration.usable_calibration): each status with ``calibrated`` and whether
# the calibration's readings are named (their sha256); a calibration file's status comes only
# from its readings and verification pass, so a status without readings is no session's
CALIBRATION_RECORDS = {
    "passed": (True, True),
    "unverified": (True, True),
    "failed": (False, True),
    "synthetic": (False, True),
    "missing": (False, False),
    "not needed": (False, False),
    "simulated": (False, False),
}
UNVERIFIED_ACCEPTED_BY = ("--pilot", "--allow-uncalibrated")
_SHA256 = re.compile(r"[0-9a-f]{64}")


def _sidecar_consistency(where_: Path, sidecar: dict) -> list[str]:
    """The fields the analysis does not read, as a session writes them: an age a session
    accepts, times that are dates with the end not before the start, at least one run, and
    ``resumed`` the runs after the first."""
    problems = []
    age = (sidecar.get("participant_info") or {}).get("age")
    if age is not None and not (
        isinstance(age, int)
        and not isinstance(age, bool)
        and AGE_RANGE_YEARS[0] <= age <= AGE_RANGE_YEARS[1]
    ):
        problems.append(
            f"{where_}: participant_info.age is {_json(age)}; must be null or whole years, "
            f"{AGE_RANGE_YEARS[0]}-{AGE_RANGE_YEARS[1]} (what a session accepts)"
        )
    times = {}
    for key in ("started", "ended"):
        if isinstance(sidecar.get(key), str):
            try:
                times[key] = datetime.fromisoformat(sidecar[key])
            except ValueError:
                problems.append(
                    f"{where_}: {key} is {_json(sidecar[key])}; must be null or an ISO date "
                    "and time, as a session writes it"
                )
    try:
        backwards = len(times) == 2 and times["ended"] < times["started"]
    except TypeError:  # one with a time zone, one without
        backwards = False
    if backwards:
        problems.append(
            f"{where_}: ended {sidecar['ended']} is before started {sidecar['started']}"
        )
    problems += _calibration_record(where_, sidecar)
    runs = sidecar.get("runs")
    shown = [  # the sidecar's bit_depth is its last run's display's (a resume may move)
        run["display"].get("bits_per_channel")
        for run in (runs if isinstance(runs, list) else [])
        if isinstance(run, dict) and isinstance(run.get("display"), dict)
    ]
    if isinstance(sidecar.get("bit_depth"), int) and shown and shown[-1] != sidecar["bit_depth"]:
        problems.append(
            f"{where_}: bit_depth is {sidecar['bit_depth']}, but its last run's display showed "
            f"{shown[-1]} bits per channel"
        )
    if isinstance(runs, list) and not runs:
        problems.append(f"{where_}: runs is empty; every session records its first run")
    elif isinstance(runs, list) and "resumed" in sidecar and sidecar["resumed"] != len(runs) - 1:
        problems.append(
            f"{where_}: resumed is {sidecar['resumed']}, but it records {len(runs)} run(s): "
            f"resumed counts the runs after the first ({len(runs) - 1})"
        )
    return problems


def _calibration_record(where_: Path, sidecar: dict) -> list[str]:
    """The sidecar's ``calibration`` as a session records it (:data:`CALIBRATION_RECORDS`): a
    known status, ``calibrated`` as that status gives it, the readings' sha256 named exactly
    when there is a calibration file, and an unverified calibration accepted by ``--pilot``
    (in a pilot) or ``--allow-uncalibrated``."""
    record = sidecar.get("calibration")
    if record is None:
        return []
    status = record.get("status")
    if status not in CALIBRATION_RECORDS:
        return [
            f"{where_}: calibration.status is {_json(status)}; must be one of "
            f"{', '.join(map(_json, CALIBRATION_RECORDS))}, as a session records it"
        ]
    calibrated, with_readings = CALIBRATION_RECORDS[status]
    problems = []
    if record.get("calibrated") is not calibrated:
        problems.append(
            f"{where_}: calibration.calibrated is {_json(record.get('calibrated'))}; a session "
            f"whose calibration is {status} records {_json(calibrated)}"
        )
    for key, of in (
        ("readings_sha256", "readings, from which alone a status comes"),
        ("curve_sha256", "curve"),  # absent in sessions before the curve's digest was recorded
    ):
        if key not in record and key == "curve_sha256":
            continue
        digest = record.get(key)
        if with_readings and not (isinstance(digest, str) and _SHA256.fullmatch(digest)):
            problems.append(
                f"{where_}: calibration.{key} is {_json(digest)}, but its status is {status}: "
                f"must be the sha256 (64 hex digits) of the calibration's {of} (the sidecar "
                "edited?)"
            )
        elif not with_readings and digest is not None:
            problems.append(
                f"{where_}: calibration.{key} is {_json(digest)}, but its status is {status}: "
                f"must be null (a session {status} names no calibration)"
            )
    accepted = record.get("accepted_unverified_by")
    allowed = (
        UNVERIFIED_ACCEPTED_BY if sidecar.get("pilot") is True else UNVERIFIED_ACCEPTED_BY[1:]
    )
    if "accepted_unverified_by" in record and (status != "unverified" or accepted not in allowed):
        problems.append(
            f"{where_}: calibration.accepted_unverified_by is {_json(accepted)}"
            + (
                f" with status {status}: only an unverified calibration is accepted"
                if status != "unverified"
                else f"; must be {' or '.join(allowed)} (in a "
                f"{'pilot' if sidecar.get('pilot') is True else 'session not a pilot'})"
            )
        )
    return problems


def _simulated_signs(where_: Path, sidecar: dict) -> list[str]:
    """A sidecar saying ``simulated: false`` whose other fields only a simulated observer's
    session writes: its calibration status ``simulated``, the observer's seed among the
    participant's information, a run's keyboard the simulated observer."""
    signs = []
    if (sidecar.get("calibration") or {}).get("status") == "simulated":
        signs.append("its calibration status is 'simulated'")
    if "simulated_observer_seed" in (sidecar.get("participant_info") or {}):
        signs.append("its participant_info holds simulated_observer_seed")
    runs = sidecar.get("runs") or []
    if any(isinstance(run, dict) and run.get("keyboard") == "simulated observer" for run in runs):
        signs.append("its runs' keyboard is 'simulated observer'")
    if not signs:
        return []
    return [
        f"{where_}: simulated is false, but {', '.join(signs)}: a simulated observer's session "
        "(the sidecar edited?); a session is analysed as what it is (simulated: true)"
    ]


def _short(value) -> str:
    return f"{str(value)[:12]}…" if value else repr(value)


def _sidecar_contradictions(
    path: Path, sidecar: dict, rows: list[dict], protocol: Protocol, stimuli: dict | None
) -> list[str]:
    """Where a session's sidecar disagrees with its CSV, the protocol or the stimulus set the
    analysis is given (a file of another session, study or protocol version put beside it, or
    edited by hand)."""
    where_ = path.with_suffix(".json")
    problems = []
    if sidecar.get("study") != protocol.study:
        problems.append(
            f"{where_}: study {sidecar.get('study')!r}, but the data are analysed as "
            f"{protocol.study!r}"
        )
    recorded = sidecar.get("protocol_sha256")
    if recorded is not None and recorded != protocol.sha256:
        problems.append(
            f"{where_}: the session ran with protocol sha256 {_short(recorded)}, the analysis "
            f"is given {_short(protocol.sha256)}: another version of the protocol (analyse "
            "it with the protocol file the session ran with, --protocol)"
        )
    if not isinstance(sidecar.get("simulated"), bool):
        problems.append(
            f"{where_}: simulated is {sidecar.get('simulated')!r}; must be true or false"
        )
    if not isinstance(sidecar.get("pilot", False), bool):
        problems.append(f"{where_}: pilot is {sidecar.get('pilot')!r}; must be true or false")
    else:  # a pilot session resumes only as a pilot, and a session only as a session
        runs = [r for r in sidecar.get("runs") or [] if isinstance(r, dict) and "pilot" in r]
        other = [
            n for n, r in enumerate(runs, start=1) if r["pilot"] != sidecar.get("pilot", False)
        ]
        if other:
            problems.append(
                f"{where_}: pilot is {_json(sidecar.get('pilot', False))}, but run(s) "
                f"{', '.join(map(str, other))} say pilot {_json(runs[other[0] - 1]['pilot'])}: a "
                "session's runs are all pilots or none (the sidecar edited?)"
            )
    recorded_order = session_order(protocol.paradigm)
    for key in ORDER_FIELDS:
        if key not in recorded_order and sidecar.get(key) is not None:
            problems.append(
                f"{where_}: {key} is {_json(sidecar[key])}; must be null: a "
                f"{protocol.paradigm} session records "
                + (
                    f"its order in {' and '.join(recorded_order)}"
                    if recorded_order
                    else f"no order ({' or '.join(ORDER_FIELDS)})"
                )
                + " (the sidecar edited?)"
            )
    for key in ("participant", "session"):
        values = {str(row.get(key)) for row in rows}
        if rows and values != {str(sidecar.get(key))}:
            problems.append(
                f"{where_}: {key} {sidecar.get(key)!r}, but its CSV's rows say "
                f"{', '.join(sorted(values))}"
            )
    calibration = (sidecar.get("calibration") or {}).get("readings_sha256")
    encoded = (sidecar.get("images_encoded_with") or {}).get("readings_sha256")
    if calibration and encoded and calibration != encoded:
        problems.append(
            f"{where_}: the session's calibration (readings {_short(calibration)}) is not the "
            f"one its images were encoded with ({_short(encoded)})"
        )
    if stimuli is not None:
        used = sidecar.get("stimulus_set_manifest_sha256")
        if used is not None and used != stimuli["manifest_sha256"]:
            problems.append(
                f"{where_}: the session ran on the stimulus set with manifest sha256 "
                f"{_short(used)}, the analysis is given {_short(stimuli['manifest_sha256'])} "
                "(another set, or the set was rebuilt since)"
            )
        source = (sidecar.get("images_encoded_with") or {}).get("source")
        if encoded and source == "stimulus set" and encoded != stimuli["readings_sha256"]:
            problems.append(
                f"{where_}: the session's images were encoded with the calibration of its "
                f"stimulus set (readings {_short(encoded)}), the set given has "
                f"{_short(stimuli['readings_sha256'])}"
            )
    return problems


def _runs_record(where_: Path, sidecar: dict) -> list[str]:
    """The session's status and trial count are its last run's (a run's end writes both,
    :func:`glarelab.experiments.session._finish_run`), no run ends with fewer trials than
    it began with, and a completed run has no ``ended_by`` (what ended an aborted one)."""
    runs = [run for run in sidecar.get("runs") or [] if isinstance(run, dict)]
    if not runs or len(runs) != len(sidecar.get("runs") or []):
        return []
    problems = []
    last = runs[-1]
    status = last.get("status")
    if "status" in sidecar and "status" in last and status != sidecar["status"]:
        problems.append(
            f"{where_}: runs[{len(runs) - 1}].status is {_json(status)}, but the session's "
            f"status is {_json(sidecar['status'])}: must be the same, the last run's end is "
            "the session's (the sidecar edited?)"
        )
    after = last.get("trials_after")
    if after is not None and "trials" in sidecar and after != sidecar["trials"]:
        problems.append(
            f"{where_}: runs[{len(runs) - 1}].trials_after is {_json(after)}, but the session "
            f"recorded {_json(sidecar['trials'])} trials: must be the same, the last run's "
            "count is the session's (the sidecar edited?)"
        )
    for number, run in enumerate(runs):
        ended_by = run.get("ended_by")
        if run.get("status") == "completed" and ended_by is not None:
            problems.append(
                f"{where_}: runs[{number}].ended_by is {_json(ended_by)}, but the run's status "
                'is "completed": must be null, a run that completed was not ended by a key or '
                "an error (the sidecar edited?)"
            )
        before, after = run.get("trials_before"), run.get("trials_after")
        if _whole(0)(before) and _whole(0)(after) and after < before:
            problems.append(
                f"{where_}: runs[{number}].trials_after is {after}, below its trials_before "
                f"{before}: must be ≥ {before}, a run only adds trials (the sidecar edited?)"
            )
    return problems


def _refresh_record(path: Path, sidecar: dict, protocol: Protocol) -> list[str]:
    """The sidecar's ``refresh_hz`` is a rate the session could time at: its protocol's
    ``display.refresh_hz``, or one measured within :data:`REFRESH_TOLERANCE_FRACTION` of it
    (:func:`glarelab.display.checks.timing_rate_hz`), and its last run's timing rate where
    that run recorded its display."""
    rate = sidecar.get("refresh_hz")
    if rate is None or isinstance(rate, bool) or not isinstance(rate, int | float):
        return []
    if "data_format" not in sidecar:  # before 0.2: the front-end's rate, not the timing rate
        return []
    where_ = path.with_suffix(".json")
    nominal = (protocol.data.get("display") or {}).get("refresh_hz", 60.0)
    if abs(rate - nominal) > REFRESH_TOLERANCE_FRACTION * nominal:
        return [
            f"{where_}: refresh_hz is {_json(rate)}; must be within "
            f"{100 * REFRESH_TOLERANCE_FRACTION:g} % of the protocol's display.refresh_hz "
            f"{nominal:g} Hz (a session times at that rate or a measured one close to it; the "
            "sidecar edited, or of another protocol?)"
        ]
    runs = sidecar.get("runs") or []
    display = runs[-1].get("display") if runs and isinstance(runs[-1], dict) else None
    timed = display.get("timing_refresh_hz") if isinstance(display, dict) else None
    if isinstance(timed, int | float) and not isinstance(timed, bool) and timed != rate:
        return [
            f"{where_}: refresh_hz is {_json(rate)}, but its last run timed at "
            f"{_json(timed)} Hz (runs[{len(runs) - 1}].display.timing_refresh_hz): must be the "
            "same (the sidecar edited?)"
        ]
    return []


def _block_order(path: Path, sidecar: dict, rows: list[dict], design: Design) -> list[str]:
    """A session's blocks, in the order of their first trials, follow its ``counterbalance``:
    0, the protocol's order of the blocks; 1, reversed (a session aborted early has the first
    of them)."""
    counterbalance = sidecar.get("counterbalance")
    if counterbalance not in (0, 1) or isinstance(counterbalance, bool):
        return []
    ordered = sorted(
        (row for row in rows if isinstance(row.get("trial"), int)), key=lambda r: r["trial"]
    )
    shown = list(dict.fromkeys(row["block"] for row in ordered))  # by their first trials
    if not set(shown) <= set(design.blocks):  # a block no session writes: named elsewhere
        return []
    expected = list(design.blocks) if counterbalance == 0 else list(design.blocks)[::-1]
    if shown == expected[: len(shown)]:
        return []
    return [
        f"{path.with_suffix('.json')}: counterbalance is {counterbalance}, but its CSV's blocks "
        f"begin in the order {', '.join(shown)}: counterbalance {counterbalance} runs them "
        f"{', '.join(expected)}"
        + ("" if counterbalance == 0 else " (the protocol's order reversed)")
        + " (the sidecar or the rows edited?)"
    ]


def _trial_order(path: Path, sidecar: dict, rows: list[dict], design: Design) -> list[str]:
    """A session that records its ``trial_order`` (``block:method:level`` of each trial, trial
    1 first: :attr:`glarelab.experiments.matching.MatchingEngine.order`) ran its trials in that
    order: the row of trial ``n`` is entry ``n`` (a resumed session continues the order, an
    aborted one has its first trials). A block no session writes is named elsewhere."""
    order = sidecar.get("trial_order")
    if not isinstance(order, list):
        return []
    problems = []
    for row in sorted(
        (row for row in rows if isinstance(row.get("trial"), int)), key=lambda r: r["trial"]
    ):
        if not all(key in row for key in ("block", "method", "level")):
            return []
        if row["block"] not in design.blocks:
            continue
        shown = f"{row['block']}:{row['method']}:{row['level']}"
        trial = row["trial"]
        expected = order[trial - 1] if 1 <= trial <= len(order) else None
        if shown != expected:
            problems.append(
                f"{path}, line {row['_line']} (trial {trial}): block:method:level is {shown}, "
                + (
                    f"but the sidecar's trial_order has {expected} at trial {trial}"
                    if expected is not None
                    else f"but the sidecar's trial_order has {len(order)} trials"
                )
                + ": a session runs its trials in its recorded order (the rows or the "
                "sidecar edited?)"
            )
    return problems


def _row_digests(path: Path, sidecar: dict | None, rows: list[dict]) -> list[str]:
    """Each row is the one the session wrote: its :func:`~glarelab.protocols.row_digest` is
    the sidecar's ``row_sha256`` entry of its trial (trial n is entry n; sidecars of data
    format :data:`~glarelab.protocols.ROW_DIGESTS_SINCE` on, and any sidecar that has them).
    A value changed by hand or in a spreadsheet, labels swapped, a row copied from another
    session: the row is named. The rows' order does not matter. Rows after the last entry are
    allowed only while the sidecar says ``running`` (the run that wrote them was killed before
    it recorded its end); ``_digest`` is taken off every row."""
    digests = [row.pop("_digest", None) for row in rows]
    if sidecar is None:
        return []
    data_format = _version(sidecar.get("data_format"))
    older = data_format is None or data_format < _version(ROW_DIGESTS_SINCE)
    recorded = sidecar.get("row_sha256")
    if recorded is None:
        return (
            []
            if older
            else [
                f"{path.with_suffix('.json')}: no row_sha256, which every session of data "
                f"format {sidecar.get('data_format')} records (each row's digest): the "
                "analysis cannot tell its rows are the ones the session wrote (the sidecar "
                "edited?)"
            ]
        )
    problems = []
    if older:  # its rows are checked all the same
        problems.append(
            f"{path.with_suffix('.json')}: data_format {_json(sidecar.get('data_format'))} "
            f"predates row_sha256 (data format {ROW_DIGESTS_SINCE}), which the sidecar has: "
            "the sidecar edited?"
        )
    for row, digest in zip(rows, digests, strict=True):
        trial = row.get("trial")
        if not isinstance(trial, int) or trial < 1:
            continue  # named by the trial checks
        if trial > len(recorded):
            if sidecar.get("status") != "running":
                problems.append(
                    f"{path}, line {row['_line']} (trial {trial}): not among the "
                    f"{len(recorded)} rows the session recorded in its sidecar's row_sha256 "
                    "(a row added by hand, or from another file?)"
                )
            elif trial > len(recorded) + 1:  # a session records each row's digest after it
                problems.append(
                    f"{path}, line {row['_line']} (trial {trial}): beyond the {len(recorded)} "
                    "rows the session recorded in its sidecar's row_sha256, by more than the "
                    f"one row (trial {len(recorded) + 1}) a run killed between a row and its "
                    "digest leaves (rows added by hand, or the sidecar of an earlier moment?)"
                )
        elif digest != recorded[trial - 1]:
            problems.append(
                f"{path}, line {row['_line']} (trial {trial}): the row is not the one the "
                f"session wrote (its digest {digest}, the sidecar's row_sha256 has "
                f"{recorded[trial - 1]}): a value changed by hand or in a spreadsheet, or the "
                "row taken from another session? The analysis counts rows as written"
            )
    trials = {row.get("trial") for row in rows}
    absent = [n for n in range(1, len(recorded) + 1) if n not in trials]
    if absent:
        listed = ", ".join(map(str, absent[:10])) + (" …" if len(absent) > 10 else "")
        problems.append(
            f"{path}: trial{'s' if len(absent) > 1 else ''} {listed} of the {len(recorded)} "
            "the session recorded (its sidecar's row_sha256) missing (rows deleted?)"
        )
    return problems


def _one_stimulus_set(sidecars: dict[str, dict]) -> list[str]:
    """The sessions of one analysis ran on one stimulus set: name each set their sidecars'
    ``stimulus_set_manifest_sha256`` give, with its sessions."""
    sets: dict[str | None, list[str]] = {}
    for name, sidecar in sidecars.items():
        if "stimulus_set_manifest_sha256" in sidecar:
            sets.setdefault(sidecar["stimulus_set_manifest_sha256"], []).append(Path(name).name)
    if len(sets) < 2:
        return []
    listed = "; ".join(
        f"{'no set' if used is None else _short(used)}: {', '.join(names)}"
        for used, names in sets.items()
    )
    return [
        f"the sessions ran on {len(sets)} stimulus sets (stimulus_set_manifest_sha256 of their "
        f"sidecars): {listed}; must be one set: analyse the sessions of each set apart (a set "
        "rebuilt between sessions, or a sidecar edited?)"
    ]


def _recorded_trials(path: Path, sidecar: dict | None, rows: list[dict]) -> list[str]:
    """A completed session's CSV holds the trials its sidecar recorded: name the trials
    missing at its end (rows deleted, or the file cut at a line break), or the rows beyond
    them."""
    recorded = (sidecar or {}).get("trials")
    if (
        sidecar is None
        or sidecar.get("status") != "completed"
        or not isinstance(recorded, int)
        or isinstance(recorded, bool)
        or not rows
    ):
        return []
    last = max(row["trial"] for row in rows if row.get("trial") is not None)
    if last < recorded:
        missing = f"{last + 1}" if last + 1 == recorded else f"{last + 1}-{recorded}"
        return [
            f"{path}: trial{'s' if last + 1 < recorded else ''} {missing} of the {recorded} the "
            "completed session recorded missing (rows deleted, or the file cut short?)"
        ]
    if last > recorded:
        return [
            f"{path}: trial {recorded + 1} and after: the completed session recorded "
            f"{recorded} trials, its CSV goes on to trial {last} (rows added?)"
        ]
    return []


def _name_contradictions(
    path: Path, rows: list[dict], sidecar: dict | None, study: str
) -> list[str]:
    """Where a session file's name disagrees with its rows (a file renamed to another
    participant or session, or a pilot's file renamed to a participant's)."""
    match = re.fullmatch(_FILE_NAME.format(study=re.escape(study)), path.name)
    named = match or re.fullmatch(_NAMED_SESSION.format(study=re.escape(study)), path.name)
    if named is None or not rows:
        return []
    problems = []
    first = rows[0]
    if named["participant"] != str(first.get("participant")):
        problems.append(
            f"{path}: the file name says participant {named['participant']}, its rows say "
            f"{first.get('participant')} (a file renamed?)"
        )
    if int(named["session"]) != first.get("session"):
        problems.append(
            f"{path}: the file name says session {named['session']}, its rows say "
            f"{first.get('session')} (a file renamed?)"
        )
    if match is not None and sidecar is not None and isinstance(sidecar.get("pilot", False), bool):
        if bool(match["pilot"]) != bool(sidecar.get("pilot", False)):
            problems.append(
                f"{path}: the file name says {'a pilot' if match['pilot'] else 'not a pilot'}, "
                f"its sidecar says pilot {str(bool(sidecar.get('pilot'))).lower()}; a pilot is "
                "marked by both (the CSV and its sidecar named …_pilot.csv and …_pilot.json, "
                '"pilot": true), so a session made a pilot afterwards, or back, is renamed as '
                "well as edited (pilots are then left out and listed; --include-pilots "
                "analyses them)"
            )
    return problems


def _trial_sequence(path: Path, rows: list[dict]) -> list[str]:
    """A session's trials are numbered 1, 2, 3, … once each: name a repeated or missing one
    (the rows may come in any order)."""
    problems = []
    seen: dict[int, int] = {}
    for row in rows:
        trial = row.get("trial")
        if trial is None:
            continue
        if trial in seen:
            problems.append(
                f"{path}, line {row['_line']}: duplicated trial (participant "
                f"{row['participant']}, session {row['session']}, trial {trial}), also on line "
                f"{seen[trial]}"
            )
        else:
            seen[trial] = row["_line"]
    if seen:
        absent = sorted(set(range(1, max(seen) + 1)) - set(seen))
        if absent:
            listed = ", ".join(map(str, absent[:10])) + (" …" if len(absent) > 10 else "")
            problems.append(
                f"{path}: trial{'s' if len(absent) > 1 else ''} {listed} of "
                f"{max(seen)} missing (rows deleted?)"
            )
    return problems


def _paradigm_session_checks(
    paradigm, path: Path, rows: list[dict], sidecar: dict | None, protocol: Protocol
) -> list[str]:
    """What a paradigm checks in one session's rows as a whole (its ``check_session``, if it
    has one: a staircase replays its staircases), once the trials are known to be unique."""
    check_session = getattr(paradigm, "check_session", None)
    if check_session is None:
        return []
    return check_session(path, rows, sidecar, protocol)


def _session(path: Path, rows: list[dict], sidecar: dict | None) -> dict:
    """What the report says of one session file: who, how many trials, how it ended."""
    first = rows[0] if rows else {}
    status = "no sidecar" if sidecar is None else str(sidecar.get("status", "unknown"))
    pilot = bool((sidecar or {}).get("pilot")) or path.name.endswith("_pilot.csv")
    return {
        "file": str(path),
        "participant": first.get("participant", (sidecar or {}).get("participant")),
        "session": first.get("session", (sidecar or {}).get("session")),
        "trials": len(rows),
        "status": status if rows or sidecar is not None else "header only",
        "sidecar": sidecar is not None,
        "simulated": None if sidecar is None else bool(sidecar.get("simulated")),
        "pilot": pilot,
        # data format 0.4 and before record no row digests: an edit of a row goes unseen
        "rows_checked": isinstance((sidecar or {}).get("row_sha256"), list),
    }


def _arguments(protocol, *flags: object) -> None:
    """Refuse a protocol that is not one (a study's name) and a flag that is not a bool
    (the string 'no' is true to ``if``: ``exclude_incomplete='no'`` would drop participants)."""
    from glarelab.protocols import Protocol

    if not isinstance(protocol, Protocol):
        raise TypeError(
            f"protocol must be a Protocol (load_protocol({protocol!r}) reads a study's); got "
            f"{protocol!r}"
            if isinstance(protocol, str)
            else f"protocol must be a Protocol (from load_protocol); got {type(protocol).__name__}"
        )
    names = ("exclude_incomplete", "include_aborted", "include_pilots", "include_no_sidecar")
    for name, flag in zip(names, flags, strict=True):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be True or False; got {flag!r}")


def load_sessions(
    protocol: Protocol,
    paths: list[str | Path],
    *,
    exclude_incomplete: bool = False,
    include_aborted: bool = False,
    include_pilots: bool = False,
    include_no_sidecar: bool = False,
    stimuli: dict | None = None,
) -> Dataset:
    """Load and validate session CSVs of one study (its protocol sets the columns, the design
    and the values a trial can hold).

    Parameters
    ----------
    protocol
        The study's validated protocol.
    paths
        Session CSV files (a list, or one path); each one's JSON sidecar (same name) is read
        where it exists.
    exclude_incomplete
        Drop participants with a missing design cell (listed in ``Dataset.excluded``) instead
        of refusing the data.
    include_aborted
        Analyse sessions that did not complete (their sidecar says aborted or running) and
        skip files without trials, instead of refusing them; either way they are listed in
        ``Dataset.sessions`` for the report.
    include_pilots
        Analyse pilot sessions (sidecar ``pilot: true``) as participants; by default they
        are left out. Either way they are listed in ``Dataset.pilots``.
    include_no_sidecar
        Analyse session CSVs that have no sidecar (a file of the first data format, or one
        whose sidecar was lost): nothing vouches for their protocol, status, pilot or
        simulated flag. By default they are refused; either way they are listed in
        ``Dataset.sessions`` (status ``no sidecar``), and the report lists them.
    stimuli
        The stimulus set the report is given, as ``{"manifest_sha256": …, "readings_sha256":
        …}`` (the sha256 of its manifest and of its calibration's readings): sessions that ran
        on another set, or whose images were encoded with the set's calibration and that is
        another one, are refused.

    Returns
    -------
    Dataset
        The trials in the order of participant, session and trial number, whatever the
        order of the files and of their rows.

    Raises
    ------
    TypeError
        For a protocol that is not a :class:`~glarelab.protocols.Protocol` (a study's name:
        use ``load_protocol``), a path that is not a str or Path, or a flag that is not
        True or False.
    DataError
        Naming file, line and column of every bad cell; a sidecar that disagrees with its
        CSV, its file name, the protocol or the stimulus set; values the protocol or its
        display cannot produce; trials duplicated or missing; a header not on the first line;
        a row cut short; a sidecar whose status, trial count, refresh rate or counterbalance
        contradicts its runs, its protocol or its CSV's block order; sessions that ran on
        different stimulus sets; a CSV of another study; a CSV without its sidecar (unless
        ``include_no_sidecar``); a file given twice; two sessions of one participant; two
        participants whose trials are the same, cell for cell and times included; sessions
        that did not complete or hold no trials (unless ``include_aborted``); nothing left
        but pilots; and (unless ``exclude_incomplete``) every participant missing a design
        cell.
    """
    problems: list[str] = []
    rows: list[dict] = []
    sidecars: dict[str, dict] = {}
    sessions: list[dict] = []
    pilots: list[dict] = []
    files = []
    replayed: list[str] = []  # what the paradigm's replay of each session finds
    edited: list[str] = []  # rows that are not the ones their session wrote
    keys: list[tuple[Path, str, int, _Trials | None]] = []  # each file's (_trials_of)
    _arguments(protocol, exclude_incomplete, include_aborted, include_pilots, include_no_sidecar)
    if isinstance(paths, str | PathLike):  # one file: not the characters of its name
        paths = [paths]
    if not isinstance(paths, Sequence) or isinstance(paths, bytes):
        raise TypeError(f"paths must be a list of session CSV paths; got {paths!r}")
    for raw in paths:
        if not isinstance(raw, str | PathLike):
            raise TypeError(f"paths must hold file paths (str or Path); got {raw!r}")
    if not paths:
        raise DataError(["no CSV files given"])
    paradigm = paradigm_analysis(protocol)
    design: Design = paradigm.design(protocol)
    given: dict[Path, Path] = {}  # each file as resolved → as given first
    for raw in paths:
        path = Path(raw)
        if not path.is_file():
            problems.append(
                f"{path}: no such file" if not path.exists() else f"{path}: not a file"
            )
            continue
        resolved = path.resolve()
        if resolved in given:
            problems.append(
                f"{path}: given twice"
                + (f" (also as {given[resolved]})" if given[resolved] != path else "")
                + "; give each session file once"
            )
            continue
        given[resolved] = path
        found = len(problems)
        sidecar = _read_sidecar(path, problems)
        if sidecar is not None:
            problems += _sidecar_fields(path, sidecar)
            if len(problems) > found:
                continue
        unvouched = sidecar is None and not include_no_sidecar and len(problems) == found
        if unvouched:  # its rows are read all the same, so that their problems are named too
            problems.append(
                f"{path}: no sidecar ({path.with_suffix('.json').name}): nothing vouches for "
                "its protocol, status or whether it is a pilot or simulated; "
                "--include-no-sidecar analyses such files and the report lists them"
            )
            found = len(problems)
        read = _read_file(path, protocol, sidecar, problems)
        if len(problems) > found:
            continue
        if sidecar is not None:
            problems += _sidecar_contradictions(path, sidecar, read, protocol, stimuli)
            problems += _refresh_record(path, sidecar, protocol)
            problems += _block_order(path, sidecar, read, design)
            problems += _trial_order(path, sidecar, read, design)
        problems += _name_contradictions(path, read, sidecar, protocol.study)
        if len({(row["participant"], row["session"]) for row in read}) > 1:
            problems.append(
                f"{path}: rows of {len({row['participant'] for row in read})} participants or "
                "sessions in one file; a session file holds one participant's session"
            )
        problems += _trial_sequence(path, read)
        if len(problems) > found:
            continue
        problems += _recorded_trials(path, sidecar, read)
        if sidecar is not None:
            problems += _runs_record(path.with_suffix(".json"), sidecar)
        if len(problems) > found or unvouched:
            continue
        session = _session(path, read, sidecar)
        sessions.append(session)
        if session["pilot"]:
            pilots.append(session)
            if not include_pilots:
                continue
        ended = session["status"] in ("completed", "no sidecar")
        if not (read and ended) and not include_aborted:
            why = "holds no trials" if not read else f"did not complete ({session['status']})"
            problems.append(
                f"{path}: the session {why}; --include-aborted analyses the sessions that did "
                "not complete and skips those without trials, and the report lists them"
            )
            continue
        if not read:
            continue
        # named after every other check: an edited row is also named for what it breaks
        edited += _row_digests(path, sidecar, read)
        files.append(str(path))
        rows += read
        text = path.read_text(encoding="utf-8-sig")  # the cells as written, for _trials_of
        cells = csv.DictReader(io.StringIO(text, newline=""))
        keys.append((path, read[0]["participant"], read[0]["session"], _trials_of(cells)))
        # named after the values no session can write (paradigm.check), which a replay of the
        # staircase would only echo as a step out of place
        replayed += _paradigm_session_checks(paradigm, path, read, sidecar, protocol)
        if sidecar is not None:
            sidecars[str(path)] = sidecar
    problems += _one_stimulus_set(sidecars)
    problems += _same_trials_twice(keys)
    if problems:
        raise DataError(problems + edited)
    if not rows and pilots and not include_pilots:
        names = ", ".join(Path(s["file"]).name for s in pilots)
        raise DataError(
            [
                f"every session given is a pilot ({names}); pilot sessions are left out of "
                "the analysis unless --include-pilots"
            ]
        )
    trials = pd.DataFrame(rows)
    if trials.empty:
        raise DataError([f"{', '.join(s['file'] for s in sessions)}: no trials"])
    problems += _several_sessions(trials)
    if problems:
        raise DataError(problems + edited)
    # the analysis sees the trials in the order of their own numbers, whatever the order of
    # the files or of their rows (a spreadsheet's sort changes nothing)
    trials["_order"] = trials["participant"].map(str)
    trials = trials.sort_values(["_order", "session", "trial"], kind="stable")
    trials = trials.drop(columns="_order").reset_index(drop=True)
    problems += _blocks(trials, design)
    problems += paradigm.check(trials, protocol)
    problems += replayed + edited
    analysed = trials[trials["block"] == design.block] if design.block else trials
    excluded: dict[str, str] = {}
    factors = list(design.factors)
    # every participant, also one with no trial in the analysed block (a session aborted
    # during training): they miss every cell
    for participant in sorted(trials["participant"].unique(), key=str):
        group = analysed[analysed["participant"] == participant]
        counts = group.groupby(factors).size()
        for cell in design.cells:
            if counts.get(cell if len(cell) > 1 else cell[0], 0) == 0:
                cell_where = dict(zip(factors, cell, strict=True))
                message = f"participant {participant} has no trial at {cell_where}"
                if exclude_incomplete:
                    excluded.setdefault(participant, message)
                else:
                    problems.append(
                        message
                        + " (incomplete design; --exclude-incomplete drops such participants "
                        "and the report lists them)"
                    )
                    break
        if design.one_trial_per_cell and (counts > 1).any():
            twice = counts[counts > 1]
            cell = twice.index.tolist()[0]  # plain values (not numpy's np.int64(4))
            at = dict(zip(factors, cell if isinstance(cell, tuple) else (cell,), strict=True))
            problems.append(
                f"participant {participant} has {int(twice.iloc[0])} trials at {at}: "
                "unbalanced design"
            )
    if problems:
        raise DataError(problems)
    kept = trials[~trials["participant"].isin(excluded)].reset_index(drop=True)
    if kept.empty:
        raise DataError(
            [
                f"every participant ({len(excluded)}) misses a cell of the design and was "
                "excluded (--exclude-incomplete): nothing is left to analyse; "
                + "; ".join(excluded.values())
            ]
        )
    unchecked = [
        Path(s["file"]).name for s in sessions if s["sidecar"] and not s["rows_checked"]
        and s["file"] in files
    ]  # fmt: skip
    if unchecked:
        warnings.warn(
            f"{len(unchecked)} session(s) of a data format before {ROW_DIGESTS_SINCE} record "
            "no row digests, so an edit of their rows since the session cannot be seen; the "
            f"report lists them: {', '.join(unchecked)}",
            stacklevel=2,
        )
    return Dataset(
        study=protocol.study,
        trials=kept,
        files=files,
        sidecars=sidecars,
        excluded=excluded,
        sessions=sessions,
        pilots=pilots,
        pilots_included=include_pilots,
        flags=paradigm.flags(kept, protocol),
    )


_WHO = ("study", "participant", "session")  # not what a participant did


_Name = TypeVar("_Name")
TIME_TOLERANCE_S = 0.001  # a time re-saved to the millisecond is the same time
NUMBER_TOLERANCE = 1e-9  # relative: a spreadsheet's re-save to 10 significant digits


class _Trials:
    """What a session's participant did, to know it again under another participant id or
    session (:func:`_trials_of`): its rows without who and which session, in a canonical
    order, the text cells as written and the numbers as numbers."""

    def __init__(self, shape: tuple, numbers: list[float], is_time: list[bool]) -> None:
        self.shape = shape  # columns, rows and text cells: equal in two copies (hashable)
        self.numbers = numbers
        self.is_time = is_time

    def same(self, other: _Trials) -> bool:
        """The same trials, numbers to :data:`NUMBER_TOLERANCE` and times to
        :data:`TIME_TOLERANCE_S` (a re-save to 10 significant digits or the millisecond)."""
        if self.shape != other.shape:
            return False
        for a, b, time in zip(self.numbers, other.numbers, self.is_time, strict=True):
            allowed = TIME_TOLERANCE_S if time else NUMBER_TOLERANCE * max(abs(a), abs(b))
            if abs(a - b) > allowed + 1e-12:
                return False
        return True


def _is_time(column: str) -> bool:
    return column == "onset_s" or column.endswith("time_s")


def _trials_of(rows) -> _Trials | None:
    """A session's :class:`_Trials` from its rows (mappings of column to cell text, in any
    order); None where the times do not tell two people apart: no time recorded, or every
    time within :data:`TIME_TOLERANCE_S` of the others (``--set time_s=0``), as answers
    alone, which two people may well give alike. Times (``onset_s``, ``time_s``, a
    question's ``…_time_s``) recorded to the millisecond are no two people's alike."""
    table = []
    for row in rows:
        if not any(row.values()):  # a row of empty cells a spreadsheet left
            continue
        cells = []  # a ragged row of a file not a session's (csv.DictReader: None, lists) too
        for k, v in sorted(row.items(), key=lambda item: str(item[0])):
            if k in _WHO:
                continue
            number = _finite(v) if isinstance(v, str) else None
            cells.append((str(k), repr(v) if not isinstance(v, str) else v, number))
        table.append(cells)
    # rows by their numbers and text (a spreadsheet's sort keeps each row's cells)
    table.sort(key=lambda cells: [(k, n is None, n if n is not None else t) for k, t, n in cells])
    times = [n for cells in table for k, _, n in cells if n is not None and _is_time(k)]
    if not times or max(times) - min(times) <= TIME_TOLERANCE_S:
        return None
    shape = tuple(tuple((k, None if n is not None else t) for k, t, n in cells) for cells in table)
    numbers = [n for cells in table for _, _, n in cells if n is not None]
    is_time = [_is_time(k) for cells in table for k, _, n in cells if n is not None]
    return _Trials(shape, numbers, is_time)


def _finite(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _twin(trials: _Trials | None, earlier: Sequence[tuple[_Name, _Trials | None]]) -> _Name | None:
    """The first of ``earlier`` (pairs of what to name and its trials) with the same trials."""
    if trials is None:
        return None
    return next((name for name, other in earlier if other and trials.same(other)), None)


def _same_trials_twice(keys: list[tuple[Path, str, int, _Trials | None]]) -> list[str]:
    """Sessions of two participants whose trials are the same, cell for cell and times
    included (:func:`_trials_of`): one person's session imported or copied twice under two
    ids (a file and its spreadsheet re-save) would count as two people. (Two files of one
    participant are named by :func:`_several_sessions`, whatever their trials.)"""
    problems = []
    for i, (path, participant, session, trials) in enumerate(keys):
        others = [((p, who, s), t) for p, who, s, t in keys[:i] if who != participant]
        twin = _twin(trials, others)
        if twin is not None:
            problems.append(
                f"{path}: its trials are those of {twin[0]}, cell for cell (times to the "
                f"millisecond), as participant {participant}'s session {session} and "
                f"participant {twin[1]}'s session {twin[2]}: one person's session imported or "
                "copied twice under two ids (a file and its spreadsheet re-save?); no two "
                "people answer to the millisecond alike: give one of the two files"
            )
    return problems


def _several_sessions(trials: pd.DataFrame) -> list[str]:
    """A participant's trials come from one session file: name the files of a participant
    given twice (the same CSV twice, a copy, or two sessions)."""
    problems = []
    spread = trials.groupby("participant")[["_file", "session"]].agg(
        lambda column: list(dict.fromkeys(column))
    )
    for participant, (in_files, numbers) in spread.iterrows():
        if len(in_files) < 2:
            continue
        listed = ", ".join(
            f"{name} (session {trials.loc[trials['_file'] == name, 'session'].iloc[0]})"
            for name in in_files
        )
        what = "the same session" if len(numbers) == 1 else f"{len(numbers)} sessions"
        problems.append(
            f"participant {participant}: {what} in {len(in_files)} files: {listed}; the "
            "analysis takes one session per participant (the same CSV given twice, a copy, or "
            "a second session?): give one of them"
        )
    return problems


def _blocks(trials: pd.DataFrame, design: Design) -> list[str]:
    """Trials in a block no session of the protocol writes (``Training`` for ``training``)."""
    problems = []
    unknown = trials[~trials["block"].isin(design.blocks)]
    for _, row in unknown.head(20).iterrows():
        problems.append(
            f"{where(row)}, column block: {row['block']!r} is not a block of this protocol "
            f"({', '.join(design.blocks)})"
        )
    return problems
