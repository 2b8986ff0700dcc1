"""Loading obstacle images (hand-drawn or photographed) for wave-optics glare."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from glare.apertures import aperture_from_image

from .exr import read_exr

__all__ = ["load_aperture_image"]


def load_aperture_image(path: str | Path) -> np.ndarray:
    """Read an obstacle transmittance image: PNG (8 or 16 bit, scaled to [0, 1], colour
    averaged) or a float EXR already in [0, 1].

    Raises
    ------
    ValueError
        If the values fall outside [0, 1] or the image is not 2-D after averaging colour.
    FileNotFoundError
        If there is no such file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no aperture image at {path}")
    if path.suffix.lower() == ".exr":
        image = read_exr(path).astype(float)
    else:
        try:
            with Image.open(path) as handle:
                raw = np.asarray(handle)
        except UnidentifiedImageError:
            raise ValueError(
                f"{path}: not an image PIL can read (PNG, TIFF, …) or an EXR"
            ) from None
        scale = 65535.0 if raw.dtype == np.uint16 or raw.max() > 255 else 255.0
        image = raw.astype(float) / scale
    if image.ndim == 3:
        image = image[..., :3].mean(axis=2)
    return aperture_from_image(image, name=f"aperture image {path.name}")
