"""What the plan reads from one image: :class:`Scene`.

The pixels above ``L_dmax`` (their bounding box and their excess ``ΔL``, Yoshida 2008 eq. 1,
kept only within that box), the pixels that can still change (under Yoshida's clamp, those
below ``L_dmax``), the brightest and total excess, and the darkest pixel.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from glarelab.glare.rendering._convolve import clusters, line_sums
from glarelab.glare.rendering.compose import excess as excess_of
from glarelab.glare.rendering.compose import over_channels
from glarelab.glare.rendering.multires import grid_shape, splat

__all__ = ["Scene"]


@dataclass(frozen=True)
class Scene:
    """What the plan reads from one image (in the render's dtype).

    ``planes`` is ``(H, W, C)``; ``excess`` is ``ΔL`` within ``source_box`` only,
    ``(rows, cols, C)``; boxes are ``(row0, row1, col0, col1)``.

    Attributes
    ----------
    planes
        The image, cd/m², ``(H, W, C)`` (``C = 1`` for luminance).
    colour
        Whether the image is RGB.
    source_box
        The smallest box holding every pixel above ``L_dmax``; None when none is.
    target_box
        The box of the pixels glare may change: below ``L_dmax`` for Yoshida's clamp, the
        whole image for Spencer's sum; None when none is below.
    excess
        ``ΔL`` within ``source_box``, cd/m²; None without a source.
    bright_pixels
        Pixels above ``L_dmax`` in any channel.
    target_pixels
        Pixels glare may change.
    max_excess
        The largest ``ΔL``, cd/m².
    total_excess
        ``Σ ΔL`` of the brightest channel, cd/m² × pixels.
    darkest
        The smallest value of the image, cd/m².
    achromatic
        Whether an RGB image has R = G = B everywhere.
    """

    planes: np.ndarray
    colour: bool
    source_box: tuple[int, int, int, int] | None
    target_box: tuple[int, int, int, int] | None
    excess: np.ndarray | None
    bright_pixels: int
    target_pixels: int
    max_excess: float
    total_excess: float
    darkest: float
    achromatic: bool
    _splats: dict = field(default_factory=dict, repr=False, compare=False)

    def clusters(self) -> list[tuple[tuple[slice, slice], np.ndarray]]:
        """The connected groups of bright pixels in the source box (made once)."""
        if "clusters" not in self._splats:
            self._splats["clusters"] = clusters(over_channels(self.excess > 0, np.logical_or))
        return self._splats["clusters"]

    def excess_norms(self) -> tuple[float, float]:
        """``ΣΔL`` and ``(ΣΔL²)^½``, cd/m², the largest over the channels (found once)."""
        if "norms" not in self._splats:
            flat = self.excess.reshape(-1, self.excess.shape[2])
            flat = flat.astype(np.float64, copy=False)
            l2 = float(np.sqrt(np.einsum("ij,ij->j", flat, flat).max()))
            self._splats["norms"] = (self.total_excess, l2)  # ΣΔL: found with the scene
        return self._splats["norms"]

    def line_norms(self) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        """``(ΣΔL, ΣΔL²)`` of each row and of each column of the source box, cd/m² and
        (cd/m²)², of the brightest channel of each pixel (:meth:`brightest_excess`: at least
        each channel's; made once)."""
        if "lines" not in self._splats:
            rows_l1, rows_l2, cols_l1, cols_l2 = line_sums(self.brightest_excess(), absolute=False)
            self._splats["lines"] = ((rows_l1, rows_l2), (cols_l1, cols_l2))
        return self._splats["lines"]

    def brightest_excess(self) -> np.ndarray:
        """The largest excess of each pixel of the source box over the channels, cd/m²
        (made once; a view for one channel)."""
        if "brightest" not in self._splats:
            self._splats["brightest"] = over_channels(self.excess, np.maximum)
        return self._splats["brightest"]

    def darkest_plane(self) -> np.ndarray:
        """The smallest channel of each pixel, cd/m², ``(H, W)`` (made once; a view for one
        channel)."""
        if "darkest" not in self._splats:
            self._splats["darkest"] = over_channels(self.planes, np.minimum)
        return self._splats["darkest"]

    def splat(self, factor: int, channel: int | None) -> np.ndarray:
        """The excess of one channel (``None``: the brightest channel of each pixel) splatted
        onto the coarse grid of ``factor`` (:func:`glarelab.glare.rendering.multires.splat`), made
        once.

        Parameters
        ----------
        factor
            Pixels per coarse node ``f``.
        channel
            The channel's index; None: the largest excess of each pixel over the channels.

        Returns
        -------
        numpy.ndarray
            The excess on the coarse grid, cd/m², float64.
        """
        if self.excess.shape[2] == 1:
            channel = 0
        key = (factor, channel)
        if key not in self._splats:
            excess = self.brightest_excess() if channel is None else self.excess[..., channel]
            self._splats[key] = splat(
                excess.astype(np.float64, copy=False),
                factor,
                self.source_box,
                grid_shape(self.planes.shape[:2], factor),
            )
        return self._splats[key]

    @classmethod
    def of(cls, image: np.ndarray, l_dmax: float, method: str, dtype) -> Scene:
        """The scene of ``image``: its planes, its excess over ``L_dmax`` and their boxes.

        Parameters
        ----------
        image
            Linear luminance, cd/m², ``(H, W)`` or ``(H, W, 3)``.
        l_dmax
            The display's maximum ``L_dmax``, cd/m².
        method
            The composition, ``'Yoshida2008'`` or ``'Spencer1995'`` (which pixels are targets).
        dtype
            The render's dtype (float64 or float32), which ``planes`` are converted to.

        Returns
        -------
        Scene
            The scene.
        """
        colour = image.ndim == 3
        planes = (image if colour else image[..., None]).astype(dtype, copy=False)
        bright = planes > l_dmax
        bright = over_channels(bright, np.logical_or)
        source = _box(bright)
        if method == "Yoshida2008":
            targets = planes < l_dmax
            targets = over_channels(targets, np.logical_or)
            target_box, n_targets = _box(targets), int(np.count_nonzero(targets))
        else:
            target_box, n_targets = (0, planes.shape[0], 0, planes.shape[1]), bright.size
        excess = None
        if source is not None:
            r0, r1, c0, c1 = source
            box = planes[r0:r1, c0:c1]
            excess = excess_of(box, l_dmax)
        achromatic = colour and bool(
            np.array_equal(image[..., 0], image[..., 1])
            and np.array_equal(image[..., 0], image[..., 2])
        )
        return cls(
            planes=planes,
            colour=colour,
            source_box=source,
            target_box=target_box,
            excess=excess,
            bright_pixels=int(np.count_nonzero(bright)) if source is not None else 0,
            target_pixels=n_targets,
            max_excess=float(excess.max()) if excess is not None else 0.0,
            total_excess=_channel_sums(excess) if excess is not None else 0.0,
            darkest=float(planes.min()),
            achromatic=achromatic,
        )


def _channel_sums(excess: np.ndarray) -> float:
    """The largest over the channels of ``ΣΔL``, in float64 (``einsum`` for interleaved
    channels: ``sum(axis=(0, 1))`` over ``(H, W, 3)`` is several times slower)."""
    if excess.shape[2] == 1:
        return float(excess.sum(dtype=np.float64))
    return float(np.einsum("ijc->c", excess, dtype=np.float64).max())


def _box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
