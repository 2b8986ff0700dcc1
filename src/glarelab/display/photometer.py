"""Photometers on a serial port, through PsychoPy's hardware plugins, and the reading of a patch.

PsychoPy's Monitor Center drives the lab photometers through its plugins: ``psychopy-minolta``
(Konica Minolta LS-100, LS-110, CS-100A), ``psychopy-photoresearch`` (PR-655, PR-670) and
``psychopy-crs`` (CRS ColorCAL MKII). :func:`open_photometer` opens one of them by its model
name and wraps it in a :class:`Photometer` whose :meth:`~Photometer.read` returns a luminance or
raises a :class:`PhotometerError` that says what went wrong and what to do: no answer, an answer
that is not a reading, a reading over or under the instrument's range, a cable pulled out. The
plugins themselves only log such faults and return ``-1`` (or raise a bare ``KeyError``); the
wrapper keeps the plugin's own serial exchange (its ``sendMessage``) and looks at the raw reply
to tell the faults apart, and records each reply as it came.

:func:`measure_patch` reads a patch as a lab does: waits for it to settle, takes a number of
readings, checks that they agree, and takes them again (up to a limit) when they do not.

The plugins are an optional extra (``pip install glarelab[photometer]``); this module imports
without them, and :func:`open_photometer` says which package to install when one is missing.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from typing import Literal

import numpy as np

try:  # a pulled cable can fail pyserial's tcdrain with termios.error, which is no OSError
    from termios import error as _TermiosError

    _LINE_ERRORS: tuple[type[BaseException], ...] = (OSError, _TermiosError)
except ImportError:  # pragma: no cover - Windows has no termios
    _LINE_ERRORS = (OSError,)

__all__ = [
    "PHOTOMETERS",
    "Disconnected",
    "Garbled",
    "LineSettings",
    "NoAnswer",
    "OutOfRange",
    "PatchProtocol",
    "PatchResult",
    "Photometer",
    "PhotometerError",
    "PluginMissing",
    "measure_patch",
    "open_photometer",
]


PhotometerModel = Literal["LS-100", "LS-110", "CS-100A", "PR-655", "ColorCAL"]


class PhotometerError(RuntimeError):
    """A photometer fault, with what to do about it in the message."""


class NoAnswer(PhotometerError):
    """The photometer did not answer within the plugin's timeout."""


class Garbled(PhotometerError):
    """The photometer answered something that is not a reading."""


class LineSettings(Garbled):
    """The photometer answered bytes that are not text: the serial line is set up otherwise
    than the instrument (baud rate, data bits, parity, stop bits)."""


class OutOfRange(PhotometerError):
    """The reading is over or under the photometer's measuring range."""


class Disconnected(PhotometerError):
    """The serial port went away (cable pulled, adapter unplugged, instrument off)."""


class PluginMissing(ImportError):
    """The PsychoPy plugin of a photometer is not installed."""


@dataclass(frozen=True)
class _Model:
    plugin: str  # the PyPI distribution
    module: str
    name: str  # the plugin's class
    floor_cd_m2: float  # lowest luminance the instrument measures (maker's data sheet)
    ceiling_cd_m2: float  # highest
    serial_settings: str
    switch_on: str
    reports_serial_number: bool


# measuring ranges from the makers' data sheets: Konica Minolta LS-100/LS-110 ("0.001 to
# 299,900 cd/m²", LS-110 "0.01 to 999,900 cd/m²"), CS-100A ("0.01 to 299,000 cd/m²"); Photo
# Research PR-655 and CRS ColorCAL MKII are given the plugin's own range checks only (a
# reading <= 0 or the instrument's error code)
PHOTOMETERS: dict[str, _Model] = {
    "LS-100": _Model(
        "psychopy-minolta",
        "psychopy_minolta",
        "LS100",
        0.001,
        299_900.0,
        "RS-232C, 4800 baud, 7 data bits, even parity, 2 stop bits",
        "switch it on while holding F (the display then shows '[' at the bottom right)",
        False,
    ),
    "LS-110": _Model(
        "psychopy-minolta",
        "psychopy_minolta",
        "LS100",
        0.01,
        999_900.0,
        "RS-232C, 4800 baud, 7 data bits, even parity, 2 stop bits",
        "switch it on while holding F (the display then shows '[' at the bottom right)",
        False,
    ),
    "CS-100A": _Model(
        "psychopy-minolta",
        "psychopy_minolta",
        "CS100A",
        0.01,
        299_000.0,
        "RS-232C, 4800 baud, 7 data bits, even parity, 2 stop bits",
        "switch it on while holding F (the display then shows '[' at the bottom right)",
        False,
    ),
    "PR-655": _Model(
        "psychopy-photoresearch",
        "psychopy_photoresearch",
        "PR655",
        0.0,
        float("inf"),
        "USB (a virtual serial port), 9600 baud, 8 data bits, no parity, 1 stop bit",
        "switch it on; the plugin puts it into remote mode",
        True,
    ),
    "ColorCAL": _Model(
        "psychopy-crs",
        "psychopy_crs.colorcal",
        "ColorCAL",
        0.0,
        float("inf"),
        "USB (a virtual serial port, /dev/ttyACM0 on Linux)",
        "plug it in; an early MKII needs its zero calibration in the dark first",
        True,
    ),
}

