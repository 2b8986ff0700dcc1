"""Night vision at the display's frame rate: what does not depend on the eye is done once.

:class:`LiveNight` renders one scene for a gaze and a pupil that change every frame, with the
adaptation and glare of :func:`glarelab.glare.render_night` (Luidolt 2020, Fig. 6.1: "In the
pre-processing step, we calculate all data, that does not change during our simulation"):

- **Once**: the scene's log luminance (the adaptation's input, eq. 5.1).
- **Once per adaptation level and pupil** (a bank, made before the first frame by
  :meth:`~glarelab.glare.night.live.LiveNight.prepare`, or as the gaze visits them): the
  excess over the display's maximum at exposure ``s`` is ``s·max(X - T, 0)`` with the threshold
  ``T = L_dmax / s`` (Yoshida 2008 eq. 1), so its spread is ``s · (max(X - T, 0) ⊛ K_p)``.
  The bank holds ``max(X - T_j, 0) ⊛ K_p`` on thresholds ``T_j = r^j`` (``r`` = 1.02),
  halved where the scene needs it (below), and on the pupils ``p`` of :func:`pupil_bank_mm`.
- **Per frame**: the windowed target around the gaze (§5.1,
  :func:`~glarelab.glare.night.adaptation.window_mean` of the log luminance), one step of
  eqs. 5.2-5.4 (:func:`~glarelab.glare.night.adaptation.adaptation_step`), the exposure, the
  spread interpolated bilinearly in ``T`` and ``p`` between the four bank entries around
  them, composed by :func:`~glarelab.glare.rendering.compose.compose`.

``max(X - T, 0)`` is linear in ``T`` for every pixel outside ``[T_j, T_{j+1})``, so the
interpolation in ``T`` errs only on the pixels within that band, by at most
``(T_{j+1} - T_j) / 4`` each (before spreading): the kink of Yoshida's eq. 1 at ``X = T``,
the only part of the frame that is not linear in the threshold (the adaptation, eqs. 5.2-5.4,
sets ``T`` and does not enter the spread; the display's tone curve only magnifies the error in
codes where the glare falls on a dark part of the frame). The error thus grows with the step
and with the area of the scene within it: a façade of one luminance that the threshold
crosses puts thousands of pixels into one band (on the night study's street at 640 × 400,
9555 pixels at 1.5 cd/m²: 1.67 codes at an adaptation of 0.0225 cd/m², 0.995 with the
acuity loss). Each interval whose area times ``r - 1`` exceeds ``band_budget_deg2`` is
halved, up to :data:`MAX_HALVINGS` times, so the bank is dense only where the scene has such
plateaus (counted once from the sorted channels, without a render). The glare kernels are exact
(``tolerance_codes=0``). The Vos PSF depends on the pupil only through its halo, which a pupil
under 3 mm drops (Spencer §2.1): the bank holds both sides of that step, so no interval spans it
and the interpolation in the pupil is exact; a model whose kernel changes continuously with the
pupil (the wave-optics one) is interpolated linearly between the bank's pupils.

References
----------
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, §5.1, §5.2.1 ii, §5.2.3,
§6.3, Fig. 6.1. Yoshida et al. (2008), eq. 1. Spencer et al. (1995), §2.1.
"""

from __future__ import annotations

import math
import time
import warnings
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import ndimage
from threadpoolctl import ThreadpoolController

from glarelab.files.memory import check_memory
from glarelab.files.values import is_real
from glarelab.glare._colour import colour
from glarelab.glare._validation import check_choice, check_image, check_in_range, check_positive
from glarelab.glare.models import _resolve
from glarelab.glare.models.base import GlareModel
from glarelab.glare.models.eye import (
    HALO_PUPIL_MM,
    MESOPIC_UPPER_CD_M2,
    SCOTOPIC_UPPER_CD_M2,
    Regime,
    regime,
)
from glarelab.glare.models.hybrid import HybridGlare
from glarelab.glare.models.spencer1995 import PUPIL_RANGE_MM, VosGlare
from glarelab.glare.night.acuity import (
    LEVELS_PER_OCTAVE,
    MIN_LUMINANCE_CD_M2,
    SIGMA_METHODS,
    _layers_at,
    _levels,
    _radius,
    acuity_blur,
    blur_sigma_deg,
)
from glarelab.glare.night.adaptation import (
    ABSOLUTE_THRESHOLD_CD_M2,
    TAU_CONE_S,
    TAU_ROD_S,
    WINDOW_SIGMA_DEG,
    adaptation_step,
    gaze_falloff,
    luminance,
    rod_sensitivity,
    window_mean,
)
from glarelab.glare.night.pipeline import (
    eye_state_model,
    given_eye_state,
    has_eye_field,
    model_pupil_mm,
)
from glarelab.glare.night.scotopic import rod_weights, scotopic_colour
from glarelab.glare.rendering.compose import COMPOSITIONS, compose
from glarelab.glare.rendering.display import CodeTable
from glarelab.glare.rendering.renderer import GlareRenderer

__all__ = [
    "LUIDOLT2020_PUPIL_RANGE_MM",
    "PUPIL_BANK_MM",
    "LiveFrame",
    "LiveNight",
    "LivePreparation",
    "pupil_bank_mm",
]

LUIDOLT2020_PUPIL_RANGE_MM = (2.0, 8.0)  # Luidolt §5.2.1 ii: "our predefined range of 2-8 mm"
PUPIL_BANK_MM = tuple(np.round(np.arange(2.0, 8.0001, 0.5), 6).tolist())  # 13 pupils, 0.5 mm
PRECISIONS = ("float32", "float64")
# the bank's thresholds T_j = r^j cd/m²: interpolating max(X - T, 0) linearly in T between them
# errs only on pixels within [T_j, T_{j+1}), by at most (T_{j+1} - T_j) / 4 of the scene
THRESHOLD_RATIO = 1.02
# where many pixels lie between two levels the interval is halved (up to MAX_HALVINGS times,
# ratio 1.02^(1/16) = 1.0012) until (ratio - 1) × their area is at most BAND_BUDGET_DEG2: the
# interpolation's error is at most (T_{j+1} - T_j)/4 on each of them (Yoshida eq. 1's kink),
# so it grows with the step times the area of the scene within it. Measured on the night
# study's street at 640 × 400 (0.0297° pixels): 1.67 codes at the worst level for 0.02 × 8.4
# deg² (a façade at 1.5 cd/m², 9555 pixels in one channel), 0.12 with the interval halved
# twice (0.005 × 8.4 = 0.04 deg²), at most 0.34 near it
BAND_BUDGET_DEG2 = 0.02 * 4.0
MAX_HALVINGS = 4
BANK_SIZE = 64  # entries kept (the least recently used are dropped)
# with the acuity loss, the pixels within this many σ (of the ladder level above their own σ,
# at least one pixel) of a pixel that meets the white between two bank levels are blurred
# directly: measured within 0.008 codes of blurring all within the kernels' 4σ on the night
# street at 640 × 400 (0.16 codes for the meeting pixels alone), with half the pixels
REACH_SIGMAS = 1.0
GEOMETRY_KEPT = 16  # pairs of acuity entries whose pixels to blur directly are kept


_CIE_DELTA = 6.0 / 29.0  # CIE 1976 L*a*b*: the cube root's knee


