"""Where the simulated observers were fitted, and a warning when they are asked beyond it.

The observers' parameters (:mod:`glarelab.observers.brightness`, :mod:`glarelab.observers.noise`)
were fitted on the stimuli of Yoshida et al. 2008 §3 and Spencer et al. 1995 §4 as this suite
renders them (``scripts/fit_observers.py``, ``docs/observers.md``). A study whose stimuli lie
outside them (another kernel or PSF normalisation, wider levels, another disk size or
luminance, another background, sky, pixel size, bit depth or room light, a Vos halo of
another pupil, wavelength or spectrum) is simulated by extrapolation:
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
    "FITTED_BIT_DEPTH",
    "FITTED_DISK_CD_M2",
    "FITTED_DISK_DIAMETER_DEG",
    "FITTED_GAUSSIAN_SIGMA_DEG",
    "FITTED_LEVEL_RATIO",
    "FITTED_PIXEL_DEG",
    "FITTED_ROOM_LUX",
    "FITTED_SKY_CLOUD_DEG",
    "FITTED_SKY_CONTRAST",
    "FITTED_SKY_SPECTRUM_SLOPE",
    "FITTED_VOS_FLARE_LINES",
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
FITTED_SKY_CLOUD_DEG = {"cloud_min_deg": (0.05, 0.05), "cloud_max_deg": (3.2, 3.2)}
"""Cloud sizes (deg) of the sky the fit saw (``yoshida2008.toml``: structure from 0.05° to the
3.2° of the whole image): the clouds' size sets how much of the surround the model's lower
quartile over 8 sectors sees as one cloud, and so whether a cloud's edge looks like a glow."""
FITTED_SKY_SPECTRUM_SLOPE = (1.0, 1.0)
"""Amplitude-spectrum slope of the sky the fit saw (``yoshida2008.toml``: 1/f, natural
scenes'): a steeper slope puts the contrast into larger clouds, a shallower one into fine
texture next to the disk's border."""
FITTED_ROOM_LUX = (0.0, 60.0)
"""Room light at the eye (lx) of the studies fitted: Spencer §4's "darkened room" (0 lx) and
Yoshida §4's "dim lighting condition (60 lx)". The model has no ambient term (no reflection
on the screen, no adaptation), so the rooms' effect is held only in the fitted values."""
FITTED_BIT_DEPTH = (8, 10)
"""Display bits per channel of the fitted sets (the observer looks at the images quantised to
the display's codes, :class:`glarelab.observers.looking.ObservedSet`): Spencer's 8-bit frame
buffer and Yoshida's 10-bit display (§3)."""
FITTED_VOS_FLARE_LINES = (150, 300)
"""``(corona_lines, halo_lines)`` of the Vos flare lines the fit saw (Spencer protocol, the
model's defaults): the number of streaks sets how much of the corona's light they gather."""
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
        out += _vos_halo_departures(where, kernel)
    outside = [r for r in ratios if not _inside(r, FITTED_LEVEL_RATIO[model])]
    if outside:
        shown = ", ".join(f"{r:.4g}" for r in outside)
        out.append(
            f"{where}: levels of {shown} × the clamp luminance "
            f"(fitted on {_bounds(FITTED_LEVEL_RATIO[model], ' ×')} for {model})"
        )
    return out


