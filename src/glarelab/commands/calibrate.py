"""The ``glarelab`` commands of display calibration: calibrate fit, calibrate measure."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from glarelab.display.calibration import Calibration, fit_calibration, read_readings
from glarelab.display.photometer import PHOTOMETERS
from glarelab.files.atomic import write_bytes
from glarelab.files.inputs import loads_json
from glarelab.files.locks import ProcessLock

from .common import claim_output, count, folder_to_write, number, one_line, output_file
from .common import log as _log

if TYPE_CHECKING:
    from glarelab.display.measure import MeasurementSession

REPLACE_HELP = (
    "write over the --out calibration (kept as STEM.replaced-N.json); without it an existing "
    "--out is kept and the new calibration gets a new name"
)


def _claim(path: Path) -> bool:
    """Create ``path`` empty if no file is there, in one step (``O_EXCL``): of two processes
    choosing one name at once, one gets it and the other goes on to the next name."""
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
    except FileExistsError:
        return False
    return True


def _free_name(path: Path, tag: str, *, claim: bool = False) -> Path:
    """``STEM-TAG2.json``, ``STEM-TAG3.json``, … : the first that does not exist; with
    ``claim``, created empty by this process (so that no other process takes it too)."""
    for index in range(2, 10_000):
        candidate = path.with_name(f"{path.stem}{tag}{index}{path.suffix}")
        if candidate.is_symlink():
            continue
        if _claim(candidate) if claim else not candidate.exists():
            return candidate
    raise ValueError(f"{path}: 10,000 calibrations of this name; give another --out")


def calibration_out(path: Path, *, replace: bool, inputs=(), claim: bool = False) -> Path:
    """Where a new calibration goes: ``path`` if it is free; beside it under a new name if a
    file is there (which is kept as it was); over it with ``replace``, when it is a glarelab
    calibration, which is then kept as ``STEM.replaced-N.json``. With ``claim`` a new name is
    created empty at once (``O_EXCL``), so that runs at once never choose the same one; the
    caller writes it, or removes it on failure (:func:`_release`).

    Parameters
    ----------
    path
        The ``--out`` file asked for, ``.json``.
    replace
        Whether to replace a calibration there (``--replace``).
    inputs
        The command's input files, none of which may be the output; default none.
    claim
        Whether to create a new name empty at once (``O_EXCL``); default False.

    Returns
    -------
    pathlib.Path
        The file to write the calibration to.

    Raises
    ------
    ValueError
        For an output that may not be written, or ``replace`` of something that is not a
        glarelab calibration.
    """
    path = Path(path)
    if not (path.exists() or path.is_symlink()):
        # with claim another run may create the name between the look and the check: its
        # empty claim is not yet listed, so its listing is not asked (the claim decides)
        output_file(path, (".json",), "calibration", inputs=inputs, shared=claim)
        if not claim or _claim(path):
            return path
    if not replace:
        new = _free_name(path, "-", claim=claim)
        try:
            output_file(new, (".json",), "calibration", inputs=inputs, shared=claim)
        except BaseException:
            if claim:
                _release(new)
            raise
        _log(f"{path} exists and is kept; the new calibration is {new} (--replace replaces it)")
        return new
    if path.is_symlink() or not path.is_file():
        raise ValueError(f"--replace {path}: not a file (a link or a folder); give another --out")
    try:
        Calibration.load(path)
    except ValueError as error:
        raise ValueError(
            f"--replace {path}: it is not a glarelab calibration ({error}); give another --out"
        ) from None
    output_file(path, (".json",), "calibration", inputs=inputs, force=True, verified_ok=True)
    kept = _free_name(path, ".replaced-", claim=True)
    write_bytes(kept, path.read_bytes())
    _log(f"the calibration {path} is replaced; it is kept as {kept}")
    return path


def _release(path: Path) -> None:
    """Remove a name claimed by :func:`_claim` that was never written (still empty)."""
    with contextlib.suppress(OSError):
        if path.is_file() and not path.is_symlink() and path.stat().st_size == 0:
            path.unlink()


def _replace_lock(path: Path) -> ProcessLock:
    """One ``--replace`` of a calibration at a time: two would each keep the old file and the
    later would write over the other's new calibration."""

    def refusal(holder: str) -> Exception:
        return ValueError(
            f"--replace {path}: another glarelab ({holder}) is replacing this calibration; "
            "run again when it has ended (nothing was changed)"
        )

    return ProcessLock(path.with_name(f".{path.name}.replace.lock"), refusal=refusal)


