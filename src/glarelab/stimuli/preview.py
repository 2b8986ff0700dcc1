"""Previews: what a linear luminance image looks like on a display, as an 8-bit PNG."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from PIL import Image

from glarelab.files.atomic import atomic_path
from glarelab.glare._colour import colour
from glarelab.glare.models.wave import sigmoid_Kakimoto2004

__all__ = ["preview_png", "psf_png", "psf_to_display", "to_display"]


def to_display(
    luminance_cd_m2: np.ndarray,
    *,
    l_dmax_cd_m2: float,
    scale: Literal["display", "log"] = "display",
    decades: float = 4.0,
) -> np.ndarray:
    """Encode linear luminance as 8-bit sRGB for viewing.

    Parameters
    ----------
    luminance_cd_m2
        ``(H, W)`` or ``(H, W, 3)`` linear image in cd/m².
    l_dmax_cd_m2
        Luminance shown as white, cd/m².
    scale
        ``'display'``: what the display shows (clipped at ``l_dmax``, sRGB-encoded).
        ``'log'``: ``decades`` decades below ``l_dmax`` mapped linearly in log luminance, to
        see faint glare such as the lenticular halo.
    decades
        Range of the log scale in decades; default 4.

    Returns
    -------
    numpy.ndarray
        uint8 image, ``(H, W)`` or ``(H, W, 3)``.
    """
    relative = np.asarray(luminance_cd_m2, dtype=np.float64) / float(l_dmax_cd_m2)
    if scale == "display":
        encoded = colour.cctf_encoding(np.clip(relative, 0.0, 1.0), function="sRGB")
    elif scale == "log":
        floor = 10.0**-decades
        encoded = (np.log10(np.clip(relative, floor, 1.0)) + decades) / decades
    else:
        raise ValueError(f"scale must be one of 'display', 'log'; got {scale!r}")
    return np.round(np.clip(encoded, 0.0, 1.0) * 255.0).astype(np.uint8)


def preview_png(
    path: str | Path,
    luminance_cd_m2: np.ndarray,
    *,
    l_dmax_cd_m2: float,
    scale: Literal["display", "log"] = "display",
) -> Path:
    """Write :func:`to_display` of an image to a PNG file and return its path.

    Parameters
    ----------
    path
        The PNG file, written whole or not at all; its folder is created.
    luminance_cd_m2
        ``(H, W)`` or ``(H, W, 3)`` linear image in cd/m².
    l_dmax_cd_m2
        Luminance shown as white, cd/m².
    scale
        ``'display'`` (default) or ``'log'``, as for :func:`to_display`.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pixels = to_display(luminance_cd_m2, l_dmax_cd_m2=l_dmax_cd_m2, scale=scale)
    with atomic_path(path) as temporary:
        Image.fromarray(pixels).save(temporary, format="PNG")
    return path


def psf_to_display(
    values: np.ndarray, *, dynamic_range: float = 1e6, peak: float | None = None
) -> np.ndarray:
    """A glare kernel as 8-bit codes through Kakimoto's sigmoid (eqs. 6-7).

    The kernel is scaled so that ``peak`` (default: its own peak) is ``dynamic_range`` (the
    bright centre is clipped, as Kakimoto §3.3 does) and 1 is ``dynamic_range`` below it; the
    sigmoid's output (1.6 to 640) is shown as codes 0-255, clipped. Each channel of a colour
    kernel is mapped with the same scale; give several kernels one ``peak`` to compare their
    intensities.

    Parameters
    ----------
    values
        The kernel (any unit: only ratios to ``peak`` count), ``(H, W)`` or ``(H, W, 3)``;
        negative values are taken as 0.
    dynamic_range
        The ratio shown between ``peak`` and 1 on the sigmoid's input; default 1e6.
    peak
        The value mapped to ``dynamic_range``; default ``None``: the kernel's maximum.

    Returns
    -------
    numpy.ndarray
        uint8, the shape of ``values``.
    """
    array = np.asarray(values, dtype=float)
    if peak is None:
        peak = float(array.max())
    x = np.clip(array, 0.0, None) / (peak if peak > 0 else 1.0) * dynamic_range
    return np.round(np.clip(sigmoid_Kakimoto2004(x), 0.0, 255.0)).astype(np.uint8)


def psf_png(
    path: str | Path,
    values: np.ndarray,
    *,
    dynamic_range: float = 1e6,
    peak: float | None = None,
) -> Path:
    """Write :func:`psf_to_display` of a kernel to a PNG file and return its path.

    Parameters
    ----------
    path
        The PNG file, written whole or not at all; its folder is created.
    values, dynamic_range, peak
        As for :func:`psf_to_display`.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pixels = psf_to_display(values, dynamic_range=dynamic_range, peak=peak)
    with atomic_path(path) as temporary:
        Image.fromarray(pixels).save(temporary, format="PNG")
    return path
