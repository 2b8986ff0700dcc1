"""Reading session CSVs: every cell checked, every problem named, nothing dropped silently.

The columns are the protocol's (:func:`glarelab.protocols.columns`), the ones the experiments
write; files written before a column was added (its ``since``) are read with that column missing. A
problem is reported with its file, line and column; all problems of all files are collected
and raised together (:class:`DataError`). A design with a missing cell is refused naming the
participant and the cell, unless the caller asks to exclude incomplete participants, in which
case they are excluded and listed (the report shows the list).
"""

from __future__ import annotations

import csv
import io
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
from glarelab.protocols import columns
from glarelab.protocols.keys import TOKEN

# the numbers a session CSV holds, as format_value writes them (int() and float() also read
# "2_50" as 250 and surrounding spaces)
_INTEGER = re.compile(r"[+-]?\d+")
_NUMBER = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf|infinity)", re.I)

__all__ = ["DataError", "Dataset", "load_sessions", "where"]

# columns added after the first data format, as files written before them are read: every
# trial of those files counted (no presentation was repeated); the others are missing
LEGACY_DEFAULTS = {"counted": True}


class DataError(ValueError):
    """Problems in the input data, each naming file, line and column."""

    def __init__(self, problems: list[str]):
        self.problems = problems
        shown = "\n".join(f"  - {p}" for p in problems[:50])
        more = f"\n  … and {len(problems) - 50} more" if len(problems) > 50 else ""
        super().__init__(f"{len(problems)} problem(s) in the data:\n{shown}{more}")


@dataclass
class Dataset:
    """Validated trials of one study: ``trials`` (typed DataFrame), the sidecars, and the
    participants excluded as incomplete (with why)."""

    study: str
    trials: pd.DataFrame
    files: list[str]
    sidecars: dict[str, dict] = field(default_factory=dict)
    excluded: dict[str, str] = field(default_factory=dict)
    sessions: list[dict] = field(default_factory=list)

    @property
    def incomplete_sessions(self) -> list[dict]:
        """The sessions that did not complete (aborted, interrupted, header only), analysed or
        skipped at the caller's request: the report lists them."""
        return [
            s
            for s in self.sessions
            if s["trials"] == 0 or s["status"] not in ("completed", "no sidecar")
        ]


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
            if not _INTEGER.fullmatch(cell):  # int() reads "2_50" as 250 and " 7" as 7
                raise ValueError
            value = int(cell)
        elif column.kind is float:
            if not _NUMBER.fullmatch(cell):  # float() reads "2_50" as 250.0
                raise ValueError
            value = float(cell)
        elif column.name == "participant" and not TOKEN.match(cell):
            problems.append(
                f"{where}: {cell!r} is not a participant id (letters, digits, '_', '-', '.'; "
                "no spaces or line breaks)"
            )
            return None
        else:
            value = cell
    except ValueError:
        problems.append(f"{where}: {cell!r} is not a {column.kind.__name__} ({column.doc})")
        return None
    if column.choices is not None and value not in column.choices:
        problems.append(f"{where}: {cell!r} is not one of {', '.join(column.choices)}")
        return None
    if isinstance(value, int | float) and not isinstance(value, bool):
        if (
            value != value
            or (column.low is not None and value < column.low)
            or (column.high is not None and value > column.high)
        ):
            low = "-inf" if column.low is None else column.low
            high = "inf" if column.high is None else column.high
            bounds = f"[{low}, {high}]"
            problems.append(
                f"{where}: {cell!r} is outside {bounds}{' ' + column.unit if column.unit else ''}"
            )
            return None
    return value


