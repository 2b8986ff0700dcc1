"""Plan the glare of one image from the scene and the display: the cheapest exact-enough path.

The glare that matters is the glare a display can show: an error below half a display code
cannot be seen. :func:`plan_glare` looks at the scene (which pixels exceed ``L_dmax``, how
bright and where, which pixels can still change) and at the display (how many cd/m² one code
step is at the darkest pixel that can change) and chooses the cheapest of three paths whose
error stays under ``tolerance_codes``:

- **direct**: each cluster of bright pixels is correlated with the kernel, or each bright
  pixel adds a scaled copy of it (no FFT round-off; the copies summed in float32 where
  their bound keeps the tolerance; for a few glints and lamps);
- **fft**: one forward and one inverse FFT of the bright pixels' box with the kernel's
  spectrum, kept by the renderer across images (exact);
- **multires**: the near kernel at full resolution, the far tail on a grid ``f`` times
  coarser (:mod:`glarelab.glare.rendering.multires`), its relative error measured on the model.

What is spread, and how far:

- **Only pixels above L_dmax are spread**, and only the bounding box of them is transformed.
- **Targets.** With Yoshida's clamp a pixel already at ``L_dmax`` cannot change; the kernel
  only has to reach from the bright pixels to the pixels that can.
- **Reach.** The kernel is cut where what its tail leaves out, times this scene's excess, is
  below a share of the tolerance: at most ``min(ΣΔL · peak_beyond, max ΔL · energy_beyond)``
  cd/m² anywhere (:meth:`~glarelab.glare.GlareModel.tail_bound`; a rigorous bound, not an
  estimate).
- **Colour**: a colour kernel is used only when the model's kernel differs between channels
  (:attr:`~glarelab.glare.GlareModel.achromatic`); an achromatic RGB scene with an achromatic
  kernel is convolved once and copied to the three channels.

The plan is an object (print it, or ``glarelab render --explain``); the rendered result
carries the error bound reached, in display codes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import scipy.fft

from glarelab.glare.models.base import GlareModel
from glarelab.glare.rendering._convolve import (
    SPAN32_MAX_TOTAL_EXCESS,
    SPAN_LAYOUT_S,
    cluster_ways,
    fft_length,
    fft_workers,
    span_layout_values,
    span_roundoff,
    span_values,
)
from glarelab.glare.rendering.costs import (
    DEFAULT_COSTS,
    DIRECT_COST_SIDE,
    PathCosts,
    coarse_lengths,
    fft_unit,
    n_log_n,
)
from glarelab.glare.rendering.display import block_reduce
from glarelab.glare.rendering.multires import PAD_NODES, cell_sums, far_spread
from glarelab.glare.rendering.scene import Scene

__all__ = ["CUT_SHARE", "FAR_SHARE", "PATHS", "GlarePlan", "plan_glare"]

PATHS = ("direct", "fft", "multires")

CUT_SHARE = 0.25  # share of the tolerance the reach cut may spend (its bound is rigorous)
FAR_SHARE = 0.5  # share the multi-resolution far tail may spend (checked per pixel afterwards)
# Cells of LEAST_FACTOR² pixels over which the precision's question bounds the spread from
# below (_least_spread): the kernel's least value over offsets ±(f - 1) around each cell
# offset. On the 1024² city at night (Vos, 0.04°/px) the bound at its darkest cell was 0.83
# of the exact spread's minimum at 8 pixels; a coarse convolution of 128² cells, 2-3 ms.
LEAST_FACTOR = 8
MULTIRES_FACTORS = (8, 4)  # coarse grid factors tried, coarsest first
SPLIT_RATIOS = (16, 24, 32, 48, 64)  # R0 / f tried, shortest first: error falls as (f / R0)²
MULTIRES_MIN_REACH = 4  # multi-resolution only when the reach is at least 4 R0
# Which split to measure first: the far path's relative error is about 0.25 (f / R0)²
# (measured on VosGlare, all regimes: 5e-4 at R0 = 16 f); the render measures it exactly.
FAR_ERROR_SAFETY = 0.25
# Costs: glarelab.glare.rendering.costs.PathCosts, measured on the machine at the threads the
# render uses (a forward and an inverse real FFT of n points per n log2 n, a unit that grows
# with n where the arrays leave the caches, costs.fft_unit, and FFT_LARGE times that beyond
# FFT_LARGE_POINTS (8192² transforms, measured beside 4096² ones); the direct spread per
# output pixel; the far tail's splat and interpolation per image pixel, its coarse
# convolution per n log2 n of its own transform, the preview when not made yet, and the error
# bound that grows with the spread per image pixel, for the far tail and float32 transforms).
# Only their ratios choose the path. A kernel spectrum is made once per renderer and FFT
# length, so it is not counted.
FFT_LARGE = 5.5 / 4.5
FFT_LARGE_POINTS = 2**25


@dataclass(frozen=True)
class GlarePlan:
    """What the renderer will compute for one image, and why.

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
    path
        ``'none'`` (nothing above ``L_dmax``), ``'clamp'`` (nothing can change), ``'direct'``,
        ``'fft'`` or ``'multires'``.
    multires_factor, split_px
        Coarse grid factor ``f`` of the far tail and the split radius ``R0`` (1 and 0: off).
    colour, colour_kernel, convolutions
        Whether the scene is RGB, whether the kernel differs between channels, and the number
        of convolutions planned.
    halo
        What happens to the lenticular halo (the model says, :meth:`GlareModel.halo`).
    fft_precision, roundoff_cd_m2, roundoff_codes
        The precision of the FFTs (``'float32'`` where their round-off bound,
        :func:`~glarelab.glare.rendering._convolve.fft_roundoff`, with the cut's, keeps what
        the far tail leaves of the tolerance, else ``'float64'``), that bound's part
        that does not grow with the spread, cd/m², and the whole bound in display codes as
        planned (both 0 for float64: its round-off is counted by the render). Without a far
        tail, that bound is at least what the render's check would find pixel by pixel
        (:meth:`~glarelab.glare.rendering.display.CodeBound.roundoff_codes`), so a render of
        a float64 image reports it and does not check again.
    direct_precision
        The precision of the direct path's spans (``'float32'`` where their round-off bound,
        :func:`~glarelab.glare.rendering._convolve.span_roundoff`, keeps the tolerance with
        the cut's; then ``roundoff_cd_m2`` is that bound's absolute part and
        ``roundoff_codes`` its relative part's codes, added to the render's error bound).
    costs
        Estimated seconds of each path considered.
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
    path: Literal["none", "clamp", "direct", "fft", "multires"]
    multires_factor: int
    split_px: int
    colour: bool
    colour_kernel: bool
    convolutions: int
    halo: str
    fft_precision: str = "float64"
    direct_precision: str = "float64"
    roundoff_cd_m2: float = 0.0
    roundoff_codes: float = 0.0
    costs: dict = field(default_factory=dict)
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def exact(self) -> bool:
        """True when the kernel is not approximated: no cut and no coarse far tail (the
        transforms may still round in float32: :attr:`fft_precision`)."""
        return self.cut_bound_cd_m2 == 0.0 and self.multires_factor == 1

    @property
    def out_box(self) -> tuple[int, int, int, int] | None:
        """The pixels that can receive glare: the targets within reach of the bright box."""
        if self.source_box is None or self.target_box is None:
            return None
        (r0, r1, c0, c1), (t0, t1, u0, u1) = self.source_box, self.target_box
        a, b = self.reach_px
        box = (max(t0, r0 - a), min(t1, r1 + a), max(u0, c0 - b), min(u1, c1 + b))
        return box if box[0] < box[1] and box[2] < box[3] else None

    def __str__(self) -> str:
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
            f" × ±{self.geometric_reach_px[1]}); the cut leaves out at most "
            f"{self.cut_bound_cd_m2:.3g} cd/m²",
        ]
        if self.path == "multires":
            near = 4 * self.split_px + 1
            lines.append(
                f"  path: multires — near part {near} × {near} px at full resolution, far "
                f"tail beyond {self.split_px} px (blended to {2 * self.split_px} px) on a grid "
                f"{self.multires_factor}× coarser"
            )
        elif self.path == "direct":
            spans = (
                f"spans in float32, round-off at most {self.roundoff_codes:.2g} codes"
                if self.direct_precision == "float32"
                else "exact"
            )
            lines.append(
                f"  path: direct — each cluster of the {self.bright_pixels} bright pixels "
                f"correlated with a {2 * reach[0] + 1} × {2 * reach[1] + 1} px kernel or a "
                f"copy of it per pixel ({spans})"
            )
        elif self.path == "fft":
            lines.append(
                f"  path: fft — a {2 * reach[0] + 1} × {2 * reach[1] + 1} px kernel at full "
                "resolution, its spectrum kept by the renderer"
            )
        else:
            lines.append(f"  path: {self.path}")
        if self.path in ("fft", "multires"):
            lines.append(
                f"  transforms: {self.fft_precision}"
                + (
                    f", round-off at most {self.roundoff_cd_m2:.3g} cd/m² plus a share of "
                    f"the spread, {self.roundoff_codes:.2g} codes"
                    if self.fft_precision == "float32"
                    else ""
                )
            )
        if self.costs:
            lines.append(
                "  estimated: " + ", ".join(f"{k} {v:.3g} s" for k, v in self.costs.items())
            )
        lines.append(
            f"  colour: {'RGB scene' if self.colour else 'luminance scene'}, "
            f"{'colour' if self.colour_kernel else 'achromatic'} kernel, "
            f"{self.convolutions} convolution(s)"
        )
        lines.append(f"  halo: {self.halo}")
        lines += [f"  - {note}" for note in self.notes]
        return "\n".join(lines)


