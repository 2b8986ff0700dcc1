"""Digitised kernels kept on disk between runs: :class:`KernelCache`.

Digitising a kernel costs far more than using it (a 4095² Vos kernel takes longer than the
render it serves), and a lab renders the same model at the same pixel size again and again:
every image of a stimulus set, every run of ``glarelab render``, every worker of a sweep. The
cache keeps each kernel in a file of the user's cache folder (``platformdirs``; on Linux
``$XDG_CACHE_HOME/glarelab/kernels``, by default ``~/.cache/glarelab/kernels``).

What makes a cached kernel the kernel that would be digitised:

- **The key** is a SHA-256 of the model's class and ``repr`` (a frozen dataclass lists every
  parameter), a digest of the fields left out of the ``repr`` (a wave-optics model's obstacle
  image: its bytes, shape and dtype), the pixel size (exactly, as ``float.hex``), the kernel
  shape, colour or luminance, glarelab's version and a fingerprint of the ``glare`` package's
  source (so a change to the digitisation in a development tree is never served stale kernels).
  A model whose ``repr`` does not pin down its parameters (an object address ``at 0x…``, or an
  array shortened with ``...``) is not cached.
- **Every file is checked**: a CRC-32 of the whole entry is stored at its end (zlib's, 2.6×
  faster than SHA-256 on a 33 MB entry, and made for catching accidental damage); an entry
  that does not match (a torn write, a flipped bit, a truncated file) is removed and the
  kernel is digitised again. So is one whose CRC matches but whose kernel could not have been
  digitised (an entry rewritten by another tool): values that are not finite or are
  negative, a shape other than the one asked for, or values and ``energy_outside`` that do
  not add up to the light the model admits (1, or its ``admitted_share``) within
  :data:`ENERGY_TOLERANCE`.
- **Writes are atomic** (:mod:`glarelab.files.atomic`, as every file the suite writes): a
  kernel is written to a temporary file in the cache folder, flushed to the disk and renamed
  onto its name, so two processes filling the cache at once each leave a complete entry, and a
  reader never sees half of one.
- **A full disk** (or any other failure to write) skips the entry with a warning; the kernel
  just digitised is returned as it is.
- **The size is bounded** (:data:`DEFAULT_MAX_BYTES`, or ``GLARELAB_CACHE_MAX_MB``): after a
  write the least recently used entries (by modification time, refreshed on every hit) are
  removed until the folder fits.

A kernel symmetric in both axes (every radial model) is stored as its quadrant, a quarter of
the bytes. Environment: ``GLARELAB_CACHE`` moves the cache (to its ``kernels`` folder);
``GLARELAB_NO_CACHE=1`` turns it off (the command line's ``--no-cache``). ``glarelab cache
info`` and ``glarelab cache clear`` show and empty it.
"""

from __future__ import annotations

import ast
import dataclasses
import hashlib
import json
import math
import os
import stat
import struct
import time
import warnings
import zlib
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import numpy as np

from glarelab.files.atomic import PARTIAL, atomic_path, special_file
from glarelab.files.inputs import loads_json
from glarelab.glare.models.digitise import Kernel, mirror_quadrant

__all__ = [
    "CACHE_DIR_ENV",
    "DEFAULT_MAX_BYTES",
    "ENERGY_TOLERANCE",
    "MAX_MB_ENV",
    "NO_CACHE_ENV",
    "KernelCache",
    "array_sha256",
    "cache_root",
    "check_cache",
    "default_cache",
    "resolve_cache",
]

CACHE_DIR_ENV = "GLARELAB_CACHE"  # the suite's cache root (stimulus sets of observers too)
NO_CACHE_ENV = "GLARELAB_NO_CACHE"
MAX_MB_ENV = "GLARELAB_CACHE_MAX_MB"
MIN_MB = 1  # a smaller GLARELAB_CACHE_MAX_MB is refused: it would keep no kernel
DEFAULT_MAX_BYTES = 2 * 2**30  # 2 GiB: about sixty 4095² kernels (stored as quadrants)
FORMAT = 1  # raise when the file layout or the meaning of a key changes
SUFFIX = ".kernel"
_MAGIC = b"GLAREKERNEL\x00"
_DIGEST_BYTES = 4
# |sum + energy_outside - admitted share| of a kernel read back: digitised kernels are within
# 1e-15; the float64 sum of a 4095² kernel added one by one errs by at most n ε ≈ 2e-9; an
# error of 1e-6 in the glare's energy is a thousandth of a 10-bit display's code step
ENERGY_TOLERANCE = 1e-6
_STALE_PART_S = 3600.0  # temporary files older than this are left over from a crash


