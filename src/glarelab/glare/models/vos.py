"""The Vos (1984) point-spread function of the eye, as extended by Spencer et al. (1995).

The PSF is a weighted sum of four unit-volume components of the angle θ (degrees) from the
source: a narrow Gaussian ``f0`` (unscattered light), ``f1`` ∝ θ⁻³ and ``f2`` ∝ θ⁻² (scattering
in cornea, lens and retina: the ciliary corona and bloom), and the lenticular halo
``f3(θ, λ)``, a ring of 3° radius at 568 nm.

Unit volume means the normalisation of Spencer eq. 4,

.. math:: \\frac{\\pi^2}{90} \\int_0^{90^\\circ} P(\\theta) \\sin\\theta \\, d\\theta = 1,

so ``P`` is a density per steradian: a source of luminance ``L`` and solid angle ``Ω`` adds
``L Ω P(θ)`` cd/m² at angle ``θ``.

Corrections to the printed equations (checked numerically in ``tests/glare/models/test_vos.py``):

- Spencer eq. 7 prints the halo as ``436.9 (568/λ) exp(-(θ - 3λ/568)²)``. With that exponent
  the component has volume 4.44 (= √19.75), not 1, and an angular width (FWHM) of 1.67°, not
  the 0.35° of the text. The factor 19.75 of Hemenger's eq. 6 was dropped in print: with
  ``exp(-19.75 (θ - θ0)²)`` the volume is within 0.04 % of 1 at every wavelength 380–780 nm
  (1.0003 at 380 nm, 0.9997 at 780 nm) and the FWHM is
  0.375°, the "approximately 0.35°" of Mallero & Palmer's observation. We use eq. 6's 19.75.
- The other printed constants (2.61e6, 20.91, 72.37, 436.9) give volumes within 0.1 % of 1.
  :func:`glarelab.glare.digitise_kernel` renormalises each component to exactly unit volume
  over the plane (the PSF's, not the kernel's). Spencer §3.2 renormalises the filter instead,
  "so that all pixels sum to one", which puts the light beyond the kernel back inside it; that
  is ``VosGlare(normalisation="Spencer1995")``.

References
----------
.. [Spencer1995] Spencer, G., Shirley, P., Zimmerman, K., Greenberg, D. P. (1995).
   Physically-based glare effects for digital images. SIGGRAPH '95, §3.1, eqs. 4-10.
.. [Vos1984] Vos, J. J. (1984). Disability glare - a state of the art report.
   CIE Journal 3(2), 39-53.
.. [Yoshida2008] Yoshida, A., Ihrke, M., Mantiuk, R., Seidel, H.-P. (2008). Brightness of
   the glare illusion. APGV '08, eqs. 3-6.
"""

from __future__ import annotations

import warnings
from typing import Final

import numpy as np

from glarelab.glare._validation import check_choice, check_in_range
from glarelab.glare.models._radial import radial_mass
from glarelab.glare.models.eye import Regime

__all__ = [
    "AGE_COEFFICIENT_PER_YEAR4",
    "AGE_VALIDATED_YEARS",
    "F0_CONSTANT",
    "F0_WIDTH_DEG",
    "F1_CONSTANT",
    "F2_CONSTANT",
    "F3_CONSTANT",
    "F3_EXPONENT_PER_DEG2",
    "HALO_RADIUS_DEG",
    "HALO_REFERENCE_NM",
    "OFFSET_DEG",
    "REGIMES",
    "WAVELENGTH_RANGE_NM",
    "WEIGHTS",
    "f0",
    "f1",
    "f2",
    "f3",
    "max_age_years",
    "psf",
    "volume",
    "weights",
]

