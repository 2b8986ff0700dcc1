"""PsychoPy's Monitor Center both ways: a lab's monitor for a study, a glarelab calibration for
the lab's monitor.

- :func:`load_monitor` reads a monitor of Monitor Center (``~/.psychopy3/monitors/NAME.json``,
  or the ``folder`` given) and :func:`monitor_display` gives what glarelab takes from it: the
  screen's size in pixels, its width and the viewing distance (for the protocol's geometry,
  :func:`glarelab.protocols.with_monitor`) and its luminance calibration (for a glarelab
  calibration, :func:`calibration_from_monitor`).
- :func:`export_calibration` writes a glarelab calibration into a Monitor Center monitor (a
  new calibration of it, named by the calibration's date and hash): the gamma grid of its
  gain-offset-gamma fit, the readings as Monitor Center's luminance measurements, the size,
  width and distance of the protocol's display.
- :func:`window_monitor` is the ``monitor`` every glarelab window is opened with: the display's
  size, width and distance, so PsychoPy has a monitor and does not warn "Monitor specification
  not found", and a default gamma grid, so PsychoPy leaves the graphics card's gamma table
  alone: glarelab encodes luminance through its own calibration, and a monitor's gamma loaded
  into the card would re-map every code a second time.

Monitor Center keeps a monitor's gamma per gun as ``L = a + (b + k·x)^γ`` (PsychoPy's
``gammaFun``, ``eq=4``) in a 4 × 6 grid (rows luminance, R, G, B; columns min, max, γ, a, b,
k); the glarelab calibration's gain-offset-gamma fit
(:func:`glarelab.display.calibration.fit_calibration`, ``method="gog"``),
``L = black + (max − black)·(gain·x + offset)^γ``, is the
same curve with ``a = black``, ``b = offset·(max − black)^(1/γ)`` and
``k = gain·(max − black)^(1/γ)``.
"""

from __future__ import annotations

import itertools
import json
import re
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from glarelab.display.calibration import Calibration, fit_calibration
from glarelab.files.atomic import write_text

__all__ = [
    "calibration_from_monitor",
    "default_monitor_folder",
    "export_calibration",
    "load_monitor",
    "monitor_display",
    "window_monitor",
]

#: the grid of a monitor without a luminance calibration (PsychoPy's ``newCalib``)
DEFAULT_GRID = np.array([[0.0, 1.0, 1.0]] * 4)


def default_monitor_folder() -> Path:
    """Monitor Center's folder (``~/.psychopy3/monitors`` on Linux and macOS,
    ``%APPDATA%/psychopy3/monitors`` on Windows)."""
    from psychopy.monitors import calibTools

    return Path(calibTools.monitorFolder)


def _monitor_class():
    from psychopy import monitors

    class _Monitor(monitors.Monitor):
        """A Monitor whose calibrations come from ``calibs`` (read from a file of a given
        folder, or made here), not from PsychoPy's own folder."""

        def __init__(self, name: str, calibs: dict):
            self._given = calibs
            super().__init__(name, autoLog=False, verbose=False)

        def _loadAll(self):
            self.calibs = dict(self._given)
            self.calibNames = sorted(self.calibs)

    return _Monitor


