"""Simple stimulus geometry: a disk of given visual angle on a uniform field, and a row of images
as a session draws them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from glarelab.glare._validation import check_in_range, check_positive

__all__ = ["MAX_FIELD_PX", "ImageRow", "disk"]

MAX_FIELD_PX = 2**15  # a field wider than this many pixels is a typo of pixel_deg (8 GiB)


def disk(
    *,
    field_deg: float,
    pixel_deg: float,
    disk_diameter_deg: float,
    disk_cd_m2: float,
    background_cd_m2: float,
) -> dict:
    """A disk centred on a uniform square field (Yoshida 2008 §3 uses a 0.3° disk).

    Parameters
    ----------
    field_deg
        Side of the square field in degrees, > 0.
    pixel_deg
        Visual angle of a pixel in degrees, > 0 and at most ``field_deg``. The field has an
        odd number of pixels so the disk has a centre pixel.
    disk_diameter_deg
        Diameter of the disk in degrees, > 0 and less than ``field_deg``.
    disk_cd_m2, background_cd_m2
        Luminances in cd/m², finite and >= 0 (numbers, not bools or strings).

    Returns
    -------
    dict
        ``img`` (float64 luminance), ``mask`` (bool, the disk: pixel centres within the
        radius) and the parameters, in the style of stimupy.

    Raises
    ------
    ValueError
        For any argument outside its range, naming it.

    Examples
    --------
    >>> s = disk(field_deg=1.0, pixel_deg=0.1, disk_diameter_deg=0.3,
    ...          disk_cd_m2=4000.0, background_cd_m2=150.0)
    >>> s["img"].shape, int(s["mask"].sum())
    ((11, 11), 9)
    """
    field_deg = check_positive("field_deg", field_deg, unit="deg")
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    diameter = check_positive("disk_diameter_deg", disk_diameter_deg, unit="deg")
    if pixel_deg > field_deg:
        raise ValueError(
            f"pixel_deg must be at most field_deg ({field_deg:g}°) for the field to hold a "
            f"pixel, got {pixel_deg:g}"
        )
    if field_deg / pixel_deg > MAX_FIELD_PX:
        raise ValueError(
            f"pixel_deg = {pixel_deg:g}: the {field_deg:g}° field would be "
            f"{field_deg / pixel_deg:.3g} pixels wide, more than {MAX_FIELD_PX}; give a larger "
            "pixel_deg"
        )
    if diameter >= field_deg:
        raise ValueError(
            f"disk_diameter_deg must be less than field_deg ({field_deg:g}°) for the disk to "
            f"lie on the field, got {diameter:g}"
        )
    for name, value in (("disk_cd_m2", disk_cd_m2), ("background_cd_m2", background_cd_m2)):
        check_in_range(name, value, 0.0, math.inf, unit="cd/m²")
    n = round(field_deg / pixel_deg)
    n += 1 - n % 2
    y, x = (np.indices((n, n)) - n // 2) * pixel_deg
    mask = np.hypot(x, y) <= diameter / 2
    img = np.where(mask, float(disk_cd_m2), float(background_cd_m2))
    return {
        "img": img,
        "mask": mask,
        "field_deg": n * pixel_deg,
        "pixel_deg": pixel_deg,
        "disk_diameter_deg": diameter,
        "disk_cd_m2": float(disk_cd_m2),
        "background_cd_m2": float(background_cd_m2),
    }


@dataclass(frozen=True)
class ImageRow:
    """The images of a protocol's first trial as a session draws them, side by side.

    Attributes
    ----------
    sizes_px
        (width, height) of each image, pixels, left to right.
    gap_px
        Pixels between two images.
    pixel_deg
        The protocol's own pixel angle, degrees; None: the display's.
    notes
        Where whole pixels depart from the protocol's angles, one sentence each.
    """

    sizes_px: list[tuple[int, int]]
    gap_px: int
    pixel_deg: float | None = None
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if isinstance(self.gap_px, bool) or not isinstance(self.gap_px, int | np.integer):
            raise ValueError(f"gap_px must be a whole number of pixels >= 0; got {self.gap_px!r}")
        if self.gap_px < 0:  # images drawn over each other
            raise ValueError(f"gap_px must be a whole number of pixels >= 0; got {self.gap_px!r}")
