"""Measuring a display: the photometer session behind ``glarelab calibrate measure``.

A plain state machine, no PsychoPy: it says which drive code to show, takes the luminance the
operator reads off the photometer, and saves the session after every entry, so nothing typed is
ever lost. Codes are shown in a random (seeded) or reversed order, so photometer drift and
display warm-up show up as non-monotone readings instead of hiding in a smooth curve; the first
code is measured again at the end to measure drift directly. Readings that break monotonicity
are flagged at once and measured once more before the fit. Where the curve bends (the linear
toe of an sRGB-type display, the knee above it) more codes are measured, chosen from the
readings: each reading is predicted from the others (the calibration fitted without it), and
where the prediction misses by more than a third of the tolerance the codes halfway to its
neighbours are measured too, round after round, until every reading is predicted within it
(at most :data:`REFINE_ROUNDS` rounds). A patch read as unsteady (its readings kept disagreeing)
is read again, up to :data:`UNSTEADY_RETRIES` times; one still unsteady refuses the calibration
(a flickering backlight or a moving tripod would otherwise bend the curve unseen). A
verification pass then shows
target luminances through the new calibration and records what the photometer reads; a
calibration whose worst error exceeds the tolerance is marked ``failed`` (as HRL's LUT tool
does), and experiments refuse it.

With a photometer on a serial port (:mod:`glarelab.display.photometer`), every single reading is
kept in the session file as it is taken (:meth:`MeasurementSession.keep_reading`), with the
instrument's model and serial number, and so is every fault; a session stopped by a fault
goes on where it stopped (:meth:`MeasurementSession.resume`).
"""

from __future__ import annotations

import datetime as dt
import itertools
import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from glarelab.display.calibration import Calibration, fit_calibration
from glarelab.files.atomic import write_text
from glarelab.files.inputs import loads_json
from glarelab.files.locks import ProcessLock

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["MeasurementLock", "MeasurementSession", "SessionInUse", "protocol_luminances"]

DRIFT_TOLERANCE = 0.02  # repeat of the first code within 2 % of the first reading
SESSION_FORMAT = "glarelab measurement session v2"
REFINE_ROUNDS = 6  # rounds of codes added where the readings bend
UNSTEADY_RETRIES = 2  # an unsteady patch is read again this many times before refusing


def protocol_luminances(protocol: Protocol) -> list[float]:
    """The luminances (cd/m²) a study names for what it shows: every ``*_cd_m2`` value of its
    protocol's tables (a matching study's target starts and background mean, a glare level, a
    night scene's adapted and starting luminance) up to its display's ``max_cd_m2``, but not
    its display's own range, its simulated observer's or an adjustment's step; sorted, each
    once. A value above the display's maximum is the scene's, never shown as it is (a glare
    source of 10,000 cd/m² is what the glare is rendered from).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        A study's protocol.

    Returns
    -------
    list of float
        The luminances, cd/m², ascending.

    Examples
    --------
    >>> from glarelab.protocols import load_protocol
    >>> protocol_luminances(load_protocol("yoshida2008"))  # on its 433 cd/m² display
    [100.0, 150.0, 220.0, 400.0]
    """
    found: set[float] = set()

    def walk(table, name: str = "") -> None:
        if isinstance(table, dict):
            for key, value in table.items():
                if key not in ("display", "observer"):
                    walk(value, key)
        elif isinstance(table, list):
            for value in table:
                walk(value, name)
        elif (
            name.endswith("_cd_m2")
            and "step" not in name
            and isinstance(table, int | float)
            and not isinstance(table, bool)
            and table > 0
        ):
            found.add(float(table))

    walk(protocol.data)
    display = protocol.data.get("display") or {}
    top = display.get("max_cd_m2", float("inf"))
    return sorted(t for t in found if t <= top)


class SessionInUse(ValueError):
    """Another process measures with this session file."""


