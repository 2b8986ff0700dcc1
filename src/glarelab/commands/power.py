"""The ``glarelab`` commands of planning a study: power, sweep."""

from __future__ import annotations

import argparse
import contextlib
import os
from pathlib import Path

from glarelab.files.inputs import loads_json
from glarelab.protocols import load_protocol

from .common import PROTOCOL_HELP, check_memory, count, number, output_folder
from .common import log as _log

WORKER_MEMORY_BYTES = 400 * 2**20
"""What one worker of a local cluster holds in a power run, with room to spare: about 260 MB
of Python and its libraries and 40-50 MB for Yoshida's stimulus set as displayed with its
percepts (measured in docs/power.md)."""
MAX_WORKERS = 256


def _fraction(text: str) -> float:
    """A number strictly between 0 and 1 (a significance level, a power)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0 < value < 1:  # NaN too
        raise argparse.ArgumentTypeError(f"{text} must be a number in (0, 1)")
    return value


def _scheduler(text: str) -> str:
    """A Dask scheduler's address: [PROTOCOL://]HOST:PORT."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import backends

    try:
        protocol, location = parse_address(text)
        if protocol not in backends:
            raise ValueError(f"unknown protocol {protocol!r} (known: {', '.join(backends)})")
        if protocol != "inproc":
            _, port = parse_host_port(location)
            if not 0 < int(port) < 65536:
                raise ValueError(f"port {port} is not 1-65535")
    except (ValueError, TypeError) as error:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a Dask scheduler's address such as tcp://10.0.0.5:8786 ({error})"
        ) from None
    return text


HANDSHAKE_WAIT_S = 3.0  # a Dask scheduler sends its handshake as soon as a client connects


def scheduler_problem(address: str, *, wait_s: float = HANDSHAKE_WAIT_S) -> str | None:
    """What answers at a ``tcp://`` scheduler address, if it is not a Dask scheduler: nothing,
    or a web server (Dask's dashboard, by default on port 8787, is one). None when the
    address sends first, as a Dask scheduler does (its comm handshake; distributed's
    ``comm.core.connect``), and for other protocols (TLS, UCX), which are not probed.

    A web server waits for a request, so only an address that has sent nothing within
    ``wait_s`` is asked one (``HEAD /``): a Dask scheduler is never sent bytes it cannot read.

    Parameters
    ----------
    address
        A Dask scheduler address as distributed parses it, ``PROTOCOL://HOST:PORT``
        (e.g. ``tcp://10.0.0.5:8786``); only ``tcp`` is probed.
    wait_s
        How long to wait to connect, for the scheduler's handshake and for a web server's
        reply, seconds, > 0 (default ``HANDSHAKE_WAIT_S`` = 3 s).

    Returns
    -------
    str or None
        One line on what answers instead of a Dask scheduler, or None when the address
        looks like one (or is not probed).

    Examples
    --------
    >>> scheduler_problem("tcp://127.0.0.1:1")[:30]
    'nothing answers at 127.0.0.1:1'
    """
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    protocol, location = parse_address(address)
    if protocol != "tcp":
        return None
    host, port = parse_host_port(location)
    try:
        connection = socket.create_connection((host, int(port)), timeout=wait_s)
    except OSError as error:
        return f"nothing answers at {host}:{port} ({error.strerror or error})"
    with connection:
        connection.settimeout(wait_s)
        try:
            if connection.recv(1):
                return None  # it spoke first: a Dask scheduler's handshake
            return f"{host}:{port} closed the connection without a word"
        except TimeoutError:
            pass
        except OSError as error:
            return f"{host}:{port} dropped the connection ({error.strerror or error})"
        try:
            connection.sendall(f"HEAD / HTTP/1.0\r\nHost: {host}\r\n\r\n".encode())
            reply = connection.recv(64)
        except OSError:
            reply = b""
    if reply.startswith(b"HTTP/"):
        status = reply.split(b"\r\n", 1)[0].decode("latin-1")
        return (
            f"{host}:{port} is a web server ({status}), not a Dask scheduler: Dask's dashboard "
            "answers HTTP (by default on port 8787); give the scheduler's own port (by "
            "default 8786), as `dask scheduler` prints it"
        )
    return (
        f"{host}:{port} answers, but not as a Dask scheduler (it sent nothing within "
        f"{wait_s:g} s of connecting)"
    )


def _folder(text: str) -> Path:
    """An existing folder this process may write into."""
    path = Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: no such folder")
    if not os.access(path, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"{text}: not a folder this user may write into")
    return path


def _stimulus_set(text: str) -> Path:
    """An intact stimulus set (its manifest verifies)."""
    from glarelab.stimuli.stimulus_set import verify_stimulus_set

    problems = verify_stimulus_set(text)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise argparse.ArgumentTypeError(
            f"{text} is not an intact stimulus set: {problems[0]}{more}"
        )
    return Path(text)


