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
    """

    png: bytes
    title: str
    caption: str = ""


def as_figure(item, name: str = "") -> Figure:
    """A :class:`Figure` from a Figure, a mapping with ``png``, ``title`` and ``caption``, or
    bare PNG bytes (titled ``name``).

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
    """The figure as PNG bytes (no timestamps), closed afterwards."""
    buffer = io.BytesIO()
    figure.tight_layout()
    # bbox "tight": a legend placed below the axes is kept whole
    figure.savefig(buffer, format="png", dpi=110, metadata={"Software": None}, bbox_inches="tight")
    plt.close(figure)
    return buffer.getvalue()


def small_multiples(panels: int, *, width_in: float = 2.3, height_in: float = 2.0, columns=5):
    """A figure with one small panel per participant (shared axes) and the axes as a flat list;
    panels beyond ``panels`` are hidden."""
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