# error codes the Minolta instruments answer with (the plugin's table): which are range faults
_MINOLTA_RANGE_CODES = ("ER10", "ER19")
# status codes a Photo Research PR-650/655 puts first in its reply to a measurement (M0), as
# Psychtoolbox's PR655measspd.m reads them: 0 a reading, 18 a reading (the source too weak to
# synchronise to), -1 or 10 too little light; psychopy-photoresearch (0.0.3) does not look at
# it and reads the luminance of the D3 report, which after a failed measurement is the last one
_PR_READING_CODES = (0, 18)
_PR_LOW_LIGHT_CODES = (-1, 10)


@dataclass
class Photometer:
    """An open photometer: a plugin's device object, its model and serial number.

    Use :func:`open_photometer` to make one.

    Attributes
    ----------
    model
        The model's name, a key of :data:`PHOTOMETERS` (``'LS-100'``, ``'PR-655'``, ...).
    port
        The serial port it answers on (``'/dev/ttyUSB0'``, ``'COM3'``).
    device
        The PsychoPy plugin's device object that talks to it.
    serial_number
        The serial number it reports; None where it reports none.
    plugin_version
        The version of the PsychoPy plugin that drives it.
    replies
        The instrument's raw replies to the last command, as they came.
    """

    model: str
    port: str
    device: object
    serial_number: str | None
    plugin_version: str
    replies: list[str] = field(default_factory=list)

    @property
    def last_reply(self) -> str:
        return self.replies[-1] if self.replies else ""

    def describe(self) -> dict:
        """What a session file records about the instrument."""
        return {
            "model": self.model,
            "port": self.port,
            "serial_number": self.serial_number,
            "plugin": f"{PHOTOMETERS[self.model].plugin} {self.plugin_version}",
        }

    def read(self) -> tuple[float, str]:
        """One luminance reading, cd/m², and the instrument's raw replies exactly as they came
        (line ends included; `` | `` between the replies of a reading that takes several
        commands, as the PR-655's).

        Raises
        ------
        NoAnswer, Garbled, OutOfRange, Disconnected
            Each with the port, the reply and what to do.
        """
        spec = PHOTOMETERS[self.model]
        self.replies.clear()
        try:
            value = self.device.getLum()
        except UnicodeDecodeError:  # the plugin decodes each reply as UTF-8 (a ValueError)
            raise _line_settings(self.model, self.port, self.last_reply) from None
        except (KeyError, ValueError, IndexError, TypeError, AttributeError) as error:
            if not any(reply.strip(" \r\n>[]'") for reply in self.replies):
                raise NoAnswer(
                    f"the {self.model} on {self.port} does not answer; check that it is on and "
                    f"in remote mode ({spec.switch_on}) and the cable is in"
                ) from None
            # the Minolta plugin looks unknown replies up in its table of error codes (KeyError)
            # or parses them as a number (ValueError)
            raise Garbled(
                f"the {self.model} on {self.port} answered {self.last_reply!r}, which is not a "
                f"reading ({type(error).__name__}: {error}); check the serial settings "
                f"({spec.serial_settings}) and that nothing else uses the port"
            ) from None
        except _LINE_ERRORS as error:  # serial.SerialException is an OSError
            raise Disconnected(
                f"lost the {self.model} on {self.port} ({error}); plug the cable back in and "
                "check the instrument is on: the measurement goes on from this patch"
            ) from None
        reply = self.last_reply.strip()
        if getattr(self.device, "ok", True) is False:  # the ColorCAL's status of its reading
            raise Garbled(
                f"the {self.model} on {self.port} answered {reply!r} instead of a reading; "
                "check the instrument, then try again"
            )
        if value is None or value == -1:
            if not reply:
                raise NoAnswer(
                    f"the {self.model} on {self.port} does not answer; check that it is on and "
                    f"in remote mode ({spec.switch_on}) and the cable is in"
                )
            if reply[:4] in _MINOLTA_RANGE_CODES:
                raise OutOfRange(
                    f"the {self.model} reports over range ({reply}: more light than it "
                    f"measures, {spec.ceiling_cd_m2:g} cd/m²); check its range setting and any "
                    "filter, or type the reading from another instrument"
                )
            raise Garbled(
                f"the {self.model} on {self.port} answered {reply!r} instead of a reading; "
                "check the instrument's display for an error (battery, memory), then try again"
            )
        if self.model == "PR-655":
            self._check_pr_status(reply)
        value = float(value)
        if not np.isfinite(value):
            raise Garbled(f"the {self.model} on {self.port} answered {reply!r}: not a number")
        if value > spec.ceiling_cd_m2:
            raise OutOfRange(
                f"the {self.model} read {value:g} cd/m², over its range "
                f"({spec.ceiling_cd_m2:g} cd/m²); check the range setting and any filter"
            )
        # no instrument reads a display as 0 (dark current, noise): 0 is "nothing measured"
        if value < spec.floor_cd_m2 or value <= 0:
            below = f"{spec.floor_cd_m2:g} cd/m²" if spec.floor_cd_m2 > 0 else "no light measured"
            raise OutOfRange(
                f"the {self.model} read {value:g} cd/m², under its range ({below}): too "
                "little light for it (a dark patch of an OLED, or the lens cap on); type the "
                "reading from a more sensitive instrument, or check the cap"
            )
        return value, " | ".join(self.replies)  # as they came, line ends included

    def _check_pr_status(self, reply: str) -> None:
        """Refuse a PR-655 reading whose measurement (the first reply, to M0) failed."""
        first = self.replies[0] if self.replies else ""
        try:
            status = int(first.split(",")[0])
        except ValueError:
            raise Garbled(
                f"the {self.model} on {self.port} answered {first!r} to the measurement, not "
                "a status; check the cable and that nothing else uses the port, then try again"
            ) from None
        if status in _PR_LOW_LIGHT_CODES:
            raise OutOfRange(
                f"the {self.model} reports too little light (status {status}): under its range; "
                "check the lens cap and the aim, or type the reading from a more sensitive "
                "instrument"
            )
        if status not in _PR_READING_CODES:
            raise Garbled(
                f"the {self.model} on {self.port} reports status {status} for the measurement, "
                "not a reading (its manual lists the codes); check the instrument, then try again"
            )

    def close(self) -> None:
        com = getattr(self.device, "com", None)
        try:
            if com:
                com.close()
        except OSError:
            pass


