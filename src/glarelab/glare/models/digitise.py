"""Digitising radial PSFs into convolution kernels (Spencer et al. 1995, §3.2).

A kernel pixel holds the energy the PSF sends into it: the integral of ``P(θ)`` over the
pixel's area, in the measure of Spencer eq. 4. Pixel ``(i, j)`` (offsets from the centre) of
size ``Δ`` degrees covers ``[(i-½)Δ, (i+½)Δ] × [(j-½)Δ, (j+½)Δ]``; angle from the source is
the distance from the centre (azimuthal equidistant map, Spencer's constant-``Δθ``
assumption), with area element ``sin θ dθ dφ``.

How the energy is computed, and why:

- **Per-pixel quadrature.** A composite midpoint rule with ``n × n`` samples per pixel
  (Spencer uses the trapezoidal rule, of the same order; the midpoint rule does not sample the
  pixel corners shared with neighbours twice). ``n`` follows the PSF: ``center_samples`` in the
  central ``center_radius_px`` pixels where ``(θ + 0.02)⁻³`` changes fast (Spencer: 10,000
  samples there), then ``samples_per_pixel`` falling as ``1/r``. For a power law
  ``(θ + a)⁻ᵏ`` the midpoint error of a pixel at ``r`` pixels is ``≈ k(k+1)/(12 n² r²)``
  relative, whatever the pixel size, so ``n ∝ 1/r`` keeps the error uniform. A profile with
  a fine feature away from the centre (the 0.16°-wide halo ring) asks for a sample spacing.
- **Exact totals.** The energy inside the kernel's support is computed separately, by
  one-dimensional Gauss-Legendre integration of the radial mass over the rectangle's outline
  (:func:`glarelab.glare.models._radial.rectangle_mass`), and so is the centre pixel (the PSF's
  peak, where sampling converges slowest). The quadrature's off-centre pixels are scaled to make
  the total exact; the size of that correction is reported as ``quadrature_error``.
- **f0** is a Gaussian and separable: its pixel energies are products of error-function
  differences, exact for any pixel size. When the pixel is much wider than f0 (0.02°), this
  is Spencer's "replaced by a delta function" without a special case.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from glarelab.files.memory import check_memory
from glarelab.files.values import is_whole
from glarelab.glare._validation import check_pixel_deg, check_positive, check_positive_int
from glarelab.glare.models._radial import radial_mass, rectangle_mass

__all__ = [
    "Kernel",
    "check_image_shape",
    "check_kernel_shape",
    "digitise_radial",
    "digitise_radial_quadrant",
    "gaussian_pixel_energies",
    "kernel_shape_for",
    "mirror_quadrant",
    "quadrant_sum",
]

Profile = Callable[[np.ndarray], np.ndarray]
_PIXEL_AREA_SR_PER_DEG2 = (math.pi / 180.0) ** 2
_SAMPLE_CHUNK = 4_000_000  # samples evaluated at once, bounding memory to ~100 MB


ROUNDING_OUTSIDE = 1e-12  # a kernel's energy outside above -this is rounding of 0


class Kernel:
    """A digitised glare kernel and its energy account.

    A kernel symmetric in both axes (every radial model) may be given as its quadrant of
    offsets ``i, j >= 0`` alone: the full ``values`` are then unfolded on first use only, and
    the renderer spreads sources straight from the quadrant (a quarter of the memory, and no
    134 MB array to fill for a 4095² kernel).

    Parameters
    ----------
    values
        Kernel of shape ``(KH, KW)`` (luminance) or ``(KH, KW, C)`` (one per colour channel),
        odd sizes, centred; or None when ``quadrant`` is given.
    pixel_deg
        Visual angle of one pixel in degrees.
    energy_outside
        Fraction of the PSF's energy that falls outside the kernel's support (not spread),
        per channel for a colour kernel.
    quadrature_error
        Relative correction the exact support energy made to the per-pixel quadrature,
        averaged over the kernel's parts by the energy each holds; a measure of how well the
        samples resolved the PSF (about 6e-5 with the default samples).
    description
        The model and digitisation settings, for logs.
    quadrant
        For a kernel symmetric in both axes, instead of ``values``: its part ``(KH // 2 + 1,
        KW // 2 + 1[, C])`` at offsets ``i, j >= 0`` from the centre.

    Attributes
    ----------
    values
        The full kernel; each channel sums to ``1 - energy_outside``, or, for a model that
        admits only a share of the light (a wave-optics kernel under Luidolt's pupil
        convention, ``description['admitted_share']``), to that share less
        ``energy_outside``.
    quadrant
        The quadrant of a kernel made from one, else None. It and the ``values`` unfolded
        from it are read-only: the direct path spreads from the one and the FFT path from
        the other, so an edit to either would render one kernel two ways.

    Raises
    ------
    ValueError
        Unless exactly one of ``values`` and ``quadrant`` is given; for ``values`` or
        ``quadrant`` that are not a 2-D or 3-D array of real numbers, ``values`` of an even
        size, or a ``pixel_deg`` that is not a finite number > 0.

    Examples
    --------
    >>> kernel = Kernel(quadrant=np.array([[0.4, 0.1], [0.1, 0.05]]), pixel_deg=0.1)
    >>> kernel.shape, float(kernel.peak), float(kernel.total())
    ((3, 3), 0.4, 1.0)
    >>> kernel.values[0]
    array([0.05, 0.1 , 0.05])
    """

    def __init__(
        self,
        values: np.ndarray | None = None,
        pixel_deg: float | None = None,
        energy_outside: float | np.ndarray = 0.0,
        quadrature_error: float = 0.0,
        description: dict | None = None,
        *,
        quadrant: np.ndarray | None = None,
    ) -> None:
        if (values is None) == (quadrant is None):
            raise ValueError("Kernel needs exactly one of values and quadrant")
        if pixel_deg is None:
            raise ValueError("Kernel needs pixel_deg")
        check_positive("pixel_deg", pixel_deg, unit="°")
        if values is not None:
            values = _kernel_array("values", values)
            if values.shape[0] % 2 == 0 or values.shape[1] % 2 == 0:
                raise ValueError(
                    f"values must have odd sizes (a kernel is centred on a pixel); got shape "
                    f"{values.shape}"
                )
        if quadrant is not None:
            quadrant = _read_only(_kernel_array("quadrant", quadrant))
        # light outside a kernel is never negative: -1e-16 is the rounding of a kernel that
        # holds all of it (a total summed to one plus a few ulp)
        if np.ndim(energy_outside) == 0:
            if -ROUNDING_OUTSIDE < float(energy_outside) < 0:
                energy_outside = 0.0
        else:
            energy_outside = np.asarray(energy_outside, dtype=float)
            rounded = (energy_outside < 0) & (energy_outside > -ROUNDING_OUTSIDE)
            if rounded.any():
                energy_outside = np.where(rounded, 0.0, energy_outside)
        fields = {
            "_values": values,
            "quadrant": quadrant,
            "pixel_deg": pixel_deg,
            "energy_outside": energy_outside,
            "quadrature_error": quadrature_error,
            "description": {} if description is None else description,
        }
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    def __setattr__(self, name: str, value) -> None:
        raise AttributeError(f"a Kernel is not changed after it is made (setting {name!r})")

    def __getstate__(self) -> dict:
        """What pickling sends (Dask, to its workers): a quadrant kernel without the full
        kernel unfolded from it, which is unfolded again where it is asked for."""
        state = dict(self.__dict__)
        if state["quadrant"] is not None:
            state["_values"] = None
        return state

    def __setstate__(self, state: dict) -> None:
        for name, value in state.items():
            object.__setattr__(self, name, value)
        if self.quadrant is not None:
            object.__setattr__(self, "quadrant", _read_only(self.quadrant))

    def __repr__(self) -> str:
        model = self.description.get("model", "kernel")
        return f"Kernel({model}, shape={self.shape}, pixel_deg={self.pixel_deg!r})"

    @property
    def values(self) -> np.ndarray:
        if self._values is None:  # unfolded once, on first use
            object.__setattr__(self, "_values", _read_only(mirror_quadrant(self.quadrant)))
        return self._values

    @property
    def shape(self) -> tuple[int, ...]:
        if self._values is not None:
            return self._values.shape
        height, width = self.quadrant.shape[:2]
        return (2 * height - 1, 2 * width - 1, *self.quadrant.shape[2:])

    @property
    def center(self) -> tuple[int, int]:
        return self.shape[0] // 2, self.shape[1] // 2

    @property
    def peak(self) -> float:
        """The largest value."""
        return np.max(self.quadrant if self._values is None else self._values)

    def total(self) -> float | np.ndarray:
        """The sum over the support, per channel for a colour kernel (from the quadrant of a
        kernel made from one, whether or not it has been unfolded: the same to the bit)."""
        if self.quadrant is not None:
            return quadrant_sum(self.quadrant)
        return self._values.sum(axis=(0, 1), dtype=np.float64)

    def replace(self, **changes) -> Kernel:
        """A copy with ``changes`` (``values`` replaces a quadrant, and the reverse).

        Parameters
        ----------
        changes
            The fields to change (``values``, ``quadrant``, ``pixel_deg``, ``energy_outside``,
            ``quadrature_error``, ``description``).

        Returns
        -------
        Kernel
            The copy; the kernel itself is unchanged.
        """
        fields = {
            "pixel_deg": self.pixel_deg,
            "energy_outside": self.energy_outside,
            "quadrature_error": self.quadrature_error,
            "description": self.description,
        }
        if "values" not in changes and "quadrant" not in changes:
            if self.quadrant is not None:
                fields["quadrant"] = self.quadrant
            else:
                fields["values"] = self._values
        return Kernel(**(fields | changes))


def _kernel_array(name: str, array: object) -> np.ndarray:
    """``array`` as a kernel's values: a 2-D ``(KH, KW)`` or 3-D ``(KH, KW, C)`` array of real
    numbers (the caller's own array, not a copy, where it is one)."""
    if isinstance(array, np.ma.MaskedArray):
        raise ValueError(f"Kernel {name} must be a plain array, not a masked array")
    if isinstance(array, str | bytes) or array is None:
        raise ValueError(
            f"Kernel {name} must be a 2-D or 3-D array of numbers; got {type(array).__name__}"
        )
    try:
        values = np.asarray(array)
    except ValueError:
        raise ValueError(f"Kernel {name} must be an array of numbers; got ragged rows") from None
    if values.dtype == bool or not (
        np.issubdtype(values.dtype, np.floating) or np.issubdtype(values.dtype, np.integer)
    ):
        raise ValueError(f"Kernel {name} must hold real numbers; got dtype {values.dtype}")
    if values.ndim not in (2, 3) or min(values.shape, default=0) < 1:
        raise ValueError(
            f"Kernel {name} must be a 2-D (KH, KW) or 3-D (KH, KW, C) array; got shape "
            f"{values.shape}"
        )
    return values


def _read_only(array) -> np.ndarray:
    """A read-only view of ``array`` (the caller's own array is left as it is)."""
    view = np.asarray(array).view()
    view.flags.writeable = False
    return view


def kernel_shape_for(image_shape: Sequence[int]) -> tuple[int, int]:
    """Kernel shape that lets every pixel of an image reach every other: ``(2H-1, 2W-1)``.

    This is Spencer §3.2's "double the width and height of the target image" and covers
    Yoshida's kernel "from -s/2 to s/2" of the stimulus size.

    Parameters
    ----------
    image_shape
        The image's shape ``(H, W[, C])``, pixels.

    Returns
    -------
    tuple of int
        ``(2H - 1, 2W - 1)``.

    Raises
    ------
    ValueError
        Unless the first two entries are whole numbers >= 1.

    Examples
    --------
    >>> kernel_shape_for((300, 200))
    (599, 399)
    """
    height, width = check_image_shape(image_shape, name="image_shape")
    return 2 * height - 1, 2 * width - 1


def check_image_shape(shape: Sequence[int], *, name: str = "shape") -> tuple[int, int]:
    """An image's ``(H, W[, C])`` as ``(H, W)``, each a whole number of pixels >= 1.

    Parameters
    ----------
    shape
        The image's shape; a third entry (channels), if any, must be 1 or 3.
    name
        The argument's name in the error.

    Returns
    -------
    tuple of int
        ``(H, W)``.

    Raises
    ------
    ValueError
        For a string, fewer than two or more than three entries, channels other than 1 or
        3, or an entry that is a bool, a fraction or < 1.

    Examples
    --------
    >>> check_image_shape((300, 200, 3))
    (300, 200)
    """
    message = f"{name} must be (H, W) of whole pixel counts >= 1, got {shape!r}"
    if isinstance(shape, str | bytes) or not hasattr(shape, "__len__") or len(shape) < 2:
        raise ValueError(message)
    if len(shape) > 3 or (len(shape) == 3 and shape[2] not in (1, 3)):  # no image has them
        raise ValueError(
            f"{name} must be (H, W) or (H, W, C) of a luminance or RGB image (C 1 or 3), got "
            f"{shape!r}"
        )
    sides = []
    for side in tuple(shape)[:2]:
        if isinstance(side, bool | np.bool_) or not isinstance(side, int | np.integer):
            raise ValueError(message)
        if side < 1:
            raise ValueError(message)
        sides.append(int(side))
    return sides[0], sides[1]


# bytes a pixel of a luminance kernel takes while it is digitised (about 110 measured, as the
# command line's psf reckons it); a shape needing more than the system has is refused
KERNEL_BYTES_PER_PIXEL = 128
ASK_MEMORY_ABOVE_BYTES = 2**28  # smaller kernels are not worth asking the system about


def check_kernel_shape(
    shape: Sequence[int], *, name: str = "shape", allocating: bool = True
) -> tuple[int, int]:
    """A kernel shape checked: two odd positive integers.

    Parameters
    ----------
    shape
        The kernel shape asked for.
    name
        The argument's name in the messages; default ``'shape'``.
    allocating
        Whether a kernel of this shape is about to be digitised (default): then a shape whose
        digitising needs more memory than the system has (about 128 bytes a pixel) is refused
        before anything is allocated. False for a kernel that exists already.

    Returns
    -------
    tuple of int
        ``(KH, KW)`` as ints.

    Raises
    ------
    ValueError
        Unless it is two odd positive integers (a kernel needs a centre pixel), or when the
        kernel would need more memory than is available (naming the shape and both sizes).

    Examples
    --------
    >>> check_kernel_shape((5, 7))
    (5, 7)
    >>> check_kernel_shape((100001, 100001))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: shape (100001, 100001) (a kernel ...) needs about 1192.1 GiB of memory, ...
    """
    try:
        height, width = shape
    except (TypeError, ValueError):
        raise ValueError(
            f"{name} must be two odd positive integers (KH, KW), got {shape!r}"
        ) from None
    for n in (height, width):
        if not is_whole(n):
            raise ValueError(
                f"{name} must be two odd positive integers (KH, KW), got {shape!r} (a "
                f"{type(n).__name__} is not a pixel count)"
            )
    height, width = int(height), int(width)
    if height < 1 or width < 1 or height % 2 == 0 or width % 2 == 0:
        raise ValueError(
            f"{name} must be two odd positive integers (KH, KW) so the kernel has a centre "
            f"pixel, got {tuple(shape)!r}"
        )
    needed = KERNEL_BYTES_PER_PIXEL * height * width
    if allocating and needed > ASK_MEMORY_ABOVE_BYTES:
        check_memory(
            needed,
            f"{name} {(height, width)!r} (a kernel takes about {KERNEL_BYTES_PER_PIXEL} bytes a "
            "pixel while it is digitised)",
        )
    return height, width


def mirror_quadrant(quadrant: np.ndarray) -> np.ndarray:
    """Unfold the quadrant ``i, j >= 0`` of a kernel symmetric in both axes to the full kernel.

    The quadrant may carry trailing axes (channels); they are kept.

    Parameters
    ----------
    quadrant
        ``(h, w[, ...])``: the kernel at offsets ``i, j >= 0`` from its centre.

    Returns
    -------
    numpy.ndarray
        ``(2h - 1, 2w - 1[, ...])``, of the quadrant's dtype.

    Examples
    --------
    >>> mirror_quadrant(np.array([[4, 2], [1, 0]]))
    array([[0, 1, 0],
           [2, 4, 2],
           [0, 1, 0]])
    """
    height, width = quadrant.shape[:2]
    full = np.empty((2 * height - 1, 2 * width - 1, *quadrant.shape[2:]), dtype=quadrant.dtype)
    full[height - 1 :, width - 1 :] = quadrant
    full[height - 1 :, : width - 1] = quadrant[:, :0:-1]
    full[: height - 1] = full[: height - 1 : -1]
    return full


def quadrant_sum(quadrant: np.ndarray) -> np.ndarray:
    """Sum over the full kernel that :func:`mirror_quadrant` would unfold, per trailing axis,
    in float64 whatever the quadrant's dtype (as the full kernel's total is taken).

    Parameters
    ----------
    quadrant
        ``(h, w[, ...])``: the kernel at offsets ``i, j >= 0`` from its centre.

    Returns
    -------
    numpy.ndarray
        float64, the shape of the trailing axes (a scalar array for none).

    Examples
    --------
    >>> q = np.array([[4.0, 2.0], [1.0, 0.5]])
    >>> float(quadrant_sum(q)), float(mirror_quadrant(q).sum())
    (12.0, 12.0)
    """
    return (
        4.0 * quadrant[1:, 1:].sum(axis=(0, 1), dtype=np.float64)
        + 2.0 * quadrant[0, 1:].sum(axis=0, dtype=np.float64)
        + 2.0 * quadrant[1:, 0].sum(axis=0, dtype=np.float64)
        + quadrant[0, 0].astype(np.float64)
    )


def gaussian_pixel_energies(width_deg: float, pixel_deg: float, half_size: int) -> np.ndarray:
    """Energy per pixel of a unit 1-D Gaussian ``exp(-(x/width)²)/(width √π)``, offsets 0..n.

    Returns ``½[erf((i+½)Δ/w) - erf((i-½)Δ/w)]`` for ``i = 0 … half_size``; the 2-D kernel of
    a separable Gaussian is the outer product of two of these, mirrored. Where the pixel's
    near edge is past ``w/2`` the difference is taken of the complements,
    ``½[erfc((i-½)Δ/w) - erfc((i+½)Δ/w)]``: a difference of two values of ``erf`` near 1
    keeps only round-off (about 1e-17 where the energy is 1e-170), which a glint of 1e9
    cd/m² spreads as 1e-8 cd/m² over pixels the Gaussian does not reach. Nearer the centre
    ``erf`` is kept: there the complements are near 1 (1e-9 of a pixel's energy lost for a
    Gaussian 1e5 pixels wide).

    Parameters
    ----------
    width_deg
        The Gaussian's width ``w``, degrees (``σ √2``).
    pixel_deg
        Visual angle of one pixel ``Δ``, degrees.
    half_size
        The largest offset ``n``, pixels.

    Returns
    -------
    numpy.ndarray
        ``(half_size + 1,)`` fractions of the Gaussian's energy.
    """
    from scipy.special import erf, erfc  # imported here: 0.2 s at start-up

    offsets = np.arange(half_size + 1, dtype=float)
    near, far = (offsets - 0.5) * pixel_deg / width_deg, (offsets + 0.5) * pixel_deg / width_deg
    tail = near >= 0.5  # both complements below 0.48: their difference keeps its digits
    energies = 0.5 * (erf(far) - erf(near))
    energies[tail] = 0.5 * (erfc(near[tail]) - erfc(far[tail]))
    return energies


def _samples_per_axis(
    radius_px: np.ndarray,
    *,
    pixel_deg: float,
    samples_per_pixel: int,
    center_samples: int,
    center_radius_px: float,
    max_spacing_deg: float | None,
) -> np.ndarray:
    counts = np.ceil(samples_per_pixel * center_radius_px / np.maximum(radius_px, 1e-12))
    counts = np.minimum(counts, samples_per_pixel)
    counts = np.where(radius_px <= center_radius_px, center_samples, counts)
    if max_spacing_deg is not None:
        counts = np.maximum(counts, math.ceil(pixel_deg / max_spacing_deg))
    return np.maximum(counts, 1).astype(int)


def _sampled(
    profiles: Sequence[Profile],
    pix_rows: np.ndarray,
    pix_cols: np.ndarray,
    n: int,
    pixel_deg: float,
) -> np.ndarray:
    """``(C, P)`` energies of pixels ``(pix_rows, pix_cols)`` by the ``n × n`` midpoint rule."""
    offsets = (np.arange(n) + 0.5) / n - 0.5
    du, dv = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
    sums = np.zeros((len(profiles), pix_rows.size))
    per_chunk = max(1, _SAMPLE_CHUNK // (n * n))
    for start in range(0, pix_rows.size, per_chunk):
        stop = start + per_chunk
        y = (pix_rows[start:stop, None] + du[None, :]) * pixel_deg
        x = (pix_cols[start:stop, None] + dv[None, :]) * pixel_deg
        theta = np.hypot(x, y)
        # sin θ / θ: area element of the azimuthal equidistant map (1 at θ = 0)
        jacobian = np.sinc(theta / 180.0)
        for c, profile in enumerate(profiles):
            density = np.where(theta <= 90.0, profile(np.minimum(theta, 90.0)), 0.0)
            sums[c, start:stop] = (density * jacobian).mean(axis=1)
    return sums * pixel_deg**2 * _PIXEL_AREA_SR_PER_DEG2


def _quadrature_exact(
    profiles, half_h, half_w, pixel_deg, active_deg, sample_options
) -> np.ndarray:
    """Every pixel of the quadrant by its own midpoint rule (the reference digitisation)."""
    quadrant = np.zeros((len(profiles), half_h + 1, half_w + 1))
    _sample_pixels(
        quadrant, profiles, half_h, half_w, pixel_deg, active_deg, sample_options, fewest=1
    )
    return quadrant


def _sample_pixels(
    quadrant, profiles, box_h, box_w, pixel_deg, active_deg, sample_options, *, fewest
) -> None:
    """Write into ``quadrant`` the pixels ``0..box_h × 0..box_w`` that get at least ``fewest``
    samples per axis, each by its own midpoint rule; the centre pixel (computed exactly by the
    caller) and pixels beyond ``active_deg`` are left as they are."""
    rows, cols = np.meshgrid(
        np.arange(box_h + 1, dtype=float), np.arange(box_w + 1, dtype=float), indexing="ij"
    )
    radius_px = np.hypot(rows, cols)
    counts = _samples_per_axis(radius_px, pixel_deg=pixel_deg, **sample_options)
    active = counts >= fewest
    if active_deg is not None:
        active &= radius_px * pixel_deg <= active_deg
    active[0, 0] = False
    for n in np.unique(counts[active]):
        select = active & (counts == n)
        quadrant[(slice(None), *np.nonzero(select))] = _sampled(
            profiles, rows[select], cols[select], int(n), pixel_deg
        )


def _quadrature_symmetric(
    profiles, half_h, half_w, pixel_deg, active_deg, sample_options
) -> np.ndarray:
    """The same midpoint rules as :func:`_quadrature_exact`, using the PSF's symmetry.

    Pixels sampled more than once (near the centre, where the PSF changes within a pixel)
    are sampled as before. Beyond them a pixel's one sample is its centre's value, which
    depends on the radius alone: it is read from a radial table on a 1/64-pixel grid
    (linear interpolation, relative error ``≈ k(k+1)/(8 (64 r)²)`` for a ``θ⁻ᵏ`` profile at
    ``r`` pixels: 2e-7 at the 40 px where one sample starts).
    """
    samples_per_pixel = sample_options["samples_per_pixel"]
    center_radius_px = sample_options["center_radius_px"]
    max_spacing_deg = sample_options["max_spacing_deg"]
    least = 1 if max_spacing_deg is None else max(1, math.ceil(pixel_deg / max_spacing_deg))
    if least > 1:  # every pixel is sampled more than once: nothing to tabulate
        return _quadrature_exact(profiles, half_h, half_w, pixel_deg, active_deg, sample_options)
    # the region of several samples per pixel (the PSF changes within a pixel), plus a margin
    near = min(
        math.ceil(max(center_radius_px, samples_per_pixel * center_radius_px)) + 2,
        max(half_h, half_w),
    )
    reach_h, reach_w = half_h, half_w
    if active_deg is not None:
        reach = math.floor(active_deg / pixel_deg)
        reach_h, reach_w = min(half_h, reach), min(half_w, reach)
    quadrant = np.zeros((len(profiles), half_h + 1, half_w + 1))
    rows = np.arange(reach_h + 1, dtype=float)
    cols = np.arange(reach_w + 1, dtype=float)
    radius_px = np.hypot(rows[:, None], cols[None, :])
    steps_per_px = 64
    r_max = float(np.hypot(reach_h, reach_w))
    table_px = np.arange(math.ceil(r_max * steps_per_px) + 2) / steps_per_px
    # linear interpolation on the uniform grid: index and fraction, shared by the profiles
    position = radius_px * steps_per_px
    index = position.astype(np.intp)  # floor: radii are >= 0
    fraction = position - index
    del position
    theta = table_px * pixel_deg
    jacobian = np.sinc(theta / 180.0)
    for c, profile in enumerate(profiles):
        table = profile(np.minimum(theta, 90.0)) * jacobian
        table *= pixel_deg**2 * _PIXEL_AREA_SR_PER_DEG2
        slope = np.append(np.diff(table), 0.0)
        values = np.take(slope, index)
        values *= fraction
        values += np.take(table, index)
        quadrant[c, : reach_h + 1, : reach_w + 1] = values
    limit = 90.0 if active_deg is None else min(active_deg, 90.0)
    if r_max * pixel_deg > limit:  # beyond the support or the hemisphere: no light
        quadrant[:, : reach_h + 1, : reach_w + 1][:, radius_px * pixel_deg > limit] = 0.0
    # the pixels sampled several times, exactly as the reference does
    box_h, box_w = min(near, reach_h), min(near, reach_w)
    _sample_pixels(
        quadrant, profiles, box_h, box_w, pixel_deg, active_deg, sample_options, fewest=2
    )
    quadrant[:, 0, 0] = 0.0
    return quadrant


def digitise_radial(
    profiles: Sequence[Profile],
    *,
    pixel_deg: float,
    shape: Sequence[int],
    samples_per_pixel: int = 10,
    center_samples_per_pixel: int = 100,
    center_radius_px: float = 4.0,
    max_spacing_deg: float | None = None,
    breakpoints: tuple[float, ...] = (),
    support_deg: float | None = None,
    symmetric: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Integrate radial profiles over the pixels of a kernel.

    Parameters
    ----------
    profiles
        Callables ``P(θ_deg) -> density per sr``, evaluated on the same samples.
    pixel_deg
        Pixel size in degrees, > 0.
    shape
        Odd kernel shape ``(KH, KW)``.
    samples_per_pixel
        Samples per axis just outside the central region; they fall as ``1/r`` beyond it,
        keeping the relative error uniform. Default 10.
    center_samples_per_pixel
        Samples per axis in the central region; default 100 (10,000 per pixel, as Spencer).
    center_radius_px
        Radius of the central region in pixels; default 4.
    max_spacing_deg
        Largest allowed sample spacing in degrees (for profiles with a fine ring); default
        None (no limit).
    breakpoints
        Angles where the profiles change fast, for the exact radial integrals.
    support_deg
        Only pixels whose centre lies within this angle (plus one pixel) are sampled; the
        profiles must vanish beyond it. Default None (all pixels).
    symmetric
        True (default): pixels with one sample are read from a radial table
        (:func:`_quadrature_symmetric`); False: every pixel is evaluated (the reference).

    Returns
    -------
    values : numpy.ndarray
        ``(C, KH, KW)`` pixel energies; each channel sums to its exact in-support energy.
    inside : numpy.ndarray
        ``(C,)`` exact energy inside the support.
    total : numpy.ndarray
        ``(C,)`` energy of each profile over the hemisphere.
    quadrature_error : numpy.ndarray
        ``(C,)`` relative correction applied to the quadrature's off-centre pixels.
    """
    quadrant, inside, total, quadrature_error = digitise_radial_quadrant(
        profiles,
        pixel_deg=pixel_deg,
        shape=shape,
        samples_per_pixel=samples_per_pixel,
        center_samples_per_pixel=center_samples_per_pixel,
        center_radius_px=center_radius_px,
        max_spacing_deg=max_spacing_deg,
        breakpoints=breakpoints,
        support_deg=support_deg,
        symmetric=symmetric,
    )
    values = np.stack([mirror_quadrant(q) for q in quadrant])
    return values, inside, total, quadrature_error


def digitise_radial_quadrant(
    profiles: Sequence[Profile],
    *,
    pixel_deg: float,
    shape: Sequence[int],
    samples_per_pixel: int = 10,
    center_samples_per_pixel: int = 100,
    center_radius_px: float = 4.0,
    max_spacing_deg: float | None = None,
    breakpoints: tuple[float, ...] = (),
    support_deg: float | None = None,
    symmetric: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`digitise_radial` returning the quadrants ``(C, KH//2 + 1, KW//2 + 1)`` of
    offsets ``i, j >= 0`` (unfold them with :func:`mirror_quadrant`).

    Parameters
    ----------
    profiles, pixel_deg, shape, samples_per_pixel, center_samples_per_pixel
        As for :func:`digitise_radial`.
    center_radius_px, max_spacing_deg, breakpoints, support_deg, symmetric
        As for :func:`digitise_radial`.

    Returns
    -------
    quadrant : numpy.ndarray
        ``(C, KH//2 + 1, KW//2 + 1)`` pixel energies at offsets ``i, j >= 0``.
    inside, total, quadrature_error : numpy.ndarray
        As for :func:`digitise_radial`.
    """
    pixel_deg = check_pixel_deg(pixel_deg)
    height, width = check_kernel_shape(shape)
    samples_per_pixel = check_positive_int("samples_per_pixel", samples_per_pixel)
    center_samples_per_pixel = check_positive_int(
        "center_samples_per_pixel", center_samples_per_pixel
    )
    center_radius_px = check_positive("center_radius_px", center_radius_px, unit="px")
    half_h, half_w = height // 2, width // 2
    n_profiles = len(profiles)
    sample_options = {
        "samples_per_pixel": samples_per_pixel,
        "center_samples": center_samples_per_pixel,
        "center_radius_px": center_radius_px,
        "max_spacing_deg": max_spacing_deg,
    }
    active_deg = None if support_deg is None else support_deg + 1.5 * pixel_deg
    quadrature = _quadrature_symmetric if symmetric else _quadrature_exact
    quadrant = quadrature(profiles, half_h, half_w, pixel_deg, active_deg, sample_options)

    inside = np.empty(n_profiles)
    total = np.empty(n_profiles)
    quadrature_error = np.empty(n_profiles)
    for c, profile in enumerate(profiles):
        total[c] = radial_mass(profile, np.array([90.0]), breakpoints=breakpoints)[0]
        inside[c] = rectangle_mass(
            profile,
            (half_w + 0.5) * pixel_deg,
            (half_h + 0.5) * pixel_deg,
            breakpoints=breakpoints,
        )
        center = rectangle_mass(profile, 0.5 * pixel_deg, 0.5 * pixel_deg, breakpoints=breakpoints)
        quadrant[c, 0, 0] = 0.0
        off_center_quadrature = float(quadrant_sum(quadrant[c]))
        off_center_exact = inside[c] - center
        if off_center_quadrature > 0:
            scale = off_center_exact / off_center_quadrature
            quadrant[c] *= scale
            quadrature_error[c] = scale - 1.0
        else:
            quadrature_error[c] = 0.0 if off_center_exact <= 0 else 1.0
        quadrant[c, 0, 0] = center
    return quadrant, inside, total, quadrature_error