def _read_file(path: Path, protocol, problems: list[str]) -> list[dict]:
    study = protocol.study
    expected = columns(protocol)
    names = [c.name for c in expected]
    rows = []
    try:  # utf-8-sig: a spreadsheet's "CSV UTF-8" starts with a byte-order mark
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        problems.append(f"{path}: not UTF-8 text ({error.reason} at byte {error.start})")
        return rows
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader, None)
        if header is None:
            problems.append(f"{path}: empty file, no header")
            return rows
        twice = sorted({n for n in header if header.count(n) > 1})
        if twice:
            problems.append(
                f"{path}, line 1: column(s) {', '.join(twice)} appear more than once; each "
                "column must appear once (which one holds the data?)"
            )
            return rows
        added = {c.name for c in expected if c.since != "0.1"}  # older files lack these
        missing = [n for n in names if n not in header and n not in added]
        extra = [n for n in header if n not in names]
        if missing or extra:
            first = dict(zip(header, next(reader, []), strict=False))
            other = first.get("study")
            problems.append(
                f"{path}, line 1: columns do not match the {study} schema"
                + (
                    f" (its study column says {other!r}: a CSV of another study?)"
                    if other and other != study
                    else ""
                )
                + (f"; missing {missing}" if missing else "")
                + (f"; unexpected {extra}" if extra else "")
            )
            return rows
        for line, cells in enumerate(reader, start=2):
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
                c.name: _parse(
                    record[c.name], c, f"{path}, line {line}, column {c.name}", problems
                )
                if c.name in record
                else LEGACY_DEFAULTS.get(c.name)
                for c in expected
            }
            parsed["_file"], parsed["_line"] = str(path), line
            rows.append(parsed)
    except csv.Error as error:  # e.g. a cell over the csv module's field size limit
        problems.append(f"{path}, line {reader.line_num}: not readable as CSV ({error})")
    return rows


def _sidecar_contradictions(path: Path, sidecar: dict, rows: list[dict], protocol) -> list[str]:
    """Where a session's sidecar disagrees with its CSV or the protocol (a file of another
    session or study put beside it, or edited by hand)."""
    problems = []
    if sidecar.get("study") != protocol.study:
        problems.append(
            f"{path}: study {sidecar.get('study')!r}, but the data are analysed as "
            f"{protocol.study!r}"
        )
    if not isinstance(sidecar.get("simulated"), bool):
        problems.append(
            f"{path}: simulated is {sidecar.get('simulated')!r}; must be true or false"
        )
    for key in ("participant", "session"):
        values = {str(row.get(key)) for row in rows}
        if rows and values != {str(sidecar.get(key))}:
            problems.append(
                f"{path}: {key} {sidecar.get(key)!r}, but its CSV's rows say "
                f"{', '.join(sorted(values))}"
            )
    return problems


def _session(path: Path, rows: list[dict], sidecar: dict | None) -> dict:
    """What the report says of one session file: who, how many trials, how it ended."""
    first = rows[0] if rows else {}
    status = "no sidecar" if sidecar is None else str(sidecar.get("status", "unknown"))
    return {
        "file": str(path),
        "participant": first.get("participant", (sidecar or {}).get("participant")),
        "session": first.get("session", (sidecar or {}).get("session")),
        "trials": len(rows),
        "status": status if rows or sidecar is not None else "header only",
        "sidecar": sidecar is not None,
        "simulated": None if sidecar is None else bool(sidecar.get("simulated")),
    }