F0_CONSTANT: Final = 2.61e6  # Spencer 1995 §3.1 (Vos 1984): f0 = 2.61e6 exp(-(θ/0.02)²)
F0_WIDTH_DEG: Final = 0.02  # Spencer 1995 §3.1: 1/e half-width of the central Gaussian
F1_CONSTANT: Final = 20.91  # Spencer 1995 §3.1: f1 = 20.91 / (θ + 0.02)³
F2_CONSTANT: Final = 72.37  # Spencer 1995 §3.1: f2 = 72.37 / (θ + 0.02)²
OFFSET_DEG: Final = 0.02  # Spencer 1995 §3.1: Vos' offset a in (θ + a)⁻³ and (θ + a)⁻²
F3_CONSTANT: Final = 436.9  # Spencer 1995 eq. 7 and §3.1.1: f3(3°, 568 nm) = 436.9
F3_EXPONENT_PER_DEG2: Final = 19.75  # Spencer 1995 eq. 6 (Hemenger); dropped from printed eq. 7
HALO_RADIUS_DEG: Final = 3.0  # Spencer 1995 §3.1.1: halo radius at 568 nm
HALO_REFERENCE_NM: Final = 568.0  # Spencer 1995 §3.1.1: Mallero & Palmer's wavelength
WAVELENGTH_RANGE_NM: Final = (380.0, 780.0)  # visible range accepted for f3

REGIMES: Final = ("photopic", "mesopic", "scotopic")
# Weights of (f0, f1, f2, f3): Spencer 1995 eq. 5 (photopic), eq. 8 (mesopic), eq. 9 (scotopic).
WEIGHTS: Final = {
    "photopic": (0.384, 0.478, 0.138, 0.0),
    "mesopic": (0.368, 0.478, 0.138, 0.016),
    "scotopic": (0.282, 0.478, 0.207, 0.033),
}
AGE_COEFFICIENT_PER_YEAR4: Final = 6.9e-9  # Spencer 1995 eq. 10 (Vos 1984): moved f0 → f2
# Spencer 1995 §3.1.2 describes eq. 10 between ages 20 and 70 ("0.36 at age 20 to 0.45 at age
# 60", "doubles between the ages of 20 and 70"): the span the relation was stated for.
AGE_VALIDATED_YEARS: Final = (20.0, 70.0)


def _numbers(name: str, values: object) -> np.ndarray:
    """``values`` as a float array, refusing bools, strings and other non-numbers (which
    ``asarray(dtype=float)`` would turn into 1.0 or 568.0)."""
    if isinstance(values, np.ma.MaskedArray):
        raise ValueError(
            f"{name} must be a plain array, not a masked array (its mask would be ignored); "
            "give values.filled(value) or values.compressed()"
        )
    try:
        array = np.asarray(values)
    except ValueError:  # a ragged list
        raise ValueError(
            f"{name} must be a number or an array of numbers, got {values!r}"
        ) from None
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be a number or an array of numbers, got {values!r}")
    return array.astype(float, copy=False)


def _theta(theta_deg: float | np.ndarray) -> np.ndarray:
    theta = _numbers("theta_deg", theta_deg)
    bad = ~np.isfinite(theta) | (theta < 0)
    if bad.any():
        value = theta[bad].flat[0] if theta.ndim else float(theta)
        raise ValueError(f"theta_deg must be finite and >= 0 degrees, got {value!r}")
    return theta


def _wavelength(wavelength_nm: float | np.ndarray) -> np.ndarray:
    wavelength = _numbers("wavelength_nm", wavelength_nm)
    low, high = WAVELENGTH_RANGE_NM
    bad = ~np.isfinite(wavelength) | (wavelength < low) | (wavelength > high)
    if bad.any():
        value = wavelength[bad].flat[0] if wavelength.ndim else float(wavelength)
        raise ValueError(f"wavelength_nm must be in [{low:g}, {high:g}] nm, got {value!r}")
    return wavelength


def _out(values: np.ndarray, theta_deg: float | np.ndarray) -> float | np.ndarray:
    return float(values) if np.ndim(values) == 0 and np.ndim(theta_deg) == 0 else values