def _load_class(model: str):
    spec = PHOTOMETERS[model]
    try:
        module = importlib.import_module(spec.module)
    except ImportError as error:
        raise PluginMissing(
            f"the {model} is driven by PsychoPy's {spec.plugin} plugin, which is not installed "
            f"({error}); pip install 'glarelab[photometer]'"
        ) from None
    return getattr(module, spec.name), metadata.version(spec.plugin)


def open_photometer(
    model: PhotometerModel, port: str, *, serial_number: str | None = None
) -> Photometer:
    """Open a photometer through its PsychoPy plugin.

    Parameters
    ----------
    model
        One of :data:`PHOTOMETERS`: ``'LS-100'``, ``'LS-110'``, ``'CS-100A'``, ``'PR-655'``,
        ``'ColorCAL'``.
    port
        The serial port (``/dev/ttyUSB0``, ``COM3``, ``/dev/cu.usbserial-…``).
    serial_number
        The instrument's serial number, for instruments that do not report it (the Minolta
        ones); one that reports it is asked.

    Raises
    ------
    ValueError
        For an unknown model.
    PluginMissing
        When the model's plugin is not installed (names the package; an ImportError).
    NoAnswer, Garbled
        When the port opens but no photometer answers on it as the model would.
    Disconnected
        When the port does not open.
    """
    if model not in PHOTOMETERS:
        raise ValueError(f"photometer must be one of {', '.join(PHOTOMETERS)}; got {model!r}")
    spec = PHOTOMETERS[model]
    cls, version = _load_class(model)
    import serial  # pyserial, a dependency of every plugin

    try:
        serial.Serial(port).close()
    except (OSError, ValueError) as error:
        raise Disconnected(
            f"cannot open the serial port {port!r} for the {model} ({error}); check the port "
            "name (ls /dev/tty*), the cable, and that your user may use it (group dialout)"
        ) from None
    replies: list[str] = []
    try:
        device = _recording(cls, replies)(port)
    except UnicodeDecodeError:
        raise _line_settings(model, port, replies[-1] if replies else "") from None
    except _LINE_ERRORS as error:  # serial.SerialException
        raise Disconnected(
            f"lost the serial port {port!r} while opening the {model} ({error})"
        ) from None
    except Exception as error:  # a plugin that trips over an unexpected answer
        if not any(reply.strip(" \r\n>[]'") for reply in replies):
            raise NoAnswer(
                f"no {model} answers on {port}; check that it is on and in remote mode "
                f"({spec.switch_on}), the cable ({spec.serial_settings}) and the port"
            ) from None
        raise Garbled(
            f"the {spec.plugin} plugin could not open a {model} on {port} (it answered "
            f"{replies[-1] if replies else 'nothing'!r}; {type(error).__name__}: {error}); "
            f"check the model, the serial settings ({spec.serial_settings}) and the port"
        ) from None
    photometer = Photometer(model, port, device, serial_number, version, replies=replies)
    if not (getattr(device, "OK", False) and getattr(device, "ok", True)):
        photometer.close()
        answered = [reply for reply in replies if reply.strip(" \r\n>[]'")]
        if answered:
            raise Garbled(
                f"something on {port} answers {answered[-1]!r}, not as a {model} does; check "
                f"the serial settings ({spec.serial_settings}) and the model"
            )
        raise NoAnswer(
            f"no {model} answers on {port}; check that it is on and in remote mode "
            f"({spec.switch_on}), the cable ({spec.serial_settings}) and the port"
        )
    if spec.reports_serial_number:
        reported = device.getDeviceSN() if hasattr(device, "getDeviceSN") else device.serialNum
        photometer.serial_number = str(reported) or serial_number
    return photometer


