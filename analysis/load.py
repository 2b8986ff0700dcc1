"""Reading session CSVs: every cell checked, every problem named, nothing dropped silently.

The columns are the protocol's (:func:`protocols.columns`), the ones the experiments write;
files written before a column was added (its ``since``) are read with that column missing. A
problem is reported with its file, line and column; all problems of all files are collected
and raised together (:class:`DataError`). A design with a missing cell is refused naming the
participant and the cell, unless the caller asks to exclude incomplete participants, in which
case they are excluded and listed (the report shows the list).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from protocols import columns

__all__ = ["DataError", "Dataset", "load_sessions"]

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
            value = int(cell)
        elif column.kind is float:
            value = float(cell)
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
    with path.open(newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        header = next(reader, None)
        if header is None:
            problems.append(f"{path}: empty file, no header")
            return rows
        added = {c.name for c in expected if c.since != "0.1"}  # older files lack these
        missing = [n for n in names if n not in header and n not in added]
        extra = [n for n in header if n not in names]
        if missing or extra:
            problems.append(
                f"{path}, line 1: columns do not match the {study} schema"
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
    return rows


def load_sessions(
    protocol, paths: list[str | Path], *, exclude_incomplete: bool = False
) -> Dataset:
    """Load and validate session CSVs of one study (its protocol sets the columns and the
    design).

    Raises
    ------
    DataError
        Naming file, line and column of every bad cell; duplicated trials; a CSV of another
        study; and (unless ``exclude_incomplete``) every participant missing a design cell.
    """
    problems: list[str] = []
    rows: list[dict] = []
    sidecars: dict[str, dict] = {}
    files = []
    if not paths:
        raise DataError(["no CSV files given"])
    for raw in paths:
        path = Path(raw)
        if not path.is_file():
            problems.append(f"{path}: no such file")
            continue
        files.append(str(path))
        rows += _read_file(path, protocol, problems)
        sidecar = path.with_suffix(".json")
        if sidecar.is_file():
            try:
                sidecars[str(path)] = json.loads(sidecar.read_text())
            except json.JSONDecodeError as error:
                problems.append(f"{sidecar}: not valid JSON ({error})")
    if problems:
        raise DataError(problems)
    trials = pd.DataFrame(rows)
    if trials.empty:
        raise DataError([f"{', '.join(files)}: no trials"])
    key = ["participant", "session", "trial"]
    duplicated = trials[trials.duplicated(key, keep="first")]
    for _, row in duplicated.iterrows():
        problems.append(
            f"{row['_file']}, line {row['_line']}: duplicated trial (participant "
            f"{row['participant']}, session {row['session']}, trial {row['trial']})"
        )
    from .paradigms import PARADIGMS

    factors, cells, block = PARADIGMS[protocol.paradigm].design(protocol)
    analysed = trials[trials["block"] == block] if block else trials
    excluded: dict[str, str] = {}
    for participant, group in analysed.groupby("participant"):
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
    return Dataset(
        study=protocol.study, trials=kept, files=files, sidecars=sidecars, excluded=excluded
    )
