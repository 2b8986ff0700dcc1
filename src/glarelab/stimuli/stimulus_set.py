"""A stimulus set on disk: what a study shows, exactly reproducible and self-describing.

A set is a folder with, for every image, float32 linear luminance (``NAME.exr``, cd/m²) and
the display codes that show it through the calibration: ``NAME.png``, an 8-bit PNG (greyscale,
or RGB for a colour image) whose samples are the codes of an 8-bit display, so PsychoPy's
``visual.ImageStim(win, image="NAME.png")`` (and Builder's Image component, which is one) and
any image viewer show the image code for code; for a display of more than 8 bits, ``NAME.png``
holds the nearest 8-bit codes (a viewer's and an 8-bit screen's copy) and ``NAME_10bit.png``
(``_12bit``, …) the display's own codes, a 16-bit PNG of the codes scaled to the full 16-bit
range, ``round(code × 65535 / (2^bits − 1))``, with an ``sBIT`` chunk recording the bit depth
(:func:`read_png_codes` gives back the exact codes;
:class:`glarelab.frontend.psychopy_plugin.SetImageStim` shows them on a deep window);
luminance-profile plots through the
disk centre (``profiles_*.png``, like Yoshida et al.'s Figure 3); ``README.md``, an index of
the files and images; and ``manifest.json``: the validated protocol and its hash, the
calibration and its hash, the geometry, every image's parameters and encoding report, the
package versions, and the sha256 of every file. A protocol's EXR background given by a path
relative to the protocol file is kept in the set's ``backgrounds`` folder under that path
(listed and hashed as its other files), and the set is proven from that copy wherever it is.
Nothing in it depends on the time or the place of the build, so the same protocol and
calibration give identical files.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import struct
import sys
import zlib
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path

import numpy as np
from PIL import Image
from PIL.PngImagePlugin import PngInfo

from glarelab.display.calibration import Calibration, synthetic_calibration
from glarelab.files.atomic import atomic_path, special_file, write_bytes, write_text
from glarelab.files.folders import (
    LISTING,
    check_replaceable,
    is_system_file,
    output_lock,
    record_files,
    replace_folder,
    staging_folder,
)
from glarelab.files.inputs import as_path, loads_json
from glarelab.files.locks import waiting_for
from glarelab.files.values import is_whole, plain_array
from glarelab.glare.models.cache import cache_root
from glarelab.protocols import Protocol, ProtocolError
from glarelab.stimuli.exr import read_exr, write_exr
from glarelab.stimuli.kernels import check_kernels
from glarelab.stimuli.paradigms import paradigm_stimuli

__all__ = [
    "SetChanged",
    "StimulusSet",
    "build_stimulus_set",
    "cached_stimulus_set",
    "check_set_protocol",
    "codes_png",
    "compose",
    "default_calibration",
    "package_versions",
    "progress_bar",
    "prove_stimulus_set",
    "read_png_codes",
    "shows_images",
    "verify_stimulus_set",
    "write_codes",
    "write_display_png",
]

MANIFEST = "manifest.json"
INDEX = "README.md"
# the protocol's EXR backgrounds, each under its path relative to the protocol file
BACKGROUNDS = "backgrounds"
# v4: NAME.png 8-bit (an 8-bit display's codes as they are), NAME_<bits>bit.png for deeper ones
FORMAT = "glarelab stimulus set v4"
PNG_MAX = 65535
PACKAGES = ("numpy", "scipy", "colour-science", "OpenEXR", "matplotlib", "pillow", "glarelab")


def check_set_protocol(protocol: Protocol, stimuli: Path) -> None:
    """Refuse a stimulus set built from another protocol (its manifest's ``protocol_sha256``),
    naming the study it was built for.

    Parameters
    ----------
    protocol
        The protocol the set is to be used with.
    stimuli
        The set's folder; a set without a readable manifest is left to its proof
        (:func:`prove_stimulus_set`).

    Raises
    ------
    ValueError
        Naming the set, the study and both protocols' sha256.
    """
    try:
        manifest = loads_json((stimuli / "manifest.json").read_text(encoding="utf-8"))
        built = manifest.get("protocol_sha256") if isinstance(manifest, dict) else None
    except (OSError, ValueError):
        built = None  # no readable manifest: named by the set's proof
    if built is not None and built != protocol.sha256:
        study = manifest.get("study")
        raise ValueError(
            f"the stimulus set {stimuli} was built from another protocol"
            + (f" ({study})" if isinstance(study, str) and study != protocol.study else "")
            + f" (sha256 {str(built)[:12]}…, this one {protocol.sha256[:12]}…); "
            "rebuild it with glarelab stimuli build"
        )


def shows_images(protocol: Protocol) -> bool:
    """Whether the protocol shows images (and so has a stimulus set): its paradigm has a
    builder, and the builder takes this protocol (a questionnaire without a scene shows none).

    Parameters
    ----------
    protocol
        A validated protocol.

    Returns
    -------
    bool
        Whether a stimulus set is built for it.

    Raises
    ------
    ValueError
        When no stimuli are registered for its paradigm.
    """
    return bool(paradigm_stimuli(protocol).shows(protocol))


def progress_bar(done: int, total: int, what: str, *, stream=None) -> None:
    """A one-line text progress bar on stderr.

    The bar is redrawn in place (a carriage return) and the line ends when ``done`` reaches
    ``total``.

    Parameters
    ----------
    done
        The steps done.
    total
        The steps in all; 0 shows a full bar.
    what
        What was done last, shown after the count.
    stream
        Where the bar is written; default ``None``: :data:`sys.stderr`.
    """
    stream = stream or sys.stderr
    width = 30
    filled = round(width * done / total) if total else width
    print(
        f"\r[{'#' * filled}{'-' * (width - filled)}] {done}/{total} {what:<28}",
        end="\n" if done >= total else "",
        file=stream,
        flush=True,
    )


def _write_rgb16_png(path: str | Path, scaled: np.ndarray, bit_depth: int) -> None:
    """``(H, W, 3)`` uint16 as a 16-bit RGB PNG with an ``sBIT`` chunk (Pillow writes 16-bit
    greyscale but not 16-bit RGB): PNG specification (ISO/IEC 15948) IHDR with bit depth 16 and
    colour type 2, sBIT of three channels, big-endian samples, filter type 0 on every row, one
    zlib-compressed IDAT."""
    height, width, _ = scaled.shape
    rows = np.ascontiguousarray(scaled.astype(">u2")).reshape(height, width * 3).view(np.uint8)
    raw = np.concatenate([np.zeros((height, 1), np.uint8), rows], axis=1).tobytes()

    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 16, 2, 0, 0, 0)
    write_bytes(
        path,
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"sBIT", bytes([bit_depth] * 3))
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b""),
    )


def write_codes(path: str | Path, codes: np.ndarray, bit_depth: int) -> None:
    """Write display codes as a 16-bit PNG that any viewer shows (greyscale; RGB for an
    ``(H, W, 3)`` colour image): the codes scaled to
    the full 16-bit range, ``round(code × 65535 / (2^bit_depth − 1))``, with an ``sBIT`` chunk
    recording ``bit_depth`` (PNG specification §11.3.4.4: the scaling it recommends, which
    keeps the code in the top ``bit_depth`` bits).

    Parameters
    ----------
    path
        The PNG file, written whole or not at all.
    codes
        Integer display codes, ``(H, W)`` (greyscale) or ``(H, W, 3)`` (RGB), each in
        0 … 2^bit_depth − 1.
    bit_depth
        The display's bits per channel, 1-16.

    Raises
    ------
    ValueError
        For a ``bit_depth`` that is not a whole number 1-16, codes that are not an ``(H, W)``
        or ``(H, W, 3)`` image of whole numbers (a masked array: its mask would be lost), or
        codes outside 0 … 2^bit_depth − 1.
    """
    codes = _checked_codes(codes, bit_depth)
    top = 2**bit_depth - 1
    scaled = np.floor(codes.astype(np.float64) * PNG_MAX / top + 0.5).astype(np.uint16)
    if scaled.ndim == 3:  # a colour image: 16-bit RGB
        _write_rgb16_png(path, scaled, bit_depth)
        return
    info = PngInfo()
    info.add(b"sBIT", bytes([bit_depth]))
    with atomic_path(path) as temporary:
        Image.fromarray(scaled).save(temporary, format="PNG", pnginfo=info)


def write_display_png(path: str | Path, codes: np.ndarray, bit_depth: int) -> None:
    """Write display codes as an 8-bit PNG (greyscale; RGB for an ``(H, W, 3)`` colour image)
    whose samples are the codes an 8-bit display shows: the codes themselves for
    ``bit_depth`` 8, the nearest 8-bit codes, ``round(code × 255 / (2^bit_depth − 1))``,
    otherwise.

    An 8-bit PNG is what PsychoPy's ``ImageStim`` draws as it is: Pillow opens it as ``L`` or
    ``RGB``, PsychoPy uploads sample ``v`` as ``v / 255`` of full scale, and an 8-bit frame
    buffer shows code ``v`` (a 16-bit PNG opens as Pillow's ``I;16``, which PsychoPy clips to
    black and white).

    Parameters
    ----------
    path
        The PNG to write (written to a temporary name and renamed; an existing file is
        replaced).
    codes
        Integer display codes, ``(H, W)`` (greyscale) or ``(H, W, 3)`` (RGB), in
        0 … 2^bit_depth − 1.
    bit_depth
        The bits per channel of the display the codes are for, 1-16 (8, 10, 12 or 16 for a
        glarelab calibration).

    Raises
    ------
    ValueError
        For a ``bit_depth`` that is not a whole number 1-16, codes that are not an ``(H, W)``
        or ``(H, W, 3)`` image of whole numbers, or codes outside 0 … 2^bit_depth − 1.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "codes.png"
    >>> write_display_png(path, np.array([[0, 1, 254, 255]]), 8)
    >>> image = Image.open(path)
    >>> image.mode, np.asarray(image).tolist()
    ('L', [[0, 1, 254, 255]])
    >>> write_display_png(path, np.array([[0, 2, 512, 1023]]), 10)  # nearest 8-bit codes
    >>> np.asarray(Image.open(path)).tolist()
    [[0, 0, 128, 255]]
    """
    codes = _checked_codes(codes, bit_depth)
    top = 2**bit_depth - 1
    eight = codes.astype(np.int64)
    if bit_depth != 8:
        eight = (eight * 255 * 2 // top + 1) // 2  # round(code × 255 / top), exactly
    with atomic_path(path) as temporary:
        Image.fromarray(eight.astype(np.uint8)).save(temporary, format="PNG")


def codes_png(name: str, bit_depth: int) -> str:
    """The file of a set's image ``name`` that holds its display codes exactly: ``NAME.png``
    for an 8-bit display, ``NAME_<bits>bit.png`` for a deeper one.

    Parameters
    ----------
    name
        The image's name in the set (its manifest's key), without ``.png``.
    bit_depth
        The bits per channel of the set's display (8, 10, 12 or 16); 8 or fewer give
        ``NAME.png``.

    Returns
    -------
    str
        The file name (no folder).

    Examples
    --------
    >>> codes_png("reference_vos_f", 8), codes_png("reference_vos_f", 10)
    ('reference_vos_f.png', 'reference_vos_f_10bit.png')
    """
    return f"{name}.png" if bit_depth <= 8 else f"{name}_{bit_depth}bit.png"


def _checked_codes(codes: np.ndarray, bit_depth: int) -> np.ndarray:
    """``codes`` as an image of whole codes for ``bit_depth`` bits, refused otherwise."""
    if not (is_whole(bit_depth) and 1 <= bit_depth <= 16):
        raise ValueError(f"bit_depth must be a whole number 1-16; got {bit_depth!r}")
    bit_depth = int(bit_depth)
    top = 2**bit_depth - 1
    codes = plain_array("codes", codes)
    if not (codes.ndim == 2 or (codes.ndim == 3 and codes.shape[2] == 3)) or not codes.size:
        raise ValueError(
            f"codes must be an image, (H, W) greyscale or (H, W, 3) RGB, of at least one "
            f"pixel; got shape {codes.shape}"
        )
    if codes.dtype.kind == "b" or codes.dtype.kind not in "uif":
        raise ValueError(f"codes must be whole numbers (display codes); got dtype {codes.dtype}")
    if codes.dtype.kind == "f":  # a float array of whole codes is taken; NaN or 511.7 not
        bad = ~np.isfinite(codes) | (codes != np.round(codes))
        if bad.any():
            raise ValueError(
                f"codes must be whole numbers (display codes); got {float(codes[bad].flat[0])!r} "
                f"at {tuple(int(i) for i in np.argwhere(bad)[0])}"
            )
    if codes.size and (codes.min() < 0 or codes.max() > top):
        raise ValueError(
            f"codes must be in [0, {top}] for bit_depth {bit_depth}; got "
            f"{codes.min()}-{codes.max()}"
        )
    return codes


def _sbit(data: bytes) -> int | None:
    """The significant bits of a PNG's sBIT chunk, its first channel's (None without one;
    :func:`write_codes` gives every channel the same)."""
    position = 8  # after the signature
    while position + 8 <= len(data):
        length = int.from_bytes(data[position : position + 4], "big")
        kind = data[position + 4 : position + 8]
        if kind == b"sBIT":
            return data[position + 8]
        if kind == b"IDAT":
            return None  # sBIT precedes the image data
        position += 12 + length
    return None


def read_png_codes(path: str | Path) -> tuple[np.ndarray, int]:
    """The display codes of a set's PNG, greyscale ``(H, W)`` or colour ``(H, W, 3)``, and
    their bit depth: a 16-bit PNG's ``sBIT`` chunk records it (:func:`write_codes`; one
    without holds the codes unscaled, 16 bits); an 8-bit PNG holds 8-bit codes as they are
    (:func:`write_display_png`).

    The PNG is decoded by pypng, which reads every sample at the file's own bit depth: Pillow
    opens a 16-bit RGB PNG as 8-bit RGB (it has no 16-bit colour mode), which would turn a
    colour image's codes into their top byte.

    Parameters
    ----------
    path
        A PNG written by :func:`write_codes` (or any 16-bit greyscale or RGB PNG).

    Returns
    -------
    codes : numpy.ndarray
        The codes, ``(H, W)`` or ``(H, W, 3)``, integers in 0 … 2^bits − 1.
    bits : int
        The bit depth of the codes (16 without ``sBIT``).

    Raises
    ------
    ValueError
        For a PNG that is not 8- or 16-bit greyscale or RGB (not a set's codes), naming the
        file.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "codes.png"
    >>> write_codes(path, np.array([[0, 1, 512, 1023]]), 10)
    >>> codes, bits = read_png_codes(path)
    >>> codes.tolist(), bits, np.asarray(Image.open(path)).tolist()
    ([[0, 1, 512, 1023]], 10, [[0, 64, 32800, 65535]])
    >>> write_codes(path, np.array([[[0, 734, 1023]]]), 10)  # a colour pixel
    >>> read_png_codes(path)[0].tolist()
    [[[0, 734, 1023]]]
    >>> write_display_png(path, np.array([[3, 250]]), 8)
    >>> codes, bits = read_png_codes(path)
    >>> codes.tolist(), bits
    ([[3, 250]], 8)
    """
    import png  # pypng

    data = Path(path).read_bytes()
    try:
        width, height, pixels, info = png.Reader(bytes=data).read_flat()
    except png.Error as error:
        raise ValueError(f"{path}: not a PNG of display codes ({error})") from None
    planes = int(info["planes"])
    depth = info["bitdepth"]
    if depth not in (8, 16) or planes not in (1, 3) or info.get("palette"):
        raise ValueError(
            f"{path}: a set's codes are 8- or 16-bit greyscale or RGB; this PNG has "
            f"{depth}-bit samples in {planes} channel(s)"
        )
    values = np.asarray(pixels, dtype=np.int64).reshape(height, width, planes)
    if planes == 1:
        values = values[..., 0]
    bits = _sbit(data)
    if bits is None or bits == depth:
        return values.astype(np.uint16), depth
    top, full = 2**bits - 1, 2**depth - 1
    return (values * top * 2 // full + 1) // 2, bits  # round(v × top / full), exactly


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def default_calibration(protocol: Protocol) -> Calibration:
    """The synthetic calibration of the protocol's display (gamma 2.2; marked synthetic).

    Parameters
    ----------
    protocol
        A validated protocol: its ``[display]`` gives the white and black (cd/m²), the bit
        depth and the name.

    Returns
    -------
    glarelab.display.calibration.Calibration
        The calibration :func:`glarelab.display.calibration.synthetic_calibration` makes of
        them.
    """
    d = protocol["display"]
    return synthetic_calibration(
        max_cd_m2=d["max_cd_m2"],
        black_cd_m2=d["black_cd_m2"],
        bit_depth=d["bit_depth"],
        label=f"SYNTHETIC calibration of '{d['name']}' from its protocol (gamma 2.2)",
    )


def package_versions(names=PACKAGES) -> dict[str, str]:
    """Installed versions of ``names`` (``'not installed'`` where absent), for provenance.

    Parameters
    ----------
    names
        Distribution names as pip knows them; default :data:`PACKAGES`, what a set's images
        depend on.

    Returns
    -------
    dict of str to str
        Each name's installed version.
    """
    versions = {}
    for name in names:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def _profile_plots(
    out: Path, groups_by: tuple[str, str], images: dict, geometry: dict
) -> list[str]:
    from matplotlib.figure import Figure

    written = []
    pixel = geometry["pixel_deg"]
    kind, key = groups_by
    groups: dict[str, list] = {}
    for name, info in images.items():
        if info["kind"] == kind:
            groups.setdefault(info[key], []).append((name, info))
    for group, members in groups.items():
        figure = Figure(figsize=(2.0 * len(members), 4.2), dpi=110)
        axes = figure.subplots(2, len(members))
        axes = np.atleast_2d(axes).reshape(2, len(members))
        for column, (_name, info) in enumerate(members):
            img = info["img"]
            row = img.shape[0] // 2
            axes[0, column].imshow(img, cmap="gray", vmin=0, vmax=img.max() or 1)
            axes[0, column].set_axis_off()
            label = info.get("label") or f"{info.get('level', '')}"
            axes[0, column].set_title(label, fontsize=9)
            offsets = (np.arange(img.shape[1]) - img.shape[1] // 2) * pixel
            axes[1, column].plot(offsets, img[row], lw=0.8)
            axes[1, column].set_xlabel("deg", fontsize=7)
            axes[1, column].tick_params(labelsize=6)
        axes[1, 0].set_ylabel("cd/m²", fontsize=8)
        figure.suptitle(f"{key} {group}: images and profiles through the centre", fontsize=10)
        figure.tight_layout()
        name = f"profiles_{group}.png"
        with atomic_path(out / name) as temporary:
            figure.savefig(temporary, format="png", metadata={"Software": None})
        written.append(name)
    return written


def build_stimulus_set(
    protocol: Protocol,
    out: str | Path,
    *,
    calibration: Calibration | None = None,
    progress=progress_bar,
    accept_mismatch: bool = False,
    inputs: Sequence[str | Path] = (),
) -> dict:
    """Build a study's stimulus set into folder ``out`` and return its manifest.

    Parameters
    ----------
    protocol
        A validated protocol of a paradigm that shows images (matching, staircase).
    out
        Output folder: new, empty, or an earlier stimulus set, which is replaced whole once
        the new set is complete (a folder holding anything else is refused).
    calibration
        The display calibration; default: the protocol display's synthetic calibration, which
        the manifest marks as synthetic.
    progress
        ``progress(done, total, what)``; default a text bar on stderr; None for silence.
    accept_mismatch
        Build although the calibration's white is not the protocol display's (a set for
        another display, knowingly; sessions check again).
    inputs
        Other files the set is made from (the calibration's file), refused inside ``out``
        as the protocol file and its EXR backgrounds are: the rebuild would delete them.

    Raises
    ------
    ValueError
        For a protocol without stimuli, a calibration whose bit depth is not the display's or
        (unless ``accept_mismatch``) whose white is not its ``max_cd_m2`` within its
        ``white_tolerance`` (:func:`glarelab.display.checks.refuse_other_display`: the images
        would be encoded for another display, most of their pixels clipped), a calibration no
        calibration file can hold (:meth:`glarelab.display.calibration.Calibration.checked`: a
        status ``passed`` without verification measurements), or an ``out`` that is a file or
        a folder holding something other than a stimulus set, or an EXR background whose
        relative path leaves the protocol's folder (``..``: the set keeps a copy under it).
    """
    if not shows_images(protocol):
        raise ValueError(
            f"the {protocol.study} protocol's paradigm ({protocol.paradigm}) shows no images: "
            "there is no stimulus set to build"
        )
    calibration = calibration or default_calibration(protocol)
    calibration = calibration.checked()  # one made in Python, as its file would be read
    from glarelab.display.checks import refuse_other_display

    refuse_other_display(
        protocol,
        calibration,
        accept_mismatch=accept_mismatch,
        codes="the set's images are that display's codes",
        encoded="the set would be encoded for another display (luminances above its white "
        "clipped)",
        anyway="build anyway with --accept-mismatch calibration (sessions check again)",
    )
    # a second build into it at once: refused
    with output_lock(out, "stimulus set build", what="stimulus set"):
        return _build_into(protocol, out, calibration, progress, [*map(Path, inputs)])


def _build_into(
    protocol: Protocol, out: str | Path, calibration: Calibration, progress, inputs: list[Path]
) -> dict:
    """:func:`build_stimulus_set` once its calibration is checked and ``out`` held."""
    if (
        Path(out).is_dir()
        and not (Path(out) / LISTING).exists()
        and (Path(out) / MANIFEST).is_file()
        and not verify_stimulus_set(out)
    ):
        record_files(Path(out), "stimulus set")  # a whole set of an earlier version: its own
    final = check_replaceable(
        out, kind="stimulus set", what="stimulus set", inputs=_protocol_inputs(protocol) + inputs
    )
    edited = _edited_since_built(final)
    if edited:  # a set listed before the listing kept contents: its manifest says
        shown = ", ".join(edited[:3]) + (f" and {len(edited) - 3} more" if len(edited) > 3 else "")
        raise ValueError(
            f"{final} holds files edited since glarelab wrote them ({shown}); the stimulus set "
            "replaces its folder whole, so copy what you added elsewhere and remove the edited "
            "files, or give another folder as --out (nothing was changed)"
        )
    _kept_backgrounds(protocol)  # a background the set cannot keep: before the rendering
    stimuli = paradigm_stimuli(protocol)
    refused = check_kernels(stimuli.kernels(protocol))  # before minutes of rendering
    if refused:
        raise ProtocolError(protocol.source, refused)
    built = stimuli.build(protocol, progress=progress)
    out = staging_folder(final)
    try:
        manifest = _write_set(out, protocol, built, calibration)
        replace_folder(out, final, kind="stimulus set")
        _remember_proof(hashlib.sha256((final / MANIFEST).read_bytes()).hexdigest())
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return manifest


def _edited_since_built(folder: Path) -> list[str]:
    """The files of the set in ``folder`` whose content differs from its manifest's record (none
    where there is no readable manifest)."""
    try:
        listed = _manifest_of(folder)["files"]
    except (OSError, ValueError):
        return []
    return [
        name
        for name, expected in sorted(listed.items())
        if (folder / name).is_file()
        and not (folder / name).is_symlink()
        and _sha256(folder / name) != expected
    ]


def _exr_paths(value) -> list[str]:
    """The ``path`` of every EXR background in a protocol table."""
    if isinstance(value, dict):
        found = [value["path"]] if value.get("kind") == "exr" and "path" in value else []
        return found + [p for v in value.values() for p in _exr_paths(v)]
    if isinstance(value, list):
        return [p for v in value for p in _exr_paths(v)]
    return []


def _protocol_inputs(protocol: Protocol) -> list[Path]:
    """The files a build reads from its protocol: the protocol file and its EXR backgrounds
    (a set replaced whole must not hold them: its rebuild would delete them)."""
    inputs = [Path(protocol.source)] if Path(protocol.source).is_file() else []
    folder = protocol.folder if protocol.folder is not None else Path.cwd()
    for name in _exr_paths(protocol.data):
        inputs.append(Path(name) if Path(name).is_absolute() else folder / name)
    return inputs


def _kept_backgrounds(protocol: Protocol) -> list[str]:
    """The EXR backgrounds a set keeps a copy of in its folder :data:`BACKGROUNDS`, under the
    protocol's relative path, so that it is proven from its own copy anywhere (an absolute path
    is read where it is)."""
    kept = []
    for name in sorted(set(_exr_paths(protocol.data))):
        path = Path(name)
        if path.is_absolute():
            continue
        if ".." in path.parts or not path.parts:
            raise ValueError(
                f"background.path = {name!r}: the stimulus set keeps a copy of the background "
                "under its path relative to the protocol file, so it must not leave the "
                "protocol's folder ('..'); move the EXR beside the protocol or below its folder, "
                "or give its absolute path"
            )
        kept.append(path.as_posix())
    return kept


def _write_set(out: Path, protocol: Protocol, built: dict, calibration: Calibration) -> dict:
    images = built["images"]
    records = {}
    for name, info in images.items():
        # the luminances as the EXR keeps them (float32): its PNG codes are their encoding,
        # the codes a session encodes from the EXR
        img = np.asarray(info["img"], dtype=np.float32).astype(np.float64)
        write_exr(out / f"{name}.exr", img.astype(np.float32))
        files = [f"{name}.exr"]
        record = {k: v for k, v in info.items() if k != "img"}
        if info["kind"] != "component":  # display luminances: encode them for the display
            codes, report = calibration.encode(img)
            write_display_png(out / f"{name}.png", codes, calibration.bit_depth)
            files.append(f"{name}.png")
            if calibration.bit_depth > 8:  # the display's own codes, beside the 8-bit copy
                deep = codes_png(name, calibration.bit_depth)
                write_codes(out / deep, codes, calibration.bit_depth)
                files.append(deep)
            record["encoding"] = {
                "above_max": report.above_max,
                "below_black": report.below_black,
                "max_error_cd_m2": report.max_error_cd_m2,
            }
        record["files"] = files
        record["shape"] = list(img.shape)
        records[name] = record
    groups_by = paradigm_stimuli(protocol).profile_groups
    plots = _profile_plots(out, groups_by, images, built["geometry"]) if groups_by else []
    for name, pixels in sorted(built.get("previews", {}).items()):  # a sequence at a glance
        with atomic_path(out / name) as temporary:
            Image.fromarray(pixels).save(temporary, format="PNG")
        plots.append(name)
    write_text(out / INDEX, _index(protocol, calibration, records, plots, built["geometry"]))
    files = sorted(f for r in records.values() for f in r["files"]) + plots + [INDEX]
    for name in _kept_backgrounds(protocol):  # the set is proven from this copy
        source = protocol.folder / name if protocol.folder is not None else Path(name)
        (out / BACKGROUNDS / name).parent.mkdir(parents=True, exist_ok=True)
        write_bytes(out / BACKGROUNDS / name, source.read_bytes())
        files.append(f"{BACKGROUNDS}/{name}")
    manifest = {
        "format": FORMAT,
        "study": protocol.study,
        "paradigm": protocol.paradigm,
        "protocol": protocol.data,
        "protocol_sha256": protocol.sha256,
        "calibration": calibration.to_json(),
        "calibration_sha256": hashlib.sha256(
            json.dumps(calibration.to_json(), sort_keys=True).encode()
        ).hexdigest(),
        "seed": protocol.seed,
        "geometry": built["geometry"],
        "parameters": built["parameters"],
        "images": records,
        "plots": plots,
        "packages": package_versions(),
        "files": {f: _sha256(out / f) for f in files},
    }
    write_text(out / MANIFEST, json.dumps(manifest, indent=2, sort_keys=True) + "\n")
    return manifest


def _index(protocol: Protocol, calibration: Calibration, records: dict, plots, geometry) -> str:
    """The set's README.md: what each file holds, how to read the PNGs, and every image."""
    top = 2**calibration.bit_depth - 1
    colour = any(len(record["shape"]) == 3 for record in records.values())
    exr = (
        "linear RGB in cd/m², channels `R`, `G`, `B`"
        if colour
        else ("linear luminance in cd/m², channel `Y`")
    )
    kind = "RGB" if colour else "greyscale"
    bits = calibration.bit_depth
    if bits == 8:
        png = [
            f"- `NAME.png`: the drive codes that show it on the display, 0-{top}, through the "
            f"calibration: an 8-bit {kind} PNG whose samples are the codes. PsychoPy shows it "
            "code for code, drawn by its file name (`visual.ImageStim(win, image='NAME.png', "
            "units='pix')`, or Builder's Image component with units `pix`, an empty size and "
            "interpolation off), and so does any image viewer. Images the sessions compose "
            "from parts (kind `component`) have no PNG.",
        ]
    else:
        png = [
            f"- `NAME_{bits}bit.png`: the drive codes that show it on the display, 0-{top}, "
            f"through the calibration: a 16-bit {kind} PNG of the codes scaled to the full "
            f"16-bit range, `value = round(code × 65535 / {top})`, with an `sBIT` chunk "
            f"recording the true bit depth ({bits}); the codes are `round(value × {top} / "
            f"65535)` (or `value >> {16 - bits}`), as "
            "`glarelab.stimuli.stimulus_set.read_png_codes` reads them. PsychoPy shows them "
            f"code for code on a {bits}-bit window through "
            "`glarelab.frontend.psychopy_plugin.SetImageStim(win, image='NAME.png')` "
            "(README: Stimuli in your own PsychoPy experiment).",
            f"- `NAME.png`: the same image at 8 bits, an 8-bit {kind} PNG of the nearest 8-bit "
            f"codes, `round(code × 255 / {top})`: what an image viewer or an 8-bit screen "
            "shows (drawn by a plain `ImageStim` it is not the display's codes). Images the "
            "sessions compose from parts (kind `component`) have no PNG.",
        ]
    lines = [
        f"# Stimulus set: {protocol.title}",
        "",
        f"Built by glarelab from the protocol `{protocol.study}` (sha256 "
        f"`{protocol.sha256[:16]}…`) for a {calibration.bit_depth}-bit display, "
        f"{calibration.black_cd_m2:.4g}-{calibration.max_cd_m2:.4g} cd/m² (calibration status "
        f"`{calibration.status}`). `manifest.json` holds every parameter and the sha256 of "
        "every file; `glarelab stimuli verify FOLDER` checks them.",
        "",
        "## Files",
        "",
        f"- `NAME.exr`: the image's {exr} (float32 OpenEXR), before the display.",
        *png,
        "- `profiles_*.png`: the images with their luminance profile through the centre.",
        "",
        "## Images",
        "",
        "| file | kind | parameters | size (px) |",
        "| --- | --- | --- | --- |",
    ]
    for record in records.values():
        parameters = ", ".join(
            f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
            for k, v in record.items()
            if k not in ("kind", "files", "shape", "encoding")
        )
        files = ", ".join(f"`{f}`" for f in record["files"])
        shape = " × ".join(str(x) for x in record["shape"][:2][::-1])
        lines.append(f"| {files} | {record['kind']} | {parameters} | {shape} |")
    lines += ["", f"Geometry: {', '.join(f'{k} = {v}' for k, v in geometry.items())}.", ""]
    if plots:
        lines += ["Profile plots: " + ", ".join(f"`{p}`" for p in plots) + ".", ""]
    return "\n".join(lines)


