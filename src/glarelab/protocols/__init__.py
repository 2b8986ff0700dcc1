"""Study protocols: the contract the stimuli, the experiments and the analysis all read.

A protocol is a TOML file that names its paradigm (matching, staircase, rating) and says
everything the study needs; the shipped studies' files live in this package. The session CSV
format is derived from the protocol here too (:mod:`glarelab.protocols.columns`), so the
experiments that write data and the analysis that reads it agree by construction. This package
imports nothing of the suite but :mod:`glarelab.glare` (to check glare models' parameters).
"""

from glarelab.protocols.columns import (
    COMMON,
    DATA_FORMAT,
    ROW_DIGESTS_SINCE,
    Column,
    columns,
    format_value,
    row_digest,
)
from glarelab.protocols.core import (
    PARADIGMS,
    SHIPPED,
    Protocol,
    describe_schema,
    load_protocol,
    parse_protocol,
    pixel_deg,
    protocol_path,
    register_paradigm,
    shipped_protocols,
    with_monitor,
)
from glarelab.protocols.keys import Key, ProtocolError, Tables

__all__ = [
    "COMMON",
    "DATA_FORMAT",
    "PARADIGMS",
    "ROW_DIGESTS_SINCE",
    "SHIPPED",
    "Column",
    "Key",
    "Protocol",
    "ProtocolError",
    "Tables",
    "columns",
    "describe_schema",
    "format_value",
    "load_protocol",
    "parse_protocol",
    "pixel_deg",
    "protocol_path",
    "register_paradigm",
    "row_digest",
    "shipped_protocols",
    "with_monitor",
]
