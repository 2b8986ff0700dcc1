"""A grid of protocol parameters: ``--set KEY=V1,V2,…`` for each key varied, every
combination of their values one protocol, each validated as a protocol file is.

**Keys** are the protocol's dotted paths, as ``glarelab protocol keys`` lists them:
``stimulus.disk_deg``, ``glare.l_dmax_cd_m2``, ``observer.glow_gain``. A list of tables
(``[[glare.methods]]``, ``[[contexts]]``) is entered by the ``name`` of one of its tables
(``glare.methods.vos.levels_cd_m2``, ``contexts.lamp.background.peak_cd_m2``) or by its
position from 0 (``glare.methods[1].parameters.regime``), as the protocol's error messages
number them. A position on the last key sets one element of a list
(``glare.methods.vos.levels_cd_m2[5]``). Free-form tables (a model's ``parameters``, the
``[observer]`` table) take new keys; everywhere else an unknown key is refused by the
protocol's validation, which names it.

**Values** are TOML values separated by commas (the text after ``=`` read as the elements of a
TOML array): ``0.2,0.3,0.5``, ``"photopic","mesopic"``, ``[220,4000],[220,7000]``, ``true,false``.
Bare words without quotes are taken as strings (``photopic,mesopic``) when the text has no
brackets, braces or quotes.
"""

from __future__ import annotations

import copy
import itertools
import re
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from glarelab.files.inputs import read_input_text
from glarelab.protocols import ProtocolError, parse_protocol, protocol_path

__all__ = ["GridError", "Point", "Setting", "apply_setting", "grid", "parse_setting"]

_SEGMENT = re.compile(r"^(?P<key>[^.\[\]]+)(?:\[(?P<index>[^\[\]]*)\])?$")


class GridError(ValueError):
    """A ``--set`` that cannot be applied, or a grid point that is not a valid protocol."""


@dataclass(frozen=True)
class Setting:
    """One key of the grid and its values.

    Attributes
    ----------
    key
        The protocol's dotted path (module docstring), such as ``stimulus.disk_deg``.
    values
        The values it takes, in the key's own unit, at least one.

    Raises
    ------
    GridError
        For a key that is not a dotted path, no values, or a value given twice.
    """

    key: str
    values: tuple

    def __post_init__(self) -> None:
        _segments(self.key)
        if not self.values:
            raise GridError(f"--set {self.key}: no values")
        for index, value in enumerate(self.values):
            for earlier in self.values[:index]:  # 6 and 6.0 are one value; true and 1 are not
                if earlier == value and isinstance(earlier, bool) == isinstance(value, bool):
                    raise GridError(
                        f"--set {self.key}: the value {value!r} is given twice (values "
                        f"{', '.join(map(repr, self.values))}); each grid value once, or the "
                        "grid builds the same protocol twice"
                    )


@dataclass(frozen=True)
class Point:
    """One protocol of the grid: its number, the value of each key varied, the protocol.

    Attributes
    ----------
    index
        The point's number in the grid, from 0.
    values
        Key → the value it has at this point.
    protocol : glarelab.protocols.Protocol
        The protocol with these values, validated.
    """

    index: int
    values: dict
    protocol: Any


def _segments(key: str) -> list[tuple[str, str | None]]:
    if not isinstance(key, str) or not key:
        raise GridError(
            f"--set: the key must be a dotted path such as stimulus.disk_deg; got {key!r}"
        )
    segments = []
    for part in key.split("."):
        match = _SEGMENT.match(part)
        if not match:
            raise GridError(
                f"--set {key}: {part!r} is not a key (a name, optionally with [position]) "
                "of a dotted path such as glare.methods[1].levels_cd_m2"
            )
        segments.append((match["key"], match["index"]))
    return segments


def _value(text: str):
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_setting(text: str) -> Setting:
    """``KEY=V1,V2,…`` as a :class:`Setting` (module docstring).

    Parameters
    ----------
    text
        The ``--set`` argument.

    Returns
    -------
    Setting
        The key and its values.

    Raises
    ------
    GridError
        For text without ``=``, a key that is not a dotted path, or values that are not TOML.

    Examples
    --------
    >>> parse_setting("stimulus.disk_deg=0.2,0.3,0.5")
    Setting(key='stimulus.disk_deg', values=(0.2, 0.3, 0.5))
    >>> parse_setting("glare.methods.vos.levels_cd_m2=[220, 4000],[220, 7000]").values
    ([220, 4000], [220, 7000])
    >>> parse_setting("glare.methods[1].parameters.regime=photopic,mesopic").values
    ('photopic', 'mesopic')
    """
    if not isinstance(text, str) or "=" not in text:
        raise GridError(f"--set {text!r}: give KEY=V1,V2,… (e.g. stimulus.disk_deg=0.2,0.3)")
    key, _, values = text.partition("=")
    key, values = key.strip(), values.strip()
    try:
        parsed = tomllib.loads(f"v = [{values}]")["v"]
    except tomllib.TOMLDecodeError as error:
        if any(c in values for c in "[]{}\"'"):
            raise GridError(
                f"--set {key}: the values {values!r} are not TOML values separated by commas "
                f"({error})"
            ) from None
        parsed = [_value(item.strip()) for item in values.split(",")]
    if not values or any(v == "" for v in parsed):
        raise GridError(f"--set {key}: empty value in {values!r}")
    return Setting(key, tuple(parsed))


