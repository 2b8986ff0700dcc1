"""Loading a study protocol: a TOML file that names its paradigm and says everything the study
needs, validated on load.

:func:`load_protocol` takes a shipped study's name (``yoshida2008``, a file in this package)
or a path to a TOML file. The ``[study]`` table names the paradigm; the paradigm's schema
(:data:`PARADIGMS`) checks every other key: a missing key, a value of the wrong type or out of
range, and an unknown key (a typo must not fall back to a default) are all reported at once,
each with its key, value and what is allowed; then the paradigm checks the rules between keys.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from glarelab.protocols import matching, rating, staircase
from glarelab.protocols.common import display_pixel_deg
from glarelab.protocols.keys import Key, ProtocolError, Schema, Tables, validate

__all__ = [
    "PARADIGMS",
    "SHIPPED",
    "Protocol",
    "describe_schema",
    "load_protocol",
    "parse_protocol",
    "pixel_deg",
    "protocol_path",
    "shipped_protocols",
]

SHIPPED = Path(__file__).parent  # the protocol files that come with the suite
PARADIGMS: dict[str, ModuleType] = {
    "matching": matching,
    "staircase": staircase,
    "rating": rating,
}
STUDY: Schema = {
    "name": Key(str, "the study's name: names its data files and report", token=True),
    "paradigm": Key(str, "how the study is run", choices=tuple(PARADIGMS)),
    "title": Key(str, "title for reports"),
    "seed": Key(int, "seed of every random choice in stimuli and trial orders", low=0),
}


@dataclass(frozen=True)
class Protocol:
    """A validated protocol: ``data`` mirrors the file with defaults filled in."""

    study: str
    paradigm: str
    data: dict
    source: str
    sha256: str
    folder: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def seed(self) -> int:
        return self.data["study"]["seed"]

    @property
    def title(self) -> str:
        return self.data["study"]["title"]


def parse_protocol(
    data: Mapping[str, Any], *, source: str = "<protocol>", folder: Path | None = None
) -> Protocol:
    """Validate a protocol given as a mapping (the parsed TOML).

    ``folder`` is where relative paths in the protocol (a background EXR) are found.

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
    validated = validate(data, {"study": STUDY, **module.SCHEMA}, "", problems)
    if not problems:
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


def shipped_protocols() -> list[str]:
    """The names of the protocols that come with the suite."""
    return sorted(p.stem for p in SHIPPED.glob("*.toml"))


def protocol_path(name: str | Path) -> Path:
    """A path to a TOML file, or the shipped protocol of that name."""
    path = Path(name)
    if path.suffix == ".toml" or path.exists() or len(path.parts) > 1:
        return path
    shipped = SHIPPED / f"{name}.toml"
    if shipped.is_file():
        return shipped
    raise FileNotFoundError(
        f"no protocol {str(name)!r}: give a TOML file or one of the shipped protocols "
        f"({', '.join(shipped_protocols())})"
    )


def load_protocol(path: str | Path) -> Protocol:
    """Read and validate a protocol TOML file (a path, or a shipped protocol's name).

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
    if not path.is_file():
        raise FileNotFoundError(f"no protocol file at {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise ProtocolError(str(path), [f"not valid TOML: {error}"]) from None
    except RecursionError:
        raise ProtocolError(str(path), [NESTED_TOO_DEEPLY]) from None
    try:
        return parse_protocol(data, source=str(path), folder=path.resolve().parent)
    except RecursionError:
        raise ProtocolError(str(path), [NESTED_TOO_DEEPLY]) from None


NESTED_TOO_DEEPLY = "arrays or tables nested too deeply (a protocol nests a few levels)"


def pixel_deg(protocol: Protocol) -> float:
    """Visual angle of one display pixel at the viewing distance, degrees."""
    return display_pixel_deg(protocol["display"], protocol["viewing"]["distance_m"])


def describe_schema(paradigm: str) -> list[tuple[str, str, str, str, str]]:
    """Rows ``(key, unit, default, allowed, description)`` of a paradigm's schema, for docs."""
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

    walk({"study": STUDY, **PARADIGMS[paradigm].SCHEMA}, "")
    return rows
