"""The stimuli as the display showed them, for a report's Stimuli section.

A session shows an image of the set as the drive codes of its calibration: the luminance the
participant saw is ``decode(encode(image))`` through the set's calibration (the manifest's),
which quantises to the display's bit depth and clips at its black and maximum. A report shows
that luminance relative to the display's maximum, encoded for an sRGB screen (IEC 61966-2-1,
through colour-science), so a reader's screen shows the same relative luminance the lab display
did, and every image at one screen pixel per display pixel.

A paradigm draws its stimuli with the helpers here (:func:`image_grid`, :func:`profiles`) in
its ``stimulus_figures(protocol, shown)``; the report opens the set (:class:`VerifiedSet`) and
calls it when it is given the set's folder.
"""

from __future__ import annotations

import io
from pathlib import Path

import matplotlib
import matplotlib.figure
import numpy as np

from glarelab.analysis.dataset import DataError
from glarelab.analysis.figures import png, subplots
from glarelab.files.inputs import loads_json
from glarelab.protocols import Protocol
from glarelab.stimuli.shown import ShownSet

__all__ = ["VerifiedSet", "image_grid", "profiles", "radial_profile", "to_srgb8"]

DPI = 100  # the grid is laid out in pixels at this resolution
TITLE_PX = 20  # room above each image for its label
GAP_PX = 8
WIDTH_PX = 1000  # as many images per row as fit in this width


def to_srgb8(luminance_cd_m2: np.ndarray, max_cd_m2: float) -> np.ndarray:
    """Luminance relative to ``max_cd_m2``, encoded as 8-bit sRGB (what an sRGB screen shows
    at that relative luminance).

    Parameters
    ----------
    luminance_cd_m2
        Luminance, cd/m², any shape.
    max_cd_m2
        The luminance shown as white, cd/m².

    Returns
    -------
    numpy.ndarray
        uint8 codes, the shape of ``luminance_cd_m2``.

    Examples
    --------
    >>> to_srgb8(np.array([0.0, 21.6, 120.0]), 120.0).tolist()  # 18 % grey → sRGB 118
    [0, 118, 255]
    """
    from glarelab.glare._colour import colour  # numpy's print options kept

    number = isinstance(max_cd_m2, int | float | np.integer | np.floating) and not isinstance(
        max_cd_m2, bool | np.bool_
    )
    if not (number and np.isfinite(max_cd_m2) and max_cd_m2 > 0):
        raise ValueError(f"max_cd_m2 must be a finite luminance above 0, cd/m²; got {max_cd_m2!r}")
    values = np.asarray(luminance_cd_m2, dtype=float)
    if not (np.isfinite(values).all() and (values >= 0).all()):
        raise ValueError("luminance_cd_m2 must hold finite luminances >= 0, cd/m²")
    relative = np.clip(np.asarray(luminance_cd_m2, dtype=float) / float(max_cd_m2), 0.0, 1.0)
    return np.round(255 * colour.cctf_encoding(relative, function="sRGB")).astype(np.uint8)


