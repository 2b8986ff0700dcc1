"""Gaze and pupil from an eye tracker through PsychoPy's ioHub, with the faults of real trackers.

- :class:`PupilCalibration`: Luidolt's pupil range calibration (2020, §5.2.1 ii and §5.2.4): "We
  calibrate our eye tracker to a user's pupil size, by showing a black or white screen for 5
  seconds each. We take the average of the pupil size during the white frame as minimum pupil
  size and the average over the black frame as maximum. During runtime, we then generate the
  pupil aperture by mapping the eye tracker output to our predefined range of 2-8 mm
  diameter." The mapping is linear (Luidolt does not say which; linear is the one that keeps
  both ends) and clamped to 2-8 mm; it is recorded with the session
  (:meth:`PupilCalibration.as_dict`).
- :class:`GazeFilter`: what a frame uses of the tracker's last sample. A lost sample (none, or
  no gaze) and a blink (pupil 0 or missing, which made Luidolt's glare flicker) hold the last
  valid state; a gaze off the window is clamped to its edge; the pupil is smoothed by a
  first-order low-pass of time constant :data:`PUPIL_FILTER_S`; each fault is counted (a blink
  once, however many samples it lasts).
- :class:`IoHubEyeTracker`: the samples of an ioHub eye tracker (``launchHubServer`` with the
  tracker's device class, :data:`TRACKERS`), in window pixels from the top-left. The simulated
  ``MouseGaze`` tracker (``'mouse'``) moves the gaze with the mouse, reports a constant 5 mm
  pupil and blinks while both buttons are held; a lab's tracker is named the same way and
  calibrated by its own procedure (``runSetupProcedure``).

PsychoPy is imported inside the functions that open a window or the ioHub server.

References
----------
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, §5.2.1 ii, §5.2.4, §6.1.2.
"""

from __future__ import annotations

import contextlib
import copy
import math
import os
import subprocess
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from glarelab.files.values import is_real
from glarelab.frontend.iohub_guard import start_guard

__all__ = [
    "CALIBRATION_SCREEN_S",
    "MOUSE_GAZE_SETTINGS",
    "PUPIL_FILTER_S",
    "TRACKERS",
    "GazeFilter",
    "GazeState",
    "IoHubEyeTracker",
    "PupilCalibration",
    "TrackerError",
    "calibrate_pupil",
    "datastore_settings",
    "tracker_config",
]

LUIDOLT2020_PUPIL_RANGE_MM = (2.0, 8.0)  # Luidolt §5.2.1 ii: "our predefined range of 2-8 mm"
CALIBRATION_SCREEN_S = 5.0  # Luidolt §5.2.1 ii: "a black or white screen for 5 seconds each"
# The pupil is smoothed with this time constant: an assumption (Luidolt does not filter), a
# tenth of a second, well under the pupil's own light response of several tenths (so the
# glare still follows the pupil), long enough to bridge a tracker's single-sample dropouts
PUPIL_FILTER_S = 0.1
# ioHub's device classes of the trackers PsychoPy drives (the lab ones need their plugin)
TRACKERS = {
    "mouse": "eyetracker.hw.mouse.EyeTracker",
    "eyelink": "eyetracker.hw.sr_research.eyelink.EyeTracker",
    "tobii": "eyetracker.hw.tobii.EyeTracker",
    "gazepoint": "eyetracker.hw.gazepoint.gp3.EyeTracker",
    "pupil_labs": "eyetracker.hw.pupil_labs.pupil_core.EyeTracker",
}
# MouseGaze as a live session's simulated tracker: sampled at 200 Hz, the rate of Luidolt's
# Pupil Labs tracker (§5.2.3: "Our eye tracker can capture images at 200Hz"), polled every
# 5 ms, and without its simulated saccades (a move beyond saccade_threshold degrees is held at
# the start for the saccade's duration): the gaze is where the mouse is at the next sample
MOUSE_GAZE_SETTINGS = {
    "runtime_settings": {"sampling_rate": 200, "track_eyes": "RIGHT_EYE"},
    "device_timer": {"interval": 0.005},
    "controls": {"move": [], "blink": ["LEFT_BUTTON", "RIGHT_BUTTON"], "saccade_threshold": 1e6},
}


