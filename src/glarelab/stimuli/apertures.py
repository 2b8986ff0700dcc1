"""Loading obstacle images (hand-drawn or photographed) for wave-optics glare."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from glarelab.glare.models.apertures import aperture_from_image
from glarelab.stimuli.exr import read_exr

__all__ = ["load_aperture_image"]


# an aperture image is sampled onto the pupil grid (at most 16385² for the largest kernel):
# a larger image only costs memory, and a decompression bomb claims a size far beyond it
MAX_APERTURE_PIXELS = 8192 * 8192


def _exr_size(path: Path) -> tuple[int, int]:
    import OpenEXR

    try:
        with OpenEXR.File(str(path), header_only=True) as exr:
            low, high = exr.header()["dataWindow"]
    except (RuntimeError, ValueError, KeyError, IndexError) as error:
        raise ValueError(f"{path} cannot be read as OpenEXR ({error})") from None
    return int(high[0] - low[0] + 1), int(high[1] - low[1] + 1)


def _check_pixels(path: Path, size: tuple[int, int]) -> None:
    """Refuse an image larger than :data:`MAX_APERTURE_PIXELS`, before decoding it."""
    width, height = size
    if width * height > MAX_APERTURE_PIXELS:
        raise ValueError(
            f"{path}: {width} × {height} pixels; an aperture image may have at most "
            f"{MAX_APERTURE_PIXELS:,} (8192²): scale it down"
        )


def load_aperture_image(path: str | Path) -> np.ndarray:
    """Read an obstacle transmittance image: PNG (8 or 16 bit, scaled to [0, 1], colour
    averaged) or a float EXR already in [0, 1].

    Parameters
    ----------
    path
        The image file: PNG (or another format Pillow reads) or OpenEXR, at most
        :data:`MAX_APERTURE_PIXELS` pixels. 1 is clear, 0 opaque.

    Returns
    -------
    numpy.ndarray
        The 2-D transmittance in [0, 1], checked by
        :func:`glarelab.glare.models.apertures.aperture_from_image`.

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
        _check_pixels(path, _exr_size(path))
        image = read_exr(path).astype(float)
    else:
        try:
            with Image.open(path) as handle:  # reads the header only
                _check_pixels(path, handle.size)
                raw = np.asarray(handle)
        except UnidentifiedImageError:
            raise ValueError(
                f"{path}: not an image PIL can read (PNG, TIFF, …) or an EXR"
            ) from None
        except Image.DecompressionBombError:
            raise ValueError(
                f"{path}: an aperture image may have at most {MAX_APERTURE_PIXELS:,} pixels "
                "(8192²); this one claims far more (a decompression bomb?)"
            ) from None
        except (OSError, SyntaxError) as error:
            if isinstance(error, FileNotFoundError):
                raise
            raise ValueError(f"{path}: not a readable image ({error})") from None
        scale = 65535.0 if raw.dtype == np.uint16 or raw.max() > 255 else 255.0
        image = raw.astype(float) / scale
    if image.ndim == 3:
        image = image[..., :3].mean(axis=2)
    return aperture_from_image(image, name=f"aperture image {path.name}")
