"""Adding glare to a linear HDR luminance image (Yoshida et al. 2008 §3; Spencer et al. 1995 §3.2).

Only light the display cannot show is spread: ``ΔL = max(L - L_dmax, 0)`` (Yoshida eq. 1) is
convolved with the glare kernel as a linear convolution (zero padding, no wrap-around) and
added back. Yoshida clamps the result to ``L_dmax``; Spencer keeps the displayable part of
each pixel and adds the spread excess without a clamp (values above ``L_dmax`` are the
"burn-out" Spencer §5 mentions, left to the tone mapper).
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from glarelab.glare._validation import (
    check_choice,
    check_image,
    check_pixel_deg,
    check_positive,
)
from glarelab.glare.models import GlareModel, _resolve
from glarelab.glare.models.cache import check_cache
from glarelab.glare.models.digitise import Kernel, check_kernel_shape
from glarelab.glare.rendering.compose import check_composition
from glarelab.glare.rendering.display import display_lut
from glarelab.glare.rendering.renderer import (
    MAX_LUMINANCE_CD_M2,
    MAX_RENDER_PIXEL_DEG,
    PRECISIONS,
    GlareRenderer,
    GlareResult,
    _renderer_for,
    check_render_memory,
    check_tolerance,
)

__all__ = [
    "L_DMAX_YOSHIDA2008_CD_M2",
    "GlareResult",
    "add_glare",
    "render_glare",
    "render_planned",
]

L_DMAX_YOSHIDA2008_CD_M2 = 220.0  # Yoshida 2008 §3: maximum luminance of a typical display


def render_glare(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float = L_DMAX_YOSHIDA2008_CD_M2,
    composition: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    precision: Literal["float64", "float32"] = "float64",
    kernel_shape: tuple[int, int] | None = None,
    kernel: Kernel | None = None,
    cache=None,
    method: None = None,
) -> GlareResult:
    """Add glare to a linear luminance image and account for every bit of energy.

    Parameters
    ----------
    luminance_cd_m2
        Linear luminance, cd/m², finite and >= 0: shape ``(H, W)``, or ``(H, W, 3)`` linear RGB
        whose channels are in cd/m² of a white of equal R, G, B.
    model
        A glare model (:class:`~glarelab.glare.GaussianGlare`,
        :class:`~glarelab.glare.VosGlare`) or its name.
    pixel_deg
        Visual angle of one pixel in degrees, in [1e-5, 10] (as the command line's
        ``--pixel-deg``; 1e-5° is 0.04 arcsec, far below the eye's resolution).
    l_dmax_cd_m2
        Maximum luminance the display shows, cd/m², > 0; default 220 (Yoshida §3).
    composition
        How the spread glare is put back: ``'Yoshida2008'`` (default):
        ``min(L + ΔL ⊛ K, L_dmax)``. ``'Spencer1995'``: ``min(L, L_dmax) + ΔL ⊛ K`` with no
        clamp.
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
    cache
        Where digitised kernels are kept between runs: ``None`` (default), the user's kernel
        cache (:mod:`glarelab.glare.models.cache`); ``False``, none; a
        :class:`glarelab.glare.models.cache.KernelCache`.
    method
        Removed: it was the composition rule, and every rule is also a glare model's name, so
        ``render_glare(image, "Spencer1995", method="Yoshida2008")`` read as a choice of model;
        any value is refused.

    Returns
    -------
    GlareResult

    Raises
    ------
    ValueError
        For a non-2-D (or non-RGB) image, NaN/Inf or negative luminance, a non-positive
        ``pixel_deg`` or ``l_dmax_cd_m2``, an unknown composition or precision, an even
        kernel shape, or an image whose render needs more memory than the system has
        (refused before anything is allocated, naming both sizes).
    TypeError
        For ``method=`` (its message names ``composition=``).

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
    >>> from glarelab.glare import GaussianGlare
    >>> image = np.full((31, 31), 100.0)
    >>> image[15, 15] = 10_000.0
    >>> result = render_glare(image, GaussianGlare(sigma_deg=0.1), pixel_deg=0.05)
    >>> float(result.image.max()), round(float(result.excess_energy), 1)
    (220.0, 9780.0)
    """
    image, renderer = _renderer_for(
        luminance_cd_m2,
        model,
        pixel_deg=pixel_deg,
        l_dmax_cd_m2=l_dmax_cd_m2,
        composition=composition,
        method=method,
        precision=precision,
        tolerance_codes=0,
        kernel_shape=kernel_shape,
        kernel=kernel,
        cache=cache,
    )
    return renderer.render(image)


def add_glare(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float = L_DMAX_YOSHIDA2008_CD_M2,
    composition: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    precision: Literal["float64", "float32"] = "float64",
    kernel_shape: tuple[int, int] | None = None,
    tolerance_codes: float | None = 0.5,
    display=None,
    cache=None,
    method: None = None,
) -> np.ndarray:
    """Add glare to a linear luminance image, doing only the work the scene and display need.

    Parameters
    ----------
    luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, composition, precision, method
        As for :func:`render_glare`.
    kernel_shape
        ``None`` (default): planned from the scene. A shape renders exactly with that kernel,
        as :func:`render_glare` does (no plan): a ``tolerance_codes`` other than the default
        or ``None``, or a ``display``, is then refused (the plan they are for is not made).
    tolerance_codes
        Largest error allowed against the exact render, in codes of ``display``; default 0.5
        (half a code step cannot be seen). The work is planned by :func:`glarelab.glare.plan_glare`
        (kernel reach, multi-resolution far tail) and the bound checked on the result.
        ``None`` or 0: the exact render with the full ``(2H - 1) × (2W - 1)`` kernel.
    display
        The display the error is counted on: a calibration, a
        :class:`glarelab.glare.Display`, or ``None`` for a 10-bit, gamma-2.2, 1000:1
        display whose white is ``l_dmax_cd_m2``.
    cache
        As for :func:`render_glare`: the second call with the same model, pixel size and
        image shape, in this process or another, reads its kernels from the cache.

    Returns
    -------
    numpy.ndarray
        The image with glare, same shape as the input, dtype of ``precision``; an image with
        no pixel above ``l_dmax_cd_m2`` comes back as an unchanged copy (its own dtype), and
        no kernel is digitised for it.

    Raises
    ------
    ValueError
        As for :func:`render_glare` and :func:`glarelab.glare.plan_glare`.

    See Also
    --------
    glarelab.glare.plan_glare, render_planned : the plan, and the result with its error bound.

    References
    ----------
    Yoshida et al. 2008, eq. 1 and §3; Spencer et al. 1995, §3.2.

    Examples
    --------
    >>> from glarelab.glare import VosGlare
    >>> dim = np.full((9, 9), 50.0)
    >>> bool((add_glare(dim, VosGlare(), pixel_deg=0.1) == dim).all())
    True
    """
    if isinstance(luminance_cd_m2, np.ndarray):  # refused before a scan of its pixels
        check_render_memory(luminance_cd_m2.shape)
    image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
    l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
    if l_dmax > MAX_LUMINANCE_CD_M2:  # as the renderer, which a dim image does not reach
        raise ValueError(
            f"l_dmax_cd_m2 must be at most {MAX_LUMINANCE_CD_M2:g} cd/m² (no display, and far "
            f"beyond any light); got {l_dmax:g}"
        )
    check_tolerance(tolerance_codes)  # also when a kernel shape or a dim image makes it moot
    if kernel_shape is not None and (tolerance_codes not in (None, 0, 0.5) or display is not None):
        given = "tolerance_codes" if tolerance_codes not in (None, 0, 0.5) else "display"
        raise ValueError(
            f"{given} beside kernel_shape={kernel_shape!r}: a kernel shape renders exactly with "
            f"that kernel (no plan), so the {given} the plan is made for would be ignored; give "
            "one of them"
        )
    if not (image > l_dmax).any():
        # nothing to spread: skip digitising a kernel, after checking the other arguments
        check_pixel_deg(pixel_deg, high=MAX_RENDER_PIXEL_DEG)
        check_composition(composition, method, where="add_glare")
        check_choice("precision", precision, PRECISIONS)
        if kernel_shape is not None:
            check_kernel_shape(kernel_shape, name="kernel_shape")
        display_lut(display, l_dmax)
        check_cache(cache)
        _resolve(model)
        return image.copy()
    renderer = GlareRenderer(
        model,
        pixel_deg=pixel_deg,
        shape=image.shape[:2],
        l_dmax_cd_m2=l_dmax_cd_m2,
        composition=composition,
        method=method,
        precision=precision,
        tolerance_codes=tolerance_codes if kernel_shape is None else 0,
        display=display,
        kernel_shape=kernel_shape,
        cache=cache,
    )
    return renderer._render(image, checked=True).image  # checked above: no second scan


def render_planned(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float = L_DMAX_YOSHIDA2008_CD_M2,
    composition: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    precision: Literal["float64", "float32"] = "float64",
    tolerance_codes: float = 0.5,
    display=None,
    log=None,
    cache=None,
    method: None = None,
) -> GlareResult:
    """Add glare as :func:`glarelab.glare.plan_glare` plans it, and bound the error reached: the
    one-call form of :meth:`GlareRenderer.render`.

    Parameters
    ----------
    luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, composition, tolerance_codes, display, method
        As for :func:`glarelab.glare.plan_glare`.
    precision
        ``'float64'`` or ``'float32'``, as for :func:`glarelab.glare.render_glare`.
    log
        Called with one line per step, or ``None``.
    cache
        As for :func:`glarelab.glare.render_glare`.

    Returns
    -------
    GlareResult

    Raises
    ------
    ValueError
        As for :func:`glarelab.glare.plan_glare`, and for an unknown precision.

    Examples
    --------
    >>> from glarelab.glare import VosGlare
    >>> image = np.full((64, 64), 50.0)
    >>> image[32, 32] = 1e5
    >>> result = render_planned(image, VosGlare(), pixel_deg=0.05, l_dmax_cd_m2=220.0)
    >>> result.error_bound_codes <= 0.5
    True
    """
    image, renderer = _renderer_for(
        luminance_cd_m2,
        model,
        pixel_deg=pixel_deg,
        l_dmax_cd_m2=l_dmax_cd_m2,
        composition=composition,
        method=method,
        precision=precision,
        tolerance_codes=tolerance_codes,
        display=display,
        log=log,
        cache=cache,
    )
    return renderer.render(image)
