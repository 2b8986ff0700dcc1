"""The ``glarelab`` commands of analysis: analyse."""

from __future__ import annotations

import argparse
from pathlib import Path

from glarelab.protocols import load_protocol

from .common import PROTOCOL_HELP
from .common import log as _log


def _analyse(args: argparse.Namespace) -> int:
    from glarelab.analysis.report import write_report

    protocol = load_protocol(args.protocol or args.study)
    if args.protocol is not None and protocol.study != args.study:
        named = load_protocol(args.study).study if Path(args.study).suffix else args.study
        if named != protocol.study:
            raise ValueError(
                f"--protocol {args.protocol} is the protocol of study {protocol.study!r}, not "
                f"of {args.study!r}; give the study's own protocol"
            )
    for csv in args.csv:
        if Path(csv).suffix.lower() != ".csv":
            raise ValueError(
                f"{csv}: session data are CSV files (each one's .json sidecar is read with it)"
            )
    if args.stimuli is not None and not (Path(args.stimuli) / "manifest.json").is_file():
        raise ValueError(f"--stimuli {args.stimuli}: no manifest.json (not a stimulus set)")
    report = write_report(
        protocol,
        args.csv,
        args.out,
        exclude_incomplete=args.exclude_incomplete,
        include_aborted=args.include_aborted,
        include_pilots=args.include_pilots,
        stimuli=args.stimuli,
    )
    _log(f"wrote {report} with its tables and figures")
    print(report.resolve())
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    analyse = commands.add_parser("analyse", help="analyse session CSVs: tables, figures, report")
    analyse.add_argument("study", help=f"the protocol: {PROTOCOL_HELP}")
    analyse.add_argument("csv", nargs="+", type=Path, help="session CSV files")
    analyse.add_argument(
        "--out",
        type=Path,
        required=True,
        help="report folder: new, empty, or an earlier report (replaced whole)",
    )
    analyse.add_argument(
        "--protocol", type=Path, default=None, help="a protocol TOML file (instead of STUDY)"
    )
    analyse.add_argument(
        "--stimuli",
        type=Path,
        default=None,
        help="the stimulus set: its hash in the provenance, its images in the report",
    )
    analyse.add_argument(
        "--exclude-incomplete",
        action="store_true",
        help="drop participants with a missing design cell (listed in the report)",
    )
    analyse.add_argument(
        "--include-aborted",
        action="store_true",
        help="analyse sessions that did not complete and skip files without trials (both "
        "listed in the report) instead of refusing them",
    )
    analyse.add_argument(
        "--include-pilots",
        action="store_true",
        help="analyse pilot sessions (sidecar pilot: true) with the participants' instead of "
        "leaving them out (either way the report lists them)",
    )
    analyse.set_defaults(run=_analyse)
