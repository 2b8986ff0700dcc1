"""Where the simulated observers were fitted, and a warning when they are asked beyond it.

The observers' parameters (:mod:`glarelab.observers.brightness`, :mod:`glarelab.observers.noise`)
were fitted on the stimuli of Yoshida et al. 2008 §3 and Spencer et al. 1995 §4 as this suite
renders them (``scripts/fit_observers.py``, ``docs/observers.md``). A study whose stimuli lie
outside them (another kernel or PSF normalisation, wider levels, another disk size or
luminance, another background or pixel size) is simulated by extrapolation:
:func:`warn_outside_fitted_range` says so, once per observer, naming each value.

What a paradigm's observers judge is given to these functions by the paradigm
(:class:`JudgedStimuli`, from its observer's ``judged(protocol, geometry)``), so this module
never asks which paradigm a protocol is.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import KW_ONLY, dataclass
from typing import Any

__all__ = [
    "FITTED_BACKGROUND_RATIO",
    "FITTED_DISK_CD_M2",
    "FITTED_DISK_DIAMETER_DEG",
    "FITTED_GAUSSIAN_SIGMA_DEG",
    "FITTED_LEVEL_RATIO",
    "FITTED_PIXEL_DEG",
    "FITTED_SKY_CONTRAST",
    "FITTED_VOS_PSFS",
    "JudgedBackground",
    "JudgedGlare",
    "JudgedStimuli",
    "OutsideFittedRangeWarning",
    "fitted_range_departures",
    "judged_background",
    "warn_outside_fitted_range",
]

# --- the stimuli the fit saw (Yoshida 2008 §3 and Spencer 1995 §4 as this suite renders them) -
FITTED_GAUSSIAN_SIGMA_DEG = (0.34, 0.34)
"""Gaussian kernel widths ``σ`` (deg) the fit saw: Yoshida 2008 §3 Method I, 0.34° only. The
glow band ``w`` was fitted on it, so a wider kernel's ramp is judged over a part of it."""
FITTED_VOS_PSFS = (("photopic", "psf"), ("mesopic", "Spencer1995"))
"""Vos PSFs the fit saw, as ``(regime, normalisation)``, at the default age: Yoshida Method II
(eqs. 3-6), photopic, normalised as a PSF (Spencer eq. 4); Spencer §4, mesopic (eq. 8) with each
filter renormalised "so that all pixels sum to one" (§3.2), with flare lines. The normalisation
changes the glow: renormalised over Yoshida's 271² kernel at 0.0118°/px, the photopic PSF
sends 9.4 % more light off the centre pixel (4 % more at 0.04°, 13 % at 0.09°, 36 % at 0.47°),
so a regime fitted with one normalisation is outside with the other."""
FITTED_LEVEL_RATIO = {"gaussian": (1.0, 7000.0 / 220.0), "vos": (1.0, 285.0)}
"""Glare source luminance over the clamp it is rendered against, per kernel: Yoshida's levels
over ``L_dmax`` = 220 cd/m² (A-F: 1-31.8; a-f: 1-45.5) and Spencer's ``1 + strength`` (1.01-285,
Vos only)."""
FITTED_DISK_DIAMETER_DEG = (0.1065, 0.3)
"""Diameters (deg) of the disks judged: Spencer's 4-pixel source at 0.0266°/px and Yoshida's
0.3° disk."""
FITTED_DISK_CD_M2 = (37.5, 220.0)
"""Luminance (cd/m²) of the judged disk as displayed, the clamp: Spencer's peak (75 % of the
50 cd/m² of §1) and Yoshida's ``L_dmax``."""
FITTED_PIXEL_DEG = (0.011824416329142544, 0.02663456932871299)
"""Pixel sizes (deg) the fit saw: Yoshida's 20.8-inch 2048 × 1536 display at 1 m and Spencer's
1280 × 1024 CRT (18-inch visible diagonal) at 0.6 m. The model measures the border, glow and
ring in rings of at least a pixel, so the same stimulus drawn with other pixels is judged
differently."""
FITTED_BACKGROUND_RATIO = {
    "sky": (150.0 / 220.0, 150.0 / 220.0),
    "uniform": (0.0, 0.1 / 37.5),
    "lamp": (75.0 / 37.5, 75.0 / 37.5),
}
"""Backgrounds the fit saw, by kind, as their luminance over the judged disk's (the model
judges every luminance relative to the disk's): Yoshida's sky (mean 150 cd/m² under the
220 cd/m² clamp), Spencer's black field (the display's black, 0.1 cd/m², or darker, under
the 37.5 cd/m² peak) and Spencer's lamp scene (scaled to 75 cd/m², twice the peak). A field
of one luminance brighter than black, a sky of another mean, or a lab's own EXR were not
fitted."""
FITTED_SKY_CONTRAST = (0.15, 0.15)
"""RMS contrast of the sky the fit saw (Yoshida's, as ``yoshida2008.toml`` draws it): a
cloud's edge can look like a glow to the model (``docs/observers.md``)."""
_RELATIVE = 1e-3  # a value within 0.1 % of a fitted bound is inside it (rounded geometry)


