"""OpenEXR input and output of linear luminance images, always float32.

Half floats overflow at 65,504, far below the luminance of a lamp or the sun (Spencer Fig. 16:
7.5e8 cd/m²), so images are written as 32-bit float and read back as such.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np
import OpenEXR

from glarelab.files.atomic import NAME_MAX_BYTES, atomic_path
from glarelab.files.inputs import input_file

__all__ = ["read_exr", "write_exr"]

EXR_MAGIC = bytes((0x76, 0x2F, 0x31, 0x01))  # the first four bytes of every OpenEXR file
FLOAT32_MAX = float(np.finfo(np.float32).max)  # 3.4028235e38; above it float32 is inf


def _first(array: np.ndarray, bad: np.ndarray) -> str:
    """The first offending value and its index."""
    where = tuple(int(i) for i in np.argwhere(bad)[0])
    return f"{float(array[where])!r} at index {where}"


def write_exr(path: str | Path, image: np.ndarray) -> Path:
    """Write a linear image as a float32 OpenEXR file (ZIP compression, lossless), whole or
    not at all (:func:`glarelab.files.atomic.atomic_path`).

    Parameters
    ----------
    path
        Output file, ending in ``.exr``.
    image
        ``(H, W)`` luminance, written as channel ``Y``, or ``(H, W, 3)`` linear RGB, written as
        channels ``R``, ``G``, ``B``; at least one pixel. Values must be finite.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        For another shape or no pixel, a masked array, values that are not real numbers,
        non-finite or negative values, values above float32's largest (3.4e38, they would be
        written as inf), or a path that is empty or not a path, does not end in ``.exr``, is
        a folder, or has a file name longer than the file system allows.
    """
    if isinstance(image, np.ma.MaskedArray):
        raise ValueError(
            "image must be a plain array, not a masked array (its mask would not be written); "
            "give image.filled(value)"
        )
    if isinstance(image, str | bytes) or image is None:
        raise ValueError(
            f"image must be an (H, W) or (H, W, 3) array of luminances; got {type(image).__name__}"
        )
    try:
        array = np.asarray(image)
    except ValueError:  # rows of different lengths
        raise ValueError("image must be an (H, W) or (H, W, 3) array; got ragged rows") from None
    if not (array.ndim == 2 or (array.ndim == 3 and array.shape[2] == 3)) or not array.size:
        raise ValueError(
            "image must be (H, W) luminance or (H, W, 3) RGB with at least one pixel; got "
            f"shape {array.shape}"
        )
    if not isinstance(path, str | os.PathLike) or not str(path):
        raise ValueError(f"path must name an .exr file; got {path!r}")
    path = Path(path)
    if len(path.name.encode()) > NAME_MAX_BYTES:
        raise ValueError(
            f"path's file name is {len(path.name.encode())} bytes long; file systems allow "
            f"{NAME_MAX_BYTES}: {path.name[:40]}…"
        )
    if path.suffix.lower() != ".exr":
        raise ValueError(f"path must name an .exr file (OpenEXR is written); got {str(path)!r}")
    if path.is_dir():
        raise ValueError(f"path {str(path)!r} is a folder; give the EXR file's name in it")
    if array.dtype.kind not in "iuf":
        raise ValueError(
            f"image must hold real numbers (integer or float) to be written as EXR; got dtype "
            f"{array.dtype}"
        )
    if not np.isfinite(array).all():
        raise ValueError(
            "image must be finite to be written as EXR; it holds NaN or Inf: "
            + _first(array, ~np.isfinite(array))
        )
    if array.size and array.min() < 0:
        raise ValueError(
            f"image must be >= 0 (linear luminance, cd/m²) to be written as EXR; it holds "
            f"{_first(array, array < 0)}"
        )
    if array.size and float(array.max()) > FLOAT32_MAX:  # float16's max: no cast of 3.4e38
        raise ValueError(
            f"image must be at most {FLOAT32_MAX:.8g}, float32's largest, to be written as EXR "
            f"(it would become inf); it holds {_first(array, array > FLOAT32_MAX)}"
        )
    array = np.ascontiguousarray(array, dtype=np.float32)
    channels = {"Y": array} if array.ndim == 2 else {"RGB": array}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path) as temporary, OpenEXR.File(header, channels) as exr:
            exr.write(str(temporary))  # whole or not at all: an earlier file stays as it was
    except RuntimeError as error:  # OpenEXR reports a full disk or a closed folder this way
        text = str(error)
        code = errno.ENOSPC if "space" in text.lower() else errno.EIO
        raise OSError(code, f"could not write the EXR file ({text})", str(path)) from None
    return path


# scan lines per chunk of each OpenEXR compression (OpenEXR file layout, "Line offset table")
LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _truncated(path: Path) -> bool | None:
    """Whether a single-part scan-line OpenEXR file ends before its last chunk does (the
    library reads such a file with zeros for the missing lines and only a warning); None
    when the layout is not one this checks (tiled, multi-part, deep)."""

    length = path.stat().st_size
    with path.open("rb") as stream:
        data = stream.read(1 << 20)  # the header and the offset table
        return _check_layout(data, length, stream)


def _check_layout(data: bytes, length: int, stream) -> bool | None:
    """:func:`_truncated` of a file of ``length`` bytes starting with ``data``."""
    import struct

    if len(data) < 8 or int.from_bytes(data[4:8], "little") & 0x1A00:  # tiled/deep/multi
        return None
    at, compression, window = 8, None, None
    try:
        while data[at] != 0:
            name_end = data.index(b"\0", at)
            type_end = data.index(b"\0", name_end + 1)
            size = int.from_bytes(data[type_end + 1 : type_end + 5], "little")
            name = data[at:name_end]
            value = data[type_end + 5 : type_end + 5 + size]
            if name == b"compression":
                compression = value[0]
            elif name == b"dataWindow":
                window = struct.unpack("<4i", value)
            at = type_end + 5 + size
    except (ValueError, IndexError, struct.error):
        return True  # the header itself is cut short
    if compression not in LINES_PER_CHUNK or window is None:
        return None
    lines = window[3] - window[1] + 1
    chunks = -(-lines // LINES_PER_CHUNK[compression])
    table = at + 1
    if table + 8 * chunks > length:
        return True
    if table + 8 * chunks > len(data):
        stream.seek(table)
        data = data[:table] + stream.read(8 * chunks)
    offsets = struct.unpack(f"<{chunks}Q", data[table : table + 8 * chunks])
    for offset in offsets:
        if offset + 8 > length:
            return True
        stream.seek(offset + 4)
        size = int.from_bytes(stream.read(4), "little")
        if offset + 8 + size > length:
            return True
    return False


class _Unreadable(Exception):
    """The OpenEXR library opened a file but read none of it."""


_LIBRARY_OUTPUT = threading.Lock()  # file descriptor 2 is held back by one read at a time


@contextlib.contextmanager
def _held_library_output(said: list[str]):
    """Hold back what the OpenEXR library prints during a read: its C core writes each error
    to file descriptor 2, its Python binding a warning to ``sys.stdout`` (a damaged chunk
    table gave thirty lines before the exception). A read that succeeds writes them out
    after; one that fails leaves their lines in ``said`` for its message. File descriptor 2
    is restored whatever happens."""
    sys.stderr.flush()
    with _LIBRARY_OUTPUT, tempfile.TemporaryFile() as held:
        try:
            saved = os.dup(2)
        except OSError:  # no standard error to hold back
            yield
            return
        printed = io.StringIO()
        failed = True
        try:
            os.dup2(held.fileno(), 2)
            with contextlib.redirect_stdout(printed):
                yield
            failed = False
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            held.seek(0)
            errors = held.read()
            if failed:
                text = errors.decode("utf-8", "replace") + printed.getvalue()
                said.extend(line.strip() for line in text.splitlines() if line.strip())
            else:
                sys.stdout.write(printed.getvalue())
                if errors:
                    os.write(2, errors)


def _check_header(path: Path, exr) -> None:
    """Refuse what reading the first part's pixels would silently drop: other parts, a pixel
    aspect ratio other than 1 (the kernel is round in pixels), a data window that is not the
    whole display window (pixels placed in, or cut from, a larger frame)."""
    if len(exr.parts) > 1:
        names = ", ".join(repr(part.name()) for part in exr.parts)
        raise ValueError(
            f"{path}: multi-part OpenEXR ({len(exr.parts)} parts: {names}); glarelab reads one "
            "image, so write each part to a file of its own"
        )
    header = exr.header()
    ratio = float(header.get("pixelAspectRatio", 1.0))
    if ratio != 1.0:
        raise ValueError(
            f"{path}: pixelAspectRatio is {ratio:g}; glarelab needs square pixels (1), since "
            "the glare kernel is digitised in square pixels: resample the image first"
        )
    data, display = header.get("dataWindow"), header.get("displayWindow")
    if data is not None and display is not None:
        data_box = tuple(int(v) for corner in data for v in corner)
        display_box = tuple(int(v) for corner in display for v in corner)
        if data_box != display_box:
            raise ValueError(
                f"{path}: dataWindow {data_box} is not the displayWindow {display_box} "
                "(xmin, ymin, xmax, ymax); glarelab reads whole images: crop or pad the image "
                "to its display window"
            )


def read_exr(path: str | Path) -> np.ndarray:
    """Read an OpenEXR file as a float32 array: ``(H, W)`` for Y, ``(H, W, 3)`` for RGB.

    Parameters
    ----------
    path
        The file, with a ``Y`` channel or ``R``, ``G`` and ``B`` channels (linear, cd/m² in a
        stimulus set).

    Returns
    -------
    numpy.ndarray
        float32, ``(H, W)`` or ``(H, W, 3)``.

    Raises
    ------
    ValueError
        If ``path`` is a named pipe or a device, or the file is not OpenEXR, is damaged
        (in one line, with what the OpenEXR library found: the lines it prints while
        reading are held back, and written out only after a read that succeeds),
        holds a NaN, infinite or negative pixel (a damaged chunk decodes as NaN, a damaged
        uncompressed one as any value), holds neither a ``Y``
        channel nor ``R``, ``G`` and ``B``, a subsampled one, has more than one part,
        a ``pixelAspectRatio``
        other than 1, or a ``dataWindow`` other than its ``displayWindow`` (a data window that
        equals the display window is read whole, wherever its origin).
    FileNotFoundError
        If the file does not exist.
    IsADirectoryError
        If ``path`` is a folder (a named pipe or a device is a ValueError).
    """
    path = input_file(path, what="EXR file")  # a pipe or a device is refused unopened
    with path.open("rb") as stream:
        magic = stream.read(4)
    if magic != EXR_MAGIC:
        what = "an empty file" if not magic else "not an OpenEXR file (its first bytes differ)"
        raise ValueError(f"{path} is {what}; give a linear float OpenEXR image")
    if _truncated(path):
        raise ValueError(
            f"{path} cannot be read: it is cut short, ending before its last scan lines (a "
            "copy or a write that did not finish?); give the complete file"
        )
    said: list[str] = []
    try:
        with _held_library_output(said), OpenEXR.File(str(path), separate_channels=True) as exr:
            if not exr.parts:  # no part's pixels read (a damaged chunk table): said, not raised
                raise _Unreadable("no part of it could be read")
            _check_header(path, exr)
            read = exr.channels()
            channels = {name: np.asarray(c.pixels) for name, c in read.items()}
            sampled = {  # (x, y) pixels per sample of a channel that is not full resolution
                name: (int(c.xSampling), int(c.ySampling))
                for name, c in read.items()
                if name in ("Y", "R", "G", "B") and (c.xSampling, c.ySampling) != (1, 1)
            }
    except (RuntimeError, IndexError, _Unreadable) as error:  # OpenEXR: the file is damaged
        reason = said[0].removeprefix(f"{path}: ") if said else ""
        raise ValueError(
            f"{path} cannot be read as OpenEXR (truncated or damaged?): {error}"
            + (f"; OpenEXR: {reason}" if reason and reason not in str(error) else "")
        ) from None
    if sampled:  # read as a smaller image, at another angular scale, without a word
        name, (x, y) = sorted(sampled.items())[0]
        raise ValueError(
            f"{path}: channel {name} is subsampled ({x} × {y} pixels per sample, as chroma in "
            "a YC image); glarelab reads channels with one sample per pixel: write the image "
            "at full resolution"
        )
    if {"R", "G", "B"} <= channels.keys() and "Y" in channels:
        raise ValueError(
            f"{path} holds both a Y channel and R, G, B channels; glarelab reads one scene, "
            "so write the file with either (not both)"
        )
    if {"R", "G", "B"} <= channels.keys():
        image = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float32, copy=False)
    elif "Y" in channels:
        image = channels["Y"].astype(np.float32, copy=False)
    else:
        raise ValueError(
            f"{path} must hold a Y channel or R, G, B channels; it holds {sorted(channels)}"
        )
    if not np.isfinite(image).all():  # OpenEXR decodes a damaged chunk as NaN, silently
        raise ValueError(
            f"{path} holds NaN or Inf (damaged, or not a luminance image): "
            + _first(image, ~np.isfinite(image))
        )
    if (image < 0).any():  # a luminance or a transmission: never below 0 (write_exr's rule)
        raise ValueError(
            f"{path} holds a negative value, where a luminance must be >= 0 cd/m² (damaged, "
            "or not a linear luminance image?): " + _first(image, image < 0)
        )
    return image