def _calibrate_fit(args: argparse.Namespace) -> int:
    if Path(args.out).suffix.lower() != ".json":
        output_file(args.out, (".json",), "calibration")  # refuses, naming the suffix
    readings = read_readings(args.readings)
    calibration = fit_calibration(
        readings,
        bit_depth=args.bit_depth,
        method=args.method,
        label=args.label,
        source=str(args.readings),
    )
    with contextlib.ExitStack() as stack:
        if args.replace:
            stack.enter_context(_replace_lock(Path(args.out)))
        args.out = calibration_out(
            args.out, replace=args.replace, inputs=[args.readings], claim=True
        )
        try:
            calibration.save(args.out)
        except BaseException:
            _release(args.out)
            raise
        # glarelab's: a later measure or --replace takes it
        claim_output(args.out, "calibrate fit")
    _log(
        f"{len(readings)} readings → {args.method} calibration, {calibration.black_cd_m2:.4g}-"
        f"{calibration.max_cd_m2:.4g} cd/m², status '{calibration.status}' → {args.out}"
    )
    if calibration.model:
        _log(
            f"gain-offset-gamma residuals: RMS {calibration.model['rms_residual_cd_m2']:.3g} cd/m²"
        )
    return 0


def _calibrate_export_monitor(args: argparse.Namespace) -> int:
    from glarelab.frontend.monitors import export_calibration
    from glarelab.protocols import load_protocol

    calibration = Calibration.load(args.calibration)
    if args.monitor_folder is not None:  # not a file, a stimulus set or a report
        folder_to_write(Path(args.monitor_folder), [f"{args.monitor}.json"])
    protocol = load_protocol(args.protocol) if args.protocol else None
    if protocol is not None:
        from glarelab.display.checks import check_calibration

        for fits in check_calibration(protocol, calibration):
            if not fits.passed:  # the monitor would pair one display's geometry and another's
                raise ValueError(  # calibration (stimuli build refuses the same pair)
                    f"--protocol {args.protocol}: {args.calibration} is not of the "
                    f"{protocol.study} protocol's display: it is {fits.actual}, the protocol "
                    f"asks for {fits.expected}; export the calibration of that display, or "
                    "leave out --protocol (the monitor keeps its own size, width and distance)"
                )
    path, name = export_calibration(
        calibration,
        args.monitor,
        display=protocol.data.get("display") if protocol else None,
        viewing=protocol.data.get("viewing") if protocol else None,
        folder=args.monitor_folder,
    )
    _log(
        f"{args.calibration} → Monitor Center monitor {args.monitor!r}, calibration {name!r} "
        f"({path}): gamma grid of its gain-offset-gamma fit, {len(calibration.readings)} "
        "luminance measurements"
        + (f", the {protocol.study} display's size, width and distance" if protocol else "")
    )
    return 0


_PROTOCOL_OPTIONS = {
    "readings": "--readings",
    "settle_s": "--settle-s",
    "spread_fraction": "--spread",
    "repeats": "--repeats",
}


def _open_meter(args: argparse.Namespace, instrument: dict | None):
    """The photometer asked for (None for typed readings; on a resumed session, the one that
    began it), a function that opens it anew, and the list of those opened."""
    from glarelab.display.photometer import open_photometer

    if args.photometer is None:
        if args.port is not None:
            raise ValueError("--port needs --photometer MODEL (the photometer on that port)")
        return None, None, []
    if args.port is None:
        raise ValueError(f"--photometer {args.photometer} needs --port (e.g. /dev/ttyUSB0, COM3)")
    if instrument and instrument.get("model") != args.photometer:
        raise ValueError(
            f"--photometer {args.photometer}: this session was measured with a "
            f"{instrument.get('model')}; finish it with the same instrument"
        )
    serial_number = args.photometer_serial or (instrument or {}).get("serial_number")

    opened = []  # every photometer opened (R after a fault opens it anew), closed at the end

    def reopen():
        opened.append(open_photometer(args.photometer, args.port, serial_number=serial_number))
        return opened[-1]

    meter = reopen()
    if instrument and instrument.get("serial_number") not in (None, meter.serial_number):
        meter.close()
        raise ValueError(
            f"the {meter.model} on {args.port} is serial number {meter.serial_number}, this "
            f"session was measured with {instrument['serial_number']}: finish it with the same "
            "instrument"
        )
    if meter.serial_number is None:
        _log(
            f"warning: the {meter.model} does not report its serial number; give it with "
            "--photometer-serial (it is printed on the instrument) so the calibration names it"
        )
    _log(f"photometer: {meter.model} on {meter.port}, serial number {meter.serial_number}")
    return meter, reopen, opened


