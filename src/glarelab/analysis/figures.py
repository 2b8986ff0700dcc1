"""Figures of the analyses: PNG bytes (matplotlib, Agg) with the title and caption a report
prints under them, and the same figure as PDF and SVG for print.

Every text of a figure is at least :data:`MIN_PRINTED_PT` points when the figure is printed
:data:`PRINT_WIDTH_IN` wide (a page's text width): a figure drawn wider is printed smaller, so
its fonts are enlarged by the ratio before it is saved."""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from dataclasses import dataclass

import matplotlib
import matplotlib.figure

__all__ = [
    "MIN_PRINTED_PT",
    "PRINT_WIDTH_IN",
    "Figure",
    "Rendered",
    "as_figure",
    "png",
    "small_multiples",
    "subplots",
]

PRINT_WIDTH_IN = 6.5  # a page's text width (US Letter and A4 with 1-inch margins)
SVG_HASH_SALT = "glarelab"  # the seed of the ids in a figure's SVG (matplotlib's svg.hashsalt)
MIN_PRINTED_PT = 8.0  # the smallest text a journal accepts in a printed figure (APA 7: 8-14 pt)


class Rendered(bytes):
    """A figure's PNG bytes, with the same figure as ``pdf`` and ``svg`` bytes (vector, for
    print)."""

    pdf: bytes
    svg: bytes


def printed_scale(figure) -> float:
    """How much smaller the figure is printed than drawn: 1 up to :data:`PRINT_WIDTH_IN`."""
    return min(1.0, PRINT_WIDTH_IN / figure.get_figwidth())


def legible(figure) -> None:
    """Enlarge every text of ``figure`` that would print below :data:`MIN_PRINTED_PT` at
    :data:`PRINT_WIDTH_IN` wide (tick labels, legends, annotations, titles).

    >>> figure, axis = subplots(figsize=(13, 3))
    >>> _ = axis.set_xlabel("level", fontsize=6)
    >>> legible(figure)
    >>> float(axis.xaxis.label.get_fontsize() * printed_scale(figure))
    8.0
    """
    from matplotlib.text import Text

    smallest = MIN_PRINTED_PT / printed_scale(figure)
    for text in figure.findobj(Text):
        if text.get_text() and text.get_fontsize() < smallest:
            text.set_fontsize(smallest)
    for axis in figure.axes:  # tick labels get their text on drawing: size them by the axis
        for which in (axis.xaxis, axis.yaxis):
            ticks = which.get_major_ticks() + which.get_minor_ticks()
            if any(tick.label1.get_fontsize() < smallest for tick in ticks):
                which.set_tick_params(which="both", labelsize=smallest)


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
    if isinstance(item, Rendered):
        return Figure(item, name)
    if isinstance(item, bytes | bytearray):
        return Figure(bytes(item), name)
    if isinstance(item, Mapping) and isinstance(item.get("png"), bytes | bytearray):
        return Figure(bytes(item["png"]), str(item.get("title", name)), item.get("caption", ""))
    raise TypeError(
        f"a report figure must be a Figure, a mapping with png (bytes), title and caption, or "
        f"PNG bytes; got {type(item).__name__} for {name!r}"
    )


def png(figure) -> Rendered:
    """The figure as PNG bytes (no timestamps) with its PDF and SVG, legible in print
    (:func:`legible`), closed afterwards.

    Parameters
    ----------
    figure
        A matplotlib figure.

    Returns
    -------
    Rendered
        The PNG file's content (at 110 dpi), with the same figure as PDF and SVG in its
        ``pdf`` and ``svg`` attributes.
    """
    legible(figure)
    figure.tight_layout()
    saved = {}
    # bbox "tight": a legend placed below the axes is kept whole
    for kind, metadata in (
        ("png", {"Software": None}),
        ("pdf", {"Creator": None, "Producer": None, "CreationDate": None}),
        ("svg", {"Creator": None, "Date": None}),
    ):
        buffer = io.BytesIO()
        # a fixed salt: the SVG's clip-path ids are the same each time (random otherwise)
        with matplotlib.rc_context({"svg.hashsalt": SVG_HASH_SALT}):
            figure.savefig(buffer, format=kind, dpi=110, metadata=metadata, bbox_inches="tight")
        saved[kind] = buffer.getvalue()
    rendered = Rendered(saved["png"])
    rendered.pdf, rendered.svg = saved["pdf"], saved["svg"]
    return rendered


def subplots(
    rows: int = 1,
    columns: int = 1,
    *,
    figsize: tuple[float, float],
    dpi: float | None = None,
    facecolor: str | None = None,
    **options,
):
    """A new figure and its axes, as ``matplotlib.pyplot.subplots`` makes them, without pyplot:
    no backend is chosen and no figure is kept open, so a user's interactive backend (a
    notebook's, a GUI's) and figures are left as they were.

    Parameters
    ----------
    rows, columns
        The grid of axes; default one axis.
    figsize
        The figure's width and height, inches.
    dpi, facecolor
        As for :class:`matplotlib.figure.Figure`; default matplotlib's settings.
    **options
        To :meth:`matplotlib.figure.Figure.subplots` (``sharex``, ``squeeze``, ...).

    Returns
    -------
    figure : matplotlib.figure.Figure
        The figure (saved with its ``savefig``; nothing to close).
    axes : matplotlib.axes.Axes or numpy.ndarray
        Its axes, as ``pyplot.subplots`` returns them.

    Examples
    --------
    >>> figure, axes = subplots(1, 2, figsize=(4, 2), squeeze=False)
    >>> axes.shape
    (1, 2)
    """
    figure = matplotlib.figure.Figure(figsize=figsize, dpi=dpi, facecolor=facecolor)
    return figure, figure.subplots(rows, columns, **options)


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
    figure, axes = subplots(
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
