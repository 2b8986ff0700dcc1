"""Data a PsychoPy experiment collected, made into glarelab session files for ``analyse``.

A Builder or Coder experiment that records a study's trials with PsychoPy's
``ExperimentHandler`` writes one wide CSV per run (``saveAsWideText``): a row per
``nextEntry()``, the columns it was given (``addData``), and columns of its own that a glarelab
session file does not have: ``thisRow.t``, ``notes``, each loop's ``LOOP.thisRepN``,
``LOOP.thisTrialN``, ``LOOP.thisN``, ``LOOP.thisIndex``, the experiment's info (``date``,
``expName``, ``psychopyVersion``, ``frameRate``, ``expStart``), each component's ``.started``
and ``.stopped``, and a last column with no name (every row ends with the delimiter).
Booleans are Python's ``True``/``False``; the file may begin with a byte-order mark.

:func:`import_psychopy` maps such a file to the study's session format
(:func:`glarelab.protocols.columns`) and writes it as a session of its own (CSV and sidecar,
named ``PARTICIPANT_STUDY_sN_YYYY-MM-DD_HHMM`` from PsychoPy's ``date``) that
:func:`glarelab.analysis.load.load_sessions` then checks like any other: every cell, every
trial. The mapping is explicit and its result is said, never silent:

- a column takes the study column of the same name, or the one ``columns`` maps it to
  (``{"key_resp.rt": "time_s"}``);
- every other column is dropped and listed (PsychoPy's own bookkeeping apart from the rest);
- rows with no trial data (a routine outside the trial loop, such as instructions, ends with
  ``nextEntry()`` too, and an outer loop of blocks ends each block with a row of its ``block``
  alone) are dropped and counted;
- ``True``/``False`` become ``true``/``false``; an integer column written as ``35.0`` (a float
  PsychoPy was given) becomes ``35``; PsychoPy's zero-padded session (``001``) becomes ``1``;
- the ``study`` column, if the experiment did not record it, is the protocol's (a recorded
  study other than the protocol's is refused, naming its lines); ``trial``, if
  not recorded, numbers the trial rows in the order ``nextEntry`` wrote them: by ``thisRow.t``
  (the experiment's clock at each entry, which Builder's routines record) where every trial row
  has one, so a file sorted in a spreadsheet is put back, else in file order (said);
- a trial row without a value that every trial records (a row outside the loop with a value
  in a mapped column) is refused, naming its line and the value;
  optional columns not recorded are empty; a required column not recorded is refused, unless
  ``values`` gives it one value for every trial (recorded in the sidecar).

Why a separate step and not an option of ``analyse``: the analysis keeps one strict reader of
one format, and the imported sessions are files a lab keeps, inspects and archives beside the
PsychoPy originals, with a sidecar recording where each came from (file, sha256, mapping, what
was dropped).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import re
import tempfile
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import (
    _other_delimiter,
    _parse,
    _Trials,
    _trials_of,
    _twin,
    load_sessions,
)
from glarelab.files.atomic import write_text
from glarelab.files.inputs import input_file, loads_json
from glarelab.protocols import columns
from glarelab.protocols.columns import DATA_FORMAT, row_digest
from glarelab.protocols.keys import TOKEN

__all__ = ["PSYCHOPY_BOOKKEEPING", "Imported", "import_psychopy", "psychopy_bookkeeping"]

# columns PsychoPy's ExperimentHandler and Builder add of their own accord (PsychoPy
# psychopy/data/experiment.py: thisRow.t, notes; psychopy/data/trial.py: a loop's thisRepN,
# thisTrialN, thisN, thisIndex; Builder's expInfo: date, expName, psychopyVersion, frameRate,
# expStart; each component's .started/.stopped and its ...StartTime columns)
PSYCHOPY_BOOKKEEPING = re.compile(
    r"thisRow\.t|notes|date|expName|psychopyVersion|frameRate|expStart|"
    r"(?:.+\.)?(?:thisRepN|thisTrialN|thisN|thisIndex|ran|order)|"
    r".+\.(?:started|stopped|startedRefresh|stoppedRefresh)"
)
_BOOLEANS = {  # Python's, the session format's, and a spreadsheet's re-save (Excel: TRUE)
    "True": "true", "False": "false", "true": "true", "false": "false",
    "TRUE": "true", "FALSE": "false",
}  # fmt: skip
_INTEGRAL = re.compile(r"[+-]?\d+(\.0*)?")
# PsychoPy's data.getDateStr(): 2026-12-03_07h29.22.123, and in older releases
# "%Y_%b_%d_%H%M", 2026_Dec_03_0729, its month abbreviated in English (the C locale)
_DATE = re.compile(r"(\d{4})-(\d{2})-(\d{2})_(\d{2})h(\d{2})")
_OLD_DATE = re.compile(r"(\d{4})_([A-Za-z]{3})_(\d{2})_(\d{2})(\d{2})")
_MONTHS = ("jan", "feb", "mar", "apr", "may", "jun", "jul", "aug", "sep", "oct", "nov", "dec")
_FILLED = ("study", "participant", "session")  # not trial data: the same on every row


def psychopy_bookkeeping(name: str) -> bool:
    """Whether a column is one PsychoPy writes of its own accord.

    Parameters
    ----------
    name
        A column name of a PsychoPy CSV, as written in its header; it must match
        ``PSYCHOPY_BOOKKEEPING`` whole (case-sensitive).

    Returns
    -------
    bool
        True for PsychoPy's own bookkeeping columns (``thisRow.t``, ``notes``, ``date``,
        a loop's ``thisN`` …, a component's ``.started``/``.stopped`` …).

    Examples
    --------
    >>> [psychopy_bookkeeping(n) for n in ("thisRow.t", "trials.thisN", "time_s")]
    [True, True, False]
    """
    return PSYCHOPY_BOOKKEEPING.fullmatch(name) is not None


@dataclass
class Imported:
    """One session made from a PsychoPy CSV: what was written and what was left out.

    Parameters
    ----------
    source
        The PsychoPy CSV the session was read from.
    csv
        The session file written (its sidecar is the same name with ``.json``).
    participant
        The participant code of the session's rows.
    session
        The session number (a whole number).
    trials
        How many trials (rows) the session file holds.
    dropped_bookkeeping
        The source's columns left out because PsychoPy writes them of its own accord
        (:func:`psychopy_bookkeeping`).
    dropped_other
        The source's other columns left out: not in the study's data format.
    dropped_rows
        The line numbers in the source (1 is the header) of rows left out because they hold
        no trial data.
    filled
        Columns of the data format the source lacks, each mapped to what it was given
        (a value given for every trial, the protocol's study, trial numbers in file order,
        or empty).
    """

    source: Path
    csv: Path
    participant: str
    session: int
    trials: int
    dropped_bookkeeping: list[str] = field(default_factory=list)
    dropped_other: list[str] = field(default_factory=list)
    dropped_rows: list[int] = field(default_factory=list)  # their line numbers in the source
    filled: dict[str, str] = field(default_factory=dict)  # column → what it was given

    def summary(self) -> str:
        """One line: source → session file, and what was dropped or filled."""
        parts = [f"{self.source.name} → {self.csv.name}: {self.trials} trials"]
        if self.dropped_bookkeeping:
            parts.append(f"dropped PsychoPy's columns {', '.join(self.dropped_bookkeeping)}")
        if self.dropped_other:
            parts.append(
                f"dropped columns not in the study's format {', '.join(self.dropped_other)}"
            )
        if self.dropped_rows:
            lines = ", ".join(map(str, self.dropped_rows[:8]))
            more = " …" if len(self.dropped_rows) > 8 else ""
            parts.append(
                f"dropped {len(self.dropped_rows)} rows without trial data (lines {lines}{more})"
            )
        if self.filled:
            parts.append("filled " + ", ".join(f"{k} ({v})" for k, v in self.filled.items()))
        return "; ".join(parts)


def _cell(value: str, column) -> str:
    """A PsychoPy cell written as the session format writes it (the loader checks it)."""
    if column.kind is bool:
        return _BOOLEANS.get(value, value)
    if column.kind is int and _INTEGRAL.fullmatch(value):
        return str(int(float(value))) if "." in value else str(int(value))
    return value


def _psychopy_date(value: str) -> datetime | None:
    """A ``date`` cell as either of PsychoPy's formats wrote it, else None."""
    match = _DATE.fullmatch(value.split(".")[0])
    if match:
        numbers = [int(part) for part in match.groups()]
    else:
        match = _OLD_DATE.fullmatch(value)
        if not match or match[2].lower() not in _MONTHS:
            return None
        numbers = [int(match[1]), _MONTHS.index(match[2].lower()) + 1]
        numbers += [int(part) for part in match.groups()[2:]]
    try:
        return datetime(*numbers)
    except ValueError:  # 2026-02-30, 25h: not a date PsychoPy writes
        return None