def _geometric_reach(source, target, half) -> tuple[int, int]:
    if source is None or target is None:
        return (0, 0)
    rows = max(target[1] - 1 - source[0], source[1] - 1 - target[0], 0)
    cols = max(target[3] - 1 - source[2], source[3] - 1 - target[2], 0)
    return min(int(rows), half[0]), min(int(cols), half[1])


def direct_costs(costs: PathCosts, precision: str) -> tuple[float, float, float]:
    """``(correlate_s, correlate_weight_s, span_pixel_s)`` of the machine's costs for a
    direct spread whose spans are in ``precision``: what
    :func:`~glarelab.glare.rendering._convolve.cluster_method` weighs."""
    if precision == "float32":
        span = costs.span32_pixel_s
    elif precision == "float64":
        span = costs.direct_pixel_s
    else:
        raise ValueError(f"precision must be 'float64' or 'float32'; got {precision!r}")
    return costs.correlate_s, costs.correlate_weight_s, span


def _direct_cost(
    scene: Scene, out, reach, limit: float, costs: PathCosts, precision: str = "float64"
) -> float:
    """Estimated seconds of spreading the scene's bright clusters directly, its spans in
    ``precision``; a lower bound when that is already above ``limit`` (the clusters are then
    not looked for). Each cluster costs what
    :func:`~glarelab.glare.rendering._convolve.direct_spread` spends on it
    (:func:`~glarelab.glare.rendering._convolve.cluster_ways`: its correlation or a span
    per bright pixel), priced by the machine's costs per output pixel it reaches: the costs'
    own up to ``DIRECT_COST_SIDE ** 2`` pixels, and their ``direct_wide_share`` for each
    pixel beyond; the spans' kernel layout at
    :data:`~glarelab.glare.rendering._convolve.SPAN_LAYOUT_S` a value."""
    area = min((out[1] - out[0]) * (out[3] - out[2]), (2 * reach[0] + 1) * (2 * reach[1] + 1))
    base = DIRECT_COST_SIDE**2
    pixels = area if area <= base else base + costs.direct_wide_share * (area - base)
    weighed = direct_costs(costs, precision)
    width, spread = out[3] - out[2], scene.source_box[3] - 1 - scene.source_box[2]
    values = span_values(width, spread, reach[1])
    lowest = pixels * scene.bright_pixels * min(weighed[1], weighed[2] * values)
    if lowest >= limit:
        return lowest
    found = [(mask.shape, int(mask.sum())) for _, mask in scene.clusters()]
    layout_values = span_layout_values(reach[0] + 1, width, spread)
    ways = cluster_ways(
        found,
        area=area,
        values=values,
        layout_values=layout_values,
        precision=precision,
        costs=weighed,
    )
    total, layout = 0.0, 0.0
    for (shape, bright), how in zip(found, ways, strict=True):
        if how == "correlation":
            total += costs.correlate_s + costs.correlate_weight_s * shape[0] * shape[1]
        elif how == "spans":
            total += weighed[2] * values * bright
            layout = SPAN_LAYOUT_S * layout_values  # shared by every span
        else:
            raise ValueError(f"unknown way to spread a cluster: {how!r}")
    return pixels * total + layout


