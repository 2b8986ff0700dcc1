"""How simulated observers differ from each other and from trial to trial, and how they decide.

**Observers** (:class:`ObserverNoise`, :class:`Observer`): each has a gain ``g ~ N(1, σ_g)``
(clipped at 0) on the illusion, ``B_obs = L_d + g (B - L_d)``; sets the "slightly darker" and
"slightly brighter" targets to ``B_obs (1 ∓ m)(1 + σ_s z)``; answers the yes/no questions by
comparing a measure plus ``N(0, σ_q)`` with a criterion; and in a comparison of two images
reports the brighter one, or neither when their relative difference plus ``N(0, σ_c)`` (plus
the observer's shift for the current block, ``N(0, σ_b)``) is within ``±b``.

The decisions are written once, as functions of arrays (:func:`observer_gains`,
:func:`perceived_brightness`, :func:`target_settings`, :func:`relative_difference`,
:func:`comparison_answers`): :class:`Observer` applies them to one trial's draws, and the fit of
the observers' parameters (``scripts/fit_observers.py``) to thousands of simulated studies at
once, so that the parameters fitted are those of the observer that runs.

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

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from glarelab.files.values import check_generator
from glarelab.glare._validation import check_in_range
from glarelab.observers.brightness import BrightnessModel, Percept

__all__ = [
    "BLOCK_SD",
    "COMPARISON_SD",
    "GAIN_SD",
    "GLOW_CRITERION",
    "GLOW_CRITERION_SD",
    "MARGIN",
    "NEITHER_BAND",
    "RING_CRITERION",
    "RING_CRITERION_SD",
    "SETTING_SD",
    "SIZE_TOLERANCE",
    "SIZE_TOLERANCE_SD",
    "Observer",
    "ObserverNoise",
    "comparison_answers",
    "observer_gains",
    "observer_parameters",
    "perceived_brightness",
    "relative_difference",
    "target_settings",
]

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
BLOCK_SD = 0.05
"""``σ_b``: SD of an observer's shift between blocks run apart (Spencer's context blocks): the
smallest on a grid under which Spencer's non-significant context effect (§4.1) is at least as
likely as a significant one, in simulated studies of the Spencer protocol as it is shipped
(mesopic PSF, 50 cd/m² display; fitted; without it, 100 %; ``docs/observers.md``)."""


# --- the decisions, on arrays ------------------------------------------------------------


def observer_gains(z: ArrayLike, gain_sd: float) -> np.ndarray:
    """Observers' gains on the illusion, ``g = max(1 + σ_g z, 0)``, from standard normal draws
    ``z`` (``g ~ N(1, σ_g)`` clipped at 0).

    Parameters
    ----------
    z
        Standard normal draws, one per observer (dimensionless; any shape).
    gain_sd
        ``σ_g``, the between-observer SD of the gain (dimensionless, ≥ 0; the fitted value
        is :data:`GAIN_SD`).

    Returns
    -------
    numpy.ndarray
        The gains ``g`` (dimensionless, ≥ 0), of the shape of ``z``.

    Examples
    --------
    >>> observer_gains([-10.0, 0.0, 1.0], 0.2).tolist()
    [0.0, 1.0, 1.2]
    """
    return np.maximum(1.0 + gain_sd * np.asarray(z, dtype=float), 0.0)


def perceived_brightness(
    disk_cd_m2: ArrayLike, brightness_cd_m2: ArrayLike, gain: ArrayLike
) -> np.ndarray:
    """An observer's brightness ``B_obs = L_d + g (B - L_d)`` (cd/m²) of a disk of luminance
    ``L_d`` that the model sees as bright as ``B``, for a gain ``g`` (broadcast).

    Parameters
    ----------
    disk_cd_m2
        ``L_d``, the disk's own luminance as displayed (cd/m², ≥ 0).
    brightness_cd_m2
        ``B``, the model's brightness of the disk: the luminance of a glare-free disk that
        looks as bright (cd/m²).
    gain
        ``g``, the observer's gain on the illusion (dimensionless, ≥ 0; 1 is the model's
        observer, 0 sees no illusion).

    Returns
    -------
    numpy.ndarray
        ``B_obs`` (cd/m²), the three arguments broadcast together.

    Examples
    --------
    >>> float(perceived_brightness(220.0, 280.0, 0.5))
    250.0
    """
    disk = np.asarray(disk_cd_m2, dtype=float)
    return disk + np.asarray(gain, dtype=float) * (
        np.asarray(brightness_cd_m2, dtype=float) - disk
    )


def target_settings(
    perceived_cd_m2: ArrayLike, z: ArrayLike, *, margin: float, setting_sd: float
) -> np.ndarray:
    """The brightness wanted for the "slightly darker" and "slightly brighter" targets,
    ``B_obs (1 ∓ m) max(1 + σ_s z, 0)``: shape ``(..., 2)`` for ``perceived_cd_m2`` of shape
    ``(...)`` and standard normal draws ``z`` of shape ``(..., 2)``.

    Parameters
    ----------
    perceived_cd_m2
        ``B_obs``, the observer's brightness of the reference disk (cd/m², shape ``(...)``).
    z
        Standard normal draws, the darker target's and the brighter target's (shape
        ``(..., 2)``).
    margin
        ``m``, the "slightly but visibly" fraction (dimensionless, in [0, 0.5); the assumed
        value is :data:`MARGIN`).
    setting_sd
        ``σ_s``, the multiplicative SD of each setting (dimensionless, ≥ 0; the fitted value
        is :data:`SETTING_SD`).

    Returns
    -------
    numpy.ndarray
        The darker and the brighter target's brightness (cd/m², shape ``(..., 2)``).

    Examples
    --------
    >>> target_settings(250.0, [0.0, 0.0], margin=0.08, setting_sd=0.1).tolist()
    [230.0, 270.0]
    """
    factor = np.maximum(1.0 + setting_sd * np.asarray(z, dtype=float), 0.0)
    bounds = np.array([1.0 - margin, 1.0 + margin])
    return np.asarray(perceived_cd_m2, dtype=float)[..., None] * bounds * factor


def relative_difference(
    first_cd_m2: ArrayLike,
    second_cd_m2: ArrayLike,
    z: ArrayLike,
    *,
    comparison_sd: float,
    shift: ArrayLike = 0.0,
) -> np.ndarray:
    """The relative difference an observer sees between two images of (its) brightness
    ``B_1`` and ``B_2``: ``2 (B_1 - B_2) / (B_1 + B_2) + (shift + σ_c z)`` (0 before the noise
    when both are black), ``shift`` the observer's bias for the block in favour of the first.

    Parameters
    ----------
    first_cd_m2, second_cd_m2
        ``B_1``, ``B_2``: the observer's brightness of the first and the second image's disk
        (cd/m², ≥ 0; broadcast).
    z
        Standard normal draws of the comparison noise (dimensionless; broadcast).
    comparison_sd
        ``σ_c``, the SD of the relative difference seen (dimensionless, ≥ 0; the assumed
        value is :data:`COMPARISON_SD`).
    shift
        The observer's bias for the current block in favour of the first image (relative
        difference, dimensionless; 0: none; broadcast).

    Returns
    -------
    numpy.ndarray
        The relative difference seen (dimensionless; positive: the first looks brighter).

    Examples
    --------
    >>> float(relative_difference(110.0, 90.0, 0.0, comparison_sd=0.04))
    0.2
    """
    a = np.asarray(first_cd_m2, dtype=float)
    b = np.asarray(second_cd_m2, dtype=float)
    total = a + b
    seen = np.where(total > 0, 2 * (a - b) / np.where(total > 0, total, 1.0), 0.0)
    return seen + (np.asarray(shift, dtype=float) + comparison_sd * np.asarray(z, dtype=float))


def comparison_answers(difference: ArrayLike, neither_band: float) -> np.ndarray:
    """The answer to a comparison from the relative difference seen: 1 (the first looks
    brighter), -1 (the second), 0 (neither: within ``±b``).

    Parameters
    ----------
    difference
        The relative difference seen, as :func:`relative_difference` returns it
        (dimensionless; any shape).
    neither_band
        ``b``, the half-width of the band answered "neither" (relative difference,
        dimensionless, in [0, 1]; the assumed value is :data:`NEITHER_BAND`).

    Returns
    -------
    numpy.ndarray
        Integers 1, -1 or 0, of the shape of ``difference``.

    Examples
    --------
    >>> comparison_answers([0.1, -0.01, -0.1], 0.02).tolist()
    [1, 0, -1]
    """
    d = np.asarray(difference, dtype=float)
    return np.where(np.abs(d) < neither_band, 0, np.where(d > 0, 1, -1))


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
        """A new observer: the gain ``g ~ N(1, gain_sd)`` clipped at 0, drawn from ``rng``.

        Parameters
        ----------
        rng
            The generator to draw the gain from (:class:`numpy.random.Generator`).

        Returns
        -------
        Observer
            The observer, with this noise.

        Raises
        ------
        ValueError
            When ``rng`` is not a :class:`numpy.random.Generator`.
        """
        check_generator(rng)
        return Observer(
            gain=float(observer_gains(rng.standard_normal(), self.gain_sd)), noise=self
        )

    def block_shift(self, rng: np.random.Generator) -> float:
        """An observer's shift for one block of comparisons, ``N(0, block_sd)``; pass it to
        :meth:`Observer.compare` as ``shift``.

        Parameters
        ----------
        rng
            The generator to draw the shift from (:class:`numpy.random.Generator`).

        Returns
        -------
        float
            The shift (relative difference, dimensionless; 0 when ``block_sd`` is 0).

        Raises
        ------
        ValueError
            When ``rng`` is not a :class:`numpy.random.Generator`.
        """
        check_generator(rng)
        return float(rng.normal(0.0, self.block_sd)) if self.block_sd > 0 else 0.0


@dataclass(frozen=True)
class Observer:
    """One simulated observer: a gain on the illusion and the noise of :class:`ObserverNoise`.

    Every method that draws noise takes the generator to draw from, so a trial's answer is
    fixed by the generator the caller seeds for it.

    Parameters
    ----------
    gain
        ``g``, the observer's gain on the illusion (dimensionless, in [0, 100]; 1 is the
        model's observer), as :meth:`ObserverNoise.draw` draws it.
    noise
        The noise of its settings, answers and comparisons.

    Raises
    ------
    ValueError
        For a gain outside [0, 100].

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
        """This observer's brightness, ``L_d + g (B - L_d)`` (cd/m²).

        Parameters
        ----------
        percept
            What the model perceives of the disk in one image (its ``disk_cd_m2`` is ``L_d``,
            its ``brightness_cd_m2`` is ``B``).

        Returns
        -------
        float
            The observer's brightness of the disk (cd/m²).
        """
        return float(perceived_brightness(percept.disk_cd_m2, percept.brightness_cd_m2, self.gain))

    def settings(self, percept: Percept, rng: np.random.Generator) -> tuple[float, float]:
        """The brightness (cd/m², as a glare-free disk) wanted for the "slightly darker" and
        "slightly brighter" targets: ``B_obs (1 ∓ m)(1 + σ_s z)``.

        Parameters
        ----------
        percept
            What the model perceives of the reference disk.
        rng
            The generator to draw the two settings' noise from
            (:class:`numpy.random.Generator`).

        Returns
        -------
        tuple of float
            The darker and the brighter target's brightness (cd/m²).
        """
        darker, brighter = target_settings(
            self.brightness(percept),
            rng.standard_normal(2),
            margin=self.noise.margin,
            setting_sd=self.noise.setting_sd,
        )
        return float(darker), float(brighter)

    def answers(
        self, reference: Percept, target: Percept, rng: np.random.Generator
    ) -> tuple[bool, bool, bool]:
        """Yes/no to Yoshida's Table 1 questions: does the reference glow (Q1), is there a
        bright ring (Q2), are reference and target disks the same size (Q3)?

        Parameters
        ----------
        reference
            What the model perceives of the reference image's disk (its ``glow`` for Q1, its
            ``ring`` for Q2, its ``apparent_diameter_deg`` for Q3).
        target
            What it perceives of the target image's disk (its ``apparent_diameter_deg``, deg,
            > 0, for Q3).
        rng
            The generator to draw the three criteria's noise from
            (:class:`numpy.random.Generator`).

        Returns
        -------
        tuple of bool
            The answers to Q1, Q2 and Q3 (True: yes).
        """
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
        in favour of ``first``.

        Parameters
        ----------
        first, second
            What the model perceives of the first and the second image's disk.
        rng
            The generator to draw the comparison noise from (:class:`numpy.random.Generator`).
        shift
            The observer's bias for the current block in favour of ``first`` (relative
            difference, dimensionless; 0: none).

        Returns
        -------
        {"first", "second", "neither"}
            The image that looks brighter, or "neither".
        """
        difference = relative_difference(
            self.brightness(first),
            self.brightness(second),
            float(rng.standard_normal()),
            comparison_sd=self.noise.comparison_sd,
            shift=shift,
        )
        answer = int(comparison_answers(difference, self.noise.neither_band))
        return {1: "first", -1: "second", 0: "neither"}[answer]


def observer_parameters(
    table: dict, *, source: str = "<protocol>"
) -> tuple[BrightnessModel, ObserverNoise]:
    """The model and the noise from a protocol's ``[observer]`` table: any field of
    :class:`BrightnessModel` or :class:`ObserverNoise`; the others keep their fitted defaults.

    Parameters
    ----------
    table
        The protocol's ``[observer]`` table: field names of either class to their values
        (each within that field's range; empty: every default).
    source
        Where the table comes from (the protocol's file), the start of every message; default
        ``'<protocol>'``.

    Returns
    -------
    tuple of BrightnessModel and ObserverNoise
        The brightness model and the observers' noise.

    Raises
    ------
    ValueError
        For a key that is neither's field, or a value out of its range: ``SOURCE:
        observer.KEY ...``, with the value and what is allowed.

    Examples
    --------
    >>> model, noise = observer_parameters({"glow_gain": 0.3, "margin": 0.05})
    >>> model.glow_gain, noise.margin, noise.gain_sd == GAIN_SD
    (0.3, 0.05, True)
    >>> observer_parameters({"glow_gain": -1}, source="lab.toml")
    Traceback (most recent call last):
    ...
    ValueError: lab.toml: observer.glow_gain must be in [0, 10], got -1
    """
    if not isinstance(table, dict):
        raise TypeError(f"{source}: observer must be a table of keys; got {table!r}")
    model_keys = {f.name for f in dataclasses.fields(BrightnessModel)}
    noise_keys = {f.name for f in dataclasses.fields(ObserverNoise)}
    unknown = sorted(set(table) - model_keys - noise_keys)
    if unknown:
        raise ValueError(
            f"{source}: observer: unknown key(s) {', '.join(unknown)} (known: "
            f"{', '.join(sorted(model_keys | noise_keys))})"
        )
    try:
        return (
            BrightnessModel(**{k: v for k, v in table.items() if k in model_keys}),
            ObserverNoise(**{k: v for k, v in table.items() if k in noise_keys}),
        )
    except (TypeError, ValueError) as error:
        problem = f"{source}: observer: {error}"  # keys that do not go together
    for key, value in table.items():  # the key that is wrong by itself, named
        try:
            (BrightnessModel if key in model_keys else ObserverNoise)(**{key: value})
        except (TypeError, ValueError) as error:
            text = str(error)
            if text.startswith(f"{key} "):
                problem = f"{source}: observer.{text}"
            else:
                problem = f"{source}: observer.{key} = {value!r}: {text}"
            break
    raise ValueError(problem)
