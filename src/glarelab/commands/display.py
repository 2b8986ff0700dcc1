"""The ``glarelab`` commands of the display check: check-display."""

from __future__ import annotations

import argparse
from pathlib import Path

from glarelab.display.calibration import Calibration
from glarelab.display.photometer import PHOTOMETERS
from glarelab.files.folders import record_written
from glarelab.protocols import load_protocol

from .common import (
    add_accept_calibration,
    add_monitor_options,
    apply_monitor,
    claim_output,
    count,
    number,
    output_file,
)
from .common import log as _log

# the options that act only through the photometer, with their defaults
PHOTOMETER_OPTIONS = {"readings": 3, "settle_s": 1.0, "photometer_serial": None}


def _check_display(args: argparse.Namespace) -> int:
    from glarelab.frontend.check_display import check_display, write_check

    given = [name for name in PHOTOMETER_OPTIONS if getattr(args, name) is not None]
    if given and args.photometer is None:
        shown = ", ".join("--" + name.replace("_", "-") for name in given)
        raise ValueError(
            f"{shown} without --photometer: only the photometer's readings use it, so it would "
            "be ignored; give --photometer MODEL --port PORT, or leave it out"
        )
    if args.accept_mismatch and args.calibration is None:
        raise ValueError(
            "--accept-mismatch calibration without --calibration: there is no calibration "
            "whose mismatch could be accepted, so it would be ignored"
        )
    protocol, monitor = apply_monitor(args, load_protocol(args.protocol))
    calibration = Calibration.load(args.calibration) if args.calibration else None
    if args.out is not None:
        out = args.out
    elif args.calibration is not None:
        out = args.calibration.with_suffix(".display-check.json")
    else:
        raise ValueError("give --out FILE, or --calibration (the check is written next to it)")
    output_file(
        out,
        (".json",),
        "display check",
        inputs=[args.calibration] if args.calibration else (),
        force=args.force,
    )
    meter = None
    if args.photometer is not None or args.port is not None:
        from glarelab.display.photometer import open_photometer

        if args.photometer is None or args.port is None:
            raise ValueError("give --photometer MODEL and --port PORT together")
        meter = open_photometer(args.photometer, args.port, serial_number=args.photometer_serial)
    try:
        result = check_display(
            protocol,
            stimuli=args.stimuli,
            calibration=calibration,
            frames=args.frames,
            fullscreen=not args.windowed,
            photometer=meter,
            patch_protocol=_patch_protocol(args),
            log=_log,
            monitor=monitor,
            accept_mismatch="calibration" in (args.accept_mismatch or ()),
        )
    finally:
        if meter is not None:
            meter.close()
    empty = result["frame_intervals_empty"]
    print(
        f"screen {result['resolution_px'][0]} × {result['resolution_px'][1]} px, refresh "
        f"{result['refresh_hz_measured'] or float('nan'):.2f} Hz measured, frame intervals "
        f"{empty['median_ms']:.2f} ± {empty['sd_ms']:.2f} ms (worst {empty['max_ms']:.1f} ms, "
        f"{100 * empty['late_fraction']:.1f} % late), {result['bits_per_channel']} bits per "
        f"channel ({result['framebuffer_levels']} of {result['framebuffer_levels_asked']} "
        "levels distinct in the frame buffer)"
    )
    for check in result["checks"]:
        print(
            f"  {'ok  ' if check['passed'] else 'FAIL'} {check['name']}: protocol "
            f"{check['expected']}, display {check['actual']}"
            + (f" (accepted: --accept-mismatch {check['name']})" if check.get("accepted") else "")
        )
    if "images" in result:
        images = result["images"]
        print(
            f"read back {len(images)} images of {args.stimuli} at "
            f"{result['bits_per_channel']} bits per channel:"
        )
        if not images:
            print("  FAIL the set has no image this check can show: nothing was read back")
        for image in images:
            exact = image["exact_fraction"] == 1.0 and image["worst_code_difference"] == 0
            if not image["places"]:
                print(f"  FAIL {image['image']}: {image['problem']}")
                continue
            line = (
                f"  {'ok  ' if exact else 'FAIL'} {image['image']}: "
                f"{100 * image['exact_fraction']:.3f} % of {image['pixels']} px exact in "
                f"{image['places']} place(s), worst difference {image['worst_code_difference']} "
                "codes"
            )
            if image.get("problem"):
                line += f" ({image['problem']})"
            elif image["first_difference"] is not None:
                row, column, shown, expected = image["first_difference"]
                line += f"; first at row {row}, column {column}: {shown}, not {expected}"
            print(line)
    if "flash" in result:
        flash = result["flash"]
        print(
            f"flash frame: draw {flash['draw_median_ms']:.2f} ms (99th percentile "
            f"{flash['draw_p99_ms']:.2f}), {100 * flash['draw_fraction_of_frame']:.1f} % of a "
            f"{flash['frame_period_ms']:.2f} ms frame; flip to flip "
            f"{flash['frame_intervals_drawing']['median_ms']:.2f} ms"
        )
    if "photometer" in result:
        found = result["photometer"]
        if found["fault"]:
            print(f"photometer fault: {found['fault']}")
        else:
            print(
                f"photometer ({found['instrument']['model']}): black "
                f"{found['black_cd_m2']:.4g} cd/m², white {found['white_cd_m2']:.4g} cd/m²"
            )
    claim_output(out, "check-display")  # the next check (after a driver change) replaces it
    _log(f"wrote {write_check(result, out)}")
    record_written(Path(out).parent, [Path(out).name])  # written: a later check replaces it
    passed = all(c["passed"] or c.get("accepted") for c in result["checks"])
    passed = passed and result.get("images_exact", True)
    return 0 if passed else 1