def _span_precision(renderer, scene: Scene, cut_bound: float, step: float):
    """``('float32', a, codes, note)`` when float32 spans' round-off bound
    (:func:`~glarelab.glare.rendering._convolve.span_roundoff`: ``a`` cd/m² and a share
    ``r`` of the spread) keeps the tolerance with the cut's bound ``cut_bound`` (cd/m², at
    the darkest pixel's code step ``step``), else ``('float64', 0, 0, note)``. ``codes`` is
    the relative part's, at most ``r / (1 - r)`` times the largest ``L / step(L)`` of the
    display: a spread's error ``r S`` is at most ``r`` of the output it is part of."""
    tolerance = renderer.tolerance_codes
    if tolerance <= 0:
        return "float64", 0.0, 0.0, None
    if scene.total_excess > SPAN32_MAX_TOTAL_EXCESS:
        note = f"float64 spans: the excess sums to more than {SPAN32_MAX_TOTAL_EXCESS:.0e}"
        return "float64", 0.0, 0.0, note
    absolute, relative = span_roundoff(scene.bright_pixels, scene.total_excess)
    codes = relative / (1.0 - relative) * renderer.code_bound.relative_codes
    if codes + (cut_bound + absolute) / step <= tolerance:
        return "float32", absolute, codes, f"float32 spans: {codes:.2g} codes of round-off"
    return "float64", 0.0, 0.0, f"float64 spans: float32 round-off could reach {codes:.2g} codes"