class OutsideFittedRangeWarning(UserWarning):
    """Simulated observers are asked about stimuli unlike those their parameters were fitted on
    (the ``FITTED_*`` constants, ``docs/observers.md``): their answers are an extrapolation."""


def _inside(value: float, bounds: tuple[float, float]) -> bool:
    low, high = bounds
    return low * (1 - _RELATIVE) <= value <= high * (1 + _RELATIVE)


def _bounds(bounds: tuple[float, float], unit: str = "") -> str:
    low, high = bounds
    if math.isclose(low, high):
        return f"{low:.4g}{unit} only"
    return f"{low:.4g}-{high:.4g}{unit}"


def _kernel_departures(where: str, model: str, parameters, ratios: list[float]) -> list[str]:
    """Departures of one glare method (``model`` with ``parameters``, its levels as ratios of
    source luminance to the clamp) from what the fit saw."""
    from glarelab.protocols.common import glare_model

    if model not in FITTED_LEVEL_RATIO:
        return [f"{where}: glare model {model!r} (fitted on {', '.join(FITTED_LEVEL_RATIO)} only)"]
    out = []
    kernel = glare_model(model, parameters or {})
    if model == "gaussian" and not _inside(kernel.sigma_deg, FITTED_GAUSSIAN_SIGMA_DEG):
        out.append(
            f"{where}: Gaussian sigma_deg = {kernel.sigma_deg:.4g}° (fitted on "
            f"{_bounds(FITTED_GAUSSIAN_SIGMA_DEG, '°')})"
        )
    if model == "vos":
        if (kernel.regime, kernel.normalisation) not in FITTED_VOS_PSFS:
            fitted = ", ".join(f"{r} with {n!r}" for r, n in FITTED_VOS_PSFS)
            out.append(
                f"{where}: Vos regime {kernel.regime!r} with normalisation "
                f"{kernel.normalisation!r} (fitted on {fitted} only)"
            )
        if kernel.age is not None:
            out.append(f"{where}: Vos age = {kernel.age:g} years (fitted at the default age)")
    outside = [r for r in ratios if not _inside(r, FITTED_LEVEL_RATIO[model])]
    if outside:
        shown = ", ".join(f"{r:.4g}" for r in outside)
        out.append(
            f"{where}: levels of {shown} × the clamp luminance "
            f"(fitted on {_bounds(FITTED_LEVEL_RATIO[model], ' ×')} for {model})"
        )
    return out


@dataclass(frozen=True)
class JudgedGlare:
    """One glare method whose images an observer judges, as the fitted range needs it.

    Attributes
    ----------
    where
        How a departure names it (``"method 'gaussian'"``).
    model
        Its glare model's name (a key of :data:`glarelab.glare.GLARE_MODELS`).
    parameters
        The model's keywords (None: its defaults).
    level_ratios
        Each level's glare-source luminance over the clamp it is rendered against.
    """

    where: str
    model: str
    parameters: Mapping[str, Any] | None
    level_ratios: tuple[float, ...]


