"""Colour at night: what rod vision does to the colours of a scene.

Two models, behind one dispatcher (:func:`scotopic_colour`):

- ``'Spencer1995'``: the HSV saturation of the image reduced by 70 % (Spencer et al. 1995,
  §5 and Figure 14: "to simulate scotopic (rod) vision ... not completely desaturated because
  color vision degrades gradually").
- ``'Luidolt2020'``: a blend towards a lavender-blue rod image by the rods' sensitivity σ of
  the adapted luminance (Luidolt 2020 eq. 5.18, after Krawczyk et al. 2005):
  ``RGB (1 - σ) + T L' σ``.

The rods see one colour, weighted by the scotopic luminous efficiency V′(λ) (CIE 1951), which
peaks at 507 nm where the cones' V(λ) peaks at 555 nm (the Purkinje shift). The rod response
``L'`` is computed here from V′(λ), through colour-science:

- from a **spectrum** (spectral radiance, W sr⁻¹ m⁻² nm⁻¹):
  ``L_s = K′_m ∫ L_e(λ) V′(λ) dλ`` with ``K′_m = 1700 lm/W`` (scotopic cd/m²);
- from **linear RGB**: each primary's spectrum is taken as Mallett & Yuksel's (2019) sRGB
  basis reflectance lit by D65 (the three sum to D65 and reproduce the Rec. 709 primaries:
  their photopic luminances are Rec. 709's 0.2126, 0.7152, 0.0722 to 1e-4), and weighted by
  V′(λ). The result is a linear map, ``L' = w · RGB``.

**Reference white.** ``L'`` is expressed in photopic-equivalent units of the display's white,
D65 (the white of Rec. 709): a grey of luminance Y has ``L' = Y``, so the rod image of a grey
scene keeps its luminance, while red loses 92 % and blue gains 5.5 × against its photopic
luminance. The absolute scotopic luminance is ``L'`` times the S/P ratio of D65, 2.465.

References
----------
Spencer, G., Shirley, P., Zimmerman, K., Greenberg, D. P. (1995). Physically-based glare effects
for digital images. SIGGRAPH '95, §5, Figure 14.
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, §5.4, eq. 5.18.
Krawczyk, G., Myszkowski, K., Seidel, H.-P. (2005). Perceptual effects in real-time tone
mapping. SCCG '05.
Mallett, I., Yuksel, C. (2019). Spectral primary decomposition for rendering with sRGB
reflectance. EGSR (the basis in colour-science).
CIE (1951) scotopic and CIE (1924) photopic luminous efficiency functions (colour-science).
"""

from __future__ import annotations

from functools import cache
from typing import Literal

import numpy as np
from colour.recovery import MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019

from glarelab.glare._colour import colour
from glarelab.glare._validation import check_choice, check_in_range, check_luminances, check_real
from glarelab.glare.night.adaptation import rod_sensitivity

__all__ = [
    "METHODS",
    "PHOTOPIC_OBSERVER",
    "REFERENCE_WHITE",
    "SCOTOPIC_OBSERVER",
    "SPENCER1995_DESATURATION",
    "TINT_LUIDOLT2020",
    "desaturate_Spencer1995",
    "luminance_from_spectra",
    "rod_luminance",
    "rod_weights",
    "scotopic_colour",
    "scotopic_luminance",
    "scotopic_shift_Luidolt2020",
    "scotopic_to_photopic_ratio",
]

SPENCER1995_DESATURATION = 0.7  # Spencer 1995 §5: "the saturation in HSV space was reduced by 70%"
TINT_LUIDOLT2020 = (1.05, 0.97, 1.27)  # Luidolt 2020 eq. 5.18: "the purple tint"
SCOTOPIC_OBSERVER = "CIE 1951 Scotopic Standard Observer"  # V′(λ)
PHOTOPIC_OBSERVER = "CIE 1924 Photopic Standard Observer"  # V(λ)
REFERENCE_WHITE = "D65"  # the white of Rec. 709, in which L' of a grey equals its luminance
METHODS = ("Luidolt2020", "Spencer1995")
_SRGB = "sRGB"  # the primaries of Mallett & Yuksel's basis