class VerifiedSet(ShownSet):
    """A stimulus set as the display showed it (:class:`glarelab.stimuli.shown.ShownSet`),
    verified first: its files are those of its manifest and it was built from the protocol.

    Parameters
    ----------
    folder
        The set's folder.
    protocol
        The study's protocol: the set must have been built from it.

    Raises
    ------
    glarelab.analysis.load.DataError
        For a folder that is not a stimulus set, a set that fails its manifest (a file changed
        or missing), or a set built from another protocol.
    """

    def __init__(self, folder: str | Path, protocol: Protocol):
        from glarelab.stimuli.stimulus_set import StimulusSet, verify_stimulus_set

        self.folder = Path(folder)
        problems = verify_stimulus_set(self.folder)
        if problems:
            raise DataError([f"stimulus set {self.folder}: {p}" for p in problems])
        manifest = loads_json(
            (self.folder / "manifest.json").read_text(), source=self.folder / "manifest.json"
        )
        if manifest.get("protocol_sha256") != protocol.sha256:
            raise DataError(
                [
                    f"stimulus set {self.folder}: built from the {manifest.get('study')} "
                    f"protocol {str(manifest.get('protocol_sha256'))[:12]}…, not from this "
                    f"{protocol.study} protocol {protocol.sha256[:12]}…"
                ]
            )
        super().__init__(StimulusSet(self.folder))
        self.images: dict[str, dict] = self.manifest["images"]

    def picture(self, name: str) -> np.ndarray:
        """Image ``name`` as the display showed it, as 8-bit sRGB (:func:`to_srgb8`).

        Parameters
        ----------
        name
            An image of the set.

        Returns
        -------
        numpy.ndarray
            uint8 sRGB codes.
        """
        return to_srgb8(self.luminance(name), self.calibration.max_cd_m2)

    def describe_display(self) -> str:
        """The calibration as a caption names it."""
        c = self.calibration
        return (
            f"{c.bit_depth}-bit display, {c.black_cd_m2:.3g}-{c.max_cd_m2:.4g} cd/m², "
            f"calibration '{c.status}'"
        )