def _calibrate_measure(args: argparse.Namespace) -> int:
    from glarelab.display.measure import MeasurementLock

    if args.simulate is not None:  # before any window: its readings could never be fitted
        white, black, gamma = args.simulate
        given = f"--simulate {white:g} {black:g} {gamma:g}"
        if not white > black:
            raise ValueError(
                f"{given}: WHITE ({white:g} cd/m²) must be above BLACK ({black:g} cd/m²); the "
                "order is WHITE BLACK GAMMA"
            )
        if not gamma > 0:
            raise ValueError(
                f"{given}: GAMMA must be > 0 (a display's is about 2.2), got {gamma:g}"
            )
    if Path(args.out).suffix.lower() != ".json":
        output_file(args.out, (".json",), "calibration")  # refuses, naming the suffix
    # an existing calibration (one that calibrate fit wrote, too) is kept: the new one gets the
    # next free name, as for fit
    args.out = calibration_out(args.out, replace=args.replace)
    with MeasurementLock(args.out):  # one process per session file, until it ends
        status = _measure_locked(args)
    if Path(args.out).is_file():  # glarelab's: a later fit or measure keeps it, --replace takes it
        claim_output(args.out, "calibrate measure")
    return status


def _protocol_targets(studies: list[str] | None) -> list[float]:
    """The luminances the studies name (:func:`glarelab.display.measure.protocol_luminances`),
    verified besides the log-spaced targets."""
    from glarelab.display.measure import protocol_luminances
    from glarelab.protocols import load_protocol

    return sorted(
        {t for study in studies or () for t in protocol_luminances(load_protocol(study))}
    )


def _log_stopped(session: MeasurementSession) -> None:
    """Say where a measurement stopped and how to go on with it (Escape, a fault, Ctrl-C)."""
    step = session.current()
    _log(
        f"stopped at {step['phase']} code {step['code']}; every reading so far is in "
        f"{session.session_path}: the same command with --resume goes on from there"
    )


