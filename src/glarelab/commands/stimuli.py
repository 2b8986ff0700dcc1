"""The ``glarelab`` commands of stimulus sets: stimuli build, stimuli verify."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from glarelab.display.calibration import Calibration
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import build_stimulus_set, prove_stimulus_set

from .common import add_accept_calibration, add_monitor_options, apply_monitor
from .common import log as _log


def _stimuli_build(args: argparse.Namespace) -> int:
    from glarelab.experiments.paradigms import paradigm_run

    protocol, monitor = apply_monitor(args, load_protocol(args.protocol))
    observer = paradigm_run(protocol).observer
    if observer is not None:  # a protocol that protocol check refuses is not built either
        observer.check(protocol)
    if "calibration" in (args.accept_mismatch or ()) and not args.calibration and monitor is None:
        raise ValueError(
            "--accept-mismatch calibration without --calibration (or --monitor): there is no "
            "calibration whose mismatch could be accepted, so it would be ignored"
        )
    calibration = Calibration.load(args.calibration) if args.calibration else None
    if calibration is None and monitor is not None:
        from glarelab.frontend.monitors import calibration_from_monitor

        calibration = calibration_from_monitor(monitor, bit_depth=protocol["display"]["bit_depth"])
        _log(f"calibration: {calibration.label} (status {calibration.status})")
    _log(f"building the {protocol.study} stimulus set into {args.out}")
    start = time.perf_counter()
    manifest = build_stimulus_set(
        protocol,
        args.out,
        calibration=calibration,
        accept_mismatch="calibration" in (args.accept_mismatch or ()),
        inputs=[args.calibration] if args.calibration else [],
    )
    encodings = [r.get("encoding", {}) for r in manifest["images"].values()]
    above = sum(e.get("above_max", 0) for e in encodings)
    below = sum(e.get("below_black", 0) for e in encodings)
    _log(
        f"{len(manifest['files'])} files in {time.perf_counter() - start:.1f} s; calibration "
        f"status '{manifest['calibration']['status']}'; {above + below} pixels clipped by the "
        f"display ({above} above its white, {below} below its black)"
    )
    print(Path(args.out).resolve())
    return 0


def _stimuli_verify(args: argparse.Namespace) -> int:
    from glarelab.files.folders import restore_folder

    restore_folder(args.folder)  # a build killed mid-swap: the set back, its leftovers gone
    if not Path(args.folder).is_dir():  # one line, exit 2: there is nothing to verify
        what = "not a folder" if Path(args.folder).exists() else "no such folder"
        raise FileNotFoundError(f"{args.folder}: {what} (give a stimulus set's folder)")
    if not (Path(args.folder) / "manifest.json").exists():  # a folder, but no set's
        raise FileNotFoundError(
            f"{args.folder}: no manifest.json, so not a stimulus set (give a set's folder, as "
            "glarelab stimuli build wrote it)"
        )
    problems = prove_stimulus_set(args.folder)
    if problems:
        for problem in problems:
            print(f"{args.folder}: {problem}", file=sys.stderr)
        return 1
    print(
        f"{args.folder}: the folder holds exactly the manifest's files, each unchanged, and "
        "the manifest is what its protocol and calibration build"
    )
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    stimuli = commands.add_parser("stimuli", help="build or verify a study's stimulus set")
    stimuli_commands = stimuli.add_subparsers(dest="stimuli_command", required=True)
    build = stimuli_commands.add_parser("build", help="build a stimulus set from a protocol")
    build.add_argument(
        "protocol",
        help="a shipped study that shows images (yoshida2008, spencer1995, …) or a TOML file",
    )
    build.add_argument(
        "--out",
        type=Path,
        required=True,
        help="folder for the set: new, empty, or an earlier set (replaced whole)",
    )
    build.add_argument("--calibration", type=Path, default=None, help="display calibration JSON")
    add_accept_calibration(
        build,
        "build although the calibration's white is not the protocol display's (calibration); "
        "sessions check again",
    )
    add_monitor_options(build, gamma=True)
    build.set_defaults(run=_stimuli_build)
    verify = stimuli_commands.add_parser(
        "verify",
        help="check a stimulus set: exactly the manifest's files, each with its sha256",
    )
    verify.add_argument("folder", type=Path)
    verify.set_defaults(run=_stimuli_verify)
