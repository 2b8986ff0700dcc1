"""The ``glarelab`` commands of the demo, the docs and the bench: demo, docs, bench."""

from __future__ import annotations

import argparse
from pathlib import Path

from glarelab.files.atomic import write_text
from glarelab.files.folders import edited_since, record_written

from .common import PROTOCOL_HELP, count, folder_to_write, output_folder, writes_into
from .common import log as _log


def _demo(args: argparse.Namespace) -> int:
    from glarelab.demo import run_demo

    report = run_demo(
        args.protocol, args.out, participants=args.participants, seed=args.seed, log=_log
    )
    print(f"report: {report.resolve()}")
    return 0


def _docs(args: argparse.Namespace) -> int:
    from glarelab.docs import data_reference, protocol_reference

    folder = args.out
    if folder is None:  # only a source checkout's docs/, never a docs/ made wherever it runs
        if not (Path("docs").is_dir() and Path("src", "glarelab").is_dir()):
            raise ValueError(
                "no --out, and this is not a glarelab source checkout (no docs/ "
                "and src/glarelab here): give --out FOLDER"
            )
        folder = Path("docs")
    out = writes_into(Path(folder), ["protocols.md", "data.md"], "docs")
    for name, text in (("protocols.md", protocol_reference()), ("data.md", data_reference())):
        write_text(out / name, text)
        print((out / name).resolve())
    record_written(out, ["protocols.md", "data.md"])  # edited later: refused, not overwritten
    return 0


def _examples(args: argparse.Namespace) -> int:
    from glarelab.files.shipped import copy_shipped

    folder_to_write(Path(args.destination), ["examples"])  # not a file, a set or a report
    try:
        written = copy_shipped(args.destination)
    except FileExistsError as error:
        raise ValueError(str(error)) from None
    for path in written:
        print(path.resolve())
    return 0


