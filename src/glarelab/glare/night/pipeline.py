"""Night vision around the glare: adaptation, glare, acuity and colour in Luidolt's order.

:func:`render_night` takes a linear HDR scene (one image or a sequence of frames, cd/m²) and
returns what a display shows of it, frame by frame, in the order of Luidolt 2020's pipeline
(Fig. 4.1, §6 and Fig. 6.1):

1. **Temporal adaptation** (§5.1, eqs. 5.1-5.4; :mod:`glarelab.glare.night.adaptation`): the
   luminance of the frame around the gaze, and the adapted luminance ``L_i`` following it over
   time. Without this effect the eye is adapted at once (``L_i`` = the frame's luminance).
2. **Exposure**: the scene is scaled by ``adapted_display_cd_m2 / L_i``, so that an adapted
   eye sees the adapting luminance at ``adapted_display_cd_m2`` on the display. This departs
   from the words of §5.1, "This adaptation luminance L_i can then be applied to the image
   by multiplying it with the linear RGB values": multiplying by ``L_i`` would make a bright
   scene brighter still and a dark one darker, the opposite of adaptation; the suite divides
   by it, as an exposure does (Krawczyk et al. 2005, whom §5.1 follows, scale by the inverse
   of the adapting luminance). A scale commutes with the glare's convolution and the blur's
   weights, so scaling first and stating the display's maximum in display units is Luidolt's
   order with tone mapping moved forward.
3. **Glare** (§5.2; any model of :data:`glarelab.glare.GLARE_MODELS`): its pupil from the adapted
   luminance (Moon & Spencer, :func:`glarelab.glare.models.eye.pupil_diameter_mm`, as Ritschel et
   al. 2009; Luidolt measures it with an eye tracker) and, for the Vos PSF, its regime (Spencer
   §3.1); the excess over the display's maximum spread and clamped (Yoshida eq. 1). Without glare
   the excess is clipped, as the display clips it.
4. **Acuity** (§5.3, eqs. 5.14-5.16; :mod:`glarelab.glare.night.acuity`): each pixel blurred by
   the σ of its scene luminance (display luminance / exposure), in CIE L* for the display's white.
5. **Scotopic colour** (§5.4, eq. 5.18, "after tone mapping";
   :mod:`glarelab.glare.night.scotopic`): the blend towards the tinted rod image by σ(``L_i``),
   or Spencer's 70 % desaturation.

The output is linear display RGB in cd/m² (channels of a white of equal R, G, B), within
``[0, display_max_cd_m2]``: never negative, never NaN, from black frames to 1e9 cd/m² suns.

References
----------
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, Fig. 4.1, ch. 5, §6.
Spencer et al. (1995), §3.1, §5; Yoshida et al. (2008), eq. 1; Krawczyk et al. (2005);
Ritschel, T. et al. (2009). Temporal glare. Eurographics.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from glarelab.glare._validation import (
    check_choice,
    check_flag,
    check_image,
    check_in_range,
    check_positive,
)
from glarelab.glare.models import _resolve
from glarelab.glare.models.base import GlareModel
from glarelab.glare.models.eye import Regime, pupil_diameter_mm, regime
from glarelab.glare.models.spencer1995 import VosGlare
from glarelab.glare.night.acuity import (
    BLUR_METHODS,
    LEVELS_PER_OCTAVE,
    MIN_LUMINANCE_CD_M2,
    SIGMA_METHODS,
    acuity_blur,
)
from glarelab.glare.night.adaptation import (
    ADAPTATION_MEANS,
    TAU_CONE_S,
    TAU_ROD_S,
    WINDOW_SIGMA_DEG,
    adaptation_luminance,
    frame_luminance,
    gaze_falloff,
)
from glarelab.glare.night.scotopic import METHODS as SCOTOPIC_METHODS
from glarelab.glare.night.scotopic import SPENCER1995_DESATURATION, scotopic_colour
from glarelab.glare.rendering.compose import COMPOSITIONS
from glarelab.glare.rendering.renderer import GlareRenderer

__all__ = [
    "EFFECTS",
    "PUPIL_STEP_MM",
    "NightResult",
    "adapted_model",
    "render_night",
]

EFFECTS = ("adaptation", "glare", "acuity", "scotopic")  # Luidolt 2020 ch. 4, in his order
PUPIL_STEP_MM = 0.1  # pupils are rounded to this, so that a sequence reuses its kernels


@dataclass(frozen=True)
class NightResult:
    """What :func:`render_night` made of a scene, frame by frame.

    Attributes
    ----------
    frames
        Display RGB (cd/m²), ``(H, W, 3)`` per frame: one array for one image, a list for a
        sequence.
    targets_cd_m2
        ``(N,)`` each frame's luminance around the gaze (eq. 5.1, §5.1).
    adaptation_cd_m2
        ``(N,)`` the adapted luminance ``L_i`` (eq. 5.2).
    exposure
        ``(N,)`` display cd/m² per scene cd/m².
    pupil_mm
        ``(N,)`` the pupil each frame's glare was rendered for, mm: from the adapted luminance
        when ``pupil_from_adaptation`` sets it (the Vos PSF in the photopic regime, which
        has no halo for it to drop, takes the regime alone), else the model's own
        (:func:`model_pupil_mm`); NaN without glare, or for a model without a pupil (the
        Gaussian).
    models
        The glare model of each frame (None without glare).
    error_bound_codes
        ``(N,)`` the glare renderer's error bound, display codes.
    effects
        The effects applied.
    """

    frames: np.ndarray | list[np.ndarray]
    targets_cd_m2: np.ndarray
    adaptation_cd_m2: np.ndarray
    exposure: np.ndarray
    pupil_mm: np.ndarray
    models: list = field(repr=False)
    error_bound_codes: np.ndarray
    effects: tuple[str, ...]


def _at_default(value, default) -> bool:
    """Whether an option holds its default (None, a flag, a name or a number)."""
    if default is None or isinstance(default, bool):
        return value is default
    return isinstance(value, str | int | float | np.number) and value == default


def takes_eye_state(model) -> bool:
    """Whether :func:`adapted_model` sets anything of a model: a ``pupil_mm`` or a
    ``regime`` of its own or of a model inside it (``HybridGlare.wave``).

    Parameters
    ----------
    model : glarelab.glare.GlareModel
        A glare model.

    Returns
    -------
    bool
        False for the Gaussian (and a model that is not a dataclass).
    """
    return has_eye_field(model, "pupil_mm") or has_eye_field(model, "regime")


def model_pupil_mm(model) -> float:
    """The pupil a glare model is made for, mm: its ``pupil_diameter`` (the wave-optics
    model's, given or from its field luminance), its ``pupil_mm``, or that of a model inside
    it (``HybridGlare.wave``); NaN for none (the Gaussian, a Vos PSF without a pupil).

    Parameters
    ----------
    model : glarelab.glare.GlareModel or None
        A glare model.

    Returns
    -------
    float
        The pupil diameter, mm, or NaN.

    Examples
    --------
    >>> from glarelab.glare import GaussianGlare, VosGlare
    >>> model_pupil_mm(VosGlare(regime="mesopic", pupil_mm=4.0)), model_pupil_mm(GaussianGlare())
    (4.0, nan)
    """
    if model is None or not dataclasses.is_dataclass(model):
        return math.nan
    for name in ("pupil_diameter", "pupil_mm"):
        value = getattr(model, name, None)
        if value is not None:
            return float(value)
    for spec in dataclasses.fields(model):
        inner = getattr(model, spec.name)
        if isinstance(inner, GlareModel):
            found = model_pupil_mm(inner)
            if not math.isnan(found):
                return found
    return math.nan


def frame_pupil_mm(adaptation_luminance_cd_m2: float, step_mm: float = PUPIL_STEP_MM) -> float:
    """The Moon & Spencer pupil of an adapted luminance rounded to ``step_mm``, as
    :func:`adapted_model` gives it."""
    pupil = float(pupil_diameter_mm(adaptation_luminance_cd_m2))
    return round(round(pupil / step_mm) * step_mm, 6)


def given_eye_state(model) -> str | None:
    """What a model (or a model inside it, ``HybridGlare.wave``) was given of the pupil that
    each frame sets (``'pupil_mm=4.0'``, or the ``field_luminance_cd_m2`` that sets a wave
    model's pupil), else None.

    Parameters
    ----------
    model : glarelab.glare.GlareModel
        A glare model.

    Returns
    -------
    str or None
        ``'NAME=VALUE'`` for a message, or None.
    """
    if not dataclasses.is_dataclass(model):
        return None
    if getattr(model, "pupil_mm", None) is not None:
        return f"pupil_mm={model.pupil_mm!r}"
    names = {f.name: f for f in dataclasses.fields(model)}
    spec = names.get("field_luminance_cd_m2")
    if spec is not None and model.field_luminance_cd_m2 != spec.default:
        return f"field_luminance_cd_m2={model.field_luminance_cd_m2!r}"
    for name in names:
        inner = getattr(model, name)
        if isinstance(inner, GlareModel):
            found = given_eye_state(inner)
            if found is not None:
                return found
    return None


def eye_state_model(
    model: GlareModel, *, pupil_mm: float | None, regime: Regime | None
) -> GlareModel:
    """A glare model with an eye state: a pupil and a Vos regime, where it has them.

    Parameters
    ----------
    model
        A glare model. Fields it has are replaced: ``pupil_mm`` (and the field luminance
        that would otherwise set it, reset to its default), ``regime`` (the Vos PSF's), and
        those of a model inside it (``HybridGlare.wave``) likewise. A model without them (the
        Gaussian) is returned as it is.
    pupil_mm
        The pupil diameter, mm, or None to leave the pupil as it is.
    regime
        ``'photopic'``, ``'mesopic'`` or ``'scotopic'`` (Spencer §3.1), or None to leave it.

    Returns
    -------
    GlareModel
        The model of that eye state; a :class:`~glarelab.glare.VosGlare` through
        :meth:`~glarelab.glare.VosGlare.with_eye_state`, which leaves what shapes a halo unset
        where the state has none.

    Examples
    --------
    >>> from glarelab.glare import HybridGlare
    >>> m = eye_state_model(HybridGlare(), pupil_mm=4.0, regime="scotopic")
    >>> m.regime, m.wave.pupil_mm
    ('scotopic', 4.0)
    """
    if not dataclasses.is_dataclass(model):
        return model
    names = {f.name for f in dataclasses.fields(model)}
    changes: dict[str, object] = {}
    if pupil_mm is not None and "pupil_mm" in names:
        changes["pupil_mm"] = pupil_mm
        if "field_luminance_cd_m2" in names:  # the pupil is given: what set it is not used
            changes["field_luminance_cd_m2"] = type(model).field_luminance_cd_m2
    if regime is not None and "regime" in names:
        changes["regime"] = regime
    for name in names:
        value = getattr(model, name)
        if isinstance(value, GlareModel) and dataclasses.is_dataclass(value):
            changes[name] = eye_state_model(value, pupil_mm=pupil_mm, regime=regime)
    if isinstance(model, VosGlare):  # a frame without a halo leaves what shapes it unset
        return model.with_eye_state(**changes) if changes else model
    return dataclasses.replace(model, **changes) if changes else model


def has_eye_field(model: GlareModel, name: str) -> bool:
    """Whether a model, or a model inside it (``HybridGlare.wave``), has the field ``name``
    (``'pupil_mm'``, ``'regime'``)."""
    if not dataclasses.is_dataclass(model):
        return False
    for spec in dataclasses.fields(model):
        if spec.name == name:
            return True
        inner = getattr(model, spec.name)
        if isinstance(inner, GlareModel) and has_eye_field(inner, name):
            return True
    return False


def adapted_model(
    model: GlareModel, adaptation_luminance_cd_m2: float, *, pupil_step_mm: float = PUPIL_STEP_MM
) -> GlareModel:
    """A glare model with the eye state of an adaptation luminance.

    Parameters
    ----------
    model
        A glare model. Fields it has are replaced (:func:`eye_state_model`): ``pupil_mm`` by
        the Moon & Spencer pupil of the luminance (rounded to ``pupil_step_mm``), ``regime``
        (the Vos PSF's) by the luminance's regime (Spencer §3.1), and a nested model
        (``HybridGlare.wave``) likewise. A model without them (the Gaussian) is returned as
        it is.
    adaptation_luminance_cd_m2
        The adapted luminance, cd/m², >= 0.
    pupil_step_mm
        Pupils are rounded to this (default 0.1 mm) to reuse kernels across frames.

    Examples
    --------
    >>> from glarelab.glare import VosGlare
    >>> m = adapted_model(VosGlare(), 0.05)
    >>> m.regime, m.pupil_mm
    ('mesopic', 5.3)
    """
    luminance = float(
        check_image("adaptation_luminance_cd_m2", [[adaptation_luminance_cd_m2]])[0, 0]
    )
    step = check_positive("pupil_step_mm", pupil_step_mm, unit="mm")
    return eye_state_model(
        model, pupil_mm=frame_pupil_mm(luminance, step), regime=regime(luminance)
    )


def render_night(
    scene_cd_m2: np.ndarray | Sequence[np.ndarray],
    *,
    pixel_deg: float,
    effects: Sequence[str] = EFFECTS,
    glare_model: GlareModel | str | None = None,
    display_max_cd_m2: float = 100.0,
    adapted_display_cd_m2: float = 10.0,
    frame_time_s: float | Sequence[float] | None = None,
    gaze_px: tuple[float, float] | Sequence[tuple[float, float] | None] | None = None,
    initial_adaptation_cd_m2: float | None = None,
    pupil_from_adaptation: bool = True,
    window_sigma_deg: float = WINDOW_SIGMA_DEG,
    glare_falloff_deg: float | None = None,
    adaptation_mean: Literal["log", "arithmetic"] = "log",
    tau_rod_s: float = TAU_ROD_S,
    tau_cone_s: float = TAU_CONE_S,
    glare_method: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    tolerance_codes: float = 0.5,
    acuity_method: Literal["Krawczyk2005", "Luidolt2020"] = "Krawczyk2005",
    blur: Literal["layers", "separable", "exact"] = "layers",
    levels_per_octave: int = LEVELS_PER_OCTAVE,
    acuity_space: Literal["lightness", "linear"] = "lightness",
    scotopic_method: Literal["Luidolt2020", "Spencer1995"] = "Luidolt2020",
    desaturation: float = SPENCER1995_DESATURATION,
    colourspace: str = "ITU-R BT.709",
    progress=None,
) -> NightResult:
    """Glare and night vision of a linear HDR scene, in Luidolt's order (see the module notes).

    Parameters
    ----------
    scene_cd_m2
        One ``(H, W)`` luminance or ``(H, W, 3)`` linear RGB image (cd/m², channels of a white
        of equal R, G, B), or a sequence (list) of such frames of one shape.
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    effects
        Which of ``'adaptation'``, ``'glare'``, ``'acuity'``, ``'scotopic'`` to apply; default
        all. The exposure is always applied, from the luminance around the gaze
        (``gaze_px``, ``window_sigma_deg``, ``adaptation_mean``, ``colourspace``). An option
        of an effect left out, set away from its default, is refused, as it would be ignored
        (a glare model without ``'glare'``, an initial adaptation without ``'adaptation'``, an
        acuity method without ``'acuity'``, a scotopic method without ``'scotopic'``): an
        ablation of a pipeline gives only the options of the effects it keeps. So is an
        option that the chosen effect's method would ignore (``desaturation`` with Luidolt's
        scotopic colour, ``levels_per_octave`` with a blur other than ``'layers'``).
    glare_model
        The glare model (an object or a name of :data:`glarelab.glare.GLARE_MODELS`); default
        the Vos PSF (Spencer 1995).
    display_max_cd_m2
        The display's white, cd/m², > 0: the most it shows (``L_dmax``); default 100.
    adapted_display_cd_m2
        Display luminance of the adapting luminance, cd/m², in (0, ``display_max_cd_m2``];
        default 10.
    frame_time_s
        Duration of each frame (a number, or one per frame), seconds; needed for a sequence
        with adaptation. One frame without ``initial_adaptation_cd_m2`` is adapted to at once,
        so nothing evolves: ``frame_time_s``, ``tau_rod_s`` and ``tau_cone_s`` are refused
        there.
    gaze_px
        ``(row, column)`` of the gaze, one for all frames or one per frame (None: the whole
        frame alike); it may lie outside the frame (a look off the screen: the adaptation
        window's weights then fall on the frame's nearer side, as
        :func:`glarelab.glare.night.adaptation.frame_luminance` weighs them).
    initial_adaptation_cd_m2
        Adapted luminance before the first frame, cd/m²; default: adapted to the first frame.
    pupil_from_adaptation
        Set the glare model's pupil (and Vos regime) from ``L_i`` (:func:`adapted_model`);
        default True. A model given a ``pupil_mm`` of its own is then refused (the pupil
        would be replaced every frame): give False to keep it. False is refused for a model
        without a pupil or regime (the Gaussian), which it would not change.
    window_sigma_deg, adaptation_mean, tau_rod_s, tau_cone_s
        Adaptation (:func:`glarelab.glare.night.adaptation.frame_luminance`, eqs. 5.2-5.4);
        the window and the mean also set the exposure without the effect ``'adaptation'``.
        ``window_sigma_deg`` weighs the luminance around a gaze: without one it is refused
        away from its default (every pixel counts alike).
    glare_falloff_deg
        σ of Luidolt's Gaussian falloff around the gaze, degrees (§5.2.3): the glared frame
        is blended with the unglared one by the falloff's weight
        (:func:`glarelab.glare.night.adaptation.gaze_falloff`); needs a gaze. Default None:
        the glare over the whole frame alike.
    glare_method, tolerance_codes
        Glare composition (``'Yoshida2008'`` clamp or ``'Spencer1995'`` sum) and the
        renderer's error tolerance in display codes (:class:`glarelab.glare.GlareRenderer`).
    acuity_method, blur, levels_per_octave, acuity_space
        Acuity (:func:`glarelab.glare.night.acuity.acuity_blur`); the lightness is taken for the
        display's white. ``levels_per_octave`` only with ``blur='layers'``.
    scotopic_method, desaturation
        Colour (:func:`glarelab.glare.night.scotopic.scotopic_colour`); ``desaturation``
        only with the effect ``'scotopic'`` and ``scotopic_method='Spencer1995'``.
    colourspace
        The RGB colourspace of the scene and the display; default Rec. 709.
    progress
        ``progress(done, total, what)`` after each frame, or None.

    Returns
    -------
    NightResult

    Raises
    ------
    ValueError
        For a bad image or sequence (empty, shapes differ, negative or non-finite values),
        an unknown effect or method, a bad number, or an option that would be ignored (that of
        an effect left out), each named.

    Examples
    --------
    >>> scene = np.full((32, 48, 3), 0.02)
    >>> scene[10:12, 20:22] = 5e4  # a lamp in a dark street
    >>> night = render_night(scene, pixel_deg=0.05, display_max_cd_m2=100.0)
    >>> night.frames.shape, bool(night.frames.max() <= 100.0), night.pupil_mm.tolist()
    ((32, 48, 3), True, [5.7])
    """
    frames, single = _frames(scene_cd_m2)
    n = len(frames)
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    # the time constants judged here, before frame_time_s: a bad one is named even where
    # another argument is missing too
    tau_rod_s = check_positive("tau_rod_s", tau_rod_s, unit="s")
    tau_cone_s = check_positive("tau_cone_s", tau_cone_s, unit="s")
    if initial_adaptation_cd_m2 is not None:  # judged by itself too
        initial_adaptation_cd_m2 = check_in_range(
            "initial_adaptation_cd_m2", initial_adaptation_cd_m2, 0.0, math.inf, unit="cd/m²",
            high_inclusive=False,
        )  # fmt: skip
    if isinstance(effects, str):
        raise ValueError(f"effects = {effects!r}: must be a sequence of names of {EFFECTS}")
    chosen = tuple(effects)
    for effect in chosen:
        check_choice("effects", effect, EFFECTS)
    twice = sorted({e for e in chosen if chosen.count(e) > 1})
    if twice:
        raise ValueError(f"effects = {chosen!r}: {', '.join(twice)} given twice; each once")
    # named as the caller gave them, not as the renderer's composition or the blur's space
    check_choice("glare_method", glare_method, COMPOSITIONS)
    check_choice("acuity_space", acuity_space, ("lightness", "linear"))
    check_flag("pupil_from_adaptation", pupil_from_adaptation)
    options = {  # each effect's options, with their defaults: unused where it is left out
        "adaptation": {
            "initial_adaptation_cd_m2": (initial_adaptation_cd_m2, None),
            "frame_time_s": (frame_time_s, None),
            "tau_rod_s": (tau_rod_s, TAU_ROD_S),
            "tau_cone_s": (tau_cone_s, TAU_CONE_S),
        },
        "glare": {
            "glare_model": (glare_model, None),
            "pupil_from_adaptation": (pupil_from_adaptation, True),
            "glare_falloff_deg": (glare_falloff_deg, None),
            "glare_method": (glare_method, "Yoshida2008"),
            "tolerance_codes": (tolerance_codes, 0.5),
        },
        "acuity": {
            "acuity_method": (acuity_method, "Krawczyk2005"),
            "blur": (blur, "layers"),
            "levels_per_octave": (levels_per_octave, LEVELS_PER_OCTAVE),
            "acuity_space": (acuity_space, "lightness"),
        },
        "scotopic": {"scotopic_method": (scotopic_method, "Luidolt2020")},
    }
    for effect in EFFECTS:
        for name, (value, default) in options[effect].items():
            if effect not in chosen and not _at_default(value, default):
                raise ValueError(
                    f"{name}={value!r:.80}: the effect {effect!r} is left out of effects="
                    f"{chosen!r}, so it would be ignored; add {effect!r} to effects or leave "
                    f"{name} at its default ({default!r})"
                )
    if "adaptation" in chosen and n == 1 and initial_adaptation_cd_m2 is None:
        for name in ("frame_time_s", "tau_rod_s", "tau_cone_s"):  # nothing evolves
            value, default = options["adaptation"][name]
            if not _at_default(value, default):
                raise ValueError(
                    f"{name}={value!r}: one frame without initial_adaptation_cd_m2 is adapted "
                    "to at once, nothing evolves, so it would be ignored; give "
                    "initial_adaptation_cd_m2 (or a sequence of frames), or leave "
                    f"{name} at its default ({default!r})"
                )
    no_gaze = gaze_px is None or (
        isinstance(gaze_px, list) and all(gaze is None for gaze in gaze_px)
    )
    check_positive("window_sigma_deg", window_sigma_deg, unit="deg")
    if no_gaze and not _at_default(window_sigma_deg, WINDOW_SIGMA_DEG):
        raise ValueError(
            f"window_sigma_deg={window_sigma_deg!r:.40} without a gaze (gaze_px): the window "
            "around the gaze weighs the luminance, and without one every pixel counts alike, "
            f"so it would be ignored; give gaze_px or leave it at {WINDOW_SIGMA_DEG!r}"
        )
    if "acuity" in chosen and blur != "layers" and levels_per_octave != LEVELS_PER_OCTAVE:
        raise ValueError(
            f"levels_per_octave={levels_per_octave!r} with blur={blur!r}: it spaces the "
            f"'layers' ladder, which that blur does not use; leave it at {LEVELS_PER_OCTAVE}"
        )
    if frame_time_s is not None and not np.isscalar(frame_time_s):
        if len(frame_time_s) != n:
            raise ValueError(
                f"frame_time_s: {len(frame_time_s)} durations for {n} frames; give one per "
                "frame (or one number for all)"
            )
    l_dmax = check_positive("display_max_cd_m2", display_max_cd_m2, unit="cd/m²")
    key = check_in_range(
        "adapted_display_cd_m2", adapted_display_cd_m2, 0.0, l_dmax, unit="cd/m²",
        low_inclusive=False,
    )  # fmt: skip
    check_choice("acuity_method", acuity_method, SIGMA_METHODS)
    check_choice("blur", blur, BLUR_METHODS)
    check_choice("adaptation_mean", adaptation_mean, ADAPTATION_MEANS)
    check_choice("scotopic_method", scotopic_method, SCOTOPIC_METHODS)
    if desaturation != SPENCER1995_DESATURATION and (
        "scotopic" not in chosen or scotopic_method != "Spencer1995"
    ):
        raise ValueError(
            f"desaturation = {desaturation!r}: only Spencer's scotopic colour takes it "
            "(effects with 'scotopic' and scotopic_method='Spencer1995'); it would be ignored"
        )
    gazes = _gazes(gaze_px, n)
    targets = np.array(
        [
            frame_luminance(
                f, pixel_deg=pixel_deg, gaze_px=g, window_sigma_deg=window_sigma_deg,
                mean=adaptation_mean, colourspace=colourspace,
            )
            for f, g in zip(frames, gazes, strict=True)
        ]
    )  # fmt: skip
    if "adaptation" in chosen:
        if frame_time_s is None and (n > 1 or initial_adaptation_cd_m2 is not None):
            raise ValueError(
                "frame_time_s is needed to adapt over a sequence (or from an initial state): "
                "give the duration of each frame in seconds"
            )
        adapted = adaptation_luminance(
            targets,
            0.0 if frame_time_s is None else frame_time_s,
            initial_cd_m2=initial_adaptation_cd_m2,
            tau_rod_s=tau_rod_s,
            tau_cone_s=tau_cone_s,
        )
    else:
        adapted = targets.copy()
    exposure = key / np.maximum(adapted, MIN_LUMINANCE_CD_M2)
    base = None
    if "glare" in chosen:
        base = _resolve(glare_model if glare_model is not None else "vos", "glare_model")
        if not pupil_from_adaptation and not takes_eye_state(base):
            raise ValueError(
                f"pupil_from_adaptation=False with glare_model={glare_model!r:.80}: the model "
                "has no pupil or regime for the adaptation to set, so it would be ignored; "
                "leave it True"
            )
        given = given_eye_state(base)
        if pupil_from_adaptation and given is not None:  # it would be replaced every frame
            raise ValueError(
                f"glare_model has {given}, which pupil_from_adaptation=True replaces by each "
                "frame's pupil (from its adaptation luminance): leave it unset, or give "
                "pupil_from_adaptation=False to keep it"
            )
    renderers: dict = {}
    out_frames, pupils, models, bounds = [], [], [], []
    for index, (frame, level, scale) in enumerate(zip(frames, adapted, exposure, strict=True)):
        rgb = frame if frame.ndim == 3 else np.repeat(frame[..., None], 3, axis=2)
        display = rgb.astype(np.float64) * scale
        model, bound = None, 0.0
        if base is not None:
            model = adapted_model(base, float(level)) if pupil_from_adaptation else base
            renderer = renderers.get(model)
            if renderer is None:
                renderer = GlareRenderer(
                    model, pixel_deg=pixel_deg, shape=display.shape[:2], l_dmax_cd_m2=l_dmax,
                    composition=glare_method, tolerance_codes=tolerance_codes,
                )  # fmt: skip
                renderers[model] = renderer
            result = renderer.render(display)
            glared = np.asarray(result.image, dtype=np.float64)
            if glare_falloff_deg is not None:
                if gazes[index] is None:
                    raise ValueError("glare_falloff_deg needs a gaze: give gaze_px")
                rows, cols = gaze_falloff(
                    display.shape[:2], pixel_deg=pixel_deg, gaze_px=gazes[index],
                    sigma_deg=glare_falloff_deg,
                )  # fmt: skip
                shown = np.minimum(display, l_dmax)
                glared = shown + (rows[:, None, None] * cols[None, :, None]) * (glared - shown)
            display, bound = glared, result.error_bound_codes
        display = np.minimum(display, l_dmax)  # what the display can show (Spencer's sum too)
        if "acuity" in chosen:
            display = acuity_blur(
                display, pixel_deg=pixel_deg, method=acuity_method, blur=blur,
                space=acuity_space, luminance_scale=1.0 / scale, colourspace=colourspace,
                white_cd_m2=l_dmax if acuity_space == "lightness" else None,
                levels_per_octave=levels_per_octave if blur == "layers" else None,
            )  # fmt: skip
        if "scotopic" in chosen:
            options = (
                {"adaptation_luminance_cd_m2": float(level), "colourspace": colourspace}
                if scotopic_method == "Luidolt2020"
                else {"desaturation": desaturation}
            )
            display = scotopic_colour(display, method=scotopic_method, **options)
        out_frames.append(np.clip(display, 0.0, l_dmax))
        if model is None or not has_eye_field(base, "pupil_mm"):
            pupils.append(math.nan)
        elif pupil_from_adaptation:  # the eye's, which a photopic Vos PSF does not take
            pupils.append(frame_pupil_mm(float(level)))
        else:
            pupils.append(model_pupil_mm(model))
        models.append(model)
        bounds.append(bound)
        if progress is not None:
            progress(index + 1, n, "night frames")
    return NightResult(
        frames=out_frames[0] if single else out_frames,
        targets_cd_m2=targets,
        adaptation_cd_m2=adapted,
        exposure=exposure,
        pupil_mm=np.array(pupils, dtype=float),
        models=models,
        error_bound_codes=np.array(bounds),
        effects=chosen,
    )


# a scene's bound: the adaptation's exposure (key / adapted luminance, at most 1e6 times
# the key over 1e-6 cd/m²) keeps every frame within the renderer's MAX_LUMINANCE_CD_M2
MAX_SCENE_CD_M2 = 1e20


def _bounded(name: str, frame: np.ndarray) -> np.ndarray:
    if frame.size and float(frame.max()) > MAX_SCENE_CD_M2:
        raise ValueError(
            f"{name} reaches {float(frame.max()):.3g} cd/m², beyond the {MAX_SCENE_CD_M2:g} "
            "cd/m² a night scene may hold (the sun is 1.6e9)"
        )
    return frame


def _frames(scene) -> tuple[list[np.ndarray], bool]:
    if isinstance(scene, np.ndarray):
        return [_bounded("scene_cd_m2", check_image("scene_cd_m2", scene, channels=(3,)))], True
    if not isinstance(scene, Sequence) or isinstance(scene, str):
        raise ValueError(
            "scene_cd_m2 must be an image ((H, W) or (H, W, 3) array) or a sequence (list) of "
            f"them; got {type(scene).__name__}"
        )
    if len(scene) == 0:
        raise ValueError("scene_cd_m2 must hold at least one frame; got an empty sequence")
    frames = [
        _bounded(f"scene_cd_m2[{i}]", check_image(f"scene_cd_m2[{i}]", f, channels=(3,)))
        for i, f in enumerate(scene)
    ]
    shapes = {f.shape[:2] for f in frames}
    if len(shapes) > 1:
        raise ValueError(f"the frames of scene_cd_m2 must have one shape; got {sorted(shapes)}")
    return frames, False


def _gazes(gaze_px, n: int) -> list:
    if gaze_px is None:
        return [None] * n
    if (
        isinstance(gaze_px, Sequence)
        and len(gaze_px) == 2
        and all(isinstance(v, int | float | np.number | np.bool_) for v in gaze_px)
    ):
        return [tuple(gaze_px)] * n  # each checked where it is used (a bool refused)
    gazes = list(gaze_px)
    if len(gazes) != n:
        raise ValueError(
            f"gaze_px must be one (row, column) or one per frame ({n}); got {len(gazes)}"
        )
    return gazes
