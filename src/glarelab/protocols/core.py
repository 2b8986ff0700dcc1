"""Loading a study protocol: a TOML file that names its paradigm and says everything the study
needs, validated on load.

:func:`load_protocol` takes a shipped study's name (``yoshida2008``, a file in this package)
or a path to a TOML file. The ``[study]`` table names the paradigm; the paradigm's schema
(:data:`PARADIGMS`) checks every other key: a missing key, a value of the wrong type or out of
range, and an unknown key (a typo must not fall back to a default) are all reported at once,
each with its key, value and what is allowed; then the paradigm checks the rules between keys.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from glarelab.files.inputs import as_path, read_input_text
from glarelab.files.values import is_real, is_whole
from glarelab.protocols import matching, rating, staircase
from glarelab.protocols.common import display_pixel_deg
from glarelab.protocols.keys import Key, ProtocolError, Schema, Tables, validate

__all__ = [
    "ORDER_FIELDS",
    "PARADIGMS",
    "SHIPPED",
    "Protocol",
    "describe_schema",
    "load_protocol",
    "parse_protocol",
    "pixel_deg",
    "protocol_path",
    "register_paradigm",
    "session_order",
    "shipped_protocols",
]

SHIPPED = Path(__file__).parent  # the protocol files that come with the suite
PARADIGMS: dict[str, ModuleType] = {
    "matching": matching,
    "staircase": staircase,
    "rating": rating,
}
ORDER_FIELDS = ("counterbalance", "trial_order")
"""The sidecar fields in which a session may record its participant's order; each paradigm's
contract names those its sessions write (``SESSION_ORDER``), the others are null."""
STUDY: Schema = {
    "name": Key(str, "the study's name: names its data files and report", token=True),
    "paradigm": Key(str, "how the study is run", choices=tuple(PARADIGMS)),
    "title": Key(str, "title for reports"),
    "seed": Key(int, "seed of every random choice in stimuli and trial orders", low=0),
}


def _study_schema() -> Schema:
    """The ``[study]`` table's keys, its paradigm one of those registered now."""
    return {**STUDY, "paradigm": Key(str, "how the study is run", choices=tuple(PARADIGMS))}


def register_paradigm(name: str, contract: ModuleType | Any) -> None:
    """Register a paradigm's contract: a module (or any object) with ``SCHEMA`` (the protocol's
    keys besides ``[study]``), ``check(validated, problems, folder)`` (the rules between keys),
    ``columns(protocol)`` (the session CSV's columns of the paradigm) and ``SESSION_ORDER``
    (the sidecar fields of :data:`ORDER_FIELDS` in which its sessions record the participant's
    order; the analysis refuses a sidecar giving another of them).

    The other layers register the paradigm in their own registries
    (:mod:`glarelab.stimuli.paradigms`, :mod:`glarelab.experiments.paradigms`,
    :mod:`glarelab.analysis.paradigms`; docs/extending.md).

    Parameters
    ----------
    name
        The paradigm's name: a lower-case identifier, not yet registered.
    contract
        Its contract: an object (usually a module) with ``SCHEMA`` (a mapping), ``check`` and
        ``columns`` (callables) and ``SESSION_ORDER`` (a tuple of :data:`ORDER_FIELDS`).

    Raises
    ------
    ValueError
        For a name already registered or not a lower-case token, or a contract that lacks one
        of the four.
    """
    if not isinstance(name, str) or not name.isidentifier() or name != name.lower():
        raise ValueError(f"paradigm name must be a lower-case identifier; got {name!r}")
    if name in PARADIGMS:
        raise ValueError(f"paradigm {name!r}: already registered in protocols")
    order = getattr(contract, "SESSION_ORDER", None)
    missing = [
        key
        for key, ok in (
            ("SCHEMA", isinstance(getattr(contract, "SCHEMA", None), Mapping)),
            ("check", callable(getattr(contract, "check", None))),
            ("columns", callable(getattr(contract, "columns", None))),
            (
                "SESSION_ORDER",
                isinstance(order, tuple) and set(order) <= set(ORDER_FIELDS),
            ),
        )
        if not ok
    ]
    if missing:
        raise ValueError(
            f"paradigm {name!r}: its contract {contract!r} lacks {', '.join(missing)} (a "
            "paradigm's contract names SCHEMA, check, columns and SESSION_ORDER, a tuple of "
            f"{', '.join(ORDER_FIELDS)})"
        )
    PARADIGMS[name] = contract