@dataclass(frozen=True)
class JudgedBackground:
    """One background the judged disk is shown on, as the fitted range needs it.

    Attributes
    ----------
    where
        How a departure names it (``"background"``, ``"context 'lamp'"``).
    kind
        Its kind (``"sky"``, ``"uniform"``, ``"lamp"``, ``"exr"``:
        :data:`glarelab.protocols.common.BACKGROUNDS`).
    ratio
        Its luminance (a sky's mean, a field's luminance as displayed, a lamp scene's scale)
        over the judged disk's; None where the protocol does not say it (an EXR).
    contrast
        A sky's RMS contrast; None for other kinds.
    """

    where: str
    kind: str
    ratio: float | None
    contrast: float | None = None


def judged_background(
    where: str, spec: Mapping[str, Any], *, disk_cd_m2: float, black_cd_m2: float
) -> JudgedBackground:
    """A protocol's background table as the fitted range judges it.

    Parameters
    ----------
    where
        How a departure names it.
    spec
        The validated background table (``kind`` and its keys,
        :data:`glarelab.protocols.common.BACKGROUNDS`).
    disk_cd_m2
        The judged disk's luminance as displayed (cd/m², > 0).
    black_cd_m2
        The display's black (cd/m²): a field darker than it is shown at it.

    Returns
    -------
    JudgedBackground
        Its kind, its luminance over the disk's and, for a sky, its contrast.

    Raises
    ------
    ValueError
        For a kind other than sky, uniform, lamp or exr.

    Examples
    --------
    >>> judged_background("background", {"kind": "uniform", "cd_m2": 0.0},
    ...                   disk_cd_m2=37.5, black_cd_m2=0.1).ratio * 37.5
    0.1
    """
    kind = spec["kind"]
    if kind == "sky":
        return JudgedBackground(where, kind, spec["mean_cd_m2"] / disk_cd_m2, spec["contrast"])
    elif kind == "uniform":
        return JudgedBackground(where, kind, max(spec["cd_m2"], black_cd_m2) / disk_cd_m2)
    elif kind == "lamp":
        return JudgedBackground(where, kind, spec["peak_cd_m2"] / disk_cd_m2)
    elif kind == "exr":
        return JudgedBackground(where, kind, None)
    else:
        raise ValueError(f"background kind must be sky, uniform, lamp or exr; got {kind!r}")


def _background_departures(background: JudgedBackground) -> list[str]:
    where, kind = background.where, background.kind
    if kind not in FITTED_BACKGROUND_RATIO:
        fitted = ", ".join(FITTED_BACKGROUND_RATIO)
        return [f"{where}: {kind} background (fitted on {fitted} only)"]
    out = []
    bounds = FITTED_BACKGROUND_RATIO[kind]
    if background.ratio is None or not (
        _inside(background.ratio, bounds) or (bounds[0] == 0.0 and background.ratio == 0.0)
    ):
        shown = "unknown" if background.ratio is None else f"{background.ratio:.4g}"
        out.append(
            f"{where}: {kind} background at {shown} × the disk's luminance "
            f"(fitted on {_bounds(bounds, ' ×')} for {kind})"
        )
    if kind == "sky" and not _inside(background.contrast, FITTED_SKY_CONTRAST):
        out.append(
            f"{where}: sky contrast {background.contrast:.4g} "
            f"(fitted on {_bounds(FITTED_SKY_CONTRAST)})"
        )
    return out