def f0(theta_deg: float | np.ndarray) -> float | np.ndarray:
    """Central Gaussian of the Vos PSF: the unscattered light.

    Parameters
    ----------
    theta_deg
        Angle from the source in degrees, >= 0.

    Returns
    -------
    float or numpy.ndarray
        Density per steradian (unit volume under Spencer eq. 4).

    Raises
    ------
    ValueError
        If an angle is negative, NaN or infinite.

    Notes
    -----
    .. math:: f_0(\\theta) = 2.61 \\times 10^6 \\, e^{-(\\theta / 0.02)^2}

    References
    ----------
    Spencer et al. 1995, §3.1; Yoshida et al. 2008, eq. 4; Vos 1984.

    Examples
    --------
    >>> f0(0.0)
    2610000.0
    """
    theta = _theta(theta_deg)
    return _out(F0_CONSTANT * np.exp(-((theta / F0_WIDTH_DEG) ** 2)), theta_deg)


def f1(theta_deg: float | np.ndarray) -> float | np.ndarray:
    """The θ⁻³ scattering component of the Vos PSF, dominant below 1-2°.

    Parameters
    ----------
    theta_deg
        Angle from the source in degrees, >= 0.

    Returns
    -------
    float or numpy.ndarray
        Density per steradian (unit volume under Spencer eq. 4).

    Raises
    ------
    ValueError
        If an angle is negative, NaN or infinite.

    Notes
    -----
    .. math:: f_1(\\theta) = \\frac{20.91}{(\\theta + 0.02)^3}

    References
    ----------
    Spencer et al. 1995, §3.1; Yoshida et al. 2008, eq. 5; Vos 1984.

    Examples
    --------
    >>> round(f1(1.0), 3)
    19.704
    """
    theta = _theta(theta_deg)
    return _out(F1_CONSTANT / (theta + OFFSET_DEG) ** 3, theta_deg)


def f2(theta_deg: float | np.ndarray) -> float | np.ndarray:
    """The θ⁻² scattering component of the Vos PSF, dominant above about 1°.

    Parameters
    ----------
    theta_deg
        Angle from the source in degrees, >= 0.

    Returns
    -------
    float or numpy.ndarray
        Density per steradian (unit volume under Spencer eq. 4).

    Raises
    ------
    ValueError
        If an angle is negative, NaN or infinite.

    Notes
    -----
    .. math:: f_2(\\theta) = \\frac{72.37}{(\\theta + 0.02)^2}

    References
    ----------
    Spencer et al. 1995, §3.1; Yoshida et al. 2008, eq. 6; Vos 1984.

    Examples
    --------
    >>> round(f2(1.0), 3)
    69.56
    """
    theta = _theta(theta_deg)
    return _out(F2_CONSTANT / (theta + OFFSET_DEG) ** 2, theta_deg)


def f3(
    theta_deg: float | np.ndarray, wavelength_nm: float | np.ndarray = HALO_REFERENCE_NM
) -> float | np.ndarray:
    """Lenticular halo: a ring of radius 3 λ/568 degrees (Hemenger's model).

    Parameters
    ----------
    theta_deg
        Angle from the source in degrees, >= 0.
    wavelength_nm
        Wavelength in nm, 380-780; default 568 nm. Broadcasts against ``theta_deg``.

    Returns
    -------
    float or numpy.ndarray
        Density per steradian (volume under Spencer eq. 4 within 0.04 % of 1 at every
        wavelength 380-780 nm).

    Raises
    ------
    ValueError
        If an angle is negative or not finite, or a wavelength lies outside 380-780 nm.

    Notes
    -----
    .. math::

       f_3(\\theta, \\lambda) = 436.9 \\, \\frac{568}{\\lambda} \\,
           e^{-19.75 (\\theta - 3 \\lambda / 568)^2}

    Spencer eq. 7 as printed lacks the factor 19.75 of eq. 6. Without it the ring has volume
    4.44 and a width of 1.67°; with it, volume 1 and a width (FWHM) of 0.375°, matching the
    3° radius and approximately 0.35° width that the text (§3.1.1) requires. We follow the
    text. The factor 568/λ keeps the volume at 1 as the ring grows with λ.

    References
    ----------
    Spencer et al. 1995, eqs. 6-7 and §3.1.1 (after Hemenger 1992, Mallero & Palmer).

    Examples
    --------
    >>> f3(3.0, 568.0)
    436.9
    """
    theta = _theta(theta_deg)
    wavelength = _wavelength(wavelength_nm)
    ratio = wavelength / HALO_REFERENCE_NM
    values = (
        F3_CONSTANT
        / ratio
        * np.exp(-F3_EXPONENT_PER_DEG2 * (theta - HALO_RADIUS_DEG * ratio) ** 2)
    )
    if np.ndim(values) == 0 and np.ndim(theta_deg) == 0 and np.ndim(wavelength_nm) == 0:
        return float(values)
    return values