def _read_calibs(path: Path) -> dict:
    import json_tricks

    try:
        calibs = json_tricks.loads(
            path.read_text(encoding="utf-8"), ignore_comments=False, preserve_order=False
        )
    except (ValueError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not a Monitor Center monitor ({error})") from None
    if not isinstance(calibs, dict) or not calibs:
        raise ValueError(f"{path}: not a Monitor Center monitor (no calibrations in it)")
    return calibs


def _check_monitor_name(name: str) -> None:
    """Refuse a monitor name that is not one file name of the monitor folder: empty (an unset
    shell variable; it would be the hidden file ``.json``), with a path separator, ``.`` or
    ``..`` at its start, or blank."""
    if not isinstance(name, str):
        raise TypeError(f"--monitor must be a name (str), got {type(name).__name__} {name!r}")
    if not name.strip():
        raise ValueError(
            f"--monitor {name!r}: a monitor name must not be empty or blank (an unset shell "
            "variable?); give the name Monitor Center shows, e.g. --monitor lab"
        )
    bad = [c for c in ("/", "\\", "\0") if c in name]
    if bad or name.startswith("."):
        raise ValueError(
            f"--monitor {name!r}: a monitor name is one file name of the monitor folder: it "
            "must not hold '/', '\\' or a NUL, nor start with '.'"
        )


def load_monitor(name: str, *, folder: str | Path | None = None):
    """The Monitor Center monitor ``name`` (its latest calibration current), from ``folder``
    (default :func:`default_monitor_folder`).

    Parameters
    ----------
    name
        The monitor's name in Monitor Center: the file ``NAME.json`` of ``folder``.
    folder
        The folder of Monitor Center's monitor files; None (default): Monitor Center's own,
        :func:`default_monitor_folder`.

    Returns
    -------
    psychopy.monitors.Monitor
        The monitor, read from that file only (not from PsychoPy's own folder).

    Raises
    ------
    ValueError
        For a monitor that is not there (naming those that are), a file that is not one, or a
        name that is not one file name (empty, with ``/``, or starting with ``.``).
    """
    _check_monitor_name(name)
    folder = Path(folder) if folder is not None else default_monitor_folder()
    path = folder / f"{name}.json"
    if not path.is_file():
        known = sorted(p.stem for p in folder.glob("*.json")) if folder.is_dir() else []
        raise ValueError(
            f"--monitor {name!r}: no such monitor in Monitor Center's folder {folder} "
            f"(monitors there: {', '.join(known) or 'none'})"
        )
    return _monitor_class()(name, _read_calibs(path))


def monitor_display(monitor) -> dict:
    """What glarelab takes from a Monitor Center monitor: ``resolution_px`` (width, height),
    ``width_cm``, ``distance_cm`` (None where the monitor does not say), and its luminance:
    ``gamma_grid`` (the 4 × 6 grid) and ``readings`` (``(level, cd/m²)`` of its luminance
    measurements, level 0-255 as Monitor Center measures them; empty without).

    Parameters
    ----------
    monitor : psychopy.monitors.Monitor
        A Monitor Center monitor, as :func:`load_monitor` gives it (its current calibration
        is read).

    Returns
    -------
    dict
        ``name``, ``calibration`` (the current calibration's name), ``resolution_px``
        (``[width, height]``, px), ``width_cm``, ``distance_cm``, ``gamma_grid`` (4 × 6 list
        or None) and ``readings`` (list of ``(level, cd/m²)``).
    """
    size = monitor.getSizePix()
    levels, lums = monitor.getLevelsPre(), monitor.getLumsPre()
    readings = []
    if levels is not None and lums is not None:
        lum = np.asarray(lums, dtype=float)
        lum = lum[0] if lum.ndim == 2 else lum  # the luminance gun's row
        lev = np.asarray(levels, dtype=float)
        lev = lev[0] if lev.ndim == 2 else lev
        readings = [(float(a), float(b)) for a, b in zip(lev, lum, strict=False)]
    grid = monitor.getGammaGrid()
    return {
        "name": monitor.name,
        "calibration": monitor.currentCalibName,
        "resolution_px": [int(v) for v in size] if size is not None else None,
        "width_cm": float(monitor.getWidth()) if monitor.getWidth() else None,
        "distance_cm": float(monitor.getDistance()) if monitor.getDistance() else None,
        "gamma_grid": None if grid is None else np.asarray(grid, dtype=float).tolist(),
        "readings": readings,
    }


def calibration_from_monitor(monitor, *, bit_depth: int) -> Calibration:
    """A glarelab calibration of a Monitor Center monitor's luminance: fitted to its luminance
    measurements when it has four or more (levels 0-255 taken to the display's codes), else
    sampled from its gamma grid's luminance row (33 codes of ``L = a + (b + k·x)^γ``, or
    ``min + (max − min)·x^γ`` where ``a``, ``b``, ``k`` are not set). Marked ``unverified``.

    Parameters
    ----------
    monitor : psychopy.monitors.Monitor
        A Monitor Center monitor, as :func:`load_monitor` gives it (its current calibration
        is read).
    bit_depth
        The display's bits per channel, one of 8, 10, 12, 16: Monitor Center's levels
        0-255 are scaled to its codes 0 … 2^bit_depth − 1.

    Returns
    -------
    Calibration
        The calibration fitted by :func:`~glarelab.display.calibration.fit_calibration`.

    Raises
    ------
    ValueError
        For a monitor without a luminance calibration (Monitor Center's default grid).
    """
    facts = monitor_display(monitor)
    top = 2**bit_depth - 1
    label = (
        f"PsychoPy Monitor Center monitor {facts['name']!r}, calibration {facts['calibration']}"
    )
    readings = facts["readings"]
    if len(readings) >= 4:
        by_code: dict[int, float] = {}
        for level, lum in readings:
            by_code[round(level * top / 255)] = lum
        pairs = sorted(by_code.items())
        return fit_calibration(
            pairs,
            bit_depth=bit_depth,
            label=label + " (its luminance measurements)",
            source=f"Monitor Center {facts['name']}",
        )
    grid = facts["gamma_grid"]
    if grid is None or np.allclose(np.asarray(grid)[:, :3], DEFAULT_GRID, equal_nan=True):
        raise ValueError(
            f"--monitor {facts['name']!r} has no luminance calibration in Monitor Center (its "
            "gamma grid is the default and it has no luminance measurements): give "
            "--calibration, or calibrate it first"
        )
    low, high, gamma, *rest = (list(grid[0]) + [np.nan] * 6)[:6]
    a, b, k = rest
    x = np.linspace(0.0, 1.0, 33)
    if all(np.isfinite(v) for v in (a, b, k)) and k > 0:
        lum = a + (b + k * x) ** gamma
    else:
        lum = low + (high - low) * x**gamma
    codes = np.unique(np.round(x * top).astype(int))
    return fit_calibration(
        [(int(c), float(v)) for c, v in zip(codes, lum, strict=True)],
        bit_depth=bit_depth,
        label=label + f" (its gamma grid: {low:g}-{high:g} cd/m², gamma {gamma:g})",
        source=f"Monitor Center {facts['name']}",
    )


def _display_geometry(display: dict | None, viewing: dict | None) -> dict:
    """Monitor Center's size (px), width (cm) and distance (cm) of a protocol's display."""
    if display is None:
        return {}
    width_px, height_px = display["resolution_px"]
    if display.get("pixel_pitch_mm"):
        width_cm = display["pixel_pitch_mm"] * width_px / 10.0
    else:  # from the diagonal, square pixels
        width_cm = display["diagonal_in"] * 2.54 * width_px / float(np.hypot(width_px, height_px))
    facts = {"size_px": [int(width_px), int(height_px)], "width_cm": width_cm}
    if viewing is not None:
        facts["distance_cm"] = viewing["distance_m"] * 100.0
    return facts


def _gamma_grid(calibration: Calibration) -> np.ndarray:
    """Monitor Center's 4 × 6 gamma grid of a calibration (its gain-offset-gamma fit, made
    here when the calibration has none), the same curve on every gun."""
    model = calibration.model or {}
    if not {"gain", "offset", "gamma"} <= set(model):
        model = fit_calibration(
            list(calibration.readings), bit_depth=calibration.bit_depth, method="gog"
        ).model
    black, peak = calibration.black_cd_m2, calibration.max_cd_m2
    scale = (peak - black) ** (1.0 / model["gamma"])
    row = [black, peak, model["gamma"], black, model["offset"] * scale, model["gain"] * scale]
    return np.array([row] * 4, dtype=float)


def export_calibration(
    calibration: Calibration,
    name: str,
    *,
    display: dict | None = None,
    viewing: dict | None = None,
    folder: str | Path | None = None,
) -> tuple[Path, str]:
    """Write ``calibration`` into the Monitor Center monitor ``name`` (made if new, its earlier
    calibrations kept, also one exported from the same calibration before) as a new
    calibration, and make it current; the file and the calibration's name.

    The new calibration holds the gamma grid of the calibration's gain-offset-gamma fit, its
    readings as Monitor Center's luminance measurements (levels 0-255, as Monitor Center
    measures), the size in pixels, width and distance of the protocol's ``display`` and
    ``viewing`` when given, and notes naming the glarelab calibration and its readings' hash.

    Parameters
    ----------
    calibration
        The glarelab calibration to write; its gain-offset-gamma fit is made from its
        readings when it has none.
    name
        The monitor's name in Monitor Center (the file ``NAME.json`` of ``folder``).
    display
        The protocol's display: ``resolution_px`` (width, height, px) and either
        ``pixel_pitch_mm`` (mm) or ``diagonal_in`` (inches, square pixels taken); None:
        no size or width.
    viewing
        The protocol's viewing conditions: ``distance_m`` (viewing distance, m); None: no
        distance (used only with ``display``).
        Where not given, the monitor's current width, distance and size are kept.
    folder
        The folder of Monitor Center's monitor files, which must exist; None (default):
        Monitor Center's own, :func:`default_monitor_folder`.

    Returns
    -------
    tuple of (pathlib.Path, str)
        The monitor file written and the new calibration's name
        (``YYYY_MM_DD HH:MM:SS.ffffff glarelab HASH``, the local time of the export as
        Monitor Center names its own): it sorts after every earlier calibration, so PsychoPy
        makes it current. An earlier release's export, ``glarelab YYYY-MM-DD HASH``, is
        renamed to its date's form (``YYYY_MM_DD 00:00:00.000000 glarelab HASH``), its content
        kept.

    Raises
    ------
    ValueError
        For a ``folder`` that does not exist, a monitor file that is not one, a ``name``
        that is not one file name (empty, with ``/``, or starting with ``.``), or a monitor
        with a calibration whose name sorts after the new one's (PsychoPy would keep that one
        current).
    """
    _check_monitor_name(name)
    folder = Path(folder) if folder is not None else default_monitor_folder()
    if not folder.is_dir():
        raise ValueError(f"--monitor-folder {folder}: no such folder")
    path = folder / f"{name}.json"
    calibs = _read_calibs(path) if path.is_file() else {}
    calibs = {_dated(n): c for n, c in calibs.items()}  # earlier exports' names, sortable
    monitor = _monitor_class()(name, calibs) if calibs else None
    # PsychoPy makes the calibration whose name sorts last current, and names its own by the
    # time they were made ("2026_12_04 14:05"): so are these, to the microsecond, to sort
    # after every earlier one, Monitor Center's own among them
    now = datetime.now().strftime("%Y_%m_%d %H:%M:%S.%f")
    stamp = f"{now} glarelab {calibration.readings_sha256[:12]}"
    taken = set(calibs)
    if stamp in taken:  # a clock set back: that entry is kept, the next number given
        stamp = next(f"{stamp} ({n})" for n in itertools.count(2) if f"{stamp} ({n})" not in taken)
    later = sorted(n for n in taken if n > stamp)
    if later:
        raise ValueError(
            f"--monitor {name!r}: its calibration {later[-1]!r} sorts after the new one "
            f"({stamp!r}), and PsychoPy makes the calibration whose name sorts last current, "
            "so the new one would not be used: rename or delete it in Monitor Center, or "
            "export to another --monitor"
        )
    if monitor is None:
        monitor = _monitor_class()(name, {stamp: {}})
        monitor.calibs, monitor.calibNames = {}, []
    geometry = _display_geometry(display, viewing)
    previous = dict(monitor.currentCalib) if monitor.calibNames else {}
    monitor.newCalib(
        calibName=stamp,
        width=geometry.get("width_cm", previous.get("width")),
        distance=geometry.get("distance_cm", previous.get("distance")),
        notes=(
            f"glarelab calibration: {calibration.label or 'no label'}; method "
            f"{calibration.method}, {calibration.bit_depth}-bit, status {calibration.status}, "
            f"{len(calibration.readings)} readings (sha256 {calibration.readings_sha256})"
        ),
    )
    size = geometry.get("size_px", previous.get("sizePix"))
    if size is not None:
        monitor.setSizePix(list(size))
    monitor.setGammaGrid(_gamma_grid(calibration))
    monitor.setLineariseMethod(4)  # PsychoPy's gammaFun eq=4: a + (b + k x)^gamma
    top = 2**calibration.bit_depth - 1
    codes = np.array([c for c, _ in calibration.readings], dtype=float)
    lums = np.array([v for _, v in calibration.readings], dtype=float)
    monitor.setLevelsPre(codes * 255.0 / top)
    monitor.setLumsPre(lums)
    try:  # the calibration's own date
        monitor.setCalibDate(time.mktime(time.strptime(calibration.created, "%Y-%m-%d")))
    except ValueError:  # a calibration without one: now
        monitor.setCalibDate(time.mktime(time.localtime()))
    import json_tricks

    text = json_tricks.dumps(monitor.calibs, indent=2, allow_nan=True)
    json.loads(text)  # what Monitor Center reads back
    write_text(path, text)
    return path, stamp


# the name earlier glarelab releases gave an export ("glarelab 2026-12-03 0123456789ab"),
# which sorts after every dated name: given its date's form, so that time orders them again
_UNDATED_EXPORT = re.compile(r"glarelab (\d{4})-(\d{2})-(\d{2}) ([0-9a-f]{12})((?: \(\d+\))?)")


def _dated(name: str) -> str:
    """An export's name as this release gives it: ``YYYY_MM_DD 00:00:00.000000 glarelab
    HASH`` for an earlier release's ``glarelab YYYY-MM-DD HASH``; any other name as it is."""
    match = _UNDATED_EXPORT.fullmatch(name)
    if match is None:
        return name
    year, month, day, digest, again = match.groups()
    return f"{year}_{month}_{day} 00:00:00.000000 glarelab {digest}{again}"


def window_monitor(
    display: dict | None, viewing: dict | None, *, monitor=None, name: str = "glarelab"
):
    """The monitor a glarelab window is opened with: the Monitor Center ``monitor``'s size,
    width and distance when given, else the protocol's display's, and Monitor Center's default
    gamma grid, so PsychoPy leaves the graphics card's gamma table as it is (glarelab encodes
    through its own calibration). Saved nowhere.

    Parameters
    ----------
    display
        The protocol's display: ``resolution_px`` (width, height, px) and either
        ``pixel_pitch_mm`` (mm) or ``diagonal_in`` (inches, square pixels taken); None:
        no size or width.
    viewing
        The protocol's viewing conditions: ``distance_m`` (viewing distance, m); None: no
        distance (used only with ``display``).
    monitor : psychopy.monitors.Monitor, optional
        A Monitor Center monitor (:func:`load_monitor`); when given, its size, width,
        distance and name are used instead of ``display``, ``viewing`` and ``name``.
    name
        The monitor's name when no ``monitor`` is given (default ``"glarelab"``).

    Returns
    -------
    psychopy.monitors.Monitor
        A monitor with a single calibration, ``glarelab``, and the default gamma grid.
    """
    if monitor is not None:
        facts = monitor_display(monitor)
        geometry = {
            "size_px": facts["resolution_px"],
            "width_cm": facts["width_cm"],
            "distance_cm": facts["distance_cm"],
        }
        name = facts["name"]
    else:
        geometry = _display_geometry(display, viewing)
    calib = {
        "width": geometry.get("width_cm"),
        "distance": geometry.get("distance_cm"),
        "sizePix": geometry.get("size_px"),
        "gammaGrid": np.array([[0.0, 1.0, 1.0, np.nan, np.nan, np.nan]] * 4),
        "gamma": None,
        "notes": "glarelab: the display's geometry; glarelab encodes through its calibration",
        "linearizeMethod": 1,
        "calibDate": time.mktime(time.localtime()),
        "usebits": False,
        "psychopyVersion": "",
    }
    return _monitor_class()(name, {"glarelab": calib})