GUARD_WAIT_S = 5.0  # how long to wait for a killed guard to end (it ends at once)
# how long a request to ioHub's server may wait for its answer before the sample is counted
# lost (an assumption: ioHub answers in about a millisecond; a loaded machine, far slower)
REQUEST_TIMEOUT_S = 2.0


class TrackerError(RuntimeError):
    """ioHub could not start the eye tracker (its plugin missing, the device unreachable)."""


def _free_udp_port() -> int:
    """A UDP port free now, for this ioHub server alone: ioHub's fixed default (9036) lets a
    second session on the machine (or a server left behind) stop it from starting."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@contextlib.contextmanager
def _output_to(path):
    """This process's stdout and stderr (file descriptors 1 and 2, which a process started
    meanwhile inherits) appended to ``path`` (None: discarded), restored after.

    ioHub's server is started with the launching process's stdout (and its stderr joined to
    it): a server outliving its session would hold the session's terminal, or the pipe of a
    program waiting for the session's output to end.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    target = os.open(path or os.devnull, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
    saved = [os.dup(1), os.dup(2)]
    try:
        os.dup2(target, 1)
        os.dup2(target, 2)
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, target):
            os.close(fd)


def tracker_config(spec: str) -> tuple[str, dict]:
    """The tracker a session names: a name of :data:`TRACKERS`, or an ioHub configuration file.

    Parameters
    ----------
    spec
        ``'mouse'`` (ioHub's simulated MouseGaze, :data:`MOUSE_GAZE_SETTINGS`), another name
        of :data:`TRACKERS` (ioHub's defaults for it), or the path of a YAML file holding one
        ioHub eye tracker's configuration, as PsychoPy's eye tracker documentation writes it:
        ``eyetracker.hw.<maker>.<model>.EyeTracker:`` with its settings below (or that entry
        inside a ``monitor_devices:`` list).

    Returns
    -------
    tuple of (str, dict)
        The device class path (or name) and its settings, a copy of the caller's own (editing
        it changes no later session's).

    Raises
    ------
    ValueError
        For an unknown name, a missing or unreadable file, or a file that names no eye tracker
        or more than one.

    Examples
    --------
    >>> tracker_config("mouse")[1]["runtime_settings"]["sampling_rate"]
    200
    """
    from pathlib import Path

    if spec in TRACKERS:
        return spec, (copy.deepcopy(MOUSE_GAZE_SETTINGS) if spec == "mouse" else {})
    path = Path(spec)
    if path.suffix.lower() not in (".yaml", ".yml"):
        raise ValueError(
            f"--eyetracker {spec!r}: must be one of {', '.join(sorted(TRACKERS))} or an ioHub "
            "configuration file (.yaml)"
        )
    import yaml

    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        raise ValueError(f"--eyetracker {spec}: cannot read it as YAML ({error})") from None
    entries = []
    if isinstance(data, dict):
        devices = data.get("monitor_devices")
        for item in devices if isinstance(devices, list) else [data]:
            if isinstance(item, dict):
                entries += [
                    (k, v)
                    for k, v in item.items()
                    if isinstance(k, str) and k.startswith("eyetracker.hw.")
                ]
    if len(entries) == 1 and not isinstance(entries[0][1], dict | None):
        raise ValueError(
            f"--eyetracker {spec}: the settings of {entries[0][0]} must be a mapping (name: "
            f"value lines below it); got a {type(entries[0][1]).__name__}"
        )
    if len(entries) != 1:
        raise ValueError(
            f"--eyetracker {spec}: must configure exactly one ioHub eye tracker "
            f"(eyetracker.hw.<maker>.<model>.EyeTracker: ...); found {len(entries)}"
        )
    device, settings = entries[0]
    return device, dict(settings or {})