def _cie_f(t: np.ndarray) -> np.ndarray:
    """CIE 1976's ``f(t)``: ``t^(1/3)`` above ``δ³``, ``t / (3δ²) + 4/29`` below
    (``L* = 116 f(Y/Y_n) - 16``; as colour-science's ``XYZ_to_Lab``)."""
    t = np.asarray(t, dtype=float)
    return np.where(t > _CIE_DELTA**3, np.cbrt(t), t / (3 * _CIE_DELTA**2) + 4.0 / 29.0)


def _cie_f_inverse(f: np.ndarray) -> np.ndarray:
    """The inverse of :func:`_cie_f` (as colour-science's ``Lab_to_XYZ``)."""
    return np.where(f > _CIE_DELTA, f**3, 3 * _CIE_DELTA**2 * (f - 4.0 / 29.0))


def _clusters(kinks: np.ndarray, reach: int, block: int = 32) -> list[tuple[slice, slice]]:
    """Boxes around the groups of kinks, each grown by ``reach`` (within the image): the
    kinks' blocks of ``block`` pixels, neighbouring blocks joined."""
    height, width = kinks.shape
    rows, cols = -(-height // block), -(-width // block)
    padded = np.zeros((rows * block, cols * block), dtype=bool)
    padded[:height, :width] = kinks
    blocks = padded.reshape(rows, block, cols, block).any(axis=(1, 3))
    labels, _ = ndimage.label(blocks, structure=np.ones((3, 3)))
    boxes = []
    for found in ndimage.find_objects(labels):
        r, c = found
        boxes.append(
            (
                slice(max(r.start * block - reach, 0), min(r.stop * block + reach, height)),
                slice(max(c.start * block - reach, 0), min(c.stop * block + reach, width)),
            )
        )
    return boxes


def _check_bank_pupil(model: GlareModel, pupil: float) -> None:
    """Refuse a bank pupil the model would refuse (the Vos PSF's
    :data:`~glarelab.glare.models.spencer1995.PUPIL_RANGE_MM`, whatever its regime; the
    wave-optics model's 1-10 mm), naming ``pupils_mm``."""
    if isinstance(model, VosGlare):
        low, high = PUPIL_RANGE_MM
        if not low <= pupil <= high:
            raise ValueError(
                f"pupils_mm holds {pupil:g} mm, outside the {low:g}-{high:g} mm the Vos PSF "
                "takes; give pupils within it"
            )
        return
    try:
        with warnings.catch_warnings():  # a frame's model warns when it is made
            warnings.simplefilter("ignore")
            eye_state_model(model, pupil_mm=pupil, regime=None)
    except ValueError as error:
        raise ValueError(
            f"pupils_mm holds {pupil:g} mm, which the glare model refuses ({error})"
        ) from None


def pupil_bank_mm(
    model: GlareModel, pupils_mm: tuple[float, ...] | np.ndarray = PUPIL_BANK_MM
) -> np.ndarray:
    """The pupils a bank holds for a model: ``pupils_mm`` and both sides of the model's steps.

    Parameters
    ----------
    model
        The glare model.
    pupils_mm
        The pupils asked for, mm, at least one, each > 0.

    Returns
    -------
    numpy.ndarray
        Sorted unique pupils, mm. For :class:`~glarelab.glare.VosGlare` and
        :class:`~glarelab.glare.HybridGlare` (whose halo follows its wave model's pupil) the
        halo's step at 3 mm (Spencer §2.1) is added from both sides (the largest float below
        3 and 3), so no interval of the bank spans it.

    Raises
    ------
    ValueError
        For an empty bank or a pupil that is not finite and positive.

    Examples
    --------
    >>> from glarelab.glare import VosGlare
    >>> pupil_bank_mm(VosGlare(), (2.0, 4.0)).round(9).tolist()
    [2.0, 3.0, 3.0, 4.0]
    """
    try:
        bank = np.asarray(pupils_mm, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(
            f"pupils_mm must be at least one finite pupil > 0 mm, a list of numbers; got "
            f"{pupils_mm!r}"
        ) from None
    if bank.size == 0 or not (np.isfinite(bank).all() and (bank > 0).all()):
        raise ValueError(f"pupils_mm must be at least one finite pupil > 0 mm; got {pupils_mm!r}")
    if isinstance(model, VosGlare | HybridGlare) and bank.min() < HALO_PUPIL_MM <= bank.max():
        bank = np.concatenate([bank, [np.nextafter(HALO_PUPIL_MM, 0.0), HALO_PUPIL_MM]])
    return np.unique(bank)


@dataclass(frozen=True)
class LiveFrame:
    """One frame of :meth:`LiveNight.frame`.

    Attributes
    ----------
    image
        Display RGB, cd/m², ``(H, W, 3)`` in ``[0, display_max_cd_m2]`` (a buffer the next
        frame overwrites: copy it to keep it).
    gaze_px
        ``(row, column)`` used (the last valid one when the frame had none).
    pupil_mm
        The pupil the glare was rendered for, mm: the frame's (the last valid one when the
        frame had none) for a model that takes each frame's pupil (a hybrid model's wave part
        takes it; the Vos PSF in the photopic regime takes it with no halo for it to drop);
        NaN for a model without a pupil (the Gaussian).
    target_cd_m2
        The windowed luminance around the gaze (eq. 5.1, §5.1).
    adaptation_cd_m2
        The adapted luminance ``L_i`` (eq. 5.2).
    exposure
        Display cd/m² per scene cd/m².
    render_ms
        Wall time of the frame, ms (with its codes when asked for them).
    new_entries
        Entries of the bank this frame had to make (0 once the gaze has visited the
        adaptation levels and pupils before; each costs about one offline glare render, or
        with the acuity loss one offline render of glare and acuity).
    exact_px
        With the acuity loss: pixels whose blur this frame computed directly (those within
        the blur's reach of a pixel that meets the display's white between the two bank
        levels); 0 without.
    codes
        The display's codes of ``image`` (a new array) when the frame was asked for them
        (``encode``), else None.
    """

    image: np.ndarray
    gaze_px: tuple[float, float]
    pupil_mm: float
    target_cd_m2: float
    adaptation_cd_m2: float
    exposure: float
    render_ms: float
    new_entries: int
    exact_px: int = 0
    codes: np.ndarray | None = None


class LiveNight:
    """Adaptation and glare of one scene, per frame, for a gaze and a pupil that change.

    Parameters
    ----------
    scene_cd_m2
        ``(H, W)`` luminance or ``(H, W, 3)`` linear RGB, cd/m² (channels of a white of equal
        R, G, B), finite and >= 0.
    pixel_deg
        Visual angle of a pixel, degrees, > 0.
    glare_model
        The glare model (an object or a name); default the Vos PSF. Each frame sets its eye
        state as :func:`~glarelab.glare.night.render_night` does
        (:func:`~glarelab.glare.night.pipeline.eye_state_model`): its ``pupil_mm`` (a hybrid
        model's wave pupil) to each pupil of the bank (a model without one has a bank of one
        entry), and the Vos ``regime`` to that of the frame's ``L_i`` (Spencer §3.1). A
        wave-optics kernel is not linear in the pupil: between two bank pupils it is
        interpolated, tens of codes off on ordinary scenes (the wave model 47 codes at 3.25 mm
        between 3 and 3.5 mm, docs/night-vision.md); give the bank the pupils the frames
        need.
    pupils_mm
        The bank's pupils, mm (see :func:`pupil_bank_mm`); default 2-8 mm in steps of 0.5
        (Luidolt's range, §5.2.1 ii). A frame's pupil must lie within them, and they within
        the model's range (the Vos PSF's 0.5-10 mm, the wave-optics model's 1-10 mm). Refused
        for a model without a frame's pupil (the Gaussian), which would
        ignore them.
    display_max_cd_m2
        The display's white ``L_dmax``, cd/m², > 0; default 100.
    adapted_display_cd_m2
        Display luminance of the adapting luminance, cd/m², in (0, ``display_max_cd_m2``];
        default 10.
    initial_adaptation_cd_m2
        Adapted luminance before the first frame, cd/m²; default None: adapted to the first
        frame's target (as :func:`~glarelab.glare.render_night`).
    window_sigma_deg
        The adaptation window's σ, degrees; default 5 (an assumption, as in
        :func:`~glarelab.glare.night.adaptation.frame_luminance`).
    adaptation_mean
        ``'log'`` (default) or ``'arithmetic'`` mean in the window.
    tau_rod_s, tau_cone_s
        Adaptation times, s; defaults 0.4 and 0.1 (Luidolt §5.1).
    glare_method
        ``'Yoshida2008'`` (default, clamped) or ``'Spencer1995'`` composition.
    colourspace
        The RGB colourspace of the scene (eq. 5.1).
    precision
        ``'float32'`` (default: the bank and the frames, half the memory traffic) or
        ``'float64'``.
    threshold_ratio
        Ratio ``r`` of the bank's neighbouring thresholds ``T_j = r^j`` cd/m², > 1; default
        1.02, each interval halved as ``band_budget_deg2`` asks.
    band_budget_deg2
        The most ``(ratio - 1) × area`` (deg², the channel with the most pixels between two
        thresholds) an interval of the bank may have before it is halved (at most
        :data:`MAX_HALVINGS` times), > 0; default 0.08 (measured against
        :func:`~glarelab.glare.render_night` on the night study's street at 640 × 400, 61
        adaptation levels from 0.001 to 100 cd/m² and the worst found, pupils 2-8 mm: at most
        0.35 codes, 1.67 without halving, at 0.0225 cd/m²; with the acuity loss at most
        0.37, 0.07 there, 0.995 without). None: no halving (thresholds ``r^j`` only).
    bank_size
        Bank entries kept, >= 4 (the least recently used are dropped); default 64.
    scotopic
        Also Luidolt's scotopic colour (§5.4, eq. 5.18, :func:`~glarelab.glare.scotopic_colour`)
        of each frame's adapted luminance, after the glare, as ``render_night`` with the
        effect ``'scotopic'``; default False.
    glare_falloff_deg
        σ of Luidolt's Gaussian falloff of the glare around the gaze, degrees (§5.2.3; as
        :func:`~glarelab.glare.render_night`'s); default None: the whole frame alike.
    acuity
        Also the loss of acuity (Luidolt §5.3, :func:`~glarelab.glare.night.acuity.acuity_blur`
        with ``blur='layers'``) of each frame, after the glare and before the scotopic colour,
        as ``render_night`` with the effect ``'acuity'``; default False. See Notes.
    acuity_method, acuity_space, levels_per_octave
        As ``render_night``'s (defaults ``'Krawczyk2005'``, ``'lightness'``, 16); others
        only with ``acuity=True``.

    Raises
    ------
    ValueError
        For a bad scene, number, method or bank, each named.

    Notes
    -----
    The bank holds ``2 × len(bank)`` images of the scene's size (fewer where neighbouring
    pupils give the same spread, as the Vos PSF's do above and below 3 mm).

    **Acuity.** The blur's input is the CIE L* of the clamped, glared display image and each
    pixel's σ follows from its scene luminance with the glare (eqs. 5.14-5.15): neither is
    linear in the exposure, so a stack of blurs of one image cannot give the frame. The bank
    keeps, with each threshold ``T_j`` and pupil, the frame with acuity loss at the exposure
    ``s_j = L_dmax / T_j``, divided by ``s_j`` (``A_j``); a frame at ``s`` is
    ``s((1 - u) A_j + u A_{j+1})``, bilinear in ``T`` and the pupil as the spread. Where no
    channel meets ``L_dmax`` between ``T_j`` and ``T_{j+1}`` the frame divided by ``s`` is
    smooth in ``T`` (in the cube-root part of L* exactly proportional to ``s``), and the
    interpolation errs by less than 0.01 codes (measured); a pixel that meets the white in
    between has a kink, so every pixel within the blur's reach of one is blurred directly
    from this frame's display (:attr:`LiveFrame.exact_px`), with the numbers of
    ``render_night``. The acuity loss does not combine with the gaze falloff: the falloff
    blends the glared and the unglared frame by a weight that changes across the frame
    before the blur, and blending the two banked blurs instead errs by up to 250 codes next
    to a lamp (measured), where the unglared frame is dark and its blur large.

    References
    ----------
    Luidolt 2020, §5.1 (eqs. 5.1-5.4), §5.2.1 ii, Fig. 6.1; Yoshida et al. 2008, eq. 1.

    Examples
    --------
    >>> scene = np.full((24, 32, 3), 0.02)
    >>> scene[10:12, 15:17] = 5e4
    >>> live = LiveNight(scene, pixel_deg=0.1, pupils_mm=(4.0, 6.0))
    >>> frame = live.frame(gaze_px=(12.0, 16.0), pupil_mm=5.0, frame_time_s=1 / 60)
    >>> frame.image.shape, bool(frame.image.max() <= 100.0), frame.pupil_mm
    ((24, 32, 3), True, 5.0)

    All four of Luidolt's effects, the acuity loss from the bank:

    >>> night = LiveNight(scene, pixel_deg=0.1, pupils_mm=(4.0, 6.0), acuity=True, scotopic=True)
    >>> frame = night.frame(gaze_px=(12.0, 16.0), pupil_mm=5.0, frame_time_s=1 / 60)
    >>> frame.image.shape, frame.new_entries > 0
    ((24, 32, 3), True)
    """

    def __init__(
        self,
        scene_cd_m2: np.ndarray,
        *,
        pixel_deg: float,
        glare_model: GlareModel | str | None = None,
        pupils_mm: tuple[float, ...] | np.ndarray = PUPIL_BANK_MM,
        display_max_cd_m2: float = 100.0,
        adapted_display_cd_m2: float = 10.0,
        initial_adaptation_cd_m2: float | None = None,
        window_sigma_deg: float = WINDOW_SIGMA_DEG,
        adaptation_mean: Literal["log", "arithmetic"] = "log",
        tau_rod_s: float = TAU_ROD_S,
        tau_cone_s: float = TAU_CONE_S,
        glare_method: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
        colourspace: str = "ITU-R BT.709",
        precision: Literal["float32", "float64"] = "float32",
        threshold_ratio: float = THRESHOLD_RATIO,
        band_budget_deg2: float | None = BAND_BUDGET_DEG2,
        bank_size: int = BANK_SIZE,
        glare_falloff_deg: float | None = None,
        scotopic: bool = False,
        acuity: bool = False,
        acuity_method: Literal["Krawczyk2005", "Luidolt2020"] = "Krawczyk2005",
        acuity_space: Literal["lightness", "linear"] = "lightness",
        levels_per_octave: int = LEVELS_PER_OCTAVE,
    ) -> None:
        image = check_image("scene_cd_m2", scene_cd_m2, channels=(3,))
        rgb = image if image.ndim == 3 else np.repeat(image[..., None], 3, axis=2)
        self.scene = rgb.astype(np.float64)
        self.shape = self.scene.shape[:2]
        self.pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
        self.l_dmax = check_positive("display_max_cd_m2", display_max_cd_m2, unit="cd/m²")
        self.key = check_in_range(
            "adapted_display_cd_m2", adapted_display_cd_m2, 0.0, self.l_dmax, unit="cd/m²",
            low_inclusive=False,
        )  # fmt: skip
        self.window_sigma_deg = check_positive("window_sigma_deg", window_sigma_deg, unit="deg")
        check_choice("adaptation_mean", adaptation_mean, ("log", "arithmetic"))
        self.tau_rod_s = check_positive("tau_rod_s", tau_rod_s, unit="s")
        self.tau_cone_s = check_positive("tau_cone_s", tau_cone_s, unit="s")
        self.method = check_choice("glare_method", glare_method, COMPOSITIONS)  # as given
        check_choice("precision", precision, PRECISIONS)
        self.dtype = np.dtype(precision)
        self.model = _resolve(glare_model if glare_model is not None else "vos", "glare_model")
        has_pupil = has_eye_field(self.model, "pupil_mm")
        # the Vos regime follows each frame's L_i (Spencer §3.1), as render_night sets it
        self._has_regime = has_eye_field(self.model, "regime")
        given = given_eye_state(self.model) if has_pupil else None
        if given is not None:  # each frame's tracked pupil would replace it, unsaid
            raise ValueError(
                f"glare_model has {given}, which each frame's pupil (from the eye tracker) "
                "replaces: leave it unset"
            )
        if not has_pupil and pupils_mm is not PUPIL_BANK_MM:  # a bank of one model
            raise ValueError(
                f"pupils_mm={pupils_mm!r:.80} with glare_model={glare_model!r:.80}: the model "
                "takes no frame's pupil, so they would be ignored; leave pupils_mm at its "
                "default"
            )
        self.pupils_mm = (
            pupil_bank_mm(self.model, pupils_mm)
            if has_pupil
            else np.array([float(np.median(pupils_mm))])
        )
        self._has_pupil = has_pupil
        self._model_pupil_mm = model_pupil_mm(self.model)  # a model without a frame's pupil
        if has_pupil:  # each pupil within the model's range, as the model judges it
            for pupil in np.unique(np.asarray(pupils_mm, dtype=float)):
                _check_bank_pupil(self.model, float(pupil))
        y = luminance(self.scene, colourspace=colourspace)
        self.adaptation_mean = adaptation_mean
        self._y = (
            np.log(np.maximum(y, ABSOLUTE_THRESHOLD_CD_M2)) if adaptation_mean == "log" else y
        )
        self._display = self.scene.astype(self.dtype)
        self._out = np.empty_like(self._display)
        self._spread = np.empty_like(self._display)
        self._work = np.empty_like(self._display)
        self._state: float | None = None
        if initial_adaptation_cd_m2 is not None:
            self._state = float(
                check_in_range(
                    "initial_adaptation_cd_m2",
                    initial_adaptation_cd_m2,
                    0.0,
                    math.inf,
                    unit="cd/m²",
                )
            )
        self._gaze: tuple[float, float] | None = None
        self._pupil: float | None = None
        self._renderers: dict[float, GlareRenderer] = {}
        self.threshold_ratio = check_in_range(
            "threshold_ratio", threshold_ratio, 1.0, math.inf, unit="", low_inclusive=False
        )
        self.band_budget_deg2 = (
            None
            if band_budget_deg2 is None
            else check_positive("band_budget_deg2", band_budget_deg2, unit="deg²")
        )
        self._fine = 2**MAX_HALVINGS  # a bank level i is the threshold r^(i / 2^MAX_HALVINGS)
        # each channel's values sorted: the pixels between two thresholds, by bisection
        self._sorted = np.sort(self.scene.reshape(-1, 3), axis=0).T.copy()
        self._halved: dict[int, int] = {}
        if (
            isinstance(bank_size, bool)
            or not isinstance(bank_size, int | np.integer)
            or bank_size < 4
        ):
            raise ValueError(f"bank_size must be an integer >= 4; got {bank_size!r}")
        self.bank_size = int(bank_size)
        self._bank: OrderedDict[tuple, np.ndarray | None] = OrderedDict()
        self.bank_entries = 0
        self._threads = ThreadpoolController()
        self._pool: ThreadPoolExecutor | None = None  # the direct blur's thread, when needed
        self.scotopic = bool(scotopic)
        self.colourspace = colourspace
        self.falloff_deg = (
            None
            if glare_falloff_deg is None
            else check_positive("glare_falloff_deg", glare_falloff_deg, unit="deg")
        )
        self.acuity = bool(acuity)
        if self.acuity and self.falloff_deg is not None:
            raise ValueError(
                "acuity=True does not combine with glare_falloff_deg (the falloff's blend "
                "precedes the blur, which the bank cannot interpolate): give one of them"
            )
        if not acuity and (acuity_method, acuity_space, levels_per_octave) != (
            "Krawczyk2005",
            "lightness",
            LEVELS_PER_OCTAVE,
        ):
            raise ValueError(
                f"acuity_method={acuity_method!r}, acuity_space={acuity_space!r}, "
                f"levels_per_octave={levels_per_octave!r} without acuity=True: the acuity loss "
                "is off, so they would be ignored"
            )
        self.acuity_method = check_choice("acuity_method", acuity_method, SIGMA_METHODS)
        self.acuity_space = check_choice("acuity_space", acuity_space, ("lightness", "linear"))
        self.levels_per_octave = int(
            check_in_range("levels_per_octave", levels_per_octave, 1, 64, unit="")
        )
        if self.levels_per_octave != levels_per_octave:
            raise ValueError(f"levels_per_octave must be an integer; got {levels_per_octave!r}")
        # the scotopic blend of eq. 5.18 is linear in RGB for a frame's L_i: one 3 × 3 matrix
        self._rod_positive = bool((rod_weights(colourspace) >= 0).all())
        # its rod image, σ(0) = 1 (eq. 5.4): each primary's T L'
        self._rod_matrix = scotopic_colour(
            np.eye(3), adaptation_luminance_cd_m2=0.0, colourspace=colourspace
        )
        self._models: dict[tuple, GlareModel] = {}  # the bank's model of a pupil and regime
        # the direct blur's colour: the space, its luminance row (summing to 1) and white
        self._space_rgb = colour.RGB_COLOURSPACES[colourspace]
        self._y_row = np.asarray(self._space_rgb.matrix_RGB_to_XYZ[1], float)
        self._y_row = self._y_row / self._y_row.sum()
        self._white = colour.xy_to_XYZ(self._space_rgb.whitepoint)
        self._geometries: OrderedDict[tuple, list] = OrderedDict()
        self.build_s = 0.0
        self.frames = 0

    # the bank ----------------------------------------------------------------------------
    def _entry(self, level: int, model: GlareModel) -> np.ndarray | None:
        """``max(X - T_j, 0) ⊛ K`` for the threshold ``T_j = r^j`` and a model of the bank
        (:meth:`_model_for`), kept; None without excess."""
        key = (level, model)
        if key in self._bank:
            self._bank.move_to_end(key)
            return self._bank[key]
        start = time.perf_counter()
        excess = np.maximum(self.scene - self._threshold(level), 0.0)
        entry = None
        if excess.any():
            renderer = self._renderers.get(model)
            if renderer is None:
                # Spencer's sum spreads onto every pixel (Yoshida's only onto those below L)
                try:
                    renderer = GlareRenderer(
                        model, pixel_deg=self.pixel_deg, shape=self.shape,
                        l_dmax_cd_m2=self.l_dmax, composition="Spencer1995", tolerance_codes=0.0,
                    )  # fmt: skip
                except ValueError as error:  # a bank's pupil the model cannot render here
                    raise ValueError(
                        f"pupils_mm: the glare model cannot be rendered at one of the bank's "
                        f"pupils ({self.pupils_mm.min():g}-{self.pupils_mm.max():g} mm) at "
                        f"{self.pixel_deg:g} deg a pixel: {error}"
                    ) from None
                self._renderers[model] = renderer
            # the renderer spreads the excess over L_dmax: L_dmax + E has the excess E
            spread = np.asarray(renderer.render(self.l_dmax + excess).spread)
            entry = np.broadcast_to(spread, self.scene.shape).astype(self.dtype)
        return self._store(key, entry, start)

    def _threshold(self, level: int) -> float:
        """The threshold ``T`` of a bank level, cd/m²: ``r^(level / 2^MAX_HALVINGS)``."""
        return self.threshold_ratio ** (level / self._fine)

    def _halvings(self, base: int) -> int:
        """How often the interval ``[r^base, r^(base + 1))`` is halved: the least ``h`` (at
        most :data:`MAX_HALVINGS`) for which ``(r^(1/2^h) - 1)`` times the area of the scene
        within it (deg², the channel with the most pixels there) is within
        ``band_budget_deg2``; 0 without a budget."""
        if base in self._halved:
            return self._halved[base]
        halvings = 0
        if self.band_budget_deg2 is not None:
            low, high = self.threshold_ratio**base, self.threshold_ratio ** (base + 1)
            pixels = max(
                int(np.searchsorted(values, high) - np.searchsorted(values, low))
                for values in self._sorted
            )
            area_deg2 = pixels * self.pixel_deg**2
            while (
                halvings < MAX_HALVINGS
                and (self.threshold_ratio ** (0.5**halvings) - 1.0) * area_deg2
                > self.band_budget_deg2
            ):
                halvings += 1
        self._halved[base] = halvings
        return halvings

    def _store(self, key: tuple, entry, start: float):
        """Keep a new bank entry (dropping the least recently used beyond ``bank_size``),
        count it and its time since ``start``, and return it."""
        self._bank[key] = entry
        self.bank_entries += 1
        while len(self._bank) > self.bank_size:
            self._bank.popitem(last=False)
        self.build_s += time.perf_counter() - start
        return entry

    def _model_for(self, pupil: float, eye_regime: Regime | None) -> GlareModel:
        """The model of a pupil of the bank and a frame's regime; pupils whose kernels are
        equal share one (the Vos PSF's pupil only drops the halo below 3 mm, Spencer §2.1)."""
        if not self._has_pupil and eye_regime is None:
            return self.model
        if isinstance(self.model, VosGlare):
            below = pupil < HALO_PUPIL_MM
            pupil = float(np.nextafter(HALO_PUPIL_MM, 0.0)) if below else HALO_PUPIL_MM
        key = (float(pupil) if self._has_pupil else None, eye_regime)
        model = self._models.get(key)
        if model is None:  # made once: a model checks its fields as it is made
            model = eye_state_model(self.model, pupil_mm=key[0], regime=eye_regime)
            self._models[key] = model
        return model

    # one frame ---------------------------------------------------------------------------
    def frame(
        self,
        *,
        gaze_px: tuple[float, float] | None,
        pupil_mm: float | None,
        frame_time_s: float,
        encode: CodeTable | None = None,
    ) -> LiveFrame:
        """The next frame for a gaze and a pupil, after ``frame_time_s`` of adaptation.

        Parameters
        ----------
        gaze_px
            ``(row, column)`` of the gaze in scene pixels (may lie off the image), or None:
            no valid sample (a blink, a lost sample), the last valid gaze is held (the image
            centre before the first).
        pupil_mm
            The pupil diameter, mm, within the bank's range, or None (or 0, a blink's): the
            last valid pupil is held (the bank's middle before the first).
        frame_time_s
            Time since the previous frame, s, >= 0 (``ft`` of eq. 5.2; 0 for the first).
        encode
            The display's codes (:class:`~glarelab.glare.rendering.display.CodeTable`), or
            None (default): with the acuity loss, the frame is encoded (and coloured) while
            the second core blurs the pixels near a kink, whose codes follow; the codes are
            ``encode(frame.image)`` exactly (:attr:`LiveFrame.codes`).

        Returns
        -------
        LiveFrame

        Raises
        ------
        ValueError
            For a pupil that is not a finite number > 0 (whatever the model) or lies outside
            the bank, a gaze that is not finite or too far off the image, or a frame time that
            is not a finite number >= 0; a refused frame leaves the held gaze, pupil and
            adaptation as they were.

        Notes
        -----
        ``L_i = L_{i-1} + (Y - L_{i-1})(1 - e^{-ft/τ(Y)})`` (eq. 5.2), the spread
        ``(1 - t)(s A_0 - L B_0) + t (s A_1 - L B_1)`` for ``t`` the pupil's place between the
        bank's entries ``p_0 <= p < p_1``, and ``min(s X + S, L_dmax)`` (Yoshida §3).
        """
        start = time.perf_counter()
        if gaze_px is not None:
            if (
                isinstance(gaze_px, str | bytes)
                or np.ndim(gaze_px) != 1
                or len(gaze_px) != 2
                or not all(
                    isinstance(v, int | float | np.integer | np.floating)
                    and not isinstance(v, bool | np.bool_)
                    for v in gaze_px
                )
            ):
                raise ValueError(
                    f"gaze_px must be (row, column), two numbers in scene pixels, or None; "
                    f"got {gaze_px!r}"
                )
            gaze = (float(gaze_px[0]), float(gaze_px[1]))
        elif self._gaze is not None:
            gaze = self._gaze
        else:
            gaze = ((self.shape[0] - 1) / 2, (self.shape[1] - 1) / 2)
        # everything checked before the state changes: a refused frame leaves the held gaze,
        # pupil and adaptation as they were
        if pupil_mm is not None and pupil_mm != 0:
            low, high = float(self.pupils_mm[0]), float(self.pupils_mm[-1])
            number = float(pupil_mm) if is_real(pupil_mm) else math.nan
            if not (math.isfinite(number) and number > 0):
                raise ValueError(
                    f"pupil_mm must be a finite number > 0 mm (or None or 0 for no sample); "
                    f"got {pupil_mm!r}"
                )
            if self._has_pupil and not low <= number <= high:
                raise ValueError(
                    f"pupil_mm must lie within the bank, {low:g}-{high:g} mm (or be None or 0 "
                    f"for no sample); got {pupil_mm!r}"
                )
            pupil = number
        elif self._pupil is None:
            pupil = float(self.pupils_mm[len(self.pupils_mm) // 2])
        else:
            pupil = self._pupil
        frame_time_s = check_in_range("frame_time_s", frame_time_s, 0.0, math.inf, unit="s")
        # one BLAS thread for the window's two products: a 1280 × 720 matrix-vector product
        # takes 0.5 ms on one thread and 15 ms on a busy 2-core machine's two (measured)
        with self._threads.limit(limits=1, user_api="blas"):
            mean = window_mean(
                self._y,
                pixel_deg=self.pixel_deg,
                gaze_px=gaze,
                window_sigma_deg=self.window_sigma_deg,
            )
        target = math.exp(mean) if self.adaptation_mean == "log" else mean
        self._gaze = gaze
        self._pupil = pupil
        previous = target if self._state is None else self._state
        self._state = adaptation_step(
            previous, target, frame_time_s, tau_rod_s=self.tau_rod_s, tau_cone_s=self.tau_cone_s
        )
        exposure = self.key / max(self._state, MIN_LUMINANCE_CD_M2)
        eye_regime = regime(self._state) if self._has_regime else None
        made = self.bank_entries
        exact, direct, matrix, codes = 0, None, None, None
        with self._threads.limit(limits=1, user_api="blas"):
            if self.acuity:  # §5.3, of the glared display, before the colour (Luidolt ch. 4)
                direct = self._acuity(exposure, pupil, eye_regime)
            else:
                self._compose(exposure, pupil, eye_regime, gaze)
            if direct is not None and self.scotopic and not self._rod_positive:
                exact, direct = self._patch(direct.result(), None, None, None), None
            if self.scotopic:  # §5.4: "after tone mapping", of the adapted luminance
                matrix = self._scotopic(self._state)
            if encode is not None:
                codes = encode(self._out)
            if direct is not None:  # the pixels blurred directly meanwhile: coloured, encoded
                exact = self._patch(direct.result(), matrix, encode, codes)
        self.frames += 1
        return LiveFrame(
            image=self._out,
            codes=codes,
            gaze_px=gaze,
            pupil_mm=pupil if self._has_pupil else self._model_pupil_mm,
            target_cd_m2=target,
            adaptation_cd_m2=self._state,
            exposure=exposure,
            render_ms=1e3 * (time.perf_counter() - start),
            new_entries=self.bank_entries - made,
            exact_px=exact,
        )

    def _terms(
        self, exposure: float, pupil: float, eye_regime: Regime | None
    ) -> list[tuple[int, GlareModel, float]]:
        """``(level, model, weight)`` of the bank entries around the frame's threshold
        ``T = L_dmax / s`` (between ``T_j = r^j`` and ``T_{j+1}``) and pupil (between the
        bank's ``p_i`` and ``p_{i+1}``), the models of the frame's regime: bilinear weights,
        those of 0 left out."""
        threshold = self.l_dmax / exposure
        place = math.log(threshold) / math.log(self.threshold_ratio)
        base = math.floor(place)
        halvings = self._halvings(base)
        step = self._fine >> halvings
        level = base * self._fine + step * min(
            math.floor((place - base) * 2**halvings), 2**halvings - 1
        )
        t_low, t_high = self._threshold(level), self._threshold(level + step)
        u = min(max((threshold - t_low) / (t_high - t_low), 0.0), 1.0)
        index = int(np.searchsorted(self.pupils_mm, pupil, side="right")) - 1
        index = min(max(index, 0), len(self.pupils_mm) - 1)
        pupils = [(self._model_for(float(self.pupils_mm[index]), eye_regime), 1.0)]
        if index + 1 < len(self.pupils_mm):
            p0, p1 = float(self.pupils_mm[index]), float(self.pupils_mm[index + 1])
            t = (pupil - p0) / (p1 - p0)
            m0, m1 = self._model_for(p0, eye_regime), self._model_for(p1, eye_regime)
            if t > 0 and m0 != m1:
                pupils = [(m0, 1.0 - t), (m1, t)]
        return [
            (index_t, p, weight_t * weight_p)
            for index_t, weight_t in ((level, 1.0 - u), (level + step, u))
            if weight_t > 0
            for p, weight_p in pupils
        ]

    def _compose(
        self,
        exposure: float,
        pupil: float,
        eye_regime: Regime | None,
        gaze: tuple[float, float],
    ) -> None:
        dtype = self.dtype.type
        out, spread, work = self._out, self._spread, self._work
        np.multiply(self._display, dtype(exposure), out=out)
        terms = []
        for step, model, weight in self._terms(exposure, pupil, eye_regime):
            entry = self._entry(step, model)
            if entry is not None:
                terms.append((entry, dtype(weight * exposure)))
        l_dmax = dtype(self.l_dmax)
        if self.falloff_deg is None:
            # min(L + S, L_dmax), the spread added term by term: Yoshida's rule, and Spencer's
            # min(L, L_dmax) + S once clamped to the display as render_night clamps it
            for entry, weight in terms:
                out += np.multiply(entry, weight, out=work)
            np.minimum(out, l_dmax, out=out)
            return
        # Luidolt §6.3.3: the unglared frame blended with the glared one by the falloff
        spread.fill(0)
        for entry, weight in terms:
            spread += np.multiply(entry, weight, out=work)
        base = np.minimum(out, l_dmax, out=work)
        compose(out, spread, self.l_dmax, self.method, out=out)
        out -= base
        out *= self._falloff(gaze)[..., None]
        out += base
        np.clip(out, 0.0, self.l_dmax, out=out)

    def _falloff(self, gaze: tuple[float, float]) -> np.ndarray:
        """The falloff's weight around the gaze (§5.2.3), ``(H, W)``."""
        rows, cols = gaze_falloff(
            self.shape, pixel_deg=self.pixel_deg, gaze_px=gaze, sigma_deg=self.falloff_deg
        )
        return (rows[:, None] * cols[None, :]).astype(self.dtype)

    # the acuity loss -------------------------------------------------------------------
    def _acuity_entry(self, level: int, model: GlareModel) -> tuple[np.ndarray, np.ndarray, int]:
        """The frame with acuity loss at the exposure ``s_j = L_dmax / T_j`` divided by
        ``s_j``, which channels meet ``L_dmax`` there, and the largest blur radius (pixels)
        of the frame's ladder levels."""
        key = ("acuity", level, model)
        if key in self._bank:
            self._bank.move_to_end(key)
            return self._bank[key]
        exposure = self.l_dmax / self._threshold(level)
        display = self.scene * exposure
        spread = self._entry(level, model)  # counted and timed there
        start = time.perf_counter()
        if spread is not None:
            display = compose(display, spread.astype(float) * exposure, self.l_dmax, self.method)
        display = np.minimum(display, self.l_dmax)
        blurred = acuity_blur(
            display, pixel_deg=self.pixel_deg, method=self.acuity_method, blur="layers",
            space=self.acuity_space, luminance_scale=1.0 / exposure,
            white_cd_m2=self.l_dmax if self.acuity_space == "lightness" else None,
            levels_per_octave=self.levels_per_octave, colourspace=self.colourspace,
        )  # fmt: skip
        # each pixel's reach: the radius of the ladder's level above its σ
        y = np.maximum(luminance(display, colourspace=self.colourspace), 0.0) / exposure
        sigma = np.asarray(blur_sigma_deg(y, method=self.acuity_method)) / self.pixel_deg
        ladder = _levels(float(sigma.max()), self.levels_per_octave)
        upper = ladder[np.minimum(np.searchsorted(ladder, sigma), ladder.size - 1)]
        clamped = (display >= self.l_dmax).astype(np.uint8)  # one bit per channel
        entry = (
            (blurred / exposure).astype(self.dtype),
            clamped[..., 0] | (clamped[..., 1] << 1) | (clamped[..., 2] << 2),
            np.maximum(np.ceil(REACH_SIGMAS * upper), 1).astype(np.int16),
        )
        return self._store(key, entry, start)

    def _acuity(self, exposure: float, pupil: float, eye_regime: Regime | None) -> Future | None:
        """Replace the display in ``_out`` by its acuity loss from the bank's interpolation;
        the pixels near a kink are blurred directly on the second core: their future
        (:meth:`_blur_kinks`, for :meth:`_patch`), or None when there are none."""
        dtype = self.dtype.type
        out, work = self._out, self._work
        keys, masks, radii, spreads, blurred = [], [], [], [], []
        for step, model, weight in self._terms(exposure, pupil, eye_regime):
            entry, clamped, radius = self._acuity_entry(step, model)
            blurred.append((entry, dtype(weight * exposure)))
            spread = self._entry(step, model)
            if spread is not None:
                spreads.append((spread, weight))
            keys.append((step, model))
            masks.append(clamped)
            radii.append(radius)
        geometry = self._geometry(tuple(keys), masks, radii)
        direct = None
        if geometry:
            # the direct blur on the second core while this one interpolates (numpy lets go
            # of the GIL in both)
            if self._pool is None:
                self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="LiveNight")
            direct = self._pool.submit(self._blur_kinks, geometry, exposure, spreads)
        for index, (entry, weight) in enumerate(blurred):
            if index == 0:
                np.multiply(entry, weight, out=out)
            else:
                out += np.multiply(entry, weight, out=work)
        return direct

    def _patch(
        self,
        found: list,
        matrix: np.ndarray | None,
        encode: CodeTable | None,
        codes: np.ndarray | None,
    ) -> int:
        """Write the pixels blurred directly (:meth:`_blur_kinks`) into ``_out``, through the
        scotopic ``matrix`` and clip of :meth:`_scotopic` when given, and their codes into
        ``codes``. Returns how many pixels."""
        exact = 0
        for rows, cols, values in found:
            values = values.astype(self.dtype)
            if matrix is not None:
                values = np.clip(values @ matrix, 0.0, self.l_dmax).astype(self.dtype)
            self._out[rows, cols] = values
            if codes is not None:
                codes[rows, cols] = encode(values)
            exact += rows.size
        return exact

    def _geometry(
        self, keys: tuple, masks: list, radii: list
    ) -> list[tuple[tuple[slice, slice], np.ndarray, np.ndarray, int]]:
        """The pixels to blur directly between the bank's acuity entries ``keys`` (their
        white masks and reaches): per box around a group of kinks, the box, the rows and
        columns of its pixels within reach of a kink, and the box's largest reach. They
        depend on the entries only, so they are kept with them (:data:`GEOMETRY_KEPT` sets)."""
        if keys in self._geometries:
            self._geometries.move_to_end(keys)
            return self._geometries[keys]
        kinks = None
        by_model: dict = {}
        for (_, model), mask in zip(keys, masks, strict=True):
            by_model.setdefault(model, []).append(mask)
        for found in by_model.values():
            if len(found) == 2:  # two levels: where a channel meets the white between them
                kink = found[0] != found[1]
                kinks = kink if kinks is None else kinks | kink
        geometry = []
        if kinks is not None and kinks.any():
            most = int(max(radius.max() for radius in radii))
            for box in _clusters(kinks, most):
                reach = radii[0][box]
                for radius in radii[1:]:
                    reach = np.maximum(reach, radius[box])
                distance = ndimage.distance_transform_cdt(~kinks[box], metric="chessboard")
                near_rows, near_cols = np.nonzero(distance <= reach)
                geometry.append(
                    (box, near_rows + box[0].start, near_cols + box[1].start, int(reach.max()))
                )
        self._geometries[keys] = geometry
        while len(self._geometries) > GEOMETRY_KEPT:
            self._geometries.popitem(last=False)
        return geometry

    def _blur_kinks(
        self, geometry: list, exposure: float, spreads: list
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """:meth:`_blur_near` of each box of :meth:`_geometry`."""
        return [
            self._blur_near(near_rows, near_cols, most, exposure, spreads, box)
            for box, near_rows, near_cols, most in geometry
        ]

    def _display_in(self, exposure: float, spreads: list, rows: slice, cols: slice) -> np.ndarray:
        """The glared display ``min(s X + S, L_dmax)`` of a part of the frame (as
        :meth:`_compose` without the falloff; ``spreads``: the bank's ``(entry, weight)``),
        float64."""
        display = self.scene[rows, cols] * exposure
        for entry, weight in spreads:
            display += entry[rows, cols].astype(float) * (weight * exposure)
        return np.minimum(display, self.l_dmax, out=display)

    def _blur_near(
        self,
        near_rows: np.ndarray,
        near_cols: np.ndarray,
        most: int,
        exposure: float,
        spreads: list,
        box: tuple[slice, slice],
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pixels ``(near_rows, near_cols)`` of ``box`` (those within their reach of a
        kink; ``most`` the largest reach, pixels), blurred directly from the frame's display
        as :func:`~glarelab.glare.night.acuity.acuity_blur` does: rows, columns, display RGB."""
        height, width = self.shape
        top, bottom, left, right = box[0].start, box[0].stop, box[1].start, box[1].stop
        space_rgb, y_row, white = self._space_rgb, self._y_row, self._white
        margin = 4 * most  # the radius ⌊4σ + ½⌋ of a reach ⌈σ⌉
        while True:  # the crop holds every pixel the kernels reach (or the image's border)
            c_top, c_bottom = max(top - margin, 0), min(bottom + margin, height)
            c_left, c_right = max(left - margin, 0), min(right + margin, width)
            crop = self._display_in(
                exposure, spreads, slice(c_top, c_bottom), slice(c_left, c_right)
            )
            r, c = near_rows - c_top, near_cols - c_left
            y = crop[r, c] @ y_row
            if self.acuity_space == "lightness":  # CIE L* of the display's white (§5.3.1)
                planes = (116.0 * _cie_f((crop @ y_row) / self.l_dmax) - 16.0)[..., None]
            else:
                planes = crop
            sigma = (
                np.asarray(
                    blur_sigma_deg(np.maximum(y, 0.0) / exposure, method=self.acuity_method)
                ).reshape(-1)
                / self.pixel_deg
            )
            needed = int(_radius(_levels(float(sigma.max()), self.levels_per_octave)[-1]))
            if needed <= margin:
                break
            margin = needed
        blurred = _layers_at(planes, sigma, r, c, self.levels_per_octave)
        if self.acuity_space == "lightness":  # the blurred L* with the pixel's a*, b*
            f = _cie_f((crop[r, c] / self.l_dmax) @ space_rgb.matrix_RGB_to_XYZ.T / white)
            # a* = 500 (f_X - f_Y), b* = 200 (f_Y - f_Z) kept: f_X, f_Z move with f_Y
            f += ((blurred[:, 0] + 16.0) / 116.0 - f[:, 1])[:, None]
            xyz = _cie_f_inverse(f) * white
            blurred = (xyz @ space_rgb.matrix_XYZ_to_RGB.T) * self.l_dmax
        return near_rows, near_cols, np.maximum(blurred, 0.0)

    def _scotopic(self, adaptation: float) -> np.ndarray | None:
        """Luidolt's eq. 5.18 of ``_out``: for Rec. 709 (rod weights >= 0) one 3 × 3 matrix,
        the shift of each primary (returned, for the pixels blurred meanwhile), else None."""
        if not self._rod_positive:
            shifted = scotopic_colour(
                self._out, adaptation_luminance_cd_m2=adaptation, colourspace=self.colourspace
            )
            np.clip(shifted, 0.0, self.l_dmax, out=self._out, casting="same_kind")
            return None
        # eq. 5.18 is RGB (1 - σ) + T L' σ: the matrix I (1 - σ) + R σ, R its rod image (σ = 1)
        sigma = rod_sensitivity(adaptation)
        matrix = (np.eye(3) * (1.0 - sigma) + self._rod_matrix * sigma).astype(self.dtype)
        flat = self._out.reshape(-1, 3)
        np.matmul(flat, matrix, out=self._work.reshape(-1, 3))
        np.clip(self._work, 0.0, self.l_dmax, out=self._out)
        return matrix

    # before the first frame ----------------------------------------------------------------
    def adaptation_range(self) -> tuple[float, float]:
        """The least and the greatest adapted luminance a gaze on the scene leads to, cd/m².

        Returns
        -------
        tuple of float
            ``(low, high)``: the extremes of the windowed target (§5.1) over gazes on the
            scene's pixels (every ``σ / 8`` of the window, and the scene's last row and column)
            and of ``initial_adaptation_cd_m2`` when given.

        Notes
        -----
        Eq. 5.2 moves the adapted luminance towards the target by a fraction
        ``1 - e^{-ft/τ}`` in ``[0, 1]`` each frame, so it never leaves the range of the
        targets it has followed and the state it began in. The target of a gaze at ``(g, h)``
        is ``R_g · Y · C_h / (ΣR_g ΣC_h)`` with Gaussian rows ``R`` and columns ``C``
        (:func:`~glarelab.glare.night.adaptation.window_mean`): every gaze of the grid in two
        matrix products.

        References
        ----------
        Luidolt 2020, §5.1, eq. 5.2.

        Examples
        --------
        >>> scene = np.full((24, 32), 0.02)
        >>> scene[:, 16:] = 2.0
        >>> low, high = LiveNight(scene, pixel_deg=0.1).adaptation_range()
        >>> bool(0.02 < low < high < 2.0)
        True
        """
        sigma_px = self.window_sigma_deg / self.pixel_deg
        step = max(1.0, sigma_px / 8.0)

        def weights(size: int) -> np.ndarray:
            places = np.unique(np.append(np.arange(0.0, size - 1.0, step), size - 1.0))
            pixels = np.arange(size)
            return np.exp(-0.5 * ((pixels[None, :] - places[:, None]) / sigma_px) ** 2)

        rows, cols = weights(self.shape[0]), weights(self.shape[1])
        with self._threads.limit(limits=1, user_api="blas"):
            means = rows @ self._y @ cols.T / np.outer(rows.sum(axis=1), cols.sum(axis=1))
        targets = np.exp(means) if self.adaptation_mean == "log" else means
        low, high = float(targets.min()), float(targets.max())
        if self._state is not None:
            low, high = min(low, self._state), max(high, self._state)
        return low, high

    def prepare(self, *, progress: Callable[[int, int], None] | None = None) -> LivePreparation:
        """Make, before the first frame, every bank entry a gaze on the scene can need.

        A frame that needs an entry the bank lacks makes it (:attr:`LiveFrame.new_entries`),
        which takes about one offline render and freezes the screen meanwhile. This makes
        them all at once: for the adaptation levels between the extremes of
        :meth:`adaptation_range` (one bank step beyond each) and every pupil of the bank, the
        glare entries and, with ``acuity=True``, the acuity entries. ``bank_size`` grows to
        hold them. A gaze off the scene may still need an entry (made when needed, counted).

        Parameters
        ----------
        progress
            Called with ``(made, total)`` before the first entry and after each; default None.

        Returns
        -------
        LivePreparation

        Raises
        ------
        ValueError
            When the entries would not fit in the memory available (before making any).

        Notes
        -----
        The thresholds ``T = L_dmax / s`` of the range's ends give the bank's places
        ``log_r T``; the middle of every interval between them, and of one more below and
        above, each halved interval's parts included, is given to the frame's own choice of
        bank entries, so that the frames find what they look up.

        References
        ----------
        Luidolt 2020, Fig. 6.1 ("In the pre-processing step, we calculate all data, that does
        not change during our simulation").

        Examples
        --------
        >>> scene = np.full((24, 32, 3), 0.02)
        >>> scene[10:12, 15:17] = 5e4
        >>> live = LiveNight(scene, pixel_deg=0.1, pupils_mm=(4.0, 6.0))
        >>> made = live.prepare()
        >>> frame = live.frame(gaze_px=(2.0, 3.0), pupil_mm=5.0, frame_time_s=0.0)
        >>> made.entries > 0, frame.new_entries
        (True, 0)
        """
        start = time.perf_counter()
        low, high = self.adaptation_range()
        log_ratio = math.log(self.threshold_ratio)
        places = [  # the bank places (log_r T) of the two ends, T = L_dmax / s = L_dmax A / key
            math.log(self.l_dmax * max(a, MIN_LUMINANCE_CD_M2) / self.key) / log_ratio
            for a in (low, high)
        ]
        samples = []  # the middle of every (halved) interval from one step below to one above
        for base in range(math.floor(places[0]) - 1, math.floor(places[1]) + 2):
            parts = 2 ** self._halvings(base)
            samples += [
                (self.l_dmax / self.threshold_ratio ** (base + (k + 0.5) / parts), None)
                for k in range(parts)
            ]
        if self._has_regime:  # each regime's models for the frames beside a regime's bound
            samples = [(exposure, regime(self.key / exposure)) for exposure, _ in samples] + [
                (self.key / bound, regime(side))
                for bound in (SCOTOPIC_UPPER_CD_M2, MESOPIC_UPPER_CD_M2)
                if low / self.threshold_ratio <= bound <= high * self.threshold_ratio
                for side in (np.nextafter(bound, 0.0), np.nextafter(bound, math.inf))
            ]
        wanted: dict[tuple, tuple[int, GlareModel]] = {}
        for exposure, eye_regime in samples:
            for pupil in self.pupils_mm:
                for step, model, _ in self._terms(exposure, float(pupil), eye_regime):
                    wanted.setdefault((step, model), (step, model))
                    if self.acuity:
                        wanted.setdefault(("acuity", step, model), (step, model))
        missing = [key for key in wanted if key not in self._bank]
        pixels = self.shape[0] * self.shape[1]
        image_bytes = pixels * 3 * self.dtype.itemsize
        needed = sum(
            image_bytes + pixels * 3 if key[0] == "acuity" else image_bytes for key in missing
        )  # an acuity entry also keeps its white mask (1 byte) and reach (2 bytes) per pixel
        check_memory(needed, f"the live scene's {len(missing)} bank entries")
        self.bank_size = max(self.bank_size, len(self._bank) + len(missing) + BANK_SIZE)
        made = self.bank_entries
        if progress is not None:
            progress(0, len(missing))
        for index, key in enumerate(missing, start=1):
            step, model = wanted[key]
            if key[0] == "acuity":
                self._acuity_entry(step, model)
            else:
                self._entry(step, model)
            if progress is not None:
                progress(index, len(missing))
        return LivePreparation(
            entries=self.bank_entries - made,
            seconds=time.perf_counter() - start,
            adaptation_cd_m2=(low, high),
            bytes=needed,
        )


@dataclass(frozen=True)
class LivePreparation:
    """What :meth:`LiveNight.prepare` made.

    Attributes
    ----------
    entries
        Bank entries made.
    seconds
        Wall time, s.
    adaptation_cd_m2
        The range of adapted luminances prepared for, cd/m² (:meth:`LiveNight.adaptation_range`).
    bytes
        Memory of the entries made, bytes.
    """

    entries: int
    seconds: float
    adaptation_cd_m2: tuple[float, float]
    bytes: int