def luminance_from_spectra(
    radiance: np.ndarray,
    wavelengths_nm: np.ndarray,
    *,
    vision: Literal["scotopic", "photopic"] = "scotopic",
) -> np.ndarray:
    """Scotopic (or photopic) luminance of spectral radiances.

    Parameters
    ----------
    radiance
        ``(..., n)`` spectral radiance, W sr⁻¹ m⁻² nm⁻¹, finite and >= 0.
    wavelengths_nm
        ``(n,)`` increasing wavelengths, nm; n >= 2. V′ and V are 0 outside 380-780 nm.
    vision
        ``'scotopic'`` (default): ``1700 ∫ L V′ dλ`` in scotopic cd/m²; ``'photopic'``:
        ``683 ∫ L V dλ`` in cd/m².

    Returns
    -------
    numpy.ndarray
        ``(...)`` luminance.

    Raises
    ------
    ValueError
        For mismatched shapes, wavelengths that do not increase, or negative radiance.

    Notes
    -----
    .. math:: L_s = K'_m \\int L_{e,\\lambda} V'(\\lambda) \\, d\\lambda, \\quad
              K'_m = 1700 \\text{ lm/W}

    integrated by the trapezoid rule on the given wavelengths (as
    ``colour.luminous_flux``), with the functions and constants of colour-science.

    References
    ----------
    CIE 1951 scotopic luminous efficiency (colour.colorimetry.SDS_LEFS_SCOTOPIC).

    Examples
    --------
    >>> w = np.arange(380.0, 781.0, 5.0)
    >>> line = np.where(w == 555.0, 1.0 / 5.0, 0.0)  # about 1 W/(sr m²) at 555 nm
    >>> s = luminance_from_spectra(line, w)
    >>> p = luminance_from_spectra(line, w, vision="photopic")
    >>> round(float(s / p), 3)  # 1700 V′(555) / 683: the units agree at 555 nm
    1.001
    """
    check_choice("vision", vision, ("scotopic", "photopic"))
    w = np.asarray(wavelengths_nm, dtype=float)
    values = np.asarray(radiance, dtype=float)
    if w.ndim != 1 or w.size < 2 or not np.all(np.diff(w) > 0) or not np.isfinite(w).all():
        raise ValueError(
            f"wavelengths_nm must be at least two increasing finite wavelengths; got {w!r}"
        )
    if values.shape[-1:] != w.shape:
        raise ValueError(
            f"radiance must have one value per wavelength in its last axis ({w.size}); got "
            f"shape {values.shape}"
        )
    if not np.isfinite(values).all() or (values < 0).any():
        raise ValueError("radiance must be finite and >= 0 W/(sr m² nm)")
    if vision == "scotopic":
        lef = colour.colorimetry.SDS_LEFS_SCOTOPIC[SCOTOPIC_OBSERVER]
        k_m = colour.constants.CONSTANT_KP_M
    else:
        lef = colour.colorimetry.SDS_LEFS_PHOTOPIC[PHOTOPIC_OBSERVER]
        k_m = colour.constants.CONSTANT_K_M
    efficiency = np.interp(w, lef.wavelengths, lef.values, left=0.0, right=0.0)
    return k_m * np.trapezoid(values * efficiency, w, axis=-1)


@cache
def _spectral_ratio(colourspace: str) -> tuple[np.ndarray, float]:
    """Rod weights of the colourspace's primaries relative to D65, and D65's S/P ratio."""
    basis = MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019
    wavelengths = basis.wavelengths
    white = colour.SDS_ILLUMINANTS[REFERENCE_WHITE][wavelengths]
    primaries = (basis.values * white[:, None]).T  # (3, n): the emitted spectra of R, G, B
    scotopic = luminance_from_spectra(primaries, wavelengths)
    photopic = luminance_from_spectra(white, wavelengths, vision="photopic")
    ratio = float(luminance_from_spectra(white, wavelengths) / photopic)
    weights = scotopic / scotopic.sum()  # D65 white (R = G = B = 1) → 1
    if colourspace != _SRGB:  # the colourspace's RGB → sRGB, then the sRGB weights
        matrix = colour.matrix_RGB_to_RGB(
            colour.RGB_COLOURSPACES[colourspace], colour.RGB_COLOURSPACES[_SRGB]
        )
        weights = weights @ matrix
    weights.setflags(write=False)
    return weights, ratio