def _bench(args: argparse.Namespace) -> int:
    from glarelab.bench.run import run_bench
    from glarelab.bench.scenes import WORKLOADS

    if args.live and args.acuity:
        raise ValueError("--live and --acuity are two benches of their own: give one of them")
    if args.live or args.acuity:  # the standard bench's options, which these two would ignore
        bench = "--live" if args.live else "--acuity"
        ignored = [
            option
            for option, given in (
                ("--large", args.large),
                ("--no-spectral", args.no_spectral),
                ("--no-fresh", args.no_fresh),
                ("--no-startup", args.no_startup),
            )
            if given
        ]
        if ignored:
            raise ValueError(
                f"{bench} runs its own workloads: {' and '.join(ignored)} (of the standard "
                f"bench) would do nothing; leave {'them' if len(ignored) > 1 else 'it'} out"
            )
    if args.live:
        from glarelab.bench.live import LIVE_WORKLOADS, live_bench, write_live_bench

        unknown = sorted(set(args.only or ()) - set(LIVE_WORKLOADS))
        if unknown:
            raise ValueError(
                f"--live runs its own workloads: --only {' '.join(unknown)} is not one; "
                f"choose from {', '.join(LIVE_WORKLOADS)}"
            )
        out = output_folder(args.out, "bench")
        for name in ("live.csv", "live.md"):  # before the bench's minutes, not after
            if edited_since(out, name):
                raise ValueError(
                    f"{out / name} was edited since glarelab wrote it; bench --live would "
                    "overwrite it, so copy what you changed elsewhere, remove the file, or give "
                    "another --out (nothing was changed)"
                )
        only = tuple(args.only) if args.only else None
        write_live_bench(out, live_bench(only=only, repeats=args.repeats, log=_log))
        record_written(out, ["live.csv", "live.md"])  # edited later: refused, not overwritten
        _log(f"wrote {out / 'live.csv'} and live.md")
        print(out.resolve())
        return 0

    if args.acuity:
        from glarelab.bench.acuity import ACUITY_WORKLOADS, acuity_bench, write_acuity_bench

        unknown = sorted(set(args.only or ()) - set(ACUITY_WORKLOADS))
        if unknown:
            raise ValueError(
                f"--acuity runs its own workloads: --only {' '.join(unknown)} is not one; "
                f"choose from {', '.join(ACUITY_WORKLOADS)}"
            )
        out = output_folder(args.out, "bench")
        only = tuple(args.only) if args.only else None
        write_acuity_bench(out, acuity_bench(repeats=args.repeats, only=only, log=_log))
        _log(f"wrote {out / 'acuity.csv'} and acuity.md")
        print(out.resolve())
        return 0

    unknown = sorted(set(args.only or ()) - set(WORKLOADS))
    if unknown:
        raise ValueError(
            f"--only {' '.join(unknown)}: no such workload; choose from {', '.join(WORKLOADS)}"
        )
    out = output_folder(args.out, "bench")
    run_bench(
        out,
        large=args.large,
        only=tuple(args.only) if args.only else None,
        spectral=not args.no_spectral,
        repeats=args.repeats,
        fresh=not args.no_fresh,
        startup=not args.no_startup,
        log=_log,
    )
    _log(f"wrote {out / 'bench.csv'}, bench.md and the Pareto plots")
    print(out.resolve())
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    bench = commands.add_parser(
        "bench", help="time each speed knob against its error in display codes"
    )
    bench.add_argument("--out", type=Path, default=Path("out/bench"))
    bench.add_argument("--large", action="store_true", help="add the 4096² scenes")
    bench.add_argument("--only", nargs="+", metavar="WORKLOAD", help="run only these workloads")
    bench.add_argument(
        "--no-spectral", action="store_true", help="skip the wave-optics spectral section"
    )
    bench.add_argument(
        "--no-fresh",
        action="store_true",
        help="skip the one-call workload in fresh processes (empty and warm kernel cache)",
    )
    bench.add_argument("--no-startup", action="store_true", help="skip the start-up times")
    bench.add_argument(
        "--repeats",
        type=count(1, 100),
        default=3,
        help="timings per case (with --live: timed passes over the 60-frame path)",
    )
    bench.add_argument(
        "--acuity",
        action="store_true",
        help="instead: the acuity blur's fast ways against the exact per-pixel blur "
        "(acuity.csv, acuity.md)",
    )
    bench.add_argument(
        "--live",
        action="store_true",
        help="instead: night vision per frame (gaze and pupil) against the offline "
        "render_night, ms per frame, fps and the error in codes (live.csv, live.md)",
    )
    bench.set_defaults(run=_bench)

    docs = commands.add_parser("docs", help="regenerate docs/protocols.md and docs/data.md")
    docs.add_argument(
        "--out",
        type=Path,
        default=None,
        help="the folder to write protocols.md and data.md in (default: docs/ of the source "
        "checkout it runs in; elsewhere --out is required)",
    )
    docs.set_defaults(run=_docs)

    examples = commands.add_parser(
        "examples",
        help="write out the example scenes and display readings glarelab ships",
        description="Copy the shipped examples (examples/scene.exr, examples/night.exr) and "
        "calibrations (the example readings and the synthetic calibrations) into DESTINATION, "
        "as a clone of the repository has them; existing files are never replaced.",
    )
    examples.add_argument("destination", type=Path, help="the folder to write them in")
    examples.set_defaults(run=_examples)
    demo = commands.add_parser(
        "demo", help="the whole study on simulated observers: stimuli, sessions, analysis, report"
    )
    demo.add_argument(
        "--protocol", default="yoshida2008", help=f"{PROTOCOL_HELP} (default yoshida2008)"
    )
    demo.add_argument(
        "--out",
        type=Path,
        default=Path("out/demo"),
        help="the demo's folder: new, empty, or an earlier demo's (its output is replaced)",
    )
    demo.add_argument("--participants", type=count(1, 999), default=10, help="simulated (1-999)")
    demo.add_argument("--seed", type=count(0), default=1, help="seed of the simulated observers")
    demo.set_defaults(run=_demo)
