"""Glare models: what the eye (or a game engine) does to a point of light, as a kernel.

Every model is a frozen dataclass subclassing :class:`~glare.base.GlareModel`, with a method
``kernel(pixel_deg, shape, *, colour)`` that returns a :class:`~glare.digitise.Kernel`; each
lives in a module named for its paper (:mod:`glare.yoshida2008`, :mod:`glare.spencer1995`,
:mod:`glare.wave`, :mod:`glare.hybrid`). Models are registered by name in
:data:`GLARE_MODELS` so that protocols and the command line can name them.
"""

from __future__ import annotations

import numpy as np

from ._validation import check_choice
from .base import GlareModel, TailBound, as_model
from .digitise import Kernel
from .hybrid import HybridGlare
from .spencer1995 import HALO_MAX_SPACING_DEG, PUPIL_RANGE_MM, TAIL_MARGIN, VosGlare
from .wave import WaveOpticsGlare
from .yoshida2008 import SIGMA_DEG_YOSHIDA2008, GaussianGlare

__all__ = [
    "GLARE_MODELS",
    "HALO_MAX_SPACING_DEG",
    "PUPIL_RANGE_MM",
    "SIGMA_DEG_YOSHIDA2008",
    "TAIL_MARGIN",
    "GaussianGlare",
    "GlareModel",
    "HybridGlare",
    "TailBound",
    "VosGlare",
    "WaveOpticsGlare",
    "digitise_kernel",
    "kernel",
    "make_model",
]


GLARE_MODELS: dict[str, type] = {
    "Yoshida2008": GaussianGlare,
    "gaussian": GaussianGlare,
    "Spencer1995": VosGlare,
    "vos": VosGlare,
    "Kakimoto2004": WaveOpticsGlare,
    "wave": WaveOpticsGlare,
    "hybrid": HybridGlare,
}


def make_model(method: str, **parameters) -> GlareModel:
    """Build a glare model by name from :data:`GLARE_MODELS`.

    Examples
    --------
    >>> make_model("vos", regime="mesopic").regime
    'mesopic'
    """
    check_choice("method", method, GLARE_MODELS)
    return GLARE_MODELS[method](**parameters)


def _resolve(model: GlareModel | str) -> GlareModel:
    if isinstance(model, str):
        return make_model(model)
    if isinstance(model, GlareModel) or callable(getattr(model, "kernel", None)):
        return as_model(model)
    raise ValueError(
        f"model must be a glare model (e.g. GaussianGlare(), VosGlare()) or one of "
        f"{', '.join(repr(m) for m in GLARE_MODELS)}; got {model!r}"
    )


def digitise_kernel(
    model: GlareModel | str, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False
) -> Kernel:
    """Digitise a glare model into a :class:`~glare.digitise.Kernel` with its energy account.

    Examples
    --------
    >>> k = digitise_kernel("vos", 0.1, (21, 21))
    >>> k.values.shape, round(float(k.energy_outside), 3)
    ((21, 21), 0.094)
    """
    return _resolve(model).kernel(pixel_deg, shape, colour=colour)


def kernel(model: GlareModel | str, pixel_deg: float, shape: tuple[int, int]) -> np.ndarray:
    """The luminance kernel of a model as a 2-D array (see :func:`digitise_kernel`).

    Parameters
    ----------
    model
        A model object or a name from :data:`GLARE_MODELS`.
    pixel_deg
        Visual angle of one pixel in degrees, > 0.
    shape
        Odd kernel shape ``(KH, KW)``.

    Examples
    --------
    >>> kernel(GaussianGlare(), 0.034, (5, 5)).shape
    (5, 5)
    """
    return digitise_kernel(model, pixel_deg, shape).values
