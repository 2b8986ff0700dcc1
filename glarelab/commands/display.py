"""The ``glarelab`` commands of the display check: check-display."""

from __future__ import annotations

import argparse
from pathlib import Path

from protocols import load_protocol
from stimuli.calibration import Calibration

from .common import count, output_file
from .common import log as _log


def _check_display(args: argparse.Namespace) -> int:
    from experiments.check_display import check_display, write_check

    protocol = load_protocol(args.protocol)
    calibration = Calibration.load(args.calibration) if args.calibration else None
    if args.out is not None:
        out = args.out
    elif args.calibration is not None:
        out = args.calibration.with_suffix(".display-check.json")
    else:
        raise ValueError("give --out FILE, or --calibration (the check is written next to it)")
    output_file(
        out, (".json",), "display check", inputs=[args.calibration] if args.calibration else ()
    )
    result = check_display(
        protocol,
        stimuli=args.stimuli,
        calibration=calibration,
        frames=args.frames,
        fullscreen=not args.windowed,
        log=_log,
    )
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
        )
    if "flash" in result:
        flash = result["flash"]
        print(
            f"flash frame: draw {flash['draw_median_ms']:.2f} ms (99th percentile "
            f"{flash['draw_p99_ms']:.2f}), {100 * flash['draw_fraction_of_frame']:.1f} % of a "
            f"{flash['frame_period_ms']:.2f} ms frame; flip to flip "
            f"{flash['frame_intervals_drawing']['median_ms']:.2f} ms"
        )
    _log(f"wrote {write_check(result, out)}")
    return 0 if all(c["passed"] for c in result["checks"]) else 1


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser."""
    check = commands.add_parser(
        "check-display",
        help="measure the display: resolution, refresh, frame jitter, bits, a flash's cost",
    )
    check.add_argument("protocol", help="a shipped protocol's name or a protocol TOML file")
    check.add_argument("--stimuli", type=Path, default=None, help="also time a flash of this set")
    check.add_argument("--calibration", type=Path, default=None, help="the display calibration")
    check.add_argument(
        "--out", type=Path, default=None, help="JSON to write (default: next to --calibration)"
    )
    check.add_argument(
        "--frames", type=count(30, 100_000), default=600, help="flips per measurement"
    )
    check.add_argument("--windowed", action="store_true", help="a window, not full screen")
    check.set_defaults(run=_check_display)