def _manifest_of(folder: Path, data: bytes | None = None) -> dict:
    """The set's manifest (from ``data``, its bytes, when given), checked to be a JSON object
    that lists its files."""
    path = folder / MANIFEST
    if data is None and not path.is_file():
        raise ValueError(f"{path}: missing (not a stimulus set?)")
    try:
        manifest = loads_json(path.read_bytes() if data is None else data)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not valid JSON ({error})") from None
    if not isinstance(manifest, dict):
        raise ValueError(f"{path}: must be a JSON object; it is a {type(manifest).__name__}")
    files = manifest.get("files")
    if not isinstance(files, dict) or not files:
        raise ValueError(f"{path}: must list the set's files and their sha256 under 'files'")
    for name, digest in files.items():
        parts = Path(name).parts  # a file of the set, or of a folder in it (a background)
        unsafe = Path(name).is_absolute() or not parts or {".", ".."} & {*name.split("/")}
        if unsafe or not isinstance(digest, str):
            raise ValueError(f"{path}: the file entry {name!r} is not a file name of the set")
    return manifest


def verify_stimulus_set(folder: str | Path) -> list[str]:
    """Check a stimulus set: the manifest is a JSON object listing every file, and the folder
    holds exactly those files, each with its recorded sha256.

    Also checked: every image's files are hashed, each image points at its own file, and the
    manifest's protocol hashes to its ``protocol_sha256``.

    Parameters
    ----------
    folder
        The set's folder.

    Returns
    -------
    list of str
        The problems, each naming the file: missing, changed, or not in the manifest (empty
        when the set is intact).
    """
    folder = as_path(folder, what="stimulus set folder")
    if not folder.is_dir():
        return [f"{folder}: not a folder"]
    try:
        manifest = _manifest_of(folder)
    except ValueError as error:
        return [str(error)]
    problems = []
    listed = manifest["files"]
    for name, expected in sorted(listed.items()):
        path = folder / name
        if not path.is_file():
            what = special_file(path) or ("a folder" if path.is_dir() else None)
            problems.append(f"{name}: {what}, not the file" if what else f"{name}: missing")
        elif _sha256(path) != expected:
            problems.append(f"{name}: changed (sha256 differs from the manifest)")
    # the folders a kept background is in (its path relative to the protocol's folder)
    folders = {p.as_posix() for name in listed for p in Path(name).parents} - {"."}
    entries = [*folder.iterdir()]
    for name in sorted(folders):
        if (folder / name).is_dir() and not (folder / name).is_symlink():
            entries += (folder / name).iterdir()
    for path in sorted(entries):
        name = path.relative_to(folder).as_posix()
        if name not in listed and name not in (MANIFEST, LISTING) and name not in folders:
            if is_system_file(path.name):
                continue  # a file browser's .DS_Store, ._NAME
            problems.append(f"{name}: not in the manifest (added after the build?)")
    images = manifest.get("images")
    if isinstance(images, dict):
        for name, record in sorted(images.items()):
            for file in record.get("files", []) if isinstance(record, dict) else []:
                if file not in listed:
                    problems.append(f"{file}: image {name}'s file is not hashed in the manifest")
                named = (f"{name}.exr", f"{name}.png")
                deep = file.removeprefix(f"{name}_").removesuffix("bit.png")
                if file not in named and not (deep.isdigit() and file.startswith(f"{name}_")):
                    # a build names each image's files after it
                    problems.append(f"{MANIFEST}: image {name} points at {file} (edited?)")
    else:
        problems.append(f"{MANIFEST}: has no table of images")
    # the protocol the set was built from is hashed as glarelab.protocols.core hashes it
    canonical = json.dumps(manifest.get("protocol"), sort_keys=True, separators=(",", ":"))
    if hashlib.sha256(canonical.encode()).hexdigest() != manifest.get("protocol_sha256"):
        problems.append(
            f"{MANIFEST}: its protocol table does not hash to its protocol_sha256 (edited?)"
        )
    return problems


