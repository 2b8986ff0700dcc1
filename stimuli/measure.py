"""Measuring a display: the photometer session behind ``glarelab calibrate measure``.

A plain state machine, no PsychoPy: it says which drive code to show, takes the luminance the
operator reads off the photometer, and saves the session after every entry, so nothing typed is
ever lost. Codes are shown in a random (seeded) or reversed order, so photometer drift and
display warm-up show up as non-monotone readings instead of hiding in a smooth curve; the first
code is measured again at the end to measure drift directly. Readings that break monotonicity
are flagged at once and measured once more before the fit. A verification pass then shows
target luminances through the new calibration and records what the photometer reads; a
calibration whose worst error exceeds the tolerance is marked ``failed`` (as HRL's LUT tool
does), and experiments refuse it.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from protocols.atomic import write_text

from .calibration import Calibration, fit_calibration

__all__ = ["MeasurementSession"]

DRIFT_TOLERANCE = 0.02  # repeat of the first code within 2 % of the first reading


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
    _retried: set[int] = field(default_factory=set)

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

    def record(self, luminance_cd_m2: float) -> list[str]:
        """Enter the photometer's reading for the code shown; returns new flags."""
        value = float(luminance_cd_m2)
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"luminance must be a number >= 0 cd/m²; got {luminance_cd_m2!r}")
        step = self.current()
        new: list[str] = []
        if step["phase"] == "measure":
            code, purpose = self.queue.pop(0)
            if purpose == "drift":
                first = self.readings[code]
                drift = abs(value - first) / max(first, 1e-9)
                if drift > DRIFT_TOLERANCE:
                    new.append(
                        f"drift: code {code} read {first:g} cd/m² first and {value:g} at the end "
                        f"({100 * drift:.1f} %)"
                    )
            else:
                self.readings[code] = value
                new += self._monotonicity(code)
            self.log.append({"phase": "measure", "code": code, "purpose": purpose, "cd_m2": value})
            if not self.queue:
                self._finish_measurement(new)
        elif step["phase"] == "verify":
            self.verification.append((step["target_cd_m2"], step["code"], value))
            self.log.append(
                {
                    "phase": "verify",
                    "code": step["code"],
                    "cd_m2": value,
                    "target_cd_m2": step["target_cd_m2"],
                }
            )
            if len(self.verification) == len(self.targets):
                self.calibration = self.calibration.verified(
                    self.verification, tolerance_fraction=self.tolerance_fraction
                )
                self.calibration.save(self.out)
                self.phase = "done"
        else:
            raise ValueError("the session is finished; nothing more to record")
        self.flags += new
        self.save()
        return new

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
            self.phase = "done"
            return
        black, white = self.calibration.black_cd_m2, self.calibration.max_cd_m2
        # the lowest luminance where half a code step is within a third of the tolerance:
        # below it, quantisation alone would eat the tolerance (8-bit, 1 % of white: 3.6 %)
        lut = self.calibration.lut
        half_step = np.diff(lut) / 2 / np.maximum(lut[:-1], 1e-12)
        fine = np.flatnonzero(half_step <= self.tolerance_fraction / 3)
        low = max(2 * black, float(lut[fine[0]]) if fine.size else 0.5 * white)
        self.targets = np.geomspace(low, 0.9 * white, self.verify_points).tolist()
        self.calibration.save(self.out)  # unverified until the verification pass is done
        self.phase = "verify"

    def save(self) -> Path:
        """Write the session so far (atomically: a crash leaves the previous file intact)."""
        data = {
            "bit_depth": self.bit_depth,
            "label": self.label,
            "order": self.order,
            "phase": self.phase,
            "log": self.log,
            "flags": self.flags,
            "readings": sorted(self.readings.items()),
            "verification": self.verification,
            "status": self.calibration.status if self.calibration else None,
        }
        self.session_path.parent.mkdir(parents=True, exist_ok=True)
        write_text(self.session_path, json.dumps(data, indent=1))
        return self.session_path
