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
from dataclasses import dataclass

import numpy as np

from glarelab.glare._validation import (
    check_image,
    check_in_range,
    check_positive,
    check_positive_int,
)

__all__ = [
    "EDGE_MARGIN_DEG",
    "GLOW_BAND_DEG",
    "GLOW_GAIN",
    "GLOW_HALF",
    "GLOW_THRESHOLD",
    "PLATEAU_TOLERANCE",
    "RING_BAND_DEG",
    "SAMPLE_DEG",
    "SECTORS",
    "SIZE_EXPONENT",
    "SURROUND_QUANTILE",
    "BrightnessModel",
    "Percept",
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

        Parameters
        ----------
        disk_cd_m2
            The disk's luminance ``L_d``, cd/m².
        glow
            The glow's strength ``G`` (:class:`Percept`).
        diameter_ratio
            ``2 R_e / d``: the apparent over the nominal diameter; below 1 counts as 1.

        Returns
        -------
        float
            ``B``, cd/m² of a glare-free disk that looks as bright.

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