def rod_weights(colourspace: str = "ITU-R BT.709") -> np.ndarray:
    """The rod response of each primary of linear RGB, relative to the reference white.

    Parameters
    ----------
    colourspace
        A colour-science RGB colourspace; default ``'ITU-R BT.709'``.

    Returns
    -------
    numpy.ndarray
        ``(3,)`` weights ``w`` with ``L' = w · RGB``; for Rec. 709 they sum to 1 (a D65 grey
        keeps its luminance).

    Notes
    -----
    .. math:: w_c = \\frac{\\int B_c(\\lambda) S_{D65}(\\lambda) V'(\\lambda) d\\lambda}
                         {\\int S_{D65}(\\lambda) V'(\\lambda) d\\lambda}

    with ``B_c`` the Mallett & Yuksel (2019) sRGB basis reflectances (``Σ_c B_c = 1``).

    References
    ----------
    Mallett & Yuksel 2019; CIE 1951 V′(λ); CIE D65.

    Examples
    --------
    >>> [round(float(w), 3) for w in rod_weights()]  # red nearly invisible to the rods
    [0.018, 0.585, 0.397]
    """
    check_choice("colourspace", colourspace, sorted(colour.RGB_COLOURSPACES))
    return _spectral_ratio(colourspace)[0]


def scotopic_to_photopic_ratio() -> float:
    """The S/P ratio of the reference white D65: scotopic over photopic luminance (2.465).

    Examples
    --------
    >>> round(scotopic_to_photopic_ratio(), 3)
    2.465
    """
    return _spectral_ratio(_SRGB)[1]


def rod_luminance(rgb: np.ndarray, *, colourspace: str = "ITU-R BT.709") -> np.ndarray:
    """The rods' response to linear RGB, in photopic-equivalent units of the D65 white.

    Parameters
    ----------
    rgb
        ``(..., 3)`` linear RGB, >= 0 (cd/m² of a white of equal R, G, B, or relative).
    colourspace
        The RGB's colourspace; default ``'ITU-R BT.709'``.

    Returns
    -------
    numpy.ndarray
        ``(...)`` ``L' = w · RGB`` (:func:`rod_weights`), clipped at 0 (a colour outside the
        sRGB gamut of another colourspace may give a negative sum).

    Examples
    --------
    >>> float(rod_luminance(np.array([0.5, 0.5, 0.5])))  # a grey keeps its luminance
    0.5
    """
    array = _rgb("rgb", rgb)
    return np.maximum(array @ rod_weights(colourspace), 0.0)


def scotopic_luminance(rgb: np.ndarray, *, colourspace: str = "ITU-R BT.709") -> np.ndarray:
    """Scotopic luminance (scotopic cd/m²) of linear RGB in cd/m²: the rod luminance times
    D65's S/P ratio.

    Parameters
    ----------
    rgb
        ``(..., 3)`` linear RGB, cd/m² (channels of a white of equal R, G, B).
    colourspace
        The RGB colourspace's name in colour-science; default ``'ITU-R BT.709'``.

    Returns
    -------
    numpy.ndarray
        ``(...)`` scotopic luminance, scotopic cd/m².

    Examples
    --------
    >>> round(float(scotopic_luminance(np.array([1.0, 1.0, 1.0]))), 3)  # 1 cd/m² of D65
    2.465
    """
    return rod_luminance(rgb, colourspace=colourspace) * scotopic_to_photopic_ratio()