@dataclass(frozen=True)
class PupilCalibration:
    """Luidolt's pupil range: the tracker's pupil on a white and a black screen → 2-8 mm.

    Attributes
    ----------
    white_raw
        Mean pupil the tracker reported on the white screen (its unit), the 2 mm end.
    black_raw
        Mean pupil on the black screen, the 8 mm end; > ``white_raw``.
    unit
        The tracker's pupil unit (``'mm'``, ``'px'``, ``'area'``...), recorded.
    range_mm
        The range mapped to, mm (the tracker's values clamped to it); default Luidolt's 2-8,
        the live renderer's pupils: a live scene refuses a range beyond them.
    screen_s
        How long each screen was shown, s (recorded); None: not measured here.
    valid_samples
        The valid pupil samples of the white and the black screen (recorded).
    simulated
        How the pupil was simulated (a tracker without one, MouseGaze), recorded; None: the
        tracker's own.

    Raises
    ------
    ValueError
        For a black-screen pupil not larger than the white-screen one (a tracker that does
        not measure the pupil, or a calibration that failed), or a bad range.

    Examples
    --------
    >>> c = PupilCalibration(white_raw=20.0, black_raw=50.0, unit="px")
    >>> c.to_mm(35.0), c.to_mm(100.0)
    (5.0, 8.0)
    """

    white_raw: float
    black_raw: float
    unit: str = "mm"
    range_mm: tuple[float, float] = LUIDOLT2020_PUPIL_RANGE_MM
    screen_s: float | None = None
    valid_samples: tuple[int, int] | None = None
    simulated: str | None = None

    def __post_init__(self) -> None:
        for name in ("white_raw", "black_raw"):
            if not is_real(getattr(self, name)):
                raise ValueError(
                    f"{name} must be a finite number (the tracker's pupil); got "
                    f"{getattr(self, name)!r}"
                )
        try:
            low, high = (float(v) for v in self.range_mm)
        except (TypeError, ValueError):
            raise ValueError(
                f"range_mm must be (low, high) mm with 0 < low < high; got {self.range_mm!r}"
            ) from None
        if not (0 < low < high and math.isfinite(high)):
            raise ValueError(
                f"range_mm must be (low, high) mm with 0 < low < high; got {self.range_mm!r}"
            )
        if not (
            math.isfinite(self.white_raw)
            and math.isfinite(self.black_raw)
            and self.black_raw > self.white_raw > 0
        ):
            raise ValueError(
                "black_raw must exceed white_raw > 0 (the pupil on the black screen larger "
                f"than on the white); got white_raw = {self.white_raw!r}, "
                f"black_raw = {self.black_raw!r}"
            )

    @classmethod
    def from_samples(
        cls,
        white_raw: np.ndarray,
        black_raw: np.ndarray,
        *,
        unit: str = "mm",
        screen_s: float | None = None,
        simulated: str | None = None,
    ) -> PupilCalibration:
        """The calibration from the pupil samples of the two screens (blinks, 0, dropped).

        Parameters
        ----------
        white_raw, black_raw
            The tracker's pupil samples during the white and the black screen.
        unit
            Their unit, recorded.
        screen_s, simulated
            Recorded (see the class).

        Returns
        -------
        PupilCalibration

        Raises
        ------
        ValueError
            When a screen has no valid sample, or the black mean is not above the white.

        Examples
        --------
        >>> PupilCalibration.from_samples([3.0, 0.0, 3.2], [6.0, 6.4]).white_raw
        3.1
        """
        means, counts = [], []
        for name, values in (("white_raw", white_raw), ("black_raw", black_raw)):
            array = np.asarray(values, dtype=float).reshape(-1)
            valid = array[np.isfinite(array) & (array > 0)]
            if valid.size == 0:
                raise ValueError(f"{name} holds no valid pupil sample (all missing or 0)")
            means.append(round(float(valid.mean()), 12))
            counts.append(int(valid.size))
        if means[0] == means[1]:  # one value on both screens: no pupil that follows light
            raise ValueError(
                f"the tracker's pupil was {means[0]:g} {unit} on the white screen and on the "
                "black: a pupil that does not follow the screen's light (a simulated tracker "
                "such as MouseGaze, whose pupil is constant) cannot be calibrated; use a "
                "tracker that measures the pupil, or the 'mouse' tracker (--eyetracker mouse), "
                "whose calibration "
                "simulates the eye's pupil"
            )
        return cls(
            white_raw=means[0], black_raw=means[1], unit=unit, screen_s=screen_s,
            valid_samples=(counts[0], counts[1]), simulated=simulated,
        )  # fmt: skip

    def to_mm(self, raw: float) -> float:
        """The pupil in mm of a tracker value (linear between the two screens, clamped).

        Parameters
        ----------
        raw
            The tracker's pupil, its unit.

        Returns
        -------
        float
            ``low + (raw - white) / (black - white) · (high - low)``, within ``range_mm``.
        """
        low, high = self.range_mm
        fraction = (float(raw) - self.white_raw) / (self.black_raw - self.white_raw)
        return float(min(max(low + fraction * (high - low), low), high))

    def as_dict(self) -> dict[str, Any]:
        """What a session records of the calibration.

        Returns
        -------
        dict
            The two means (the raw minimum, white, and maximum, black), the unit, the range,
            the mapping ``pupil_mm = offset_mm + slope_mm_per_unit · raw`` (clamped to the
            range) and its rule, the screens' duration, the valid samples and the simulation.

        Examples
        --------
        >>> d = PupilCalibration(white_raw=20.0, black_raw=50.0, unit="px").as_dict()
        >>> d["slope_mm_per_unit"], d["offset_mm"]
        (0.2, -2.0)
        """
        low, high = (float(v) for v in self.range_mm)
        slope = (high - low) / (self.black_raw - self.white_raw)
        return {
            "white_raw": self.white_raw,
            "black_raw": self.black_raw,
            "unit": self.unit,
            "range_mm": [low, high],
            "slope_mm_per_unit": round(slope, 12),
            "offset_mm": round(low - slope * self.white_raw, 12),
            "rule": "linear from white (min) to black (max), clamped (Luidolt 2020 §5.2.1 ii)",
            "screen_s": self.screen_s,
            "valid_samples": None if self.valid_samples is None else list(self.valid_samples),
            "simulated": self.simulated,
        }