def image_grid(panels: list[tuple[np.ndarray, str]], *, columns: int | None = None) -> bytes:
    """8-bit images with a label above each, one screen pixel per image pixel, as PNG bytes.

    Parameters
    ----------
    panels
        ``(picture, label)`` pairs: uint8 images (grey or RGB) and their labels, at least one.
    columns
        Panels per row; default None: as many as fit in 1000 px.

    Returns
    -------
    bytes
        The PNG file's content.

    Raises
    ------
    ValueError
        Without panels.
    """
    if not panels:
        raise ValueError("image_grid needs at least one image")
    height = max(p[0].shape[0] for p in panels)
    width = max(p[0].shape[1] for p in panels)
    if columns is None:
        columns = max(1, min(len(panels), WIDTH_PX // (width + GAP_PX)))
    rows = -(-len(panels) // columns)
    cell_w, cell_h = width + GAP_PX, height + TITLE_PX + GAP_PX
    total_w, total_h = columns * cell_w + GAP_PX, rows * cell_h + GAP_PX
    figure = matplotlib.figure.Figure(
        figsize=(total_w / DPI, total_h / DPI), dpi=DPI, facecolor="white"
    )
    for index, (picture, label) in enumerate(panels):
        row, column = divmod(index, columns)
        h, w = picture.shape[:2]
        left = GAP_PX + column * cell_w
        top = GAP_PX + row * cell_h + TITLE_PX
        axis = figure.add_axes((left / total_w, 1 - (top + h) / total_h, w / total_w, h / total_h))
        shown = picture if picture.ndim == 3 else np.repeat(picture[..., None], 3, axis=2)
        axis.imshow(shown, interpolation="nearest", aspect="auto")
        axis.set_axis_off()
        figure.text(
            (left + w / 2) / total_w,
            1 - (top - 4) / total_h,
            label,
            ha="center",
            va="bottom",
            fontsize=9,
        )
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI, metadata={"Software": None})
    return buffer.getvalue()


def radial_profile(
    luminance_cd_m2: np.ndarray, centre_px: tuple[float, float], pixel_deg: float
) -> tuple[np.ndarray, np.ndarray]:
    """Mean luminance over every direction at each distance from the centre, in one-pixel
    rings out to the nearest image border: (distance in degrees, cd/m²). A colour image is
    averaged as Rec. 709 luminance.

    Parameters
    ----------
    luminance_cd_m2
        ``(H, W)`` luminance, or ``(H, W, 3)`` linear RGB, cd/m².
    centre_px
        ``(row, column)`` of the centre, pixel indices (fractions allowed).
    pixel_deg
        Visual angle of one pixel, degrees.

    Returns
    -------
    distance_deg, mean_cd_m2 : numpy.ndarray
        Each ring's distance from the centre, degrees, and its mean luminance, cd/m².

    Examples
    --------
    >>> r, mean = radial_profile(np.full((5, 5), 3.0), (2, 2), 0.1)
    >>> r.round(1).tolist(), mean.tolist()
    ([0.0, 0.1, 0.2], [3.0, 3.0, 3.0])
    >>> radial_profile(np.full((4, 4), 1.0), (1.5, 1.5), 1.0)[0].tolist()  # no ring 0
    [1.0]
    """
    image = np.asarray(luminance_cd_m2, dtype=float)
    if image.ndim == 3:
        image = image @ np.array([0.2126, 0.7152, 0.0722])
    if image.ndim != 2 or min(image.shape) < 1:
        raise ValueError(
            f"luminance_cd_m2 must be an (H, W) or (H, W, 3) image; got {image.shape}"
        )
    inside = (
        len(centre_px) == 2
        and all(np.isfinite(c) for c in centre_px)
        and 0 <= centre_px[0] <= image.shape[0] - 1
        and 0 <= centre_px[1] <= image.shape[1] - 1
    )
    if not inside:
        raise ValueError(
            f"centre_px must be (row, column) inside the {image.shape[0]} × {image.shape[1]} "
            f"image; got {tuple(centre_px)!r}"
        )
    rows, columns = np.indices(image.shape)
    ring = np.rint(np.hypot(rows - centre_px[0], columns - centre_px[1])).astype(int)
    reach = int(
        min(centre_px[0], centre_px[1], image.shape[0] - 1 - centre_px[0],
            image.shape[1] - 1 - centre_px[1])
    )  # fmt: skip
    sums = np.bincount(ring.ravel(), weights=image.ravel())[: reach + 1]
    counts = np.bincount(ring.ravel())[: reach + 1]
    filled = counts > 0  # a centre between pixels leaves ring 0 empty
    return np.flatnonzero(filled) * pixel_deg, sums[filled] / counts[filled]


def profiles(
    groups: dict[str, list[tuple[str, np.ndarray, np.ndarray]]],
    *,
    log: bool = False,
    lines: dict[str, float] | None = None,
    xlabel: str = "distance from the centre (°)",
    ylabel: str = "displayed luminance (cd/m²)",
) -> bytes:
    """Luminance profiles: one panel per group (a method, a context), one curve per image
    ``(label, x, values)``; ``lines`` adds labelled horizontal lines (as L_dmax).

    Parameters
    ----------
    groups
        Panel title → its curves ``(label, x, values)``.
    log
        Whether the luminance axis is logarithmic; default False.
    lines
        Label → luminance of a horizontal line, cd/m²; default none.
    xlabel, ylabel
        The axes' labels; defaults: distance in degrees, displayed luminance in cd/m².

    Returns
    -------
    bytes
        The PNG file's content.
    """
    figure, axes = subplots(
        1, len(groups), figsize=(4.6 * len(groups), 3.6), sharey=True, squeeze=False
    )
    colours = matplotlib.colormaps["viridis"](
        np.linspace(0.0, 0.9, max(len(m) for m in groups.values()))
    )
    for axis, (group, members) in zip(axes[0], groups.items(), strict=True):
        for colour, (label, x, values) in zip(colours, members, strict=False):
            axis.plot(x, values, lw=1.2, color=colour, label=label)
        for index, (name, value) in enumerate((lines or {}).items()):
            axis.axhline(value, color="k", ls="--", lw=0.8)
            axis.annotate(  # the first label above its line, the others below
                name,
                (0.98, value),
                xycoords=("axes fraction", "data"),
                ha="right",
                va="bottom" if index == 0 else "top",
                fontsize=7,
            )
        if log:
            axis.set_yscale("log")
        axis.set_title(group, fontsize=10)
        axis.set_xlabel(xlabel)
        axis.legend(fontsize=7, ncol=2, frameon=False)
    axes[0, 0].set_ylabel(ylabel)
    return png(figure)