def _setting(text: str):
    """``KEY=V1,V2,…`` (:func:`glarelab.planning.grid.parse_setting`)."""
    from glarelab.planning.grid import GridError, parse_setting

    try:
        return parse_setting(text)
    except GridError as error:
        raise argparse.ArgumentTypeError(str(error).removeprefix("--set ")) from None


def _simulated(text: str) -> int:
    """Simulated observers per point: 0 (build only), or 2-999 to analyse them."""
    value = count(0, 999)(text)
    if value == 1:
        raise argparse.ArgumentTypeError(
            "1: the analysis needs at least 2 simulated observers (0 builds the sets only)"
        )
    return value


def _cluster(stack: contextlib.ExitStack, args: argparse.Namespace):
    """The Dask client the arguments ask for (none with ``--workers 0``), closed with
    ``stack``."""
    from glarelab.planning.execute import available_cores, dask_client

    if args.workers == 0:
        _log("running here, without Dask")
        return None
    if args.scheduler:
        _log(f"connecting to the Dask scheduler at {args.scheduler}")
        problem = scheduler_problem(args.scheduler)
        if problem is not None:
            raise ValueError(f"--scheduler {args.scheduler}: {problem}")
        try:
            client = stack.enter_context(dask_client(scheduler=args.scheduler))
        except OSError as error:
            raise ValueError(
                f"--scheduler {args.scheduler}: no Dask scheduler answered ({error})"
            ) from None
    else:
        workers = args.workers or available_cores()
        _log(f"starting a local Dask cluster of {workers} workers")
        client = stack.enter_context(dask_client(workers=workers))
    _log(f"{len(client.scheduler_info()['workers'])} workers ready")
    return client


def _check_workers(args: argparse.Namespace) -> None:
    """Refuse a local cluster larger than the memory it needs (before anything is written)."""
    from glarelab.planning.execute import available_cores

    if args.scheduler is None and args.workers != 0:
        workers = args.workers or available_cores()
        check_memory(workers * WORKER_MEMORY_BYTES, f"--workers {workers}")


def _power(args: argparse.Namespace) -> int:
    import pandas as pd

    from glarelab.files.folders import restore_folder
    from glarelab.planning.effects import WITHOUT_F_TESTS
    from glarelab.planning.power import (
        check_run_folder,
        power_analysis,
        run_inputs,
        stimuli_sha256,
    )
    from glarelab.stimuli.stimulus_set import shows_images

    twice = sorted({n for n in args.participants if args.participants.count(n) > 1})
    if twice:  # the same size twice is simulated once: say so rather than drop it
        raise ValueError(
            f"--participants {' '.join(map(str, args.participants))}: "
            f"{', '.join(map(str, twice))} given more than once; give each sample size once"
        )
    protocol = load_protocol(args.protocol)
    if args.correction is not None and protocol.paradigm in WITHOUT_F_TESTS:
        raise ValueError(
            f"--correction {args.correction}: the {protocol.study} protocol's analysis "
            f"({protocol.paradigm}) runs no ANOVA, so there is no sphericity to correct; give "
            "no --correction"
        )
    if args.stimuli is not None:
        if not shows_images(protocol):
            raise ValueError(
                f"--stimuli: the {protocol.study} protocol shows no images; give no --stimuli"
            )
        manifest_path = args.stimuli / "manifest.json"
        manifest = loads_json(manifest_path.read_text(), source=manifest_path)
        if manifest.get("protocol_sha256") != protocol.sha256:
            raise ValueError(
                f"--stimuli {args.stimuli}: built from another protocol than "
                f"{protocol.study}'s; give that protocol's set, or none"
            )
    _check_workers(args)
    restore_folder(args.out)  # a run killed mid-swap may have left it aside
    check_run_folder(
        args.out,
        run_inputs(
            protocol,
            seed=args.seed,
            participants=args.participants,
            stimuli_sha256=None if args.stimuli is None else stimuli_sha256(args.stimuli),
        ),
    )
    with contextlib.ExitStack() as stack:
        client = _cluster(stack, args)
        out = output_folder(args.out, "power")  # the last check: then it is written
        recommended = power_analysis(
            protocol,
            out,
            participants=args.participants,
            replications=args.replications,
            seed=args.seed,
            alpha=args.alpha,
            correction=args.correction or "gg",
            target=args.target_power,
            stimuli=args.stimuli,
            client=client,
            scratch=args.scratch,
            log=_log,
            task_delay_s=args.task_delay_ms / 1000,
        )
    _log(f"power of each effect in {out / 'power.csv'}, curves in power_curves.png")
    print(f"sample size for power {args.target_power:g} (α = {args.alpha:g}):")
    for row in recommended.itertuples(index=False):
        n = f"more than {row.largest}" if pd.isna(row.n_power) else str(row.n_power)
        print(f"  {row.effect}: {n} (power at {row.largest}: {row.power_at_largest:.2f})")
    return 0