class MeasurementLock(ProcessLock):
    """Hold the session of calibration ``out`` for this process: ``with MeasurementLock(out):``.

    An exclusive, non-blocking lock on ``NAME.session.lock``, as
    :class:`glarelab.experiments.data.SessionLock` holds a participant's session: two measurements
    on one session file would interleave their readings and overwrite each other's saves. The
    operating system releases the lock when the process ends, however it ends (a killed
    measurement can be resumed at once).

    Parameters
    ----------
    out
        The calibration file the session writes; the lock is ``NAME.session.lock`` beside it.

    Raises
    ------
    SessionInUse
        When another process holds it (names its process id and host).
    """

    def __init__(self, out: str | Path):
        path = Path(out).with_suffix(".session.lock")
        super().__init__(
            path,
            refusal=lambda holder: SessionInUse(
                f"{path.with_suffix('.json')} is being measured by another process "
                f"({holder}; lock file {path}): one measurement per session at a time"
            ),
        )


@dataclass
class MeasurementSession:
    """One photometer session.

    Parameters
    ----------
    bit_depth
        Display bits per channel.
    out
        Calibration file to write at the end; the session itself is saved next to it
        (``NAME.session.json``) after every entry.
    rng
        Random order of the codes.
    points
        Number of codes measured, evenly spaced from 0 to the top code; default 33 (with 17,
        a gamma-2.3 display's toe is under-resolved: 4.9 % error at twice black).
    order
        ``'random'`` (default) or ``'reversed'`` (top code first).
    verify_points
        Targets in the verification pass, log-spaced to 90 % of white from the lowest
        luminance where half a code step is within a third of the tolerance (and at least
        twice black): below it, quantisation alone would use up the tolerance.
    tolerance_fraction
        Largest relative verification error for ``passed``; default 0.03.
    label
        Display, photometer, operator.
    instrument
        The photometer (model, port, serial number, plugin), when one measures.
    patch_protocol
        How each patch is read (readings, settling, spread), when a photometer measures.
    protocol_targets
        Luminances (cd/m²) the studies to be run use (:func:`protocol_luminances`), verified
        besides the log-spaced targets.

    Attributes
    ----------
    readings
        Drive code → luminance measured, cd/m².
    log
        Every entry in order (phase, code, purpose, cd/m², the photometer's readings, where
        it came from), as saved and replayed by :meth:`resume`.
    flags
        What the session found, one sentence each (drift, non-monotone readings, unsteady
        patches).
    queue
        The ``(code, purpose)`` patches still to measure: ``'measure'``, ``'refine'`` or the
        closing ``'drift'`` re-reading of the first code.
    phase
        ``'measure'``, ``'verify'`` or ``'done'``.
    calibration
        The calibration fitted once the codes are measured; None before.
    targets
        The verification's target luminances, cd/m².
    verification
        ``(target cd/m², code shown, measured cd/m²)`` of each verification patch so far.
    refused
        Why the session gave no calibration; None while it may.
    raw
        Every photometer reading as taken (:meth:`keep_reading`).
    interruptions
        The faults that stopped a patch's reading (:meth:`interrupted`).
    codes
        The order of the codes measured (set from ``rng`` or ``order``).
    """

    bit_depth: int
    out: Path
    rng: np.random.Generator
    points: int = 33
    order: Literal["random", "reversed"] = "random"
    verify_points: int = 5
    tolerance_fraction: float = 0.03
    label: str = ""
    readings: dict[int, float] = field(default_factory=dict)
    log: list[dict] = field(default_factory=list)
    flags: list[str] = field(default_factory=list)
    queue: list[tuple[int, str]] = field(default_factory=list)  # (code, purpose)
    phase: Literal["measure", "verify", "done"] = "measure"
    calibration: Calibration | None = None
    targets: list[float] = field(default_factory=list)
    verification: list[tuple[float, int, float]] = field(default_factory=list)
    instrument: dict | None = None
    patch_protocol: dict | None = None
    protocol_targets: list[float] = field(default_factory=list)
    refused: str | None = None  # why the session gave no calibration
    raw: list[dict] = field(default_factory=list)  # every photometer reading, as taken
    interruptions: list[dict] = field(default_factory=list)
    codes: list[int] = field(default_factory=list)  # the order of the codes
    _retried: set[int] = field(default_factory=set)
    _refinements: int = 0
    _unsteady: dict = field(default_factory=dict)  # (phase, code) → times read unsteady
    _replaying: bool = False

    def __post_init__(self) -> None:
        if self.bit_depth not in (8, 10, 12, 16):
            raise ValueError(f"bit_depth must be one of 8, 10, 12, 16; got {self.bit_depth!r}")
        if self.points < 4:
            raise ValueError(f"points must be at least 4; got {self.points!r}")
        if self.order not in ("random", "reversed"):
            raise ValueError(f"order must be 'random' or 'reversed'; got {self.order!r}")
        self.out = Path(self.out)
        top = 2**self.bit_depth - 1
        codes = np.unique(np.round(np.linspace(0, top, self.points)).astype(int)).tolist()
        codes = codes[::-1] if self.order == "reversed" else list(self.rng.permutation(codes))
        self.codes = [int(c) for c in codes]
        self.queue = [(int(c), "measure") for c in codes] + [(int(codes[0]), "drift")]

    @property
    def session_path(self) -> Path:
        return self.out.with_suffix(".session.json")

    def current(self) -> dict:
        """What to show now: ``{'phase', 'code', 'target_cd_m2', 'remaining'}``."""
        if self.phase == "measure":
            code, purpose = self.queue[0]
            return {
                "phase": "measure",
                "code": code,
                "purpose": purpose,
                "remaining": len(self.queue),
            }
        if self.phase == "verify":
            index = len(self.verification)
            target = self.targets[index]
            code = int(self.calibration.encode(np.array([target]))[0][0])
            return {
                "phase": "verify",
                "code": code,
                "target_cd_m2": target,
                "remaining": len(self.targets) - index,
            }
        return {"phase": "done"}

    def record(
        self,
        luminance_cd_m2: float,
        *,
        readings: list[float] | None = None,
        source: Literal["typed", "photometer", "simulated"] = "typed",
        flags: list[str] = (),
    ) -> list[str]:
        """Enter the luminance of the code shown; returns new flags.

        Parameters
        ----------
        luminance_cd_m2
            The patch's luminance, cd/m², >= 0 (typed, or the photometer's median).
        readings
            The photometer's readings it was made of, cd/m², recorded with it; default None.
        source
            Where it came from: ``'typed'`` (default), ``'photometer'`` or ``'simulated'``.
        flags
            What the reading of the patch found (``'unsteady ...'``: the patch is read
            again, not used).

        Returns
        -------
        list of str
            The flags this entry raised (drift, non-monotone readings, a re-read).

        Raises
        ------
        ValueError
            For a luminance that is negative or not a number, or when the session is
            finished.
        """
        value = float(luminance_cd_m2)
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"luminance must be a number >= 0 cd/m²; got {luminance_cd_m2!r}")
        step = self.current()
        new: list[str] = list(flags)
        if step["phase"] in ("measure", "verify") and any(
            flag.startswith("unsteady") for flag in flags
        ):
            return self._unsteady_patch(step, value, readings, source, new)
        if step["phase"] == "measure":
            code, purpose = self.queue.pop(0)
            if purpose == "drift":
                first = self.readings[code]
                drift = abs(value - first) / max(first, 1e-9)
                if drift > DRIFT_TOLERANCE:
                    new.append(
                        f"drift: code {code} read {first:g} cd/m² first and {value:g} at the end "
                        f"({100 * drift:.1f} %, more than {100 * DRIFT_TOLERANCE:g} %): the "
                        "display or the photometer changed during the session; let the display "
                        "warm up longer (30 min or more) and measure again"
                    )
            else:
                self.readings[code] = value
                new += self._monotonicity(code)
            entry = {"phase": "measure", "code": code, "purpose": purpose, "cd_m2": value}
            self.log.append(self._entry(entry, readings, source, flags))
            if not self.queue:
                self._finish_measurement(new)
        elif step["phase"] == "verify":
            self.verification.append((step["target_cd_m2"], step["code"], value))
            entry = {
                "phase": "verify",
                "code": step["code"],
                "cd_m2": value,
                "target_cd_m2": step["target_cd_m2"],
            }
            self.log.append(self._entry(entry, readings, source, flags))
            if len(self.verification) == len(self.targets):
                self.calibration = self.calibration.verified(
                    self.verification, tolerance_fraction=self.tolerance_fraction
                )
                if not self._replaying:
                    self.calibration.save(self.out)
                self.phase = "done"
        else:
            raise ValueError("the session is finished; nothing more to record")
        self.flags += new
        if not self._replaying:
            self.save()
        return new

    def _unsteady_patch(self, step, value, readings, source, new: list[str]) -> list[str]:
        """A patch whose readings kept disagreeing: kept in the log, not used; read again, or
        after :data:`UNSTEADY_RETRIES` times the calibration is refused."""
        key = (step["phase"], step["code"])
        self._unsteady[key] = self._unsteady.get(key, 0) + 1
        entry = {"phase": step["phase"], "code": step["code"], "cd_m2": value, "unused": True}
        if step["phase"] == "verify":
            entry["target_cd_m2"] = step["target_cd_m2"]
        else:
            entry["purpose"] = step["purpose"]
        self.log.append(self._entry(entry, readings, source, new))
        if self._unsteady[key] <= UNSTEADY_RETRIES:
            new.append(
                f"reading {step['phase']} code {step['code']} again (unsteady "
                f"{self._unsteady[key]} of {UNSTEADY_RETRIES + 1} times allowed)"
            )
        else:
            self.refused = (
                f"{step['phase']} code {step['code']} stayed unsteady in "
                f"{UNSTEADY_RETRIES + 1} readings of its patch: the display or the photometer "
                "does not hold still (a flickering backlight, PWM dimming, a moving tripod, a "
                "display not warmed up); the calibration is refused, fix the cause and measure "
                "again"
            )
            new.append(f"refused: {self.refused}")
            self.phase = "done"
            if self.calibration is not None and not self._replaying:
                self.out.unlink(missing_ok=True)  # the unverified fit of this session
            self.calibration = None
        self.flags += new
        if not self._replaying:
            self.save()
        return new

    def _entry(self, entry: dict, readings: list[float] | None, source: str, flags) -> dict:
        if source not in ("typed", "photometer", "simulated"):
            raise ValueError(
                f"source must be 'typed', 'photometer' or 'simulated'; got {source!r}"
            )
        entry["source"] = source
        if source == "photometer" or self.raw:  # the raw readings taken up to this entry
            entry["readings_kept"] = len(self.raw)
        if readings is not None:
            entry["readings_cd_m2"] = [float(r) for r in readings]
        if flags:
            entry["flags"] = list(flags)
        return entry

    def keep_reading(self, row: dict) -> None:
        """Keep one photometer reading of the patch shown now, at once (saved before the next).

        Parameters
        ----------
        row
            The reading: ``cd_m2``, the instrument's raw ``reply`` and the reading's ``set``;
            the time, phase, code and purpose are added.
        """
        step = self.current()
        purpose = step.get("purpose", "verify")
        self.raw.append(
            {
                "time": dt.datetime.now().astimezone().isoformat(timespec="milliseconds"),
                "phase": step["phase"],
                "code": step["code"],
                "purpose": purpose,
                **row,
            }
        )
        self.save()

    def interrupted(self, message: str, *, save: bool = True) -> None:
        """Keep a fault that stopped the reading of the patch shown now.

        Parameters
        ----------
        message
            The fault, as the photometer or the operator reported it.
        save
            Whether to save the session at once; default True.
        """
        step = self.current()
        self.interruptions.append(
            {
                "time": dt.datetime.now().astimezone().isoformat(timespec="seconds"),
                "phase": step["phase"],
                "code": step.get("code"),
                "readings_kept": len(self.raw),
                "message": message,
            }
        )
        if save:
            self.save()

    @classmethod
    def resume(cls, session_path: str | Path, out: str | Path) -> MeasurementSession:
        """The session saved in ``session_path``, ready to go on where it stopped.

        Its entries are played again through the same steps (so the re-measured codes, the
        fit and the verification targets come out as they did); the raw readings and the
        faults are kept as they were.

        Parameters
        ----------
        session_path
            The saved session, ``NAME.session.json``.
        out
            The calibration file to write at the end.

        Returns
        -------
        MeasurementSession
            The session, its next patch the one it stopped at.

        Raises
        ------
        FileNotFoundError
            Without a session file.
        ValueError
            For a file that is not a session, one already finished, or entries that do not
            follow the session's steps (an edited file).
        """
        path = Path(session_path)
        if not path.is_file():
            raise FileNotFoundError(f"no measurement session at {path} to resume")
        try:
            data = loads_json(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise ValueError(f"{path}: a measurement session must be JSON; {error}") from None
        if not isinstance(data, dict) or data.get("format") != SESSION_FORMAT:
            raise ValueError(
                f"{path}: not a resumable measurement session (format "
                f"{data.get('format') if isinstance(data, dict) else None!r}, need "
                f"{SESSION_FORMAT!r})"
            )
        if data["phase"] == "done":
            raise ValueError(f"{path}: the session is finished (status {data['status']!r})")
        session = cls(
            bit_depth=data["bit_depth"],
            out=Path(out),
            rng=np.random.default_rng(0),
            points=data["points"],
            order=data["order"],
            verify_points=data["verify_points"],
            tolerance_fraction=data["tolerance_fraction"],
            label=data["label"],
            instrument=data.get("instrument"),
            patch_protocol=data.get("patch_protocol"),
            protocol_targets=list(data.get("protocol_targets") or []),
        )
        session.codes = [int(c) for c in data["codes"]]
        session.queue = [(c, "measure") for c in session.codes] + [(session.codes[0], "drift")]
        session._replaying = True
        try:
            for line, entry in enumerate(data["log"]):
                step = session.current()
                if step["phase"] != entry["phase"] or step["code"] != entry["code"]:
                    raise ValueError(
                        f"{path}: entry {line} is {entry['phase']} of code {entry['code']}, but "
                        f"the session's step is {step['phase']} of code {step.get('code')}"
                        " (an edited file?)"
                    )
                session.record(
                    entry["cd_m2"],
                    readings=entry.get("readings_cd_m2"),
                    source=entry.get("source", "typed"),
                    flags=entry.get("flags", []),
                )
                session.log[-1].pop("readings_kept", None)
                if "readings_kept" in entry:
                    session.log[-1]["readings_kept"] = entry["readings_kept"]
        finally:
            session._replaying = False
        session.raw = list(data.get("raw", []))
        session.interruptions = list(data.get("interruptions", []))
        session._unrecorded_stop()
        return session

    def _unrecorded_stop(self) -> None:
        """Name the readings of a patch that a stop with no fault (a killed process, a crash,
        power lost) left behind: kept, but not the patch's (it is read again)."""
        ends = [entry["readings_kept"] for entry in self.log if "readings_kept" in entry]
        ends += [fault["readings_kept"] for fault in self.interruptions]
        if self.log and "readings_kept" not in self.log[-1]:  # a file that does not say
            return
        left = len(self.raw) - max(ends, default=0)
        if left > 0 and self.phase != "done":
            self.interrupted(
                f"stopped with no fault recorded (the process was killed, crashed or lost "
                f"power) after {left} reading{'s' if left > 1 else ''} of this patch: kept here, "
                "not used; the patch is read again",
                save=False,  # saved with the next reading
            )

    @property
    def simulated(self) -> bool:
        """Whether a reading came from a simulated photometer (its calibration is then
        ``synthetic``, whatever its verification pass gives)."""
        return any(entry.get("source") == "simulated" for entry in self.log)

    def _monotonicity(self, code: int) -> list[str]:
        value = self.readings[code]
        flags = []
        for other, reading in self.readings.items():
            if other != code and (other < code) != (reading < value):
                flags.append(
                    f"outlier: code {code} → {value:g} cd/m² is out of order with code "
                    f"{other} → {reading:g} cd/m²"
                )
        return flags

    def _finish_measurement(self, new: list[str]) -> None:
        ordered = sorted(self.readings.items())
        suspects = {
            c for (c0, v0), (c1, v1) in itertools.pairwise(ordered) if v1 <= v0 for c in (c0, c1)
        } - self._retried
        if suspects:  # measure the suspects once more before fitting
            self._retried |= suspects
            self.queue = [(c, "remeasure") for c in sorted(suspects)]
            new.append(f"re-measuring codes {sorted(suspects)}: readings out of order")
            return
        try:
            self.calibration = fit_calibration(
                ordered, bit_depth=self.bit_depth, label=self.label, source="measurement"
            )
        except ValueError as error:
            new.append(f"fit failed: {error}")
            self.refused = f"the readings cannot be fitted: {error}"
            self.phase = "done"
            return
        if self.simulated:  # made-up readings: a synthetic display, never a measured one
            label = "SYNTHETIC: simulated photometer"
            label += f"; {self.label}" if self.label else ""
            self.calibration = replace(self.calibration, status="synthetic", label=label)
        bends = self._bends(ordered) if self._refinements < REFINE_ROUNDS else []
        if bends:  # the curve bends between readings: measure there before verifying
            self._refinements += 1
            self.calibration = None
            self.queue = [(c, "refine") for c in bends]
            new.append(
                f"measuring codes {bends} too: the curve bends there (round "
                f"{self._refinements} of at most {REFINE_ROUNDS})"
            )
            return
        black, white = self.calibration.black_cd_m2, self.calibration.max_cd_m2
        # the lowest luminance from which on half a code step stays within a third of the
        # tolerance: below it, quantisation alone would eat the tolerance (8-bit, 1 % of
        # white: 3.6 %); near black the steps are small again beside the black level, so the
        # last coarse step counts, not the first fine one
        lut = self.calibration.lut
        half_step = np.diff(lut) / 2 / np.maximum(lut[:-1], 1e-12)
        coarse = np.flatnonzero(half_step > self.tolerance_fraction / 3)
        fine_from = float(lut[coarse[-1] + 1]) if coarse.size else 0.0
        low = min(max(2 * black, fine_from), 0.5 * white)
        targets = np.geomspace(low, 0.9 * white, self.verify_points).tolist()
        studies = [t for t in self.protocol_targets if low <= t < white and t not in targets]
        self.targets = sorted(targets + studies)
        above = [t for t in self.protocol_targets if t > white]
        if above:  # said, not dropped silently: the display cannot show them
            new.append(
                f"the studies' luminances {', '.join(f'{t:g}' for t in above)} cd/m² are above "
                f"this display's white ({white:.4g} cd/m²): it cannot show them as the study "
                "asks, and they are not verified"
            )
        near = [t for t in self.protocol_targets if t < low or t == white]
        if near:  # shown, but outside the range a verification measures
            new.append(
                f"the studies' luminances {', '.join(f'{t:g}' for t in near)} cd/m² are not "
                f"verified: the verification measures {low:.3g} up to below white "
                f"{white:.4g} cd/m² (near black a code's step is beyond the tolerance; white "
                "is a reading of the fit)"
            )
        if not self._replaying:  # unverified until the verification pass is done
            self.calibration.save(self.out)
        self.phase = "verify"

    def _bends(self, ordered: list[tuple[int, float]]) -> list[int]:
        """Codes to measure where the readings bend: halfway to its neighbours from each
        reading that the calibration fitted without it misses by more than a third of the
        tolerance (each reading's own noise is far below it)."""
        limit = self.tolerance_fraction / 3
        codes = set()
        for index in range(1, len(ordered) - 1):
            others = ordered[:index] + ordered[index + 1 :]
            code, value = ordered[index]
            try:
                predicted = fit_calibration(others, bit_depth=self.bit_depth).lut[code]
            except ValueError:
                continue
            if abs(predicted - value) > limit * value:
                for low, high in ((ordered[index - 1][0], code), (code, ordered[index + 1][0])):
                    if high - low > 1:
                        codes.add((low + high) // 2)
        return sorted(codes - {c for c, _ in ordered})

    def save(self) -> Path:
        """Write the session so far (atomically: a crash leaves the previous file intact)."""
        data = {
            "format": SESSION_FORMAT,
            "bit_depth": self.bit_depth,
            "label": self.label,
            "order": self.order,
            "points": self.points,
            "verify_points": self.verify_points,
            "tolerance_fraction": self.tolerance_fraction,
            "codes": self.codes,
            "instrument": self.instrument,
            "patch_protocol": self.patch_protocol,
            "protocol_targets": self.protocol_targets,
            "refused": self.refused,
            "phase": self.phase,
            "log": self.log,
            "flags": self.flags,
            "readings": sorted(self.readings.items()),
            "verification": self.verification,
            "status": self.calibration.status if self.calibration else None,
            "raw": self.raw,
            "interruptions": self.interruptions,
        }
        self.session_path.parent.mkdir(parents=True, exist_ok=True)
        write_text(self.session_path, json.dumps(data, indent=1))
        return self.session_path
