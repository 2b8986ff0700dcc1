"""Memory asked of the system: work that would need more than it has is refused before anything
is allocated, with a message giving both sizes, instead of a ``MemoryError`` (or the system
killing the process) part-way through."""

from __future__ import annotations

from pathlib import Path

__all__ = ["available_memory", "check_memory", "refuse_beyond"]


MEMINFO = Path("/proc/meminfo")  # Linux's own account of its memory (proc(5))


def available_memory() -> int | None:
    """Bytes the system can still give without swapping: Linux's ``MemAvailable``, read from
    :data:`MEMINFO` (what psutil's ``available`` reports there), and psutil's ``available``
    where there is no such file (macOS, Windows) or the file leaves it to psutil's estimate
    (:func:`_meminfo_available`); None where unknown.

    Notes
    -----
    On Linux the file is read rather than psutil imported: the import took 14-37 ms in a
    fresh process, a tenth of a one-call render of a 2048² night scene, for one number the
    kernel writes in a line of text.
    """
    from_file = _meminfo_available(MEMINFO)
    if from_file is not None:
        return from_file
    import psutil

    try:
        return int(psutil.virtual_memory().available)
    except (OSError, RuntimeError, NotImplementedError):
        return None


def _meminfo_available(path: Path) -> int | None:
    """``MemAvailable`` of a ``/proc/meminfo`` file in bytes (the kernel writes kB, of 1024
    bytes); None where psutil is to answer instead: the file or either line missing or
    unreadable (kernels before 3.14 have no ``MemAvailable``), ``MemAvailable`` 0 (a kernel
    bug psutil works around by estimating it) or above ``MemTotal`` (some containers: psutil
    takes ``MemFree``)."""
    fields: dict[bytes, int] = {}
    try:
        with path.open("rb") as file:
            for line in file:
                name, _, rest = line.partition(b":")
                if name in (b"MemTotal", b"MemAvailable") and name not in fields:
                    parts = rest.split()
                    if len(parts) != 2 or parts[1] != b"kB" or not parts[0].isdigit():
                        return None
                    fields[name] = int(parts[0]) * 1024
                    if len(fields) == 2:
                        break
    except OSError:
        return None
    total, available = fields.get(b"MemTotal"), fields.get(b"MemAvailable")
    if total is None or available is None or not 0 < available <= total:
        return None
    return available


def refuse_beyond(needed: float, free: int | None, what: str) -> None:
    """Raise ``ValueError`` if ``needed`` bytes exceed ``free`` (nothing when ``free`` is None).

    Parameters
    ----------
    needed
        Bytes the work needs.
    free
        Bytes available (:func:`available_memory`), or None where unknown.
    what
        The work, for the message.

    Raises
    ------
    ValueError
        Naming ``what``, both sizes in GiB, when ``needed > free``.

    Examples
    --------
    >>> refuse_beyond(3 * 2**30, 2**30, "shape (9, 9)")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    ValueError: shape (9, 9) needs about 3.0 GiB of memory, 1.0 GiB are available; use ...
    """
    if free is not None and needed > free:
        raise ValueError(
            f"{what} needs about {needed / 2**30:.1f} GiB of memory, {free / 2**30:.1f} GiB "
            "are available; use a smaller size"
        )


def check_memory(needed: float, what: str) -> None:
    """Refuse work that needs more memory than the system has, before allocating it.

    Parameters
    ----------
    needed
        Bytes the work needs.
    what
        The work, for the message (e.g. ``"shape (100001, 100001)"``).

    Raises
    ------
    ValueError
        If the system reports less memory available than ``needed`` (where it reports
        nothing, nothing is checked).
    """
    refuse_beyond(needed, available_memory(), what)