@dataclass(frozen=True)
class GazeState:
    """What a frame uses: the filtered gaze and pupil and whether this sample was valid.

    Attributes
    ----------
    gaze_x_px, gaze_y_px
        Gaze in window pixels from the top-left (held or clamped).
    pupil_mm
        The smoothed pupil, mm (held through blinks).
    valid_gaze, valid_pupil
        Whether this frame's sample gave them.
    clamped
        Whether this frame's gaze lay off the window and was clamped.
    """

    gaze_x_px: float
    gaze_y_px: float
    pupil_mm: float
    valid_gaze: bool
    valid_pupil: bool
    clamped: bool


@dataclass
class GazeFilter:
    """The faults of a tracker handled: hold, clamp, smooth and count.

    Parameters
    ----------
    window_px
        ``(width, height)`` of the window, pixels.
    calibration
        The pupil calibration, or None: the tracker's pupil taken in mm (``MouseGaze``
        reports 5 mm), clamped to 2-8 mm.
    pupil_filter_s
        Time constant of the pupil's low-pass, s, >= 0 (0: none); default
        :data:`PUPIL_FILTER_S`.

    Examples
    --------
    >>> f = GazeFilter((100, 50))
    >>> f.update(0.0, 10.0, 20.0, 4.0).pupil_mm
    4.0
    >>> s = f.update(0.1, None, None, 0.0)  # a blink: gaze and pupil held
    >>> (s.gaze_x_px, s.pupil_mm, f.blinks)
    (10.0, 4.0, 1)
    >>> f.update(0.2, 500.0, -3.0, 4.0).gaze_x_px, f.off_screen  # clamped to the window
    (99.0, 1)
    """

    window_px: tuple[int, int]
    calibration: PupilCalibration | None = None
    pupil_filter_s: float = PUPIL_FILTER_S
    lost: int = field(default=0, init=False)
    blinks: int = field(default=0, init=False)
    off_screen: int = field(default=0, init=False)
    samples: int = field(default=0, init=False)
    _state: GazeState | None = field(default=None, init=False, repr=False)
    _time_s: float | None = field(default=None, init=False, repr=False)
    _blinking: bool = field(default=False, init=False, repr=False)
    _seen: bool = field(default=False, init=False, repr=False)

    def __post_init__(self) -> None:
        try:
            width, height = (int(v) for v in self.window_px)
        except (TypeError, ValueError):
            raise ValueError(
                f"window_px must be (width, height); got {self.window_px!r}"
            ) from None
        if width < 1 or height < 1:
            raise ValueError(f"window_px must be positive; got {self.window_px!r}")
        self.window_px = (width, height)
        if not (math.isfinite(self.pupil_filter_s) and self.pupil_filter_s >= 0):
            raise ValueError(f"pupil_filter_s must be >= 0 s; got {self.pupil_filter_s!r}")

    def update(
        self,
        time_s: float,
        gaze_x_px: float | None,
        gaze_y_px: float | None,
        pupil_raw: float | None,
        *,
        blink: bool | None = None,
    ) -> GazeState:
        """The state after one sample (None for a field the tracker did not give).

        Parameters
        ----------
        time_s
            The sample's time, s, a finite number.
        gaze_x_px, gaze_y_px
            Gaze in window pixels from the top-left, or None (lost, blink).
        pupil_raw
            The tracker's pupil (its unit), or None / 0 / NaN (blink, lost).
        blink
            Whether the tracker reported the eye closed in this sample
            (``IoHubEyeTracker.blinking``); None (default): a sample without a pupil is
            one.

        Returns
        -------
        GazeState

        Raises
        ------
        ValueError
            For a time that is not a finite number (the state is left as it was).
        """
        if not (is_real(time_s) and math.isfinite(time_s)):
            raise ValueError(f"time_s must be a finite number of seconds; got {time_s!r}")
        self.samples += 1
        width, height = self.window_px
        previous = self._state
        valid_gaze = (
            gaze_x_px is not None
            and gaze_y_px is not None
            and math.isfinite(gaze_x_px)
            and math.isfinite(gaze_y_px)
        )
        clamped = False
        if valid_gaze:
            x = min(max(float(gaze_x_px), 0.0), width - 1.0)
            y = min(max(float(gaze_y_px), 0.0), height - 1.0)
            clamped = (x, y) != (float(gaze_x_px), float(gaze_y_px))
            self.off_screen += clamped
        else:
            self.lost += 1
            x, y = (
                (previous.gaze_x_px, previous.gaze_y_px)
                if previous
                else ((width - 1) / 2, (height - 1) / 2)
            )
        valid_pupil = pupil_raw is not None and math.isfinite(pupil_raw) and pupil_raw > 0
        if valid_pupil:
            measured = (
                self.calibration.to_mm(pupil_raw)
                if self.calibration is not None
                else min(max(float(pupil_raw), 2.0), 8.0)
            )
            if previous is None or self.pupil_filter_s == 0:
                pupil = measured
            else:
                since = float(time_s) - self._time_s if self._time_s is not None else 0.0
                elapsed = max(since, 0.0)
                keep = math.exp(-elapsed / self.pupil_filter_s)
                pupil = previous.pupil_mm * keep + measured * (1.0 - keep)
        else:
            pupil = previous.pupil_mm if previous else 5.0
        if blink is None:
            blink = not valid_pupil
        # a blink counted once, as it starts, and only once the tracker has seen the eye (the
        # samples before the first one and those lost to a disconnect are lost, not blinks)
        self.blinks += bool(blink) and not self._blinking and self._seen
        self._blinking = bool(blink)
        self._seen = self._seen or (valid_gaze and valid_pupil)
        self._time_s = float(time_s)
        self._state = GazeState(x, y, pupil, valid_gaze, valid_pupil, clamped)
        return self._state

    def counts(self) -> dict[str, int]:
        """The faults so far.

        Returns
        -------
        dict
            ``samples``; ``lost``, the samples without a gaze (lost, a blink's, none from a
            disconnected tracker); ``blinks``, the blinks (each run of samples the tracker
            reported the eye closed in counts once, from the first sample with the eye seen);
            ``off_screen``, the samples with the gaze off the window.
        """
        return {
            "samples": self.samples,
            "lost": self.lost,
            "blinks": self.blinks,
            "off_screen": self.off_screen,
        }