NOT_TEXT = "not text: "  # how a reply of bytes that are not UTF-8 is kept


def _line_settings(model: str, port: str, reply: str) -> LineSettings:
    """The fault of a reply that is not text: a serial line set up otherwise than the
    instrument (a baud rate or parity that differs turns every character into others, most of
    them with the high bit set)."""
    spec = PHOTOMETERS[model]
    return LineSettings(
        f"the {model} on {port} answered bytes that are not text ({reply.removeprefix(NOT_TEXT)})"
        f": the serial line's settings differ from the instrument's ({spec.serial_settings}; "
        "a wrong baud rate or parity, set on the instrument or on a USB-serial adapter); set "
        "them alike, then try again"
    )


def _recording(cls, replies: list[str]):
    """The plugin's class with each raw reply kept (its own serial exchange, unchanged); a
    reply the plugin cannot decode (bytes that are not UTF-8) is kept as its bytes,
    ``not text: b'…'``, before the plugin's error goes on."""

    def send_and_keep(self, message, *args, **kwargs):
        try:
            reply = cls.sendMessage(self, message, *args, **kwargs)
        except UnicodeDecodeError as error:
            replies.append(f"{NOT_TEXT}{error.object!r}")
            raise
        # a spectrum (the PR-655's D5) comes as a list of lines: kept as its length
        replies.append(reply if isinstance(reply, str) else f"<{len(reply)} lines>")
        return reply

    return type(cls.__name__, (cls,), {"sendMessage": send_and_keep})


