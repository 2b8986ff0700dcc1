"""The ``glarelab`` commands of display calibration: calibrate fit, calibrate measure."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from protocols.atomic import write_bytes
from stimuli.calibration import Calibration, fit_calibration, read_readings

from .common import count, number, output_file
from .common import log as _log

REPLACE_HELP = (
    "write over the --out calibration (kept as STEM.replaced-N.json); without it an existing "
    "--out is kept and the new calibration gets a new name"
)


def _free_name(path: Path, tag: str) -> Path:
    """``STEM-TAG2.json``, ``STEM-TAG3.json``, … : the first that does not exist."""
    for index in range(2, 10_000):
        candidate = path.with_name(f"{path.stem}{tag}{index}{path.suffix}")
        if not candidate.exists() and not candidate.is_symlink():
            return candidate
    raise ValueError(f"{path}: 10,000 calibrations of this name; give another --out")


def calibration_out(path: Path, *, replace: bool, inputs=()) -> Path:
    """Where a new calibration goes: ``path`` if it is free; beside it under a new name if a
    file is there (which is kept as it was); over it with ``replace``, when it is a glarelab
    calibration, which is then kept as ``STEM.replaced-N.json``."""
    path = Path(path)
    if not (path.exists() or path.is_symlink()):
        return output_file(path, (".json",), "calibration", inputs=inputs)
    if not replace:
        new = _free_name(path, "-")
        output_file(new, (".json",), "calibration", inputs=inputs)
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
    kept = _free_name(path, ".replaced-")
    write_bytes(kept, path.read_bytes())
    _log(f"the calibration {path} is replaced; it is kept as {kept}")
    return path


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
    args.out = calibration_out(args.out, replace=args.replace, inputs=[args.readings])
    calibration.save(args.out)
    _log(
        f"{len(readings)} readings → {args.method} calibration, {calibration.black_cd_m2:.4g}-"
        f"{calibration.max_cd_m2:.4g} cd/m², status '{calibration.status}' → {args.out}"
    )
    if calibration.model:
        _log(
            f"gain-offset-gamma residuals: RMS {calibration.model['rms_residual_cd_m2']:.3g} cd/m²"
        )
    return 0


def _calibrate_measure(args: argparse.Namespace) -> int:
    from stimuli.measure import MeasurementSession
    from stimuli.measure_psychopy import run_measurement

    args.out = calibration_out(args.out, replace=args.replace)

    session = MeasurementSession(
        bit_depth=args.bit_depth,
        out=args.out,
        rng=np.random.default_rng(args.seed),
        points=args.points,
        order=args.order,
        verify_points=args.verify_points,
        tolerance_fraction=args.tolerance,
        label=args.label,
    )
    photometer = None
    if args.simulate is not None:  # a display following L = black + (white - black) x^gamma
        white, black, gamma = args.simulate
        top = 2**args.bit_depth - 1

        def photometer(code: int) -> float:
            return black + (white - black) * (code / top) ** gamma

    result = run_measurement(
        session,
        photometer=photometer,
        fullscr=not args.windowed,
        allow_fewer_bits=args.allow_fewer_bits,
        log=_log,
    )
    for flag in result["flags"]:
        _log(f"flag: {flag}")
    _log(f"calibration status: {result['status']}; session saved at {session.session_path}")
    return 0 if result["status"] == "passed" else 1


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser."""
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
        choices=("pchip", "gog"),
        default="pchip",
        help="pchip: monotone interpolation in a gamma-linearised space; gog: a fitted "
        "gain-offset-gamma curve with its residuals",
    )
    fit.add_argument("--label", default="", help="display, photometer, operator")
    fit.add_argument("--replace", action="store_true", help=REPLACE_HELP)
    fit.set_defaults(run=_calibrate_fit)

    measure = calibrate_commands.add_parser(
        "measure", help="measure a display with a photometer (PsychoPy, full-field patches)"
    )
    measure.add_argument("--out", type=Path, required=True, help="calibration JSON to write")
    measure.add_argument(
        "--bit-depth", type=int, default=10, choices=(8, 10, 12, 16), help="the display's bits"
    )
    measure.add_argument("--points", type=count(4, 4096), default=33, help="codes measured")
    measure.add_argument(
        "--order", choices=("random", "reversed"), default="random", help="order of the codes"
    )
    measure.add_argument(
        "--verify-points", type=count(0, 1024), default=5, help="codes measured again to verify"
    )
    measure.add_argument(
        "--tolerance",
        type=number(0, 1, above=True),
        default=0.03,
        help="relative error allowed for 'passed'",
    )
    measure.add_argument("--seed", type=count(0), default=0, help="seed of the code order")
    measure.add_argument("--label", default="", help="display, photometer, operator")
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
        help="a simulated photometer instead of typed readings (dry runs)",
    )
    measure.set_defaults(run=_calibrate_measure)
