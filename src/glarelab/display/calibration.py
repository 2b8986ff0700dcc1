"""Display calibration: from photometer readings to luminance ↔ drive-code conversion.

A calibration maps every drive code of a display (0 … 2^bits - 1) to the luminance it
produces. It is built from readings (code → cd/m², as from a Minolta LS-100) by a monotone
piecewise-cubic interpolant (PCHIP) or by a gain-offset-gamma model (with its residuals
reported). PCHIP comes in two spaces:

- ``'pchip-log'`` (the default): log(L − black) against log(code). A power law (a gamma
  display) is a straight line there, and so is the linear toe of an sRGB-type curve (sRGB's
  EOTF, IEC 61966-2-1, is linear below 4 % of the code range; ITU-R BT.1886 displays and
  monitors' "gamma 2.4 with a linear part" bend likewise), so PCHIP follows both, and the bend
  between them, from a few readings. Below the first code measured above 0 the curve goes on
  as the power law of the first two readings (a model of the toe): interpolating from code 0
  cannot, as log(code) has no value there.
- ``'pchip'``: ((L − black) / (white − black))^(1/2.2) against the code, the space of earlier
  calibrations (kept so that their files give the same luminances): it follows a gamma display
  but misses a linear toe by 20-50 % near black (an sRGB display with 33 or 65 readings).

Encoding picks, for each luminance, the code whose luminance is nearest, so the error is at
most half the local code step inside the display's range; luminances above the maximum or
below the black level are clipped to the end codes and counted, never wrapped.

A calibration file (JSON) carries its date, the readings and their hash, the method, and a
verification status: ``unverified`` after fitting, ``passed`` or ``failed`` after a
verification pass, ``synthetic`` for the made-up displays shipped for demos.
"""

from __future__ import annotations

import csv
import datetime as dt
import hashlib
import io
import itertools
import json
import math
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Literal

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.optimize import curve_fit

from glarelab.files.atomic import write_text
from glarelab.files.inputs import as_path, loads_json, read_input_text
from glarelab.files.values import DECIMAL_TEXT, WHOLE_TEXT, is_real, is_whole, plain_array

__all__ = [
    "Calibration",
    "EncodeReport",
    "fit_calibration",
    "read_readings",
    "synthetic_calibration",
    "usable_calibration",
    "verification_outcome",
]

FORMAT = "glarelab display calibration v1"
SYNTHETIC_GAMMA = 2.2  # the synthetic displays follow L = black + (max - black) (c/cmax)^2.2
LINEARISING_GAMMA = 2.2  # 'pchip' interpolates in (normalised luminance)^(1/2.2)
TOE_EXPONENTS = (0.5, 5.0)  # the toe's power law, bounded: no display's curve is steeper
METHODS = ("pchip-log", "pchip", "gog")

# the brightest displays reach about 1e4 cd/m² (HDR reference monitors); a reading ten
# times that is a typo or a reading in another unit, never a display
MAX_DISPLAY_CD_M2 = 1e5
# the eye's absolute threshold is near 1e-6 cd/m² (Hood & Finkelstein 1986, Handbook of
# Perception and Human Performance, vol. 1, ch. 5) and photometers stop orders of magnitude
# above it: a positive reading below it (5e-324, a subnormal float) is no measurement; a
# black below the photometer's floor is read as 0
MIN_READING_CD_M2 = 1e-6
READING_RANGE = (
    f"0 (below the photometer's floor) or {MIN_READING_CD_M2:g}-{MAX_DISPLAY_CD_M2:g} cd/m² "
    "(no display is brighter, no photometer reads less: a typo or a unit slip?)"
)


def _plausible_reading(value: float) -> bool:
    """A luminance a photometer can have read off a display: 0, or within the range above."""
    return bool(
        np.isfinite(value) and (value == 0 or MIN_READING_CD_M2 <= value <= MAX_DISPLAY_CD_M2)
    )


@dataclass(frozen=True)
class EncodeReport:
    """What encoding did to an image: pixels clipped above the maximum or below black.

    Attributes
    ----------
    above_max
        Pixels brighter than the display's maximum, shown at the top code.
    below_black
        Pixels darker than its black, shown at code 0.
    max_error_cd_m2
        The largest difference between a pixel inside the display's range and the luminance
        of its code, cd/m² (at most half the local code step).
    pixels
        Values encoded in all (pixels times channels).
    """

    above_max: int
    below_black: int
    max_error_cd_m2: float
    pixels: int

    @property
    def clipped(self) -> int:
        return self.above_max + self.below_black


def _gog(
    code_fraction: np.ndarray, gain: float, offset: float, gamma: float, black: float, peak: float
):
    drive = np.clip(gain * code_fraction + offset, 0.0, None)
    return black + (peak - black) * drive**gamma