def max_age_years(regime: Regime) -> float:
    """Age at which eq. 10 drives the weight of ``f0`` to zero for a regime.

    Beyond it the "PSF" would have a negative central peak, so eq. 10 cannot be used there.

    Parameters
    ----------
    regime
        ``'photopic'``, ``'mesopic'`` or ``'scotopic'``.

    Returns
    -------
    float
        The age, years: ``(w0 / c)^(1/4)`` with eq. 10's coefficient ``c``.

    Raises
    ------
    ValueError
        For an unknown regime.

    Examples
    --------
    >>> round(max_age_years("photopic"), 1), round(max_age_years("scotopic"), 1)
    (86.4, 80.0)
    """
    check_choice("regime", regime, REGIMES)
    return (WEIGHTS[regime][0] / AGE_COEFFICIENT_PER_YEAR4) ** 0.25


def weights(
    regime: Regime = "photopic", age: float | None = None, *, warn: bool = True
) -> tuple[float, ...]:
    """Weights of ``(f0, f1, f2, f3)`` for an adaptation regime and, optionally, an age.

    ``warn=False`` leaves out the warning for an age outside 20-70 years, for a caller that
    has given it once already (a model warns when it is made, not at every kernel).

    Parameters
    ----------
    regime
        ``'photopic'`` (eq. 5), ``'mesopic'`` (eq. 8) or ``'scotopic'`` (eq. 9).
    age
        Observer's age in years, or ``None`` for the standard observer of eqs. 5, 8, 9.
        Eq. 10 moves ``6.9e-9 A⁴`` of the weight from ``f0`` to ``f2``.
    warn
        Warn for an age outside 20-70 years (default True); False for a caller that has
        warned once already.

    Returns
    -------
    tuple of float
        Four weights summing to 1.

    Raises
    ------
    ValueError
        For an unknown regime, or an age below 0 or at/above :func:`max_age_years`, where
        the weight of ``f0`` would be negative and the PSF no longer a density.

    Warns
    -----
    UserWarning
        For an age outside 20-70 years, the span Spencer §3.1.2 states eq. 10 for.

    Notes
    -----
    Eq. 10 is printed for the photopic PSF only. Spencer §3.1.2 says ``P_m`` and ``P_s``
    "have similar behavior" with the ``f3`` weight constant, so the same transfer from
    ``f0`` to ``f2`` is applied in every regime.

    References
    ----------
    Spencer et al. 1995, eqs. 5, 8, 9, 10 and §3.1.2; Vos 1984.

    Examples
    --------
    >>> weights("mesopic")
    (0.368, 0.478, 0.138, 0.016)
    >>> [round(w, 4) for w in weights("photopic", age=60)]
    [0.2946, 0.478, 0.2274, 0.0]
    """
    check_choice("regime", regime, REGIMES)
    w0, w1, w2, w3 = WEIGHTS[regime]
    if age is None:
        return (w0, w1, w2, w3)
    limit = max_age_years(regime)
    age_years = check_in_range(
        "age", age, 0.0, limit, unit=f"years (eq. 10, {regime})", high_inclusive=False
    )
    low, high = AGE_VALIDATED_YEARS
    if warn and not low <= age_years <= high:
        warnings.warn(
            f"age={age_years:g} years is outside {low:g}-{high:g} years, the span for which "
            "Spencer 1995 §3.1.2 states the age relation eq. 10; the PSF is extrapolated",
            UserWarning,
            stacklevel=2,
        )
    shift = AGE_COEFFICIENT_PER_YEAR4 * age_years**4
    return (w0 - shift, w1, w2 + shift, w3)


