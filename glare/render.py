"""Adding glare to a linear HDR luminance image (Yoshida et al. 2008 §3; Spencer et al. 1995 §3.2).

Only light the display cannot show is spread: ``ΔL = max(L - L_dmax, 0)`` (Yoshida eq. 1) is
convolved with the glare kernel as a linear convolution (zero padding, no wrap-around) and
added back. Yoshida clamps the result to ``L_dmax``; Spencer keeps the displayable part of
each pixel and adds the spread excess without a clamp (values above ``L_dmax`` are the
"burn-out" Spencer §5 mentions, left to the tone mapper).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from ._convolve import bounding_box, convolution_dtype
from ._convolve import spread as spread_fn
from ._validation import check_choice, check_image, check_positive
from .digitise import Kernel, check_kernel_shape, kernel_shape_for
from .models import GlareModel, _resolve
from .plan import render_planned

__all__ = ["L_DMAX_YOSHIDA2008_CD_M2", "GlareResult", "add_glare", "render_glare"]

L_DMAX_YOSHIDA2008_CD_M2 = 220.0  # Yoshida 2008 §3: maximum luminance of a typical display
METHODS = ("Yoshida2008", "Spencer1995")
PRECISIONS = ("float64", "float32")


@dataclass(frozen=True)
class GlareResult:
    """An image with glare, and everything needed to say what was done to it.

    Attributes
    ----------
    image
        The image with glare, cd/m², same shape as the input.
    excess
        ``ΔL``: the luminance above ``l_dmax_cd_m2`` that was spread (Yoshida eq. 1).
    spread
        ``ΔL`` convolved with the kernel, inside the image.
    kernel
        The kernel used, with its own energy account.
    excess_energy
        Sum of ``ΔL`` (cd/m² × pixels), per channel for colour images.
    energy_outside_kernel
        Part of ``excess_energy`` the PSF sends beyond the kernel's support.
    energy_outside_image
        Part of ``excess_energy`` the kernel sends beyond the image border.
    parameters
        The arguments, for logs.
    """

    image: np.ndarray
    excess: np.ndarray
    spread: np.ndarray
    kernel: Kernel
    excess_energy: np.ndarray
    energy_outside_kernel: np.ndarray
    energy_outside_image: np.ndarray
    parameters: dict


def render_glare(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float = L_DMAX_YOSHIDA2008_CD_M2,
    method: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    precision: Literal["float64", "float32"] = "float64",
    kernel_shape: tuple[int, int] | None = None,
    kernel: Kernel | None = None,
) -> GlareResult:
    """Add glare to a linear luminance image and account for every bit of energy.

    Parameters
    ----------
    luminance_cd_m2
        Linear luminance, cd/m², finite and >= 0: shape ``(H, W)``, or ``(H, W, 3)`` linear RGB
        whose channels are in cd/m² of a white of equal R, G, B.
    model
        A glare model (:class:`~glare.GaussianGlare`, :class:`~glare.VosGlare`) or its name.
    pixel_deg
        Visual angle of one pixel in degrees, > 0.
    l_dmax_cd_m2
        Maximum luminance the display shows, cd/m², > 0; default 220 (Yoshida §3).
    method
        ``'Yoshida2008'`` (default): ``min(L + ΔL ⊛ K, L_dmax)``. ``'Spencer1995'``:
        ``min(L, L_dmax) + ΔL ⊛ K`` with no clamp.
    precision
        ``'float64'`` (reference) or ``'float32'`` (fast; about 1e-6 relative). The float32
        path convolves in float64 when its FFT round-off could add more than 1e-3 cd/m² to the
        image (a scene with a sun); ``parameters['convolution_precision']`` says which ran.
    kernel_shape
        Odd kernel shape; default ``(2H - 1, 2W - 1)``, which lets every pixel reach every
        other (Spencer §3.2: "double the width and height of the target image").
    kernel
        A kernel already digitised by ``model`` for this ``pixel_deg`` (and colour), to reuse
        across images; its ``pixel_deg`` must match. Default None: digitise one.

    Returns
    -------
    GlareResult

    Raises
    ------
    ValueError
        For a non-2-D (or non-RGB) image, NaN/Inf or negative luminance, a non-positive
        ``pixel_deg`` or ``l_dmax_cd_m2``, an unknown method or precision, or an even kernel
        shape.

    Notes
    -----
    .. math::

       \\Delta L = \\max(L - L_{dmax}, 0), \\qquad
       L' = \\min(L + \\Delta L \\circledast K, \\; L_{dmax})

    An image with no pixel above ``L_dmax`` is returned unchanged (bit for bit).

    References
    ----------
    Yoshida et al. 2008, eq. 1 and §3; Spencer et al. 1995, §3.2.

    Examples
    --------
    >>> from glare import GaussianGlare
    >>> image = np.full((31, 31), 100.0)
    >>> image[15, 15] = 10_000.0
    >>> result = render_glare(image, GaussianGlare(sigma_deg=0.1), pixel_deg=0.05)
    >>> float(result.image.max()), round(float(result.excess_energy), 1)
    (220.0, 9780.0)
    """
    image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
    check_choice("method", method, METHODS)
    check_choice("precision", precision, PRECISIONS)
    glare_model = _resolve(model)
    colour = image.ndim == 3
    if kernel is None:
        shape = kernel_shape_for(image.shape) if kernel_shape is None else tuple(kernel_shape)
        digitised = glare_model.kernel(pixel_deg, shape, colour=colour)
    else:
        if not np.isclose(kernel.pixel_deg, pixel_deg, rtol=1e-12, atol=0):
            raise ValueError(
                f"kernel was digitised for pixel_deg = {kernel.pixel_deg!r}, not {pixel_deg!r}"
            )
        if colour and kernel.values.ndim == 3 and kernel.values.shape[2] != 3:
            raise ValueError(f"kernel must have 3 channels for an RGB image; got {kernel.shape}")
        digitised, shape = kernel, kernel.values.shape[:2]
    dtype = np.dtype(precision)
    parameters = {
        "pixel_deg": pixel_deg,
        "l_dmax_cd_m2": l_dmax,
        "method": method,
        "precision": precision,
        "kernel_shape": shape,
        "model": digitised.description,
    }

    work = image.astype(dtype, copy=False)
    channels = [work] if not colour else [work[..., c] for c in range(3)]
    kernels = digitised.values
    kernel_channels = (
        [kernels] if kernels.ndim == 2 else [kernels[..., c] for c in range(kernels.shape[2])]
    )
    excess_list, spread_list = [], []
    used: set[str] = set()
    for index, channel in enumerate(channels):
        excess = np.maximum(channel - dtype.type(l_dmax), dtype.type(0))
        k = kernel_channels[min(index, len(kernel_channels) - 1)].astype(dtype, copy=False)
        bright = excess > 0
        if bright.any():
            work_dtype = convolution_dtype(excess, k, dtype)
            used.add(work_dtype.name)
            spread = spread_fn(
                excess.astype(work_dtype, copy=False),
                k.astype(work_dtype, copy=False),
                bounding_box(bright),
            )
            # the spread of a non-negative excess by a non-negative kernel is non-negative;
            # FFT round-off is not
            spread = np.maximum(spread, 0.0).astype(dtype, copy=False)
        else:
            spread = np.zeros_like(excess)
        excess_list.append(excess)
        spread_list.append(spread)
    stack = (lambda arrays: arrays[0]) if not colour else (lambda arrays: np.stack(arrays, -1))
    excess = stack(excess_list)
    spread = stack(spread_list)

    if not (excess > 0).any():
        out = image.copy()
    elif method == "Yoshida2008":
        out = np.minimum(work + spread, dtype.type(l_dmax))
    elif method == "Spencer1995":
        out = np.minimum(work, dtype.type(l_dmax)) + spread
    else:
        raise ValueError(f"method must be one of {METHODS}; got {method!r}")

    parameters["convolution_precision"] = sorted(used) or [precision]
    axes = (0, 1)
    excess_energy = excess.sum(axis=axes, dtype=np.float64)
    kernel_sum = digitised.values.sum(axis=axes, dtype=np.float64)
    outside_kernel = excess_energy * np.asarray(digitised.energy_outside)
    outside_image = excess_energy * kernel_sum - spread.sum(axis=axes, dtype=np.float64)
    return GlareResult(
        image=out,
        excess=excess,
        spread=spread,
        kernel=digitised,
        excess_energy=excess_energy,
        energy_outside_kernel=outside_kernel,
        energy_outside_image=outside_image,
        parameters=parameters,
    )


def add_glare(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float = L_DMAX_YOSHIDA2008_CD_M2,
    method: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    precision: Literal["float64", "float32"] = "float64",
    kernel_shape: tuple[int, int] | None = None,
    tolerance_codes: float | None = 0.5,
    display=None,
) -> np.ndarray:
    """Add glare to a linear luminance image, doing only the work the scene and display need.

    Parameters
    ----------
    luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, method, precision
        As for :func:`render_glare`.
    kernel_shape
        ``None`` (default): planned from the scene. A shape renders exactly with that kernel,
        as :func:`render_glare` does (no plan).
    tolerance_codes
        Largest error allowed against the exact render, in codes of ``display``; default 0.5
        (half a code step cannot be seen). The work is planned by :func:`glare.plan_glare`
        (kernel reach, multi-resolution far tail) and the bound checked on the result.
        ``None`` or 0: the exact render with the full ``(2H - 1) × (2W - 1)`` kernel.
    display
        The display the error is counted on: a calibration, a :class:`glare.plan.Display`,
        or ``None`` for a 10-bit, gamma-2.2, 1000:1 display whose white is ``l_dmax_cd_m2``.

    Returns
    -------
    numpy.ndarray
        The image with glare, same shape as the input, dtype of ``precision``; an image with
        no pixel above ``l_dmax_cd_m2`` comes back as an unchanged copy (its own dtype), and
        no kernel is digitised for it.

    Raises
    ------
    ValueError
        As for :func:`render_glare` and :func:`glare.plan_glare`.

    See Also
    --------
    glare.plan_glare, glare.render_planned : the plan, and the result with its error bound.

    References
    ----------
    Yoshida et al. 2008, eq. 1 and §3; Spencer et al. 1995, §3.2.

    Examples
    --------
    >>> from glare import VosGlare
    >>> dim = np.full((9, 9), 50.0)
    >>> bool((add_glare(dim, VosGlare(), pixel_deg=0.1) == dim).all())
    True
    """
    image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
    l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
    if not (image > l_dmax).any():
        # nothing to spread: skip digitising a kernel, after checking the other arguments
        check_positive("pixel_deg", pixel_deg, unit="deg")
        check_choice("method", method, METHODS)
        check_choice("precision", precision, PRECISIONS)
        if kernel_shape is not None:
            check_kernel_shape(kernel_shape)
        _resolve(model)
        return image.copy()
    common = {
        "pixel_deg": pixel_deg,
        "l_dmax_cd_m2": l_dmax_cd_m2,
        "method": method,
        "precision": precision,
    }
    if kernel_shape is None and tolerance_codes:
        return render_planned(
            image, model, **common, tolerance_codes=tolerance_codes, display=display
        ).image
    return render_glare(image, model, **common, kernel_shape=kernel_shape).image