def _sweep(args: argparse.Namespace) -> int:
    from glarelab.planning.sweep import prepare, sweep

    if "seed" in getattr(args, "given_options", ()) and not args.simulate:
        raise ValueError(
            "--seed without --simulate: the seed draws the simulated observers, and a sweep "
            "that only builds the sets would ignore it"
        )
    prepare(args.protocol, args.set, args.out, simulate=args.simulate, seed=args.seed)
    _check_workers(args)
    with contextlib.ExitStack() as stack:
        client = _cluster(stack, args)
        out = output_folder(args.out, "sweep")  # the last check: then it is written
        index = sweep(
            args.protocol,
            args.set,
            out,
            simulate=args.simulate,
            seed=args.seed,
            client=client,
            log=_log,
        )
    _log(f"{len(index)} stimulus sets; the grid's index in {out / 'index.csv'}")
    print(index.to_string(index=False))
    return 0


def _cluster_arguments(parser: argparse.ArgumentParser, workers_need: str) -> None:
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers",
        type=count(0, MAX_WORKERS),
        default=None,
        help="Dask workers of the local cluster (default: one per core; 0: run here, no Dask)",
    )
    where.add_argument(
        "--scheduler",
        type=_scheduler,
        default=None,
        metavar="ADDRESS",
        help="the address of an existing Dask scheduler (tcp://HOST:PORT) instead of a local "
        f"cluster; its workers need glarelab installed{workers_need}",
    )


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    from glarelab.planning.effects import CORRECTIONS
    from glarelab.planning.power import MAX_PARTICIPANTS

    power = commands.add_parser(
        "power",
        help="power and sample size of a study's effects from simulated studies (Dask)",
    )
    power.add_argument("protocol", help=PROTOCOL_HELP)
    power.add_argument(
        "--participants",
        type=count(2, MAX_PARTICIPANTS),
        nargs="+",
        required=True,
        metavar="N",
        help="the sample sizes (e.g. 6 8 10 12 16 20)",
    )
    power.add_argument(
        "--replications",
        type=count(1, 1_000_000),
        default=1000,
        help="simulated studies per sample size (default 1000)",
    )
    power.add_argument(
        "--seed", type=count(0), default=1, help="seed of the simulated observers (default 1)"
    )
    power.add_argument(
        "--alpha", type=_fraction, default=0.05, help="significance level (default 0.05)"
    )
    power.add_argument(
        "--correction",
        choices=CORRECTIONS,
        default=None,
        help="the p that judges an ANOVA effect: gg (Greenhouse-Geisser, the default: the "
        "more conservative, so the N it recommends is not too small), girden (GG when eps < "
        "0.75, else HF: the reports' rule), hf (Huynh-Feldt), none; where sphericity is not "
        "estimable, the lower bound; refused for a study without an ANOVA",
    )
    power.add_argument(
        "--target-power",
        type=_fraction,
        default=0.8,
        help="power wanted, for the recommended N (default 0.8)",
    )
    power.add_argument(
        "--stimuli",
        type=_stimulus_set,
        default=None,
        help="the stimulus set (default: built into the cache)",
    )
    power.add_argument(
        "--scratch",
        type=_folder,
        default=None,
        help="folder for the simulated sessions' files (default /dev/shm where writable)",
    )
    power.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output folder: new, empty, or an earlier run of this command (resumed)",
    )
    _cluster_arguments(power, " (a worker that cannot read the stimulus set builds its own)")
    power.add_argument(
        "--task-delay-ms", type=number(0, 60_000), default=0.0, help=argparse.SUPPRESS
    )
    power.set_defaults(run=_power)

    sweep = commands.add_parser(
        "sweep",
        help="the stimulus sets of a grid of protocol parameters (Dask), optionally simulated",
    )
    sweep.add_argument("protocol", help=PROTOCOL_HELP)
    sweep.add_argument(
        "--set",
        type=_setting,
        action="append",
        required=True,
        metavar="KEY=V1,V2,…",
        help="a protocol key and its values on the grid, as TOML values: "
        "stimulus.disk_deg=0.2,0.3; a list of tables by name or position: "
        "glare.methods.vos.levels_cd_m2=[220,4000],[220,7000] or "
        "glare.methods[1].parameters.regime=photopic,mesopic (repeat --set for more keys)",
    )
    sweep.add_argument(
        "--simulate",
        type=_simulated,
        default=0,
        metavar="N",
        help="also run N simulated observers on each set and analyse them (default 0: build only)",
    )
    sweep.add_argument(
        "--seed", type=count(0), default=1, help="seed of the simulated observers (default 1)"
    )
    sweep.add_argument(
        "--out",
        type=Path,
        required=True,
        help="output folder: new, empty, or an earlier run of this command (resumed)",
    )
    _cluster_arguments(sweep, ", and --out on a file system they share (they write the sets)")
    sweep.set_defaults(run=_sweep)