def session_order(paradigm: str) -> tuple[str, ...]:
    """The sidecar fields in which a session of ``paradigm`` records its participant's order.

    Parameters
    ----------
    paradigm
        A registered paradigm's name (a protocol's ``paradigm``).

    Returns
    -------
    tuple of str
        Its contract's ``SESSION_ORDER``: some of :data:`ORDER_FIELDS`; a session writes the
        others null.

    Raises
    ------
    ValueError
        For a paradigm not registered here.

    Examples
    --------
    >>> session_order("staircase")
    ('counterbalance',)
    >>> session_order("rating")
    ()
    """
    try:
        return PARADIGMS[paradigm].SESSION_ORDER
    except KeyError:
        raise ValueError(
            f"paradigm {paradigm!r} has no contract registered in "
            f"glarelab.protocols.core.PARADIGMS ({', '.join(sorted(PARADIGMS))})"
        ) from None


class _Refused:
    """Refuse every change of a validated protocol's tables: its hash, its stimulus sets and
    its sessions record what was validated (``protocol.data["viewing"]["distance_m"] = 0.5``
    changed the geometry, not the hash). A copy (``copy.deepcopy``) is plain and changeable."""

    __slots__ = ()

    def _refuse(self, *args, **kwargs):
        raise TypeError(
            "a Protocol's tables cannot be changed (its sha256, stimulus sets and sessions "
            "record the validated protocol): change the protocol file and load it again "
            "(load_protocol), or validate tables of your own (parse_protocol)"
        )


class _Table(_Refused, dict):
    """A table of a validated protocol: a dict that cannot be changed."""

    __slots__ = ()
    __setitem__ = __delitem__ = __ior__ = _Refused._refuse
    clear = pop = popitem = setdefault = update = _Refused._refuse

    def __deepcopy__(self, memo) -> dict:
        return {key: copy.deepcopy(value, memo) for key, value in self.items()}

    def __copy__(self) -> dict:
        return dict(self)

    def __reduce__(self):
        return (_Table, (dict(self),))


class _Array(_Refused, list):
    """An array of a validated protocol: a list that cannot be changed."""

    __slots__ = ()
    __setitem__ = __delitem__ = __iadd__ = __imul__ = _Refused._refuse
    append = clear = extend = insert = pop = remove = reverse = sort = _Refused._refuse

    def __deepcopy__(self, memo) -> list:
        return [copy.deepcopy(value, memo) for value in self]

    def __copy__(self) -> list:
        return list(self)

    def __reduce__(self):
        return (_Array, (list(self),))


def _frozen(value: Any) -> Any:
    """``value`` with every dict and list in it made unchangeable (:class:`_Table`,
    :class:`_Array`): equal to it, read and written to JSON as it is."""
    if isinstance(value, Mapping):
        return _Table({key: _frozen(item) for key, item in value.items()})
    if isinstance(value, list | tuple):
        return _Array(_frozen(item) for item in value)
    return value


@dataclass(frozen=True)
class Protocol:
    """A validated protocol: ``data`` mirrors the file with defaults filled in.

    Made by :func:`load_protocol` and :func:`parse_protocol`; ``protocol["display"]`` reads a
    table of ``data``.

    Parameters
    ----------
    study
        The study's name (``study.name``): it names the data files and the report.
    paradigm
        The paradigm that runs it, a key of :data:`PARADIGMS`.
    data
        Every table of the file, validated, with defaults filled in.
    source
        Where it came from: the file's path, or the name given to :func:`parse_protocol`.
    sha256
        The SHA-256 of ``data`` as canonical JSON (sorted keys): two protocols that say the
        same have the same hash, whatever their layout or comments; stimulus sets and data
        record it.
    folder
        The folder relative paths in the protocol are read from (the file's own); ``None``
        for a protocol made in code.
    """

    study: str
    paradigm: str
    data: dict
    source: str
    sha256: str
    folder: Path | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "data", _frozen(self.data))

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def seed(self) -> int:
        return self.data["study"]["seed"]

    @property
    def title(self) -> str:
        return self.data["study"]["title"]


