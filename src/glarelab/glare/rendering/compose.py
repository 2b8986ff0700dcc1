"""Putting the spread excess back into the image: Yoshida's clamp or Spencer's sum.

``ΔL = max(L - L_dmax, 0)`` is the light the display cannot show (Yoshida et al. 2008 eq. 1).
After it is spread by the kernel (``S = ΔL ⊛ K``) the two methods compose differently:

- ``'Yoshida2008'``: ``min(L + S, L_dmax)`` (Yoshida §3): pixels at ``L_dmax`` cannot change.
- ``'Spencer1995'``: ``min(L, L_dmax) + S`` (Spencer §3.2, no clamp; values above ``L_dmax``
  are the "burn-out" of §5, left to the tone mapper).

Every render path composes through :func:`compose`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

__all__ = [
    "COMPOSITIONS",
    "METHODS",
    "Composition",
    "Method",
    "check_composition",
    "compose",
    "excess",
    "over_channels",
]

COMPOSITIONS = ("Yoshida2008", "Spencer1995")
"""How the spread excess is put back: the ``composition=`` of the render functions."""
Composition = Literal["Yoshida2008", "Spencer1995"]
METHODS = COMPOSITIONS  # the name :func:`compose` gives its argument
Method = Composition


def check_composition(composition: object, method: object = None, *, where: str) -> str:
    """The composition rule ``composition`` checked, and the render functions' removed
    ``method=`` keyword refused.

    ``method=`` named the composition rule, but every rule is also the name of a glare model
    (``GLARE_MODELS["Spencer1995"]`` is the Vos PSF), so ``render_glare(image, "Spencer1995",
    method="Yoshida2008")`` read as a model choice and ran with another meaning; the keyword
    is refused whatever it holds.

    Parameters
    ----------
    composition
        The composition rule, one of :data:`COMPOSITIONS`.
    method
        The removed keyword's value, as the caller received it; only None is taken.
    where
        The caller's name, which the error names (``"render_glare"``).

    Returns
    -------
    str
        ``composition``.

    Raises
    ------
    TypeError
        When ``method`` is given.
    ValueError
        For a composition that is not one of :data:`COMPOSITIONS`.

    Examples
    --------
    >>> check_composition("Spencer1995", where="render_glare")
    'Spencer1995'
    """
    if method is not None:
        raise TypeError(
            f"{where}: method={method!r} is not taken: the glare model is the second argument, "
            f"and how the spread glare is composed is composition= "
            f"({' or '.join(map(repr, COMPOSITIONS))})"
        )
    if composition not in COMPOSITIONS:
        raise ValueError(
            f"composition must be one of {', '.join(map(repr, COMPOSITIONS))}; got {composition!r}"
        )
    return str(composition)


def excess(planes: np.ndarray, l_dmax_cd_m2: float) -> np.ndarray:
    """``ΔL = max(L - L_dmax, 0)`` (Yoshida 2008 eq. 1), in the dtype of ``planes``.

    Parameters
    ----------
    planes
        Linear luminance, cd/m², any shape.
    l_dmax_cd_m2
        The display's maximum luminance ``L_dmax``, cd/m².

    Returns
    -------
    numpy.ndarray
        ``ΔL``, cd/m², the shape and dtype of ``planes``.

    Examples
    --------
    >>> excess(np.array([100.0, 300.0]), 220.0).tolist()
    [0.0, 80.0]
    """
    dtype = planes.dtype.type
    out = np.subtract(planes, dtype(l_dmax_cd_m2))
    return np.maximum(out, dtype(0), out=out)  # in place: one array, not two


def over_channels(values: np.ndarray, ufunc) -> np.ndarray:
    """``ufunc`` over the channels (the last axis) of ``(H, W, C)``, one pixel at a time.

    The channels are copied apart first (channel-major) and reduced element-wise: several
    times faster than ``ufunc.reduce(values, axis=2)`` or element-wise calls on the
    interleaved channels. One channel returns a view.

    Parameters
    ----------
    values
        ``(H, W, C)`` array.
    ufunc
        A binary ufunc (``np.minimum``, ``np.maximum``, ``np.logical_or``).

    Returns
    -------
    numpy.ndarray
        ``(H, W)``.

    Examples
    --------
    >>> values = np.array([[[1.0, 5.0, 3.0]]])
    >>> over_channels(values, np.minimum).tolist(), over_channels(values, np.maximum).tolist()
    ([[1.0]], [[5.0]])
    """
    if values.shape[-1] == 1:
        return values[..., 0]
    return ufunc.reduce(np.ascontiguousarray(np.moveaxis(values, -1, 0)), axis=0)


def compose(
    planes: np.ndarray,
    spread: np.ndarray,
    l_dmax_cd_m2: float,
    method: Method,
    *,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """The image with glare from the image ``planes`` and the spread excess ``spread``.

    Parameters
    ----------
    planes, spread
        Arrays of one dtype that broadcast together, cd/m².
    l_dmax_cd_m2
        Maximum luminance of the display, cd/m².
    method
        ``'Yoshida2008'`` (``min(L + S, L_dmax)``) or ``'Spencer1995'``
        (``min(L, L_dmax) + S``).
    out
        Where to write the result (may be ``planes`` itself), or ``None`` for a new array.

    Raises
    ------
    ValueError
        For an unknown method.

    Examples
    --------
    >>> L, S = np.array([100.0, 300.0]), np.array([50.0, 50.0])
    >>> compose(L, S, 220.0, "Yoshida2008").tolist(), compose(L, S, 220.0, "Spencer1995").tolist()
    ([150.0, 220.0], [150.0, 270.0])
    """
    l_dmax = np.result_type(planes, spread).type(l_dmax_cd_m2)
    if method == "Yoshida2008":
        out = np.add(planes, spread, out=out)
        return np.minimum(out, l_dmax, out=out)
    if method == "Spencer1995":
        out = np.minimum(planes, l_dmax, out=out)
        out += spread
        return out
    raise ValueError(f"method must be one of {METHODS}; got {method!r}")