def fft_cost(
    lengths: tuple[int, int], costs: PathCosts = DEFAULT_COSTS, precision: str = "float64"
) -> float:
    """Estimated seconds of one forward and one inverse real FFT of ``N0 × N1`` points."""
    n = lengths[0] * lengths[1]
    large = FFT_LARGE if n > FFT_LARGE_POINTS else 1.0
    return large * fft_unit(n, costs, precision) * n * math.log2(max(n, 2))


def plan_glare(
    luminance_cd_m2: np.ndarray,
    model: GlareModel | str,
    *,
    pixel_deg: float,
    l_dmax_cd_m2: float,
    composition: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
    tolerance_codes: float = 0.5,
    display=None,
    method: None = None,
) -> GlarePlan:
    """Plan the glare of one image: what to spread, how far, by which path.

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
    composition
        ``'Yoshida2008'`` (clamped to ``L_dmax``: saturated pixels cannot change) or
        ``'Spencer1995'`` (every pixel can change).
    tolerance_codes
        Largest error allowed, in display codes, >= 0; default 0.5 (half a code step cannot
        be seen). 0 plans the exact render.
    display
        The display the image is for: a :class:`~glarelab.glare.rendering.display.Display`, a
        calibration (anything with a code → cd/m² ``lut``) or ``None`` for the reference display:
        10-bit, gamma 2.2, 1000:1, white at ``l_dmax_cd_m2``.
    method
        Removed (it was the composition rule, and read as a model's name): refused with a
        TypeError.

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
    :math:`E(r)` the energy beyond the cut. To plan many images of one shape, use
    :meth:`glarelab.glare.GlareRenderer.plan`, which keeps the kernel and what it measured.

    Examples
    --------
    >>> from glarelab.glare import GaussianGlare
    >>> image = np.full((101, 101), 100.0)
    >>> image[50, 50] = 5000.0
    >>> plan = plan_glare(image, GaussianGlare(sigma_deg=0.1), pixel_deg=0.02,
    ...                   l_dmax_cd_m2=220.0)
    >>> plan.reach_px < plan.geometric_reach_px, plan.path
    (True, 'direct')
    """
    from glarelab.glare.rendering.renderer import _renderer_for  # it imports this module

    image, renderer = _renderer_for(
        luminance_cd_m2,
        model,
        pixel_deg=pixel_deg,
        l_dmax_cd_m2=l_dmax_cd_m2,
        tolerance_codes=tolerance_codes,
        display=display,
        composition=composition,
        method=method,
    )
    return renderer.plan(image)


