"""Previews: what a linear luminance image looks like on a display, as an 8-bit PNG."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Literal

import numpy as np
from PIL import Image

from glarelab.files.atomic import atomic_path
from glarelab.glare._colour import colour
from glarelab.glare._validation import check_choice, check_image, check_in_range, check_positive
from glarelab.glare.models.wave import sigmoid_Kakimoto2004

__all__ = ["preview_png", "psf_png", "psf_to_display", "to_display"]

DEFAULT_DECADES = 4.0  # decades below white the log preview shows
MAX_DECADES = 20.0  # beyond, every float64 luminance ratio of an image fits


def _write_png(path: str | Path, encode: Callable[[], np.ndarray]) -> Path:
    """Create ``path``'s folder, then write the 8-bit image ``encode()`` returns to ``path``
    whole or not at all; return ``path``."""
    path = Path(path)
    if path.suffix.lower() != ".png":  # PNG bytes under another name would mislead a viewer
        raise ValueError(f"path must name a .png file; got {str(path)!r}")
    pixels = encode()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:
        Image.fromarray(pixels).save(temporary, format="PNG")
    return path


def to_display(
    luminance_cd_m2: np.ndarray,
    *,
    l_dmax_cd_m2: float,
    scale: Literal["display", "log"] = "display",
    decades: float = DEFAULT_DECADES,
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

    Raises
    ------
    ValueError
        For an image that is not finite, non-negative numbers of those shapes, a white that
        is not positive, decades outside (0, 20], or decades given with ``scale='display'``
        (which would ignore them).

    Examples
    --------
    >>> to_display(np.array([[0.0, 50.0, 100.0, 400.0]]), l_dmax_cd_m2=100.0).tolist()
    [[0, 188, 255, 255]]
    """
    image = check_image("luminance_cd_m2", luminance_cd_m2, channels=(3,))
    l_dmax = check_positive("l_dmax_cd_m2", l_dmax_cd_m2, unit="cd/m²")
    check_choice("scale", scale, ("display", "log"))
    decades = check_in_range("decades", decades, 0.0, MAX_DECADES, low_inclusive=False)
    if scale == "display" and decades != DEFAULT_DECADES:
        raise ValueError(
            f"decades = {decades:g} is used only with scale='log'; with 'display' it would "
            "be ignored"
        )
    relative = image.astype(np.float64) / l_dmax
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
    return _write_png(
        path, lambda: to_display(luminance_cd_m2, l_dmax_cd_m2=l_dmax_cd_m2, scale=scale)
    )


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

    Raises
    ------
    ValueError
        For values that are not finite numbers of those shapes, a dynamic range that is not
        a finite number > 0, or a peak that is not a finite number > 0.
    """
    if isinstance(values, str | bytes) or values is None:
        raise ValueError(f"values must be an (H, W) or (H, W, 3) kernel; got {values!r}")
    array = np.asarray(values)
    # negative values are allowed (taken as 0): the kernel's sign is checked as its magnitude
    check_image("values", np.abs(array) if array.dtype.kind in "iuf" else array, channels=(3,))
    array = array.astype(float)
    dynamic_range = check_positive("dynamic_range", dynamic_range)
    if peak is None:
        peak = float(array.max())
    else:
        peak = check_positive("peak", peak)
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
    return _write_png(path, lambda: psf_to_display(values, dynamic_range=dynamic_range, peak=peak))


def psf_figure(
    path: str | Path,
    values: np.ndarray,
    *,
    pixel_deg: float,
    title: str = "",
    dynamic_range: float = 1e6,
    peak: float | None = None,
) -> Path:
    """Write a kernel's :func:`psf_to_display` image as a figure with its axes in degrees of
    visual angle and a scale of its intensity relative to ``peak`` (ticks at each decade the
    sigmoid maps), as PNG (and PDF beside it) for print.

    Parameters
    ----------
    path
        The PNG to write (``.png``); the PDF gets the same name with ``.pdf``.
    values
        The kernel, (n, n) or (n, n, 3).
    pixel_deg
        Visual angle of a kernel pixel, degrees.
    title
        The figure's title.
    dynamic_range, peak
        As :func:`psf_to_display`.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        For a ``pixel_deg`` that is not a positive number.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> y, x = np.mgrid[-8:9, -8:9]
    >>> psf_figure(folder / "k.png", np.exp(-(x**2 + y**2) / 4.0), pixel_deg=0.01).name
    'k.png'
    >>> sorted(p.suffix for p in folder.iterdir())
    ['.pdf', '.png']
    """
    import matplotlib
    from matplotlib.figure import Figure

    if not (isinstance(pixel_deg, int | float) and np.isfinite(pixel_deg) and pixel_deg > 0):
        raise ValueError(f"pixel_deg must be a positive number of degrees; got {pixel_deg!r}")
    array = np.asarray(values, dtype=float)
    pixels = psf_to_display(array, dynamic_range=dynamic_range, peak=peak)
    size = array.shape[0]
    half = size * pixel_deg / 2
    figure = Figure(figsize=(4.8, 3.6))
    axis = figure.subplots()
    axis.imshow(
        pixels,
        cmap="gray",
        vmin=0,
        vmax=255,
        extent=(-half, half, -half, half),
        interpolation="none",
    )
    axis.set_xlabel("horizontal angle (deg)", fontsize=9)
    axis.set_ylabel("vertical angle (deg)", fontsize=9)
    axis.tick_params(labelsize=8)
    if title:
        axis.set_title(title, fontsize=9)
    # the scale: the code each decade below the peak is shown with (the sigmoid of
    # 10^decade × dynamic_range), labelled by its intensity relative to the peak; from the
    # intensity the sigmoid maps to 255 on, the bright centre is clipped (Kakimoto §3.3)
    decades = np.arange(-round(np.log10(dynamic_range)), 1)
    codes = sigmoid_Kakimoto2004(10.0**decades * dynamic_range)
    fine = np.logspace(-np.log10(dynamic_range), 0, 2001)
    white = fine[np.argmax(sigmoid_Kakimoto2004(fine * dynamic_range) >= 254.5)]
    kept = codes < 254.5 - 8  # a decade tick clear of the clipping tick
    ticks = [*codes[kept], 255.0]
    labels = [f"$10^{{{d}}}$" for d in decades[kept]] + [f"≥{white:.1e}"]
    scale = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, 255), cmap="gray")
    bar = figure.colorbar(scale, ax=axis, ticks=ticks)
    bar.ax.set_yticklabels(labels, fontsize=8)
    bar.set_label("intensity / peak (per channel; white: clipped)", fontsize=9)
    figure.tight_layout()
    path = Path(path)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, format="png", dpi=150, metadata={"Software": None})
    with atomic_path(path.with_suffix(".pdf")) as temporary:
        figure.savefig(temporary, format="pdf", metadata={"Creator": None, "Producer": None,
                                                         "CreationDate": None})  # fmt: skip
    return path
