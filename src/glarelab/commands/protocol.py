"""The ``glarelab`` commands of protocols: protocol check, protocol keys."""

from __future__ import annotations

import argparse

from glarelab.protocols import PARADIGMS, describe_schema, load_protocol

from .common import PROTOCOL_HELP


def _protocol_keys(args: argparse.Namespace) -> int:
    print("| key | unit | default | allowed | meaning |\n| --- | --- | --- | --- | --- |")
    paradigm = args.paradigm
    if paradigm not in PARADIGMS:  # a protocol: its paradigm
        paradigm = load_protocol(paradigm).paradigm
    for row in describe_schema(paradigm):
        print("| " + " | ".join(row) + " |")
    return 0


def _protocol_check(args: argparse.Namespace) -> int:
    from glarelab.experiments.paradigms import paradigm_run

    protocol = load_protocol(args.protocol)
    observer = paradigm_run(protocol).observer
    if observer is not None:
        observer.check(protocol)  # the simulated observers' parameters
    print(
        f"{args.protocol}: valid protocol of the {protocol.paradigm} paradigm (study "
        f"{protocol.study}), sha256 {protocol.sha256}"
    )
    from glarelab.experiments.layout import protocol_drawing

    lines, exact = protocol_drawing(protocol)
    for line in lines:
        print(f"  {line}")
    return 0 if exact else 1


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser."""
    protocol = commands.add_parser("protocol", help="check a protocol or list its keys")
    protocol_commands = protocol.add_subparsers(dest="protocol_command", required=True)
    check = protocol_commands.add_parser("check", help="validate a protocol file")
    check.add_argument("protocol", help=PROTOCOL_HELP)
    check.set_defaults(run=_protocol_check)
    keys = protocol_commands.add_parser("keys", help="every key of a study's protocol")
    keys.add_argument(
        "paradigm", help=f"a paradigm ({', '.join(PARADIGMS)}) or a protocol ({PROTOCOL_HELP})"
    )
    keys.set_defaults(run=_protocol_keys)