def _glarelab_session(source: Path) -> Path | None:
    """The sidecar beside ``source`` if it is a session glarelab ran (or imported), else None."""
    sidecar = source.with_suffix(".json")
    try:
        data = loads_json(sidecar.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if isinstance(data, dict) and {"data_format", "runs", "status"} <= set(data):
        return sidecar
    return None


def _clock(text: str) -> float | datetime | None:
    """A ``thisRow.t`` as Builder writes it: seconds of the experiment's clock, or with its
    clock set to wall-clock time, an ISO date and time; None for anything else."""
    try:
        seconds = float(text)
    except ValueError:
        try:
            moment = datetime.fromisoformat(text.strip())
        except ValueError:
            return None
        return moment.timestamp() if moment.tzinfo else moment
    return seconds if math.isfinite(seconds) else None


def _psychopy_order(
    rows: list[tuple[int, dict[str, str]]],
) -> tuple[list[tuple[int, dict[str, str]]], str]:
    """The rows of a file that records no trial number, in the order PsychoPy wrote them:
    by ``thisRow.t`` (the experiment clock at each entry, increasing as they are written) where
    every row has one, so a file sorted in a spreadsheet is put back; else in file order. The
    second value says which, for the import's summary."""
    times = []
    for _, record in rows:
        moment = _clock(record.get("thisRow.t", ""))
        if moment is None:
            return rows, "numbered in file order (no thisRow.t on every row to order them by)"
        times.append(moment)
    if len({type(t) for t in times}) > 1:  # seconds and wall-clock times: no one order
        return rows, "numbered in file order (thisRow.t in two formats)"
    order = sorted(range(len(rows)), key=times.__getitem__)  # stable: ties keep file order
    moved = "" if order == list(range(len(rows))) else ", the file's rows having been moved"
    return [
        rows[i] for i in order
    ], f"numbered in the order PsychoPy wrote them (thisRow.t){moved}"


def _started(rows: list[dict[str, str]], source: Path) -> tuple[datetime, str | None]:
    """When the run started, and why not by PsychoPy's ``date`` if it is not.

    The first row whose ``date`` is one of PsychoPy's formats dates the run; with none, the
    file's modification time does, and the second value says so, naming a ``date`` that is
    there in another format (a spreadsheet's re-save)."""
    for row in rows:
        started = _psychopy_date(row.get("date", ""))
        if started is not None:
            return started, None
    started = datetime.fromtimestamp(source.stat().st_mtime)
    other = next((row["date"] for row in rows if row.get("date")), None)
    found = f"its 'date' {other!r} is not PsychoPy's" if other is not None else "no PsychoPy date"
    return started, (
        f"the file's modification time, {started:%Y-%m-%d %H:%M}: {found} "
        "(a 'date' column as 2026-12-03_07h29.22 or, from older PsychoPy releases, "
        "2026_Dec_03_0729)"
    )


def _read(source: Path, problems: list[str]) -> tuple[list[str], list[tuple[int, list[str]]]]:
    try:  # a named pipe or a device is refused before it is opened: reading one may not end
        input_file(source, what="PsychoPy file")
    except (OSError, ValueError) as error:
        problems.append(str(error))
        return [], []
    try:
        text = source.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        problems.append(f"{source}: not readable as UTF-8 text ({error})")
        return [], []
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    try:
        records = [(reader.line_num, cells) for cells in reader]
    except csv.Error as error:
        problems.append(f"{source}, line {reader.line_num}: not readable as CSV ({error})")
        return [], []
    if not records:
        problems.append(f"{source}: empty file, no header")
        return [], []
    return records[0][1], [(line, cells) for line, cells in records[1:] if cells]


def import_psychopy(
    protocol,
    sources: list[str | Path],
    out: str | Path,
    *,
    mapping: dict[str, str] | None = None,
    values: dict[str, str] | None = None,
) -> list[Imported]:
    """Write glarelab session files (CSV and sidecar) from PsychoPy ExperimentHandler CSVs.

    Parameters
    ----------
    protocol
        The study's validated protocol: its columns are the session format.
    sources
        PsychoPy CSVs (``ExperimentHandler.saveAsWideText``), one run each; a file with the
        trials of several participants or sessions gives one session file each.
    out
        The folder for the session files (made if missing); existing files are not replaced.
    mapping
        PsychoPy column → study column, for columns the experiment named otherwise.
    values
        Study column → one value for every trial, for a required column the experiment did not
        record (e.g. ``{"dropped_frames": "0"}``); recorded in the sidecar.

    Returns
    -------
    list of Imported
        One per session written, with what was dropped and filled.

    Raises
    ------
    glarelab.analysis.dataset.DataError
        Naming every problem of every file (nothing is written then): a mapping from a column
        the file lacks or to a column the study does not have, a required column neither
        recorded nor given, a value given for a column the file records (the participant
        stays the one the experiment recorded), two columns mapped to one, a participant id
        that cannot name a file, a session file that exists already, a last column with no
        name that holds data, a study recorded on a trial row that is not the protocol's,
        trials equal to another session's of the import or of ``out`` (times included), a
        session glarelab ran (its sidecar beside it, or exactly a session file's columns), a
        glarelab report's ``trials.csv`` (a session file's columns and ``file``), and what
        the analysis refuses in a session read alone (its own loader,
        :func:`glarelab.analysis.load.load_sessions`: a rating outside the scale, a category
        the study does not have), named at the source's line.
    ValueError
        If ``out`` is a file, not a folder (nothing is read or written).

    Examples
    --------
    >>> import tempfile
    >>> from glarelab.protocols import load_protocol
    >>> folder = Path(tempfile.mkdtemp())
    >>> names = [c.name for c in columns(load_protocol("yoshida2008"))]
    >>> _ = (folder / "run.csv").write_text(",".join(names) + ",thisRow.t,notes,\\n")
    >>> import_psychopy(load_protocol("yoshida2008"), [folder / "run.csv"], folder / "out")
    []
    """
    if Path(out).exists() and not Path(out).is_dir():
        raise ValueError(
            f"--out {out} is a file; the imported session files go into a folder (give a "
            "folder's path, new or existing)"
        )
    mapping = dict(mapping or {})
    values = dict(values or {})
    schema = columns(protocol)
    by_name = {c.name: c for c in schema}
    problems: list[str] = []
    for target in [*mapping.values(), *values]:
        if target not in by_name:
            problems.append(
                f"{target!r} is not a column of the {protocol.study} session format "
                f"({', '.join(by_name)})"
            )
    twice = sorted({t for t in mapping.values() if list(mapping.values()).count(t) > 1})
    if twice:
        problems.append(f"several PsychoPy columns mapped to {', '.join(twice)}")
    for name, value in values.items():  # read as the analysis will read every row's cell
        if name in by_name:
            _parse(value, by_name[name], f"--set {name}={value}", problems)
    if problems:
        raise DataError(problems)
    out = Path(out)
    planned: list[tuple[Imported, str, dict]] = []
    lines_of: dict[Path, list[int]] = {}  # each session file's rows: their source lines
    for raw in sources:
        source = Path(raw)
        found = len(problems)
        header, records = _read(source, problems)
        own = _glarelab_session(source)
        if own is not None:  # its pilot, simulated and status marks would be lost
            problems.append(
                f"{source}: a glarelab session file (its sidecar {own.name} is beside it, "
                "recording a session glarelab ran): give it to glarelab analyse as it is; "
                "import-psychopy takes the CSV PsychoPy's ExperimentHandler wrote"
            )
            continue
        if header == [c.name for c in schema]:  # exactly a session file's columns, no more
            problems.append(
                f"{source}: a glarelab session file's columns, exactly (its sidecar missing?): "
                "PsychoPy's files add columns of their own (thisRow.t, notes, a loop's thisN); "
                "a session glarelab ran is analysed with its sidecar, never imported"
            )
            continue
        if "file" in header and sorted(n for n in header if n != "file") == sorted(
            c.name for c in schema
        ):  # a report's trials.csv: the session columns and the session file of each row
            at = header.index("file")
            named = list(dict.fromkeys(c[at] for _, c in records if len(c) > at and c[at]))
            shown = ", ".join(named[:3]) + (f" … ({len(named)} files)" if len(named) > 3 else "")
            problems.append(
                f"{source}: a glarelab report's table of trials (the session files' columns and "
                f"'file', the session file each row was analysed from: {shown or 'none'}): "
                "give glarelab analyse the session files it names, with their sidecars; "
                "import-psychopy takes the CSV PsychoPy's ExperimentHandler wrote"
            )
            continue
        if len(problems) > found or not header:
            continue
        # the empty last column: every row of saveAsWideText ends with the delimiter
        while header and header[-1] == "":
            if any(len(cells) == len(header) and cells[-1] != "" for _, cells in records):
                problems.append(
                    f"{source}, line 1: the last column has no name but holds data; name it"
                )
                break
            header.pop()
            records = [(line, cells[: len(header)]) for line, cells in records]
        if len(problems) > found:
            continue
        duplicated = sorted({n for n in header if header.count(n) > 1})
        if duplicated:
            problems.append(f"{source}, line 1: column(s) {', '.join(duplicated)} appear twice")
            continue
        delimiter = _other_delimiter(header)
        if delimiter:
            problems.append(f"{source}, line 1: not comma-separated{delimiter}")
            continue
        absent = [name for name in mapping if name not in header]
        if absent:
            problems.append(f"{source}, line 1: no column {', '.join(absent)} to map")
            continue
        renamed = [mapping.get(name, name) for name in header]
        taken = [n for n in renamed if n in by_name]
        clash = sorted({n for n in taken if taken.count(n) > 1})
        if clash:
            problems.append(
                f"{source}, line 1: two columns give {', '.join(clash)} (one by its name, one "
                "mapped to it); map or drop one"
            )
            continue
        recorded = [name for name in values if name in taken]
        if recorded:  # --set is for what was not recorded: never over the file's own values
            problems.extend(
                f"{source}, line 1: --set {name}={values[name]}: the file records {name!r} "
                f"(column {header[renamed.index(name)]!r}); --set gives a value only to a "
                "column the experiment did not record (correct the recorded values in the file)"
                for name in recorded
            )
            continue
        filled: dict[str, str] = {}
        for column in schema:
            if column.name in taken:
                continue
            if column.name in values:
                filled[column.name] = f"given: {values[column.name]!r}"
            elif column.name == "study":
                filled["study"] = f"the protocol's: {protocol.study}"
            elif column.name == "trial":
                pass  # numbered below, in the order PsychoPy wrote the rows
            elif column.optional:
                filled[column.name] = "empty (not recorded)"
            else:
                problems.append(
                    f"{source}, line 1: no column {column.name!r} ({column.doc}); map the "
                    f"experiment's column to it (--column PSYCHOPY={column.name}) or give it "
                    f"one value for every trial (--set {column.name}=VALUE)"
                )
        if len(problems) > found:
            continue
        dropped = [h for h, n in zip(header, renamed, strict=True) if n not in by_name]
        rows: list[tuple[int, dict[str, str]]] = []
        empty_rows: list[int] = []
        # the block alone is no trial: an outer loop (Builder's blocks) ends with a row of it
        data_columns = [n for n in taken if n not in _FILLED and n != "block"]
        for line, cells in records:
            if len(cells) != len(header):
                problems.append(
                    f"{source}, line {line}: {len(cells)} cells, the header has {len(header)}"
                )
                continue
            record = dict(zip(renamed, cells, strict=True))
            if all(record[n] == "" for n in data_columns):
                empty_rows.append(line)
                continue
            rows.append((line, record))
        if "trial" not in taken:  # numbered in the order PsychoPy wrote the rows
            rows, how = _psychopy_order(rows)
            filled["trial"] = how
        sessions: dict[tuple[str, str], list[tuple[int, dict[str, str]]]] = {}
        originals = [
            dict(zip(header, cells, strict=True))
            for _, cells in records
            if len(cells) == len(header)
        ]
        for name in ("participant", "session"):  # not recorded: --set gives it (or nothing)
            for _, record in rows if name not in taken else ():
                record[name] = values.get(name, "")
        if "study" in taken:  # the analysis refuses every row of another study: said now
            others: dict[str, list[int]] = {}
            for line, record in rows:
                if record["study"] not in ("", protocol.study):  # empty: named below
                    others.setdefault(record["study"], []).append(line)
            for value, lines in others.items():
                shown = ", ".join(map(str, lines[:8])) + (" …" if len(lines) > 8 else "")
                problems.append(
                    f"{source}, line{'s' if len(lines) > 1 else ''} {shown}, column "
                    f"{header[renamed.index('study')]!r}: {value!r}, not {protocol.study!r}: "
                    "trials of another study? Import a file with the protocol of the study "
                    "it records"
                )
        never = [
            n for n in ("participant", "session") if rows and all(r[n] == "" for _, r in rows)
        ]
        for name in never:  # the experiment info's field left empty: no row's own problem
            problems.append(
                f"{source}: no {name} on any trial row (column {header[renamed.index(name)]!r} "
                f"empty: the experiment's info dialog left empty?); write the {name} into the "
                "column"
            )
        for line, record in rows:
            unnamed = [n for n in ("participant", "session") if record[n] == "" and n not in never]
            if unnamed:  # a row outside the trial loop with a value in a trial column?
                given = ", ".join(
                    f"{header[renamed.index(n)]}={record[n]!r}"
                    for n in data_columns
                    if record[n] != ""
                )
                problems.append(
                    f"{source}, line {line}: no {' and no '.join(unnamed)}, which every trial "
                    f"records, but {given} makes it a trial row: a row outside the trial loop "
                    "(instructions) with a value in a trial column? Leave that row's trial "
                    "columns empty, or remove it"
                )
            participant = record.get("participant", "")
            if participant and not TOKEN.match(participant):
                problems.append(
                    f"{source}, line {line}: participant {participant!r} cannot name a session "
                    "file (letters, digits, '_', '-', '.')"
                )
            session = _cell(record.get("session", ""), by_name["session"])
            sessions.setdefault((participant, session), []).append((line, record))
        if len(problems) > found:
            continue
        started, undated = _started(originals, source)
        if undated is not None:
            filled["started"] = undated
        digest = hashlib.sha256(source.read_bytes()).hexdigest()
        version = next((r["psychopyVersion"] for r in originals if r.get("psychopyVersion")), None)
        for (participant, session), trial_rows in sessions.items():
            cells_rows = []
            source_lines = []  # each written row's line in the source
            for number, (line, record) in enumerate(trial_rows, start=1):
                row = {}
                for column in schema:
                    if column.name in record:
                        row[column.name] = _cell(record[column.name], column)
                    elif column.name in values:
                        row[column.name] = values[column.name]
                    elif column.name == "study":
                        row[column.name] = protocol.study
                    elif column.name == "trial":
                        row[column.name] = str(number)
                    else:
                        row[column.name] = ""
                empty = [c.name for c in schema if not c.optional and row[c.name] == ""]
                if empty:  # a row outside the trial loop with a value in a mapped column
                    given = ", ".join(
                        f"{header[renamed.index(n)]}={record[n]!r}"
                        for n in data_columns
                        if record.get(n, "") != ""
                    )
                    missing = ", ".join(empty[:4]) + (
                        f" and {len(empty) - 4} more" if len(empty) > 4 else ""
                    )
                    problems.append(
                        f"{source}, line {line}: {given or 'a value'} makes it a trial row, "
                        f"but it has no {missing}, which every trial records: a row outside "
                        "the trial loop (instructions) with a value in a trial column? Leave "
                        "that row's trial columns empty, or remove it"
                    )
                cells_rows.append(row)
                source_lines.append(line)
            if all(_INTEGRAL.fullmatch(r["trial"]) for r in cells_rows):
                # in trial order, as a session writes them: row_sha256 is by trial (trial n at
                # entry n), and a file sorted in a spreadsheet keeps its trials' numbers
                order = sorted(range(len(cells_rows)), key=lambda i: int(cells_rows[i]["trial"]))
                cells_rows = [cells_rows[i] for i in order]
                source_lines = [source_lines[i] for i in order]
            try:
                number = int(session)
            except ValueError:
                problems.append(f"{source}: session {session!r} is not a whole number")
                continue
            stem = f"{participant}_{protocol.study}_s{number}_{started:%Y-%m-%d_%H%M}"
            target = out / f"{stem}.csv"
            earlier = sorted(
                p
                for p in out.glob(f"{participant}_{protocol.study}_s{number}_*.csv")
                if p != target
            )
            if earlier:  # the analysis would refuse the pair as one session in two files
                problems.append(
                    f"{source}: participant {participant}'s session {number} is in "
                    f"{out} already ({earlier[0].name}; imported again, dated by another "
                    "time?): an import never adds a second copy of a session; remove the "
                    "earlier one, or give another --out"
                )
                continue
            for existing in (target, target.with_suffix(".json")):
                if existing.exists():
                    problems.append(
                        f"{existing} exists: an import never replaces a session file (give "
                        "another --out)"
                    )
            trials = [int(r["trial"]) for r in cells_rows if _INTEGRAL.fullmatch(r["trial"])]
            imported = Imported(
                source=source,
                csv=target,
                participant=participant,
                session=number,
                trials=len(cells_rows),
                dropped_bookkeeping=[d for d in dropped if psychopy_bookkeeping(d)],
                dropped_other=[d for d in dropped if not psychopy_bookkeeping(d)],
                dropped_rows=empty_rows,
                filled=filled,
            )
            mapped = {
                h: n for h, n in zip(header, renamed, strict=True) if n in by_name and h != n
            }
            sidecar = {
                "study": protocol.study,
                "participant": participant,
                "session": number,
                "status": "completed",
                "trials": max(trials, default=0),
                "simulated": False,
                "pilot": False,
                "data_format": DATA_FORMAT,
                "protocol_sha256": protocol.sha256,
                "row_sha256": [row_digest(row[c.name] for c in schema) for row in cells_rows],
                "started": started.isoformat(),
                "packages": {"psychopy": version} if version else {},
                "imported_from": {
                    "format": "PsychoPy ExperimentHandler CSV (saveAsWideText)",
                    "file": str(source.resolve()),
                    "sha256": digest,
                    "imported": datetime.now(UTC).isoformat(timespec="seconds"),
                    "mapping": mapped,
                    "filled": filled,
                    "dropped_columns": dropped,
                    "dropped_rows": empty_rows,
                },
            }
            planned.append((imported, _csv_text(schema, cells_rows), sidecar))
            lines_of[imported.csv] = source_lines
    names = [p[0].csv for p in planned]
    for name in sorted({n for n in names if names.count(n) > 1}):
        problems.append(f"{name}: two sessions of the sources would get this name")
    problems += _same_trials(planned, out)
    if not problems:
        problems += _as_analysed(protocol, planned, lines_of)
    if problems:
        raise DataError(problems)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    try:  # every session or none: a full disk must not leave half an import
        for imported, text, sidecar in planned:
            written.append(write_text(imported.csv, text))
            written.append(
                write_text(
                    imported.csv.with_suffix(".json"),
                    json.dumps(sidecar, indent=2, sort_keys=True) + "\n",
                )
            )
    except BaseException:
        for path in written:  # new files (existing names were refused above)
            path.unlink(missing_ok=True)
        raise
    return [p[0] for p in planned]


# the one problem of a session read alone that is no problem of its file: a session cut
# short lacks design cells, which the analysis of the study names (or --exclude-incomplete)
_INCOMPLETE = re.compile(r"^every participant \(\d+\) misses a cell of the design")


def _as_analysed(protocol, planned: list, lines_of: dict[Path, list[int]]) -> list[str]:
    """What ``glarelab analyse`` would refuse in each planned session, read alone by the
    analysis' own loader (``load_sessions``) from a temporary copy: a rating of 4.5, a
    category the study does not have, a staircase step out of place. Named by the source file
    and its line, so that no session is written that the analysis can never read."""
    problems: list[str] = []
    with tempfile.TemporaryDirectory(prefix="glarelab-import-") as folder:
        for imported, text, sidecar in planned:
            copy = Path(folder) / imported.csv.name
            copy.write_text(text, encoding="utf-8")
            copy.with_suffix(".json").write_text(json.dumps(sidecar), encoding="utf-8")
            try:
                load_sessions(protocol, [copy], exclude_incomplete=True, include_pilots=True)
            except DataError as error:
                lines, source = lines_of[imported.csv], imported.source

                def source_line(match: re.Match, lines=lines, source=source) -> str:
                    row = int(match.group(1)) - 2  # the session file's line 1 is its header
                    at = f", line {lines[row]}" if 0 <= row < len(lines) else ""
                    return f"{source}{at}"

                for problem in error.problems:
                    if _INCOMPLETE.match(problem):
                        continue
                    problem = re.sub(re.escape(str(copy)) + r", line (\d+)", source_line, problem)
                    problem = problem.replace(
                        str(copy.with_suffix(".json")), f"{imported.csv.stem}.json (its sidecar)"
                    ).replace(str(copy), f"{imported.source}")
                    problems.append(
                        f"{problem} (participant {imported.participant}, session "
                        f"{imported.session}: the analysis would refuse it; correct the file)"
                    )
            finally:
                copy.unlink(missing_ok=True)
                copy.with_suffix(".json").unlink(missing_ok=True)
    return problems


def _trials_in(text: str) -> _Trials | None:
    """:func:`glarelab.analysis.load._trials_of` of a session file's text: the analysis's
    rule, so that what the import refuses and what the analysis refuses are one."""
    return _trials_of(csv.DictReader(io.StringIO(text, newline="")))


def _same_trials(planned: list, out: Path) -> list[str]:
    """Sessions of this import whose trials equal another's, or a session's already in
    ``out``, times included to the millisecond (no two people answer to the millisecond
    alike): a file and its spreadsheet re-save (participant ``001`` became ``1``) were two
    participants with the same trials."""
    problems: list[str] = []
    earlier: list = []
    for path in sorted(out.glob("*.csv")) if out.is_dir() else []:
        try:
            earlier.append((path.name, _trials_in(path.read_text(encoding="utf-8"))))
        except (OSError, ValueError):
            continue
    seen: list = []
    for imported, text, _ in planned:
        trials = _trials_in(text)
        twin = _twin(trials, seen) or _twin(trials, earlier)
        if twin is not None:
            problems.append(
                f"{imported.source}: its trials are those of {twin}, cell for cell, as "
                f"participant {imported.participant}'s session {imported.session}: a file and "
                "its re-save (a spreadsheet makes 001 into 1)? Import one of them"
            )
        seen.append((imported.source.name, trials))
    return problems


def _csv_text(schema, rows: list[dict[str, str]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([c.name for c in schema])
    for row in rows:
        writer.writerow([row[c.name] for c in schema])
    return buffer.getvalue()