def apply_setting(data: dict, key: str, value) -> None:
    """Set ``key`` (a path of the module docstring) to ``value`` in a protocol's parsed TOML.

    Parameters
    ----------
    data
        The protocol's tables as :mod:`tomllib` reads them; changed in place.
    key
        The dotted path to set.
    value
        Its new value, in the key's unit.

    Raises
    ------
    GridError
        Naming the key: a table name or position that does not exist, a path through a value,
        a path that ends on a table.
    """
    segments = _segments(key)
    node: Any = data
    where = ""
    for number, (name, index) in enumerate(segments):
        last = number == len(segments) - 1
        here = f"{where}.{name}" if where else name
        if isinstance(node, list):  # a list of tables, entered by a table's name
            if index is not None:
                raise GridError(f"--set {key}: {where} is a list of tables; give {where}[{index}]")
            names = [t.get("name") for t in node if isinstance(t, dict)]
            if name not in names:
                raise GridError(
                    f"--set {key}: {where} has no table named {name!r} (names: "
                    f"{', '.join(map(str, names)) or 'none'}; or give a position, {where}[0])"
                )
            if last:
                raise GridError(f"--set {key}: names a whole table; give a key inside it")
            node, where = node[names.index(name)], here
            continue
        if not isinstance(node, dict):
            raise GridError(f"--set {key}: {where} is a value, not a table")
        if last and index is None:
            node[name] = value
            return
        if name not in node:
            if index is not None:
                raise GridError(f"--set {key}: {here} is not in the protocol")
            node[name] = {}
        child = node[name]
        if index is None:
            node, where = child, here
            continue
        if not isinstance(child, list):
            raise GridError(f"--set {key}: {here} is not a list, so [{index}] names nothing")
        try:
            position = int(index)
        except ValueError:
            raise GridError(
                f"--set {key}: [{index}] must be a position from 0 (a table's name goes after "
                f"a dot: {here}.NAME)"
            ) from None
        if not 0 <= position < len(child):
            raise GridError(
                f"--set {key}: {here} has {len(child)} entries, positions 0-{len(child) - 1}; "
                f"got {position}"
            )
        if last:
            child[position] = value
            return
        node, where = child[position], f"{here}[{position}]"
    raise GridError(f"--set {key}: names a table; give a key inside it")  # pragma: no cover


def grid(protocol: str | Path, settings: Sequence[Setting]) -> list[Point]:
    """Every combination of the settings' values applied to a protocol file, each validated.

    Parameters
    ----------
    protocol
        A shipped study's name or a protocol TOML file.
    settings
        The keys varied (:func:`parse_setting`); the first varies slowest.

    Raises
    ------
    GridError
        For a key repeated, a path that does not apply, or a point that does not validate (all
        problems of all points, each with the values that made it).
    """
    keys = [s.key for s in settings]
    if len(set(keys)) != len(keys):
        repeated = sorted({k for k in keys if keys.count(k) > 1})
        raise GridError(f"--set: each key once; repeated {', '.join(repeated)}")
    path = protocol_path(protocol)
    raw = tomllib.loads(read_input_text(path, what="protocol file"))
    points, problems = [], []
    for index, values in enumerate(itertools.product(*(s.values for s in settings))):
        data = copy.deepcopy(raw)
        chosen = dict(zip(keys, values, strict=True))
        for key, value in chosen.items():
            apply_setting(data, key, value)
        label = ", ".join(f"{k} = {v!r}" for k, v in chosen.items())
        try:
            parsed = parse_protocol(
                data, source=f"{path} with {label}", folder=path.resolve().parent
            )
        except ProtocolError as error:
            problems += [f"{label}: {p}" for p in error.problems]
            continue
        points.append(Point(index, chosen, parsed))
    if problems:
        shown = "\n".join(f"  - {p}" for p in problems[:30])
        more = f"\n  … and {len(problems) - 30} more" if len(problems) > 30 else ""
        raise GridError(f"{len(problems)} problem(s) in the grid:\n{shown}{more}")
    return points