def calibrate_pupil(
    window,
    source,
    *,
    screen_s: float = CALIBRATION_SCREEN_S,
    unit: str = "mm",
    simulate_cd_m2: tuple[float, float] | None = None,
    stop: Callable[[], None] | None = None,
) -> PupilCalibration:
    """Luidolt's pupil range calibration: a white screen, then a black one, ``screen_s`` each.

    Parameters
    ----------
    window
        The window (anything with a settable ``color`` in PsychoPy's ``rgb`` [-1, 1] and a
        ``flip()``); its colour is put back afterwards.
    source
        The tracker (:class:`IoHubEyeTracker`, recording): ``sample()`` gives
        ``(gaze_x_px, gaze_y_px, pupil_raw)``.
    screen_s
        How long each screen is shown, s, > 0; default 5 (Luidolt §5.2.1 ii).
    unit
        The tracker's pupil unit, recorded.
    simulate_cd_m2
        ``(white, black)`` luminance of the two screens, cd/m², for a tracker that does not
        measure the pupil (``MouseGaze``'s is a constant 5 mm): each valid sample's pupil is
        replaced by Moon & Spencer's pupil of the screen's luminance
        (:func:`glarelab.glare.models.eye.pupil_diameter_mm`), a simulated eye; default None:
        the tracker's pupil.
    stop
        Called after every flip: it ends the calibration by raising (a session's Escape);
        default None.

    Returns
    -------
    PupilCalibration
        From the mean pupil of each screen (blinks and lost samples left out).

    Raises
    ------
    ValueError
        For a bad duration, or a screen without a valid pupil or with no range between them
        (MouseGaze reports 5 mm on both: give ``simulate_cd_m2``).

    Warns
    -----
    UserWarning
        For screens shorter than Luidolt's 5 s with the tracker's own pupil: the pupil may
        not have settled.

    Notes
    -----
    "We calibrate our eye tracker to a user's pupil size, by showing a black or white screen
    for 5 seconds each. We take the average of the pupil size during the white frame as
    minimum pupil size and the average over the black frame as maximum." (Luidolt 2020,
    §5.2.1 ii). White is shown first: the pupil then dilates on the black screen, as it
    does faster than it constricts after the dark.
    """
    import time

    from glarelab.glare.models.eye import pupil_diameter_mm

    if not (math.isfinite(screen_s) and screen_s > 0):
        raise ValueError(f"screen_s must be a duration > 0 s; got {screen_s!r}")
    if screen_s < CALIBRATION_SCREEN_S and simulate_cd_m2 is None:
        warnings.warn(
            f"screen_s={screen_s:g}: Luidolt's pupil calibration shows each screen "
            f"{CALIBRATION_SCREEN_S:g} s; on a shorter one the pupil may not have settled to "
            "the screen (it dilates in the dark over seconds), and the range measured is "
            "too narrow",
            stacklevel=2,
        )
    simulated = None
    if simulate_cd_m2 is not None:
        try:
            white_cd_m2, black_cd_m2 = (float(v) for v in simulate_cd_m2)
        except (TypeError, ValueError):
            raise ValueError(
                f"simulate_cd_m2 must be (white, black) in cd/m²; got {simulate_cd_m2!r}"
            ) from None
        if not (math.isfinite(white_cd_m2) and white_cd_m2 > black_cd_m2 >= 0):
            raise ValueError(
                f"simulate_cd_m2 must be (white, black) cd/m² with white > black >= 0; got "
                f"{simulate_cd_m2!r}"
            )
        screens = {"white": white_cd_m2, "black": black_cd_m2}
        simulated = (
            f"Moon & Spencer's pupil of each screen (white {white_cd_m2:g} cd/m², black "
            f"{black_cd_m2:g} cd/m²) in place of the tracker's"
        )
        unit = "mm"
    before = getattr(window, "color", None)
    samples: dict[str, list[float]] = {}
    try:
        for name, colour in (("white", (1.0, 1.0, 1.0)), ("black", (-1.0, -1.0, -1.0))):
            window.color = colour
            window.flip()
            pupils = samples[name] = []
            end = time.monotonic() + screen_s
            while time.monotonic() < end:
                window.flip()
                if stop is not None:
                    stop()
                pupil = source.sample()[2]
                if simulated is not None and _finite(pupil) and pupil > 0:  # not a blink
                    pupil = float(pupil_diameter_mm(screens[name]))
                pupils.append(math.nan if pupil is None else float(pupil))
    except BaseException:
        # stopped (a signal's exception may cut a GL call short, and the next flip then
        # fails): the window is put back as it can be, and the stop goes on
        with contextlib.suppress(Exception):
            if before is not None:
                window.color = before
            window.flip()
        raise
    if before is not None:
        window.color = before
    window.flip()
    return PupilCalibration.from_samples(
        samples["white"], samples["black"], unit=unit, screen_s=float(screen_s),
        simulated=simulated,
    )  # fmt: skip


