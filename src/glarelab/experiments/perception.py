"""What a simulated observer perceives: an image-computable brightness model of a disk with the
glare around it, and the noise of observers who report it.

The model looks at one image, luminance in cd/m² as the display shows it, and at the geometry
of the region judged (its centre, its nominal diameter, the pixel size). It never sees labels,
method names, levels or how the image was made, so any two images that are the same give the
same percept, and a new protocol's stimuli are judged by the same rules as the papers'.

**The object and its border.** From the azimuthal mean profile ``P(r)`` around the centre
(rings one pixel wide), the disk's luminance ``L_d`` is the mean over the disk's core
(``r <= R - pixel``, ``R`` the nominal radius). The *plateau* ``R_p >= R`` is where the profile
first leaves ``L_d`` by more than the Weber fraction ``ε`` (glare clamped at the display's
maximum extends the disk's luminance outward). The luminance just outside the border is
``P_a``, the mean over a ring of width ``δ`` at ``a = R_p + h`` (``h``: the border's blur).
A disk within ``ε`` of its immediate surround has no visible border: its plateau then runs into
the surround and its apparent size is not meaningful.

**The glow** (Yoshida's Q1; drives the brightness) is the luminance ramp that descends from the
object: the drop of the luminance over the glow band ``w`` beyond the border, relative to the
object (Zavagno & Caputo 2001: the luminance gradient makes the centre glow). Glare surrounds
its source while the texture of a background does not, so the drop is measured in ``K`` equal
sectors around the centre and the glow is their lower quartile (a drop seen on three sides out
of four):

.. math::

   G = \\max\\Bigl(Q_{25\\%}\\bigl[\\min(P_a^{(k)}, L_d) - P_{a+w}^{(k)}\\bigr]_{k=1..K},
       \\ 0\\Bigr) / L_d ,

with ``P_r^{(k)}`` the mean luminance of sector ``k`` over ``r <= ρ < r + δ``.

**The ring** (Mach band, Q2) is the same drop over the short band ``w_r`` right at the knee,
where Mach bands form at the top of a ramp (Ratliff 1965).

**The apparent diameter** (Q3) is ``2 R_e``, with ``R_e`` where the profile crosses halfway
between ``L_d`` and ``P_a`` (the 50 % point of the border; for a glare-free disk, its own
radius).

**Brightness**, as the luminance of a glare-free disk of the same size on the same background
that looks as bright, is the disk's luminance raised by a glow that must be visible
(``G > G_0``) and saturates (Yoshida 2008 §5: the boost saturates for large ``L_disk``), and by
the object's apparent size when glare has enlarged it (Yoshida §6, after Li & Gilchrist 1999:
larger areas look brighter):

.. math::

   B = L_d \\Bigl(1 + \\beta\\,\\frac{G'}{G' + G_{50}}\\Bigr)
       \\Bigl(\\max\\bigl(\\tfrac{2 R_e}{d},\\,1\\bigr)\\Bigr)^{\\alpha},
   \\qquad G' = \\max(G - G_0, 0).

A glare-free disk has no plateau beyond ``R``, no ramp and ``2 R_e = d``, so ``B = L_d``; the
model is invariant to the luminance scale (``B(kI) = k B(I)``), as Weber's law is in the
photopic range. ``β``, ``G_50``, ``α`` and the glow band ``w`` are fitted once
(``scripts/fit_observers.py``, see ``docs/observers.md``); the other geometry constants and
``G_0`` are set from the vision literature, as their comments say.

**Observers** (:class:`ObserverNoise`, :class:`Observer`): each has a gain ``g ~ N(1, σ_g)``
(clipped at 0) on the illusion, ``B_obs = L_d + g (B - L_d)``; sets the "slightly darker" and
"slightly brighter" targets to ``B_obs (1 ∓ m)(1 + σ_s z)``; answers the yes/no questions by
comparing a measure plus ``N(0, σ_q)`` with a criterion; and in a comparison of two images
reports the brighter one, or neither when their relative difference plus ``N(0, σ_c)`` (plus
the observer's shift for the current block, ``N(0, σ_b)``) is within ``±b``.

References
----------
Yoshida, Ihrke, Mantiuk & Seidel (2008). Brightness of the glare illusion. APGV.
Spencer, Shirley, Zimmerman & Greenberg (1995). Physically-based glare effects. SIGGRAPH.
Zavagno & Caputo (2001). The glare effect and the perception of luminosity. Perception 30.
Li & Gilchrist (1999). Relative area and relative luminance combine to anchor surface
lightness values. Perception & Psychophysics 61.
Ratliff (1965). Mach bands. Holden-Day.
Whittle (1986). Increments and decrements: luminance discrimination. Vision Research 26.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from glarelab.glare._validation import (
    check_image,
    check_in_range,
    check_positive,
    check_positive_int,
)

__all__ = [
    "FITTED_DISK_CD_M2",
    "FITTED_DISK_DIAMETER_DEG",
    "FITTED_GAUSSIAN_SIGMA_DEG",
    "FITTED_LEVEL_RATIO",
    "FITTED_VOS_REGIMES",
    "BrightnessModel",
    "JudgedGlare",
    "JudgedStimuli",
    "Observer",
    "ObserverNoise",
    "OutsideFittedRangeWarning",
    "Percept",
    "fitted_range_departures",
    "observer_parameters",
    "warn_outside_fitted_range",
]

# --- geometry of the judgement (set from the literature; the glow band fitted) -------------
PLATEAU_TOLERANCE = 0.01
"""``ε``: luminances within 1 % of the disk's belong to it: the photopic Weber fraction for
large fields (Whittle 1986 reports increment thresholds of 1-2 % on photopic backgrounds)."""
EDGE_MARGIN_DEG = 0.03
"""``h``: the border's blur, 2 arcmin (about the eye's line-spread width); at least a pixel."""
GLOW_BAND_DEG = 0.16
"""``w``: the glow band beyond the border over which the ramp is judged, about 10 arcmin
(fitted on a grid of 0.1-0.25°, scripts/fit_observers.py)."""
RING_BAND_DEG = 0.05
"""``w_r``: the knee band, 3 arcmin: Mach bands are a few arcmin wide (Ratliff 1965)."""
SAMPLE_DEG = 0.02
"""``δ``: width of the rings whose mean luminance is compared; at least a pixel."""
SECTORS = 8
"""``K``: glare surrounds its source, the texture of a background does not: drops are measured
in 8 sectors of 45° ..."""
SURROUND_QUANTILE = 25.0
"""... and the one counted is their lower quartile, a drop seen on three sides out of four. On
100 random skies like the Yoshida stimuli's, a glare-free disk at 150-433 cd/m² then has no glow
on 92 % or more and one above ``G_0`` on at most 3 % (the drop of the azimuthal mean exceeds
``G_0`` on 12-29 %; ``docs/observers.md``)."""
GLOW_THRESHOLD = 0.02
"""``G_0``: the smallest ramp seen as a glow, twice the Weber fraction ``ε``."""

# --- fitted once to Yoshida 2008 §5 and Spencer 1995 §4.1 (scripts/fit_observers.py) --------
GLOW_GAIN = 0.481
"""``β``: the largest boost a glow gives (a fraction of the disk's luminance)."""
GLOW_HALF = 0.0779
"""``G_50``: the visible glow (``G - G_0``) that gives half the largest boost."""
SIZE_EXPONENT = 0.0375
"""``α``: brightness grows as apparent diameter ** α once glare enlarges the object."""

# --- observers: fitted (gain, setting, questions) or assumed (margin, comparisons) ----------
GAIN_SD = 0.209
"""``σ_g``: between-observer SD of the gain on the illusion (fitted to Yoshida's F values)."""
SETTING_SD = 0.113
"""``σ_s``: SD of each target setting, multiplicative (fitted to Yoshida's F values)."""
MARGIN = 0.08
"""``m``: "slightly but visibly" darker / brighter (assumed; the match is the mean of both
settings, so it cancels from every analysed number)."""
GLOW_CRITERION = 0.0457
"""Q1 "Does the reference image glow?": yes when ``G + N(0, σ) >`` this (fitted to Table 1)."""
GLOW_CRITERION_SD = 0.0216
RING_CRITERION = 0.0306
"""Q2 "Do you see a bright ring?": yes when ``M + N(0, σ) >`` this (fitted to Table 1)."""
RING_CRITERION_SD = 0.0307
SIZE_TOLERANCE = 0.418
"""Q3 "Are the sizes the same?": yes when ``|ln(D_ref / D_target)| + N(0, σ) <`` this
(fitted to Table 1)."""
SIZE_TOLERANCE_SD = 0.385
COMPARISON_SD = 0.04
"""``σ_c``: SD of the relative brightness difference seen in one brief comparison (assumed:
Spencer 1995 gives no spread)."""
NEITHER_BAND = 0.02
"""``b``: relative differences within ±2 % are answered "neither" (assumed)."""
BLOCK_SD = 0.02
"""``σ_b``: SD of an observer's shift between blocks run apart (Spencer's context blocks): the
smallest on a grid under which Spencer's non-significant context effect (§4.1) is at least as
likely as a significant one (fitted; without it, 100 %; ``docs/observers.md``)."""


# --- the stimuli the fit saw (Yoshida 2008 §3 and Spencer 1995 §4 as this suite renders them) -
FITTED_GAUSSIAN_SIGMA_DEG = (0.34, 0.34)
"""Gaussian kernel widths ``σ`` (deg) the fit saw: Yoshida 2008 §3 Method I, 0.34° only. The
glow band ``w`` was fitted on it, so a wider kernel's ramp is judged over a part of it."""
FITTED_VOS_REGIMES = ("photopic",)
"""Vos PSF regimes the fit saw: photopic, at the default age (Yoshida Method II, eqs. 3-6;
Spencer §4, with and without flare lines)."""
FITTED_LEVEL_RATIO = {"gaussian": (1.0, 7000.0 / 220.0), "vos": (1.0, 285.0)}
"""Glare source luminance over the clamp it is rendered against, per kernel: Yoshida's levels
over ``L_dmax`` = 220 cd/m² (A-F: 1-31.8; a-f: 1-45.5) and Spencer's ``1 + strength`` (1.01-285,
Vos only)."""
FITTED_DISK_DIAMETER_DEG = (0.1065, 0.3)
"""Diameters (deg) of the disks judged: Spencer's 4-pixel source at 0.0266°/px and Yoshida's
0.3° disk."""
FITTED_DISK_CD_M2 = (75.0, 220.0)
"""Luminance (cd/m²) of the judged disk as displayed, the clamp: Spencer's peak (75 % of
100 cd/m²) and Yoshida's ``L_dmax``."""
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
        if kernel.regime not in FITTED_VOS_REGIMES:
            out.append(
                f"{where}: Vos regime {kernel.regime!r} (fitted on "
                f"{', '.join(FITTED_VOS_REGIMES)} only)"
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
class JudgedStimuli:
    """What a paradigm's simulated observers judge, in the terms of the fitted range: the glare
    methods, the judged disk's luminance (the clamp, cd/m²) and its diameter (deg). Each
    paradigm's observer says it (``judged(protocol, geometry)``), so this module never asks
    which paradigm a protocol is."""

    glare: tuple[JudgedGlare, ...]
    disk_cd_m2: float
    disk_diameter_deg: float


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
        One line per departure (kernel width or model, levels, disk size, disk luminance),
        naming the value and the fitted range; empty inside it.

    Examples
    --------
    >>> gaussian = JudgedGlare("method 'gaussian'", "gaussian", {"sigma_deg": 0.34}, (1.0, 20.0))
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 0.3))
    []
    >>> fitted_range_departures(JudgedStimuli((gaussian,), 220.0, 1.0))
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
    return out