def load_sessions(
    protocol,
    paths: list[str | Path],
    *,
    exclude_incomplete: bool = False,
    include_aborted: bool = False,
) -> Dataset:
    """Load and validate session CSVs of one study (its protocol sets the columns, the design
    and the values a trial can hold).

    Parameters
    ----------
    protocol
        The study's validated protocol.
    paths
        Session CSV files; each one's JSON sidecar (same name) is read where it exists.
    exclude_incomplete
        Drop participants with a missing design cell (listed in ``Dataset.excluded``) instead
        of refusing the data.
    include_aborted
        Analyse sessions that did not complete (their sidecar says aborted or running) and
        skip files without trials, instead of refusing them; either way they are listed in
        ``Dataset.sessions`` for the report.

    Raises
    ------
    DataError
        Naming file, line and column of every bad cell; values the protocol or its display
        cannot produce; duplicated trials; a CSV of another study; sessions that did not
        complete or hold no trials (unless ``include_aborted``); and (unless
        ``exclude_incomplete``) every participant missing a design cell.
    """
    problems: list[str] = []
    rows: list[dict] = []
    sidecars: dict[str, dict] = {}
    sessions: list[dict] = []
    files = []
    if not paths:
        raise DataError(["no CSV files given"])
    for raw in paths:
        path = Path(raw)
        if not path.is_file():
            problems.append(f"{path}: no such file")
            continue
        found = len(problems)
        read = _read_file(path, protocol, problems)
        sidecar_path = path.with_suffix(".json")
        sidecar = None
        if sidecar_path.is_file():
            try:
                sidecar = json.loads(sidecar_path.read_text())
            except (json.JSONDecodeError, UnicodeDecodeError) as error:
                problems.append(f"{sidecar_path}: not valid JSON ({error})")
            else:
                if not isinstance(sidecar, dict):
                    problems.append(f"{sidecar_path}: a sidecar must be a JSON object")
                    sidecar = None
        if sidecar is not None:
            problems += _sidecar_contradictions(sidecar_path, sidecar, read, protocol)
        if len(problems) > found:
            continue
        session = _session(path, read, sidecar)
        sessions.append(session)
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
        files.append(str(path))
        rows += read
        if sidecar is not None:
            sidecars[str(path)] = sidecar
    if problems:
        raise DataError(problems)
    trials = pd.DataFrame(rows)
    if trials.empty:
        raise DataError([f"{', '.join(s['file'] for s in sessions)}: no trials"])
    from glarelab.analysis.paradigms import PARADIGMS

    problems += PARADIGMS[protocol.paradigm].check(trials, protocol)
    key = ["participant", "session", "trial"]
    spread = trials.groupby(["participant", "session"])["_file"].unique()
    for (participant, session), in_files in spread.items():
        if len(in_files) > 1:  # one line, not one per trial
            problems.append(
                f"participant {participant}, session {session} is in {len(in_files)} files: "
                f"{', '.join(map(str, in_files))} (the same CSV given twice, or a copy?)"
            )
    twice = {pair for pair, in_files in spread.items() if len(in_files) > 1}
    duplicated = trials[trials.duplicated(key, keep="first")]
    duplicated = duplicated[
        [
            pair not in twice
            for pair in zip(duplicated["participant"], duplicated["session"], strict=True)
        ]
    ]
    for _, row in duplicated.iterrows():
        problems.append(
            f"{row['_file']}, line {row['_line']}: duplicated trial (participant "
            f"{row['participant']}, session {row['session']}, trial {row['trial']})"
        )
    factors, cells, block = PARADIGMS[protocol.paradigm].design(protocol)
    analysed = trials[trials["block"] == block] if block else trials
    excluded: dict[str, str] = {}
    # every participant, also one with no trial in the analysed block (a session aborted
    # during training): they miss every cell
    for participant in sorted(trials["participant"].unique(), key=str):
        group = analysed[analysed["participant"] == participant]
        counts = group.groupby(factors).size()
        for cell in cells:
            if counts.get(cell if len(cell) > 1 else cell[0], 0) == 0:
                where = dict(zip(factors, cell, strict=True))
                message = f"participant {participant} has no trial at {where}"
                if exclude_incomplete:
                    excluded.setdefault(participant, message)
                else:
                    problems.append(
                        message
                        + " (incomplete design; --exclude-incomplete drops such participants "
                        "and the report lists them)"
                    )
                    break
        if protocol.paradigm != "staircase" and (counts > 1).any():
            cell = counts[counts > 1].index[0]
            problems.append(
                f"participant {participant} has {counts.max()} trials at {cell}: unbalanced design"
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
    return Dataset(
        study=protocol.study,
        trials=kept,
        files=files,
        sidecars=sidecars,
        excluded=excluded,
        sessions=sessions,
    )


def where(row) -> str:
    """The file and line of a trial, as problems name them."""
    return f"{row['_file']}, line {row['_line']}"
