"""The protocol file format's building blocks: keys with type, unit, default and range, tables
of keys, and lists of tables; and their validation, which reports every problem at once, each
with its key, its value and what is allowed.

No other module of the suite is imported here.
"""

from __future__ import annotations

import datetime
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

__all__ = ["TOKEN", "Key", "ProtocolError", "Schema", "Tables", "check_token", "validate"]

# a label that is safe in a file name and a CSV cell: letters, digits, '_', '-', '.'
TOKEN = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}\Z")  # \Z: "$" admits a final newline


class ProtocolError(ValueError):
    """A protocol file that does not validate; ``problems`` lists every finding.

    Parameters
    ----------
    source
        Where the protocol came from (its file, or a name for one built in code), the
        message's first word.
    problems
        Every problem found, one line each, naming the key, its value and what is allowed.
    """

    def __init__(self, source: str, problems: list[str]):
        self.source = source
        self.problems = problems
        lines = "\n".join(f"  - {p}" for p in problems)
        super().__init__(f"{source}: {len(problems)} problem(s) in the protocol:\n{lines}")


@dataclass(frozen=True)
class Key:
    """One key of a protocol schema.

    ``kind`` is ``float``, ``int``, ``str``, ``bool``, ``list`` or ``dict`` (a free-form table,
    checked by whoever reads it); lists give ``item`` (the kind of their elements) and
    optionally ``length``. Numbers may have ``low``/``high`` bounds (inclusive); strings and
    numbers may have ``choices``; ``token`` strings must be file-name-safe labels. A key with
    ``default`` is optional.

    Parameters
    ----------
    kind
        The type of the value: ``float``, ``int``, ``str``, ``bool``, ``list`` or ``dict``.
    doc
        What the key means, for the error messages and ``docs/protocols.md``.
    unit
        The unit of a number (``'deg'``, ``'cd/m²'``, ``'m'``); empty (default) for none.
    low, high
        Inclusive bounds of a number (or of a list's numbers), in ``unit``; default ``None``:
        unbounded.
    choices
        The values allowed; default ``None``: any of ``kind``.
    default
        The value of a key the file leaves out; default ``...``: the key is required.
    item
        The type of a list's elements; default ``None``: not checked.
    length
        A list's length, or its ``(shortest, longest)`` range; default ``None``: any.
    token
        Whether a string (or a list's strings) must be a file-name-safe label (:data:`TOKEN`);
        default ``False``.
    unique
        Whether a list's elements must all differ (strings ignoring case, as file names on
        macOS and Windows do); default ``False``.
    ascending
        Whether a list's numbers must rise strictly from first to last (its order numbers the
        levels the data and the report name, 1 the lowest); default ``False``.
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
    token: bool = False
    unique: bool = False
    ascending: bool = False

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
            if self.ascending:
                what += ", ascending"
            elif self.unique:
                what += ", all different"
            parts.append(what)
        elif self.kind is dict:
            parts.append("a table")
        else:
            parts.append(self.kind.__name__)
        if self.token:
            parts.append("letters, digits, '_', '-', '.' (a file-name-safe label)")
        if self.choices:
            parts.append("one of " + ", ".join(repr(c) for c in self.choices))
        if self.low is not None or self.high is not None:
            low = "-inf" if self.low is None else f"{self.low:g}"
            high = "inf" if self.high is None else f"{self.high:g}"
            parts.append(f"in [{low}, {high}]{' ' + self.unit if self.unit else ''}")
        return ", ".join(parts)


@dataclass(frozen=True)
class Tables:
    """A list of tables (``[[name]]`` in TOML), each following ``schema``.

    Parameters
    ----------
    schema
        The keys of each table: :class:`Key`, :class:`Tables` or nested tables, by name.
    doc
        What the tables are, for the error messages and ``docs/protocols.md``.
    length
        The ``(fewest, most)`` tables allowed; default ``(1, 100)``.
    default
        The value when the file has none; default ``...``: required.
    """

    schema: Mapping
    doc: str
    length: tuple[int, int] = (1, 100)
    default: Any = ...

    @property
    def required(self) -> bool:
        return self.default is ...


Schema = Mapping[str, "Key | Tables | Schema"]


def check_token(value: str, where: str, problems: list[str]) -> bool:
    """Whether ``value`` is a file-name-safe label; if not, say so.

    Parameters
    ----------
    value
        The label: 1-64 letters, digits, ``_``, ``-`` or ``.``, starting with a letter or
        digit (:data:`TOKEN`).
    where
        The key it is the value of, for the message (``'study.name'``).
    problems
        The list the problem is appended to.

    Returns
    -------
    bool
        Whether ``value`` is a label.
    """
    if isinstance(value, str) and TOKEN.match(value):
        return True
    problems.append(
        f"{where} = {value!r}: must be 1-64 letters, digits, '_', '-' or '.', starting with a "
        "letter or digit (it names files and CSV cells)"
    )
    return False


def _dates_in(value: Any, path: str) -> list[str]:
    """The keys under ``value`` (a free-form table) that hold a TOML date or time."""
    if isinstance(value, datetime.date | datetime.time):
        return [f"{path} = {value.isoformat()}"]
    if isinstance(value, Mapping):
        return [d for k, v in value.items() for d in _dates_in(v, f"{path}.{k}")]
    if isinstance(value, list | tuple):
        return [d for i, v in enumerate(value) for d in _dates_in(v, f"{path}[{i}]")]
    return []


def _check_scalar(value: Any, kind: type, key: Key, path: str, problems: list[str]) -> Any:
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            problems.append(f"{path} = {value!r}: must be a number ({key.allowed()})")
            return None
        try:
            value = float(value)
        except OverflowError:  # an integer of hundreds of digits
            digits = int(value.bit_length() * math.log10(2)) + 1
            problems.append(
                f"{path} = an integer of {digits} digits: must be finite ({key.allowed()})"
            )
            return None
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
        if key.token and not check_token(value, path, problems):
            return None
    elif kind is dict:
        if not isinstance(value, Mapping):
            problems.append(f"{path} = {value!r}: must be a table")
            return None
        dated = _dates_in(value, path)
        if dated:
            problems.append(
                f"{dated[0]}: a TOML date or time is not a protocol value; write it as a "
                "string (in quotes)"
            )
            return None
        return dict(value)
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
    if key.item and any(i is None for i in items):
        return None
    # case folded: labels name files, and macOS's and Windows's file names ignore case
    folded = [v.casefold() if isinstance(v, str) else v for v in items]
    if key.unique and len(set(folded)) != len(folded):
        repeated = sorted(
            {v for v, f in zip(items, folded, strict=True) if folded.count(f) > 1}, key=str
        )
        folding = " (ignoring case)" if any(isinstance(v, str) for v in items) else ""
        problems.append(
            f"{path} repeats {', '.join(map(repr, repeated))}: must be all different{folding}"
        )
        return None
    if key.ascending and any(b <= a for a, b in pairwise(items)):
        problems.append(f"{path} = {items!r}: must be {key.allowed()} (each above the one before)")
        return None
    return items


def validate(data: Mapping[str, Any], schema: Schema, path: str, problems: list[str]) -> dict:
    """``data`` checked against ``schema`` with defaults filled in; problems appended.

    Parameters
    ----------
    data
        One table of the protocol as read from TOML.
    schema
        Its keys: :class:`Key`, :class:`Tables` or nested tables, by name.
    path
        The table's dotted name, prefixed to each key in the messages; ``''`` at the top.
    problems
        The list every problem is appended to (unknown keys, missing keys, wrong types,
        values out of range), so that one pass reports them all.

    Returns
    -------
    dict
        Every key of ``schema``: the checked value, its default where ``data`` leaves it out,
        or ``None`` where the value is wrong.
    """
    result: dict[str, Any] = {}
    for name in data:
        if name not in schema:
            where = f"{path}.{name}" if path else name
            known = ", ".join(sorted(schema))
            problems.append(f"{where}: unknown key (known here: {known})")
    for name, spec in schema.items():
        where = f"{path}.{name}" if path else name
        if isinstance(spec, Tables):
            result[name] = _tables(data.get(name), spec, where, problems)
        elif isinstance(spec, Mapping):
            table = data.get(name)
            if table is None and _all_optional(spec):
                table = {}  # every key has a default: the table left out is the defaults
            if table is None:
                problems.append(f"[{where}]: missing table")
                continue
            if not isinstance(table, Mapping):
                problems.append(f"{where} = {table!r}: must be a table [{where}]")
                continue
            result[name] = validate(table, spec, where, problems)
        elif name in data:
            result[name] = _check_key(data[name], spec, where, problems)
        elif spec.required:
            problems.append(f"{where}: missing ({spec.doc}; {spec.allowed()})")
        else:
            result[name] = spec.default
    return result


def _all_optional(schema: Mapping) -> bool:
    """Whether every key of a table (and of the tables in it) has a default."""
    for spec in schema.values():
        if isinstance(spec, Tables | Key):
            if spec.required:
                return False
        elif isinstance(spec, Mapping):
            if not _all_optional(spec):
                return False
    return True


def _tables(value: Any, spec: Tables, where: str, problems: list[str]) -> list[dict] | None:
    if value is None:
        if spec.required:
            problems.append(f"[[{where}]]: missing ({spec.doc})")
            return None
        return spec.default
    if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
        problems.append(f"{where}: must be a list of tables [[{where}]] ({spec.doc})")
        return None
    low, high = spec.length
    if not low <= len(value) <= high:
        problems.append(f"[[{where}]] has {len(value)} entries: must have {low}-{high}")
        return None
    return [validate(v, spec.schema, f"{where}[{i}]", problems) for i, v in enumerate(value)]