def datastore_settings(datastore, session_code: str) -> dict:
    """ioHub's settings for its hdf5 store at ``datastore`` (none for None).

    The store's name is made absolute: ioHub's server process runs in another working folder
    (glarelab's package folder), where a relative name would put the store.

    Parameters
    ----------
    datastore
        The store's file (``.hdf5``), or None.
    session_code
        ioHub's session code in the store.

    Returns
    -------
    dict
        ``experiment_code``, ``session_code`` and ``datastore_name`` (without ``.hdf5``).

    Examples
    --------
    >>> datastore_settings("/data/P01_iohub.hdf5", "run1")["datastore_name"]
    '/data/P01_iohub'
    >>> datastore_settings(None, "run1")
    {}
    """
    if datastore is None:
        return {}
    name = str(Path(datastore).absolute())
    return {
        "experiment_code": "glarelab",
        "session_code": session_code,
        "datastore_name": name[: -len(".hdf5")] if name.endswith(".hdf5") else name,
    }


class IoHubEyeTracker:
    """The samples of an ioHub eye tracker, in window pixels from the top-left.

    Parameters
    ----------
    window
        The PsychoPy window (units ``'pix'``), which ioHub's display takes its size from.
    tracker
        A name of :data:`TRACKERS` (``'mouse'`` for pilots and tests) or an ioHub device class
        path (``'eyetracker.hw....EyeTracker'``).
    settings
        More of the device's ioHub configuration (``runtime_settings``, ``calibration``...).
    datastore
        Keep ioHub's own record of every event (its hdf5 store: the raw samples, blinks,
        fixations and saccades as the tracker reported them) in this file (``.hdf5``); None
        (default): none. Needs PyTables (the ``eyetracker`` extra).
    session_code
        ioHub's name of this recording in the store (unique within the file).
    server_log
        Where ioHub's server writes its output (stdout and stderr: its errors), appended;
        None (default): discarded. The server never writes to this process's terminal or
        pipes, and a guard (:mod:`glarelab.frontend.iohub_guard`) stops it when this process
        ends without stopping it (killed).

    Raises
    ------
    ValueError
        For an unknown tracker name or a window not in pixels.
    TrackerError
        When ioHub cannot start the tracker (its plugin missing, the device unreachable).

    Notes
    -----
    ioHub reports gaze in the window's units with the origin at its centre and y up; this
    turns it into pixels from the top-left, y down (``x + W/2``, ``H/2 - y``).
    """

    def __init__(
        self,
        window,
        *,
        tracker: str = "mouse",
        settings: dict | None = None,
        datastore=None,
        session_code: str = "live",
        server_log=None,
    ) -> None:
        import msgpack  # ioHub's wire format (a PsychoPy dependency)
        from psychopy.iohub import launchHubServer
        from psychopy.iohub.devices.eyetracker.eye_events import (
            BinocularEyeSampleEvent,
            MonocularEyeSampleEvent,
        )

        if tracker in TRACKERS:
            device = TRACKERS[tracker]
        elif tracker.startswith("eyetracker.hw.") and tracker.endswith("EyeTracker"):
            device = tracker
        else:
            raise ValueError(
                f"tracker must be one of {sorted(TRACKERS)} or an ioHub eye tracker class "
                f"path; got {tracker!r}"
            )
        if window.units != "pix":
            raise ValueError(f"window must have units 'pix' for the gaze; got {window.units!r}")
        self.window = window
        self.tracker = tracker
        self.device = device
        self._names = {
            "mono": list(MonocularEyeSampleEvent.CLASS_ATTRIBUTE_NAMES),
            "bino": list(BinocularEyeSampleEvent.CLASS_ATTRIBUTE_NAMES),
        }
        config = {**(settings or {}), "name": "tracker"}
        store = datastore_settings(datastore, session_code)
        port = _free_udp_port()
        # the request ioHub's client sends to stop its server, packed as its client packs it
        self._guard = start_guard(port, msgpack.Packer().pack(("STOP_IOHUB_SERVER",)))
        try:
            self._server_log = server_log
            with _output_to(server_log):
                self.io = launchHubServer(
                    window=window, udp_port=port, **store, **{device: config}
                )
            self.device_handle = self.io.getDevice("tracker")
            # ioHub's client waits for each answer without a limit: a server that ends between
            # a request and its answer would freeze the frame for ever
            self.io.udp_client.sock.settimeout(REQUEST_TIMEOUT_S)
        except Exception as error:  # ioHub raises many kinds; the session needs one message
            self._stop_guard()
            raise TrackerError(
                f"ioHub could not start the eye tracker {tracker!r}: {error}"
            ) from error
        if self.device_handle is None:
            self._quit()
            self._stop_guard()
            raise TrackerError(f"ioHub started without the eye tracker {tracker!r}")
        self.disconnects = 0
        self.blinking = False  # whether the last sample had the eye closed

    def start(self) -> None:
        """Start recording (ioHub keeps the raw samples as it stores them); ``disconnects``
        counts the samples asked for while the tracker or ioHub's server was gone."""
        self.device_handle.setRecordingState(True)

    def time_s(self) -> float:
        """The ioHub clock now, s (the clock of its samples' times and of its hdf5 store).

        Returns
        -------
        float
        """
        from psychopy.iohub.devices import Computer

        return float(Computer.getTime())  # the shared time base, without asking the server

    def sample(self) -> tuple[float | None, float | None, float | None]:
        """The tracker's last sample: gaze x, y in window pixels from the top-left and the pupil
        in the tracker's unit, each None where the tracker gave none (lost, blink, no tracker).

        Returns
        -------
        tuple
            ``(gaze_x_px, gaze_y_px, pupil_raw)``: a binocular tracker's mean of the eyes it
            found (one eye's alone when it lost the other). A sample with the eye(s) not
            found or without a pupil is a blink (``blinking`` true): all three None.
        """
        self.blinking = False
        server = getattr(self.io, "_server_process", None)
        if server is not None and server.poll() is not None:
            # ioHub's server has ended: a request would wait for its answer for ever
            self.disconnects += 1
            return None, None, None
        try:
            raw = self.device_handle.getLastSample()
        except Exception:  # a tracker that disconnects: no sample, counted, never a crash
            self.disconnects += 1
            return None, None, None
        if not raw:
            return None, None, None
        names = (
            self._names["mono"] if len(raw) == len(self._names["mono"]) else self._names["bino"]
        )
        event = dict(zip(names, raw, strict=False))
        width, height = self.window.size
        # ioHub's status is 0 for a sample with its eye(s) found (MouseGaze: 2 in a blink); a
        # binocular sample's is 20 with the left eye missing, 2 the right, 22 both. Its
        # UNDEFINED is 0, the centre's coordinate too, so the status decides
        status = int(event.get("status") or 0)
        if "gaze_x" in event:
            eyes = [("", status == 0)]
        else:  # binocular: the mean of the eyes found, one eye's alone
            eyes = [("left_", status // 10 % 10 == 0), ("right_", status % 10 == 0)]
        found = [prefix for prefix, ok in eyes if ok]
        gazes = [
            (float(event[f"{p}gaze_x"]), float(event[f"{p}gaze_y"]))
            for p in found
            if _finite(event[f"{p}gaze_x"]) and _finite(event[f"{p}gaze_y"])
        ]
        pupils = [
            float(event[f"{p}pupil_measure1"])
            for p in found
            if _finite(event[f"{p}pupil_measure1"]) and event[f"{p}pupil_measure1"] > 0
        ]
        pupil_raw = sum(pupils) / len(pupils) if pupils else None
        self.blinking = pupil_raw is None  # the eye closed: its pupil not measured
        if not found:  # a blink: no gaze either
            return None, None, None
        if not gazes:
            return None, None, pupil_raw
        x = sum(g[0] for g in gazes) / len(gazes)
        y = sum(g[1] for g in gazes) / len(gazes)
        return x + width / 2, height / 2 - y, pupil_raw

    def close(self) -> None:
        """Stop recording and the ioHub server (a tracker or server already gone: nothing)."""
        server = getattr(self.io, "_server_process", None)
        try:
            if server is None or server.poll() is None:  # a request to an ended one would hang
                self.device_handle.setRecordingState(False)
        except Exception:  # a disconnected tracker, a server that ended: nothing to stop
            pass
        finally:
            try:
                self._quit()
            except Exception:  # the server already gone: nothing to quit
                pass
            self._stop_guard()

    def _quit(self) -> None:
        """ioHub's quit, whose words on the server's end ("ioHub Server Process Completed
        With Code: 0") go to the server's log, not the session's terminal."""
        with _output_to(getattr(self, "_server_log", None)):
            self.io.quit()

    def _stop_guard(self) -> None:
        """Stop the guard of a server this process quit (or never started)."""
        self._guard.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self._guard.wait(timeout=GUARD_WAIT_S)


def _finite(value) -> bool:
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError):
        return False