def _other_paradigm(data: dict, paradigm: str, problems: list[str]) -> str | None:
    """A line naming the paradigm whose schema the file's tables follow, where it is not the
    one ``paradigm`` names: every key known to that one, many unknown to this."""
    unknown = sum("unknown key" in p for p in problems)
    if unknown < 3:
        return None
    for other, module in PARADIGMS.items():
        if other == paradigm:
            continue
        theirs: list[str] = []
        validate(data, {"study": _study_schema(), **module.SCHEMA}, "", theirs)
        if not any("unknown key" in p for p in theirs):
            return (
                f"paradigm = {paradigm!r}, but the file's tables are those of the {other!r} "
                f"paradigm ({unknown} of its keys are unknown to {paradigm!r}, none to "
                f"{other!r}): was the paradigm changed? The problems as {paradigm!r}:"
            )
    return None


def parse_protocol(
    data: Mapping[str, Any], *, source: str = "<protocol>", folder: Path | None = None
) -> Protocol:
    """Validate a protocol given as a mapping (the parsed TOML).

    Parameters
    ----------
    data
        Every table of the protocol, as :mod:`tomllib` reads it; ``study.paradigm`` selects
        the paradigm whose schema the rest follows.
    source
        The name of the protocol in messages and in :attr:`Protocol.source`; default
        ``'<protocol>'``.
    folder
        Where relative paths in the protocol (a background EXR) are found; default ``None``:
        the working folder.

    Returns
    -------
    Protocol
        The validated protocol.

    Raises
    ------
    ProtocolError
        Listing every problem: unknown and missing keys, wrong types, values out of range.
    """
    if not isinstance(data, Mapping):
        raise ProtocolError(
            source,
            [f"the protocol is a {type(data).__name__}; must be a table (a mapping of keys)"],
        )
    study_table = data.get("study")
    paradigm = study_table.get("paradigm") if isinstance(study_table, Mapping) else None
    if not isinstance(paradigm, str) or paradigm not in PARADIGMS:
        raise ProtocolError(
            source,
            [
                f"study.paradigm = {paradigm!r}: must be one of "
                f"{', '.join(repr(p) for p in PARADIGMS)}"
            ],
        )
    module = PARADIGMS[paradigm]
    problems: list[str] = []
    validated = validate(data, {"study": _study_schema(), **module.SCHEMA}, "", problems)
    if problems:  # a file of another paradigm whose `paradigm` was changed: say so first
        hint = _other_paradigm(data, paradigm, problems)
        if hint:
            problems.insert(0, hint)
    if not problems:
        _check_shipped_name(validated["study"], problems)
        module.check(validated, problems, folder)
    if problems:
        raise ProtocolError(source, problems)
    canonical = json.dumps(validated, sort_keys=True, separators=(",", ":"))
    return Protocol(
        study=validated["study"]["name"],
        paradigm=paradigm,
        data=validated,
        source=source,
        sha256=hashlib.sha256(canonical.encode()).hexdigest(),
        folder=folder,
    )


def _shipped_paradigms() -> dict[str, str]:
    """Each shipped study's name, case-folded, and its paradigm (read from its ``[study]``)."""
    paradigms = {}
    for path in SHIPPED.glob("*.toml"):
        try:
            study = tomllib.loads(path.read_text(encoding="utf-8")).get("study", {})
        except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
            continue  # a broken shipped file is the shipped-protocol tests' to report
        name, paradigm = study.get("name"), study.get("paradigm")
        if isinstance(name, str) and isinstance(paradigm, str):
            paradigms[name.casefold()] = paradigm
    return paradigms