def _vos_halo_departures(where: str, kernel) -> list[str]:
    """Departures of a Vos model's pupil, halo wavelength and spectrum and flare lines from
    those the fit saw, each only where it changes the luminance kernel (a photopic PSF has no
    halo, Spencer eq. 5, so its pupil and wavelength do not matter)."""
    from glarelab.glare.models import vos
    from glarelab.glare.models.spectral import HaloSpectrum

    def _seen(spectrum) -> tuple:  # what the luminance halo H_Y depends on
        low, high = spectrum.wavelength_range_nm  # a TOML table gives a list
        return (spectrum.n_wavelengths, (float(low), float(high)), spectrum.illuminant)

    def _shown(spectrum) -> str:
        low, high = spectrum.wavelength_range_nm
        return f"{spectrum.n_wavelengths} over {low:g}-{high:g} nm under {spectrum.illuminant}"

    out = []
    has_halo = vos.WEIGHTS[kernel.regime][3] > 0.0
    if has_halo and kernel.halo_skipped:
        out.append(
            f"{where}: Vos pupil_mm = {kernel.pupil_mm:g} mm drops the lenticular halo "
            "(Spencer §2.1; fitted with the regime's halo, no pupil given)"
        )
    elif has_halo and kernel.wavelength_nm is not None:
        out.append(
            f"{where}: Vos wavelength_nm = {kernel.wavelength_nm:g} nm, a monochromatic halo "
            "(fitted on the white halo only)"
        )
    elif has_halo and _seen(kernel.halo_spectrum) != _seen(HaloSpectrum()):
        out.append(
            f"{where}: Vos halo spectrum of {_shown(kernel.halo_spectrum)} (fitted on "
            f"{_shown(HaloSpectrum())} only)"
        )
    # the halo's streaks count only where there is a halo
    lines = (kernel.corona_lines, kernel.halo_lines if has_halo else FITTED_VOS_FLARE_LINES[1])
    if kernel.flare_lines and lines != FITTED_VOS_FLARE_LINES:
        out.append(
            f"{where}: Vos flare lines corona_lines = {lines[0]}, halo_lines = {lines[1]} "
            f"(fitted on {FITTED_VOS_FLARE_LINES[0]}, {FITTED_VOS_FLARE_LINES[1]} only)"
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
    cloud_deg
        A sky's smallest and largest cloud structure ``(cloud_min_deg, cloud_max_deg)``, deg;
        None for other kinds.
    spectrum_slope
        A sky's amplitude-spectrum slope; None for other kinds.
    """

    where: str
    kind: str
    ratio: float | None
    contrast: float | None = None
    cloud_deg: tuple[float, float] | None = None
    spectrum_slope: float | None = None


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
        Its kind, its luminance over the disk's and, for a sky, its contrast, cloud sizes and
        spectrum slope.

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
        return JudgedBackground(
            where,
            kind,
            spec["mean_cd_m2"] / disk_cd_m2,
            spec["contrast"],
            cloud_deg=(spec["cloud_min_deg"], spec["cloud_max_deg"]),
            spectrum_slope=spec["spectrum_slope"],
        )
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
    if kind != "sky":
        return out
    if not _inside(background.contrast, FITTED_SKY_CONTRAST):
        out.append(
            f"{where}: sky contrast {background.contrast:.4g} "
            f"(fitted on {_bounds(FITTED_SKY_CONTRAST)})"
        )
    for name, value in zip(FITTED_SKY_CLOUD_DEG, background.cloud_deg, strict=True):
        if not _inside(value, FITTED_SKY_CLOUD_DEG[name]):
            out.append(
                f"{where}: sky {name} = {value:.4g}° "
                f"(fitted on {_bounds(FITTED_SKY_CLOUD_DEG[name], '°')})"
            )
    if not _inside(background.spectrum_slope, FITTED_SKY_SPECTRUM_SLOPE):
        out.append(
            f"{where}: sky spectrum_slope = {background.spectrum_slope:.4g} "
            f"(fitted on {_bounds(FITTED_SKY_SPECTRUM_SLOPE)})"
        )
    return out


@dataclass(frozen=True)
class JudgedStimuli:
    """What a paradigm's simulated observers judge, in the terms of the fitted range: the glare
    methods, the judged disk's luminance (the clamp, cd/m²) and its diameter (deg), the
    backgrounds it is shown on, the pixel size (deg), the display's bit depth and the room's
    light (lx). Each
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
    bit_depth
        The display's bits per channel (the protocol's ``display.bit_depth``; fitted on
        :data:`FITTED_BIT_DEPTH`).
    room_lux
        The room's light at the eye (lx, the protocol's ``viewing.room_lux``; fitted on
        :data:`FITTED_ROOM_LUX`).
    """

    glare: tuple[JudgedGlare, ...]
    disk_cd_m2: float
    disk_diameter_deg: float
    _: KW_ONLY
    backgrounds: tuple[JudgedBackground, ...]
    pixel_deg: float
    bit_depth: int
    room_lux: float


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
        One line per departure (kernel width, model or PSF normalisation, a Vos halo's
        pupil, wavelength and spectrum and its flare lines, levels, disk size, disk
        luminance, background and a sky's contrast, cloud sizes and spectrum, pixel size, bit
        depth, room light), naming the value and the fitted range; empty inside it.

    Examples
    --------
    >>> gaussian = JudgedGlare("method 'gaussian'", "gaussian", {"sigma_deg": 0.34}, (1.0, 20.0))
    >>> sky = JudgedBackground("background", "sky", 150.0 / 220.0, 0.15, cloud_deg=(0.05, 3.2),
    ...                        spectrum_slope=1.0)
    >>> seen = dict(backgrounds=(sky,), pixel_deg=0.011824416329142544, bit_depth=10,
    ...             room_lux=60.0)
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 0.3, **seen))
    []
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 1.0, **seen))
    ['disk diameter 1° (fitted on 0.1065-0.3°)']
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 0.3, **{**seen,
    ...                         "bit_depth": 12, "room_lux": 500.0}))
    ['display bit depth 12 (fitted on 8-10)', 'room light 500 lx (fitted on 0-60 lx)']
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
    if not _inside(judged.bit_depth, FITTED_BIT_DEPTH):
        out.append(f"display bit depth {judged.bit_depth} (fitted on {_bounds(FITTED_BIT_DEPTH)})")
    if not _inside(judged.room_lux, FITTED_ROOM_LUX):
        out.append(
            f"room light {judged.room_lux:.4g} lx (fitted on {_bounds(FITTED_ROOM_LUX, ' lx')})"
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