def make_plan(renderer, scene: Scene) -> GlarePlan:
    """The plan of ``scene`` for ``renderer`` (a :class:`glarelab.glare.GlareRenderer`)."""
    model, tolerance = renderer.model, renderer.tolerance_codes
    colour_kernel = scene.colour and not model.achromatic
    if not scene.colour or (scene.achromatic and not colour_kernel):
        convolutions = 1
    else:
        convolutions = 3
    notes = []
    if scene.colour and convolutions == 1:
        notes.append("achromatic scene and kernel: one convolution, copied to R, G and B")
    half = renderer.kernel_half
    geometric = _geometric_reach(scene.source_box, scene.target_box, half)
    # one code step at the darkest pixel that can change, in cd/m²
    step = float(renderer.code_bound.step(scene.darkest))
    common = {
        "shape": tuple(scene.planes.shape[:2]) + ((3,) if scene.colour else ()),
        "model": model.description(colour_kernel),
        "tolerance_codes": tolerance,
        "tolerance_cd_m2": tolerance * step,
        "bright_pixels": scene.bright_pixels,
        "source_box": scene.source_box,
        "max_excess_cd_m2": scene.max_excess,
        "total_excess": scene.total_excess,
        "target_pixels": scene.target_pixels,
        "target_box": scene.target_box,
        "geometric_reach_px": geometric,
        "colour": scene.colour,
        "colour_kernel": colour_kernel,
        "convolutions": convolutions,
        "halo": model.halo() + (" (colour kernel)" if colour_kernel else ""),
    }
    if scene.source_box is None:
        notes.append("nothing above L_dmax: the image is returned unchanged")
        return GlarePlan(
            **common, reach_px=(0, 0), cut_bound_cd_m2=0.0, path="none", multires_factor=1,
            split_px=0, notes=tuple(notes),
        )  # fmt: skip
    if renderer.method == "Yoshida2008" and scene.target_box is None:
        notes.append("every pixel is at L_dmax: Yoshida's clamp leaves nothing to spread into")
        return GlarePlan(
            **common, reach_px=(0, 0), cut_bound_cd_m2=0.0, path="clamp", multires_factor=1,
            split_px=0, notes=tuple(notes),
        )  # fmt: skip

    reach, cut_bound = geometric, 0.0
    bound = renderer.tail_bound(colour_kernel) if tolerance > 0 else None
    if bound is not None and max(geometric) > 0:
        left_out = np.minimum(scene.total_excess * bound.peak, scene.max_excess * bound.energy)
        fits = np.flatnonzero(left_out[: max(geometric) + 1] <= CUT_SHARE * tolerance * step)
        radius = int(fits[0]) if fits.size else max(geometric)
        reach = (min(geometric[0], radius), min(geometric[1], radius))
        if reach != geometric:
            cut_bound = float(left_out[max(reach)])
            notes.append(
                f"kernel cut at {max(reach) * renderer.pixel_deg:.3g}°: beyond it the tail "
                f"holds at most {cut_bound:.3g} cd/m² of this scene's glare"
            )
    elif tolerance == 0:
        notes.append("tolerance 0: exact render")
    elif bound is None:
        notes.append(
            "the model gives no tail bound (as with flare lines or wave optics): full reach, exact"
        )

    plan = GlarePlan(
        **common, reach_px=reach, cut_bound_cd_m2=cut_bound, path="fft", multires_factor=1,
        split_px=0, notes=(),
    )  # fmt: skip
    out = plan.out_box
    source = scene.source_box
    if out is None:  # the cut kernel reaches no pixel that can change
        notes.append("path direct: the cut kernel reaches no pixel that can change")
        return replace(plan, path="direct", costs={"direct": 0.0}, notes=tuple(notes))
    lengths = _lengths(source, out, reach)  # the render's own (the part of out in reach)
    machine = renderer.costs
    precision, roundoff, roundoff_codes, precision_note = renderer.dtype.name, 0.0, 0.0, None
    # the float32 FFT at its cheapest: its transforms and the check of its bound, which
    # grows with the spread (a plan of its precision costs the kernel's norms: 37 ms for a
    # 4095² kernel, paid in vain where the direct path is cheaper still). A float64 image's
    # float32 transforms are not checked after the render (the plan's bound is at least the
    # check's), but the plan charges the check all the same, a margin for the round-off
    # bound's measured constant: charged nothing, float32 FFTs were taken where the direct
    # path had been as cheap, and on glints along an image's edge their round-off exceeded
    # the bound of the time, white alone (0.69 codes, bound 0.42, a 300 × 457 image with
    # every default), which now counts the round-off a row transform keeps in its row
    pixels = scene.planes.shape[0] * scene.planes.shape[1]
    check = machine.bound_s * pixels
    optimistic = fft_cost(lengths, machine, "float32") + check
    spans, span_a, span_codes, span_note = _span_precision(renderer, scene, cut_bound, step)
    direct = _direct_cost(scene, out, reach, optimistic, machine, spans)
    if tolerance > 0:
        precision = "float64"
        if direct >= optimistic:  # the FFT may win: plan its precision
            precision, roundoff, roundoff_codes, precision_note = _choose_precision(
                renderer, scene, plan, lengths, step, reach
            )
    costs = {"fft": fft_cost(lengths, machine, precision) * convolutions}
    if precision == "float32":  # the check of its bound, run or not (above)
        costs["fft"] += check
    costs["direct"] = (
        direct
        if direct >= costs["fft"] / convolutions or direct < optimistic
        else _direct_cost(scene, out, reach, costs["fft"] / convolutions, machine, spans)
    ) * convolutions
    exact_paths = [p for p in ("direct", "fft") if p in renderer.paths] or ["direct", "fft"]
    path, factor, split = min(exact_paths, key=costs.get), 1, 0
    if bound is not None and tolerance > 0 and "multires" in renderer.paths:
        limit = costs[path] if len(renderer.paths) > 1 else math.inf
        far_share = FAR_SHARE * tolerance
        choice = _choose_multires(
            renderer,
            scene,
            plan,
            lengths_cost=limit,
            # its near part's precision if the far tail takes all it may: float32 then is
            # float32 for sure (an estimate hoping for float32 built the far tail's preview
            # for nothing on the RGB street, 14-47 ms a plan)
            near_precision=lambda lengths: _choose_precision(
                renderer, scene, plan, lengths, step, geometric, far_codes=far_share
            )[0],
        )
        if choice is not None:
            factor, split, predicted, cost, cost_precision = choice
            far_error = renderer.multires(factor, split, colour_kernel).relative_error
            near_lengths = _lengths(source, out, (2 * split,) * 2)
            near = _choose_precision(
                renderer,
                scene,
                plan,
                near_lengths,
                step,
                geometric,
                far_error=far_error,
                far_codes=predicted,
            )
            if near[0] != cost_precision:  # the far tail's own share and measured error
                cost += (
                    fft_cost(near_lengths, machine, near[0])
                    - fft_cost(near_lengths, machine, cost_precision)
                ) * convolutions
            costs["multires"] = cost
            far_note = (
                f"far tail beyond {split} px at 1/{factor} resolution: measured relative error "
                f"{far_error:.3g}, {predicted:.3g} codes predicted on the coarse grid"
            )
            if cost < costs[path] or len(renderer.paths) == 1:
                path = "multires"
                precision, roundoff, roundoff_codes, precision_note = near
                notes.append(far_note)
            else:
                factor, split = 1, 0
                notes.append(f"{far_note}: its near part needs {near[0]} transforms, dearer")
    if path in ("fft", "multires") and precision_note is not None:
        notes.append(precision_note)
    if path == "direct":
        precision, roundoff, roundoff_codes = "float64", span_a, span_codes
        if span_note is not None:
            notes.append(span_note)
    else:
        spans = "float64"
    if path not in ("fft", "multires", "direct"):
        precision, roundoff, roundoff_codes = "float64", 0.0, 0.0
    if len(renderer.paths) < len(PATHS):
        notes.append(f"path {path}: of the paths allowed, {', '.join(renderer.paths)}")
    else:
        notes.append(f"path {path}: the cheapest estimated that keeps the tolerance")
    return GlarePlan(
        **{
            k: v
            for k, v in plan.__dict__.items()
            if k
            not in (
                "path",
                "costs",
                "notes",
                "fft_precision",
                "direct_precision",
                "roundoff_cd_m2",
                "roundoff_codes",
            )
        }
        | {"path": path, "multires_factor": factor, "split_px": split},
        fft_precision=precision,
        direct_precision=spans,
        roundoff_cd_m2=roundoff,
        roundoff_codes=roundoff_codes,
        costs=costs,
        notes=tuple(notes),
    )