def _proven_folder() -> Path:
    """Where the digests of manifests proven by a rebuild (or written by a build) on this
    machine are kept: ``proven-sets`` in :func:`glarelab.glare.models.cache.cache_root`."""
    return cache_root() / "proven-sets"


def _proof_key(manifest_sha256: str) -> Path:
    # a proof holds for this version of the builder only (its packages make the bytes)
    versions = hashlib.sha256(json.dumps(package_versions(), sort_keys=True).encode())
    return _proven_folder() / f"{manifest_sha256}-{versions.hexdigest()[:16]}"


def _remember_proof(manifest_sha256: str) -> None:
    with contextlib.suppress(OSError):  # a cache: a read-only home only costs a rebuild
        key = _proof_key(manifest_sha256)
        key.parent.mkdir(parents=True, exist_ok=True)
        write_text(key, "built or rebuilt identically by glarelab\n")


def _differences(found, rebuilt, where: str, out: list[str], limit: int = 8) -> None:
    """The keys at which two JSON values differ, as ``where.key: found X, rebuilt Y``."""
    if len(out) >= limit:
        return
    if isinstance(found, dict) and isinstance(rebuilt, dict):
        for key in sorted(set(found) | set(rebuilt), key=str):
            _differences(found.get(key), rebuilt.get(key), f"{where}.{key}", out, limit)
    elif found != rebuilt or type(found) is not type(rebuilt):
        shown = json.dumps(found)[:60], json.dumps(rebuilt)[:60]
        out.append(f"{where}: {shown[0]} in the manifest, {shown[1]} when rebuilt")


