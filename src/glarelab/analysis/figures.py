"""Figures of the analyses: PNG bytes (matplotlib, Agg) with the title and caption a report
prints under them."""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

__all__ = ["Figure", "as_figure", "plt", "png", "small_multiples"]


@dataclass(frozen=True)
class Figure:
    """A figure of a report: PNG bytes, a title (what it shows, one phrase) and a caption
    (what is plotted: the statistic, its error bars and n, the units, the lines drawn).

    A report numbers figures in the order it shows them and prints ``Figure N. Title.
    Caption``.

    Attributes
    ----------
    png
        The image, PNG bytes.
    title
        What it shows, one phrase.
    caption
        What is plotted; default empty.
    """

    png: bytes
    title: str
    caption: str = ""


def as_figure(item, name: str = "") -> Figure:
    """A :class:`Figure` from a Figure, a mapping with ``png``, ``title`` and ``caption``, or
    bare PNG bytes (titled ``name``).

    Parameters
    ----------
    item
        A :class:`Figure`, a mapping, or PNG bytes.
    name
        The title of bare bytes, and the name in the message; default empty.

    Returns
    -------
    Figure
        The figure.

    Raises
    ------
    TypeError
        For anything else, or a mapping without ``png`` bytes.
    """
    if isinstance(item, Figure):
        return item
    if isinstance(item, bytes | bytearray):
        return Figure(bytes(item), name)
    if isinstance(item, Mapping) and isinstance(item.get("png"), bytes | bytearray):
        return Figure(bytes(item["png"]), str(item.get("title", name)), item.get("caption", ""))
    raise TypeError(
        f"a report figure must be a Figure, a mapping with png (bytes), title and caption, or "
        f"PNG bytes; got {type(item).__name__} for {name!r}"
    )


def png(figure) -> bytes:
    """The figure as PNG bytes (no timestamps), closed afterwards.

    Parameters
    ----------
    figure
        A matplotlib figure.

    Returns
    -------
    bytes
        The PNG file's content, at 110 dpi.
    """
    buffer = io.BytesIO()
    figure.tight_layout()
    # bbox "tight": a legend placed below the axes is kept whole
    figure.savefig(buffer, format="png", dpi=110, metadata={"Software": None}, bbox_inches="tight")
    plt.close(figure)
    return buffer.getvalue()


def small_multiples(panels: int, *, width_in: float = 2.3, height_in: float = 2.0, columns=5):
    """A figure with one small panel per participant (shared axes) and the axes as a flat list;
    panels beyond ``panels`` are hidden.

    Parameters
    ----------
    panels
        The number of panels, >= 1.
    width_in, height_in
        A panel's size, inches; defaults 2.3 and 2.0.
    columns
        Panels per row, at most; default 5.

    Returns
    -------
    figure : matplotlib.figure.Figure
        The figure.
    axes : list of matplotlib.axes.Axes
        The ``panels`` visible axes, row by row.
    """
    columns = max(1, min(columns, panels))
    rows = math.ceil(panels / columns)
    figure, axes = plt.subplots(
        rows,
        columns,
        figsize=(width_in * columns + 0.6, height_in * rows + 0.6),
        sharex=True,
        sharey=True,
        squeeze=False,
    )
    flat = list(axes.ravel())
    for axis in flat[panels:]:
        axis.set_visible(False)
    return figure, flat[:panels]