def warn_outside_fitted_range(study: str, judged: JudgedStimuli) -> list[str]:
    """Warn once, with every departure, when the stimuli a study's observers judge lie outside
    what the observers were fitted on (:func:`fitted_range_departures`); return the
    departures.

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


@dataclass(frozen=True)
class Percept:
    """What an observer perceives of the disk in one image.

    Attributes
    ----------
    brightness_cd_m2
        Luminance of a glare-free disk of the same size on the same background that looks as
        bright (cd/m²).
    glow
        Strength of the glow around the disk, ``G`` (relative drop of the ramp; drives Q1).
    ring
        Strength of a bright ring (Mach band) at the disk's edge, ``M`` (Q2).
    apparent_diameter_deg
        The disk's apparent size (deg; Q3).
    disk_cd_m2
        The disk's own luminance ``L_d`` as displayed (cd/m²).
    """

    brightness_cd_m2: float
    glow: float
    ring: float
    apparent_diameter_deg: float
    disk_cd_m2: float

    @property
    def boost(self) -> float:
        """Relative brightness gain over the disk's own luminance, ``B / L_d - 1`` (0 for a
        black disk)."""
        return self.brightness_cd_m2 / self.disk_cd_m2 - 1.0 if self.disk_cd_m2 > 0 else 0.0


@functools.lru_cache(maxsize=8)
def _ring_geometry(
    shape: tuple[int, int], centre_px: tuple[float, float], pixel_deg: float, sectors: int
):
    """Pixels sorted by radius (deg) around the centre, whole and per sector: what every image
    of one geometry shares (a study's images all do), computed once for the last few
    geometries. Returns ``(order, sorted radius, its cumulative sum, [(sector's pixels
    sorted, their radii)])``, the arrays read-only."""
    rows = (np.arange(shape[0]) - centre_px[0])[:, None]
    cols = (np.arange(shape[1]) - centre_px[1])[None, :]
    radius = (np.sqrt(rows**2 + cols**2) * pixel_deg).ravel()
    angle = np.arctan2(np.broadcast_to(rows, shape), np.broadcast_to(cols, shape))
    sector = (np.floor((angle.ravel() + np.pi) / (2 * np.pi) * sectors).astype(int)) % sectors
    order = np.argsort(radius, kind="stable")
    sorted_radius = radius[order]
    cumulative_radius = np.concatenate(([0.0], np.cumsum(sorted_radius)))
    in_sector = sector[order]
    parts = []
    for s in range(sectors):
        part = order[in_sector == s]
        parts.append((part, radius[part]))
    arrays = [order, sorted_radius, cumulative_radius, *(a for pair in parts for a in pair)]
    for array in arrays:
        array.flags.writeable = False
    return order, sorted_radius, cumulative_radius, tuple(parts)


class _Rings:
    """Mean luminance over rings around a centre, whole or in equal sectors, from pixels sorted
    by radius."""

    def __init__(
        self, image: np.ndarray, centre_px: tuple[float, float], pixel_deg: float, sectors: int
    ):
        order, self.radius, self.cumulative_radius, parts = _ring_geometry(
            image.shape, (float(centre_px[0]), float(centre_px[1])), float(pixel_deg), sectors
        )
        values = image.ravel()
        self.cumulative = np.concatenate(([0.0], np.cumsum(values[order])))
        self.sectors = [
            (radius, np.concatenate(([0.0], np.cumsum(values[part])))) for part, radius in parts
        ]

    @property
    def extent_deg(self) -> float:
        return float(self.radius[-1])

    def within(self, radius_deg: float) -> float:
        """Mean over pixels at most ``radius_deg`` away (at least the nearest pixel)."""
        n = max(int(np.searchsorted(self.radius, radius_deg, side="right")), 1)
        return float(self.cumulative[n] / n)

    def mean(self, inner_deg: float, outer_deg: float) -> float | None:
        """Mean over ``inner <= r < outer``; None when no pixel lies there."""
        i, j = np.searchsorted(self.radius, [inner_deg, outer_deg], side="left")
        return float((self.cumulative[j] - self.cumulative[i]) / (j - i)) if j > i else None

    def sector_means(self, inner_deg: float, outer_deg: float) -> np.ndarray:
        """Mean over ``inner <= r < outer`` in each sector (NaN where a sector has no pixel)."""
        out = np.full(len(self.sectors), np.nan)
        for s, (radius, cumulative) in enumerate(self.sectors):
            i, j = np.searchsorted(radius, [inner_deg, outer_deg], side="left")
            if j > i:
                out[s] = (cumulative[j] - cumulative[i]) / (j - i)
        return out

    def profile(self, step_deg: float) -> tuple[np.ndarray, np.ndarray]:
        """``(mean radius, mean luminance)`` of consecutive rings ``step_deg`` wide."""
        edges = np.arange(0.0, self.extent_deg + 2 * step_deg, step_deg)
        index = np.searchsorted(self.radius, edges, side="left")
        counts = np.diff(index)
        full = counts > 0
        i, j = index[:-1][full], index[1:][full]
        n = counts[full]
        radii = (self.cumulative_radius[j] - self.cumulative_radius[i]) / n
        return radii, (self.cumulative[j] - self.cumulative[i]) / n


@dataclass(frozen=True)
class BrightnessModel:
    """The image-computable brightness model (see the module docstring for the equations).

    Parameters
    ----------
    glow_gain
        ``β``, the largest boost from a glow (fraction; default :data:`GLOW_GAIN`).
    glow_half
        ``G_50``, the visible glow giving half of ``β`` (default :data:`GLOW_HALF`).
    size_exponent
        ``α``, brightness ∝ apparent diameter ** α beyond the nominal one (default
        :data:`SIZE_EXPONENT`).
    glow_threshold
        ``G_0``, the smallest ramp seen as a glow (default :data:`GLOW_THRESHOLD`).
    plateau_tolerance
        ``ε``, Weber fraction within which luminance belongs to the disk (default
        :data:`PLATEAU_TOLERANCE`).
    edge_margin_deg, glow_band_deg, ring_band_deg, sample_deg
        ``h``, ``w``, ``w_r``, ``δ`` in degrees (defaults :data:`EDGE_MARGIN_DEG`,
        :data:`GLOW_BAND_DEG`, :data:`RING_BAND_DEG`, :data:`SAMPLE_DEG`).
    sectors, surround_quantile
        ``K`` sectors and the percentile of their drops counted (defaults :data:`SECTORS`,
        :data:`SURROUND_QUANTILE`).

    Raises
    ------
    ValueError
        For a parameter outside its range (named in the message).

    Examples
    --------
    A glare-free disk looks as bright as it is; glare around it makes it brighter:

    >>> y, x = np.indices((121, 121))
    >>> r_deg = np.hypot(y - 60, x - 60) * 0.01
    >>> plain = np.where(r_deg <= 0.15, 220.0, 150.0)
    >>> model = BrightnessModel()
    >>> round(model.percept(plain, centre_px=(60, 60), diameter_deg=0.3,
    ...                     pixel_deg=0.01).brightness_cd_m2, 6)
    220.0
    >>> glow = np.minimum(plain + 200.0 * np.exp(-(r_deg / 0.3) ** 2), 220.0)
    >>> p = model.percept(glow, centre_px=(60, 60), diameter_deg=0.3, pixel_deg=0.01)
    >>> bool(p.brightness_cd_m2 > 230.0), bool(p.glow > GLOW_THRESHOLD)
    (True, True)
    """

    glow_gain: float = GLOW_GAIN
    glow_half: float = GLOW_HALF
    size_exponent: float = SIZE_EXPONENT
    glow_threshold: float = GLOW_THRESHOLD
    plateau_tolerance: float = PLATEAU_TOLERANCE
    edge_margin_deg: float = EDGE_MARGIN_DEG
    glow_band_deg: float = GLOW_BAND_DEG
    ring_band_deg: float = RING_BAND_DEG
    sample_deg: float = SAMPLE_DEG
    sectors: int = SECTORS
    surround_quantile: float = SURROUND_QUANTILE

    def __post_init__(self) -> None:
        check_positive_int("sectors", self.sectors)
        check_in_range("surround_quantile", self.surround_quantile, 0.0, 100.0)
        check_in_range("glow_gain", self.glow_gain, 0.0, 10.0)
        check_positive("glow_half", self.glow_half)
        check_in_range("size_exponent", self.size_exponent, 0.0, 1.0)
        check_in_range("glow_threshold", self.glow_threshold, 0.0, 1.0)
        check_in_range("plateau_tolerance", self.plateau_tolerance, 0.0, 0.5, low_inclusive=False)
        for name in ("edge_margin_deg", "glow_band_deg", "ring_band_deg", "sample_deg"):
            check_positive(name, getattr(self, name), unit="deg")

    def brightness(self, disk_cd_m2: float, glow: float, diameter_ratio: float) -> float:
        """``B`` from the disk's luminance, its glow ``G`` and ``2 R_e / d`` (module docstring).

        Examples
        --------
        >>> BrightnessModel().brightness(220.0, 0.0, 1.0)
        220.0
        """
        visible = max(glow - self.glow_threshold, 0.0)
        glow_factor = 1.0 + self.glow_gain * visible / (visible + self.glow_half)
        return disk_cd_m2 * glow_factor * max(diameter_ratio, 1.0) ** self.size_exponent

    def percept(
        self,
        image_cd_m2: np.ndarray,
        *,
        centre_px: tuple[float, float],
        diameter_deg: float,
        pixel_deg: float,
    ) -> Percept:
        """Perceive the disk of nominal ``diameter_deg`` centred at ``centre_px`` in an image.

        Parameters
        ----------
        image_cd_m2
            ``(H, W)`` luminance as the display shows it (cd/m², finite, >= 0).
        centre_px
            ``(row, column)`` of the disk's centre in pixel indices (pixel ``(i, j)`` has its
            centre at ``(i, j)``; fractions allowed, e.g. 149.5 between two pixels). Must lie
            inside the image.
        diameter_deg
            The disk's nominal diameter (deg, > 0): the region judged.
        pixel_deg
            Size of a pixel (deg, > 0).

        Returns
        -------
        Percept

        Raises
        ------
        ValueError
            For an image that is not a finite, non-negative 2-D array, a centre outside it, or a
            diameter or pixel size that is not a finite number > 0.

        Warns
        -----
        UserWarning
            When the disk spans fewer than 3 pixels: its border and glow are not resolved.

        Notes
        -----
        The equations are in the module docstring. Where a ring needed lies wholly outside the
        image, the measure that needs it is 0 (no glow is seen beyond the image).
        """
        image = check_image("image_cd_m2", image_cd_m2).astype(np.float64, copy=False)
        diameter_deg = check_positive("diameter_deg", diameter_deg, unit="deg")
        pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
        centre = _check_centre(centre_px, image.shape)
        if diameter_deg / pixel_deg < 3.0:
            warnings.warn(
                f"diameter_deg / pixel_deg = {diameter_deg / pixel_deg:.3g} px: a disk narrower "
                "than 3 pixels has no resolved border; its glow and size are unreliable",
                UserWarning,
                stacklevel=2,
            )
        rings = _Rings(image, centre, pixel_deg, self.sectors)
        radius = diameter_deg / 2
        core = max(radius - pixel_deg, 0.0)
        disk = rings.within(core)
        radii, profile = rings.profile(pixel_deg)

        # the plateau: the disk's luminance, within ε, extends to r_p
        outside = radii >= core
        tolerance = self.plateau_tolerance * disk
        departs = outside & (np.abs(profile - disk) > tolerance)
        if departs.any():
            first = int(np.argmax(departs))
            plateau = max(radius, float(radii[first]) - pixel_deg / 2)
        else:
            plateau = max(radius, rings.extent_deg)

        margin = max(self.edge_margin_deg, pixel_deg)
        width = max(self.sample_deg, pixel_deg)
        start = plateau + margin
        near = rings.mean(start, start + width)
        glow = self._surrounding_drop(rings, start, self.glow_band_deg, width, disk)
        ring = self._surrounding_drop(rings, start, self.ring_band_deg, width, disk)
        edge = _border(radii, profile, disk, core, plateau, near)
        brightness = self.brightness(disk, glow, 2 * edge / diameter_deg)
        return Percept(
            brightness_cd_m2=float(brightness),
            glow=float(glow),
            ring=float(ring),
            apparent_diameter_deg=float(2 * edge),
            disk_cd_m2=float(disk),
        )

    def _surrounding_drop(
        self, rings: _Rings, start: float, band: float, width: float, disk: float
    ) -> float:
        """The drop ``(min(P_a, L_d) - P_{a+band}) / L_d`` in each sector, its lower quartile
        over the sectors that have pixels at both radii (clipped at 0)."""
        if disk <= 0:
            return 0.0
        near = rings.sector_means(start, start + width)
        far = rings.sector_means(start + band, start + band + width)
        drops = (np.minimum(near, disk) - far) / disk
        drops = drops[np.isfinite(drops)]
        if drops.size < len(rings.sectors) / 2:  # the band leaves the image
            return 0.0
        return max(float(np.percentile(drops, self.surround_quantile)), 0.0)


def _check_centre(centre_px, shape: tuple[int, int]) -> tuple[float, float]:
    try:
        row, col = (float(c) for c in centre_px)
    except (TypeError, ValueError):
        raise ValueError(
            f"centre_px must be two numbers (row, column) inside the image of shape {shape}; "
            f"got {centre_px!r}"
        ) from None
    if not (
        math.isfinite(row)
        and math.isfinite(col)
        and 0 <= row <= shape[0] - 1
        and 0 <= col <= shape[1] - 1
    ):
        raise ValueError(
            f"centre_px must lie inside the image, rows 0-{shape[0] - 1} and columns "
            f"0-{shape[1] - 1}; got {centre_px!r}"
        )
    return row, col


def _border(
    radii: np.ndarray,
    profile: np.ndarray,
    disk: float,
    core: float,
    plateau: float,
    near: float | None,
) -> float:
    """``R_e``: where the profile crosses halfway between the disk and ``near`` (the luminance
    just outside the plateau), searched outward from the core; the plateau when there is no
    contrast to cross."""
    if near is None or near == disk:
        return plateau
    half = (disk + near) / 2
    sign = 1.0 if disk > near else -1.0
    inner_r, inner_value = core, disk
    for r, value in zip(radii, profile, strict=True):
        if r < core:
            continue
        if sign * (value - half) < 0:
            if value == inner_value:
                return float(r)
            t = (inner_value - half) / (inner_value - value)
            return float(inner_r + t * (r - inner_r))
        inner_r, inner_value = r, value
    return plateau


# --- observers ---------------------------------------------------------------------------


@dataclass(frozen=True)
class ObserverNoise:
    """How simulated observers differ from each other and from trial to trial.

    Parameters
    ----------
    gain_sd
        ``σ_g``, between-observer SD of the gain on the illusion (default :data:`GAIN_SD`).
    setting_sd
        ``σ_s``, multiplicative SD of each target setting (default :data:`SETTING_SD`).
    margin
        ``m``, the "slightly but visibly" darker / brighter fraction (default :data:`MARGIN`).
    glow_criterion, glow_criterion_sd
        Q1: yes when ``glow + N(0, sd) > criterion`` (defaults :data:`GLOW_CRITERION`,
        :data:`GLOW_CRITERION_SD`).
    ring_criterion, ring_criterion_sd
        Q2: yes when ``ring + N(0, sd) > criterion`` (:data:`RING_CRITERION`,
        :data:`RING_CRITERION_SD`).
    size_tolerance, size_tolerance_sd
        Q3: "same size" when ``|ln(D_ref / D_target)| + N(0, sd) < tolerance``
        (:data:`SIZE_TOLERANCE`, :data:`SIZE_TOLERANCE_SD`).
    comparison_sd
        ``σ_c``, SD of the relative difference seen in one comparison (:data:`COMPARISON_SD`).
    neither_band
        ``b``, relative differences within ``±b`` are "neither" (:data:`NEITHER_BAND`).
    block_sd
        ``σ_b``, SD of an observer's shift between blocks run apart (:data:`BLOCK_SD`).

    Raises
    ------
    ValueError
        For a parameter outside its range (named in the message).

    Examples
    --------
    >>> observer = ObserverNoise().draw(np.random.default_rng(1))
    >>> bool(observer.gain >= 0)
    True
    """

    gain_sd: float = GAIN_SD
    setting_sd: float = SETTING_SD
    margin: float = MARGIN
    glow_criterion: float = GLOW_CRITERION
    glow_criterion_sd: float = GLOW_CRITERION_SD
    ring_criterion: float = RING_CRITERION
    ring_criterion_sd: float = RING_CRITERION_SD
    size_tolerance: float = SIZE_TOLERANCE
    size_tolerance_sd: float = SIZE_TOLERANCE_SD
    comparison_sd: float = COMPARISON_SD
    neither_band: float = NEITHER_BAND
    block_sd: float = BLOCK_SD

    def __post_init__(self) -> None:
        for name in (
            "block_sd",
            "gain_sd",
            "setting_sd",
            "glow_criterion_sd",
            "ring_criterion_sd",
            "size_tolerance_sd",
            "comparison_sd",
        ):
            check_in_range(name, getattr(self, name), 0.0, 5.0)
        check_in_range("margin", self.margin, 0.0, 0.5, high_inclusive=False)
        check_in_range("neither_band", self.neither_band, 0.0, 1.0)
        check_in_range("glow_criterion", self.glow_criterion, -10.0, 10.0)
        check_in_range("ring_criterion", self.ring_criterion, -10.0, 10.0)
        check_in_range("size_tolerance", self.size_tolerance, -10.0, 10.0)

    def draw(self, rng: np.random.Generator) -> Observer:
        """A new observer: the gain ``g ~ N(1, gain_sd)`` clipped at 0, drawn from ``rng``."""
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator; got {type(rng).__name__}")
        return Observer(gain=max(0.0, float(rng.normal(1.0, self.gain_sd))), noise=self)

    def block_shift(self, rng: np.random.Generator) -> float:
        """An observer's shift for one block of comparisons, ``N(0, block_sd)``; pass it to
        :meth:`Observer.compare` as ``shift``."""
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator; got {type(rng).__name__}")
        return float(rng.normal(0.0, self.block_sd)) if self.block_sd > 0 else 0.0


@dataclass(frozen=True)
class Observer:
    """One simulated observer: a gain on the illusion and the noise of :class:`ObserverNoise`.

    Every method that draws noise takes the generator to draw from, so a trial's answer is
    fixed by the generator the caller seeds for it.

    Examples
    --------
    >>> model = BrightnessModel()
    >>> y, x = np.indices((61, 61))
    >>> disk = np.where(np.hypot(y - 30, x - 30) * 0.01 <= 0.15, 220.0, 150.0)
    >>> p = model.percept(disk, centre_px=(30, 30), diameter_deg=0.3, pixel_deg=0.01)
    >>> observer = Observer(gain=1.0, noise=ObserverNoise(setting_sd=0.0))
    >>> observer.settings(p, np.random.default_rng(0))
    (202.4, 237.6)
    """

    gain: float
    noise: ObserverNoise

    def __post_init__(self) -> None:
        check_in_range("gain", self.gain, 0.0, 100.0)

    def brightness(self, percept: Percept) -> float:
        """This observer's brightness, ``L_d + g (B - L_d)`` (cd/m²)."""
        return percept.disk_cd_m2 + self.gain * (percept.brightness_cd_m2 - percept.disk_cd_m2)

    def settings(self, percept: Percept, rng: np.random.Generator) -> tuple[float, float]:
        """The brightness (cd/m², as a glare-free disk) wanted for the "slightly darker" and
        "slightly brighter" targets: ``B_obs (1 ∓ m)(1 + σ_s z)``."""
        b, m, sd = self.brightness(percept), self.noise.margin, self.noise.setting_sd
        z = rng.standard_normal(2)
        return (
            float(b * (1 - m) * max(1 + sd * z[0], 0.0)),
            float(b * (1 + m) * max(1 + sd * z[1], 0.0)),
        )

    def answers(
        self, reference: Percept, target: Percept, rng: np.random.Generator
    ) -> tuple[bool, bool, bool]:
        """Yes/no to Yoshida's Table 1 questions: does the reference glow (Q1), is there a
        bright ring (Q2), are reference and target disks the same size (Q3)?"""
        n = self.noise
        z = rng.standard_normal(3)
        glow = reference.glow + n.glow_criterion_sd * z[0] > n.glow_criterion
        ring = reference.ring + n.ring_criterion_sd * z[1] > n.ring_criterion
        ratio = reference.apparent_diameter_deg / target.apparent_diameter_deg
        same = abs(math.log(ratio)) + n.size_tolerance_sd * z[2] < n.size_tolerance
        return bool(glow), bool(ring), bool(same)

    def compare(
        self,
        first: Percept,
        second: Percept,
        rng: np.random.Generator,
        *,
        shift: float = 0.0,
    ) -> Literal["first", "second", "neither"]:
        """Which of two images looks brighter: their relative difference
        ``2 (B_1 - B_2) / (B_1 + B_2) + shift + N(0, σ_c)``, "neither" within ``±b``.
        ``shift`` is the observer's bias for the current block (:meth:`ObserverNoise.block_shift`)
        in favour of ``first``."""
        a, b = self.brightness(first), self.brightness(second)
        difference = 2 * (a - b) / (a + b) if a + b > 0 else 0.0
        difference += shift + self.noise.comparison_sd * float(rng.standard_normal())
        if abs(difference) < self.noise.neither_band:
            return "neither"
        if difference > 0:
            return "first"
        return "second"


