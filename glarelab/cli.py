"""The ``glarelab`` command: its parser, made of the command modules of
:mod:`glarelab.commands`, and the one place errors become messages and exit statuses."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from protocols import ProtocolError

from .commands import MODULES
from .commands.common import log as _log
from .commands.render import build_model

__all__ = ["build_model", "main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="glarelab", description="Glare illusion psychophysics suite"
    )
    commands = parser.add_subparsers(dest="command", required=True)
    for module in MODULES:
        module.add(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``glarelab`` command; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    from experiments.loop import SessionAborted

    try:
        return args.run(args)
    except (ValueError, FileNotFoundError, ProtocolError) as error:
        parser.error(f"{args.command}: {error}")
    except (SessionAborted, KeyboardInterrupt) as stop:
        why = stop.args[0] if stop.args else "SIGINT"
        _log(f"{args.command}: stopped by {why} before the first trial; nothing was recorded")
        return 3
    return 2


if __name__ == "__main__":
    sys.exit(main())
