"""The ``glarelab`` commands of planning a study: power, sweep."""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path

from protocols import load_protocol

from .common import PROTOCOL_HELP
from .common import log as _log


def _cluster(args: argparse.Namespace):
    """The Dask client the arguments ask for (none with ``--workers 0``)."""
    from planning.execute import available_cores, dask_client

    if args.workers == 0:
        if args.scheduler:
            raise ValueError("--workers 0 runs here without Dask: give no --scheduler with it")
        _log("running here, without Dask")
        return contextlib.nullcontext(None)
    if args.scheduler:
        _log(f"connecting to the Dask scheduler at {args.scheduler}")
    else:
        _log(f"starting a local Dask cluster of {args.workers or available_cores()} workers")
    return dask_client(workers=None if args.scheduler else args.workers, scheduler=args.scheduler)


def _power(args: argparse.Namespace) -> int:
    import pandas as pd

    from planning.power import power_analysis

    protocol = load_protocol(args.protocol)
    with _cluster(args) as client:
        if client is not None:
            _log(f"{len(client.scheduler_info()['workers'])} workers ready")
        recommended = power_analysis(
            protocol,
            args.out,
            participants=args.participants,
            replications=args.replications,
            seed=args.seed,
            alpha=args.alpha,
            correction=args.correction,
            target=args.target_power,
            stimuli=args.stimuli,
            client=client,
            scratch=args.scratch,
            log=_log,
            task_delay_s=args.task_delay_ms / 1000,
        )
    _log(f"power of each effect in {args.out / 'power.csv'}, curves in power_curves.png")
    print(f"sample size for power {args.target_power:g} (α = {args.alpha:g}):")
    for row in recommended.itertuples(index=False):
        n = f"more than {row.largest}" if pd.isna(row.n_power) else str(row.n_power)
        print(f"  {row.effect}: {n} (power at {row.largest}: {row.power_at_largest:.2f})")
    return 0


def _sweep(args: argparse.Namespace) -> int:
    from planning.grid import parse_setting
    from planning.sweep import sweep

    settings = [parse_setting(text) for text in args.set]
    with _cluster(args) as client:
        index = sweep(
            args.protocol,
            settings,
            args.out,
            simulate=args.simulate,
            seed=args.seed,
            client=client,
            log=_log,
        )
    _log(f"{len(index)} stimulus sets; the grid's index in {args.out / 'index.csv'}")
    print(index.to_string(index=False))
    return 0


def _cluster_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        help="Dask workers of the local cluster (default: one per core; 0: run here, no Dask)",
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="the address of an existing Dask scheduler (tcp://HOST:PORT) instead of a local "
        "cluster; its workers need glarelab installed and the output folder on their file system",
    )


def _sample_size(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a sample size must be a whole number; got {text!r}"
        ) from None
    if value < 2:
        raise argparse.ArgumentTypeError(f"a sample size must be at least 2; got {value}")
    return value


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser."""
    from planning.effects import CORRECTIONS

    power = commands.add_parser(
        "power",
        help="power and sample size of a study's effects from simulated studies (Dask)",
    )
    power.add_argument("protocol", help=PROTOCOL_HELP)
    power.add_argument(
        "--participants",
        type=_sample_size,
        nargs="+",
        required=True,
        metavar="N",
        help="the sample sizes (e.g. 6 8 10 12 16 20)",
    )
    power.add_argument(
        "--replications",
        type=int,
        default=1000,
        help="simulated studies per sample size (default 1000)",
    )
    power.add_argument(
        "--seed", type=int, default=1, help="seed of the simulated observers (default 1)"
    )
    power.add_argument(
        "--alpha", type=float, default=0.05, help="significance level (default 0.05)"
    )
    power.add_argument(
        "--correction",
        choices=CORRECTIONS,
        default="gg",
        help="the p that judges an ANOVA effect: gg (Greenhouse-Geisser, the default, as the "
        "reports), hf (Huynh-Feldt), girden (GG when eps < 0.75, else HF), none; where "
        "sphericity is not estimable, the lower bound",
    )
    power.add_argument(
        "--target-power",
        type=float,
        default=0.8,
        help="power wanted, for the recommended N (default 0.8)",
    )
    power.add_argument(
        "--stimuli",
        type=Path,
        default=None,
        help="the stimulus set (default: built into the cache)",
    )
    power.add_argument(
        "--scratch",
        type=Path,
        default=None,
        help="folder for the simulated sessions' files (default /dev/shm where writable)",
    )
    power.add_argument(
        "--out", type=Path, required=True, help="output folder (a rerun resumes it)"
    )
    _cluster_arguments(power)
    power.add_argument("--task-delay-ms", type=float, default=0.0, help=argparse.SUPPRESS)
    power.set_defaults(run=_power)

    sweep = commands.add_parser(
        "sweep",
        help="the stimulus sets of a grid of protocol parameters (Dask), optionally simulated",
    )
    sweep.add_argument("protocol", help=PROTOCOL_HELP)
    sweep.add_argument(
        "--set",
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
        type=int,
        default=0,
        metavar="N",
        help="also run N simulated observers on each set and analyse them (default 0: build only)",
    )
    sweep.add_argument(
        "--seed", type=int, default=1, help="seed of the simulated observers (default 1)"
    )
    sweep.add_argument(
        "--out", type=Path, required=True, help="output folder (a rerun resumes it)"
    )
    _cluster_arguments(sweep)
    sweep.set_defaults(run=_sweep)
