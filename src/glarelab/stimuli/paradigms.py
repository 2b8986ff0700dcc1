"""The stimuli of each paradigm: one registry for the layer (see docs/extending.md).

A paradigm's stimulus module gives how its images are rendered (``build``), how a session draws
its first trial's images side by side (``first_row``, which ``glarelab protocol check`` reports
on the protocol's display), how a set's profile plots group its images, whether a protocol
shows images at all, the backgrounds its builder draws (which ``glarelab protocol check``
draws to refuse what a build would), and the glare kernels it digitises (which the check asks
each model whether it can make). Every entry names all six, so a new paradigm cannot
leave one out and be passed over silently; code outside the paradigms' modules finds an entry
through :func:`paradigm_stimuli`, which names the registry when the entry is missing.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from glarelab.protocols import Protocol
from glarelab.stimuli.backgrounds import BackgroundField
from glarelab.stimuli.kernels import KernelUse, no_kernels
from glarelab.stimuli.matching import (
    build_matching,
    matching_backgrounds,
    matching_kernels,
    matching_row,
)
from glarelab.stimuli.night import build_night, night_kernels, night_row, shows_scene
from glarelab.stimuli.shapes import ImageRow
from glarelab.stimuli.staircase import (
    build_staircase,
    staircase_backgrounds,
    staircase_kernels,
    staircase_row,
)

__all__ = [
    "PARADIGMS",
    "ImageRow",
    "ParadigmStimuli",
    "always_shows",
    "no_backgrounds",
    "no_kernels",
    "paradigm_stimuli",
    "register_paradigm",
]


@dataclass(frozen=True)
class ParadigmStimuli:
    """How a paradigm's stimuli are made and drawn.

    Attributes
    ----------
    build
        ``build(protocol, *, progress)``: the images (cd/m²) with their parameters, the set's
        geometry and parameters.
    first_row
        ``first_row(protocol, display_pixel_deg)``: the first trial's images
        (:class:`ImageRow`); None when the protocol shows no images.
    profile_groups
        (image kind, the key that names a group) of the set's profile plots; None: the
        paradigm's images have none (a sequence has its preview strips instead).
    shows
        ``shows(protocol)``: whether a protocol of the paradigm shows images (and so has a
        stimulus set; a questionnaire without a scene shows none).
    backgrounds
        ``backgrounds(protocol)``: the backgrounds the builder draws, in the order it draws
        them (:class:`glarelab.stimuli.backgrounds.BackgroundField`); :func:`no_backgrounds`
        for a paradigm that draws none.
    kernels
        ``kernels(protocol)``: the glare kernels the builder digitises
        (:class:`glarelab.stimuli.kernels.KernelUse`); :func:`~glarelab.stimuli.kernels.no_kernels`
        where none is known before the build (a rating scene's night pipeline plans its
        kernels per frame, from the adaptation).
    """

    build: Callable[..., dict]
    first_row: Callable[[Protocol, float], ImageRow | None]
    profile_groups: tuple[str, str] | None
    shows: Callable[[Protocol], bool]
    backgrounds: Callable[[Protocol], list[BackgroundField]]
    kernels: Callable[[Protocol], list[KernelUse]]


def always_shows(protocol: Protocol) -> bool:
    """``shows`` of a paradigm every protocol of which shows images.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol (not read).

    Returns
    -------
    bool
        Always True.
    """
    return True


def no_backgrounds(protocol: Protocol) -> list[BackgroundField]:
    """``backgrounds`` of a paradigm whose builder draws no protocol background.

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


PARADIGMS: dict[str, ParadigmStimuli] = {}


def register_paradigm(name: str, stimuli: ParadigmStimuli) -> None:
    """Register how the paradigm ``name``'s stimuli are made and drawn.

    Parameters
    ----------
    name
        The paradigm's name, as a protocol's ``paradigm`` gives it (not yet registered).
    stimuli
        Its entry: callable ``build``, ``first_row``, ``shows``, ``backgrounds`` and
        ``kernels``, and
        ``profile_groups``
        None or two names (image kind, key).

    Raises
    ------
    ValueError
        For a name already registered, or an entry whose functions are not callable or whose
        profile groups are neither None nor two names.
    """
    if name in PARADIGMS:
        raise ValueError(f"paradigm {name!r}: already registered in stimuli")
    if not isinstance(stimuli, ParadigmStimuli):
        raise ValueError(f"paradigm {name!r}: expected a ParadigmStimuli entry; got {stimuli!r}")
    for key in ("build", "first_row", "shows", "backgrounds", "kernels"):
        if not callable(getattr(stimuli, key)):
            raise ValueError(f"paradigm {name!r}: stimuli.{key} must be callable")
    groups = stimuli.profile_groups
    if groups is not None and not (
        isinstance(groups, tuple) and len(groups) == 2 and all(isinstance(g, str) for g in groups)
    ):
        raise ValueError(
            f"paradigm {name!r}: profile_groups must be None or (image kind, key); got {groups!r}"
        )
    PARADIGMS[name] = stimuli


register_paradigm(
    "matching",
    ParadigmStimuli(
        build_matching,
        matching_row,
        ("reference", "method"),
        always_shows,
        matching_backgrounds,
        matching_kernels,
    ),
)
register_paradigm(
    "staircase",
    ParadigmStimuli(
        build_staircase,
        staircase_row,
        ("glare", "context"),
        always_shows,
        staircase_backgrounds,
        staircase_kernels,
    ),
)
register_paradigm(
    "rating",
    ParadigmStimuli(build_night, night_row, None, shows_scene, no_backgrounds, night_kernels),
)


def paradigm_stimuli(protocol: Protocol) -> ParadigmStimuli:
    """The registry entry of ``protocol``'s paradigm.

    Parameters
    ----------
    protocol
        A validated protocol; its ``paradigm`` is looked up in :data:`PARADIGMS`.

    Returns
    -------
    ParadigmStimuli
        How the paradigm's stimuli are built and drawn.

    Raises
    ------
    ValueError
        When no stimuli are registered for the paradigm.
    """
    try:
        return PARADIGMS[protocol.paradigm]
    except KeyError:
        raise ValueError(
            f"paradigm {protocol.paradigm!r} has no stimuli registered in "
            f"glarelab.stimuli.paradigms.PARADIGMS ({', '.join(sorted(PARADIGMS))})"
        ) from None