def desaturate_Spencer1995(
    rgb: np.ndarray, *, desaturation: float = SPENCER1995_DESATURATION
) -> np.ndarray:
    """Spencer's night colours: the HSV saturation reduced by ``desaturation``.

    Parameters
    ----------
    rgb
        ``(..., 3)`` RGB, >= 0 (any scale: HSV saturation does not depend on it).
    desaturation
        Fraction of the saturation removed, 0-1; default 0.7 (Spencer §5).

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` with the same hue and value (the largest channel), saturation
        ``(1 - desaturation) S``.

    Notes
    -----
    With ``V = max(R, G, B)``, reducing ``S = (V - min) / V`` by a factor keeps hue and value,
    i.e. ``c' = V - (1 - d)(V - c)``: every channel moves towards the largest, which brightens
    coloured pixels. Spencer applied it to the displayed image; here it is applied to the
    values given (the night pipeline gives linear display RGB). The conversion is
    colour-science's ``RGB_to_HSV`` / ``HSV_to_RGB``.

    References
    ----------
    Spencer et al. 1995, §5, Figure 14.

    Examples
    --------
    >>> desaturate_Spencer1995(np.array([1.0, 0.0, 0.5])).round(3).tolist()
    [1.0, 0.7, 0.85]
    """
    array = _rgb("rgb", rgb)
    d = check_in_range("desaturation", desaturation, 0.0, 1.0)
    hsv = colour.RGB_to_HSV(array)
    hsv[..., 1] *= 1.0 - d
    out = colour.HSV_to_RGB(hsv)
    return np.clip(out, 0.0, array.max(axis=-1, keepdims=True))  # round-off below 0 or past V


def scotopic_shift_Luidolt2020(
    rgb: np.ndarray,
    adaptation_luminance_cd_m2: float | np.ndarray,
    *,
    tint: tuple[float, float, float] = TINT_LUIDOLT2020,
    rod: Literal["scotopic", "photopic"] = "scotopic",
    colourspace: str = "ITU-R BT.709",
) -> np.ndarray:
    """Luidolt's scotopic colour shift: a blend towards a tinted rod image by σ(L), eq. 5.18.

    Parameters
    ----------
    rgb
        ``(..., 3)`` linear RGB after tone mapping (display cd/m² or relative), >= 0.
    adaptation_luminance_cd_m2
        The adapted luminance of the scene ``L_i`` (before tone mapping), cd/m², >= 0: a
        number for the frame (Luidolt) or one per pixel, broadcast against ``rgb[..., 0]``.
    tint
        The rods' colour, linear RGB, > 0; default Luidolt's (1.05, 0.97, 1.27), scaled to
        unit luminance (see Notes).
    rod
        ``'scotopic'`` (default): the rod response ``L'`` from V′(λ) (:func:`rod_luminance`);
        ``'photopic'``: the pixel's luminance, as Luidolt's tone-mapped ``L'_i``.
    colourspace
        The RGB's colourspace; default ``'ITU-R BT.709'``.

    Returns
    -------
    numpy.ndarray
        ``(..., 3)`` RGB: the input where σ = 0, the tinted rod image where σ = 1.

    Notes
    -----
    .. math:: SV = RGB \\, (1 - \\sigma(L_i)) + T \\, L' \\, \\sigma(L_i) \\qquad (5.18)

    with σ of eq. 5.4. The printed tint has luminance 1.0087 in Rec. 709 (D65 white): it is
    divided by its luminance, so that at σ = 1 a grey keeps its luminance exactly and takes
    the tint's chromaticity (x, y) = (0.3002, 0.3001), bluer than D65's (0.3127, 0.3290).

    References
    ----------
    Luidolt 2020, §5.4, eq. 5.18 (after Krawczyk et al. 2005).

    Examples
    --------
    >>> grey = np.array([0.2, 0.2, 0.2])
    >>> scotopic_shift_Luidolt2020(grey, 1e6).round(4).tolist()  # σ ≈ 0: unchanged
    [0.2, 0.2, 0.2]
    >>> scotopic_shift_Luidolt2020(grey, 0.0).round(4).tolist()  # σ = 1: tinted, Y kept
    [0.2082, 0.1923, 0.2518]
    """
    array = _rgb("rgb", rgb)
    check_choice("rod", rod, ("scotopic", "photopic"))
    check_choice("colourspace", colourspace, sorted(colour.RGB_COLOURSPACES))
    tint_rgb = check_real("tint", tint)
    if tint_rgb.shape != (3,) or not np.isfinite(tint_rgb).all() or (tint_rgb <= 0).any():
        raise ValueError(f"tint must be three linear RGB values > 0; got {tint!r}")
    y_row = np.asarray(colour.RGB_COLOURSPACES[colourspace].matrix_RGB_to_XYZ[1], float)
    y_row = y_row / y_row.sum()
    tint_rgb = tint_rgb / float(tint_rgb @ y_row)
    # checked under its own name (rod_sensitivity's would name luminance_cd_m2)
    check_luminances("adaptation_luminance_cd_m2", adaptation_luminance_cd_m2)
    sigma = np.asarray(rod_sensitivity(adaptation_luminance_cd_m2), dtype=float)
    try:
        sigma = np.broadcast_to(sigma, array.shape[:-1])[..., None]
    except ValueError:
        raise ValueError(
            f"adaptation_luminance_cd_m2 of shape {np.shape(adaptation_luminance_cd_m2)} does "
            f"not broadcast against the image's {array.shape[:-1]}"
        ) from None
    response = (
        rod_luminance(array, colourspace=colourspace) if rod == "scotopic" else array @ y_row
    )
    return array * (1.0 - sigma) + tint_rgb * response[..., None] * sigma