@dataclass(frozen=True)
class JudgedStimuli:
    """What a paradigm's simulated observers judge, in the terms of the fitted range: the glare
    methods, the judged disk's luminance (the clamp, cd/m²) and its diameter (deg), the
    backgrounds it is shown on and the pixel size (deg). Each
    paradigm's observer says it (``judged(protocol, geometry)``), so this module never asks
    which paradigm a protocol is.

    Parameters
    ----------
    glare
        The glare methods whose images the observers judge, one :class:`JudgedGlare` each.
    disk_cd_m2
        The judged disk's luminance as displayed, the clamp (cd/m², > 0; fitted on
        :data:`FITTED_DISK_CD_M2`).
    disk_diameter_deg
        The judged disk's diameter (deg, > 0; fitted on :data:`FITTED_DISK_DIAMETER_DEG`).
    backgrounds
        The backgrounds the disk is shown on, one :class:`JudgedBackground` each (fitted on
        :data:`FITTED_BACKGROUND_RATIO`, :data:`FITTED_SKY_CONTRAST`).
    pixel_deg
        The pixel size (deg, > 0; fitted on :data:`FITTED_PIXEL_DEG`).
    """

    glare: tuple[JudgedGlare, ...]
    disk_cd_m2: float
    disk_diameter_deg: float
    _: KW_ONLY
    backgrounds: tuple[JudgedBackground, ...]
    pixel_deg: float


def fitted_range_departures(judged: JudgedStimuli) -> list[str]:
    """How the stimuli judged depart from those the observers were fitted on.

    Parameters
    ----------
    judged
        The glare methods, the disk's luminance and its diameter, as a paradigm's observer
        gives them (``judged(protocol, geometry)``).

    Returns
    -------
    list of str
        One line per departure (kernel width, model or PSF normalisation, levels, disk size,
        disk luminance, background, pixel size), naming the value and the fitted range; empty
        inside it.

    Examples
    --------
    >>> gaussian = JudgedGlare("method 'gaussian'", "gaussian", {"sigma_deg": 0.34}, (1.0, 20.0))
    >>> sky = JudgedBackground("background", "sky", 150.0 / 220.0, 0.15)
    >>> seen = dict(backgrounds=(sky,), pixel_deg=0.011824416329142544)
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 0.3, **seen))
    []
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 1.0, **seen))
    ['disk diameter 1° (fitted on 0.1065-0.3°)']
    """
    out: list[str] = []
    for method in judged.glare:
        out += _kernel_departures(
            method.where, method.model, method.parameters, list(method.level_ratios)
        )
    diameter, clamp = judged.disk_diameter_deg, judged.disk_cd_m2
    if not _inside(diameter, FITTED_DISK_DIAMETER_DEG):
        out.append(
            f"disk diameter {diameter:.4g}° (fitted on {_bounds(FITTED_DISK_DIAMETER_DEG, '°')})"
        )
    if not _inside(clamp, FITTED_DISK_CD_M2):
        out.append(
            f"disk luminance {clamp:.4g} cd/m² (the clamp; fitted on "
            f"{_bounds(FITTED_DISK_CD_M2, ' cd/m²')})"
        )
    for background in judged.backgrounds:
        out += _background_departures(background)
    if not _inside(judged.pixel_deg, FITTED_PIXEL_DEG):
        out.append(
            f"pixel size {judged.pixel_deg:.4g}° (fitted on {_bounds(FITTED_PIXEL_DEG, '°')})"
        )
    return out


def warn_outside_fitted_range(study: str, judged: JudgedStimuli) -> list[str]:
    """Warn once, with every departure, when the stimuli a study's observers judge lie outside
    what the observers were fitted on (:func:`fitted_range_departures`); return the
    departures.

    Parameters
    ----------
    study
        How the warning names the study (its protocol's study name).
    judged
        The glare methods, the disk's luminance and its diameter, as a paradigm's observer
        gives them (``judged(protocol, geometry)``).

    Returns
    -------
    list of str
        The departures, as :func:`fitted_range_departures` returns them; empty inside the
        fitted range (and no warning).

    Warns
    -----
    OutsideFittedRangeWarning
        Naming each value and its fitted range.
    """
    departures = fitted_range_departures(judged)
    if departures:
        warnings.warn(
            f"the simulated observers of {study} are asked about stimuli outside those they "
            f"were fitted on (docs/observers.md), so their answers are an extrapolation: "
            + "; ".join(departures),
            OutsideFittedRangeWarning,
            stacklevel=2,
        )
    return departures
