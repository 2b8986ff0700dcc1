"""What every command shares: the progress log and the protocol argument's help."""

from __future__ import annotations

import sys

__all__ = ["PROTOCOL_HELP", "log"]

PROTOCOL_HELP = "a shipped study's name (yoshida2008, spencer1995, luidolt2020, …) or a TOML file"


def log(message: str) -> None:
    """A progress line on stderr (stdout keeps what a command prints as its result)."""
    print(f"[glarelab] {message}", file=sys.stderr, flush=True)