def _measure_locked(args: argparse.Namespace) -> int:
    from glarelab.display.measure import MeasurementSession
    from glarelab.display.photometer import PatchProtocol
    from glarelab.frontend.measure import run_measurement

    if args.simulate is not None:
        for dest, flag in (
            ("photometer_serial", "--photometer-serial"),
            ("settle_s", "--settle-s"),
        ):
            if dest in getattr(args, "given_options", ()):
                raise ValueError(
                    f"{flag} with --simulate: the simulated photometer has neither serial "
                    "number nor settling time, so it would be ignored"
                )
    session_path = args.out.with_suffix(".session.json")
    given = {  # the reading protocol's options given on the command line
        name: value
        for name, value in (
            ("readings", args.readings),
            ("settle_s", args.settle_s),
            ("spread_fraction", args.spread),
            ("repeats", args.repeats),
        )
        if value is not None
    }
    protocol = PatchProtocol(**given)
    if args.resume:
        session = MeasurementSession.resume(session_path, args.out)
        if session.patch_protocol:  # the session goes on reading patches as it began
            protocol = PatchProtocol(**session.patch_protocol)
            for name, value in given.items():
                if value != session.patch_protocol[name]:
                    option = _PROTOCOL_OPTIONS[name]
                    raise ValueError(
                        f"{option} {value:g}: this session reads its patches with {option} "
                        f"{session.patch_protocol[name]:g}; resume without {option} (or with "
                        f"{session.patch_protocol[name]:g}) so every patch is read alike"
                    )
        for option, value, kept in (
            ("--bit-depth", args.bit_depth, session.bit_depth),
            ("--points", args.points, session.points),
            ("--order", args.order, session.order),
            ("--verify-points", args.verify_points, session.verify_points),
            ("--tolerance", args.tolerance, session.tolerance_fraction),
            ("--label", args.label, session.label),
        ):
            if value is not None and value != kept:
                raise ValueError(
                    f"{option} {value}: this session was begun with {option} {kept}; resume "
                    f"without {option}, the session goes on as it began"
                )
        if args.protocol is not None and _protocol_targets(args.protocol) != (
            session.protocol_targets
        ):
            raise ValueError(
                f"--protocol {' '.join(args.protocol)}: this session verifies the luminances "
                f"{session.protocol_targets} of the studies it was begun for; resume without "
                "--protocol"
            )
        if args.seed is not None:
            raise ValueError(
                f"--seed {args.seed}: this session's order of codes is in its file; resume "
                "without --seed"
            )
        _log(
            f"resuming {session_path}: {len(session.log)} patches done, "
            f"{len(session.raw)} photometer readings kept, {session.current()['phase']} "
            f"code {session.current()['code']} next"
        )
    else:
        if session_path.exists():
            previous = loads_json(session_path.read_text(), source=session_path)
            begun = previous.get("log") or previous.get("raw")
            if previous.get("phase") not in (None, "done") and begun:
                raise ValueError(
                    f"{session_path}: a measurement of this calibration stopped before its end "
                    f"({len(previous.get('log', []))} patches done); --resume goes on with it, or "
                    "move the file away to start again"
                )
        session = MeasurementSession(
            protocol_targets=_protocol_targets(args.protocol),
            bit_depth=10 if args.bit_depth is None else args.bit_depth,
            out=args.out,
            rng=np.random.default_rng(0 if args.seed is None else args.seed),
            points=33 if args.points is None else args.points,
            order=args.order or "random",
            verify_points=5 if args.verify_points is None else args.verify_points,
            tolerance_fraction=0.03 if args.tolerance is None else args.tolerance,
            label=args.label or "",
        )
    if args.simulate is not None and args.photometer is not None:
        raise ValueError("give --simulate or --photometer, not both")
    meter, reopen, opened = _open_meter(args, session.instrument)
    if meter is not None:
        session.instrument = meter.describe()
        session.patch_protocol = dataclasses.asdict(protocol)  # saved with the first reading
    photometer = None
    if args.simulate is not None:  # a display following L = black + (white - black) x^gamma
        white, black, gamma = args.simulate
        top = 2**session.bit_depth - 1

        def photometer(code: int) -> float:
            return black + (white - black) * (code / top) ** gamma

    try:
        result = run_measurement(
            session,
            photometer=photometer,
            meter=meter,
            patch_protocol=protocol,
            reopen=reopen,
            fullscr=not args.windowed,
            allow_fewer_bits=args.allow_fewer_bits,
            log=_log,
        )
    except KeyboardInterrupt:  # Ctrl-C: the session says so, and how to go on
        if session.phase != "done" and (session.log or session.raw):
            session.interrupted("stopped by Ctrl-C (SIGINT)")
            _log_stopped(session)
        raise
    finally:
        for each in opened:
            each.close()
    for flag in result["flags"]:
        _log(f"flag: {flag}")
    if session.refused:
        _log(f"no calibration: {session.refused}; the readings are in {session.session_path}")
        return 1
    if result["status"] == "stopped":
        _log_stopped(session)
        return 1
    if result["status"] == "synthetic":  # --simulate: the measurement tried, no display known
        _log(
            f"calibration status: synthetic (a simulated photometer's readings; sessions and "
            f"builds treat it as uncalibrated); its verification pass {result['verification']}; "
            f"session saved at {session.session_path}"
        )
        return 0 if result["verification"] == "passed" else 1
    _log(f"calibration status: {result['status']}; session saved at {session.session_path}")
    return 0 if result["status"] == "passed" else 1


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    calibrate = commands.add_parser("calibrate", help="display calibration")
    calibrate_commands = calibrate.add_subparsers(dest="calibrate_command", required=True)
    fit = calibrate_commands.add_parser("fit", help="fit a calibration to photometer readings")
    fit.add_argument(
        "readings",
        type=Path,
        help="CSV with a header row 'code,luminance_cd_m2' and one row per code measured "
        "(calibrations/example-readings.csv is one)",
    )
    fit.add_argument("--out", type=Path, required=True, help="calibration JSON to write")
    fit.add_argument(
        "--bit-depth", type=int, default=10, choices=(8, 10, 12, 16), help="the display's bits"
    )
    fit.add_argument(
        "--method",
        choices=("pchip-log", "pchip", "gog"),
        default="pchip-log",
        help="pchip-log: monotone interpolation of log(L - black) against log(code), which "
        "follows gamma curves and sRGB-type curves with a linear toe; pchip: the same in a "
        "gamma-2.2 space (earlier calibrations; misses a linear toe); gog: a fitted "
        "gain-offset-gamma curve with its residuals",
    )
    fit.add_argument("--label", default="", type=one_line, help="display, photometer, operator")
    fit.add_argument("--replace", action="store_true", help=REPLACE_HELP)
    fit.set_defaults(run=_calibrate_fit)

    export = calibrate_commands.add_parser(
        "export-monitor",
        help="write a calibration into a PsychoPy Monitor Center monitor (a new calibration)",
    )
    export.add_argument("calibration", type=Path, help="a glarelab calibration JSON")
    export.add_argument(
        "--monitor", required=True, metavar="NAME", help="the monitor (made if new)"
    )
    export.add_argument(
        "--protocol",
        default=None,
        help="a study (shipped name or TOML file): the monitor gets its display's size in "
        "pixels and width and its viewing distance",
    )
    export.add_argument(
        "--monitor-folder",
        type=Path,
        default=None,
        metavar="DIR",
        help="Monitor Center's folder of monitors (default PsychoPy's, ~/.psychopy3/monitors)",
    )
    export.set_defaults(run=_calibrate_export_monitor)

    measure = calibrate_commands.add_parser(
        "measure", help="measure a display with a photometer (PsychoPy, full-field patches)"
    )
    measure.add_argument("--out", type=Path, required=True, help="calibration JSON to write")
    measure.add_argument(
        "--bit-depth",
        type=int,
        default=None,
        choices=(8, 10, 12, 16),
        help="the display's bits (default 10)",
    )
    measure.add_argument(
        "--points", type=count(4, 4096), default=None, help="codes measured (default 33)"
    )
    measure.add_argument(
        "--order",
        choices=("random", "reversed"),
        default=None,
        help="order of the codes (default random)",
    )
    measure.add_argument(
        "--verify-points",
        type=count(1, 1024),
        default=None,
        help="codes measured again to verify (1-1024, default 5): the status of a calibration "
        "comes only from its verification pass",
    )
    measure.add_argument(
        "--tolerance",
        type=number(0, 1, above=True),
        default=None,
        help="relative error allowed for 'passed' (default 0.03)",
    )
    measure.add_argument(
        "--seed", type=count(0), default=None, help="seed of the code order (default 0)"
    )
    measure.add_argument(
        "--label", default=None, type=one_line, help="display, photometer, operator"
    )
    measure.add_argument(
        "--protocol",
        nargs="+",
        default=None,
        metavar="STUDY",
        help="verify also the luminances these studies name (a shipped study's name or a "
        "TOML file): the region of the curve their images use",
    )
    measure.add_argument("--replace", action="store_true", help=REPLACE_HELP)
    measure.add_argument("--windowed", action="store_true", help="a window, not full screen")
    measure.add_argument(
        "--allow-fewer-bits",
        action="store_true",
        help="measure although the window gives fewer bits per channel than --bit-depth",
    )
    measure.add_argument(
        "--simulate",
        type=number(0),
        nargs=3,
        metavar=("WHITE", "BLACK", "GAMMA"),
        default=None,
        help="a simulated photometer instead of typed readings (dry runs): a display of "
        "L = BLACK + (WHITE - BLACK) x^GAMMA, WHITE > BLACK >= 0 cd/m², GAMMA > 0",
    )
    measure.add_argument(
        "--photometer",
        choices=tuple(PHOTOMETERS),
        default=None,
        help="read the patches with this photometer (PsychoPy's plugins: pip install "
        "'glarelab[photometer]'); without it the operator types the readings",
    )
    measure.add_argument(
        "--port", default=None, help="the photometer's serial port (/dev/ttyUSB0, COM3, …)"
    )
    measure.add_argument(
        "--photometer-serial",
        default=None,
        help="the photometer's serial number, recorded (for models that do not report it)",
    )
    measure.add_argument(
        "--readings",
        type=count(1, 100),
        default=None,
        help="photometer readings per patch (default 3)",
    )
    measure.add_argument(
        "--settle-s",
        type=number(0, 600),
        default=None,
        help="seconds a patch is shown before its first reading (default 1)",
    )
    measure.add_argument(
        "--spread",
        type=number(0, 1, above=True),
        default=None,
        help="largest (max - min) / median of a patch's readings before it is read again "
        "(default 0.01)",
    )
    measure.add_argument(
        "--repeats",
        type=count(0, 20),
        default=None,
        help="times a patch whose readings disagree is read again (default 2)",
    )
    measure.add_argument(
        "--resume",
        action="store_true",
        help="go on with the session of --out that stopped (a fault, Escape, a crash)",
    )
    measure.set_defaults(run=_calibrate_measure)