def _lengths(source, out, half) -> tuple[int, int]:
    """FFT lengths of the spread from ``source`` to the part of ``out`` within ``half``."""
    near = (
        max(out[0], source[0] - half[0]),
        min(out[1], source[1] + half[0]),
        max(out[2], source[2] - half[1]),
        min(out[3], source[3] + half[1]),
    )
    return (
        fft_length(source[:2], near[:2], half[0]),
        fft_length(source[2:], near[2:], half[1]),
    )


def _choose_precision(
    renderer,
    scene: Scene,
    plan: GlarePlan,
    lengths,
    step: float,
    reach,
    *,
    far_error=0.0,
    far_codes=0.0,
):
    """``'float32'`` transforms when their round-off bound (:func:`fft_roundoff`), with the
    cut's, keeps what the far tail (``far_codes`` predicted) leaves of the tolerance: at the
    darkest pixel's code step, or else, when it could, at the darkest output each cell of
    :data:`LEAST_FACTOR` pixels can have
    (:meth:`~glarelab.glare.rendering.display.CodeBound.roundoff_codes`; a render with a far
    tail or of an image kept in float32 checks it pixel by pixel and falls back to float64).
    Returns ``(precision, a, codes, note)``: the
    bound's absolute part ``a`` and the whole bound in codes for float32, zeros for float64.

    The spread the kernel applied to ``reach`` pixels (the path's; the far tail's, of
    relative error ``far_error``, covers the whole kernel) gives every pixel of a cell is
    bounded from below by :func:`_least_spread`, a rigorous bound: the far tail's spread is at
    least ``1 - far_error`` times the full kernel's. The round-off's relative part, ``r S``
    at a pixel of spread ``S``, is at most ``r`` times the pixel's own output, which is at
    most ``L / step(L)`` codes anywhere on the display; its absolute part ``a``, with the
    cut's bound and what the render adds for float64 round-off, is counted at each cell's
    lowest output: without a far tail, a bound on what the render's check finds pixel by
    pixel, so that float32 so planned is kept (a float64 image's render reports it without
    the check). On the 1024² city at night (2,000 lamps, Vos) the coarse preview of the far
    tail, halved, put outputs at the display's black (0.5 cd/m², steps of 1e-4 cd/m²) where
    the spread is at least 7.4 cd/m², and predicted 460 codes; this bound is 0.46 codes, 0.43
    from the exact spread's least value in each cell (0.035 reached).

    The cut, the far tail and the round-off once had fixed shares of the tolerance (a
    quarter, a half, a quarter); the round-off now takes what the other two leave, since its
    bound is checked with theirs, pixel by pixel, by the same render.

    A strip's transforms (one FFT length of 1) are one-dimensional and stay in float64: their
    round-off is not white (with one glint at a strip's end it lands at fixed fractions of
    the length, up to 1.74 times the bound on 1 × 900 px with Vos and flare lines, 0.5 % of
    280,000 such strips over it), and float32 saves nothing worth it there."""
    if min(lengths) == 1:
        return "float64", 0.0, 0.0, "float64 transforms: a strip's are one-dimensional"
    budget = plan.tolerance_codes - far_codes
    own, relative = renderer.roundoff_bound(scene, lengths, plan.colour_kernel)
    absolute = own + renderer._absolute(scene, plan, set())  # the cut's, as the render adds
    # at the darkest pixel with no spread: a bound on what the render's check finds
    at_darkest = renderer.code_bound.roundoff_codes(
        np.array([scene.darkest]), np.zeros(1), absolute=absolute, relative=relative
    )
    if at_darkest <= budget:
        note = f"float32 transforms: {at_darkest:.2g} codes of round-off"
        return "float32", own, float(at_darkest), note
    if absolute / renderer.code_bound.largest_step > budget:  # nowhere within the budget
        note = f"float64 transforms: float32 round-off up to {own:.3g} cd/m² would show"
        return "float64", 0.0, 0.0, note
    predicted = at_darkest
    # the round-off bound's constants were measured on the models with a tail bound
    if renderer.tail_bound(plan.colour_kernel) is not None and far_error < 1.0:
        least = _least_spread(renderer, scene, plan.colour_kernel, reach)
        predicted = renderer.code_bound.roundoff_codes(
            _darkest_cells(scene, LEAST_FACTOR),
            (1.0 - far_error) * least,
            absolute=absolute,
            relative=relative,
        )
        if predicted <= budget:
            note = (
                f"float32 transforms: at most {predicted:.2g} codes of round-off at the "
                "darkest output the glare leaves"
            )
            return "float32", own, predicted, note
    note = f"float64 transforms: float32 round-off could reach {predicted:.2g} codes"
    return "float64", 0.0, 0.0, note


