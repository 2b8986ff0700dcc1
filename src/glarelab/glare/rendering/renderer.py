"""Render many images of one shape with one kernel: :class:`GlareRenderer`.

A renderer owns, for one (model, pixel size, image shape, display), the digitised kernel,
its spectra for the FFT lengths it has used, the model's tail bounds, and the multi-resolution
kernels with their measured errors. Each is computed the first time a render needs it and kept
for the next images. :func:`glarelab.glare.add_glare` and :func:`glarelab.glare.render_glare`
are one-call forms that build a renderer for one image.

Memory: the kernel (``(2H-1) × (2W-1)`` float64, ``[× 3]`` for a colour kernel) and the
spectra, at most :data:`SPECTRA_BYTES` of them (the least recently used are dropped; the one
in use is always kept).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import replace
from typing import Literal

import numpy as np
import scipy.fft

from glarelab.files.memory import check_memory
from glarelab.glare._validation import (
    check_choice,
    check_flag,
    check_image,
    check_pixel_deg,
    check_positive,
    real_number,
)
from glarelab.glare.models import _resolve
from glarelab.glare.models.base import GlareModel, TailBound, _Declared
from glarelab.glare.models.cache import resolve_cache
from glarelab.glare.models.digitise import (
    Kernel,
    check_image_shape,
    check_kernel_shape,
    kernel_shape_for,
)
from glarelab.glare.rendering._convolve import (
    FLOAT32_NOISE_LIMIT_CD_M2,
    convolution_dtype,
    direct_spread,
    fft_length,
    fft_roundoff,
    fft_workers,
    kernel_spectrum,
    line_roundoff_norms,
    line_sums,
    spectral_spread,
)
from glarelab.glare.rendering.compose import check_composition, compose
from glarelab.glare.rendering.costs import DEFAULT_COSTS, PathCosts, machine_costs
from glarelab.glare.rendering.display import CodeBound, display_lut
from glarelab.glare.rendering.multires import (
    FOOTPRINT_NODES,
    MultiresKernels,
    channels,
    far_spread,
    least_kernel,
    multires_kernels,
    upsample,
)
from glarelab.glare.rendering.plan import PATHS, GlarePlan, direct_costs, make_plan
from glarelab.glare.rendering.result import GlareResult, PlannedGlare
from glarelab.glare.rendering.scene import Scene

__all__ = ["SPECTRA_BYTES", "GlareRenderer", "GlareResult", "PlannedGlare"]

SPECTRA_BYTES = 512 * 2**20  # kernel spectra a renderer keeps (the one in use always)
LEAST_KERNELS = 8  # cell-to-cell least kernels kept (one per grid, reach and channel set)
# When the FFT's round-off bound exceeds the tolerance, the image is spread directly (no
# round-off) if that is estimated to cost at most DIRECT_FALLBACK times the FFT.
DIRECT_FALLBACK = 50.0
FLOAT32_UNIT_ROUNDOFF = 2.0**-24  # a float32 rounding: at most this much of the value
PRECISIONS = ("float64", "float32")
WHITE_ROUNDING = (
    1e-9  # l_dmax above the display's white by less is its rounding (a JSON round trip)
)
# as the command line's --pixel-deg: a coarse grid of the far tail (up to 8 pixels a node)
# then stays within the 180° a kernel's pixel can subtend
MAX_RENDER_PIXEL_DEG = 10.0
# glarelab's bound: 6e20 times the sun's 1.6e9 cd/m², where a whole image's sums and the code
# tables' logarithms stay finite (an image of 1e306 cd/m² overflowed them: IndexError), in
# float32 too (3.5e38 cd/m² became inf)
MAX_LUMINANCE_CD_M2 = 1e30
# bytes per pixel a render needs at its peak (measured on 512²-2048² scenes, exact and planned
# renders: 230-240 for luminance, 300 for RGB; with headroom)
RENDER_BYTES_PER_PIXEL = {1: 260, 3: 340}
# below this the system is not asked (reading its memory costs 0.1 ms, a tenth of a 271² render):
# a render of a 440² RGB image or less; a system without 64 MiB to give is out of the question
SMALL_RENDER_BYTES = 64 * 2**20


def check_render_memory(shape: tuple[int, ...], name: str = "luminance_cd_m2") -> None:
    """Refuse an image of ``shape`` whose render needs more memory than the system has,
    before anything is allocated (a 100000² image was allocated until the process was killed).

    Parameters
    ----------
    shape
        The image's ``(H, W)`` or ``(H, W, C)``.
    name
        The argument, for the message.

    Raises
    ------
    ValueError
        Naming the shape, the memory the render needs and the memory available (a render
        of less than :data:`SMALL_RENDER_BYTES` is not checked).
    """
    shape = tuple(int(n) for n in shape)
    if len(shape) not in (2, 3):
        return  # the image's own check names it
    channels = 3 if len(shape) == 3 else 1
    needed = RENDER_BYTES_PER_PIXEL[channels] * shape[0] * shape[1]
    if needed >= SMALL_RENDER_BYTES:
        check_memory(needed, f"rendering {name} of shape {shape}")


class GlareRenderer:
    """Glare for many images of one shape: the kernel and its spectra are made once.

    Parameters
    ----------
    model
        A glare model or its name.
    pixel_deg
        Visual angle of one pixel in degrees, in [1e-5, 10].
    shape
        ``(H, W)`` of the images (RGB images ``(H, W, 3)`` are accepted too).
    l_dmax_cd_m2
        Maximum luminance of the display, cd/m², > 0; default 220 (Yoshida §3).
    composition
        How the spread glare is put back: ``'Yoshida2008'`` (default, clamped to ``L_dmax``) or
        ``'Spencer1995'`` (added without a clamp); :mod:`glarelab.glare.rendering.compose`.
    method
        Removed (it was the composition rule, and read as a model's name): refused with a
        TypeError.
    precision
        The image's and the result's dtype: ``'float64'`` (default) or ``'float32'``. A
        planned render (``tolerance_codes`` > 0) sums its spread in float64 and plans its
        transforms' precision either way (float32 where the bound keeps the tolerance), and
        counts float32's roundings of the excess and the result; the exact paths convolve in
        float64 where float32 FFT round-off could show, next to a sun.
    tolerance_codes
        Largest error allowed against the exact render, display codes, >= 0; default 0.5.
        0 (or ``None``): exact paths only.
    display
        The display the error is counted on (a calibration, a :class:`glarelab.glare.Display`, or a
        code → cd/m² table) whose white is at least ``l_dmax_cd_m2``; ``None``: 10-bit, gamma
        2.2, 1000:1, white at ``L_dmax``.
    kernel_shape
        Odd shape of the reference kernel; default ``(2H - 1, 2W - 1)`` (every pixel reaches
        every other, Spencer §3.2).
    kernel
        The reference kernel, already digitised by ``model`` for ``pixel_deg``, or ``None``.
    paths
        The paths the plan may choose from (default all: ``'direct'``, ``'fft'``,
        ``'multires'``), to measure one of them; an exact path is taken when none allowed
        fits.
    log
        Called with one line per step, or ``None``.
    cache
        Where digitised kernels are kept between runs (:mod:`glarelab.glare.models.cache`):
        ``None`` (default) or ``True``, the user's kernel cache (off when ``GLARELAB_NO_CACHE`` is
        set); ``False``, none; a :class:`glarelab.glare.models.cache.KernelCache` or a folder.
    costs
        What each path costs (:class:`~glarelab.glare.rendering.costs.PathCosts`), or
        ``'machine'``: measured once on this machine at its thread count and kept in the
        kernel cache's folder (:func:`~glarelab.glare.rendering.costs.machine_costs`; the
        constants below without a cache). Default ``None``: the constants measured on a
        quiet 2-core machine, :data:`~glarelab.glare.rendering.costs.DEFAULT_COSTS`.

    Raises
    ------
    ValueError
        For a bad model, pixel size, shape, ``l_dmax_cd_m2``, composition, precision, tolerance,
        display table or kernel.

    Examples
    --------
    >>> from glarelab.glare import VosGlare
    >>> renderer = GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(64, 64))
    >>> images = [np.full((64, 64), 50.0) for _ in range(3)]
    >>> for image, level in zip(images, (1e4, 1e5, 1e6)):
    ...     image[32, 32] = level
    >>> results = [renderer.render(image) for image in images]
    >>> [r.plan.path for r in results], max(r.error_bound_codes for r in results) <= 0.5
    (['direct', 'direct', 'direct'], True)
    """

    def __init__(
        self,
        model: GlareModel | str,
        *,
        pixel_deg: float,
        shape: tuple[int, ...],
        l_dmax_cd_m2: float = 220.0,
        composition: Literal["Yoshida2008", "Spencer1995"] = "Yoshida2008",
        precision: Literal["float64", "float32"] = "float64",
        tolerance_codes: float | None = 0.5,
        display=None,
        kernel_shape: tuple[int, int] | None = None,
        kernel: Kernel | None = None,
        paths: tuple[str, ...] = PATHS,
        log=None,
        cache=None,
        costs: PathCosts | Literal["machine"] | None = None,
        method: None = None,
    ) -> None:
        self.model = _resolve(model)
        self.cache = resolve_cache(cache)
        self.pixel_deg = check_pixel_deg(pixel_deg, high=MAX_RENDER_PIXEL_DEG)
        self.l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
        if self.l_dmax > MAX_LUMINANCE_CD_M2:
            raise ValueError(
                f"l_dmax_cd_m2 must be at most {MAX_LUMINANCE_CD_M2:g} cd/m² (no display, "
                f"and far beyond any light); got {self.l_dmax:g}"
            )
        self.composition = check_composition(composition, method, where="GlareRenderer")
        check_choice("precision", precision, PRECISIONS)
        self.method, self.dtype = self.composition, np.dtype(precision)
        self.tolerance_codes = check_tolerance(tolerance_codes)
        self.shape = check_image_shape(shape)
        check_render_memory(self.shape, "an image")
        self.lut = display_lut(display, self.l_dmax)
        white = float(self.lut[-1])
        if self.l_dmax > white * (1.0 + WHITE_ROUNDING):
            raise ValueError(
                f"l_dmax_cd_m2 = {self.l_dmax:g} is above the display's white ({white:g} cd/m²): "
                "the render would put luminances there that the display cannot show; give "
                f"l_dmax_cd_m2 <= {white:g} (the display's white, or the calibration's)"
            )
        self.code_bound = CodeBound(self.lut, self.l_dmax, self.composition)
        self._given = None
        if kernel is not None:
            _check_kernel_of(kernel, self.model)
            check_kernel_values(kernel, "kernel")
            if not np.isclose(kernel.pixel_deg, self.pixel_deg, rtol=1e-12, atol=0):
                raise ValueError(
                    f"kernel was digitised for pixel_deg = {kernel.pixel_deg!r}, not {pixel_deg!r}"
                )
            if len(kernel.shape) == 3 and kernel.shape[2] != 3:
                raise ValueError(f"kernel must have 1 or 3 channels; got {kernel.shape}")
            if kernel_shape is not None and (
                check_kernel_shape(kernel_shape, name="kernel_shape") != tuple(kernel.shape[:2])
            ):
                raise ValueError(
                    f"kernel_shape={kernel_shape!r} with a kernel of shape "
                    f"{tuple(kernel.shape[:2])}: the kernel given is the one used; leave "
                    "kernel_shape None"
                )
            kernel_shape = check_kernel_shape(kernel.shape[:2], allocating=False)
            self._given = kernel
        elif kernel_shape is not None:
            kernel_shape = check_kernel_shape(kernel_shape, name="kernel_shape")
        self.kernel_shape = kernel_shape or kernel_shape_for(self.shape)
        self.kernel_half = (self.kernel_shape[0] // 2, self.kernel_shape[1] // 2)
        self.paths = tuple(paths)
        for path in self.paths:
            check_choice("paths", path, PATHS)
        if not self.paths:
            raise ValueError(f"paths must name at least one of {PATHS}; got {paths!r}")
        if self.paths == ("multires",) and not self.tolerance_codes:
            raise ValueError(
                f"paths={paths!r} with tolerance_codes={tolerance_codes!r}: the far tail's "
                "approximation is never taken for an exact render; give a tolerance, or an "
                "exact path ('direct', 'fft')"
            )
        if log is not None and not callable(log):
            raise ValueError(
                f"log must be a function taking one line of text, or None; got {log!r}"
            )
        self.say = log or (lambda line: None)
        self._kernels: dict[bool, Kernel] = {}
        self._given_grey: Kernel | None = None  # a given colour kernel's first channel
        self._peaks: dict[bool, float] = {}
        self._norms: dict[bool, tuple[float, float]] = {}
        self._lines: dict[bool, tuple] = {}
        if costs is not None and costs != "machine" and not isinstance(costs, PathCosts):
            raise ValueError(f"costs must be None, 'machine' or a PathCosts; got {costs!r}")
        self._costs = DEFAULT_COSTS if costs is None else costs
        self._bounds: dict[bool, TailBound | None] = {}
        self._coarse: dict[tuple, np.ndarray] = {}
        self._multires: dict[tuple, MultiresKernels] = {}
        self._least: OrderedDict[tuple, np.ndarray] = OrderedDict()
        self._least_spectra: OrderedDict[tuple, tuple] = OrderedDict()
        self._spectra: OrderedDict[tuple, np.ndarray] = OrderedDict()

    # what is kept between images ----------------------------------------------------------
    def kernel(self, colour: bool = False) -> Kernel:
        """The reference kernel (digitised on first use).

        Parameters
        ----------
        colour
            Whether the colour kernel (one per channel) is meant; default False: the luminance
            kernel.

        Returns
        -------
        Kernel
            The kernel of the renderer's shape (or the one given), kept for the next images.
        """
        colour = check_flag("colour", colour)  # the string 'no' is true to if
        if self._given is not None:
            given = self._given
            if len(given.shape) == 3 and not colour:  # the first channel, as before
                if self._given_grey is None:  # made once: the result reports it
                    outside = given.energy_outside
                    first = {"energy_outside": float(np.asarray(outside).reshape(-1)[0])}
                    if given.quadrant is not None:
                        first["quadrant"] = given.quadrant[..., 0]
                    else:
                        first["values"] = given.values[..., 0]
                    self._given_grey = given.replace(**first)
                return self._given_grey
            return given
        if colour not in self._kernels:
            self._kernels[colour] = self._digitised(self.pixel_deg, self.kernel_shape, colour)
        return self._kernels[colour]

    def _digitised(
        self, pixel_deg: float, shape: tuple[int, int], colour: bool, *, say: bool = True
    ) -> Kernel:
        """The model's kernel, from the kernel cache when it holds it (``say``: one log line
        saying which)."""
        log = self.say if say else None

        def build() -> Kernel:
            if log is not None:
                log(f"digitising a {shape[0]} × {shape[1]} kernel")
            return self.model.kernel(pixel_deg, shape, colour=colour)

        if self.cache is None:
            kernel = build()
        else:
            kernel = self.cache.kernel(
                self.model, pixel_deg, shape, colour=colour, build=build, log=log
            )
        what = f"the kernel of {type(self.model).__name__}"
        if not isinstance(kernel, Kernel):
            raise TypeError(f"{what} must be a Kernel; got {type(kernel).__name__}")
        if _custom(self.model):  # glarelab's own models are tested to make sound kernels (a
            check_kernel_values(kernel, what)  # pass over a 4095² kernel costs a one call 4 %)
            if tuple(kernel.shape[:2]) != tuple(shape):
                raise ValueError(
                    f"{what} has shape {tuple(kernel.shape[:2])}, not the {tuple(shape)} asked "
                    "for: its kernel method must digitise the shape it is given"
                )
        return kernel

    def kernel_peak(self, colour: bool = False) -> float:
        """The reference kernel's largest value (found once).

        Parameters
        ----------
        colour
            Whether the colour kernel (one per channel) is meant; default False: the luminance
            kernel.

        Returns
        -------
        float
            The peak, a fraction of the source's energy per pixel.
        """
        colour = check_flag("colour", colour)  # the string 'no' is true to if
        if colour not in self._peaks:
            self._peaks[colour] = float(self.kernel(colour).peak)
        return self._peaks[colour]

    @property
    def costs(self) -> PathCosts:
        """What each path costs here (:func:`~glarelab.glare.rendering.costs.machine_costs`)."""
        if self._costs == "machine":
            folder = None if self.cache is None else self.cache.directory
            self._costs = machine_costs(folder)
        return self._costs

    def kernel_norms(self, colour: bool = False) -> tuple[float, float]:
        """``Σ|K|`` and ``(ΣK²)^½`` of the reference kernel, the largest over its channels
        (found once; from the quadrant of a symmetric kernel, which is not unfolded).

        Parameters
        ----------
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel
            (default).

        Returns
        -------
        tuple of float
            ``(Σ|K|, (ΣK²)^½)``, dimensionless (the kernel's weights per pixel).
        """
        self.kernel_lines(colour)  # found with them
        return self._norms[check_flag("colour", colour)]

    def kernel_lines(
        self, colour: bool = False
    ) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """``(Σ|K|, ΣK²)`` of each row and of each column of the reference kernel, centred
        (offset ``d`` at index ``d + half``), the largest over its channels (found once, with
        :meth:`kernel_norms`; from the quadrant of a symmetric kernel, which is not
        unfolded).

        Parameters
        ----------
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel
            (default).

        Returns
        -------
        tuple
            ``((rows_l1, rows_l2²), (cols_l1, cols_l2²))``, float64 arrays.
        """
        colour = check_flag("colour", colour)  # the string 'no' is true to if
        if colour not in self._lines:
            kernel = self.kernel(colour)
            if kernel.quadrant is not None:  # an offset off the axes stands for four
                q = np.asarray(kernel.quadrant)
                rows_l1, rows_l2, cols_l1, cols_l2 = line_sums(q, absolute=True)
                axis = np.asarray(q[:, 0], dtype=np.float64)  # the kernel's column at 0
                across = np.asarray(q[0], dtype=np.float64)  # and its row at 0
                lines = [
                    _unfold(2.0 * line - edge)
                    for line, edge in (
                        (rows_l1, np.abs(axis)),
                        (rows_l2, axis * axis),
                        (cols_l1, np.abs(across)),
                        (cols_l2, across * across),
                    )
                ]
            else:
                lines = list(line_sums(kernel.values, absolute=True))
            l1, l2 = lines[0].sum(axis=0), lines[1].sum(axis=0)
            self._norms[colour] = (float(np.max(l1)), float(np.sqrt(np.max(l2))))
            channels = [line.reshape(line.shape[0], -1).max(axis=1) for line in lines]
            self._lines[colour] = ((channels[0], channels[1]), (channels[2], channels[3]))
        return self._lines[colour]

    def roundoff_bound(
        self, scene: Scene, lengths: tuple[int, int], colour: bool
    ) -> tuple[float, float]:
        """The float32 round-off bound of a spread of ``scene``'s excess by FFTs.

        Parameters
        ----------
        scene
            The image's :class:`~glarelab.glare.rendering.scene.Scene`.
        lengths
            The FFT lengths ``N0 × N1``.
        colour
            Whether the colour kernel is meant, else the luminance kernel.

        Returns
        -------
        tuple of float
            ``(a, r)``: each pixel's spread is off by at most ``a + r S`` cd/m²
            (:func:`~glarelab.glare.rendering._convolve.fft_roundoff`, with the norms of the
            excess's and the kernel's rows and columns, found once per scene and kernel).
        """
        key = ("line roundoff", colour)
        if key not in scene._splats:
            (excess_rows, excess_cols), (kernel_rows, kernel_cols) = (
                scene.line_norms(),
                self.kernel_lines(colour),
            )
            scene._splats[key] = {
                "rows": line_roundoff_norms(excess_rows, kernel_rows),
                "cols": line_roundoff_norms(excess_cols, kernel_cols),
            }
        return fft_roundoff(
            lengths,
            *scene.excess_norms(),
            *self.kernel_norms(colour),
            np.float32,
            **scene._splats[key],
        )

    def tail_bound(self, colour: bool) -> TailBound | None:
        """The model's tail bounds for every radius up to the kernel's half-size.

        Parameters
        ----------
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel.

        Returns
        -------
        TailBound or None
            Bounds for radii 0 … the larger half-size, scaled to the reference kernel where it
            is renormalised; None when the model has none.
        """
        if colour not in self._bounds:
            radii = np.arange(max(self.kernel_half) + 1)
            bound = self.model.tail_bound(self.pixel_deg, radii, colour=colour)
            if bound is not None and bound.renormalised:
                # the reference kernel is normalised over its own support, which holds at
                # least 1 - E(its smaller half-size) of the PSF: its values are at most
                # 1 / that times the PSF's
                half = min(self.kernel_half)
                kept = float(1.0 - bound.energy[half] if bound.kept is None else bound.kept[half])
                scale = 1.0 / kept if kept > 0 else np.inf
                bound = TailBound(bound.peak * scale, np.minimum(bound.energy * scale, 1.0))
            self._bounds[colour] = bound
        return self._bounds[colour]

    def coarse_kernel(self, factor: int, colour: bool) -> np.ndarray:
        """The model digitised at ``factor`` pixels, reaching past the whole kernel.

        Parameters
        ----------
        factor
            Pixels per coarse node ``f``.
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel.

        Returns
        -------
        numpy.ndarray
            The coarse kernel, odd, centred, kept for the next images.
        """
        key = (factor, colour)
        if key not in self._coarse:
            shape = tuple(2 * (-(-h // factor) + FOOTPRINT_NODES) + 1 for h in self.kernel_half)
            coarse = self._digitised(self.pixel_deg * factor, shape, colour, say=False)
            self._coarse[key] = coarse.values
        return self._coarse[key]

    def least_kernel(self, factor: int, colour: bool, reach: tuple[int, int]) -> np.ndarray:
        """The reference kernel's least value between the pixels of two cells of ``factor``
        pixels, for each offset between the cells
        (:func:`~glarelab.glare.rendering.multires.least_kernel`).

        Parameters
        ----------
        factor
            Pixels per cell side ``f``.
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel.
        reach
            ``(rows, columns)``: the kernel is cut beyond these offsets.

        Returns
        -------
        numpy.ndarray
            ``(2 ceil(H / f) - 1, 2 ceil(W / f) - 1[, C])``, centred; the last
            :data:`LEAST_KERNELS` made are kept.
        """
        cut = (int(reach[0]), int(reach[1]))

        def make() -> np.ndarray:
            values = np.asarray(self.kernel(colour).values, dtype=np.float64)
            return least_kernel(values, factor, cut, self.shape)

        return _kept(self._least, (factor, colour, cut), make, LEAST_KERNELS)

    def least_spectrum(
        self, factor: int, colour: bool, reach: tuple[int, int]
    ) -> tuple[np.ndarray, tuple[int, int], float]:
        """The spectrum of :meth:`least_kernel`, its least channel, for a linear convolution
        with the cell sums of a whole image (the last :data:`LEAST_KERNELS` made are kept).

        Parameters
        ----------
        factor
            Pixels per cell side ``f``.
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel.
        reach
            ``(rows, columns)``: the kernel is cut beyond these offsets.

        Returns
        -------
        tuple
            The ``rfft2`` of the least kernel placed at the grid's corner, float64; the FFT
            lengths ``(N0, N1)``, at least ``3 ceil(H / f) - 2`` by ``3 ceil(W / f) - 2``
            (no wrap-around); the kernel's largest value.
        """
        cut = (int(reach[0]), int(reach[1]))

        def make() -> tuple[np.ndarray, tuple[int, int], float]:
            kernel = self.least_kernel(factor, colour, cut)
            kernel = kernel if kernel.ndim == 2 else kernel.min(axis=2)
            cells = (-(-self.shape[0] // factor), -(-self.shape[1] // factor))
            lengths = tuple(
                scipy.fft.next_fast_len(c + k - 1, real=True)
                for c, k in zip(cells, kernel.shape, strict=True)
            )
            with scipy.fft.set_workers(fft_workers(lengths)):
                spectrum = scipy.fft.rfft2(kernel, s=lengths)
            return spectrum, (lengths[0], lengths[1]), float(kernel.max())

        return _kept(self._least_spectra, (factor, colour, cut), make, LEAST_KERNELS)

    def multires(self, factor: int, split_px: int, colour: bool) -> MultiresKernels:
        """Near and far kernels of one split, with the far path's error measured over the
        whole kernel (kept for the next images).

        Parameters
        ----------
        factor
            Pixels per coarse node ``f``.
        split_px
            The split radius between the near and far kernels, pixels.
        colour
            Whether the colour kernel (one per channel) is meant, else the luminance kernel.

        Returns
        -------
        MultiresKernels
            The kernels and the far path's measured relative error.
        """
        key = (factor, split_px, colour)
        if key not in self._multires:
            self.say(f"measuring the far path's error: split {split_px} px, grid 1/{factor}")
            full = self.kernel(colour).values
            self._multires[key] = multires_kernels(
                full,
                self.coarse_kernel(factor, colour and full.ndim == 3),
                factor,
                split_px,
                self.kernel_half,
            )
        return self._multires[key]

    def _spectrum(self, lengths, reach, colour, split_px, channel, dtype, values=None):
        key = (tuple(lengths), tuple(reach), colour, split_px, channel, np.dtype(dtype).name)
        if key in self._spectra:
            self._spectra.move_to_end(key)
            return self._spectra[key]
        if values is None:
            full = channels(self.kernel(colour).values)
            k = full[min(channel, len(full) - 1)]
            a, b = self.kernel_half
            values = k[a - reach[0] : a + reach[0] + 1, b - reach[1] : b + reach[1] + 1]
        # made in float64 and rounded once: a float32 spectrum is off by u, not u log2 n
        spectrum = kernel_spectrum(values.astype(np.float64, copy=False), tuple(lengths))
        if np.dtype(dtype) == np.float32:
            spectrum = spectrum.astype(np.complex64)
        self._spectra[key] = spectrum
        while (
            sum(s.nbytes for s in self._spectra.values()) > SPECTRA_BYTES
            and len(self._spectra) > 1
        ):
            self._spectra.popitem(last=False)
        return spectrum

    # one image ----------------------------------------------------------------------------
    def _scene(self, luminance_cd_m2, *, checked: bool = False) -> tuple[np.ndarray, Scene]:
        """The image as an array and its scene; ``checked``: the image is an array that
        :func:`~glarelab.glare._validation.check_image` has returned already (add_glare's)."""
        if checked:
            image = luminance_cd_m2
        else:
            if isinstance(luminance_cd_m2, np.ndarray):  # refused before a scan of its pixels
                check_render_memory(luminance_cd_m2.shape)
            image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
        if image.shape[:2] != self.shape:
            raise ValueError(
                f"luminance_cd_m2 must have the renderer's shape {self.shape}; "
                f"got {image.shape[:2]}"
            )
        peak = float(image.max()) if image.size else 0.0
        if peak > MAX_LUMINANCE_CD_M2:
            shown = f"{peak:.3g}"
            if float(shown) <= MAX_LUMINANCE_CD_M2:  # float32's 1e30 is 1.00000002e+30
                shown = f"{peak:.9g}"
            raise ValueError(
                f"luminance_cd_m2 reaches {shown} cd/m², beyond the "
                f"{MAX_LUMINANCE_CD_M2:g} cd/m² glarelab renders (the sun is 1.6e9)"
            )
        return image, Scene.of(image, self.l_dmax, self.method, self.dtype)

    def plan(self, luminance_cd_m2: np.ndarray) -> GlarePlan:
        """The plan for one image (what :meth:`render` will do).

        Parameters
        ----------
        luminance_cd_m2
            Linear luminance, cd/m², finite and >= 0, the renderer's shape, ``(H, W)`` or
            ``(H, W, 3)``.

        Returns
        -------
        GlarePlan
            The kernel's reach, the paths and the error bound the render will reach.
        """
        return make_plan(self, self._scene(luminance_cd_m2)[1])

    def render(self, luminance_cd_m2: np.ndarray) -> GlareResult:
        """Add glare to one image as planned, and bound the error reached.

        Parameters
        ----------
        luminance_cd_m2
            Linear luminance, cd/m², finite and >= 0, the renderer's shape, ``(H, W)`` or
            ``(H, W, 3)`` linear RGB in cd/m² of a white of equal R, G, B.

        Returns
        -------
        GlareResult

        Raises
        ------
        ValueError
            For an image that is not finite and non-negative, or not of the renderer's shape.

        Notes
        -----
        The error bound per pixel is ``cut + ε / (1 - ε) · S(p)`` cd/m², with ``ε`` the far
        path's measured relative error, ``S`` the spread and ``cut`` the plan's rigorous
        bound, passed through the display (:class:`glarelab.glare.rendering.display.CodeBound`).
        When it exceeds the tolerance anywhere, the exact path is taken instead.
        """
        return self._render(luminance_cd_m2, checked=False)

    def _render(self, luminance_cd_m2, *, checked: bool) -> GlareResult:
        """:meth:`render`; ``checked``: the image has been checked already (add_glare's)."""
        image, scene = self._scene(luminance_cd_m2, checked=checked)
        plan = make_plan(self, scene)
        self.say(f"plan: {plan.path}")
        parameters = {
            "pixel_deg": self.pixel_deg,
            "l_dmax_cd_m2": self.l_dmax,
            "method": self.method,
            "precision": self.dtype.name,
            "kernel_shape": self.kernel_shape,
            "model": plan.model,
            "convolution_precision": [self.dtype.name],
        }
        source = (scene.excess, scene.source_box)
        empty = np.zeros(image.shape, dtype=self.dtype)  # calloc: pages only when touched
        result = {"error_bound_codes": 0.0, "far_relative_error": 0.0, "fallback": ""}
        if plan.path == "none":
            return GlareResult(
                image.copy(), plan, **result, kernel=None, parameters=parameters,
                spread=empty, source=source,
            )  # fmt: skip
        if plan.path == "clamp":
            out = compose(scene.planes, self.dtype.type(0), self.l_dmax, self.method)
            return GlareResult(
                out if scene.colour else out[..., 0], plan, **result, kernel=None,
                parameters=parameters, spread=empty, source=source,
            )  # fmt: skip
        spread, used, roundoff = self._spread(scene, plan)
        out = compose(scene.planes, spread, self.l_dmax, self.method)
        relative = 0.0
        if plan.path == "multires":
            relative = self.multires(plan.multires_factor, plan.split_px, plan.colour_kernel)
            relative = relative.relative_error
        error = self._error(scene, plan, spread, used, roundoff, relative)
        if error > plan.tolerance_codes and roundoff[0] > 0:
            result["fallback"] = (
                f"float32 round-off bound {error:.3g} codes > {plan.tolerance_codes:g}: "
                "float64 transforms"
            )
            self.say(result["fallback"])
            plan = replace(plan, fft_precision="float64", roundoff_cd_m2=0.0, roundoff_codes=0.0)
            spread, used, roundoff = self._spread(scene, plan)
            out = compose(scene.planes, spread, self.l_dmax, self.method)
            error = self._error(scene, plan, spread, used, roundoff, relative)
        if plan.path == "multires" and error > plan.tolerance_codes:
            result["fallback"] = (
                f"far tail error bound {error:.3g} codes > {plan.tolerance_codes:g}: "
                "rendered at full resolution"
            )
            self.say(result["fallback"])
            exact = [p for p in ("direct", "fft") if p in self.paths] or ["direct", "fft"]
            exact = min(exact, key=lambda p: plan.costs.get(p, math.inf))
            plan = replace(plan, path=exact, multires_factor=1, split_px=0)
            spread, used, roundoff = self._spread(scene, plan)
            out = compose(scene.planes, spread, self.l_dmax, self.method)
            relative = 0.0
            error = self._error(scene, plan, spread, used, roundoff, relative)
        if (
            plan.path == "fft"
            and error > plan.tolerance_codes
            and "direct" in self.paths
            and plan.costs.get("direct", math.inf) <= DIRECT_FALLBACK * plan.costs["fft"]
        ):
            result["fallback"] = (
                f"FFT round-off bound {error:.3g} codes > {plan.tolerance_codes:g}: "
                "spread directly"
            )
            self.say(result["fallback"])
            plan = replace(plan, path="direct")
            spread, used, roundoff = self._spread(scene, plan)
            out = compose(scene.planes, spread, self.l_dmax, self.method)
            error = self._error(scene, plan, spread, used, roundoff, 0.0)
        elif error > plan.tolerance_codes:  # said, not left silent: nothing cheaper is exact
            if plan.path != "fft":
                why = f"no path left to try on the {plan.path} path"
            elif "direct" not in self.paths:
                why = "the direct spread, which does not round, is not among paths"
            else:
                times = plan.costs.get("direct", math.inf) / plan.costs["fft"]
                why = (
                    f"the direct spread, which does not round, would cost about {times:.3g} "
                    f"times the FFT (more than {DIRECT_FALLBACK:g})"
                )
            note = f"error bound {error:.3g} codes > {plan.tolerance_codes:g}, kept: {why}"
            result["fallback"] = f"{result['fallback']}; {note}" if result["fallback"] else note
            self.say(note)
        self.say(f"error bound {error:.3g} display codes")
        parameters["convolution_precision"] = sorted(used)
        result.update(error_bound_codes=error, far_relative_error=relative)
        # the image's precision (a planned render summed its spread in float64)
        out, spread = out.astype(self.dtype, copy=False), spread.astype(self.dtype, copy=False)
        if not scene.colour:
            out, spread = out[..., 0], spread[..., 0]
        elif spread.shape[2] == 1:
            spread = np.broadcast_to(spread, out.shape)
        return GlareResult(
            out, plan, **result, kernel=self.kernel(plan.colour_kernel),
            parameters=parameters, spread=spread, source=source,
        )  # fmt: skip

    def _exact_error(self, scene: Scene, spread, absolute: float, tolerance: float) -> float:
        """Codes of a bound that does not grow with the spread: at the darkest pixel's step,
        or, when that is over the tolerance, pixel by pixel through the display."""
        error = absolute / float(self.code_bound.step(scene.darkest))
        if error > tolerance:
            error = min(
                error,
                self.code_bound.codes(
                    scene.planes, spread, absolute=absolute, relative=0.0,
                    tolerance_codes=tolerance,
                ),
            )  # fmt: skip
        return error

    def _error(self, scene, plan, spread, used, roundoff, relative) -> float:
        """The error bound in codes: the cut, the FFT round-off (``roundoff``: the planned
        float32 transforms' ``(a, r)``) and the far tail's relative error."""
        if (
            plan.path == "fft"
            and roundoff[0] > 0
            and roundoff[0] == plan.roundoff_cd_m2
            and self.dtype == np.float64
        ):
            # the plan's bound of these float32 transforms, at the darkest outputs they can
            # leave, is at least what the check pixel by pixel would find
            return plan.roundoff_codes
        absolute = self._absolute(scene, plan, used) + roundoff[0]
        ratio = relative / max(1.0 - relative, 1e-12) + roundoff[1]
        stored = 0.0
        if plan.path == "direct" and plan.direct_precision == "float32":
            # float32 spans: r / (1 - r) of the output at most, the plan's codes
            absolute += plan.roundoff_cd_m2
            stored = plan.roundoff_codes
        if self.dtype == np.float32 and plan.tolerance_codes > 0:
            # the excess rounded to float32 (each ΔL within u of its value: the spread within
            # u of its own), and the output rounded to float32: u of a value, at most
            # u · max L / step(L) codes
            ratio += FLOAT32_UNIT_ROUNDOFF
            stored += FLOAT32_UNIT_ROUNDOFF * self.code_bound.relative_codes
        if ratio:
            return stored + self.code_bound.codes(
                scene.planes,
                spread,
                absolute=absolute,
                relative=ratio,
                tolerance_codes=max(plan.tolerance_codes - stored, 0.0),
            )
        return stored + self._exact_error(
            scene, spread, absolute, max(plan.tolerance_codes - stored, 0.0)
        )

    def _absolute(self, scene: Scene, plan: GlarePlan, used: set[str]) -> float:
        """The part of the error bound that does not grow with the spread, cd/m², but for
        planned float32 transforms: the cut's bound and the float64 FFT round-off (about
        ``ε log2 n`` times the largest spread, ``ΣΔL · max K``, anywhere in the image); the
        exact path's float32 transforms (an image in float32, tolerance 0) add what
        :func:`~glarelab.glare.rendering._convolve.convolution_dtype` allows."""
        absolute = plan.cut_bound_cd_m2
        if plan.tolerance_codes == 0 and plan.path in ("fft", "multires") and "float32" in used:
            absolute += FLOAT32_NOISE_LIMIT_CD_M2  # the exact path's float32 transforms
        if plan.path in ("fft", "multires"):
            peak = self.kernel_peak(plan.colour_kernel)
            n = 4 * self.shape[0] * self.shape[1]
            absolute += np.finfo(np.float64).eps * math.log2(n) * scene.total_excess * peak
        return absolute

    def _spread(self, scene: Scene, plan: GlarePlan):
        """The spread ``(H, W, 1 or C)`` of the plan's path, the precisions used, and the
        round-off bound ``(a, r)`` of planned float32 transforms (zeros otherwise)."""
        height, width = self.shape
        box, out_box = plan.source_box, plan.out_box
        n = plan.convolutions
        # a planned render sums its spread in float64 whatever the image's precision (the
        # transforms' own precision is planned): a float32 sum of many lamps' spreads would
        # round once per lamp
        planned = plan.tolerance_codes > 0
        dtype = np.dtype(np.float64) if planned else self.dtype
        spread = np.zeros((height, width, n), dtype=dtype)
        used: set[str] = set()
        roundoff = (0.0, 0.0)
        if out_box is None:
            return spread, {dtype.name}, roundoff
        o = np.s_[out_box[0] : out_box[1], out_box[2] : out_box[3]]
        reach = plan.reach_px
        for c in range(n):
            excess = scene.excess[..., c]
            if plan.path == "direct":
                kernel = self.kernel(plan.colour_kernel)
                symmetric = kernel.quadrant is not None
                k = channels(kernel.quadrant if symmetric else kernel.values)
                k = k[min(c, len(k) - 1)]
                if symmetric:  # spread from the quadrant: the full kernel is never made
                    k = k[: reach[0] + 1, : reach[1] + 1]
                else:
                    a, b = self.kernel_half
                    k = k[a - reach[0] : a + reach[0] + 1, b - reach[1] : b + reach[1] + 1]
                used.add(dtype.name)
                if plan.direct_precision == "float32":
                    used.add("float32")
                direct_spread(
                    excess,
                    box[::2],
                    k.astype(dtype, copy=False),
                    out_box,
                    spread[..., c],
                    quadrant=symmetric,
                    # the scene's own groups, where its excess is this one plane
                    groups=scene.clusters() if scene.excess.shape[2] == 1 else None,
                    precision=plan.direct_precision,
                    costs=direct_costs(self.costs, plan.direct_precision),
                )
                continue
            if plan.path == "fft":
                values, half = None, reach
            elif plan.path == "multires":
                kernels = self.multires(plan.multires_factor, plan.split_px, plan.colour_kernel)
                near = channels(kernels.near)
                values, half = near[min(c, len(near) - 1)], (2 * plan.split_px,) * 2
                far = channels(kernels.far)
                coarse = far_spread(
                    None,
                    box,
                    self.shape,
                    far[min(c, len(far) - 1)],
                    plan.multires_factor,
                    nodes=True,
                    splatted=scene.splat(plan.multires_factor, c),
                )
                spread[..., c][o] = upsample(
                    coarse,
                    plan.multires_factor,
                    (out_box[1] - out_box[0], out_box[3] - out_box[2]),
                    start=out_box[::2],
                )
            else:
                raise ValueError(f"unknown path {plan.path!r}")
            near_box = _within(out_box, box, half)
            lengths = (
                fft_length(box[:2], near_box[:2], half[0]),
                fft_length(box[2:], near_box[2:], half[1]),
            )
            if plan.tolerance_codes > 0:
                work = np.dtype(plan.fft_precision)
                if work == np.float32:
                    bound = self.roundoff_bound(scene, lengths, plan.colour_kernel)
                    roundoff = tuple(max(a, b) for a, b in zip(roundoff, bound, strict=True))
            else:
                peak = np.array([self.kernel_peak(plan.colour_kernel)])
                work = convolution_dtype(excess, peak, self.dtype)
            used.add(work.name)
            spectrum = self._spectrum(
                lengths,
                half,
                plan.colour_kernel,
                plan.split_px,
                c if plan.colour_kernel else 0,
                work,
                values,
            )
            part = spectral_spread(
                excess.astype(work, copy=False), box, near_box, spectrum, lengths
            )
            near = spread[..., c][near_box[0] : near_box[1], near_box[2] : near_box[3]]
            if plan.path == "fft":  # the only part: the rest of the spread stays 0
                np.maximum(part, 0.0, out=near)  # FFT round-off is not non-negative
            else:
                near += part
        if plan.path == "multires":  # the far tail's coarse transforms too
            np.maximum(spread, 0.0, out=spread)
        return spread, used, roundoff


def _kept(cache: OrderedDict, key: tuple, make, limit: int):
    """``cache[key]``, made by ``make()`` the first time; beyond ``limit`` entries the least
    recently used is dropped."""
    if key in cache:
        cache.move_to_end(key)
    else:
        cache[key] = make()
        while len(cache) > limit:
            cache.popitem(last=False)
    return cache[key]


def _unfold(half: np.ndarray) -> np.ndarray:
    """The lines of a symmetric kernel at offsets ``-h … h`` from those at ``0 … h``."""
    return np.concatenate([half[:0:-1], half])


# a digitised kernel sums to at most 1 (the share of its PSF inside its support; measured
# 1 + 2.2e-16 at most); a float32 kernel's roundings stay far below this
KERNEL_SUM_ROUNDING = 1e-6


def _custom(model: GlareModel) -> bool:
    """Whether a model is a user's (any object with a ``kernel`` method, or a subclass of
    :class:`GlareModel` defined outside glarelab), whose kernels are checked."""
    return isinstance(model, _Declared) or not type(model).__module__.startswith("glarelab.")


def check_kernel_values(kernel: Kernel, what: str) -> None:
    """Refuse a kernel with NaN, Inf or negative values, or a channel summing to more than
    1 (more light than its source sends): it would render without a word otherwise.

    Parameters
    ----------
    kernel
        The kernel.
    what
        The kernel, for the message (``'kernel'``, ``"VosGlare's kernel"``).

    Raises
    ------
    ValueError
        Naming the first bad value, or the sum.
    """
    part = kernel.quadrant if kernel.quadrant is not None else kernel.values
    low, high = np.min(part), np.max(part)  # NaN propagates
    if not (np.isfinite(low) and np.isfinite(high)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(part))[0])
        raise ValueError(f"{what} must be finite; got {float(part[bad])!r} at index {bad}")
    if low < 0:
        raise ValueError(
            f"{what} must be >= 0 (a kernel spreads light, it takes none away); got {float(low)!r}"
        )
    total = float(np.max(kernel.total()))
    if total > 1.0 + KERNEL_SUM_ROUNDING:
        raise ValueError(
            f"{what} sums to {total:.6g}; a kernel holds at most its source's light (each "
            "channel sums to <= 1, the share of the PSF inside its support): divide it by "
            "its sum, or digitise it with glarelab.glare.digitise_kernel"
        )


def _check_kernel_of(kernel, model: GlareModel) -> None:
    """Refuse a ``kernel`` that is not a :class:`Kernel`, or whose description names another
    model or other parameters than ``model`` (a kernel built by hand, with no ``model`` in its
    description, is taken as given)."""
    if not isinstance(kernel, Kernel):
        raise TypeError(
            "kernel must be a Kernel digitised by the model (glarelab.glare.digitise_kernel), "
            f"got {type(kernel).__name__}"
        )
    described = kernel.description or {}
    if "model" not in described:
        return
    own = model.description(len(kernel.shape) == 3)
    if described["model"] != own["model"]:
        raise ValueError(
            f"kernel was digitised by {described['model']}, not by the model given "
            f"({own['model']})"
        )
    scalar = (int, float, str, bool, type(None))
    for key, value in own.items():
        given = described.get(key, value)
        if key == "colour" or not isinstance(value, scalar) or not isinstance(given, scalar):
            continue
        if given != value:
            raise ValueError(
                f"kernel was digitised by {own['model']} with {key} = {given!r}, not the "
                f"model's {key} = {value!r}"
            )


def check_tolerance(tolerance_codes: float | None) -> float:
    """``tolerance_codes`` as a float (None: 0), after checking it is a finite number >= 0
    (not a bool or a string, which ``float`` would read).

    Parameters
    ----------
    tolerance_codes
        The largest error allowed against the exact render, display codes, or None.

    Returns
    -------
    float
        The tolerance, 0 for None.

    Raises
    ------
    ValueError
        For anything else.
    """
    if tolerance_codes is None:
        return 0.0
    try:
        tolerance = real_number(tolerance_codes)
    except TypeError:
        tolerance = math.nan
    if not math.isfinite(tolerance) or tolerance < 0:
        raise ValueError(
            f"tolerance_codes must be a finite number >= 0 or None, got {tolerance_codes!r}"
        )
    return tolerance


def _renderer_for(
    luminance_cd_m2: np.ndarray, model: GlareModel | str, **options
) -> tuple[np.ndarray, GlareRenderer]:
    """The one-call functions' start: the image checked (``(H, W)`` or ``(H, W, 3)``, finite,
    >= 0) and a :class:`GlareRenderer` of its shape with ``options``, which it checks."""
    if isinstance(luminance_cd_m2, np.ndarray):  # refused before a scan of its pixels
        check_render_memory(luminance_cd_m2.shape)
    image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
    return image, GlareRenderer(model, shape=image.shape[:2], **options)


def _within(out_box, box, half) -> tuple[int, int, int, int]:
    """The part of ``out_box`` within ``half`` pixels of ``box``."""
    return (
        max(out_box[0], box[0] - half[0]),
        min(out_box[1], box[1] + half[0]),
        max(out_box[2], box[2] - half[1]),
        min(out_box[3], box[3] + half[1]),
    )