def _source_fingerprint(model: object) -> str:
    """SHA-256 of the ``glare`` package's modules (and of the model's own module when it
    lives elsewhere): kernels digitised by other code are never served."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parents[1]  # glarelab.glare, its subpackages too
    files = sorted(package.rglob("*.py"))
    module = getattr(type(model), "__module__", "")
    try:
        import sys

        extra = getattr(sys.modules.get(module), "__file__", None)
    except Exception:  # pragma: no cover - a module without a file
        extra = None
    if extra and Path(extra).resolve().parent != package:
        files.append(Path(extra).resolve())
    for path in files:
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def array_sha256(array: np.ndarray) -> str:
    """The sha256 of an array's shape, dtype and values (in C order): two arrays get one
    digest only when they are the same array.

    Parameters
    ----------
    array
        Any NumPy array.

    Returns
    -------
    str
        The hexadecimal digest.

    Examples
    --------
    >>> a = np.zeros((2, 3))
    >>> array_sha256(a) == array_sha256(a.reshape(3, 2))
    False
    >>> array_sha256(a) == array_sha256(np.asfortranarray(a))
    True
    """
    contiguous = np.ascontiguousarray(array)
    digest = hashlib.sha256(f"{contiguous.shape} {contiguous.dtype.str}".encode())
    digest.update(contiguous.tobytes())
    return digest.hexdigest()


def _hidden_fields(model: object, prefix: str = "") -> list[str]:
    """A digest of each dataclass field left out of ``model``'s repr (a wave-optics model's
    obstacle image: its bytes, shape and dtype), in the models it holds too (a hybrid's wave
    model), so two models that differ there get two keys."""
    if not dataclasses.is_dataclass(model) or isinstance(model, type):
        return []
    found = []
    for spec in dataclasses.fields(model):
        value = getattr(model, spec.name, None)
        name = f"{prefix}{spec.name}"
        if spec.repr:
            found += _hidden_fields(value, f"{name}.")
            continue
        if isinstance(value, np.ndarray):
            found.append(f"{name}={array_sha256(value)}")
        else:
            found.append(f"{name}={value!r}")
    return found


def _version() -> str:
    try:
        return metadata.version("glarelab")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a bare source tree
        return "unknown"


def _literal(description: dict) -> str | None:
    """``repr`` of a description that reads back equal (``ast.literal_eval``), else None."""
    text = repr(description)
    try:
        same = ast.literal_eval(text) == description
    except (ValueError, SyntaxError, TypeError):
        return None
    return text if same is True else None


def cache_root() -> Path:
    """The folder of glarelab's caches (kernels, the observers' stimulus sets, the proofs of
    sets): ``$GLARELAB_CACHE``, a leading ``~`` expanded (a quoted ``'~/cache'`` made a
    folder named ``~``), else the user's cache folder (``platformdirs.user_cache_dir``,
    which honours ``XDG_CACHE_HOME``).

    Returns
    -------
    pathlib.Path
        The folder (made when first written to).
    """
    root = os.environ.get(CACHE_DIR_ENV)
    if root:
        return Path(root).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("glarelab"))


class KernelCache:
    """A folder of digitised kernels, keyed by everything that decides them.

    Parameters
    ----------
    directory
        The folder; ``None``: ``kernels`` in ``$GLARELAB_CACHE``, else in the user's cache
        folder (``platformdirs.user_cache_dir('glarelab')``, which honours
        ``XDG_CACHE_HOME``).
    max_bytes
        Largest total size of the entries, a whole number of bytes >= 1 (not a bool);
        ``None``: ``$GLARELAB_CACHE_MAX_MB`` MiB (at least 1), else
        :data:`DEFAULT_MAX_BYTES`.

    Raises
    ------
    ValueError
        For a size that is not a positive whole number of bytes, or a
        ``GLARELAB_CACHE_MAX_MB`` that is not a number >= 1.

    Examples
    --------
    >>> import tempfile
    >>> from glarelab.glare import VosGlare
    >>> cache = KernelCache(tempfile.mkdtemp())
    >>> first = cache.kernel(VosGlare(), 0.1, (21, 21))
    >>> again = cache.kernel(VosGlare(), 0.1, (21, 21))  # read back, not digitised
    >>> bool(np.array_equal(first.values, again.values)), cache.info()["entries"]
    (True, 1)
    """

    def __init__(self, directory: str | os.PathLike | None = None, *, max_bytes=None) -> None:
        if directory is None:
            root = cache_root()
            if root.exists() and not root.is_dir():
                raise ValueError(
                    f"{CACHE_DIR_ENV}={root}: not a folder; set it to a folder (the kernel cache "
                    "and the observers' stimulus sets are kept there), or unset it"
                )
            directory = root / "kernels"
        self.directory = Path(directory)
        if max_bytes is None:
            megabytes = os.environ.get(MAX_MB_ENV)
            max_bytes = DEFAULT_MAX_BYTES if not megabytes else _megabytes(megabytes)
        try:
            limit = math.nan if isinstance(max_bytes, bool) else float(max_bytes)
        except (TypeError, ValueError):
            limit = math.nan
        if not math.isfinite(limit) or limit < 1 or limit != math.floor(limit):
            raise ValueError(
                f"max_bytes must be a positive whole number of bytes, got {max_bytes!r}"
            )
        self.max_bytes = int(limit)
        self._fingerprints: dict[str, str] = {}
        self._warned = False

    def __repr__(self) -> str:
        return f"KernelCache({str(self.directory)!r}, max_bytes={self.max_bytes})"

    # keys ---------------------------------------------------------------------------------
    def key(
        self, model: object, pixel_deg: float, shape: tuple[int, int], *, colour: bool
    ) -> str | None:
        """The entry's name for a model's kernel, or ``None`` when the model cannot be keyed
        (its ``repr`` does not pin down its parameters).

        Parameters
        ----------
        model
            The glare model; its class, its ``repr`` (its parameters), a digest of the fields
            left out of the repr (an obstacle image's bytes, shape and dtype) and the source
            of its module are in the key, so an edited model never reads an old kernel.
        pixel_deg
            Visual angle of one pixel in degrees.
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether the kernel is the colour one.

        Returns
        -------
        str or None
            A SHA-256 hex digest, or None.
        """
        described = repr(model)
        if " at 0x" in described or "..." in described:
            return None
        module = type(model).__module__
        if module not in self._fingerprints:
            self._fingerprints[module] = _source_fingerprint(model)
        parts = [
            FORMAT,
            _version(),
            self._fingerprints[module],
            f"{module}.{type(model).__qualname__}",
            described,
            float(pixel_deg).hex(),
            [int(n) for n in shape],
            bool(colour),
        ]
        hidden = _hidden_fields(model)
        if any(" at 0x" in text for text in hidden):
            return None
        if hidden:  # an obstacle image: not in the repr, but it decides the kernel
            parts.append(hidden)
        return hashlib.sha256(json.dumps(parts).encode()).hexdigest()

    def path(self, key: str) -> Path:
        """The file of the entry ``key``.

        Parameters
        ----------
        key
            An entry's name (:meth:`key`).

        Returns
        -------
        pathlib.Path
            The entry's file in the cache folder.
        """
        return self.directory / f"{key}{SUFFIX}"

    # entries ------------------------------------------------------------------------------
    def get(self, key: str, shape: tuple[int, int] | None = None) -> Kernel | None:
        """The kernel stored under ``key``, or ``None`` (missing, or corrupt and removed).

        Parameters
        ----------
        key
            The entry's name (:meth:`key`). A hit marks the entry most recently used.
        shape
            The kernel shape ``(KH, KW)`` asked for; an entry of another is corrupt. Default
            None: any.

        Returns
        -------
        Kernel or None
            The kernel, or None.
        """
        path = self.path(key)
        try:
            data = _read_regular(path)
        except OSError:
            return None
        if data is None:  # a FIFO or device under an entry's name: read, it would block
            return None  # for ever; a miss, replaced by the next put (a rename over it)
        kernel = _decode(data, key, shape)
        if kernel is None:  # corrupt: never served, removed so that it is written again
            try:
                path.unlink()
            except OSError:
                pass
            return None
        try:
            os.utime(path)  # most recently used
        except OSError:
            pass
        return kernel

    def put(self, key: str, kernel: Kernel) -> bool:
        """Store a kernel under ``key``; False (and a warning) when it could not be written.

        Parameters
        ----------
        key
            The entry's name (:meth:`key`).
        kernel
            The kernel; one larger than the cache's ``max_bytes`` is not stored. The least
            recently used entries are evicted to make room.

        Returns
        -------
        bool
            Whether it was stored.
        """
        encoded = _encode(kernel, key)
        if encoded is None or len(encoded) > self.max_bytes:
            return False
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            path = self.path(key)
            if special_file(path) is not None:
                path.unlink()  # the cache's own entry's name: what is there is no kernel
            with atomic_path(path) as temporary:
                temporary.write_bytes(encoded)
        except OSError as error:
            if not self._warned:
                warnings.warn(
                    f"the kernel cache in {self.directory} could not be written ({error}); "
                    "kernels are digitised without it",
                    UserWarning,
                    stacklevel=3,
                )
                self._warned = True
            return False
        self._evict(keep=self.path(key))
        return True

    def kernel(
        self,
        model,
        pixel_deg: float,
        shape: tuple[int, int],
        *,
        colour: bool = False,
        build: Callable[[], Kernel] | None = None,
        log: Callable[[str], None] | None = None,
    ) -> Kernel:
        """The model's kernel from the cache, or digitised (``build()``, by default
        ``model.kernel(pixel_deg, shape, colour=colour)``) and stored.

        Parameters
        ----------
        model
            The glare model; its class, its ``repr`` (its parameters), a digest of the fields
            left out of the repr (an obstacle image's bytes, shape and dtype) and the source
            of its module are in the key, so an edited model never reads an old kernel.
        pixel_deg
            Visual angle of one pixel in degrees.
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether the colour kernel is wanted; default False.
        build
            ``build()`` digitises the kernel on a miss; default None:
            ``model.kernel(pixel_deg, shape, colour=colour)``.
        log
            Called with a message when the kernel is read from the cache; default None.

        Returns
        -------
        Kernel
            The kernel.
        """
        key = self.key(model, pixel_deg, shape, colour=colour)
        if key is not None:
            cached = self.get(key, shape)
            if cached is not None:
                if log is not None:
                    log(f"kernel {shape[0]} × {shape[1]} read from the cache ({self.directory})")
                return cached
        made = build() if build is not None else model.kernel(pixel_deg, shape, colour=colour)
        if key is not None:
            self.put(key, made)
        return made

    # the folder ---------------------------------------------------------------------------
    def _entries(self) -> list[tuple[float, int, Path]]:
        try:
            listing = list(os.scandir(self.directory))
        except OSError:
            return []
        entries = []
        now = time.time()
        for item in listing:
            try:
                info = item.stat()
            except OSError:
                continue
            if item.name.endswith(SUFFIX):
                entries.append((info.st_mtime, info.st_size, Path(item.path)))
            elif _temporary(item.name) and now - info.st_mtime > _STALE_PART_S:
                _remove(Path(item.path))
        return entries

    def _evict(self, keep: Path | None = None) -> None:
        entries = sorted(self._entries(), key=lambda e: e[0])
        total = sum(size for _, size, _ in entries)
        for _, size, path in entries:
            if total <= self.max_bytes:
                break
            if path == keep:
                continue
            if _remove(path):
                total -= size

    def info(self) -> dict:
        """``directory``, ``entries``, ``bytes`` and ``max_bytes`` of the cache."""
        entries = self._entries()
        return {
            "directory": str(self.directory),
            "entries": len(entries),
            "bytes": sum(size for _, size, _ in entries),
            "max_bytes": self.max_bytes,
        }

    def clear(self) -> int:
        """Remove every entry (and left-over temporary files); returns how many entries."""
        removed = 0
        try:
            listing = list(os.scandir(self.directory))
        except OSError:
            return 0
        for item in listing:
            if item.name.endswith(SUFFIX):
                removed += _remove(Path(item.path))
            elif _temporary(item.name):
                _remove(Path(item.path))
        return removed


def _read_regular(path: Path) -> bytes | None:
    """The bytes of ``path`` when it is a regular file, else None, without blocking: opened
    non-blocking (a FIFO opens at once) and checked before it is read."""
    descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    try:
        if not stat.S_ISREG(os.fstat(descriptor).st_mode):
            return None
        with os.fdopen(os.dup(descriptor), "rb") as handle:
            return handle.read()
    finally:
        os.close(descriptor)


def _temporary(name: str) -> bool:
    """Whether ``name`` is an entry being written (or left by a crash while written)."""
    return PARTIAL in name or name.endswith(".part")  # .part: written by glarelab < 0.3


def _remove(path: Path) -> bool:
    try:
        path.unlink()
    except OSError:
        return False
    return True


def _megabytes(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value <= 0:  # named here: max_bytes would show bytes
        raise ValueError(f"{MAX_MB_ENV} must be a positive number of MiB, got {text!r}")
    if value < MIN_MB:  # 1e-9 MiB kept nothing, and nothing said so
        raise ValueError(
            f"{MAX_MB_ENV} must be at least {MIN_MB} MiB (a smaller cache keeps no kernel; "
            f"GLARELAB_NO_CACHE=1 turns it off), got {text!r}"
        )
    return math.floor(value * 2**20)


NO_CACHE_VALUES = ("", "0", "1")
"""What ``GLARELAB_NO_CACHE`` may be: unset, empty or ``0`` (the cache is used), ``1`` (off)."""


def no_cache_from_env() -> bool:
    """Whether ``GLARELAB_NO_CACHE`` turns the cache off: ``1`` yes; unset, empty or ``0`` no.

    Returns
    -------
    bool
        True for ``1``.

    Raises
    ------
    ValueError
        For any other value (``maybe``, ``yes``, ``true``), naming the variable: a value
        that might mean either is not guessed.

    Examples
    --------
    >>> os.environ.get(NO_CACHE_ENV, "") in NO_CACHE_VALUES
    True
    """
    value = os.environ.get(NO_CACHE_ENV, "")
    if value not in NO_CACHE_VALUES:
        raise ValueError(
            f"{NO_CACHE_ENV} must be 1 (no kernel cache), 0 or unset (the cache), got {value!r}"
        )
    return value == "1"


def _encode(kernel: Kernel, key: str) -> bytes | None:
    """The file of an entry: magic, header length, JSON header, array bytes, CRC-32."""
    description = _literal(kernel.description)
    if description is None:
        return None
    if kernel.quadrant is not None:
        values, layout = np.ascontiguousarray(kernel.quadrant, dtype=np.float64), "quadrant"
    else:
        values = np.ascontiguousarray(kernel.values, dtype=np.float64)
        half = tuple(n // 2 for n in values.shape[:2])
        quadrant = values[half[0] :, half[1] :]
        layout = "full"
        if values.ndim >= 2 and np.array_equal(mirror_quadrant(quadrant), values):
            values, layout = np.ascontiguousarray(quadrant), "quadrant"
    outside = kernel.energy_outside
    header = {
        "key": key,
        "format": FORMAT,
        "layout": layout,
        "shape": list(values.shape),
        "pixel_deg": float(kernel.pixel_deg),
        "energy_outside": np.asarray(outside, float).tolist(),
        "energy_outside_array": isinstance(outside, np.ndarray),
        "quadrature_error": float(kernel.quadrature_error),
        "description": description,
    }
    text = json.dumps(header).encode()
    text += b" " * (-(len(_MAGIC) + 8 + len(text)) % 8)  # the array starts 8-byte aligned
    body = b"".join([_MAGIC, struct.pack("<Q", len(text)), text, values.tobytes()])
    return body + struct.pack("<I", zlib.crc32(body))


def _decode(data: bytes, key: str, shape: tuple[int, int] | None = None) -> Kernel | None:
    """The kernel of an entry's bytes, or None when they are not a whole, matching entry of a
    kernel that could have been digitised (:func:`_plausible`). The bytes' CRC-32 and the
    least of the values (the plausibility's one pass over them) are taken at once, each on a
    core (both release the GIL: 12 and 9 ms for a 2048² quadrant of a one-call render)."""
    from concurrent.futures import ThreadPoolExecutor

    if len(data) < len(_MAGIC) + 8 + _DIGEST_BYTES or not data.startswith(_MAGIC):
        return None
    body = memoryview(data)[:-_DIGEST_BYTES]  # no copy of the array's bytes
    with ThreadPoolExecutor(1) as pool:
        digest = pool.submit(zlib.crc32, body)
        read = _read_entry(body, key)  # None for a header that does not parse or match
        least = float(read[1].min()) if read is not None and read[1].size else math.nan
        whole = struct.pack("<I", digest.result()) == data[-_DIGEST_BYTES:]
    if not whole or read is None:
        return None
    kernel = read[0]
    return kernel if _plausible(kernel, least, shape) else None


def _read_entry(body: memoryview, key: str) -> tuple[Kernel, np.ndarray] | None:
    """The kernel and its stored values of an entry's bytes but the CRC, or None when its
    header does not parse or is not this key's."""
    try:
        (length,) = struct.unpack_from("<Q", body, len(_MAGIC))
        start = len(_MAGIC) + 8
        header = loads_json(bytes(body[start : start + length]))
        if header["key"] != key or header["format"] != FORMAT:
            return None
        stored = tuple(int(n) for n in header["shape"])
        values = np.frombuffer(body, dtype="<f8", offset=start + length)
        values = values.reshape(stored)  # read-only, over the entry's bytes: no copy
        if header["layout"] == "quadrant":
            arrays = {"quadrant": values}
        elif header["layout"] == "full":
            arrays = {"values": values}
        else:
            return None
        outside = header["energy_outside"]
        outside = np.asarray(outside, float) if header["energy_outside_array"] else float(outside)
        kernel = Kernel(
            **arrays,
            pixel_deg=float(header["pixel_deg"]),
            energy_outside=outside,
            quadrature_error=float(header["quadrature_error"]),
            description=ast.literal_eval(header["description"]),
        )
    except (KeyError, TypeError, ValueError, SyntaxError, OverflowError, struct.error):
        return None  # OverflowError: an edited header's infinite shape or pixel size
    return kernel, values


def _plausible(kernel: Kernel, least: float, shape: tuple[int, int] | None) -> bool:
    """Whether ``kernel`` (the least of its stored values ``least``, NaN for none or a NaN)
    could be a digitised kernel of ``shape``: finite values >= 0, and each channel's sum and
    ``energy_outside`` adding up to the light the model admits, 1 or
    ``description['admitted_share']``, within :data:`ENERGY_TOLERANCE`."""
    if shape is not None and tuple(kernel.shape[:2]) != tuple(shape):
        return False
    # the least is >= 0 (NaN compares False); an infinite value makes a channel's sum
    # infinite, which the energy check below refuses
    if not least >= 0:
        return False
    try:
        outside = np.asarray(kernel.energy_outside, dtype=float)
        admitted = kernel.description.get("admitted_share", 1.0)
        if not isinstance(admitted, float | int) or isinstance(admitted, bool):
            return False
        if not (np.all(np.isfinite(outside)) and np.all(outside >= 0)):
            return False
        error = np.abs(np.asarray(kernel.total(), dtype=float) + outside - admitted)
    except (KeyError, TypeError, ValueError, AttributeError):
        return False
    return bool(np.all(error <= ENERGY_TOLERANCE))


def default_cache() -> KernelCache | None:
    """The user's kernel cache, or ``None`` when ``GLARELAB_NO_CACHE`` is ``1`` (any value
    but 1, 0 or empty is refused, :func:`no_cache_from_env`)."""
    if no_cache_from_env():
        return None
    return KernelCache()


def resolve_cache(cache) -> KernelCache | None:
    """``True`` or ``None``: :func:`default_cache`; ``False``: no cache; a
    :class:`KernelCache` or a folder: that cache.

    Parameters
    ----------
    cache
        ``True``, ``None``, ``False``, a :class:`KernelCache` or a folder (str or path).

    Returns
    -------
    KernelCache or None
        The cache, or None for no cache.

    Raises
    ------
    ValueError
        For anything else.
    """
    check_cache(cache)
    if cache is None or cache is True:
        return default_cache()
    if cache is False:
        return None
    if isinstance(cache, KernelCache):
        return cache
    return KernelCache(cache)


def check_cache(cache: object) -> None:
    """Refuse what :func:`resolve_cache` cannot take, without making or reading a cache (a
    render with nothing to spread checks its argument too).

    Parameters
    ----------
    cache
        What was given.

    Raises
    ------
    ValueError
        For anything but ``True``, ``None``, ``False``, a :class:`KernelCache` or a folder's
        name.
    """
    if cache is None or cache is True or cache is False or isinstance(cache, KernelCache):
        return
    if isinstance(cache, str | os.PathLike):
        if "\0" in os.fspath(cache) or not str(os.fspath(cache)).strip():  # no folder's name
            raise ValueError(f"cache must name a folder; got {cache!r}")
        return
    raise ValueError(f"cache must be True, False, None, a KernelCache or a folder; got {cache!r}")
