"""Checking the screen and the calibration against the protocol before the first trial.

A protocol's stimuli are what it says only on the display it describes: its resolution sets the
pixel size and so every visual angle, its refresh rate turns every timed presentation into a
number of frames, its bits per channel set the luminance steps, and the calibration that turns
luminance into codes must be this display's. Each is checked before any trial (the calibration
before the window opens, the screen once it is open and measured):

- ``resolution``: the screen's pixels equal ``display.resolution_px``;
- ``refresh``: the refresh rate measured on the open window is within
  :data:`REFRESH_TOLERANCE_FRACTION` of ``display.refresh_hz``; a measurement that failed (no
  stable frame interval) is its own finding, ``refresh-unmeasured``;
- ``bit-depth``: the window gives at least ``display.bit_depth`` bits per channel;
- ``calibration``: the calibration has the protocol's bit depth and its white is within
  ``display.white_tolerance`` of ``display.max_cd_m2``.

A failed check refuses the session, naming both values, unless the session accepts that
mismatch explicitly (``--accept-mismatch NAME``, ``--allow-unmeasured-refresh``); every check,
passed or accepted, is recorded in the session's sidecar. A session whose refresh was not
verified times its presentations at the protocol's nominal rate, paced by the clock.

No PsychoPy here: the front-end measures the screen (:class:`ScreenFacts`).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = [
    "CHECKS",
    "REFRESH_TOLERANCE_FRACTION",
    "Check",
    "DisplayMismatch",
    "ScreenFacts",
    "check_calibration",
    "check_screen",
    "enforce",
    "refuse_other_display",
    "timing_rate_hz",
]

# a display's real rate is within a fraction of a per cent of its nominal one (59.94 vs 60 Hz);
# 2 % tells a 60 Hz display from a 59, 75 or 120 Hz one and tolerates measurement jitter
REFRESH_TOLERANCE_FRACTION = 0.02
CHECKS = ("resolution", "refresh", "refresh-unmeasured", "bit-depth", "calibration")


class DisplayMismatch(ValueError):
    """The display or calibration is not the protocol's; nothing was written."""


@dataclass(frozen=True)
class ScreenFacts:
    """What the open window measured.

    Parameters
    ----------
    resolution_px
        The screen's (width, height) in pixels.
    refresh_hz
        Measured refresh rate; None when the measurement failed.
    bits_per_channel
        Bits per colour channel the window was given.
    """

    resolution_px: tuple[int, int]
    refresh_hz: float | None
    bits_per_channel: int


@dataclass(frozen=True)
class Check:
    """One comparison of the display with the protocol.

    Attributes
    ----------
    name
        Which check, one of :data:`CHECKS`.
    expected
        What the protocol asks for, in words with units (``'1920 × 1080 px'``).
    actual
        What the display has, in the same words.
    passed
        Whether the display is what the protocol asks for.
    accepted
        Whether a failed check was accepted for this session (``--accept-mismatch``);
        default False.
    """

    name: str
    expected: str
    actual: str
    passed: bool
    accepted: bool = False

    def message(self) -> str:
        return f"{self.name}: the protocol asks for {self.expected}, the display has {self.actual}"


def check_calibration(protocol: Protocol, calibration) -> list[Check]:
    """The calibration belongs to the protocol's display: bit depth, and white luminance within
    ``display.white_tolerance`` (a fraction) of ``display.max_cd_m2``. No calibration, no check
    (an uncalibrated session is refused or recorded elsewhere).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The session's protocol; without a ``[display]``, nothing is checked.
    calibration : glarelab.display.calibration.Calibration or None
        The session's calibration.

    Returns
    -------
    list of Check
        The ``calibration`` check, or none.

    Raises
    ------
    TypeError
        For a ``calibration`` that is not a Calibration (a file's path: read it with
        ``Calibration.load``).
    """
    from glarelab.display.calibration import Calibration

    if calibration is not None and not isinstance(calibration, Calibration):
        raise TypeError(
            f"calibration must be a Calibration (Calibration.load(path) reads a file) or None; "
            f"got {type(calibration).__name__} {calibration!r}"
        )
    if calibration is None or not protocol.data.get("display"):
        return []
    display = protocol["display"]
    tolerance = display["white_tolerance"]
    white = calibration.max_cd_m2
    return [
        Check(
            "calibration",
            f"a {display['bit_depth']}-bit calibration with white {display['max_cd_m2']:g} "
            f"cd/m² (± {100 * tolerance:g} %)",
            f"a {calibration.bit_depth}-bit calibration with white {white:.4g} cd/m²"
            + (f" ({calibration.label})" if calibration.label else ""),
            calibration.bit_depth == display["bit_depth"]
            and abs(white - display["max_cd_m2"]) <= tolerance * display["max_cd_m2"],
        )
    ]