def _darkest_cells(scene: Scene, factor: int) -> np.ndarray:
    """The darkest value of each cell of ``factor × factor`` pixels over the channels (made
    once per scene and factor)."""
    key = ("darkest", factor)
    if key not in scene._splats:
        scene._splats[key] = block_reduce(scene.darkest_plane(), np.minimum, factor)
    return scene._splats[key]


def _least_spread(renderer, scene: Scene, colour_kernel: bool, reach) -> np.ndarray:
    """A lower bound on the spread, cd/m², at every pixel of each cell of
    :data:`LEAST_FACTOR` pixels and in every channel, for the kernel cut at ``reach`` (made
    once per scene, kernel and reach).

    Each cell's excess, summed, spread with the kernel's least value between the two cells'
    pixels (:meth:`~glarelab.glare.GlareRenderer.least_kernel`): every pixel ``q`` of a cell
    ``A`` adds ``ΔL(q) K(p - q) >= ΔL(q) m(B - A)`` to each pixel ``p`` of cell ``B``. Over
    the channels, each cell's least sum with the least kernel over the channels bounds every
    channel: one coarse convolution (on the RGB street, whose blue has the least excess in
    every cell, it is the blue channel's own bound). The coarse convolution's float64
    round-off (about ``ε log2 n`` times its largest value) is taken off."""
    key = ("least", colour_kernel, tuple(reach))
    if key not in scene._splats:
        shape = scene.planes.shape[:2]
        sums = cell_sums(scene.excess, LEAST_FACTOR, scene.source_box, shape).min(axis=2)
        least = np.zeros(sums.shape)
        if sums.any():  # a tinted scene's least channel may have no excess at all
            # the kernel's spectrum is the renderer's, made once for every scene
            spectrum, lengths, peak = renderer.least_spectrum(LEAST_FACTOR, colour_kernel, reach)
            a, b = sums.shape[0] - 1, sums.shape[1] - 1  # the least kernel's half-sizes
            with scipy.fft.set_workers(fft_workers(lengths)):
                full = scipy.fft.irfft2(scipy.fft.rfft2(sums, s=lengths) * spectrum, s=lengths)
            least = full[a : a + sums.shape[0], b : b + sums.shape[1]]
            n = lengths[0] * lengths[1]
            least -= np.finfo(np.float64).eps * math.log2(n) * sums.sum() * peak
        scene._splats[key] = np.maximum(least, 0.0)
    return scene._splats[key]


