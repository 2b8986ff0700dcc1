"""The ``glarelab`` commands of protocols: protocol check, protocol keys, protocol copy."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from glarelab.protocols import PARADIGMS, describe_schema, load_protocol

from .common import PROTOCOL_HELP, inside_whole_output


def _protocol_keys(args: argparse.Namespace) -> int:
    paradigm = args.paradigm
    if not paradigm.strip():  # named as the argument it is, not as a protocol's path
        raise ValueError(
            f"keys {paradigm!r}: empty (an unset shell variable?); give a paradigm "
            f"({', '.join(PARADIGMS)}) or a protocol"
        )
    if paradigm not in PARADIGMS:  # a protocol: its paradigm (a refusal prints no table)
        try:
            paradigm = load_protocol(paradigm).paradigm
        except FileNotFoundError as error:  # neither: the paradigms named too
            raise FileNotFoundError(
                f"{str(error).rstrip('.')}; or a paradigm: {', '.join(PARADIGMS)}"
            ) from None
    print("| key | unit | default | allowed | meaning |\n| --- | --- | --- | --- | --- |")
    for row in describe_schema(paradigm):
        print("| " + " | ".join(row) + " |")
    return 0


def _protocol_check(args: argparse.Namespace) -> int:
    from glarelab.experiments.paradigms import paradigm_run

    protocol = load_protocol(args.protocol)
    observer = paradigm_run(protocol).observer
    if observer is not None:
        observer.check(protocol)  # the simulated observers' parameters
    from glarelab.protocols import ProtocolError
    from glarelab.stimuli.backgrounds import check_backgrounds
    from glarelab.stimuli.kernels import check_kernels
    from glarelab.stimuli.paradigms import paradigm_stimuli

    stimuli = paradigm_stimuli(protocol)
    problems = check_backgrounds(  # drawn as a build draws them: what it would refuse
        stimuli.backgrounds(protocol),
        seed=protocol.seed,
        folder=protocol.folder,
    )
    problems += check_kernels(stimuli.kernels(protocol))  # each model asked of its kernel
    if problems:
        raise ProtocolError(args.protocol, problems)
    print(
        f"{args.protocol}: valid protocol of the {protocol.paradigm} paradigm (study "
        f"{protocol.study}), sha256 {protocol.sha256}"
    )
    from glarelab.experiments.layout import protocol_drawing

    lines, exact = protocol_drawing(protocol)
    for line in lines:
        print(f"  {line}")
    return 0 if exact else 1


def _protocol_copy(args: argparse.Namespace) -> int:
    from glarelab.files.atomic import write_bytes
    from glarelab.protocols.core import SHIPPED, shipped_protocols

    if args.name not in shipped_protocols():
        raise ValueError(
            f"copy {args.name!r}: not a shipped protocol ({', '.join(shipped_protocols())})"
        )
    source = SHIPPED / f"{args.name}.toml"
    destination = Path(args.destination)
    if destination.is_dir():
        destination = destination / source.name
    if destination.suffix != ".toml":
        raise ValueError(f"copy to {destination}: must end in .toml (or be a folder)")
    if destination.is_symlink():  # a dangling link does not "exist", yet it is someone's
        raise ValueError(
            f"copy to {destination}: a symbolic link (to {os.readlink(destination)}); it is "
            "never replaced or written through"
        )
    if destination.exists():
        raise ValueError(f"copy to {destination}: the file exists; it is never replaced")
    if not destination.parent.is_dir():
        raise ValueError(f"copy: no folder {destination.parent}")
    whole = inside_whole_output(destination)
    if whole is not None:
        raise ValueError(
            f"copy to {destination}: inside the {whole}, which glarelab writes and checks as a "
            "whole; copy the protocol elsewhere (nothing was changed)"
        )
    write_bytes(destination, source.read_bytes())
    print(destination.resolve())
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
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
    copy = protocol_commands.add_parser(
        "copy",
        help="write out a shipped protocol's TOML to edit into a study of your own",
    )
    copy.add_argument("name", help="a shipped protocol (yoshida2008, spencer1995, …)")
    copy.add_argument(
        "destination", type=Path, help="a new .toml file, or a folder to write NAME.toml in"
    )
    copy.set_defaults(run=_protocol_copy)