def _patch_protocol(args: argparse.Namespace):
    from glarelab.display.photometer import PatchProtocol

    values = {
        name: PHOTOMETER_OPTIONS[name] if getattr(args, name) is None else getattr(args, name)
        for name in ("readings", "settle_s")
    }
    return PatchProtocol(**values)


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    check = commands.add_parser(
        "check-display",
        help="measure the display: resolution, refresh, frame jitter, bits, a flash's cost, and "
        "read every image of a stimulus set back from the screen",
    )
    check.add_argument("protocol", help="a shipped protocol's name or a protocol TOML file")
    check.add_argument(
        "--stimuli",
        type=Path,
        default=None,
        help="also draw every image of this set, read the screen back and compare it with the "
        "set's codes (and time a flash of it)",
    )
    check.add_argument(
        "--calibration",
        type=Path,
        default=None,
        help="the display calibration (of the protocol's display: its bit depth and white)",
    )
    add_accept_calibration(
        check,
        "check although the calibration's white is not the protocol display's (calibration; "
        "recorded in the check)",
    )
    add_monitor_options(check)
    check.add_argument(
        "--out", type=Path, default=None, help="JSON to write (default: next to --calibration)"
    )
    check.add_argument(
        "--force",
        action="store_true",
        help="write the check over a file of that name glarelab did not write (its own earlier "
        "check is replaced without it)",
    )
    check.add_argument(
        "--frames", type=count(30, 100_000), default=600, help="flips per measurement"
    )
    check.add_argument("--windowed", action="store_true", help="a window, not full screen")
    check.add_argument(
        "--photometer",
        choices=tuple(PHOTOMETERS),
        default=None,
        help="also measure black, white and the calibration's luminances with this photometer",
    )
    check.add_argument("--port", default=None, help="the photometer's serial port")
    check.add_argument(
        "--photometer-serial", default=None, help="the photometer's serial number, recorded"
    )
    check.add_argument(
        "--readings",
        type=count(1, 100),
        default=None,
        help="photometer readings per patch (default 3; with --photometer)",
    )
    check.add_argument(
        "--settle-s",
        type=number(0, 600),
        default=None,
        help="seconds before a patch is read (default 1; with --photometer)",
    )
    check.set_defaults(run=_check_display)