def _choose_multires(
    renderer, scene: Scene, plan: GlarePlan, *, lengths_cost: float, near_precision
):
    """The cheapest coarse factor and split whose far path fits ``FAR_SHARE`` of the
    tolerance, predicted on the coarse grid with the measured relative error; ``None`` when
    none fits or none is cheaper than ``lengths_cost``. Returns ``(f, R0, codes, cost,
    precision)``, the cost with the near part in the precision ``near_precision`` (of its FFT
    lengths) gives."""
    reach = plan.geometric_reach_px  # the far tail covers the whole geometric reach
    budget = FAR_SHARE * plan.tolerance_codes
    source, out = plan.source_box, plan.out_box
    for factor in MULTIRES_FACTORS:
        ratios = [
            k
            for k in SPLIT_RATIOS
            if max(reach) >= MULTIRES_MIN_REACH * k * factor and min(reach) >= 2 * k * factor
        ]
        if not ratios:
            continue
        far_cost = _far_cost(renderer, scene, factor, plan.colour_kernel, plan.convolutions)
        # the preview is paid whether or not the far tail then keeps the tolerance: it is
        # made only where the path, taken, would save more than the preview costs (on the
        # 2048² night with a glint of the sun a 28 ms preview, 22 % of the direct render,
        # was made for a saving of 27 ms and then found the far tail's error too large)
        pending = _preview_cost(renderer, scene, factor, plan.colour_kernel)
        preview = None
        for k in ratios:
            split = k * factor
            near = (
                max(out[0], source[0] - 2 * split),
                min(out[1], source[1] + 2 * split),
                max(out[2], source[2] - 2 * split),
                min(out[3], source[3] + 2 * split),
            )
            near_lengths = (
                fft_length(source[:2], near[:2], 2 * split),
                fft_length(source[2:], near[2:], 2 * split),
            )
            cost = far_cost + fft_cost(near_lengths, renderer.costs, "float32") * plan.convolutions
            if cost + pending >= lengths_cost:
                break  # longer splits cost more, at either precision
            precision = near_precision(near_lengths)
            if precision == "float64":
                cost += plan.convolutions * (
                    fft_cost(near_lengths, renderer.costs, "float64")
                    - fft_cost(near_lengths, renderer.costs, "float32")
                )
                if cost + pending >= lengths_cost:
                    continue  # a longer split's near part may take float32
            if preview is None:
                preview = _preview(renderer, scene, factor, plan.colour_kernel)
            if preview(FAR_ERROR_SAFETY / k**2) > budget:
                continue
            measured = renderer.multires(factor, split, plan.colour_kernel).relative_error
            predicted = preview(measured) if measured < 1.0 else math.inf
            if predicted <= budget:
                return factor, split, predicted, cost, precision
    return None


def _far_cost(renderer, scene: Scene, factor: int, colour_kernel: bool, convolutions: int):
    """Estimated seconds of the far tail at ``factor``: per image pixel its splat,
    interpolation and bound; its coarse convolutions by their own transform size (the coarse
    grid's, which a 512² image at 1/4 shares with a 1024² image at 1/8); and the plan's
    preview when it is not made yet (the multi-resolution path cannot be taken without it)."""
    machine = renderer.costs
    height, width = scene.planes.shape[:2]
    coarse = machine.coarse_fft_s * n_log_n(
        coarse_lengths((height, width), renderer.kernel_half, factor)
    )
    cost = (machine.multires_s * height * width + coarse) * convolutions
    cost += machine.bound_s * height * width * scene.planes.shape[2]
    return cost + _preview_cost(renderer, scene, factor, colour_kernel)


def _preview_cost(renderer, scene: Scene, factor: int, colour_kernel: bool) -> float:
    """Estimated seconds of the plan's preview of the far tail at ``factor`` (its splat,
    darkest cells and coarse convolution); 0 once it is made. Its per-pixel part is measured
    on one channel and counted per channel: an RGB image's brightest excess and darkest
    channel are found first (on the 2048² RGB city at night, 91 ms at 1/8 without the coarse
    convolution, 22 ms estimated per channel)."""
    if ("preview", factor, colour_kernel) in scene._splats:
        return 0.0
    machine = renderer.costs
    height, width, channels = scene.planes.shape
    coarse = machine.coarse_fft_s * n_log_n(
        coarse_lengths((height, width), renderer.kernel_half, factor)
    )
    return machine.preview_s * height * width * channels + coarse


def _preview(renderer, scene: Scene, factor: int, colour_kernel: bool):
    """A function from the far path's relative error to the predicted largest error in codes:
    the scene's spread at the coarse nodes (the model digitised at ``f`` pixels) over the
    darkest pixel of each cell (made once per scene, factor and kernel). A prediction, not a
    bound: the cubic splat's negative weights next to a lamp can leave a node's spread far
    below the spread at the pixels of its cell; the render measures the far tail's error."""
    key = ("preview", factor, colour_kernel)
    if key not in scene._splats:
        coarse = renderer.coarse_kernel(factor, colour_kernel)
        brightest = coarse if coarse.ndim == 2 else coarse.max(axis=2)
        height, width = scene.planes.shape[:2]
        nodes = far_spread(
            None,
            scene.source_box,
            (height, width),
            brightest / factor**2,
            factor,
            nodes=True,
            splatted=scene.splat(factor, None),
        )
        cells = -(-height // factor), -(-width // factor)
        spread_cells = nodes[PAD_NODES : PAD_NODES + cells[0], PAD_NODES : PAD_NODES + cells[1]]
        darkest = _darkest_cells(scene, factor)
        scene._splats[key] = (darkest[..., None], np.maximum(spread_cells, 0.0)[..., None])
    darkest, spread_cells = scene._splats[key]

    def codes(relative: float) -> float:
        return renderer.code_bound.codes(
            darkest,
            spread_cells,
            absolute=0.0,
            relative=relative / max(1.0 - relative, 1e-12),
        )

    return codes
