"""The ``glarelab`` commands of analysis: analyse, import-psychopy."""

from __future__ import annotations

import argparse
from pathlib import Path

from glarelab.protocols import load_protocol

from .common import PROTOCOL_HELP, inside_whole_output
from .common import log as _log


def _study_or_csv(args: argparse.Namespace, what: str) -> None:
    """``--protocol FILE CSV…`` (no STUDY, as the help says): the first positional is a CSV,
    not the study; without ``--protocol`` a CSV as STUDY is refused naming it. (The CSVs stay
    ``nargs="+"``: with ``"*"`` argparse ends them at the first option, and CSVs after
    ``--out`` would be refused.)"""
    if Path(args.study).suffix.lower() == ".csv":
        if args.protocol is None:
            raise ValueError(
                f"STUDY {args.study!r} is a CSV file: give the study first (a shipped name or "
                f"a protocol TOML), or --protocol FILE before the {what}"
            )
        args.csv = [Path(args.study), *args.csv]
        args.study = None


def _protocol(args: argparse.Namespace):
    """STUDY's protocol, or ``--protocol``'s, which must then be STUDY's own (one line, not a
    problem per column the other study lacks)."""
    protocol = load_protocol(args.protocol or args.study)
    if args.protocol is not None and args.study is not None and protocol.study != args.study:
        named = load_protocol(args.study).study if Path(args.study).suffix else args.study
        if named != protocol.study:
            raise ValueError(
                f"--protocol {args.protocol} is the protocol of study {protocol.study!r}, not "
                f"of {args.study!r}; give the study's own protocol"
            )
    return protocol


def _analyse(args: argparse.Namespace) -> int:
    from glarelab.analysis.report import write_report

    _study_or_csv(args, "session CSV files")
    protocol = _protocol(args)
    for csv in args.csv:
        if Path(csv).is_dir():  # a shell's glob of a folder: the folder itself, not its files
            raise ValueError(
                f"{csv}: a folder; give the session CSV files in it (e.g. {Path(csv) / '*.csv'})"
            )
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
        include_no_sidecar=args.include_no_sidecar,
        stimuli=args.stimuli,
    )
    _log(f"wrote {report} with its tables and figures")
    print(report.resolve())
    return 0


def _pairs(option: str, items: list[str]) -> dict[str, str]:
    """``["A=B", …]`` as ``{"A": "B"}``; one-line error naming the option otherwise."""
    pairs = {}
    for item in items:
        name, equals, value = item.partition("=")
        if not equals or not name:
            raise ValueError(f"{option} {item!r}: give NAME=VALUE")
        if name in pairs:
            raise ValueError(f"{option} {name}: given twice")
        pairs[name] = value
    return pairs


def _import_psychopy(args: argparse.Namespace) -> int:
    from glarelab.analysis.psychopy_import import import_psychopy

    _study_or_csv(args, "PsychoPy CSV files")
    whole = inside_whole_output(Path(args.out) / "session.csv")
    if whole is not None:  # a stimulus set or a report would no longer verify or be remade
        raise ValueError(
            f"--out {args.out} is inside the {whole}, which glarelab replaces and checks as a "
            "whole: give a folder of its own for the session files (nothing was written)"
        )
    protocol = _protocol(args)
    for csv in args.csv:
        if Path(csv).suffix.lower() != ".csv":
            raise ValueError(f"{csv}: PsychoPy's data are the CSV its ExperimentHandler wrote")
    imported = import_psychopy(
        protocol,
        args.csv,
        args.out,
        mapping=_pairs("--column", args.column),
        values=_pairs("--set", args.set),
    )
    for session in imported:
        _log(session.summary())
        print(session.csv.resolve())
    if not imported:
        _log("no trial rows in the files given: nothing written")
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
    analyse.add_argument(
        "study", metavar="STUDY", help=f"the protocol: {PROTOCOL_HELP}; left out with --protocol"
    )
    analyse.add_argument("csv", nargs="+", type=Path, metavar="CSV", help="session CSV files")
    analyse.add_argument(
        "--out",
        type=Path,
        required=True,
        help="report folder: new, empty, or an earlier report (replaced whole)",
    )
    analyse.add_argument(
        "--protocol",
        type=Path,
        default=None,
        help="a protocol TOML file, instead of STUDY (--protocol FILE CSV CSV…; with a single "
        "CSV, STUDY CSV --protocol FILE) or with it (then the file must be STUDY's protocol)",
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
    analyse.add_argument(
        "--include-no-sidecar",
        action="store_true",
        help="analyse session CSVs without their .json sidecar (nothing vouches for their "
        "protocol, status, pilot or simulated flag; the report lists them) instead of refusing "
        "them",
    )
    analyse.set_defaults(run=_analyse)
    imports = commands.add_parser(
        "import-psychopy",
        help="make session files of data a PsychoPy experiment collected (ExperimentHandler CSVs)",
        description="Map a PsychoPy ExperimentHandler CSV (Builder or Coder) to the study's "
        "session format and write it as a session (CSV and sidecar) for glarelab analyse; "
        "prints the columns and rows it dropped and the columns it filled.",
    )
    imports.add_argument(
        "study", metavar="STUDY", help=f"the protocol: {PROTOCOL_HELP}; left out with --protocol"
    )
    imports.add_argument("csv", nargs="+", type=Path, metavar="CSV", help="PsychoPy data CSVs")
    imports.add_argument(
        "--out", type=Path, required=True, help="folder for the session files (existing files "
        "are never replaced)"
    )  # fmt: skip
    imports.add_argument(
        "--protocol",
        type=Path,
        default=None,
        help="a protocol TOML file, instead of STUDY (--protocol FILE CSV CSV…; with a single "
        "CSV, STUDY CSV --protocol FILE) or with it (then the file must be STUDY's protocol)",
    )
    imports.add_argument(
        "--column",
        action="append",
        default=[],
        metavar="PSYCHOPY=GLARELAB",
        help="a PsychoPy column that holds a study column under another name "
        "(e.g. key_resp.rt=time_s); repeatable",
    )
    imports.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="COLUMN=VALUE",
        help="one value for every trial of a required column the experiment did not record "
        "(e.g. dropped_frames=0); recorded in the sidecar; repeatable",
    )
    imports.set_defaults(run=_import_psychopy)
