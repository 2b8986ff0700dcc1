"""Glare models: what the eye (or a game engine) does to a point of light, as a kernel.

Every model is a frozen dataclass subclassing :class:`~glarelab.glare.models.base.GlareModel`, with
a method ``kernel(pixel_deg, shape, *, colour)`` that returns a
:class:`~glarelab.glare.models.digitise.Kernel`; each lives in a module named for its paper
(:mod:`glarelab.glare.models.yoshida2008`, :mod:`glarelab.glare.models.spencer1995`,
:mod:`glarelab.glare.models.wave`, :mod:`glarelab.glare.models.hybrid`). Models are registered by
name in :data:`GLARE_MODELS` so that protocols and the command line can name them.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping

import numpy as np

from glarelab.glare._validation import check_choice
from glarelab.glare.models.base import GlareModel, TailBound, as_model
from glarelab.glare.models.digitise import Kernel
from glarelab.glare.models.spencer1995 import (
    HALO_MAX_SPACING_DEG,
    PUPIL_RANGE_MM,
    TAIL_MARGIN,
    VosGlare,
)
from glarelab.glare.models.yoshida2008 import SIGMA_DEG_YOSHIDA2008, GaussianGlare

__all__ = [
    "GLARE_MODELS",
    "HALO_MAX_SPACING_DEG",
    "PUPIL_RANGE_MM",
    "SIGMA_DEG_YOSHIDA2008",
    "TAIL_MARGIN",
    "GaussianGlare",
    "GlareModel",
    "TailBound",
    "VosGlare",
    "digitise_kernel",
    "kernel",
    "make_model",
]


class _Registry(Mapping):
    """Model classes by name, each module imported the first time its class is asked for
    (the wave-optics model needs colour-science, whose import takes a second or more)."""

    def __init__(self, entries: dict[str, str]) -> None:
        self._entries = entries

    def __getitem__(self, name: str) -> type:
        module, _, attribute = self._entries[name].rpartition(".")
        return getattr(importlib.import_module(module, __package__), attribute)

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"GLARE_MODELS({', '.join(self._entries)})"


GLARE_MODELS: Mapping[str, type] = _Registry(
    {
        "Yoshida2008": ".yoshida2008.GaussianGlare",
        "gaussian": ".yoshida2008.GaussianGlare",
        "Spencer1995": ".spencer1995.VosGlare",
        "vos": ".spencer1995.VosGlare",
        "Kakimoto2004": ".wave.WaveOpticsGlare",
        "wave": ".wave.WaveOpticsGlare",
        "hybrid": ".hybrid.HybridGlare",
    }
)
_LAZY = {"WaveOpticsGlare": ".wave", "HybridGlare": ".hybrid"}  # importable, imported on use


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __package__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def make_model(method: str, **parameters) -> GlareModel:
    """Build a glare model by name from :data:`GLARE_MODELS`.

    Parameters
    ----------
    method
        A model's name in :data:`GLARE_MODELS` (``'gaussian'``, ``'vos'``, ``'wave'``,
        ``'hybrid'``).
    parameters
        The model's constructor keywords, in its own units.

    Returns
    -------
    GlareModel
        The model.

    Raises
    ------
    ValueError
        For an unknown name, or (from the model) a parameter out of range.

    Examples
    --------
    >>> make_model("vos", regime="mesopic").regime
    'mesopic'
    """
    check_choice("method", method, GLARE_MODELS)
    return GLARE_MODELS[method](**parameters)


def _resolve(model: GlareModel | str, name: str = "model") -> GlareModel:
    """The model a caller's argument ``name`` names (an object, or a name of
    :data:`GLARE_MODELS`), its errors naming ``name``."""
    if isinstance(model, str):
        if model not in GLARE_MODELS:  # named as the caller's argument, not make_model's
            same = [name for name in GLARE_MODELS if name.lower() == model.strip().lower()]
            raise ValueError(
                f"{name} must be one of {', '.join(repr(m) for m in GLARE_MODELS)}; got "
                f"{model!r}" + (f" (names are case-sensitive: {same[0]!r})" if same else "")
            )
        return make_model(model)
    if isinstance(model, type):
        raise ValueError(
            f"{name} must be a glare model object, e.g. {model.__name__}(), not the class "
            f"{model.__name__} itself"
        )
    if isinstance(model, GlareModel) or callable(getattr(model, "kernel", None)):
        return as_model(model)
    raise ValueError(
        f"{name} must be a glare model (e.g. GaussianGlare(), VosGlare()) or one of "
        f"{', '.join(repr(m) for m in GLARE_MODELS)}; got {model!r}"
    )


def digitise_kernel(
    model: GlareModel | str,
    pixel_deg: float,
    shape: tuple[int, int],
    *,
    colour: bool = False,
    cache=None,
) -> Kernel:
    """Digitise a glare model into a :class:`~glarelab.glare.models.digitise.Kernel` with its
    energy account.

    Parameters
    ----------
    model
        A glare model, or its name in :data:`GLARE_MODELS`.
    pixel_deg
        Visual angle of one pixel in degrees, in [1e-5, 180].
    shape
        Odd kernel shape ``(KH, KW)``, pixels.
    colour
        Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
        luminance kernel ``(KH, KW)``; default False. The Gaussian, the same in every
        channel, gives its one ``(KH, KW)`` kernel either way.
    cache
        ``None`` (default) or ``True``: the kernel is read from (or kept in) the user's
        kernel cache (:mod:`glarelab.glare.models.cache`, off when ``GLARELAB_NO_CACHE`` is
        set); ``False``: always digitised; a :class:`glarelab.glare.models.cache.KernelCache`
        or a folder: that cache.

    Returns
    -------
    Kernel
        The kernel and its energy account.

    Examples
    --------
    >>> k = digitise_kernel("vos", 0.1, (21, 21))
    >>> k.values.shape, round(float(k.energy_outside), 3)
    ((21, 21), 0.094)
    """
    from glarelab.glare._validation import check_flag, check_pixel_deg
    from glarelab.glare.models.cache import resolve_cache
    from glarelab.glare.models.digitise import check_kernel_shape

    resolved = _resolve(model)
    check_pixel_deg(pixel_deg)  # before the cache builds a key of them
    colour = check_flag("colour", colour)
    shape = check_kernel_shape(shape)
    chosen = resolve_cache(cache)
    if chosen is None:
        return resolved.kernel(pixel_deg, shape, colour=colour)
    return chosen.kernel(resolved, pixel_deg, shape, colour=colour)


def kernel(model: GlareModel | str, pixel_deg: float, shape: tuple[int, int]) -> np.ndarray:
    """The luminance kernel of a model as a 2-D array (see :func:`digitise_kernel`).

    Parameters
    ----------
    model
        A model object or a name from :data:`GLARE_MODELS`.
    pixel_deg
        Visual angle of one pixel in degrees, in [1e-5, 180].
    shape
        Odd kernel shape ``(KH, KW)``.

    Examples
    --------
    >>> kernel(GaussianGlare(), 0.034, (5, 5)).shape
    (5, 5)
    """
    return digitise_kernel(model, pixel_deg, shape).values