def _without_none(value):
    if isinstance(value, dict):
        return {k: _without_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [_without_none(v) for v in value]
    return value


def prove_stimulus_set(folder: str | Path, *, progress=None) -> list[str]:
    """Check a stimulus set against its protocol: its files against its manifest
    (:func:`verify_stimulus_set`), then the manifest itself, by rebuilding the set from the
    protocol and the calibration the manifest records and comparing every file byte for byte
    (builds are byte-reproducible). A manifest whose sha256s, geometry, image records or
    calibration were edited to match edited files does not rebuild to itself.

    A manifest proven once (or written by a build) on this machine, with these package
    versions, is remembered by its sha256 and not rebuilt again.

    Parameters
    ----------
    folder
        The set's folder.
    progress
        As for :func:`build_stimulus_set` (default: silent).

    Returns
    -------
    list of str
        The problems, each naming the file or the manifest key (empty when proven).
    """
    from glarelab.protocols import parse_protocol

    folder = Path(folder)
    problems = verify_stimulus_set(folder)
    if problems:
        return problems
    data = (folder / MANIFEST).read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    if _proof_key(digest).is_file():
        return []
    manifest = loads_json(data, source=folder / MANIFEST)
    try:
        # the manifest holds the protocol as validated (defaults filled in, unset keys None):
        # validated again without its unset keys, it must hash as it did
        protocol = parse_protocol(  # its EXR backgrounds are the set's copies
            _without_none(manifest["protocol"]),
            source=f"{folder / MANIFEST} protocol",
            folder=(folder / BACKGROUNDS).resolve(),
        )
        calibration = Calibration.from_json(
            manifest["calibration"], source=f"{folder / MANIFEST} calibration"
        )
    except (KeyError, TypeError, ValueError, ProtocolError) as error:
        return [f"{MANIFEST}: cannot be rebuilt to prove it ({error})"]
    if protocol.sha256 != manifest.get("protocol_sha256"):
        return [f"{MANIFEST}: its protocol table does not hash to its protocol_sha256 (edited?)"]
    if not shows_images(protocol):
        return [f"{MANIFEST}: its protocol ({protocol.paradigm}) shows no images"]
    import tempfile

    with tempfile.TemporaryDirectory(prefix="glarelab-proof-") as scratch:
        built = paradigm_stimuli(protocol).build(protocol, progress=progress)
        _write_set(Path(scratch), protocol, built, calibration)
        rebuilt = json.loads((Path(scratch) / MANIFEST).read_bytes())  # as written, in JSON
    found = {k: v for k, v in manifest.items() if k != "packages"}
    expected = {k: v for k, v in rebuilt.items() if k != "packages"}
    out: list[str] = []
    _differences(found, expected, "manifest", out)
    if out:
        packages = manifest.get("packages")
        if packages != rebuilt["packages"]:
            out.append(
                f"{MANIFEST}: built with other package versions ({packages}); this rebuild "
                f"used {rebuilt['packages']}, which may explain the differences"
            )
        return [
            f"{MANIFEST} does not match a rebuild from its own protocol and calibration: {d}"
            for d in out
        ]
    _remember_proof(digest)
    return []


def compose(terms, image) -> np.ndarray:
    """The image ``Σ weight × image(name)`` of ``terms``, ``[(name, weight), …]``: how sessions
    show images that depend on a setting (a target's disk, a staircase's disc) from the set's
    components.

    Parameters
    ----------
    terms
        ``(name, weight)`` pairs, at least one: the images to add and the factor of each
        (cd/m² for a coverage image, 1 for a luminance image).
    image
        ``image(name)``: the set's image of that name (cd/m² or coverage), as an array.

    Returns
    -------
    numpy.ndarray
        The sum, cd/m².

    Raises
    ------
    ValueError
        If ``terms`` is empty.
    """
    total = None
    for name, weight in terms:
        part = image(name) * float(weight)
        total = part if total is None else total + part
    if total is None:
        raise ValueError("terms must name at least one image")
    return total


class SetChanged(ValueError):
    """A file of a stimulus set differs from the manifest the set was read with: the set was
    rebuilt or edited while in use."""


class StimulusSet:
    """A built stimulus set, read back: its manifest and its images (float64 cd/m², read once).

    The manifest is read once; every image read afterwards is checked against the sha256 that
    manifest lists, so a set rebuilt or edited while in use (a session running on it) is
    refused at its first changed image rather than shown half old, half new.

    Parameters
    ----------
    folder
        The set's folder (verify it first: :func:`verify_stimulus_set`).

    Attributes
    ----------
    manifest_sha256
        The sha256 of the manifest's bytes as read: what a session records and compares with
        the manifest it verified.
    """

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        path = self.folder / MANIFEST
        if not path.is_file():
            raise ValueError(f"{path}: missing (not a stimulus set?)")
        data = path.read_bytes()
        self.manifest_sha256 = hashlib.sha256(data).hexdigest()
        self.manifest = _manifest_of(self.folder, data)
        self.geometry = self.manifest["geometry"]
        self._images: dict[str, np.ndarray] = {}

    def image(self, name: str) -> np.ndarray:
        """An image of the set, read from its file the first time and kept.

        Parameters
        ----------
        name
            The image's name in the manifest (its EXR file without the suffix).

        Returns
        -------
        numpy.ndarray
            float64, cd/m² (a coverage image: 0-1).
        """
        if name not in self._images:
            self._images[name] = self.read(name)
        return self._images[name]

    def read(self, name: str) -> np.ndarray:
        """An image read from its file, not kept (a sequence's frames are shown once).

        Parameters
        ----------
        name
            The image's name in the manifest (its EXR file without the suffix).

        Returns
        -------
        numpy.ndarray
            float64, cd/m².

        Raises
        ------
        SetChanged
            If the file is not the one the manifest lists (its sha256 differs, or it was
            replaced while being read).
        """
        file = f"{name}.exr"
        path = self.folder / file
        expected = self.manifest["files"].get(file)
        if expected is None:
            raise SetChanged(f"stimulus set {self.folder}: {file} is not in its manifest")
        before = os.stat(path)
        if _sha256(path) != expected:
            raise SetChanged(
                f"stimulus set {self.folder}: {file} changed since the set was verified "
                "(rebuilt or edited while in use); nothing of it was shown"
            )
        image = read_exr(path).astype(np.float64)
        after = os.stat(path)
        if (before.st_ino, before.st_size, before.st_mtime_ns) != (
            after.st_ino,
            after.st_size,
            after.st_mtime_ns,
        ):
            raise SetChanged(
                f"stimulus set {self.folder}: {file} was replaced while it was read (rebuilt "
                "while in use); nothing of it was shown"
            )
        return image

    def compose(self, terms) -> np.ndarray:
        """The image ``Σ weight × image(name)`` of ``terms`` (:func:`compose`).

        Parameters
        ----------
        terms
            ``(name, weight)`` pairs of the set's images, at least one.

        Returns
        -------
        numpy.ndarray
            The sum, cd/m².
        """
        return compose(terms, self.image)


CACHE_BUILD_WAIT_S = 3600.0  # longest wait for another process building a cached set


def cached_stimulus_set(
    protocol: Protocol, *, root: Path | None = None, progress=progress_bar
) -> Path:
    """The protocol's stimulus set with its display's synthetic calibration, built once into a
    cache folder and reused while it verifies (simulated sessions need the images, not a lab
    calibration).

    Parameters
    ----------
    protocol
        A validated protocol that shows images.
    root
        The cache folder; default ``None``: :func:`glarelab.glare.models.cache.cache_root`
        (``$GLARELAB_CACHE``, else the user's cache folder).
        The set is ``ROOT/sets/STUDY-SHA``, named by the protocol's hash.
    progress
        ``progress(done, total, what)`` while a set is built; default :func:`progress_bar`.

    Returns
    -------
    pathlib.Path
        The set's folder, verified.
    """
    if root is None:
        root = cache_root()
    folder = Path(root) / "sets" / f"{protocol.study}-{protocol.sha256[:16]}"
    if (folder / MANIFEST).is_file() and not verify_stimulus_set(folder):
        return folder
    # one process checks and builds at a time; the others wait and then use its set (the
    # simulated sessions of a batch run at once; a second build would have been refused,
    # and its clearing of a damaged set could remove the one just built)
    with waiting_for(
        folder.parent / f".{folder.name}.cache.lock",
        wait_s=CACHE_BUILD_WAIT_S,
        poll_s=0.2,
        what=f"{folder} (a cached stimulus set being built; run again when it has ended)",
    ):
        if (folder / MANIFEST).is_file() and not verify_stimulus_set(folder):
            return folder  # built by the process waited for
        shutil.rmtree(folder, ignore_errors=True)  # the cache's own folder, damaged: rebuilt
        build_stimulus_set(
            protocol, folder, calibration=default_calibration(protocol), progress=progress
        )
        return folder
