"""The Vos (1984) eye PSF as Spencer et al. (1995) use it, with halo, regimes, age and flare
lines: :class:`VosGlare`. The PSF's components and weights are in
:mod:`glarelab.glare.models.vos`."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Literal

import numpy as np

from glarelab.glare._validation import (
    check_choice,
    check_flag,
    check_in_range,
    check_pixel_deg,
    check_positive,
    check_positive_int,
)
from glarelab.glare.models import vos
from glarelab.glare.models._radial import radial_mass, rectangle_mass
from glarelab.glare.models.base import GlareModel, TailBound
from glarelab.glare.models.digitise import (
    Kernel,
    check_kernel_shape,
    digitise_radial_quadrant,
    gaussian_pixel_energies,
    mirror_quadrant,
    quadrant_sum,
)
from glarelab.glare.models.eye import HALO_PUPIL_MM, Regime, regime
from glarelab.glare.models.flare import (
    CORONA_LINES,
    HALO_LINES,
    MAX_FLARE_LINES,
    flare_line_pattern,
)
from glarelab.glare.models.spectral import HALO_TABLE_MAX_DEG, HaloSpectrum, halo_profiles

__all__ = [
    "HALO_MAX_SPACING_DEG",
    "HALO_OPTIONS",
    "NORMALISATIONS",
    "PUPIL_RANGE_MM",
    "SPENCER_MIN_HALO_HELD",
    "TAIL_MARGIN",
    "VosGlare",
]

NORMALISATIONS = ("psf", "Spencer1995")  # Spencer 1995 §3.2: "renormalize the filter"

PUPIL_RANGE_MM = (0.5, 10.0)  # accepted pupil diameters; the eye spans about 2-8 mm
# Sample spacing in the halo ring (σ = 0.159°): σ/16. At σ/4 the 0.03°/px night scene was
# 0.99 display codes (2e-4 relative) off near the black of a 10-bit display; at σ/16, 0.16.
# samples a pixel side of the halo's midpoint rule at most: 2000² is the 4e6 samples the
# digitiser evaluates at once (about 100 MB); more, and a coarse pixel would take gigabytes
MAX_HALO_SAMPLES = 2000
HALO_MAX_SPACING_DEG = 0.01
TAIL_MARGIN = 1.02  # the peak beyond a radius is found on a grid; 2 % covers the ring's crest
# glarelab's, not the paper's: Spencer's renormalisation (§3.2) divides each halo filter by the
# share of the halo the kernel holds; under 1 % it would multiply a sliver of the ring (or the
# 1e-39 tail of a colour channel's halo) into the whole halo, so such a kernel is refused
SPENCER_MIN_HALO_HELD = 0.01
# VosGlare's options that shape only the lenticular halo: refused where there is none (the
# photopic PSF, a pupil under 3 mm), and reset by the night pipeline when a frame leaves none
HALO_OPTIONS = ("wavelength_nm", "halo_spectrum", "halo_spacing_deg", "halo_lines")


@dataclass(frozen=True)
class VosGlare(GlareModel):
    """Vos (1984) eye PSF with Spencer et al.'s (1995) halo, regimes, age and flare lines.

    Parameters
    ----------
    regime
        ``'photopic'`` (eq. 5), ``'mesopic'`` (eq. 8) or ``'scotopic'`` (eq. 9).
    age
        Observer's age in years for eq. 10, or ``None`` for the standard observer.
    flare_lines
        Multiply seeded random radial streaks into the corona and the halo (§3.2).
    seed
        Seed of the flare lines (``numpy.random.default_rng``); the corona and the halo get
        independent child streams. A seed other than 0 without ``flare_lines`` is refused (it
        would act on nothing).
    wavelength_nm
        ``None`` (default): the halo of a white source, integrated over 400-700 nm.
        A number: a monochromatic halo at that wavelength (380-780 nm); refused in the
        photopic regime, which has no halo, and beside a ``halo_spectrum`` (one of them
        would be ignored), and behind a pupil under 3 mm, which drops the halo it colours.
    halo_spectrum
        Wavelength sampling and display primaries of the coloured halo.
    samples_per_pixel, center_samples_per_pixel, center_radius_px
        Kernel integration (see :func:`glarelab.glare.models.digitise.digitise_radial`); defaults
        10, 100 (Spencer's 10,000 samples per central pixel), 4 px.
    halo_spacing_deg
        Largest sample spacing in the halo ring, degrees; default 0.01 (a sixteenth of the
        ring's σ).
    corona_lines, halo_lines
        Number of flare lines in the corona and the halo; defaults 150 and 300.
    pupil_mm
        Pupil diameter in mm (0.5-10), or ``None`` (default): the pupil the regime implies.
        Below 3 mm the lenticular halo is dropped and its weight returned to ``f0``: a beam
        narrower than 3 mm passes the clear centre of the lens (Spencer §2.1), and eq. 8's
        halo weight is "diverted from the central peak" (§3.1.1). The photopic PSF has no
        halo, so there the pupil would change nothing and is refused; :meth:`with_eye_state`
        (the state the night pipeline and the live mode give every frame's model) leaves it
        unset there.
    normalisation
        ``'psf'`` (default): each component holds the PSF's energy inside the kernel, and the
        energy beyond it is reported as ``energy_outside`` (not spread). ``'Spencer1995'``:
        as Spencer §3.2 does, "calculate each filter proportional to a given function, and
        then renormalize the filter so that all pixels sum to one": each of ``f0``-``f3``
        sums to 1 over the kernel, so the light the PSF sends beyond the kernel is put back
        inside it, in proportion (``energy_outside`` 0). A kernel that holds under 1 % of a
        channel's halo (:data:`SPENCER_MIN_HALO_HELD`) is refused: its filter would multiply
        a sliver of the ring into the whole halo.

    Notes
    -----
    The kernel is ``w0 K0 + (w1 K1 + w2 K2) S_c + w3 K3 S_h`` with ``K_i`` the digitised
    unit-volume components, weights from :func:`glarelab.glare.models.vos.weights` and ``S`` the
    flare-line patterns (1 without flare lines). ``K0`` uses exact pixel integrals of the Gaussian,
    which becomes Spencer's delta function when a pixel is much wider than 0.02°.

    References
    ----------
    Spencer et al. 1995, §3.1-3.2, eqs. 4-10; Vos 1984; Yoshida et al. 2008, eqs. 3-6.

    Examples
    --------
    >>> k = VosGlare().kernel(0.05, (61, 61))
    >>> round(float(k.values.sum() + k.energy_outside), 9)
    1.0
    """

    regime: Regime = "photopic"
    age: float | None = None
    flare_lines: bool = False
    seed: int = 0
    wavelength_nm: float | None = None
    halo_spectrum: HaloSpectrum = field(default_factory=HaloSpectrum)
    samples_per_pixel: int = 10
    center_samples_per_pixel: int = 100
    center_radius_px: float = 4.0
    halo_spacing_deg: float = HALO_MAX_SPACING_DEG
    corona_lines: int = CORONA_LINES
    halo_lines: int = HALO_LINES
    pupil_mm: float | None = None
    normalisation: Literal["psf", "Spencer1995"] = "psf"

    def __post_init__(self) -> None:
        vos.weights(self.regime, self.age)  # validates regime and age
        check_flag("flare_lines", self.flare_lines)
        check_choice("normalisation", self.normalisation, NORMALISATIONS)
        if self.pupil_mm is not None:
            check_in_range("pupil_mm", self.pupil_mm, *PUPIL_RANGE_MM, unit="mm")
        if not isinstance(self.halo_spectrum, HaloSpectrum):  # a protocol's halo_spectrum = 3
            raise ValueError(
                f"halo_spectrum must be a HaloSpectrum (a protocol's table of its keys); got "
                f"{self.halo_spectrum!r:.80}"
            )
        if self.wavelength_nm is not None:
            vos.f3(0.0, self.wavelength_nm)  # validates the wavelength
            if np.ndim(self.wavelength_nm) != 0:  # f3 takes arrays; a model's halo has one
                raise ValueError(
                    f"wavelength_nm must be one number (380-780 nm) or None; got "
                    f"{self.wavelength_nm!r:.80}"
                )
            if self.halo_spectrum != HaloSpectrum():  # one of the two would be ignored
                raise ValueError(
                    f"wavelength_nm={self.wavelength_nm!r} with halo_spectrum="
                    f"{self.halo_spectrum!r}: a monochromatic halo uses no spectrum; give one "
                    "of them"
                )
        check_positive_int("seed", self.seed, minimum=0)
        if self.seed != 0 and not self.flare_lines:  # as the command line's --seed alone
            raise ValueError(
                f"seed={self.seed!r} without flare_lines=True: the seed places Spencer's flare "
                "lines, and without them it would be ignored; give flare_lines=True or leave "
                "seed at 0"
            )
        for name in ("samples_per_pixel", "center_samples_per_pixel"):
            check_positive_int(name, getattr(self, name))
            if getattr(self, name) > MAX_HALO_SAMPLES:  # the digitiser's samples at once
                raise ValueError(
                    f"{name} must be at most {MAX_HALO_SAMPLES} ({MAX_HALO_SAMPLES}² samples a "
                    f"pixel, about 100 MB at once); got {getattr(self, name)!r}"
                )
        check_positive("center_radius_px", self.center_radius_px, unit="px")
        check_positive("halo_spacing_deg", self.halo_spacing_deg, unit="deg")
        check_positive_int("corona_lines", self.corona_lines)
        check_positive_int("halo_lines", self.halo_lines)
        for name in ("corona_lines", "halo_lines"):  # as flare_line_pattern, when it is made
            if getattr(self, name) > MAX_FLARE_LINES:
                raise ValueError(
                    f"{name} must be at most {MAX_FLARE_LINES:,} (so many lines are a smooth "
                    f"ring already); got {getattr(self, name):,}"
                )
        if not self.flare_lines:  # as the seed: the lines' counts shape only the lines
            for name, default in (("corona_lines", CORONA_LINES), ("halo_lines", HALO_LINES)):
                if getattr(self, name) != default:
                    raise ValueError(
                        f"{name}={getattr(self, name)!r} without flare_lines=True: it counts "
                        f"Spencer's flare lines, and without them it would be ignored; give "
                        f"flare_lines=True or leave {name} at {default}"
                    )
        if self.weights[3] == 0.0:  # no halo: what shapes only the halo would be ignored
            why = (
                f"the pupil of {self.pupil_mm:g} mm drops the lenticular halo (under 3 mm, "
                "Spencer §2.1)"
                if self.halo_skipped
                else f"the {self.regime} PSF (eq. 5) has no lenticular halo"
            )
            for name in HALO_OPTIONS:
                value, unset = getattr(self, name), _field_default(name)
                if value != unset:
                    raise ValueError(
                        f"{name}={value!r}: it shapes only the halo, and {why}, so it would be "
                        f"ignored; leave it at its default ({unset!r}) or give a pupil and "
                        "regime with a halo"
                    )
        if self.pupil_mm is not None and vos.WEIGHTS[self.regime][3] == 0.0:
            raise ValueError(
                f"pupil_mm={self.pupil_mm!r} with regime={self.regime!r}: the pupil drops the "
                "lenticular halo when under 3 mm (Spencer §2.1), and the photopic PSF (eq. 5) "
                "has none, so it would be ignored; leave pupil_mm None or give regime "
                "'mesopic' or 'scotopic'"
            )

    def with_eye_state(self, **state) -> VosGlare:
        """This model with another eye state (``pupil_mm``, ``regime``); where that state
        leaves no lenticular halo (a pupil under 3 mm, the photopic regime), the options that
        shape only the halo (:data:`HALO_OPTIONS`) return to their defaults, and in the
        photopic regime, whose PSF has no halo for a pupil to drop, the pupil is left unset,
        as the state a night pipeline or a live session gives each frame is no choice of the
        user's.

        Parameters
        ----------
        state
            Fields to replace, ``pupil_mm`` and ``regime`` among them.

        Returns
        -------
        VosGlare
            The model of that eye.

        Examples
        --------
        >>> m = VosGlare(regime="mesopic", wavelength_nm=550.0)
        >>> m.with_eye_state(pupil_mm=2.0).wavelength_nm is None
        True
        >>> m.with_eye_state(pupil_mm=5.0).wavelength_nm
        550.0
        >>> print(m.with_eye_state(pupil_mm=5.0, regime="photopic").pupil_mm)
        None
        """
        unset = {name: _field_default(name) for name in HALO_OPTIONS}
        eye_regime = state.get("regime", self.regime)  # an unknown one is refused when made
        if isinstance(eye_regime, str) and vos.WEIGHTS.get(eye_regime, (1.0,) * 4)[3] == 0.0:
            state = {**state, "pupil_mm": None}  # no halo for the pupil to drop
        if dataclasses.replace(self, **{**unset, **state}).weights[3] == 0.0:
            state = {**state, **unset}
        return dataclasses.replace(self, **state)

    @classmethod
    def from_field_luminance(cls, field_luminance_cd_m2: float, **options) -> VosGlare:
        """The model for an observer adapted to a field luminance (Spencer §3.1, §3.1.1).

        Parameters
        ----------
        field_luminance_cd_m2
            The luminance the observer is adapted to, cd/m² (Spencer §3.1: photopic above 3,
            scotopic below 0.01, mesopic between).
        options
            The model's other parameters (``age``, ``pupil_mm``, ``flare_lines``, ...).

        Returns
        -------
        VosGlare
            The model with the regime of that luminance.

        Examples
        --------
        >>> VosGlare.from_field_luminance(0.5).regime
        'mesopic'
        """
        return cls(regime=regime(field_luminance_cd_m2), **options)

    @property
    def halo_skipped(self) -> bool:
        """True when a pupil under 3 mm removes the lenticular halo (Spencer §2.1)."""
        return self.pupil_mm is not None and self.pupil_mm < HALO_PUPIL_MM

    @property
    def weights(self) -> tuple[float, float, float, float]:
        """``(w0, w1, w2, w3)`` of eqs. 5, 8-10, with the halo's weight moved to ``f0`` when
        :attr:`halo_skipped`."""
        w0, w1, w2, w3 = vos.weights(self.regime, self.age, warn=False)  # warned when made
        if self.halo_skipped:
            return (w0 + w3, w1, w2, 0.0)
        return (w0, w1, w2, w3)

    @property
    def achromatic(self) -> bool:
        """True without a lenticular halo: only the halo differs between channels."""
        return self.weights[3] == 0.0

    def halo(self) -> str:
        if self.halo_skipped:
            return f"skipped: pupil {self.pupil_mm:g} mm < 3 mm (Spencer §2.1)"
        if self.weights[3] == 0.0:
            return f"none in this model ({self.regime} weights, Spencer eq. 5)"
        return "included"

    def _profile(self, halo) -> Callable[[np.ndarray], np.ndarray]:
        """``P(θ) = w0 f0 + w1 f1 + w2 f2 + w3 halo(θ)`` with this model's weights; the halo
        term is left out when the model has none."""
        w0, w1, w2, w3 = self.weights

        def profile(theta: np.ndarray) -> np.ndarray:
            values = w0 * vos.f0(theta) + w1 * vos.f1(theta) + w2 * vos.f2(theta)
            return values + w3 * halo(theta) if w3 else values

        return profile

    def psf(self, theta_deg: float | np.ndarray) -> float | np.ndarray:
        """The continuous PSF (per steradian) at the halo wavelength (568 nm if white).

        Parameters
        ----------
        theta_deg
            Angle from the source, degrees, a number or an array.

        Returns
        -------
        float or numpy.ndarray
            The PSF, per steradian, the shape of ``theta_deg``.
        """
        wavelength = vos.HALO_REFERENCE_NM if self.wavelength_nm is None else self.wavelength_nm
        values = self._profile(lambda t: vos.f3(t, wavelength))(np.asarray(theta_deg, float))
        return float(values) if np.ndim(theta_deg) == 0 else values

    def tail_bound(
        self, pixel_deg: float, radius_px: np.ndarray, *, colour: bool = False
    ) -> TailBound | None:
        """What a kernel cut to a centred square of half-size ``radius_px`` leaves out.

        A pixel outside the square lies beyond ``θ = (r + ½) Δ``; its energy is at most the
        PSF's largest value beyond that angle times the pixel's area (the measure of eq. 4
        has ``sin θ ≤ θ``), and the energy outside the square at most that outside the disc
        of radius ``θ``. Every channel's halo profile is bounded separately. ``None`` with
        flare lines, whose streaks are not bounded by the smooth PSF, and with Spencer's
        renormalisation, which scales the kernel by a factor that depends on its shape.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        radius_px
            Half-sizes of the centred squares the kernel is cut to, whole pixels (a square spans
            ``2 r + 1`` pixels a side).
        colour
            Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.

        Returns
        -------
        TailBound or None
            For each radius, the largest kernel pixel outside the square and the energy outside
            (fractions of the source's energy); ``None`` where no bound is known.
        """
        if self.flare_lines or self.normalisation != "psf":
            return None
        pixel_deg = check_pixel_deg(pixel_deg)
        radius = np.asarray(radius_px, dtype=float)
        theta = (radius + 0.5) * pixel_deg
        halos = [None]
        if self.weights[3] > 0:
            halos = halo_profiles(
                "RGB" if colour else "Y", self.halo_spectrum, wavelength_nm=self.wavelength_nm
            )
        grid = np.unique(
            np.concatenate(
                [theta, np.linspace(0.0, HALO_TABLE_MAX_DEG, 1601), np.geomspace(1e-4, 180, 4000)]
            )
        )
        grid = grid[grid >= theta.min()]
        peak = np.zeros_like(theta)
        energy = np.zeros_like(theta)
        for halo in halos:
            profile = self._profile(halo)
            running_max = np.maximum.accumulate(profile(grid)[::-1])[::-1]
            peak = np.maximum(peak, running_max[np.searchsorted(grid, theta)])
            # the whole hemisphere and each radius's disc: one integration of the profile
            angles = np.concatenate([[90.0], theta])
            masses = radial_mass(profile, angles, breakpoints=(2.0, 3.0, 4.0))
            total, inside = masses[0], masses[1:]
            energy = np.maximum(energy, 1.0 - inside / total)
        pixel_sr = math.radians(pixel_deg) ** 2
        return TailBound(
            peak=TAIL_MARGIN * peak * pixel_sr,
            energy=np.clip(TAIL_MARGIN * energy, 0.0, 1.0),
        )

    def _digitise_settings(self, pixel_deg: float, shape: tuple[int, int]) -> dict:
        return {
            "pixel_deg": pixel_deg,
            "shape": shape,
            "samples_per_pixel": self.samples_per_pixel,
            "center_samples_per_pixel": self.center_samples_per_pixel,
            "center_radius_px": self.center_radius_px,
        }

    def _quadrant_parts(
        self, pixel_deg: float, shape: tuple[int, int], *, colour: bool, symmetric: bool = True
    ) -> dict:
        """The smooth parts of the PSF (no flare lines) as quadrants ``i, j >= 0``: each is
        symmetric in both axes, so the kernel is unfolded once, after they are added."""
        pixel_deg = check_pixel_deg(pixel_deg)
        shape = check_kernel_shape(shape)
        w0, w1, w2, w3 = self.weights
        settings = self._digitise_settings(pixel_deg, shape)

        # f0: exact, separable (Spencer: a delta when narrower than a pixel)
        gy = gaussian_pixel_energies(vos.F0_WIDTH_DEG, pixel_deg, shape[0] // 2)
        gx = gaussian_pixel_energies(vos.F0_WIDTH_DEG, pixel_deg, shape[1] // 2)
        core = np.outer(gy, gx)

        # f1, f2: the corona, one sampling pass for both
        (k1, k2), inside, total, error = digitise_radial_quadrant(
            [vos.f1, vos.f2], **settings, symmetric=symmetric
        )
        spencer = self.normalisation == "Spencer1995"
        if spencer:  # Spencer §3.2: every filter renormalised to sum to one over the kernel
            core = core / quadrant_sum(core)
            total = inside
        scatter = k1
        scatter *= w1 / total[0]
        scatter += (w2 / total[1]) * k2
        del k1, k2
        scatter_outside = w1 * (1 - inside[0] / total[0]) + w2 * (1 - inside[1] / total[1])
        # each part's quadrature error, weighted by the energy it holds inside the support
        held = (w1 * inside[0] / total[0], w2 * inside[1] / total[1])
        errors = [(held[0], abs(float(error[0]))), (held[1], abs(float(error[1])))]

        n_channels = 3 if colour else 1
        halo = None
        halo_outside = np.zeros(n_channels)
        if w3 > 0:
            self._check_halo_samples(pixel_deg)
            channels = "RGB" if colour else "Y"
            profiles = halo_profiles(
                channels, self.halo_spectrum, wavelength_nm=self.wavelength_nm
            )
            pieces, inside, total, error = digitise_radial_quadrant(
                profiles,
                **settings,
                max_spacing_deg=self.halo_spacing_deg,
                breakpoints=(2.0, 3.0, 4.0),
                support_deg=HALO_TABLE_MAX_DEG,
                symmetric=symmetric,
            )
            if spencer:
                held = inside / total
                if (held < SPENCER_MIN_HALO_HELD).any():
                    raise ValueError(self._unreached_halo(pixel_deg, shape, profiles, held))
                total = inside
            halo = w3 * pieces / total[:, None, None]
            halo_outside = w3 * (1 - inside / total)
            errors += [
                (w3 * i / t, abs(float(e))) for i, t, e in zip(inside, total, error, strict=True)
            ]
        return {
            "weights": (w0, w1, w2, w3),
            "core": core,
            "core_outside": 1.0 - float(quadrant_sum(core)),
            "scatter": scatter,
            "scatter_outside": scatter_outside,
            "halo": halo,
            "halo_outside": halo_outside,
            "errors": errors,
        }

    def check_kernel(
        self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False
    ) -> None:
        """Refuse a kernel Spencer's renormalisation cannot make (:data:`SPENCER_MIN_HALO_HELD`).

        The share of each channel's halo the kernel holds is its energy in the kernel's
        rectangle (:func:`~glarelab.glare.models._radial.rectangle_mass`), a second's work
        where digitising the halo takes longer; a share within 1 % of the threshold is left
        to :meth:`kernel`, which measures it on the digitised pixels.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether the colour kernel would be made; default False.

        Raises
        ------
        ValueError
            If the halo would take more than 2000² samples a pixel
            (``MAX_HALO_SAMPLES``), or the kernel holds under 1 % of a channel's halo under
            ``normalisation='Spencer1995'``.
        """
        pixel_deg = check_pixel_deg(pixel_deg)
        shape = check_kernel_shape(shape)
        if self.weights[3] > 0:
            self._check_halo_samples(pixel_deg)
        if self.normalisation != "Spencer1995" or self.weights[3] == 0:
            return
        profiles = halo_profiles(
            "RGB" if colour else "Y", self.halo_spectrum, wavelength_nm=self.wavelength_nm
        )
        half_h, half_w = (shape[0] * pixel_deg / 2, shape[1] * pixel_deg / 2)
        held = np.array(
            [
                rectangle_mass(profile, half_w, half_h, breakpoints=(2.0, 3.0, 4.0))
                / radial_mass(profile, np.array([180.0]))[0]
                for profile in profiles
            ]
        )
        if (held < 0.99 * SPENCER_MIN_HALO_HELD).any():
            raise ValueError(self._unreached_halo(pixel_deg, shape, profiles, held))

    def _check_halo_samples(self, pixel_deg: float) -> None:
        """Refuse pixels that would take the halo's sampling over :data:`MAX_HALO_SAMPLES`."""
        if math.ceil(pixel_deg / self.halo_spacing_deg) > MAX_HALO_SAMPLES:
            raise ValueError(
                f"pixel_deg must be at most {MAX_HALO_SAMPLES * self.halo_spacing_deg:g} deg "
                f"for the {self.regime} halo sampled every halo_spacing_deg = "
                f"{self.halo_spacing_deg:g} deg ({MAX_HALO_SAMPLES}² samples a pixel); got "
                f"{pixel_deg:g} (give a larger halo_spacing_deg)"
            )

    def _unreached_halo(self, pixel_deg, shape, profiles, held) -> str:
        """Why Spencer's renormalisation cannot hold: a channel's halo lies beyond the kernel."""
        names = "RGB" if len(profiles) == 3 else "Y"
        short = ", ".join(
            f"{names[i]} {100 * held[i]:.2g} %"
            for i in np.flatnonzero(held < SPENCER_MIN_HALO_HELD)
        )
        totals = [radial_mass(profile, np.array([180.0]))[0] for profile in profiles]

        def holds(side_px: int) -> bool:  # a square kernel of that side holds every halo
            half = side_px * pixel_deg / 2
            return all(
                rectangle_mass(profile, half, half, breakpoints=(2.0, 3.0, 4.0)) / total
                >= SPENCER_MIN_HALO_HELD
                for profile, total in zip(profiles, totals, strict=True)
            )

        # the least odd square side that holds the share (by bisection: the share grows with
        # the side), from the disc of the halo table's reach, which holds it whole
        low, high = 0, math.ceil(HALO_TABLE_MAX_DEG / pixel_deg)  # sides 2 k + 1
        while low < high:
            middle = (low + high) // 2
            low, high = (low, middle) if holds(2 * middle + 1) else (middle + 1, high)
        across = 2 * low + 1
        return (
            f"normalisation='Spencer1995' renormalises each filter to sum to one over the "
            f"kernel (Spencer 1995 §3.2), but a {shape[0]} × {shape[1]} px kernel at "
            f"pixel_deg={pixel_deg:g} holds under {100 * SPENCER_MIN_HALO_HELD:g} % of the "
            f"{self.regime} halo of a channel ({short}), which it would multiply by more than "
            f"{1 / SPENCER_MIN_HALO_HELD:g}: give a kernel at least {across} px across (a "
            f"stimulus set's kernel spans twice its image: an image or window of at least "
            f"{(across + 1) // 2} px), or normalisation='psf'"
        )

    def parts(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> dict:
        """The digitised parts of the PSF, each with its energy outside the support.

        Returns a dict with ``weights`` ``(w0, w1, w2, w3)``; ``core`` (``f0``, unit volume,
        ``(KH, KW)``) and ``core_outside``; ``scatter`` (``w1 f1 + w2 f2``, flare lines
        applied, ``(KH, KW)``) and ``scatter_outside``; ``halo`` (``w3 f3``, ``(C, KH, KW)``)
        and ``halo_outside`` ``(C,)``; and ``errors``, ``(energy, quadrature error)`` pairs.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.
        """
        p = self._quadrant_parts(pixel_deg, shape, colour=colour)
        shape = check_kernel_shape(shape)
        scatter = mirror_quadrant(p["scatter"])
        rng_corona, rng_halo = np.random.default_rng(self.seed).spawn(2)
        if self.flare_lines:
            scatter = _streak(scatter, rng_corona, self.corona_lines)
        if p["halo"] is None:
            halo = np.zeros((len(p["halo_outside"]), *shape))
        else:
            halo = np.stack([mirror_quadrant(h) for h in p["halo"]])
            if self.flare_lines:
                pattern = flare_line_pattern(shape, rng=rng_halo, n_lines=self.halo_lines)
                halo = np.stack([_rescaled(h, h * pattern) for h in halo])
        return {**p, "core": mirror_quadrant(p["core"]), "scatter": scatter, "halo": halo}

    def description(self, colour: bool) -> dict:
        """The model's name and parameters, for logs.

        Parameters
        ----------
        colour
            Whether the kernel described is the colour one (recorded as ``colour``).

        Returns
        -------
        dict
            ``model`` (the class's name), the model's parameters and ``colour``. The halo
            spectrum is given as a dict.
        """
        return {
            "model": type(self).__name__,
            **{k: v for k, v in asdict(self).items() if k != "halo_spectrum"},
            "halo_spectrum": asdict(self.halo_spectrum),
            "weights": self.weights,
            "colour": colour,
        }

    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        """Digitise the PSF into an odd ``shape`` for pixels of ``pixel_deg`` degrees.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``.
        colour
            ``False``: a luminance kernel ``(KH, KW)``. ``True``: ``(KH, KW, 3)`` in the linear
            RGB of ``halo_spectrum.colourspace``; only the halo differs between channels.
        """
        return self._kernel(pixel_deg, shape, colour=colour)

    def _kernel(
        self, pixel_deg: float, shape: tuple[int, int], *, colour: bool, symmetric: bool = True
    ) -> Kernel:
        if self.flare_lines:  # the streaks break the symmetry: the parts are unfolded first
            p = self.parts(pixel_deg, shape, colour=colour)
            w0 = p["weights"][0]
            return _combine(
                w0 * p["core"],
                w0 * p["core_outside"],
                p,
                pixel_deg=pixel_deg,
                colour=colour,
                description=self.description(colour),
            )
        p = self._quadrant_parts(pixel_deg, shape, colour=colour, symmetric=symmetric)
        w0 = p["weights"][0]
        quadrant = p["scatter"]
        quadrant += w0 * p["core"]
        if p["halo"] is not None:
            quadrant = quadrant[None] + p["halo"]  # (C, h, w)
            quadrant = np.moveaxis(quadrant, 0, -1) if colour else quadrant[0]
        elif colour:
            quadrant = np.repeat(quadrant[..., None], 3, axis=-1)
        energy_outside = w0 * p["core_outside"] + p["scatter_outside"] + p["halo_outside"]
        errors = p["errors"]
        return Kernel(
            quadrant=np.ascontiguousarray(quadrant),
            pixel_deg=pixel_deg,
            energy_outside=float(energy_outside[0]) if not colour else energy_outside.copy(),
            quadrature_error=sum(w * e for w, e in errors) / sum(w for w, _ in errors),
            description=self.description(colour),
        )


def _combine(
    core: np.ndarray,
    core_outside: float | np.ndarray,
    parts: dict,
    *,
    pixel_deg: float,
    colour: bool,
    description: dict,
) -> Kernel:
    """A kernel from a weighted core ``(KH, KW)`` or ``(C, KH, KW)`` and the Vos scattering
    and halo parts of :meth:`VosGlare.parts`."""
    values = core + parts["scatter"] + parts["halo"]  # (C, KH, KW)
    energy_outside = core_outside + parts["scatter_outside"] + parts["halo_outside"]
    errors = parts["errors"]
    return Kernel(
        values=values[0] if not colour else np.moveaxis(values, 0, -1),
        pixel_deg=pixel_deg,
        energy_outside=float(np.asarray(energy_outside).reshape(-1)[0])
        if not colour
        else np.broadcast_to(energy_outside, (3,)).copy(),
        quadrature_error=sum(w * e for w, e in errors) / sum(w for w, _ in errors),
        description=description,
    )


def _rescaled(smooth: np.ndarray, streaked: np.ndarray) -> np.ndarray:
    """``streaked`` scaled to the energy of ``smooth``: the ring normalisation of the flare
    lines keeps it to within a percent; this makes the energy account exact."""
    total = streaked.sum()
    return streaked * (smooth.sum() / total) if total > 0 else smooth


def _streak(corona: np.ndarray, rng: np.random.Generator, n_lines: int) -> np.ndarray:
    pattern = flare_line_pattern(corona.shape, rng=rng, n_lines=n_lines)
    return _rescaled(corona, corona * pattern)


def _field_default(name: str):
    """The default of :class:`VosGlare`'s field ``name``."""
    spec = VosGlare.__dataclass_fields__[name]
    return spec.default_factory() if callable(spec.default_factory) else spec.default
