"""The peers the renderer is timed against: what a user could write with scipy and OpenCV,
each given the kernel already digitised.

- :func:`spectrum_peer`: ``irfft2(rfft2(ΔL) · K̂)`` with the kernel's spectrum made once
  (float64 or float32), the best a user could write with ``scipy.fft``;
- :func:`fftconvolve_peer`: ``scipy.signal.fftconvolve`` of the whole excess with the full
  kernel;
- :func:`floor_peer`: one forward and one inverse real FFT of the excess at the peers' padded
  lengths in float32 and nothing else, the least any whole-image FFT method pays (it returns
  the clamped image, without glare);
- :func:`gaussian_peers`: for the Gaussian, ``scipy.ndimage.gaussian_filter`` and OpenCV's
  ``GaussianBlur`` (when ``cv2`` is installed), each truncated at 4-6 σ.

Each returns a function of no arguments that renders the image (Yoshida's clamp at
:data:`~glarelab.bench.scenes.L_DMAX`). The FFT peers run their transforms with the
renderer's threads (:func:`~glarelab.glare.rendering._convolve.fft_workers`: one thread on
small grids, where starting threads costs more than they save, every core on large ones).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import scipy.fft

from glarelab.bench.scenes import L_DMAX
from glarelab.glare.rendering._convolve import fft_workers

__all__ = [
    "FLOOR",
    "GAUSSIAN_PEER_TRUNCATE",
    "PEER",
    "PEER_SPECTRUM",
    "PEER_SPECTRUM_32",
    "fftconvolve_peer",
    "floor_peer",
    "gaussian_peers",
    "spectrum_peer",
]

PEER = "peer: scipy fftconvolve, whole image, full kernel"
PEER_SPECTRUM = "peer: rfft2 with precomputed kernel spectrum, float64"
PEER_SPECTRUM_32 = "peer: rfft2 with precomputed kernel spectrum, float32"
FLOOR = "floor: one padded rfft2 and irfft2, float32 (no glare computed)"
GAUSSIAN_PEER_TRUNCATE = (4.0, 5.0, 6.0)  # 4 σ is both libraries' default


def spectrum_peer(image, kernel, dtype) -> Callable[[], np.ndarray]:
    """The peer a user could write: the kernel's spectrum computed once, then per image
    ``irfft2(rfft2(ΔL padded to next_fast_len) · K̂)``, every channel at once.

    Parameters
    ----------
    image
        The workload, luminance, cd/m², ``(H, W)`` or ``(H, W, 3)``.
    kernel
        The full kernel ``(2H - 1, 2W - 1[, C])``, centred.
    dtype
        The numpy float type computed in (``np.float32`` or ``np.float64``).

    Returns
    -------
    callable
        ``peer()``: the image with Yoshida's clamped glare (:data:`L_DMAX`), cd/m².
    """
    height, width = image.shape[:2]
    lengths = tuple(scipy.fft.next_fast_len(2 * n - 1, real=True) for n in (height, width))
    placed = np.zeros(lengths + kernel.shape[2:], dtype=dtype)
    placed[: 2 * height - 1, : 2 * width - 1] = kernel
    placed = np.roll(placed, (1 - height, 1 - width), axis=(0, 1))
    workers = fft_workers(lengths)
    with scipy.fft.set_workers(workers):
        spectrum = scipy.fft.rfft2(placed, axes=(0, 1))
    if image.ndim == 3 and kernel.ndim == 2:
        spectrum = spectrum[..., None]
    work = image.astype(dtype)

    def peer():
        with scipy.fft.set_workers(workers):
            excess = np.maximum(work - dtype(L_DMAX), dtype(0))
            transformed = scipy.fft.rfft2(excess, s=lengths, axes=(0, 1)) * spectrum
            spread = scipy.fft.irfft2(transformed, s=lengths, axes=(0, 1))[:height, :width]
        return np.minimum(work + spread, dtype(L_DMAX))

    return peer


def floor_peer(image) -> Callable[[], np.ndarray]:
    """One padded ``rfft2`` and ``irfft2`` of the excess in float32, every channel at once:
    the floor of a whole-image FFT render. Returns the clamped image (no glare).

    Parameters
    ----------
    image
        The workload, luminance, cd/m², ``(H, W)`` or ``(H, W, 3)``; each axis is padded to
        a fast FFT length >= ``2 n - 1``.

    Returns
    -------
    callable
        ``peer()``: the image clamped at :data:`L_DMAX`, cd/m², float32, after the
        transforms a glare render cannot do without (their result is thrown away).
    """
    height, width = image.shape[:2]
    lengths = tuple(scipy.fft.next_fast_len(2 * n - 1, real=True) for n in (height, width))
    work = image.astype(np.float32)
    workers = fft_workers(lengths)

    def peer():
        with scipy.fft.set_workers(workers):
            excess = np.maximum(work - np.float32(L_DMAX), np.float32(0))
            transformed = scipy.fft.rfft2(excess, s=lengths, axes=(0, 1))
            scipy.fft.irfft2(transformed, s=lengths, axes=(0, 1))
        return np.minimum(work, np.float32(L_DMAX))

    return peer


def fftconvolve_peer(image, kernel) -> Callable[[], np.ndarray]:
    """``scipy.signal.fftconvolve`` of the whole excess image with the full kernel.

    Parameters
    ----------
    image
        The workload, luminance, cd/m², ``(H, W)`` or ``(H, W, 3)``.
    kernel
        The full kernel, centred, ``(KH, KW[, C])``.

    Returns
    -------
    callable
        ``peer()``: the image with Yoshida's clamped glare (:data:`L_DMAX`), cd/m².
    """

    from scipy.signal import fftconvolve

    padded = (image.shape[0] + kernel.shape[0] - 1, image.shape[1] + kernel.shape[1] - 1)
    workers = fft_workers(padded)

    def peer():
        excess = np.maximum(image - L_DMAX, 0.0)
        with scipy.fft.set_workers(workers):
            if image.ndim == 3:
                k = kernel if kernel.ndim == 3 else kernel[..., None]
                spread = fftconvolve(excess, k, mode="same", axes=(0, 1))
            else:
                spread = fftconvolve(excess, kernel, mode="same")
        return np.minimum(image + spread, L_DMAX)

    return peer


def gaussian_peers(image, pixel, model) -> dict[str, Callable[[], np.ndarray]]:
    """What a user could write for the Gaussian model: library Gaussian filters of the excess,
    clamped at :data:`L_DMAX`.

    Parameters
    ----------
    image
        The workload, luminance, cd/m², ``(H, W)`` or ``(H, W, 3)``.
    pixel
        Visual angle of one pixel, degrees.
    model
        The Gaussian model whose ``sigma_deg`` the filters use.

    Returns
    -------
    dict of str to callable
        Name → ``peer()``: SciPy's ``gaussian_filter`` and, where OpenCV is installed, its
        ``GaussianBlur``, at each truncation of :data:`GAUSSIAN_PEER_TRUNCATE`.
    """
    from scipy.ndimage import gaussian_filter

    sigma_px = model.sigma_deg / pixel

    def excess():
        return np.maximum(image - L_DMAX, 0.0)

    def scipy_filter(truncate):
        return lambda: np.minimum(
            image + gaussian_filter(excess(), sigma_px, mode="constant", truncate=truncate),
            L_DMAX,
        )

    def opencv_blur(truncate):
        size = 2 * math.ceil(truncate * sigma_px) + 1
        return lambda: np.minimum(
            image
            + cv2.GaussianBlur(excess(), (size, size), sigma_px, borderType=cv2.BORDER_CONSTANT),
            L_DMAX,
        )

    try:
        import cv2
    except ImportError:  # OpenCV is not a dependency; measured where it is installed
        cv2 = None
    peers = {}
    for truncate in GAUSSIAN_PEER_TRUNCATE:
        peers[f"peer: scipy gaussian_filter ({truncate:g} σ)"] = scipy_filter(truncate)
        if cv2 is not None:
            peers[f"peer: OpenCV GaussianBlur ({truncate:g} σ)"] = opencv_blur(truncate)
    return peers