def _check_shipped_name(study: Mapping[str, Any], problems: list[str]) -> None:
    """A study named like a shipped study must be of its paradigm: a lab's copy keeps the
    name, but sessions and reports of another paradigm under it would read as that study's
    (its files are named after it)."""
    name, paradigm = study["name"], study["paradigm"]
    shipped = _shipped_paradigms().get(name.casefold())
    if shipped is not None and shipped != paradigm:
        problems.append(
            f"study.name = {name!r}: the name of the shipped {shipped!r} study, but "
            f"study.paradigm = {paradigm!r}; must be a name of its own (not one of the shipped "
            f"studies of another paradigm: their data files and reports are named after them)"
        )


def shipped_protocols() -> list[str]:
    """The names of the protocols that come with the suite."""
    return sorted(p.stem for p in SHIPPED.glob("*.toml"))


def protocol_path(name: str | Path) -> Path:
    """A path to a TOML file, or the shipped protocol of that name.

    Parameters
    ----------
    name
        A path (a :class:`~pathlib.Path`, text ending in ``.toml`` or with a folder in it, or
        an existing file), taken as it is; or the name of a shipped protocol
        (:func:`shipped_protocols`: the TOML files of ``src/glarelab/protocols/``, without
        the suffix), also where a folder of that name is in the working folder.

    Returns
    -------
    pathlib.Path
        The path, not checked to exist when ``name`` is a path.

    Raises
    ------
    FileNotFoundError
        If ``name`` is neither a path nor a shipped protocol's name.
    ValueError
        If ``name`` is a shipped protocol's name and a file of the working folder.
    """
    path = as_path(name, what="protocol")
    text = str(name)
    if (
        isinstance(name, Path)
        or path.suffix == ".toml"
        or "/" in text
        or os.sep in text
        or len(path.parts) > 1
    ):
        return path
    shipped = SHIPPED / f"{name}.toml"
    if shipped.is_file():
        if path.exists() and not path.is_dir():  # a folder is never a protocol: its output?
            raise ValueError(
                f"protocol {text!r}: both a shipped protocol and a file in {Path.cwd()}; give "
                f"./{text} for the file, or name the shipped one from another folder"
            )
        return shipped
    if path.exists():
        return path
    raise FileNotFoundError(
        f"no protocol {str(name)!r}: give a TOML file or one of the shipped protocols "
        f"({', '.join(shipped_protocols())})"
    )


def load_protocol(path: str | Path) -> Protocol:
    """Read and validate a protocol TOML file (a path, or a shipped protocol's name).

    Parameters
    ----------
    path
        A TOML file, or the name of a shipped protocol (:func:`protocol_path`). The file is
        read as UTF-8 (a byte-order mark is allowed); relative paths in it are read from its
        folder.

    Returns
    -------
    Protocol
        The validated protocol.

    Raises
    ------
    ProtocolError
        For a file that is not valid TOML or does not follow its paradigm's schema.
    FileNotFoundError
        If there is no such file.

    Examples
    --------
    >>> p = load_protocol("yoshida2008")
    >>> p.study, p.paradigm, p["glare"]["methods"][0]["labels"][0]
    ('yoshida2008', 'matching', 'A')
    """
    path = protocol_path(path)
    text = read_input_text(path, what="protocol file")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ProtocolError(str(path), [toml_problem(text, error)]) from None
    except RecursionError:
        raise ProtocolError(str(path), [NESTED_TOO_DEEPLY]) from None
    try:
        return parse_protocol(data, source=str(path), folder=path.resolve().parent)
    except RecursionError:
        raise ProtocolError(str(path), [NESTED_TOO_DEEPLY]) from None


