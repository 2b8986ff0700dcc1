"""Where a screen's images go: whole device pixels, one image pixel on one screen pixel.

An image of ``w × h`` pixels is drawn 1:1 only when its edges lie on the screen's pixel
boundaries: then every screen pixel's centre falls on the centre of one image pixel, and the
nearest-texel lookup (PsychoPy's ``interpolate=False``) picks that pixel whatever the rounding
of the graphics card. PsychoPy places a stimulus by its centre, in pixels from the window's
centre: an odd-sized image at a whole-pixel centre of an even-sized window has its edges on
half pixels, and the lookup, exactly between two texels, doubles some rows and columns and
drops others. So the layout here works in whole pixels from the window's lower-left corner
(OpenGL's), and converts to PsychoPy's centre position only at the end.

A row of images (the matching paradigm's targets and reference, the staircase's two windows)
is centred on the window as closely as whole pixels allow: when the row's width and the
window's differ in parity, the row sits half a pixel left of the centre (and an image half a
pixel below it when their heights differ in parity), and :func:`row_layout` says so.

No PsychoPy here: the front-end, the display check and ``protocol check`` share it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from glarelab.protocols import pixel_deg
from glarelab.stimuli.paradigms import paradigm_stimuli

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["Placement", "row_layout"]


@dataclass(frozen=True)
class Placement:
    """One image on the window, in whole pixels from the window's lower-left corner.

    Parameters
    ----------
    left_px, bottom_px
        The image's first column and bottom row on the window.
    width_px, height_px
        Its size.
    window_px
        The window's (width, height).
    """

    left_px: int
    bottom_px: int
    width_px: int
    height_px: int
    window_px: tuple[int, int]

    @property
    def pos(self) -> tuple[float, float]:
        """PsychoPy's ``pos`` of the image: its centre, in pixels from the window's centre."""
        return (
            self.left_px + self.width_px / 2 - self.window_px[0] / 2,
            self.bottom_px + self.height_px / 2 - self.window_px[1] / 2,
        )

    @property
    def inside(self) -> bool:
        """Whether the whole image is on the window."""
        return (
            self.left_px >= 0
            and self.bottom_px >= 0
            and self.left_px + self.width_px <= self.window_px[0]
            and self.bottom_px + self.height_px <= self.window_px[1]
        )


def _whole(value, name: str, low: int) -> int:
    if isinstance(value, bool) or not float(value).is_integer() or value < low:
        raise ValueError(f"{name} must be a whole number of pixels, at least {low}; got {value!r}")
    return int(value)


def row_layout(
    window_px: tuple[int, int], sizes_px: list[tuple[int, int]], *, gap_px: int
) -> list[Placement]:
    """Images side by side, ``gap_px`` apart, the row centred on the window, each image
    centred vertically, every edge on a whole pixel.

    Parameters
    ----------
    window_px
        The window's (width, height) in pixels.
    sizes_px
        Each image's (width, height) in pixels, left to right.
    gap_px
        Pixels between neighbouring images.

    Returns
    -------
    list of Placement
        Left to right. An image that does not fit the window has ``inside`` False.

    Raises
    ------
    ValueError
        For a size, gap or window that is not a whole number of pixels.

    Notes
    -----
    The row of total width :math:`T = \\sum w_i + (n - 1) g` starts at column
    :math:`\\lfloor (W - T) / 2 \\rfloor` and image :math:`i` at row
    :math:`\\lfloor (H - h_i) / 2 \\rfloor`.

    Examples
    --------
    Yoshida et al.'s three 271-pixel images, 34 px apart, on a 1920 × 1080 window: PsychoPy
    centres on half pixels, so every edge is on a whole one.

    >>> [p.pos for p in row_layout((1920, 1080), [(271, 271)] * 3, gap_px=34)]
    [(-305.5, -0.5), (-0.5, -0.5), (304.5, -0.5)]
    >>> row_layout((1920, 1080), [(271, 271)] * 3, gap_px=34)[0].left_px
    519
    """
    width, height = (_whole(v, "window_px", 1) for v in window_px)
    gap = _whole(gap_px, "gap_px", 0)
    sizes = [(_whole(w, "image width", 1), _whole(h, "image height", 1)) for w, h in sizes_px]
    total = sum(w for w, _ in sizes) + gap * max(len(sizes) - 1, 0)
    left = (width - total) // 2
    placements = []
    for w, h in sizes:
        placements.append(Placement(left, (height - h) // 2, w, h, (width, height)))
        left += w + gap
    return placements


def protocol_drawing(protocol: Protocol) -> tuple[list[str], bool]:
    """How a protocol's first trial is drawn on the protocol's own display: lines to print and
    whether every image is drawn 1:1 (each image pixel on one screen pixel, the whole row on
    the screen). A protocol that shows no images: no lines, True.

    The lines also say where whole pixels depart from the protocol's angles: an image size or
    gap in degrees rounded to pixels, and a ``pixel_deg`` that is not the display's pixel.
    """
    data = protocol.data
    display = data.get("display")
    if not display:
        return [], True
    display_deg = pixel_deg(protocol)
    row = paradigm_stimuli(protocol).first_row(protocol, display_deg)
    if row is None:
        return [], True
    screen = tuple(display["resolution_px"])
    sizes, gap, own_deg, notes = row.sizes_px, row.gap_px, row.pixel_deg, list(row.notes)
    if own_deg:  # a pixel angle of the protocol's own
        departure = own_deg / display_deg - 1.0
        if abs(departure) > 0.01:
            notes.append(
                f"pixel_deg = {own_deg:g}° is not the display's pixel ({display_deg:.4g}° at "
                f"viewing.distance_m = {data['viewing']['distance_m']:g}): images are drawn "
                f"1:1, so every angle on this display is {100 * departure:+.1f} % off the "
                "protocol's"
            )
    placements = row_layout(screen, sizes, gap_px=gap)
    exact = all(p.inside for p in placements)
    width = sum(w for w, _ in sizes) + gap * (len(sizes) - 1)
    what = (
        f"{len(sizes)} image{'s' if len(sizes) > 1 else ''} of "
        + " and ".join(sorted({f"{w} × {h} px" for w, h in sizes}))
        + (f", {gap} px apart" if len(sizes) > 1 else "")
    )
    if exact:
        columns = ", ".join(str(p.left_px) for p in placements)
        left = screen[0] / 2 - (placements[0].left_px + width / 2)
        tallest = max(placements, key=lambda p: p.height_px)
        below = -tallest.pos[1]
        off = [f"{v:g} px {side}" for v, side in ((left, "left of"), (below, "below")) if v]
        lines = [
            f"drawn 1:1 on the display's {screen[0]} × {screen[1]} px: {what}; every edge on a "
            f"whole pixel (left columns {columns})"
            + (f"; the row's centre is {' and '.join(off)} the screen's" if off else "")
        ]
    else:
        lines = [
            f"CANNOT be drawn 1:1 on the display's {screen[0]} × {screen[1]} px: {what} take "
            f"{width} × {max(h for _, h in sizes)} px, more than the screen"
        ]
    return lines + notes, exact