def scotopic_colour(
    rgb: np.ndarray,
    *,
    method: Literal["Luidolt2020", "Spencer1995"] = "Luidolt2020",
    adaptation_luminance_cd_m2: float | np.ndarray | None = None,
    **options,
) -> np.ndarray:
    """Night colours of an image by a named model (the dispatcher).

    Parameters
    ----------
    rgb
        ``(..., 3)`` linear RGB, >= 0.
    method
        ``'Luidolt2020'`` (default, eq. 5.18; needs ``adaptation_luminance_cd_m2``) or
        ``'Spencer1995'`` (70 % less HSV saturation).
    adaptation_luminance_cd_m2
        The scene's adapted luminance, cd/m² (Luidolt2020 only).
    options
        The method's keywords (:func:`scotopic_shift_Luidolt2020`,
        :func:`desaturate_Spencer1995`).

    Raises
    ------
    ValueError
        For an unknown method, Luidolt2020 without an adaptation luminance, or Spencer1995
        with one (it would act on nothing).

    Examples
    --------
    >>> rgb = np.array([1.0, 0.0, 0.5])
    >>> scotopic_colour(rgb, method="Spencer1995").round(2).tolist()
    [1.0, 0.7, 0.85]
    """
    check_choice("method", method, METHODS)
    if method == "Luidolt2020":
        if adaptation_luminance_cd_m2 is None:
            raise ValueError(
                "method 'Luidolt2020' needs adaptation_luminance_cd_m2 (the scene's adapted "
                "luminance, cd/m²: eq. 5.18 blends by the rods' sensitivity to it)"
            )
        return scotopic_shift_Luidolt2020(rgb, adaptation_luminance_cd_m2, **options)
    if method == "Spencer1995":
        if adaptation_luminance_cd_m2 is not None:
            raise ValueError(
                f"adaptation_luminance_cd_m2={adaptation_luminance_cd_m2!r} with method "
                "'Spencer1995': its desaturation is the same at every adaptation level; leave "
                "it None, or use method 'Luidolt2020', which blends by it"
            )
        return desaturate_Spencer1995(rgb, **options)
    raise ValueError(f"method must be one of {METHODS}; got {method!r}")


def _rgb(name: str, value) -> np.ndarray:
    array = check_real(name, value)
    if array.shape[-1:] != (3,):
        raise ValueError(f"{name} must have 3 channels in its last axis; got shape {array.shape}")
    if not np.isfinite(array).all() or (array < 0).any():
        raise ValueError(f"{name} must be finite and >= 0")
    return array
