"""Model only what a scene requires: plan the glare of one image from the scene and the display.

The glare that matters is the glare a display can show: an error below half a display code
cannot be seen. :func:`plan_glare` looks at the scene (which pixels exceed ``L_dmax``, how
bright and where, which pixels can still change) and at the display (how many cd/m² one code
step is at the darkest pixel that can change) and chooses the cheapest work whose error stays
under ``tolerance_codes``:

- **Only pixels above L_dmax are spread**, and only the bounding box of them is transformed.
- **Targets.** With Yoshida's clamp a pixel already at ``L_dmax`` cannot change; the kernel
  only has to reach from the bright pixels to the pixels that can.
- **Reach.** The kernel is cut where what its tail leaves out, times this scene's excess, is
  below a share of the tolerance: at most ``min(ΣΔL · peak_beyond, max ΔL · energy_beyond)``
  cd/m² anywhere (:meth:`~glare.VosGlare.tail_bound`; a rigorous bound, not an estimate).
- **Multi-resolution far tail.** Beyond a split radius ``R0`` the PSF is smooth, so the far
  part of the kernel is convolved on a grid ``f`` times coarser (block sums of ``ΔL``, the
  model digitised at ``f`` pixels, linear interpolation back), blended with the full-resolution
  near part over ``R0 … 2R0``. Its relative error is measured on the model itself, for a
  point source in the worst place of a coarse block; the output is then checked pixel by pixel
  through the display and rendered exactly if any pixel's error bound exceeds the tolerance.
- **Halo** (Vos mesopic/scotopic): dropped by the model itself when its pupil is under 3 mm
  (:attr:`~glare.VosGlare.halo_skipped`); the plan says so.
- **Colour**: a colour kernel is digitised only when the model's kernel differs between
  channels (a lenticular halo); an achromatic RGB scene with an achromatic kernel is convolved
  once and copied to the three channels.

The plan is an object (print it, or ``glarelab render --explain``); the rendered result
carries the error bound reached, in display codes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from ._convolve import FLOAT32_NOISE_LIMIT_CD_M2, bounding_box, convolution_dtype, spread
from ._validation import check_choice, check_image, check_positive
from .digitise import kernel_shape_for
from .models import GaussianGlare, GlareModel, _resolve

__all__ = [
    "DISPLAY_BITS",
    "DISPLAY_CONTRAST",
    "DISPLAY_GAMMA",
    "Display",
    "GlarePlan",
    "PlannedGlare",
    "plan_glare",
    "render_planned",
]

# The reference display used when none is given: a 10-bit (Yoshida 2008 and Luidolt 2020 ask
# for 10 bits), gamma 2.2, 1000:1 display whose white is L_dmax.
DISPLAY_BITS = 10
DISPLAY_GAMMA = 2.2
DISPLAY_CONTRAST = 1000.0

CUT_SHARE = 0.25  # share of the tolerance the reach cut may spend (its bound is rigorous)
FAR_SHARE = 0.5  # share the multi-resolution far tail may spend (checked per pixel afterwards)
MULTIRES_FACTORS = (8, 4)  # coarse grid factors tried, coarsest first
SPLIT_RATIOS = (16, 24, 32, 48, 64)  # R0 / f tried, shortest first: error falls as (f / R0)²
MULTIRES_MIN_REACH = 4  # multi-resolution only when the reach is at least 4 R0
# Splatting and linear interpolation blur the far kernel by two tents of variance f²/6 each,
# a relative error of about (f²/3) ∇²K / K; for the r^-2 tail of f2 that is 1.3 (f/r)² at r.
# Measured on VosGlare (all regimes) at r = R0: 0.004 for R0 = 16 f, i.e. ≈ (f / R0)².
FAR_ERROR_SAFETY = 0.25  # predicted relative error = 0.25 (f / R0)², measured before convolving


@dataclass(frozen=True)
class Display:
    """A display as its code → luminance table (cd/m², increasing).

    A :class:`stimuli.calibration.Calibration` serves as well: the planner reads ``lut``.
    """

    lut: np.ndarray

    @classmethod
    def gamma(
        cls,
        white_cd_m2: float,
        *,
        black_cd_m2: float,
        bits: int = DISPLAY_BITS,
        gamma: float = DISPLAY_GAMMA,
    ) -> Display:
        """A gain-offset-gamma display: ``L = black + (white - black) (code / max)^γ``.

        Examples
        --------
        >>> d = Display.gamma(220.0, black_cd_m2=0.22)
        >>> d.lut.size, float(d.lut[0]), float(d.lut[-1])
        (1024, 0.22, 220.0)
        """
        white = check_positive("white_cd_m2", white_cd_m2, unit="cd/m²")
        black = float(black_cd_m2)
        if not 0.0 <= black < white:
            raise ValueError(f"black_cd_m2 must lie in [0, {white:g}) cd/m², got {black_cd_m2!r}")
        levels = np.linspace(0.0, 1.0, 2**bits)
        return cls(lut=black + (white - black) * levels**gamma)


def _lut(display) -> np.ndarray:
    lut = np.asarray(getattr(display, "lut", display), dtype=float)
    if lut.ndim != 1 or lut.size < 2 or not np.all(np.diff(lut) > 0):
        raise ValueError(
            "display must have a 1-D increasing code → cd/m² table (.lut) of >= 2 codes"
        )
    return lut


def display_codes(luminance_cd_m2: np.ndarray, lut: np.ndarray) -> np.ndarray:
    """Continuous display codes of luminances (clipped to the display's range)."""
    values = np.clip(luminance_cd_m2, lut[0], lut[-1])
    return np.interp(values, lut, np.arange(lut.size, dtype=float))


def _steps_above(lut: np.ndarray) -> np.ndarray:
    """For each code, the smallest step (cd/m²) between it and white."""
    steps = np.diff(lut)
    return np.minimum.accumulate(steps[::-1])[::-1]


@dataclass(frozen=True)
class GlarePlan:
    """What :func:`render_planned` will compute for one image, and why.

    Attributes
    ----------
    shape
        Image shape.
    model
        The model's description.
    tolerance_codes
        Largest error allowed, display codes.
    tolerance_cd_m2
        The same at the darkest pixel that can change (one code step there × tolerance).
    bright_pixels, source_box
        Pixels above ``L_dmax`` and their bounding box ``(row0, row1, col0, col1)``.
    max_excess_cd_m2, total_excess
        Largest ``ΔL`` and ``ΣΔL`` (cd/m² × pixels) over the channels.
    target_pixels, target_box
        Pixels whose output can change, and their bounding box.
    geometric_reach_px
        Half-size ``(rows, cols)`` that lets every bright pixel reach every target.
    reach_px
        Half-size of the kernel after the tolerance cut.
    cut_bound_cd_m2
        Rigorous bound on what the cut leaves out, anywhere in the image.
    multires_factor, split_px
        Coarse grid factor ``f`` of the far tail and the split radius ``R0`` (0: off).
    colour, colour_kernel, convolutions
        Whether the scene is RGB, whether the kernel differs between channels, and the number
        of convolutions planned.
    halo
        What happens to the lenticular halo.
    exact
        True when nothing is approximated (tolerance 0 or a model without a tail bound).
    notes
        Reasons, one line each.
    """

    shape: tuple[int, ...]
    model: dict
    tolerance_codes: float
    tolerance_cd_m2: float
    bright_pixels: int
    source_box: tuple[int, int, int, int] | None
    max_excess_cd_m2: float
    total_excess: float
    target_pixels: int
    target_box: tuple[int, int, int, int] | None
    geometric_reach_px: tuple[int, int]
    reach_px: tuple[int, int]
    cut_bound_cd_m2: float
    multires_factor: int
    split_px: int
    colour: bool
    colour_kernel: bool
    convolutions: int
    halo: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    preview: _Preview | None = field(default=None, repr=False, compare=False)

    @property
    def exact(self) -> bool:
        """True when nothing is approximated: no cut and no coarse far tail."""
        return self.cut_bound_cd_m2 == 0.0 and self.multires_factor == 1

    def __str__(self) -> str:
        full = kernel_shape_for(self.shape[:2])
        reach = self.reach_px
        lines = [
            f"glare plan for a {self.shape[1]} × {self.shape[0]} "
            f"{'RGB' if self.colour else 'luminance'} image, model {self.model.get('model')}",
            f"  tolerance: {self.tolerance_codes:g} display codes"
            f" = {self.tolerance_cd_m2:.3g} cd/m² at the darkest pixel that can change",
            f"  bright: {self.bright_pixels} px above L_dmax, max ΔL {self.max_excess_cd_m2:.4g}"
            f" cd/m², ΣΔL {self.total_excess:.4g} cd/m²·px, box {self.source_box}",
            f"  targets: {self.target_pixels} px can change, box {self.target_box}",
            f"  reach: ±{reach[0]} × ±{reach[1]} px (geometric need ±{self.geometric_reach_px[0]}"
            f" × ±{self.geometric_reach_px[1]}; the full kernel is {full[0]} × {full[1]});"
            f" the cut leaves out at most {self.cut_bound_cd_m2:.3g} cd/m²",
        ]
        if self.multires_factor > 1:
            near = 4 * self.split_px + 1
            lines.append(
                f"  near part: {near} × {near} px at full resolution; far tail beyond "
                f"{self.split_px} px (blended to {2 * self.split_px} px) on a grid "
                f"{self.multires_factor}× coarser"
            )
        else:
            lines.append(
                f"  kernel: {2 * reach[0] + 1} × {2 * reach[1] + 1} px at full resolution"
            )
        lines.append(
            f"  colour: {'RGB scene' if self.colour else 'luminance scene'}, "
            f"{'colour' if self.colour_kernel else 'achromatic'} kernel, "
            f"{self.convolutions} convolution(s)"
        )
        lines.append(f"  halo: {self.halo}")
        lines += [f"  - {note}" for note in self.notes]
        return "\n".join(lines)


@dataclass(frozen=True)
class PlannedGlare:
    """The result of :func:`render_planned`.

    Attributes
    ----------
    image
        The image with glare, cd/m².
    plan
        The plan that was carried out (after any fallback).
    error_bound_codes
        Bound on the error against the exact render, display codes, largest over the image:
        the cut's rigorous bound plus the far tail's measured relative error times the far
        glare, both passed through the display.
    far_relative_error
        Measured relative error of the multi-resolution kernel (0 when not used).
    fallback
        Why the plan was changed while rendering, or ``''``.
    """

    image: np.ndarray
    plan: GlarePlan
    error_bound_codes: float
    far_relative_error: float
    fallback: str = ""


def _box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _geometric_reach(source, target) -> tuple[int, int]:
    if source is None or target is None:
        return (0, 0)
    rows = max(target[1] - 1 - source[0], source[1] - 1 - target[0], 0)
    cols = max(target[3] - 1 - source[2], source[3] - 1 - target[2], 0)
    return int(rows), int(cols)


def _achromatic_kernel(model: GlareModel) -> bool:
    weights = getattr(model, "weights", None)
    if weights is not None and not callable(weights):
        return weights[3] == 0.0
    return isinstance(model, GaussianGlare)


def plan_glare(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float,
    method: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    tolerance_codes: float = 0.5,
    display=None,
) -> GlarePlan:
    """Plan the glare of one image: what to spread, how far, at what resolution.

    Parameters
    ----------
    luminance_cd_m2
        Linear luminance, cd/m², ``(H, W)`` or ``(H, W, 3)``, finite and >= 0.
    model
        A glare model or its name.
    pixel_deg
        Visual angle of one pixel, degrees, > 0.
    l_dmax_cd_m2
        Maximum luminance the display shows, cd/m², > 0.
    method
        ``'Yoshida2008'`` (clamped to ``L_dmax``: saturated pixels cannot change) or
        ``'Spencer1995'`` (every pixel can change).
    tolerance_codes
        Largest error allowed, in display codes, >= 0; default 0.5 (half a code step cannot
        be seen). 0 plans the exact render.
    display
        The display the image is for: a :class:`Display`, a calibration (anything with a
        code → cd/m² ``lut``) or ``None`` for the reference display: 10-bit, gamma 2.2,
        1000:1, white at ``l_dmax_cd_m2``.

    Returns
    -------
    GlarePlan

    Raises
    ------
    ValueError
        For a bad image, a non-positive ``pixel_deg`` or ``l_dmax_cd_m2``, a negative or
        non-finite tolerance, an unknown method, or a display table that is not increasing.

    Notes
    -----
    The cut's error anywhere is at most :math:`\\min(\\Sigma\\Delta L \\cdot K_{max}(r),
    \\max\\Delta L \\cdot E(r))` with :math:`K_{max}(r)` the largest kernel pixel and
    :math:`E(r)` the energy beyond the cut (plus :math:`\\max\\Delta L \\, E/(1-E)` for a
    model normalised over its support).

    Examples
    --------
    >>> from glare import GaussianGlare
    >>> image = np.full((101, 101), 100.0)
    >>> image[50, 50] = 5000.0
    >>> plan = plan_glare(image, GaussianGlare(sigma_deg=0.1), pixel_deg=0.02,
    ...                   l_dmax_cd_m2=220.0)
    >>> plan.reach_px < plan.geometric_reach_px
    True
    """
    return _plan(
        *_checked(luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, method, tolerance_codes),
        method=method,
        lut=_display_lut(display, l_dmax_cd_m2),
    )[0]


def _checked(luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, method, tolerance_codes):
    """The public arguments, validated: image, model, pixel_deg, l_dmax, tolerance."""
    image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
    check_choice("method", method, ("Yoshida2008", "Spencer1995"))
    tolerance = float(tolerance_codes)
    if not math.isfinite(tolerance) or tolerance < 0:
        raise ValueError(f"tolerance_codes must be a finite number >= 0, got {tolerance_codes!r}")
    return image, _resolve(model), pixel_deg, l_dmax, tolerance


def _display_lut(display, l_dmax_cd_m2: float) -> np.ndarray:
    """The display's code → cd/m² table; the reference display when ``display`` is None."""
    if display is None:
        l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
        return Display.gamma(l_dmax, black_cd_m2=l_dmax / DISPLAY_CONTRAST).lut
    return _lut(display)


def _plan(
    image, glare_model, pixel_deg, l_dmax, tolerance, *, method, lut
) -> tuple[GlarePlan, np.ndarray]:
    """The plan, and the excess ``ΔL`` as ``(H, W, C)`` (the renderer reuses it)."""
    colour = image.ndim == 3
    planes = image if colour else image[..., None]
    excess = np.maximum(planes - l_dmax, 0.0)
    bright = (excess > 0).any(axis=2)
    if method == "Yoshida2008":
        targets = (planes < l_dmax).any(axis=2)
    elif method == "Spencer1995":
        targets = np.ones(bright.shape, dtype=bool)
    else:
        raise ValueError(f"method must be 'Yoshida2008' or 'Spencer1995'; got {method!r}")
    source_box, target_box = _box(bright), _box(targets)
    geometric = _geometric_reach(source_box, target_box)
    max_excess = float(excess.max())
    total_excess = float(excess.sum(axis=(0, 1)).max())
    notes = []

    # one code step at the darkest pixel that can change, in cd/m²
    if targets.any():
        # the darkest channel of any pixel is a target's (Yoshida: some channel below L_dmax)
        darkest = float(planes.min())
        code = int(np.floor(display_codes(np.array(darkest), lut)))
        step = float(_steps_above(lut)[min(code, lut.size - 2)])
    else:
        step = float(np.diff(lut).min())
    tolerance_cd_m2 = tolerance * step

    colour_kernel = colour and not _achromatic_kernel(glare_model)
    achromatic_scene = colour and bool(
        np.array_equal(image[..., 0], image[..., 1])
        and np.array_equal(image[..., 0], image[..., 2])
    )
    if not colour:
        convolutions = 1
    elif achromatic_scene and not colour_kernel:
        convolutions = 1
        notes.append("achromatic scene and kernel: one convolution, copied to R, G and B")
    else:
        convolutions = 3
    if getattr(glare_model, "halo_skipped", False):
        halo = f"skipped: pupil {glare_model.pupil_mm:g} mm < 3 mm (Spencer §2.1)"
    elif _achromatic_kernel(glare_model):
        halo = "none in this model"
    else:
        halo = "included" + (" (colour kernel)" if colour_kernel else " (luminance)")

    reach = geometric
    cut_bound = 0.0
    factor, split, preview = 1, 0, None
    tail_bound = getattr(glare_model, "tail_bound", None)
    bound = None
    if tolerance > 0 and source_box is not None and max(geometric) > 0 and tail_bound:
        radii = np.arange(max(geometric) + 1)
        bound = tail_bound(pixel_deg, radii, colour=colour_kernel)
    if bound is not None:
        left_out = np.minimum(total_excess * bound.peak, max_excess * bound.energy)
        if bound.renormalised:
            left_out = left_out + max_excess * bound.energy / np.maximum(1 - bound.energy, 1e-300)
        fits = np.flatnonzero(left_out <= CUT_SHARE * tolerance_cd_m2)
        radius = int(fits[0]) if fits.size else int(radii[-1])
        reach = (min(geometric[0], radius), min(geometric[1], radius))
        cut_bound = 0.0 if reach == geometric else float(left_out[max(reach)])
        if reach != geometric:
            notes.append(
                f"kernel cut at {max(reach) * pixel_deg:.3g}°: beyond it the tail holds at most "
                f"{cut_bound:.3g} cd/m² of this scene's glare"
            )
        factor, split, predicted, preview = _choose_multires(
            glare_model,
            excess,
            planes,
            targets,
            reach,
            source_box,
            pixel_deg=pixel_deg,
            l_dmax=l_dmax,
            method=method,
            lut=lut,
            colour_kernel=colour_kernel,
            budget=FAR_SHARE * tolerance,
        )
        if factor > 1:
            notes.append(
                f"far tail beyond {split} px at 1/{factor} resolution: a coarse preview "
                f"predicts {predicted:.3g} codes of error at most"
            )
        elif max(reach) < MULTIRES_MIN_REACH * SPLIT_RATIOS[0] * MULTIRES_FACTORS[-1]:
            notes.append("far tail at full resolution: the kernel's reach is too short to gain")
        else:
            notes.append(
                f"far tail at full resolution: a coarse preview predicts {predicted:.3g} codes "
                "of error even at the longest split"
            )
    elif tolerance == 0:
        notes.append("tolerance 0: exact render")
    elif source_box is None:
        notes.append("nothing above L_dmax: the image is returned unchanged")
    elif target_box is None:
        notes.append("every pixel is at L_dmax: Yoshida's clamp leaves nothing to spread into")
    elif not tail_bound or bound is None:
        notes.append("the model has no tail bound (flare lines or wave optics): full reach")
    return GlarePlan(
        shape=tuple(image.shape),
        model=glare_model.description(colour_kernel)
        if hasattr(glare_model, "description") and callable(glare_model.description)
        else {"model": type(glare_model).__name__},
        tolerance_codes=tolerance,
        tolerance_cd_m2=tolerance_cd_m2,
        bright_pixels=int(bright.sum()),
        source_box=source_box,
        max_excess_cd_m2=max_excess,
        total_excess=total_excess,
        target_pixels=int(targets.sum()),
        target_box=target_box,
        geometric_reach_px=geometric,
        reach_px=reach,
        cut_bound_cd_m2=cut_bound,
        multires_factor=factor,
        split_px=split,
        colour=colour,
        colour_kernel=colour_kernel,
        convolutions=convolutions,
        halo=halo,
        notes=tuple(notes),
        preview=preview,
    ), excess


@dataclass(frozen=True)
class _Preview:
    """The scene's spread on a coarse grid, to predict a far path's error in codes."""

    factor: int
    coarse_kernel: np.ndarray  # the model digitised at f pixels, unweighted, all channels
    spread: np.ndarray  # at the nodes whose cell holds a target
    darkest: np.ndarray  # the darkest target in each such cell
    ratios: tuple[int, ...]  # R0 / f the geometry allows
    l_dmax: float
    method: str
    lut: np.ndarray

    def codes(self, relative: float) -> float:
        """Predicted largest error, display codes, for a far path of this relative error."""
        if self.method == "Yoshida2008":
            out = np.minimum(self.darkest + self.spread, self.l_dmax)
        else:
            out = np.minimum(self.darkest, self.l_dmax) + self.spread
        bound = relative / max(1.0 - relative, 1e-12) * self.spread
        return _error_codes(
            out, bound, self.darkest, self.spread, self.l_dmax, self.method, self.lut
        )


def _choose_multires(
    model,
    excess,
    planes,
    targets,
    reach,
    source_box,
    *,
    pixel_deg,
    l_dmax,
    method,
    lut,
    colour_kernel,
    budget,
) -> tuple[int, int, float, _Preview | None]:
    """The coarsest factor and shortest split whose predicted error fits ``budget`` codes.

    The spread is previewed on the coarse grid (cheap), and the far path's relative error
    predicted as ``FAR_ERROR_SAFETY (f / R0)²``; the render measures it on the model before
    convolving. Returns ``(f, R0, predicted codes, preview)``, or ``(1, 0, best predicted,
    None)`` when none fits.
    """
    best = math.inf
    for factor in MULTIRES_FACTORS:
        ratios = tuple(
            k
            for k in SPLIT_RATIOS
            if max(reach) >= MULTIRES_MIN_REACH * k * factor
            and min(reach) >= 2 * k * factor + 2 * factor
        )
        if not ratios:
            continue
        rc = (reach[0] // factor + 2, reach[1] // factor + 2)
        coarse = model.kernel(
            pixel_deg * factor, (2 * rc[0] + 1, 2 * rc[1] + 1), colour=colour_kernel
        ).values
        brightest = coarse if coarse.ndim == 2 else coarse.max(axis=2)
        # on the coarse grid: the spread at the nodes over the darkest target of each cell
        nodes = _far_spread(
            excess.max(axis=2), brightest / factor**2, factor, source_box, nodes=True
        )
        darkest = _block_min(np.where(targets, planes.min(axis=2), np.inf), factor)
        keep = np.isfinite(darkest)
        preview = _Preview(factor, coarse, nodes[keep], darkest[keep], ratios, l_dmax, method, lut)
        for k in ratios:
            predicted = preview.codes(FAR_ERROR_SAFETY / k**2)
            best = min(best, predicted)
            if predicted <= budget:
                return factor, k * factor, predicted, preview
    return 1, 0, best, None


def _blend(radius_px: np.ndarray, split_px: int) -> np.ndarray:
    """Weight of the far part: 0 within ``R0``, 1 beyond ``2 R0``, between them Perlin's
    smootherstep ``6t⁵ - 15t⁴ + 10t³``, whose first and second derivatives vanish at both
    ends (a kink in ``w''`` would cost cubic interpolation an order)."""
    t = np.clip((radius_px - split_px) / split_px, 0.0, 1.0)
    return t**3 * (t * (6.0 * t - 15.0) + 10.0)


def _radius(shape: tuple[int, int], scale: float = 1.0) -> np.ndarray:
    y = (np.arange(shape[0]) - shape[0] // 2) * scale
    x = (np.arange(shape[1]) - shape[1] // 2) * scale
    return np.hypot(y[:, None], x[None, :])


def _channels(values: np.ndarray) -> list[np.ndarray]:
    return [values] if values.ndim == 2 else [values[..., c] for c in range(values.shape[2])]


PAD_NODES = 2  # nodes in front of the first cell, so that every cubic weight is on the grid


def _cubic(n_fine: int, factor: int, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Cubic-convolution weights (Keys 1981, a = -½) between fine pixels
    ``start … start + n_fine - 1`` and the nodes of a grid ``f`` times coarser.

    Node ``j`` sits at the centre of coarse cell ``j - PAD_NODES``, fine coordinate
    ``(j - PAD_NODES) f + (f - 1) / 2``. Returns each pixel's first node (of four) and the
    ``(n_fine, 4)`` weights. The weights reproduce quadratics, so interpolating with them, or
    splatting with them (the adjoint), is exact to second order.
    """
    u = (np.arange(start, start + n_fine) + 0.5) / factor - 0.5
    base = np.floor(u)
    t = (u - base)[:, None]
    weights = np.hstack(
        [
            -0.5 * t**3 + t**2 - 0.5 * t,
            1.5 * t**3 - 2.5 * t**2 + 1.0,
            -1.5 * t**3 + 2.0 * t**2 + 0.5 * t,
            0.5 * t**3 - 0.5 * t**2,
        ]
    )
    return base.astype(np.int64) + PAD_NODES - 1, weights


def _node_matrix(first: np.ndarray, weights: np.ndarray, n_nodes: int) -> np.ndarray:
    matrix = np.zeros((n_nodes, first.size))
    index = np.arange(first.size)
    for tap in range(4):
        matrix[first + tap, index] += weights[:, tap]
    return matrix


def _splat(excess: np.ndarray, factor: int, box, grid: tuple[int, int]) -> np.ndarray:
    """Distribute each pixel of ``excess`` (within ``box``) over its 4 × 4 nearest coarse
    nodes with cubic weights: the total, centroid and second moments of the excess are kept,
    so the coarse convolution is off only in third order of ``f / r``."""
    r0, r1, c0, c1 = box
    out = np.zeros(grid)
    rows, row_w = _cubic(r1 - r0, factor, r0)
    cols, col_w = _cubic(c1 - c0, factor, c0)
    lo_r, hi_r = rows.min(), rows.max() + 4
    lo_c, hi_c = cols.min(), cols.max() + 4
    left = _node_matrix(rows - lo_r, row_w, hi_r - lo_r)
    right = _node_matrix(cols - lo_c, col_w, hi_c - lo_c)
    out[lo_r:hi_r, lo_c:hi_c] = left @ excess[r0:r1, c0:c1] @ right.T
    return out


def _upsample(coarse: np.ndarray, factor: int, shape: tuple[int, int]) -> np.ndarray:
    """Cubic interpolation of the coarse nodes onto the fine pixels (the adjoint of
    :func:`_splat`)."""
    rows = _node_matrix(*_cubic(shape[0], factor), coarse.shape[0])
    cols = _node_matrix(*_cubic(shape[1], factor), coarse.shape[1])
    return (rows.T @ coarse) @ cols  # two dense products: BLAS beats gathering taps


def _sharpen_cells(cells: np.ndarray) -> np.ndarray:
    """Point values from cell averages to second order: ``K - (1/24) Δ K`` (a cell average
    is the point value blurred by a box of variance 1/12 per axis)."""
    padded = np.pad(cells, [(1, 1), (1, 1)] + [(0, 0)] * (cells.ndim - 2), mode="edge")
    laplacian = (
        padded[:-2, 1:-1] + padded[2:, 1:-1] + padded[1:-1, :-2] + padded[1:-1, 2:] - 4.0 * cells
    )
    return cells - laplacian / 24.0


def _far_spread(
    excess: np.ndarray, far: np.ndarray, factor: int, box, *, nodes: bool = False
) -> np.ndarray:
    """The far tail's spread of one channel: splat, convolve on the coarse grid, interpolate
    (or, with ``nodes``, the values at the coarse nodes)."""
    grid = tuple(-(-n // factor) + 2 * PAD_NODES for n in excess.shape)
    coarse = _splat(excess, factor, box, grid)
    spread_coarse = spread(coarse, far, bounding_box(coarse != 0))
    return spread_coarse if nodes else _upsample(spread_coarse, factor, excess.shape)


def _block_min(values: np.ndarray, factor: int) -> np.ndarray:
    """Minimum over each ``f × f`` cell (``inf`` beyond the image), on the node grid."""
    height, width = values.shape
    grid = np.full((-(-height // factor) * factor, -(-width // factor) * factor), np.inf)
    grid[:height, :width] = values
    cells = grid.reshape(grid.shape[0] // factor, factor, -1, factor).min(axis=(1, 3))
    out = np.full((cells.shape[0] + 2 * PAD_NODES, cells.shape[1] + 2 * PAD_NODES), np.inf)
    out[PAD_NODES:-PAD_NODES, PAD_NODES:-PAD_NODES] = cells
    return out


@dataclass(frozen=True)
class _MultiresKernels:
    near: np.ndarray  # (KH, KW[, C]) full resolution, (1 - w) K within 2 R0
    far: np.ndarray  # coarse, w K / f²
    relative_error: float


def _multires_kernels(model, pixel_deg, factor, split, colour, coarse) -> _MultiresKernels:
    """Near and far kernels, and the far path's relative error measured on the model.

    The error is measured for a point source at each corner and the centre of a coarse
    block, against the full-resolution kernel within ``3 R0`` (where the far part starts and
    its relative error, which falls as ``f / r``, is largest).
    """
    window = 2 * split + 2 * factor
    fine = model.kernel(pixel_deg, (2 * window + 1, 2 * window + 1), colour=colour).values
    w_fine = _blend(_radius(fine.shape[:2]), split)
    w_coarse = _blend(_radius(coarse.shape[:2], factor), split)
    if fine.ndim == 3:
        w_fine, w_coarse = w_fine[..., None], w_coarse[..., None]
    near_full = (1.0 - w_fine) * fine
    c = window - 2 * split
    near = near_full[c : fine.shape[0] - c, c : fine.shape[1] - c]
    # point values of K at the nodes, then the blend (sharpening w K would blur w too)
    far = w_coarse * _sharpen_cells(coarse) / factor**2
    worst = 0.0
    base = factor * (window // factor + 2)
    size = base + factor + window + 1
    # the corners of a block (where the source is farthest from a node) and its centre
    corners = sorted({0, factor - 1})
    positions = [(dy, dx) for dy in corners for dx in corners] + [(factor // 2,) * 2]
    for dy, dx in positions:
        q = (base + dy, base + dx)
        point = np.zeros((size, size))
        point[q] = 1.0
        box = (q[0], q[0] + 1, q[1], q[1] + 1)
        window_slice = np.s_[q[0] - window : q[0] + window + 1, q[1] - window : q[1] + window + 1]
        for n_k, f_k, exact in zip(
            _channels(near_full), _channels(far), _channels(fine), strict=True
        ):
            approx = n_k + _far_spread(point, f_k, factor, box)[window_slice]
            ratio = np.abs(approx - exact)[exact > 0] / exact[exact > 0]
            worst = max(worst, float(ratio.max()))
    return _MultiresKernels(near=near, far=far, relative_error=worst)


def _convolve(excess, kernels, source_box, dtype, *, into=None) -> np.ndarray:
    """Full-resolution spread of one channel; float64 when float32 round-off could show."""
    k = kernels.astype(dtype, copy=False)
    work = convolution_dtype(excess, k, dtype)
    rows, cols = slice(source_box[0], source_box[1]), slice(source_box[2], source_box[3])
    return spread(
        excess.astype(work, copy=False), k.astype(work, copy=False), (rows, cols), into=into
    )


def _error_codes(out, bound, planes, spread_values, l_dmax, method, lut) -> float:
    """Bound on the largest error in display codes when the exact spread lies within
    ``± bound`` of ``spread_values`` (cd/m², per pixel or one number).

    Pixels whose range of possible values is clipped away by the display (all below black,
    or all at or above white or Yoshida's clamp) cannot be off. Pixels at or above the
    luminance from which every code step exceeds ``2 max(bound)`` are off by less than half a
    code step there (no table look-up); the rest are looked up through the display."""
    bound = np.broadcast_to(bound, np.shape(spread_values))
    if method == "Yoshida2008":
        high = np.minimum(planes + spread_values + bound, l_dmax)
        low = np.minimum(planes + np.maximum(spread_values - bound, 0.0), l_dmax)
    else:
        base = np.minimum(planes, l_dmax)
        high = base + spread_values + bound
        low = base + np.maximum(spread_values - bound, 0.0)
    top = min(lut[-1], l_dmax if method == "Yoshida2008" else np.inf)
    visible = (high > lut[0]) & (low < top)
    if not visible.any():
        return 0.0
    steps = _steps_above(lut)
    largest = float(bound.max())
    wide = np.flatnonzero(steps >= 2.0 * largest)  # steps_above is non-decreasing
    quick = 0.0
    if wide.size and largest > 0:
        above = visible & (low >= lut[wide[0]])
        visible &= ~above
        quick = largest / steps[wide[0]] if above.any() else 0.0
        if not visible.any():
            return quick
    codes = display_codes(out[visible], lut)
    return float(
        max(
            quick,
            np.max(display_codes(high[visible], lut) - codes),
            np.max(codes - display_codes(low[visible], lut)),
        )
    )


def render_planned(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float,
    method: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    precision: Literal["float64", "float32"] = "float64",
    tolerance_codes: float = 0.5,
    display=None,
    log=None,
) -> PlannedGlare:
    """Add glare as :func:`plan_glare` plans it, and bound the error reached.

    Parameters
    ----------
    luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, method, tolerance_codes, display
        As for :func:`plan_glare`.
    precision
        ``'float64'`` or ``'float32'``, as for :func:`glare.render_glare`.
    log
        Called with one line per step, or ``None``.

    Returns
    -------
    PlannedGlare

    Raises
    ------
    ValueError
        As for :func:`plan_glare`, and for an unknown precision.

    Notes
    -----
    The error bound per pixel is ``ε / (1 - ε) · S(p) + cut`` cd/m², with ``ε`` the far
    path's measured relative error, ``S`` the spread and ``cut`` the plan's rigorous bound,
    passed through the display (codes of the clamped output at both ends). When it exceeds
    the tolerance anywhere, the far tail is rendered at full resolution instead.

    Examples
    --------
    >>> from glare import VosGlare
    >>> image = np.full((64, 64), 50.0)
    >>> image[32, 32] = 1e5
    >>> result = render_planned(image, VosGlare(), pixel_deg=0.05, l_dmax_cd_m2=220.0)
    >>> result.error_bound_codes <= 0.5
    True
    """
    check_choice("precision", precision, ("float64", "float32"))
    image, glare_model, pixel_deg, l_dmax, tolerance = _checked(
        luminance_cd_m2, model, pixel_deg, l_dmax_cd_m2, method, tolerance_codes
    )
    lut = _display_lut(display, l_dmax)
    plan, planned_excess = _plan(
        image, glare_model, pixel_deg, l_dmax, tolerance, method=method, lut=lut
    )
    say = log or (lambda line: None)
    dtype = np.dtype(precision)
    if plan.source_box is None:
        return PlannedGlare(image.copy(), plan, 0.0, 0.0)
    planes = (image if plan.colour else image[..., None]).astype(dtype, copy=False)
    if method == "Yoshida2008" and plan.target_pixels == 0:
        out = np.minimum(planes, dtype.type(l_dmax))
        return PlannedGlare(out if plan.colour else out[..., 0], plan, 0.0, 0.0)
    excess = (
        planned_excess
        if planned_excess.dtype == dtype
        else np.maximum(planes - dtype.type(l_dmax), dtype.type(0))
    )
    n_conv = plan.convolutions
    sources = [excess[..., 0]] if n_conv == 1 else [excess[..., c] for c in range(3)]

    def full_resolution() -> tuple[list[np.ndarray], bool]:
        shape = (2 * plan.reach_px[0] + 1, 2 * plan.reach_px[1] + 1)
        say(f"digitising a {shape[0]} × {shape[1]} kernel")
        kernel = glare_model.kernel(pixel_deg, shape, colour=plan.colour_kernel).values
        ks = _channels(kernel)
        results, used32 = [], False
        for i, e in enumerate(sources):
            k = ks[min(i, len(ks) - 1)]
            s = _convolve(e, k, plan.source_box, dtype)
            used32 |= s.dtype == np.float32
            results.append(np.maximum(s, 0.0))
        return results, used32

    relative, fallback, kernels = 0.0, "", None
    if plan.multires_factor > 1:
        f, preview = plan.multires_factor, plan.preview
        budget = FAR_SHARE * plan.tolerance_codes
        for k in (k for k in preview.ratios if k * f >= plan.split_px):
            say(f"multi-resolution kernels: split {k * f} px, far tail at 1/{f}")
            kernels = _multires_kernels(
                glare_model, pixel_deg, f, k * f, plan.colour_kernel, preview.coarse_kernel
            )
            predicted = preview.codes(kernels.relative_error)
            say(
                f"far path relative error (worst point source) {kernels.relative_error:.3g}:"
                f" {predicted:.3g} codes predicted"
            )
            if kernels.relative_error < 1.0 and predicted <= budget:
                plan = replace(plan, split_px=k * f)
                break
            kernels = None
        if kernels is None:
            fallback = "the far path's measured error does not fit the tolerance"
            say(fallback + ": full resolution")
            plan = replace(plan, multires_factor=1, split_px=0)
    if kernels is not None:
        relative = kernels.relative_error
        near_ks, far_ks = _channels(kernels.near), _channels(kernels.far)
        spreads, used32 = [], False
        for i, e in enumerate(sources):
            total = _far_spread(
                e.astype(np.float64), far_ks[min(i, len(far_ks) - 1)], f, plan.source_box
            )
            # the near part is non-zero only around the bright box: added there, in place
            k = near_ks[min(i, len(near_ks) - 1)]
            used32 |= convolution_dtype(e, k.astype(dtype, copy=False), dtype) == np.float32
            _convolve(e, k, plan.source_box, dtype, into=total)
            spreads.append(np.maximum(total, 0.0, out=total))
    else:
        spreads, used32 = full_resolution()
    while True:
        if plan.colour:
            spread_values = np.stack(spreads * (3 if n_conv == 1 else 1), axis=-1)
        else:
            spread_values = spreads[0][..., None]  # a view: no copy of a large image
        spread_values = spread_values.astype(dtype, copy=False)
        if method == "Yoshida2008":
            out = np.add(planes, spread_values)
            np.minimum(out, dtype.type(l_dmax), out=out)
        else:
            out = np.minimum(planes, dtype.type(l_dmax))
            out += spread_values
        bound = plan.cut_bound_cd_m2 + (FLOAT32_NOISE_LIMIT_CD_M2 if used32 else 0.0)
        if relative:
            bound = bound + relative / max(1.0 - relative, 1e-12) * spread_values
        error = (
            _error_codes(out, bound, planes, spread_values, l_dmax, method, lut)
            if np.any(bound)
            else 0.0
        )
        if plan.multires_factor > 1 and error > plan.tolerance_codes:
            fallback = (
                f"far tail error bound {error:.3g} codes > {plan.tolerance_codes:g}: "
                "rendered at full resolution"
            )
            say(fallback)
            plan = replace(plan, multires_factor=1, split_px=0)
            relative = 0.0
            spreads, used32 = full_resolution()
            continue
        break
    say(f"error bound {error:.3g} display codes")
    return PlannedGlare(
        image=out if plan.colour else out[..., 0],
        plan=plan,
        error_bound_codes=error,
        far_relative_error=relative,
        fallback=fallback,
    )