def _log_log_curve(data: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """Luminance of ``codes`` from ``data`` (code, cd/m² rows from code 0, increasing): PCHIP
    through log(L − black) against log(code), and below the first code above 0 the power law
    of the first two readings, ``black + (L1 − black)(c / c1)^k``, its exponent bounded by
    :data:`TOE_EXPONENTS`.

    Examples
    --------
    >>> codes = np.arange(256.0)
    >>> x = codes / 255
    >>> srgb = 0.1 + 99.9 * np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
    >>> read = [0, 2, 4, 8, 12, 16, 24, 32, 48, 64, 96, 128, 160, 192, 224, 255]  # denser low
    >>> fitted = _log_log_curve(np.column_stack([read, srgb[read]]), codes)
    >>> bool(np.all(np.abs(fitted - srgb) <= 0.002 * srgb))  # 0.2 % everywhere, toe included
    True
    """
    black = data[0, 1]
    measured, excess = data[1:, 0], data[1:, 1] - black
    x, y = np.log(measured), np.log(excess)
    curve = PchipInterpolator(x, y, extrapolate=False)
    values = np.full(codes.shape, black, dtype=float)
    inside = codes >= measured[0]
    values[inside] = black + np.exp(curve(np.log(np.minimum(codes[inside], measured[-1]))))
    exponent = float(np.clip((y[1] - y[0]) / (x[1] - x[0]), *TOE_EXPONENTS))
    toe = (codes > 0) & ~inside
    values[toe] = black + excess[0] * (codes[toe] / measured[0]) ** exponent
    return values


@dataclass(frozen=True)
class Calibration:
    """Luminance of every drive code of a display.

    Attributes
    ----------
    bit_depth
        Bits per channel (codes 0 … 2^bits - 1).
    readings
        ``(code, cd/m²)`` pairs measured (or made up, for a synthetic display).
    method
        ``'pchip-log'``, ``'pchip'`` or ``'gog'`` (see the module notes).
    created
        ISO date of the fit.
    status
        ``'unverified'``, ``'passed'``, ``'failed'`` or ``'synthetic'``.
    label
        Free text: display, photometer, who measured.
    model
        GOG parameters and residuals when ``method == 'gog'``.
    verification
        The verification pass (targets, codes, measured luminances, errors, tolerance).
    """

    bit_depth: int
    readings: tuple[tuple[int, float], ...]
    method: Literal["pchip-log", "pchip", "gog"] = "pchip-log"
    created: str = ""
    status: Literal["unverified", "passed", "failed", "synthetic"] = "unverified"
    label: str = ""
    model: dict = field(default_factory=dict)
    verification: dict = field(default_factory=dict)

    @property
    def n_codes(self) -> int:
        return 2**self.bit_depth

    @property
    def readings_sha256(self) -> str:
        text = json.dumps([[int(c), float(v)] for c, v in self.readings])
        return hashlib.sha256(text.encode()).hexdigest()

    @property
    def curve_sha256(self) -> str:
        """The sha256 of what fixes each code's luminance: bit depth, method, readings, model.

        Two calibrations of one digest encode every luminance alike, whatever their label,
        date or verification; a refit of the same readings by another method differs."""
        text = json.dumps(
            [self.bit_depth, self.method, self.readings_sha256, self.model], sort_keys=True
        )
        return hashlib.sha256(text.encode()).hexdigest()

    @cached_property
    def lut(self) -> np.ndarray:
        """Luminance of every code, cd/m² (monotone non-decreasing; computed once, read-only)."""
        codes = np.arange(self.n_codes, dtype=float)
        data = np.array(self.readings, dtype=float)
        if self.method == "pchip-log":
            values = _log_log_curve(data, codes)
        elif self.method == "pchip":
            # interpolate in a linearised space, y = ((L - black) / (white - black))^(1/2.2):
            # a gamma display is nearly a straight line there, so its toe near black is
            # followed (in plain luminance PCHIP misses it by 18 % at twice black with 9
            # readings); the transform is monotone, so any measured curve stays monotone
            black, white = data[0, 1], data[-1, 1]
            y = ((data[:, 1] - black) / (white - black)) ** (1 / LINEARISING_GAMMA)
            curve = PchipInterpolator(data[:, 0], y, extrapolate=False)
            fitted = np.clip(curve(np.clip(codes, data[0, 0], data[-1, 0])), 0.0, 1.0)
            values = black + (white - black) * fitted**LINEARISING_GAMMA
        elif self.method == "gog":
            p = self.model
            values = _gog(
                codes / (self.n_codes - 1),
                p["gain"],
                p["offset"],
                p["gamma"],
                p["black_cd_m2"],
                p["max_cd_m2"],
            )
        else:
            raise ValueError(f"method must be one of {', '.join(METHODS)}; got {self.method!r}")
        values = np.maximum.accumulate(values)
        values.setflags(write=False)
        return values

    @property
    def black_cd_m2(self) -> float:
        return float(self.lut[0])

    @property
    def max_cd_m2(self) -> float:
        return float(self.lut[-1])

    def decode(self, codes: np.ndarray) -> np.ndarray:
        """Luminance (cd/m²) the display shows for drive codes.

        Parameters
        ----------
        codes
            Integer drive codes, any shape, in 0 … 2^bit_depth − 1.

        Returns
        -------
        numpy.ndarray
            The luminance of each code, cd/m², the shape of ``codes``.

        Raises
        ------
        ValueError
            For a code outside the display's range, or codes that are not integers (10.7,
            True, '12').
        """
        codes = plain_array("codes", codes)
        if codes.dtype.kind not in "iu":
            raise ValueError(
                f"codes must be integer drive codes (an integer array); got dtype {codes.dtype}"
            )
        if codes.size and (codes.min() < 0 or codes.max() >= self.n_codes):
            bad = codes.min() if codes.min() < 0 else codes.max()
            raise ValueError(
                f"codes must be in [0, {self.n_codes - 1}] for a {self.bit_depth}-bit display; "
                f"got {int(bad)}"
            )
        return self.lut[codes.astype(np.int64)]

    def encode(self, luminance_cd_m2: np.ndarray) -> tuple[np.ndarray, EncodeReport]:
        """Drive codes (uint16) for a luminance image, and a report of what was clipped.

        Each luminance gets the code whose luminance is nearest: within the display's range
        the error is at most half the step between neighbouring codes.

        Parameters
        ----------
        luminance_cd_m2
            Linear luminance, cd/m², any shape, finite; values beyond the display's black and
            maximum are clipped to codes 0 and 2^bit_depth − 1 (and counted).

        Returns
        -------
        codes : numpy.ndarray
            uint16, the shape of ``luminance_cd_m2``.
        report : EncodeReport
            The pixels clipped and the largest error inside the range.

        Raises
        ------
        ValueError
            If a luminance is not a finite real number (strings, bools, complex numbers and
            masked arrays are refused, not converted).
        """
        values = plain_array("luminance_cd_m2", luminance_cd_m2)
        if values.dtype.kind not in "iuf":
            raise ValueError(
                f"luminance_cd_m2 must hold real numbers (cd/m²); got dtype {values.dtype}"
            )
        values = values.astype(float)
        if not np.isfinite(values).all():
            raise ValueError("luminance_cd_m2 must be finite to be encoded")
        lut = self.lut
        upper = np.clip(np.searchsorted(lut, values, side="left"), 1, self.n_codes - 1)
        lower = upper - 1
        nearer_upper = np.abs(lut[upper] - values) < np.abs(values - lut[lower])
        codes = np.where(nearer_upper, upper, lower)
        codes = np.where(values >= lut[-1], self.n_codes - 1, codes)
        codes = np.where(values <= lut[0], 0, codes)
        # the table's ends as the readings give them: a luminance equal to the top reading
        # is not above the maximum when the fitted curve ends 1e-16 below it
        top, bottom = lut[-1] * (1 + ENDS_TOLERANCE), lut[0] * (1 - ENDS_TOLERANCE)
        inside = (values >= lut[0]) & (values <= lut[-1])
        error = np.abs(lut[codes] - values)[inside]
        report = EncodeReport(
            above_max=int((values > top).sum()),
            below_black=int((values < bottom).sum()),
            max_error_cd_m2=float(error.max()) if error.size else 0.0,
            pixels=int(values.size),
        )
        return codes.astype(np.uint16), report

    def step_cd_m2(self, codes: np.ndarray) -> np.ndarray:
        """Luminance step to the neighbouring codes (the larger of the two), cd/m².

        Parameters
        ----------
        codes
            Integer drive codes, any shape, in 0 … 2^bit_depth − 1.

        Returns
        -------
        numpy.ndarray
            The step at each code, cd/m²: what one code more or less changes.
        """
        lut = self.lut
        codes = np.asarray(codes, dtype=np.int64)
        up = lut[np.minimum(codes + 1, self.n_codes - 1)] - lut[codes]
        down = lut[codes] - lut[np.maximum(codes - 1, 0)]
        return np.maximum(up, down)

    def verified(
        self,
        measurements: list[tuple[float, int, float]],
        *,
        tolerance_fraction: float = 0.03,
    ) -> Calibration:
        """This calibration with a verification pass recorded.

        Parameters
        ----------
        measurements
            ``(target cd/m², code shown, measured cd/m²)`` triples.
        tolerance_fraction
            Largest allowed ``|measured - target| / target``; default 3 %.
        """
        rows = []
        for target, code, measured in measurements:
            rows.append(
                {
                    "target_cd_m2": float(target),
                    "code": int(code),
                    "measured_cd_m2": float(measured),
                    "relative_error": abs(float(measured) - float(target)) / float(target),
                }
            )
        worst = max(r["relative_error"] for r in rows) if rows else float("inf")
        # a synthetic display (made-up readings, a simulated photometer) stays synthetic: its
        # verification pass says whether the measurement works, not that a display is known
        if self.status == "synthetic":
            status = "synthetic"
        else:
            status = verification_outcome(worst, tolerance_fraction)
        verification = {
            "tolerance_fraction": tolerance_fraction,
            "max_relative_error": worst,
            "measurements": rows,
            "date": dt.date.today().isoformat(),
        }
        verification["sha256"] = _verification_sha256(self.readings_sha256, verification)
        return replace(self, status=status, verification=verification)

    def to_json(self) -> dict:
        return {
            "format": FORMAT,
            "label": self.label,
            "created": self.created,
            "status": self.status,
            "method": self.method,
            "bit_depth": self.bit_depth,
            "readings": [[int(c), float(v)] for c, v in self.readings],
            "readings_sha256": self.readings_sha256,
            "model": self.model,
            "verification": self.verification,
            "black_cd_m2": self.black_cd_m2,
            "max_cd_m2": self.max_cd_m2,
        }

    def save(self, path: str | Path) -> Path:
        """Write the calibration as JSON (:meth:`to_json`), whole or not at all.

        Parameters
        ----------
        path
            The file; its folder is created.

        Returns
        -------
        pathlib.Path
            ``path``.

        Raises
        ------
        ValueError
            For a calibration :meth:`load` would refuse (:meth:`checked`: a status its
            verification pass does not give, a model its readings do not give, ...): nothing
            is written.
        """
        self.checked(source=str(path))  # never a file the next session cannot load
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps(self.to_json(), indent=2) + "\n")  # whole or not at all
        return path

    @classmethod
    def from_json(cls, data: dict, *, source: str = "calibration") -> Calibration:
        """A calibration from its JSON form (a file, or a stimulus-set manifest), checking its
        format and the hash of its readings.

        Parameters
        ----------
        data
            The JSON object, as :meth:`to_json` writes it.
        source
            Where it came from, for the messages; default ``'calibration'``.

        Returns
        -------
        Calibration
            The calibration.

        Raises
        ------
        ValueError
            If ``data`` is not a glarelab calibration, lacks a field, has malformed values,
            readings that do not match their hash, or a method, model, range or status that
            its readings and its verification pass do not give (an edited file).
        """
        if not isinstance(data, dict):
            raise ValueError(
                f"{source}: not a glarelab calibration (a JSON {type(data).__name__}, "
                "not an object)"
            )
        if data.get("format") != FORMAT:
            raise ValueError(
                f"{source}: not a glarelab calibration (format {data.get('format')!r})"
            )
        try:
            _whole("bit_depth", data["bit_depth"], source)
            for pair in data["readings"]:
                if not isinstance(pair, list | tuple) or len(pair) != 2:
                    raise ValueError(f"a reading must be [code, cd/m²]; got {pair!r}")
                _whole("a reading's code", pair[0], source)
            calibration = cls(
                bit_depth=int(data["bit_depth"]),
                readings=tuple((int(c), float(v)) for c, v in data["readings"]),
                method=data["method"],
                created=data["created"],
                status=data["status"],
                label=data.get("label", ""),
                model=data.get("model", {}),
                verification=data.get("verification", {}),
            )
        except KeyError as error:
            raise ValueError(f"{source}: the calibration has no {error.args[0]!r}") from None
        except (TypeError, ValueError) as error:
            raise ValueError(f"{source}: a malformed calibration ({error})") from None
        if calibration.readings_sha256 != data.get("readings_sha256"):
            raise ValueError(f"{source}: the readings do not match their recorded hash (edited?)")
        _check_consistent(calibration, data, source)
        return calibration

    def checked(self, *, source: str = "calibration") -> Calibration:
        """This calibration, checked as its file would be (:meth:`from_json` of
        :meth:`to_json`): one made in Python is admitted only as one read from a file is.

        Parameters
        ----------
        source
            Its name in the messages; default ``'calibration'``.

        Returns
        -------
        Calibration
            The calibration.

        Raises
        ------
        ValueError
            As :meth:`from_json`: a status its verification pass does not give (``passed``
            without verification measurements), a model its readings do not give, ...

        Examples
        --------
        >>> readings = [(0, 0.5), (128, 40.0), (200, 120.0), (255, 200.0)]
        >>> fit_calibration(readings, bit_depth=8).checked().status
        'unverified'
        >>> forged = replace(fit_calibration(readings, bit_depth=8), status="passed")
        >>> forged.checked()  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        ValueError: calibration: status 'passed' without verification measurements; ...
        """
        return Calibration.from_json(self.to_json(), source=source)

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read a calibration file, checking its format and the hash of its readings.

        Parameters
        ----------
        path
            A JSON file written by :meth:`save`.

        Returns
        -------
        Calibration
            The calibration (:meth:`from_json`).

        Raises
        ------
        FileNotFoundError
            If there is no such file.
        ValueError
            If the file is not JSON, or as for :meth:`from_json`.
        """
        path = as_path(path, what="calibration file")
        text = read_input_text(path, what="calibration file")
        try:
            data = loads_json(text)
        except json.JSONDecodeError as error:
            raise ValueError(f"{path}: a calibration must be a JSON file; {error}") from None
        return cls.from_json(data, source=str(path))


def _whole(name: str, value, source: str) -> None:
    """A JSON whole number (not a bool, not 10.9 that ``int`` would truncate)."""
    if not is_whole(value):
        raise ValueError(f"{source}: {name} is {value!r}; must be a whole number")


def verification_outcome(max_relative_error: float, tolerance_fraction: float) -> str:
    """``'passed'`` when a verification pass's worst relative error is within its tolerance,
    else ``'failed'``: the one rule a calibration's status, its file's check and the
    measurement's report read.

    Parameters
    ----------
    max_relative_error
        The pass's largest ``|measured - target| / target``.
    tolerance_fraction
        The largest it may be.

    Returns
    -------
    str
        ``'passed'`` or ``'failed'``.

    Examples
    --------
    >>> verification_outcome(0.03, 0.03), verification_outcome(0.031, 0.03)
    ('passed', 'failed')
    """
    return "passed" if max_relative_error <= tolerance_fraction else "failed"


def _verification_sha256(readings_sha256: str, verification: dict) -> str:
    """The hash binding a verification pass to the readings it verified (as the readings'
    own hash: an edited tolerance, status or measurement no longer matches)."""
    body = {k: v for k, v in verification.items() if k != "sha256"}
    text = json.dumps([readings_sha256, body], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


STATUSES = ("unverified", "passed", "failed", "synthetic")
ENDS_TOLERANCE = 1e-9  # relative: a luminance this close to the table's end is at it
MODEL_TOLERANCE = 1e-6  # relative: a model re-fitted from the same readings agrees to 1e-9


def _close(a, b) -> bool:
    return abs(a - b) <= MODEL_TOLERANCE * max(abs(a), abs(b), 1e-12)


def _check_consistent(calibration: Calibration, data: dict, source: str) -> None:
    """Refuse a calibration whose method, model, range or status its readings and its
    verification pass do not give (an edited file).

    Raises
    ------
    ValueError
        Naming the field that disagrees, its value and the value the readings give.
    """
    if calibration.status not in STATUSES:
        raise ValueError(
            f"{source}: status {calibration.status!r} is not one of {', '.join(STATUSES)}"
        )
    if calibration.method not in METHODS:
        raise ValueError(
            f"{source}: method {calibration.method!r} is not one of {', '.join(METHODS)}"
        )
    if not isinstance(calibration.model, dict) or not isinstance(calibration.verification, dict):
        raise ValueError(f"{source}: model and verification must be JSON objects")
    try:
        ordered = _check_readings(list(calibration.readings), calibration.bit_depth, source)
    except ValueError as error:
        raise ValueError(f"{source}: its readings are not a calibration's ({error})") from None
    if calibration.method == "gog":
        refit = fit_calibration(ordered, bit_depth=calibration.bit_depth, method="gog").model
        for name in ("gain", "offset", "gamma", "black_cd_m2", "max_cd_m2"):
            value = calibration.model.get(name)
            if not is_real(value):
                raise ValueError(
                    f"{source}: method 'gog' with model {name} {value!r}: a gain-offset-gamma "
                    f"calibration records its model's numbers ({name} {refit[name]:.6g} from its "
                    "readings); a method or model edited?"
                )
            if not _close(float(value), refit[name]):
                raise ValueError(
                    f"{source}: the model's {name} is {value!r}, its readings give "
                    f"{refit[name]:.6g} (edited? fit the readings again)"
                )
    elif calibration.model:
        raise ValueError(
            f"{source}: a {calibration.method} calibration has no model; it holds one (edited?)"
        )
    lut = calibration.lut
    for name, value in (("black_cd_m2", float(lut[0])), ("max_cd_m2", float(lut[-1]))):
        recorded = data.get(name, value)
        if not is_real(recorded):
            raise ValueError(f"{source}: {name} is {recorded!r}; its readings give {value:.6g}")
        if not _close(float(recorded), value):
            raise ValueError(
                f"{source}: {name} is {recorded!r}, its readings give {value:.6g} (edited?)"
            )
    _check_status(calibration, source)


def _check_status(calibration: Calibration, source: str) -> None:
    """The status must be the one the verification data give."""
    verification = calibration.verification
    status = calibration.status
    if status == "synthetic" and not calibration.label.startswith("SYNTHETIC"):
        raise ValueError(f"{source}: status 'synthetic' for a display not labelled SYNTHETIC")
    if status == "unverified" and (
        calibration.label.startswith("SYNTHETIC") or calibration.created == "synthetic"
    ):  # a synthetic curve relabelled would pass for a display's measurement ('passed' needs
        # a verification pass, checked below)
        raise ValueError(
            f"{source}: status {status!r} for a synthetic display (labelled "
            f"{calibration.label[:40]!r}, created {calibration.created!r}): a synthetic "
            "calibration is a gamma curve, never measured, and keeps status 'synthetic' "
            "(edited?); fit a calibration from readings (glarelab calibrate fit)"
        )
    if status == "unverified" and verification:
        raise ValueError(
            f"{source}: status 'unverified' but it holds a verification pass; its status "
            "comes from that pass (edited?)"
        )
    if status in ("unverified", "synthetic") and not verification:
        return
    rows = verification.get("measurements")
    tolerance = verification.get("tolerance_fraction")
    if not isinstance(rows, list) or not rows:
        raise ValueError(
            f"{source}: status {status!r} without verification measurements; the status of a "
            "calibration comes only from its verification pass (glarelab calibrate measure)"
        )
    if not is_real(tolerance) or not 0 < tolerance <= 1:
        raise ValueError(
            f"{source}: verification tolerance_fraction is {tolerance!r}; must be a number in "
            "(0, 1]"
        )
    try:
        for r in rows:
            _whole("a verification code", r["code"], source)
            for key in ("measured_cd_m2", "target_cd_m2"):
                value = r[key]
                if not is_real(value):
                    raise TypeError
                if not (np.isfinite(value) and value > 0):
                    raise ValueError(
                        f"{source}: a verification measurement's {key} is {value!r}; must be "
                        "a finite luminance above 0 cd/m²"
                    )
        worst = max(
            abs(float(r["measured_cd_m2"]) - float(r["target_cd_m2"])) / float(r["target_cd_m2"])
            for r in rows
        )
        codes = [int(r["code"]) for r in rows]
    except (KeyError, TypeError, ZeroDivisionError):
        raise ValueError(f"{source}: a malformed verification measurement") from None
    if verification.get("sha256") != _verification_sha256(
        calibration.readings_sha256, verification
    ):
        raise ValueError(
            f"{source}: its verification pass does not match its recorded hash (sha256): the "
            "status, tolerance_fraction or measurements were edited, or written by hand; "
            "measure the display again (glarelab calibrate measure)"
        )
    if any(not 0 <= code < calibration.n_codes for code in codes):
        raise ValueError(f"{source}: a verification code is outside the display's codes")
    given = verification_outcome(worst, tolerance)
    if status != "synthetic" and given != status:
        raise ValueError(
            f"{source}: status {status!r}, but its verification measurements (worst error "
            f"{100 * worst:.2f} %, tolerance {100 * tolerance:.2f} %) give {given!r} (edited?)"
        )


def _check_bit_depth(bit_depth: object) -> None:
    if not is_whole(bit_depth) or bit_depth not in (8, 10, 12, 16):
        raise ValueError(f"bit_depth must be one of 8, 10, 12, 16; got {bit_depth!r}")


def _check_readings(
    readings: list[tuple[int, float]] | np.ndarray, bit_depth: int, source: str
) -> list[tuple[int, float]]:
    _check_bit_depth(bit_depth)
    if isinstance(readings, np.ndarray):  # one (code, cd/m²) per row: codes as whole floats
        if readings.ndim != 2 or readings.shape[1] != 2 or readings.dtype.kind not in "iuf":
            raise ValueError(
                f"{source}: readings as an array must be real numbers of shape (N, 2), one "
                f"(code, cd/m²) per row; got {readings.dtype} of shape {readings.shape}"
            )
        codes = readings[:, 0]
        fractional = ~(np.isfinite(codes) & (codes == np.round(codes)))
        if fractional.any():
            raise ValueError(
                f"{source}: a reading's code must be a whole number (a drive level); got "
                f"{float(codes[fractional][0])!r} in row {int(np.argmax(fractional))}"
            )
        readings = [(int(code), value.item()) for code, value in readings]
    if len(readings) < 4:
        raise ValueError(f"{source}: at least 4 readings are needed, got {len(readings)}")
    for reading in readings:
        if not isinstance(reading, tuple | list) or len(reading) != 2:
            raise ValueError(
                f"{source}: each reading must be a pair (code, cd/m²); got {reading!r}"
            )
        code, value = reading
        if not is_whole(code):
            whole_float = is_real(code) and math.isfinite(code) and float(code).is_integer()
            raise ValueError(
                f"{source}: a reading's code must be a whole number (a drive level); got "
                f"{code!r} in {reading!r}"
                + (
                    f" (a float: write {int(code)}; an (N, 2) array of floats is read as "
                    "whole codes)"
                    if whole_float
                    else ""
                )
            )
        if not is_real(value):
            raise ValueError(
                f"{source}: a reading's luminance must be a number of cd/m²; got {value!r} for "
                f"code {code}"
            )
    readings = [(int(code), float(value)) for code, value in readings]
    ordered = sorted(readings)
    top = 2**bit_depth - 1
    for code, value in ordered:
        if not 0 <= code <= top:
            raise ValueError(
                f"{source}: code {code} is outside 0-{top} for a {bit_depth}-bit display"
            )
        if not _plausible_reading(value):
            raise ValueError(
                f"{source}: code {code} has luminance {value!r}; must be {READING_RANGE}"
            )
    for (c0, v0), (c1, v1) in itertools.pairwise(ordered):
        if c1 == c0:
            raise ValueError(f"{source}: code {c0} is measured twice; average the readings first")
        if v1 == v0 == 0:  # an OLED's darkest codes below the photometer's floor
            zeros = [c for c, v in ordered if v == 0]
            raise ValueError(
                f"{source}: codes {', '.join(map(str, zeros))} all read 0 cd/m², below the "
                f"photometer's floor: keep the reading of code {zeros[0]} and leave out the "
                "others (a 0 says only that a luminance is under what the photometer reads; "
                "the fit then runs from black to the first reading above 0)"
            )
        if v1 <= v0:
            raise ValueError(
                f"{source}: luminance is not increasing: code {c1} → {v1:g} cd/m² is not above "
                f"code {c0} → {v0:g} cd/m² (photometer drift or a misread value?)"
            )
    if ordered[0][0] != 0 or ordered[-1][0] != top:
        raise ValueError(
            f"{source}: readings must include code 0 and code {top} (black and white)"
        )
    return ordered


def read_readings(path: str | Path) -> list[tuple[int, float]]:
    """Read photometer readings from a CSV with columns ``code`` and ``luminance_cd_m2``.

    Parameters
    ----------
    path
        The CSV file (UTF-8, a byte-order mark allowed, or UTF-16/32 with one: "Unicode
        text"); other columns are ignored, and so are empty cells after the last column (a
        spreadsheet's trailing comma).

    Returns
    -------
    list of tuple of (int, float)
        ``(code, cd/m²)`` in file order, not yet checked (:func:`fit_calibration` checks).

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    IsADirectoryError
        If ``path`` is a folder.
    ValueError
        If ``path`` is not a regular file (a FIFO, a device), is in another encoding (naming
        the byte), a column is missing, a cell is not a number, or a luminance is no
        reading of a display: negative, not finite, above ``MAX_DISPLAY_CD_M2`` or positive
        below ``MIN_READING_CD_M2`` (naming the line and the value as written).
    """
    path = as_path(path, what="readings file")
    text = read_input_text(path, what="readings file")
    rows = []
    reader = csv.DictReader(io.StringIO(text, newline=""))  # quoted newlines kept
    if reader.fieldnames:  # 'code, luminance_cd_m2' as typed: the names without the spaces
        reader.fieldnames = [name.strip() for name in reader.fieldnames]
    missing = {"code", "luminance_cd_m2"} - set(reader.fieldnames or [])
    if missing:
        first = text.splitlines()[0] if text.strip() else ""
        raise ValueError(
            f"{path}, line 1: missing column(s) {sorted(missing)}: the first line must name "
            f"the columns, comma-separated (code,luminance_cd_m2; other columns are ignored); "
            f"it is {first[:80]!r}"
        )
    names = [name.strip() for name in reader.fieldnames or []]
    repeated = sorted({name for name in names if names.count(name) > 1 and name})
    if repeated:
        raise ValueError(
            f"{path}, line 1: the column(s) {repeated} appear more than once; which one holds "
            "the readings? Name each column once"
        )
    for row in reader:
        line = reader.line_num  # the file's own line: empty lines are skipped, not counted
        if None in row and not any(cell.strip() for cell in row[None]):
            del row[None]  # empty cells after the last column: a spreadsheet's trailing comma
        if None in row:  # more cells than columns: a decimal comma splits a number
            cells = [row[name] or "" for name in reader.fieldnames] + list(row[None])
            written = ",".join(cells)
            if list(reader.fieldnames) == ["code", "luminance_cd_m2"] and len(cells) == 3:
                # the code is a whole number: the comma is in the luminance
                fix = f"write {cells[0]},{cells[1]}.{cells[2]} (luminance {cells[1]}.{cells[2]})"
            else:
                fix = "write each number with a decimal point"
            raise ValueError(
                f"{path}, line {line}: {len(cells)} cells for {len(reader.fieldnames)} columns "
                f"({', '.join(reader.fieldnames)}) in {written!r}; a decimal comma splits a "
                f"number: {fix}"
            )
        if not (row.get("code") or "").strip() or not (row.get("luminance_cd_m2") or "").strip():
            raise ValueError(
                f"{path}, line {line}: code and luminance_cd_m2 both need a value; got {row}"
            )
        code_text, value_text = row["code"].strip(), row["luminance_cd_m2"].strip()
        # as written, not as Python reads numbers ('12_8' is 128 to int(), '1_0.5' 10.5)
        if not (WHOLE_TEXT.fullmatch(code_text) and DECIMAL_TEXT.fullmatch(value_text)):
            raise ValueError(
                f"{path}, line {line}: code must be a whole number and luminance_cd_m2 a "
                f"decimal number (e.g. 512,94.83); got code {code_text!r}, luminance_cd_m2 "
                f"{value_text!r}"
            )
        code, value = int(code_text), float(value_text)
        if not _plausible_reading(value):  # named as written in the file
            raise ValueError(
                f"{path}, line {line}: code {code} has luminance_cd_m2 "
                f"{row['luminance_cd_m2'].strip()}; must be {READING_RANGE}"
            )
        rows.append((code, value))
    return rows


def fit_calibration(
    readings: list[tuple[int, float]] | np.ndarray,
    *,
    bit_depth: int,
    method: Literal["pchip-log", "pchip", "gog"] = "pchip-log",
    label: str = "",
    source: str = "readings",
) -> Calibration:
    """Build a calibration from ``(code, cd/m²)`` readings.

    Parameters
    ----------
    readings
        ``(drive code, luminance cd/m²)`` pairs, in any order (or an ``(N, 2)`` array, codes
        whole numbers): at least 4, codes 0 and 2^bit_depth − 1 among them, luminance
        increasing with code.
    bit_depth
        Bits per channel of the display.
    method
        ``'pchip-log'`` (default), ``'pchip'`` or ``'gog'`` (see the module notes).
    label
        Free text recorded with it: display, photometer, who measured.
    source
        Where the readings came from, for the messages; default ``'readings'``.

    Returns
    -------
    Calibration
        Unverified, dated today.

    Raises
    ------
    ValueError
        For a ``bit_depth`` other than the integers 8, 10, 12, 16, fewer than 4 readings, a
        reading that is not a pair of a whole-number code and a luminance number, codes
        outside the bit depth, a luminance neither 0 nor within ``MIN_READING_CD_M2``-
        ``MAX_DISPLAY_CD_M2``, a repeated code, readings that do not increase with code
        (named), readings without code 0 and the top code, or another ``method``.
    TypeError
        For readings that are not a sequence of pairs (a string, a dict), or a masked array.
    """
    if isinstance(readings, str | bytes | dict) or not hasattr(readings, "__iter__"):
        raise TypeError(
            f"{source}: readings must be a sequence of (code, cd/m²) pairs; got {readings!r:.80}"
        )
    if isinstance(readings, np.ma.MaskedArray):
        raise TypeError(
            f"{source}: readings must be a plain array, not a masked array (its mask would be "
            "ignored); leave the masked readings out"
        )
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    ordered = _check_readings(
        readings if isinstance(readings, np.ndarray) else list(readings), bit_depth, source
    )
    model: dict = {}
    if method == "gog":
        data = np.array(ordered, dtype=float)
        fraction = data[:, 0] / (2**bit_depth - 1)
        black, peak = data[0, 1], data[-1, 1]

        def curve(x, gain, offset, gamma):
            # the optimiser's trials reach a negative gamma at zero drive (inf) and overflow:
            # not the user's concern; the fit found is checked below
            with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
                return _gog(x, gain, offset, gamma, black, peak)

        params, _ = curve_fit(curve, fraction, data[:, 1], p0=(1.0, 0.0, 2.2), maxfev=20_000)
        residuals = curve(fraction, *params) - data[:, 1]
        if not (np.all(np.isfinite(params)) and np.all(np.isfinite(residuals))):
            raise ValueError(
                f"{source}: the gain-offset-gamma model does not fit these readings (its fit "
                "does not give a finite luminance at every code); use method 'pchip-log'"
            )
        model = {
            "gain": float(params[0]),
            "offset": float(params[1]),
            "gamma": float(params[2]),
            "black_cd_m2": float(black),
            "max_cd_m2": float(peak),
            "rms_residual_cd_m2": float(np.sqrt(np.mean(residuals**2))),
            "max_residual_cd_m2": float(np.abs(residuals).max()),
            "residuals_cd_m2": [float(r) for r in residuals],
        }
    elif method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")
    return Calibration(
        bit_depth=bit_depth,
        readings=tuple(ordered),
        method=method,
        created=dt.date.today().isoformat(),
        status="unverified",
        label=label,
        model=model,
    )


def synthetic_calibration(
    *, max_cd_m2: float, black_cd_m2: float, bit_depth: int, label: str = ""
) -> Calibration:
    """A made-up display following a 2.2 gamma, marked ``synthetic`` (for demos and tests,
    never for a real study: experiments treat it as uncalibrated).

    Parameters
    ----------
    max_cd_m2
        The white, cd/m².
    black_cd_m2
        The black, cd/m², below ``max_cd_m2``.
    bit_depth
        Bits per channel.
    label
        The label recorded; default: one that says it is synthetic and how it was made.

    Returns
    -------
    Calibration
        ``black + (max − black) (code / top)^2.2`` read at 33 codes and fitted (``'pchip'``),
        status ``synthetic``.

    Raises
    ------
    ValueError
        For a luminance no photometer reads off a display, a black not below the white, or
        a bit depth other than 8, 10, 12 or 16.
    """
    for name, value in (("max_cd_m2", max_cd_m2), ("black_cd_m2", black_cd_m2)):
        if not is_real(value) or not _plausible_reading(float(value)):
            raise ValueError(f"{name} must be {READING_RANGE}; got {value!r}")
    if not black_cd_m2 < max_cd_m2:
        raise ValueError(f"black_cd_m2 = {black_cd_m2!r} must be below max_cd_m2 = {max_cd_m2!r}")
    _check_bit_depth(bit_depth)
    top = 2**bit_depth - 1
    codes = np.unique(np.round(np.linspace(0, top, 33)).astype(int))
    values = black_cd_m2 + (max_cd_m2 - black_cd_m2) * (codes / top) ** SYNTHETIC_GAMMA
    text = (
        label
        or f"SYNTHETIC display: {max_cd_m2:g} cd/m², black {black_cd_m2:g}, "
        f"{bit_depth}-bit, gamma 2.2"
    )
    calibration = fit_calibration(  # the space of the shipped synthetic calibrations
        list(zip(codes.tolist(), values.tolist(), strict=True)),
        bit_depth=bit_depth,
        label=text,
        method="pchip",
    )
    return replace(calibration, status="synthetic", created="synthetic")


def usable_calibration(
    calibration: Calibration | None, *, allow_uncalibrated: bool = False
) -> dict:
    """Decide whether a session may run on this calibration; return what to record.

    A missing, failed or synthetic calibration is refused unless ``allow_uncalibrated`` (and
    the session data then say it ran uncalibrated); an unverified one runs with a warning.

    Parameters
    ----------
    calibration
        The session's calibration; ``None``: none given.
    allow_uncalibrated
        Whether to run anyway on a missing, failed or synthetic calibration; default False.

    Returns
    -------
    dict
        ``calibrated`` (bool), ``status``, ``readings_sha256`` and ``curve_sha256``
        (:attr:`Calibration.curve_sha256`; both None without a calibration).

    Raises
    ------
    ValueError
        If the calibration is missing, failed or synthetic and ``allow_uncalibrated`` is False,
        or is not one a calibration file can hold (:meth:`Calibration.checked`: a status
        ``passed`` without verification measurements).
    """
    if calibration is not None:  # as its file would be read (a Calibration made in Python)
        calibration = calibration.checked()
    status = calibration.status if calibration is not None else "missing"
    record = {
        "calibrated": status in ("passed", "unverified"),
        "status": status,
        "readings_sha256": calibration.readings_sha256 if calibration is not None else None,
        "curve_sha256": calibration.curve_sha256 if calibration is not None else None,
    }
    if status in ("missing", "failed", "synthetic") and not allow_uncalibrated:
        raise ValueError(
            f"the display calibration is {status}: measure the display "
            "(glarelab calibrate measure) or run explicitly uncalibrated "
            "(--allow-uncalibrated, recorded in the data)"
        )
    if status == "unverified":
        warnings.warn(
            "the display calibration has not been verified (no verification pass)",
            UserWarning,
            stacklevel=2,
        )
    return record