_TOML_PLACE = re.compile(r"\(at line (\d+), column (\d+)\)")
_TOML_BARE_OR_QUOTED = r"""(?:[A-Za-z0-9_-]+|"[^"]*"|'[^']*')"""
_TOML_KEY = re.compile(rf"^\s*({_TOML_BARE_OR_QUOTED}(?:\s*\.\s*{_TOML_BARE_OR_QUOTED})*)\s*=")
_TOML_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\[\]]+?)\s*(\]\]?)\s*(?:#.*)?$")
_TOML_TABLE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?\s*(?:#.*)?$")


def toml_problem(text: str, error: tomllib.TOMLDecodeError) -> str:
    """The TOML parser's complaint about ``text``, with the key it was reading when the line
    holds one (``glare.methods.name``), and what to do about a string cut by a newline.

    Parameters
    ----------
    text
        The protocol's text.
    error
        What :func:`tomllib.loads` raised for it.

    Returns
    -------
    str
        One problem, for :class:`ProtocolError`.

    Examples
    --------
    >>> text = '[study]\\nname = "yoshida\\n2008"\\n'
    >>> try:
    ...     tomllib.loads(text)
    ... except tomllib.TOMLDecodeError as error:
    ...     problem = toml_problem(text, error)
    >>> problem.split(": ")[0], "use triple quotes" in problem
    ('study.name (line 2)', True)
    """
    message = f"not valid TOML: {error}"
    place = _TOML_PLACE.search(str(error))
    if place is None:
        return message
    number = int(place.group(1))
    lines = text.splitlines()
    line = lines[number - 1] if 0 < number <= len(lines) else ""
    if "Illegal character '\\n'" in str(error):
        message += (
            "; a quoted string ends on the line it starts on: close its quote there, or use "
            "triple quotes for text of several lines"
        )
    header = _TOML_HEADER.match(line)
    if header is not None:  # [X] where [[X]] is meant, or the other way round
        name = re.sub(r"\s*\.\s*", ".", header.group(2))
        single = {f"[{name}]", f"[[{name}]]"} - {f"{header.group(1)}{name}{header.group(3)}"}
        other = next(
            (
                index
                for index, earlier in enumerate(lines, start=1)
                if (found := _TOML_HEADER.match(earlier))
                and re.sub(r"\s*\.\s*", ".", found.group(2)) == name
                and found.group(1) != header.group(1)
            ),
            None,
        )
        if other is not None:
            return (
                f"{name} (line {number}): headed {header.group(1)}{name}{header.group(3)} here "
                f"and {single.pop()} on line {other}; a list of tables heads every entry "
                f"[[{name}]], a single table [{name}] once ({message})"
            )
    key = _TOML_KEY.match(line)
    if key is None:
        return message
    table = next(
        (
            found.group(1)
            for earlier in reversed(lines[: number - 1])
            if (found := _TOML_TABLE.match(earlier))
        ),
        None,
    )
    name = re.sub(r"\s*\.\s*", ".", key.group(1))
    return f"{table + '.' if table else ''}{name} (line {number}): {message}"


NESTED_TOO_DEEPLY = "arrays or tables nested too deeply (a protocol nests a few levels)"


def with_monitor(
    protocol: Protocol,
    *,
    name: str,
    resolution_px: tuple[int, int] | None = None,
    width_cm: float | None = None,
    distance_cm: float | None = None,
) -> Protocol:
    """The protocol with its display's geometry taken from a PsychoPy Monitor Center monitor
    ``name``: its size in pixels (``display.resolution_px``), its width (the pixel pitch,
    ``display.pixel_pitch_mm = 10 × width_cm / width_px``, square pixels) and the viewing
    distance (``viewing.distance_m``); None keeps the protocol's. Validated as any protocol;
    its source names the monitor.

    Raises
    ------
    ValueError
        For a protocol without a display, or values the protocol's keys do not allow.

    Examples
    --------
    >>> p = with_monitor(load_protocol("yoshida2008"), name="lab", resolution_px=(1920, 1080),
    ...                  width_cm=53.0, distance_cm=57.0)
    >>> p["display"]["resolution_px"], p["display"]["pixel_pitch_mm"], p["viewing"]["distance_m"]
    ([1920, 1080], 0.2760416666666667, 0.57)
    """
    if not protocol.data.get("display"):
        raise ValueError(f"--monitor {name}: the {protocol.study} protocol has no display")
    data = json.loads(json.dumps(protocol.data))  # a deep copy of the validated tables
    display = data["display"]
    if resolution_px is not None:  # not int(): 1920.5 was cut to 1920, '1920' read
        if (
            isinstance(resolution_px, str | bytes)
            or not hasattr(resolution_px, "__len__")  # a tuple, list or array
            or len(resolution_px) != 2
            or not all(is_whole(v) and v >= 1 for v in resolution_px)
        ):
            raise ValueError(
                f"--monitor {name}: resolution_px must be two whole numbers of pixels >= 1 "
                f"(width, height); got {resolution_px!r}"
            )
        display["resolution_px"] = [int(v) for v in resolution_px]
    for option, value in (("width_cm", width_cm), ("distance_cm", distance_cm)):
        if value is not None and not (is_real(value) and math.isfinite(value) and value > 0):
            raise ValueError(f"--monitor {name}: {option} must be a number > 0; got {value!r}")
    if width_cm is not None:
        display["pixel_pitch_mm"] = float(width_cm) * 10.0 / display["resolution_px"][0]
        display["diagonal_in"] = None
    if distance_cm is not None:
        data["viewing"]["distance_m"] = float(distance_cm) / 100.0
    for table in ("display", "viewing"):  # keys left at their defaults need not be given
        data[table] = {k: v for k, v in data[table].items() if v is not None}
    scene = getattr(PARADIGMS[protocol.paradigm], "SCENE", None)
    if scene and isinstance(data.get("scene"), dict):  # as the file gave it: a scene refuses
        data["scene"] = {  # some keys only where given (a live scene's frame_rate_hz)
            k: v
            for k, v in data["scene"].items()
            if k not in scene or scene[k].required or v != scene[k].default
        }
    try:
        return parse_protocol(
            data,
            source=f"{protocol.source} with PsychoPy Monitor Center monitor {name!r}",
            folder=protocol.folder,
        )
    except ProtocolError as error:
        raise ValueError(f"--monitor {name}: {error}") from None


def pixel_deg(protocol: Protocol) -> float:
    """Visual angle of one display pixel at the viewing distance, degrees.

    Parameters
    ----------
    protocol
        A protocol whose ``[display]`` and ``viewing.distance_m`` give the geometry
        (:func:`glarelab.protocols.common.display_pixel_deg`).

    Returns
    -------
    float
        Degrees per pixel.

    Examples
    --------
    >>> round(pixel_deg(load_protocol("yoshida2008")), 5)
    0.01182
    """
    return display_pixel_deg(protocol["display"], protocol["viewing"]["distance_m"])


def describe_schema(paradigm: str) -> list[tuple[str, str, str, str, str]]:
    """Rows ``(key, unit, default, allowed, description)`` of a paradigm's schema, for docs.

    Parameters
    ----------
    paradigm
        A key of :data:`PARADIGMS`.

    Returns
    -------
    list of tuple of str
        One row per key, in schema order, ``[study]`` first: the dotted key (``[[name]]`` for
        a list of tables, ``name[].key`` for its keys), its unit, its default (``required``
        if none), what is allowed and what it means.

    Raises
    ------
    ValueError
        If ``paradigm`` is not a known paradigm.
    """
    if paradigm not in PARADIGMS:
        raise ValueError(f"paradigm must be one of {', '.join(PARADIGMS)}; got {paradigm!r}")
    rows = []

    def walk(schema: Schema, prefix: str) -> None:
        for name, spec in schema.items():
            path = f"{prefix}.{name}" if prefix else name
            if isinstance(spec, Tables):
                default = "required" if spec.required else repr(spec.default)
                low, high = spec.length
                rows.append((f"[[{path}]]", "", default, f"{low}-{high} tables", spec.doc))
                walk(spec.schema, f"{path}[]")
            elif isinstance(spec, Mapping):
                walk(spec, path)
            else:
                default = "required" if spec.required else repr(spec.default)
                rows.append((path, spec.unit, default, spec.allowed(), spec.doc))

    walk({"study": _study_schema(), **PARADIGMS[paradigm].SCHEMA}, "")
    return rows