def refuse_other_display(
    protocol: Protocol,
    calibration,
    *,
    accept_mismatch: bool = False,
    codes: str,
    encoded: str,
    anyway: str,
) -> Check:
    """Refuse a calibration of another display than the protocol's, as a stimulus set's build
    and a display check do: a bit depth not the display's always, a white not its
    ``max_cd_m2`` (:func:`check_calibration`) unless ``accept_mismatch``.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The protocol, with a ``[display]``.
    calibration : glarelab.display.calibration.Calibration
        The calibration given.
    accept_mismatch
        Accept a white that is not the display's (``--accept-mismatch calibration``); default
        False.
    codes
        What a bit depth of another display would do, in words (``"the set's images are that
        display's codes"``).
    encoded
        What a white of another display would do, in words.
    anyway
        How to go on anyway, in words (``"build anyway with --accept-mismatch calibration
        (sessions check again)"``).

    Returns
    -------
    Check
        The ``calibration`` check, ``accepted`` when it failed and ``accept_mismatch``.

    Raises
    ------
    ValueError
        For a bit depth not the display's, or a white not its own unless ``accept_mismatch``,
        naming both.
    """
    display = protocol["display"]
    if calibration.bit_depth != display["bit_depth"]:
        raise ValueError(
            f"the calibration is for a {calibration.bit_depth}-bit display, the protocol's "
            f"display is {display['bit_depth']}-bit: {codes}, so no mismatch of bit depth can "
            "be accepted; calibrate the protocol's display, or set the protocol's "
            "display.bit_depth to your display's"
        )
    (fits,) = check_calibration(protocol, calibration)
    if not fits.passed and not accept_mismatch:
        raise ValueError(
            f"the calibration is not of the {protocol.study} protocol's display: it is "
            f"{fits.actual}, the protocol asks for {fits.expected}; {encoded}. Calibrate the "
            f"protocol's display, edit the protocol's [display] for yours, or {anyway}"
        )
    if not fits.passed:
        return Check(fits.name, fits.expected, fits.actual, False, accepted=True)
    return fits


def check_screen(protocol: Protocol, facts: ScreenFacts) -> list[Check]:
    """Resolution, refresh rate and bits per channel of the open window against the protocol.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The session's protocol; without a ``[display]``, nothing is checked.
    facts
        What the open window measured.

    Returns
    -------
    list of Check
        ``resolution``; ``refresh`` (within :data:`REFRESH_TOLERANCE_FRACTION`) or
        ``refresh-unmeasured``; ``bit-depth`` (at least the protocol's).
    """
    if not protocol.data.get("display"):
        return []
    display = protocol["display"]
    width, height = display["resolution_px"]
    nominal = display["refresh_hz"]
    checks = [
        Check(
            "resolution",
            f"{width} × {height} px",
            f"{facts.resolution_px[0]} × {facts.resolution_px[1]} px",
            tuple(facts.resolution_px) == (width, height),
        )
    ]
    if facts.refresh_hz is None:
        checks.append(
            Check(
                "refresh-unmeasured",
                f"a measured refresh rate of {nominal:g} Hz",
                "no stable frame interval (the measurement failed)",
                False,
            )
        )
    else:
        checks.append(
            Check(
                "refresh",
                f"{nominal:g} Hz (± {100 * REFRESH_TOLERANCE_FRACTION:g} %)",
                f"{facts.refresh_hz:.2f} Hz measured",
                abs(facts.refresh_hz - nominal) <= REFRESH_TOLERANCE_FRACTION * nominal,
            )
        )
    checks.append(
        Check(
            "bit-depth",
            f"{display['bit_depth']} bits per channel",
            f"{facts.bits_per_channel} bits per channel",
            facts.bits_per_channel >= display["bit_depth"],
        )
    )
    return checks


def enforce(checks: Iterable[Check], *, accept: Iterable[str] = ()) -> list[dict]:
    """Refuse on any failed check not accepted; return every check as a record.

    Parameters
    ----------
    checks
        The checks made (:func:`check_calibration`, :func:`check_screen`).
    accept
        Names of checks (:data:`CHECKS`) whose failure the session accepts; default none.

    Returns
    -------
    list of dict
        Every check as a dict of its fields, an accepted failure marked ``accepted``, for the
        session's sidecar.

    Raises
    ------
    DisplayMismatch
        Naming each failed check with the protocol's and the display's values and the option
        that would accept it.
    ValueError
        If ``accept`` names a check that does not exist.
    """
    accept = set(accept)
    unknown = accept - set(CHECKS)
    if unknown:
        raise ValueError(f"accept must name checks among {', '.join(CHECKS)}; got {unknown}")
    records, refused = [], []
    for check in checks:
        if not check.passed and check.name in accept:
            check = Check(check.name, check.expected, check.actual, False, accepted=True)
        elif not check.passed:
            refused.append(check)
        records.append(asdict(check))
    if refused:
        names = [c.name for c in refused if c.name != "refresh-unmeasured"]
        options = " and ".join(
            ([f"--accept-mismatch {' '.join(names)}"] if names else [])
            + (["--allow-unmeasured-refresh"] if len(names) < len(refused) else [])
        )
        raise DisplayMismatch(
            "the display is not the protocol's: "
            + "; ".join(c.message() for c in refused)
            + f". Fix the display or the protocol, or accept it with {options} (recorded in "
            "the session's sidecar)"
        )
    return records


def timing_rate_hz(protocol: Protocol, facts: ScreenFacts | None, records: list[dict]) -> float:
    """The frame rate presentations are timed at: the measured one when the refresh check
    passed, else the protocol's nominal rate (the window then paces frames by the clock).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The session's protocol; its ``display.refresh_hz`` (default 60) is the nominal rate.
    facts
        What the open window measured; None when nothing was measured.
    records
        The checks' records (:func:`enforce`).

    Returns
    -------
    float
        Frames per second, Hz.
    """
    nominal = (protocol.data.get("display") or {}).get("refresh_hz", 60.0)
    passed = any(r["name"] == "refresh" and r["passed"] for r in records)
    if passed and facts is not None and facts.refresh_hz is not None:
        return float(facts.refresh_hz)
    return float(nominal)
