"""State of the observer's eye: pupil diameter and adaptation regime from field luminance.

References
----------
.. [Spencer1995] Spencer, G., Shirley, P., Zimmerman, K., Greenberg, D. P. (1995).
   Physically-based glare effects for digital images. SIGGRAPH '95, §3.1 and §3.1.1.
.. [Moon1944] Moon, P., Spencer, D. E. (1944). On the Stiles-Crawford effect.
   JOSA 34(6), as quoted in [Spencer1995]_ §3.1.1.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from glarelab.files.values import plain_array
from glarelab.glare._validation import check_image

__all__ = [
    "HALO_PUPIL_MM",
    "MESOPIC_UPPER_CD_M2",
    "SCOTOPIC_UPPER_CD_M2",
    "Regime",
    "pupil_diameter_mm",
    "regime",
]

Regime = Literal["photopic", "mesopic", "scotopic"]

SCOTOPIC_UPPER_CD_M2 = 0.01  # Spencer 1995, §3.1: below 0.01 cd/m² is scotopic
MESOPIC_UPPER_CD_M2 = 3.0  # Spencer 1995, §3.1: 0.01-3 cd/m² is mesopic, above is photopic
HALO_PUPIL_MM = 3.0  # Spencer 1995, §2.1 and §3.1.1: no lenticular halo below a 3 mm pupil

# Moon & Spencer (1944) pupil formula, Spencer 1995 §3.1.1: D = 4.9 - 3 tanh(0.4 (log10 L + 1))
_MOON_SPENCER_MEAN_MM = 4.9
_MOON_SPENCER_SWING_MM = 3.0
_MOON_SPENCER_SLOPE = 0.4
_MOON_SPENCER_OFFSET = 1.0


def pupil_diameter_mm(field_luminance_cd_m2: float | np.ndarray) -> float | np.ndarray:
    """Average pupil diameter for a field luminance (Moon & Spencer 1944).

    Parameters
    ----------
    field_luminance_cd_m2
        Field (adapting) luminance in cd/m², >= 0. Scalar or array.

    Returns
    -------
    float or numpy.ndarray
        Pupil diameter in mm, between 1.9 mm (very bright) and 7.9 mm (darkness, the limit
        at 0 cd/m²).

    Raises
    ------
    ValueError
        If the luminance is negative, NaN or infinite, or an array that does not hold numbers.
    TypeError
        If the luminance is a string.

    Notes
    -----
    .. math:: D = 4.9 - 3 \\tanh\\bigl(0.4 (\\log_{10} L + 1)\\bigr)

    At :math:`L = 0` the formula is taken at its limit, 7.9 mm.

    References
    ----------
    Spencer et al. 1995, §3.1.1 (quoting Moon & Spencer 1944).

    Examples
    --------
    >>> round(pupil_diameter_mm(10.0), 2)
    2.91
    """
    if isinstance(field_luminance_cd_m2, str | bytes):  # np.asarray(.., float) reads '100'
        raise TypeError(
            "field_luminance_cd_m2 must be a number or an array of numbers (cd/m²), got the "
            f"{type(field_luminance_cd_m2).__name__} {field_luminance_cd_m2!r}"
        )
    if isinstance(field_luminance_cd_m2, np.ma.MaskedArray):  # asarray would drop the mask
        check_image("field_luminance_cd_m2", field_luminance_cd_m2)
    plain = plain_array("field_luminance_cd_m2", field_luminance_cd_m2)
    real = np.issubdtype(plain.dtype, np.integer) or np.issubdtype(plain.dtype, np.floating)
    if plain.size == 0:  # no luminances, no diameters: as acuity_cpd and the others
        if not real:
            raise ValueError(
                "field_luminance_cd_m2 must hold luminances, numbers in cd/m²; got an empty "
                f"array of {plain.dtype}"
            )
        return np.empty(plain.shape)
    array = check_image(  # its own dtype checked (strings and bools refused), then float;
        "field_luminance_cd_m2",  # any shape, as one row (a stack of frames too)
        plain.reshape(1, -1) if plain.ndim != 2 else plain,
    ).astype(float)
    with np.errstate(divide="ignore"):
        log_l = np.log10(array)  # -inf at L = 0, where tanh(-inf) = -1 gives the 7.9 mm limit
    diameter = _MOON_SPENCER_MEAN_MM - _MOON_SPENCER_SWING_MM * np.tanh(
        _MOON_SPENCER_SLOPE * (log_l + _MOON_SPENCER_OFFSET)
    )
    if np.ndim(field_luminance_cd_m2) == 0:
        return float(diameter.reshape(-1)[0])
    return diameter.reshape(np.shape(field_luminance_cd_m2))


def regime(field_luminance_cd_m2: float) -> Regime:
    """Adaptation regime of the observer for a field luminance.

    Parameters
    ----------
    field_luminance_cd_m2
        Field (adapting) luminance in cd/m², >= 0.

    Returns
    -------
    {'scotopic', 'mesopic', 'photopic'}
        ``'scotopic'`` below 0.01 cd/m², ``'mesopic'`` from 0.01 to 3 cd/m² inclusive,
        ``'photopic'`` above 3 cd/m².

    Raises
    ------
    ValueError
        If the luminance is negative, NaN, infinite or not a scalar.

    References
    ----------
    Spencer et al. 1995, §3.1 (after Rea 1993).

    Examples
    --------
    >>> regime(0.001), regime(1.0), regime(100.0)
    ('scotopic', 'mesopic', 'photopic')
    """
    plain = plain_array("field_luminance_cd_m2", field_luminance_cd_m2)  # ragged rows named
    if plain.ndim != 0:
        raise ValueError(
            "field_luminance_cd_m2 must be a scalar luminance in cd/m², "
            f"got an array of shape {plain.shape}"
        )
    value = float(check_image("field_luminance_cd_m2", [[field_luminance_cd_m2]])[0, 0])
    if value < SCOTOPIC_UPPER_CD_M2:
        return "scotopic"
    if value <= MESOPIC_UPPER_CD_M2:
        return "mesopic"
    return "photopic"