def observer_parameters(table: dict) -> tuple[BrightnessModel, ObserverNoise]:
    """The model and the noise from a protocol's ``[observer]`` table: any field of
    :class:`BrightnessModel` or :class:`ObserverNoise`; the others keep their fitted defaults.

    Raises
    ------
    ValueError
        For a key that is neither's field, or a value out of its range.

    Examples
    --------
    >>> model, noise = observer_parameters({"glow_gain": 0.3, "margin": 0.05})
    >>> model.glow_gain, noise.margin, noise.gain_sd == GAIN_SD
    (0.3, 0.05, True)
    """
    import dataclasses

    model_keys = {f.name for f in dataclasses.fields(BrightnessModel)}
    noise_keys = {f.name for f in dataclasses.fields(ObserverNoise)}
    unknown = sorted(set(table) - model_keys - noise_keys)
    if unknown:
        raise ValueError(
            f"observer: unknown key(s) {', '.join(unknown)} (known: "
            f"{', '.join(sorted(model_keys | noise_keys))})"
        )
    try:
        return (
            BrightnessModel(**{k: v for k, v in table.items() if k in model_keys}),
            ObserverNoise(**{k: v for k, v in table.items() if k in noise_keys}),
        )
    except TypeError as error:
        raise ValueError(f"observer: {error}") from None
