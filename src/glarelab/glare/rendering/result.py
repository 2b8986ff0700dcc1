"""The result of every render: :class:`GlareResult` (the image, the plan carried out, the
error bound reached, and the energy account)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from glarelab.glare.models.digitise import Kernel
from glarelab.glare.rendering.plan import GlarePlan

__all__ = ["GlareResult", "PlannedGlare"]


@dataclass(frozen=True)
class GlareResult:
    """An image with glare, what was done to it, and its error bound.

    Attributes
    ----------
    image
        The image with glare, cd/m², the input's shape.
    plan
        The plan that was carried out (after any fallback).
    error_bound_codes
        Bound on the error against the exact render (the full kernel at full resolution),
        display codes, largest over the image; 0 for an exact path.
    far_relative_error
        Measured relative error of the multi-resolution kernel (0 when not used).
    fallback
        Why the plan was changed while rendering, or ``''``.
    kernel
        The reference kernel (full reach), when it was digitised.
    parameters
        The arguments, for logs.
    spread
        ``ΔL`` convolved with the kernel, inside the image, cd/m².
    source
        ``(values, box)``: ``ΔL`` within ``box = (row0, row1, col0, col1)``, ``(rows, cols,
        C)``, cd/m², or ``(None, None)`` for an image without excess; the energy account is
        derived from it.

    The energy account (``excess``, ``excess_energy``, ``energy_outside_kernel``,
    ``energy_outside_image``) is derived on access; the last two are ``None`` unless the
    render was exact.
    """

    image: np.ndarray
    plan: GlarePlan
    error_bound_codes: float
    far_relative_error: float
    fallback: str
    kernel: Kernel | None
    parameters: dict
    spread: np.ndarray
    source: tuple[np.ndarray | None, tuple[int, int, int, int] | None] = field(repr=False)

    @property
    def excess(self) -> np.ndarray:
        """``ΔL``: the luminance above ``L_dmax`` that was spread (Yoshida eq. 1)."""
        values, box = self.source
        out = np.zeros(self.spread.shape, dtype=self.spread.dtype)
        if box is not None:
            part = values if self.spread.ndim == 3 else values[..., 0]
            out[box[0] : box[1], box[2] : box[3]] = part
        return out

    @property
    def excess_energy(self) -> np.ndarray:
        """Sum of ``ΔL`` (cd/m² × pixels), per channel for colour images."""
        values, box = self.source
        if box is None:
            return np.zeros(3) if self.spread.ndim == 3 else np.float64(0.0)
        total = values.sum(axis=(0, 1), dtype=np.float64)
        return total if self.spread.ndim == 3 else total[0]

    @property
    def energy_outside_kernel(self) -> np.ndarray | None:
        """Part of ``excess_energy`` the PSF sends beyond the kernel's support."""
        if self.kernel is None or not self.plan.exact:
            return None
        return self.excess_energy * np.asarray(self.kernel.energy_outside)

    @property
    def energy_outside_image(self) -> np.ndarray | None:
        """Part of ``excess_energy`` the kernel sends beyond the image border."""
        if self.kernel is None or not self.plan.exact:
            return None
        kernel_sum = self.kernel.total()
        if self.spread.ndim == 3 and np.ndim(kernel_sum) == 0:
            kernel_sum = np.full(3, kernel_sum)
        elif self.spread.ndim == 2 and np.ndim(kernel_sum) == 1:
            kernel_sum = kernel_sum[0]
        return self.excess_energy * kernel_sum - self.spread.sum(axis=(0, 1), dtype=np.float64)


PlannedGlare = GlareResult  # the name of earlier versions