def psf(
    theta_deg: float | np.ndarray,
    regime: Regime = "photopic",
    wavelength_nm: float = HALO_REFERENCE_NM,
    age: float | None = None,
) -> float | np.ndarray:
    """The Vos/Spencer PSF of the eye for one wavelength.

    Parameters
    ----------
    theta_deg
        Angle from the source in degrees, >= 0.
    regime
        ``'photopic'`` (eq. 5, no halo), ``'mesopic'`` (eq. 8) or ``'scotopic'`` (eq. 9).
    wavelength_nm
        Wavelength of the halo term in nm, 380-780; default 568 nm. Only the default with
        a regime without a halo (``'photopic'``): another would be ignored.
    age
        Observer's age in years (eq. 10), or ``None`` for the standard observer.

    Returns
    -------
    float or numpy.ndarray
        Density per steradian with unit volume under Spencer eq. 4.

    Raises
    ------
    ValueError
        For a negative or non-finite angle, a masked array, an unknown regime, a wavelength
        that is not one number in 380-780 nm (or is not the default in a regime without a
        halo), or an age outside eq. 10's range (see :func:`weights`).

    Notes
    -----
    .. math::

       P(\\theta, \\lambda) = w_0 f_0(\\theta) + w_1 f_1(\\theta) + w_2 f_2(\\theta)
           + w_3 f_3(\\theta, \\lambda)

    with the weights of :func:`weights`.

    References
    ----------
    Spencer et al. 1995, eqs. 5, 8, 9, 10.

    Examples
    --------
    >>> round(psf(3.0), 2)  # Spencer §3.1.1 prints P_p(3°) = 1.462
    1.46
    """
    w0, w1, w2, w3 = weights(regime, age)
    theta = _theta(theta_deg)
    wavelength = _wavelength(wavelength_nm)
    if wavelength.ndim:  # one PSF per call: its angles may be an array, its wavelength not
        raise ValueError(
            f"wavelength_nm must be one wavelength (a number) for psf; got {wavelength_nm!r} "
            "(call psf once per wavelength, or f3 for the halo at many)"
        )
    wavelength = float(wavelength)
    if not w3 and wavelength != HALO_REFERENCE_NM:
        raise ValueError(
            f"wavelength_nm={wavelength_nm!r}: it shapes only the halo, and the {regime} PSF "
            f"(eq. 5) has no lenticular halo, so it would be ignored; leave it at its default "
            f"({HALO_REFERENCE_NM!r}) or give a regime with a halo"
        )
    values = w0 * f0(theta) + w1 * f1(theta) + w2 * f2(theta)
    if w3:
        values = values + w3 * f3(theta, wavelength)
    return _out(np.asarray(values), theta_deg)


def volume(profile, *, upper_deg: float = 90.0) -> float:
    """Volume of a radial profile under Spencer eq. 4, ``(π²/90) ∫ P(θ) sin θ dθ``.

    Parameters
    ----------
    profile
        Callable taking angles in degrees (array) and returning densities per steradian.
    upper_deg
        Upper limit of the integral in degrees, 0 < upper <= 90; default 90 (the hemisphere).

    Returns
    -------
    float
        The volume; 1 for a normalised PSF.

    References
    ----------
    Spencer et al. 1995, eq. 4.

    Examples
    --------
    >>> round(volume(f2), 4)
    0.9999
    """
    if not callable(profile):
        raise ValueError(
            f"profile must be a function of angles in degrees (f0, f1, f2, a PSF); got "
            f"{profile!r:.80}"
        )
    check_in_range("upper_deg", upper_deg, 0.0, 90.0, unit="deg", low_inclusive=False)
    return float(radial_mass(profile, np.array([upper_deg]))[0])
