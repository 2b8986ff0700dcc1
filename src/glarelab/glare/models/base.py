"""What the renderer and the planner need from a glare model: :class:`GlareModel`.

Every model of :mod:`glarelab.glare` subclasses :class:`GlareModel`. It must digitise its kernel
(:meth:`GlareModel.kernel`); the other capabilities have safe defaults, so that a model which
says nothing about them is rendered exactly and described truthfully:

- :meth:`~GlareModel.tail_bound` (default ``None``): rigorous bounds on what a kernel cut to a
  square leaves out. Without them the planner neither cuts the kernel nor approximates its
  far tail.
- :attr:`~GlareModel.achromatic` (default ``False``): the kernel is the same in every colour
  channel, so an achromatic RGB scene needs one convolution.
- :meth:`~GlareModel.halo` (default: "not declared by the model"): what the model does with
  the lenticular halo, as the plan reports it.
- :meth:`~GlareModel.description`: the model and its parameters, for logs.

An object that only has a ``kernel`` method (the protocol of earlier versions) is wrapped by
:func:`as_model` with those defaults.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, fields, is_dataclass

import numpy as np

from glarelab.glare.models.digitise import Kernel

__all__ = ["GlareModel", "TailBound", "as_model"]


@dataclass(frozen=True)
class TailBound:
    """Upper bounds on what a kernel cut to a centred square leaves out, per radius.

    Attributes
    ----------
    peak
        Largest value of a kernel pixel outside the square (fraction of the source's energy).
    energy
        Energy of the PSF outside the square (fraction).
    renormalised
        Whether the model normalises its kernel over the support, so that cutting it also
        scales what is kept by ``1 / (1 - energy)``.
    kept
        The PSF's share inside the square, ``1 - energy``, where the model sums it to more
        digits than that difference keeps (a kernel holding 1e-9 of a wide Gaussian); None:
        ``1 - energy``.
    """

    peak: np.ndarray
    energy: np.ndarray
    renormalised: bool = False
    kept: np.ndarray | None = None


class GlareModel(abc.ABC):
    """Base class of the glare models: a kernel, and what the planner may rely on.

    Examples
    --------
    >>> from glarelab.glare import VosGlare, WaveOpticsGlare
    >>> VosGlare().achromatic, VosGlare(regime="mesopic").achromatic
    (True, False)
    >>> WaveOpticsGlare().halo()
    'none in this model'
    """

    @abc.abstractmethod
    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        """The kernel for pixels of ``pixel_deg`` degrees in an odd ``shape``.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether a kernel per colour channel ``(KH, KW, C)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.

        Returns
        -------
        Kernel
            The kernel, each channel summing to its PSF energy inside the support, with its
            energy account.
        """

    def tail_bound(
        self, pixel_deg: float, radius_px: np.ndarray, *, colour: bool = False
    ) -> TailBound | None:
        """Bounds on what a cut at each radius leaves out, or ``None`` (none known).

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
            (fractions of the source's energy); ``None`` when the model knows no bound.
        """
        return None

    def check_kernel(
        self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False
    ) -> None:
        """Refuse, before any work, a kernel this model cannot make at this size.

        ``protocol check`` calls it for every kernel a stimulus set's build would digitise, so
        what the build would refuse is refused by key, in a second. The default knows no such
        limit; a model with one (the wave-optics aperture grid, Spencer's renormalisation)
        checks it here as cheaply as it can.

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
            If :meth:`kernel` would refuse this size, with its message.
        """
        return None

    @property
    def achromatic(self) -> bool:
        """True when the colour kernel is the same in every channel."""
        return False

    def halo(self) -> str:
        """What the model does with the lenticular halo, in a few words."""
        return "not declared by the model"

    def description(self, colour: bool) -> dict:
        """The model's name and parameters, for logs.

        Parameters
        ----------
        colour
            Whether the kernel described is the colour one (recorded as ``colour``).

        Returns
        -------
        dict
            ``model`` (the class's name), the model's parameters and ``colour``.
        """
        parameters = (
            {f.name: getattr(self, f.name) for f in fields(self)} if is_dataclass(self) else {}
        )
        return {"model": type(self).__name__, **parameters, "colour": colour}


@dataclass(frozen=True)
class _Declared(GlareModel):
    """A model that only has a ``kernel`` method: rendered exactly, described truthfully."""

    wrapped: object

    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        return self.wrapped.kernel(pixel_deg, shape, colour=colour)

    def description(self, colour: bool) -> dict:
        return {"model": type(self.wrapped).__name__, "colour": colour}


def as_model(model: object) -> GlareModel:
    """``model`` as a :class:`GlareModel`: itself, or an object with a ``kernel`` method
    wrapped with the safe defaults (no tail bound, a colour kernel, halo not declared).

    Parameters
    ----------
    model
        A :class:`GlareModel`, or any object with a
        ``kernel(pixel_deg, shape, *, colour)`` method.

    Returns
    -------
    GlareModel
        ``model`` itself, or wrapped.

    Raises
    ------
    ValueError
        If ``model`` has no ``kernel`` method.
    """
    if isinstance(model, GlareModel):
        return model
    if callable(getattr(model, "kernel", None)):
        return _Declared(model)
    raise ValueError(
        "model must be a glare model (a glare.GlareModel such as GaussianGlare() or "
        f"VosGlare(), or an object with a kernel(pixel_deg, shape, *, colour) method); got "
        f"{model!r}"
    )
