"""Linear convolution of the excess with a kernel, restricted to the bright pixels' box."""

from __future__ import annotations

import numpy as np
import scipy.fft
from scipy.signal import convolve, fftconvolve

__all__ = [
    "FFT_WORKERS",
    "FLOAT32_NOISE_LIMIT_CD_M2",
    "bounding_box",
    "convolution_dtype",
    "spread",
]

FFT_WORKERS = -1  # scipy.fft threads for the convolutions: all cores

FLOAT32_NOISE_LIMIT_CD_M2 = 1e-3  # largest FFT round-off the float32 path may add anywhere


def convolution_dtype(excess: np.ndarray, kernel: np.ndarray, requested: np.dtype) -> np.dtype:
    """float32 unless its FFT round-off could exceed FLOAT32_NOISE_LIMIT_CD_M2.

    FFT round-off is about machine epsilon times the largest values in the transform, and it
    lands everywhere, including the dark parts of the image. The spread's largest value is at
    most ``Σ ΔL × max K``; next to the sun (Spencer Fig. 16: 7.5e8 cd/m²) float32 would add
    ±2 cd/m² of noise to dark pixels, so such scenes are convolved in float64.
    """
    if requested == np.float64:
        return np.dtype(np.float64)
    bound = float(excess.sum(dtype=np.float64)) * float(kernel.max()) * np.finfo(np.float32).eps
    return np.dtype(np.float64 if bound > FLOAT32_NOISE_LIMIT_CD_M2 else np.float32)


def bounding_box(mask: np.ndarray) -> tuple[slice, slice]:
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def spread(
    excess: np.ndarray,
    kernel: np.ndarray,
    box: tuple[slice, slice],
    *,
    into: np.ndarray | None = None,
    method: str = "fft",
) -> np.ndarray:
    """Linear convolution of ``excess`` (zero outside ``box``) with a centred odd kernel,
    cropped to the image. Only the bounding box of the bright pixels is transformed: exact,
    and far cheaper than the whole image when the bright region is small. With ``into``, the
    result is added to that image-sized array (only where it is non-zero) and returned.
    ``method='direct'`` sums the products instead (for comparison: exact, far slower)."""
    height, width = excess.shape
    rows, cols = box
    if method == "fft":
        with scipy.fft.set_workers(FFT_WORKERS):  # every core: a scope, not global state
            full = fftconvolve(excess[rows, cols], kernel, mode="full")
    elif method == "direct":
        full = convolve(excess[rows, cols], kernel, mode="full", method="direct")
    else:
        raise ValueError(f"method must be 'fft' or 'direct'; got {method!r}")
    kh, kw = kernel.shape
    # full[a, b] is the response at image pixel (a + rows.start - kh//2, b + cols.start - kw//2)
    top, left = rows.start - kh // 2, cols.start - kw // 2
    out = np.zeros((height, width), dtype=full.dtype) if into is None else into
    src_r0, src_c0 = max(0, -top), max(0, -left)
    dst_r0, dst_c0 = max(0, top), max(0, left)
    n_rows = min(full.shape[0] - src_r0, height - dst_r0)
    n_cols = min(full.shape[1] - src_c0, width - dst_c0)
    if n_rows > 0 and n_cols > 0:
        out[dst_r0 : dst_r0 + n_rows, dst_c0 : dst_c0 + n_cols] += full[
            src_r0 : src_r0 + n_rows, src_c0 : src_c0 + n_cols
        ]
    return out