@dataclass(frozen=True)
class PatchProtocol:
    """How one patch is read.

    Parameters
    ----------
    readings
        Readings per patch (their median is the patch's luminance); default 3.
    settle_s
        Time after the patch appears before the first reading, s; default 1 (an LCD's
        response and backlight, and the photometer's own integration, settle well within it).
    spread_fraction
        Largest ``(max - min) / median`` of a patch's readings; default 0.01 (the LS-100's
        repeatability is 0.2 % + 1 digit).
    spread_floor_cd_m2
        Spread always allowed, cd/m² (the last digit of a dark reading); default 0.002.
    repeats
        Times a patch whose readings disagree is read again before it is accepted with a flag;
        default 2.
    """

    readings: int = 3
    settle_s: float = 1.0
    spread_fraction: float = 0.01
    spread_floor_cd_m2: float = 0.002
    repeats: int = 2

    def __post_init__(self) -> None:
        if not 1 <= self.readings <= 100:
            raise ValueError(f"readings must be 1-100 per patch; got {self.readings!r}")
        if not 0 <= self.settle_s <= 600:
            raise ValueError(f"settle_s must be 0-600 s; got {self.settle_s!r}")
        if not 0 < self.spread_fraction < 1:
            raise ValueError(f"spread_fraction must be in (0, 1); got {self.spread_fraction!r}")
        if not 0 <= self.spread_floor_cd_m2:
            raise ValueError(f"spread_floor_cd_m2 must be >= 0; got {self.spread_floor_cd_m2!r}")
        if not 0 <= self.repeats <= 20:
            raise ValueError(f"repeats must be 0-20; got {self.repeats!r}")

    def allowed_spread(self, median_cd_m2: float) -> float:
        """The largest spread (max − min) a patch's readings may have, cd/m².

        Parameters
        ----------
        median_cd_m2
            The median of the patch's readings, cd/m².

        Returns
        -------
        float
            ``max(spread_fraction × median, spread_floor_cd_m2)``, cd/m².
        """
        return max(self.spread_fraction * median_cd_m2, self.spread_floor_cd_m2)


@dataclass
class PatchResult:
    """A patch read: its luminance (median of the accepted readings), every reading taken.

    Attributes
    ----------
    luminance_cd_m2
        The median of the last set of readings, cd/m².
    readings
        Every reading taken, cd/m², in order, over all sets.
    sets
        The sets of readings taken (more than 1: the earlier ones disagreed).
    flags
        ``'unsteady: ...'`` when even the last set disagreed; empty otherwise.
    """

    luminance_cd_m2: float
    readings: list[float]
    sets: int
    flags: list[str] = field(default_factory=list)


def measure_patch(
    read: Callable[[], tuple[float, str]],
    protocol: PatchProtocol,
    *,
    wait: Callable[[float], None] = time.sleep,
    keep: Callable[[dict], None] = lambda row: None,
    what: str = "the patch",
) -> PatchResult:
    """Read a patch: settle, ``protocol.readings`` readings, repeated while they disagree.

    Parameters
    ----------
    read
        One reading: ``(cd/m², raw reply)`` (:meth:`Photometer.read`).
    protocol
        Readings, settling time and spread allowed.
    wait
        Waits so many seconds (a window keeps showing the patch meanwhile).
    keep
        Called with every reading as it is taken (``{'set', 'cd_m2', 'reply'}``), before the
        next one, so a fault later loses none.
    what
        Names the patch in flags.

    Returns
    -------
    PatchResult
        The median of the last set; a flag when even the last set disagreed.

    Raises
    ------
    PhotometerError
        From ``read``; the readings taken before it were already passed to ``keep``.

    Examples
    --------
    >>> values = iter([10.0, 10.01, 13.0, 10.02, 10.0, 10.01])
    >>> result = measure_patch(lambda: (next(values), ""), PatchProtocol(settle_s=0), wait=None)
    >>> result.luminance_cd_m2, result.sets
    (10.01, 2)
    """
    sets = protocol.repeats + 1
    flags: list[str] = []
    everything: list[float] = []
    for index in range(sets):
        if protocol.settle_s and wait is not None:
            wait(protocol.settle_s)
        values = []
        for _ in range(protocol.readings):
            value, reply = read()
            values.append(value)
            everything.append(value)
            keep({"set": index, "cd_m2": value, "reply": reply})
        median = float(np.median(values))
        spread = max(values) - min(values)
        if spread <= protocol.allowed_spread(median):
            return PatchResult(median, everything, index + 1, flags)
        if index == sets - 1:
            flags.append(
                f"unsteady: {what} read {min(values):g}-{max(values):g} cd/m² in its last of "
                f"{sets} sets (more than {protocol.allowed_spread(median):.3g} cd/m² apart); "
                "the median is used"
            )
    return PatchResult(median, everything, sets, flags)
