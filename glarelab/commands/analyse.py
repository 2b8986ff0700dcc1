"""The ``glarelab`` commands of analysis: analyse."""

from __future__ import annotations

import argparse
from pathlib import Path

from protocols import load_protocol

from .common import PROTOCOL_HELP
from .common import log as _log


def _analyse(args: argparse.Namespace) -> int:
    from analysis.report import write_report

    protocol = load_protocol(args.protocol or args.study)
    report = write_report(
        protocol,
        args.csv,
        args.out,
        exclude_incomplete=args.exclude_incomplete,
        stimuli=args.stimuli,
    )
    _log(f"wrote {report} with its tables and figures")
    print(report.resolve())
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser."""
    analyse = commands.add_parser("analyse", help="analyse session CSVs: tables, figures, report")
    analyse.add_argument("study", help=f"the protocol: {PROTOCOL_HELP}")
    analyse.add_argument("csv", nargs="+", type=Path, help="session CSV files")
    analyse.add_argument("--out", type=Path, required=True, help="report folder")
    analyse.add_argument(
        "--protocol", type=Path, default=None, help="a protocol TOML file (instead of STUDY)"
    )
    analyse.add_argument("--stimuli", type=Path, default=None, help="the set, for provenance")
    analyse.add_argument(
        "--exclude-incomplete",
        action="store_true",
        help="drop participants with a missing design cell (listed in the report)",
    )
    analyse.set_defaults(run=_analyse)
