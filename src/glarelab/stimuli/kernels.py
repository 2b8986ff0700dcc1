"""The glare kernels a paradigm's builder digitises, so a protocol is refused before a build.

Each paradigm says which kernels its builder makes (:class:`KernelUse`: the protocol's key of
the model's parameters, the model, the pixel angle and the kernel shape), and
``glarelab protocol check`` asks each model whether it can make that kernel
(:meth:`glarelab.glare.GlareModel.check_kernel`: the wave-optics aperture grid, Spencer's
renormalisation), so a build is not refused after minutes of rendering for what a second's
check finds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from glarelab.glare import GlareModel

__all__ = ["KernelUse", "check_kernels", "no_kernels"]


@dataclass(frozen=True)
class KernelUse:
    """A kernel a paradigm's builder digitises.

    Attributes
    ----------
    where
        The protocol's key of the model's parameters, for messages
        (``'glare.methods[2].parameters'``).
    model
        The glare model, made from the protocol.
    pixel_deg
        Visual angle of the kernel's pixels, degrees.
    shape
        The kernel's (odd) shape, pixels.
    colour
        Whether the colour kernel is made.
    """

    where: str
    model: GlareModel
    pixel_deg: float
    shape: tuple[int, int]
    colour: bool = False


def check_kernels(uses: Sequence[KernelUse]) -> list[str]:
    """What a build would refuse of a protocol's kernels, each asked of its model.

    Parameters
    ----------
    uses
        The paradigm's kernels (its stimuli entry's ``kernels(protocol)``).

    Returns
    -------
    list of str
        One line per kernel refused, naming its key; empty when a build would make all.

    Examples
    --------
    >>> from glarelab.glare import WaveOpticsGlare
    >>> wave = WaveOpticsGlare(pupil_mm=6.0, fresnel=True)
    >>> (problem,) = check_kernels([KernelUse("glare.parameters", wave, 0.01, (541, 541))])
    >>> problem[:73]
    'glare.parameters: the aperture grid would need 8748² samples (more than 8'
    >>> smaller = WaveOpticsGlare(pupil_mm=4.0, fresnel=True)
    >>> check_kernels([KernelUse("glare.parameters", smaller, 0.01, (541, 541))])
    []
    """
    problems = []
    for use in uses:
        try:
            use.model.check_kernel(use.pixel_deg, use.shape, colour=use.colour)
        except ValueError as error:
            problems.append(f"{use.where}: {error}")
    return problems


def no_kernels(protocol) -> list[KernelUse]:
    """``kernels`` of a paradigm whose kernels are not known before its build.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol (not read).

    Returns
    -------
    list
        Always empty.
    """
    return []
