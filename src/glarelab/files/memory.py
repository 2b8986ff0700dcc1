"""Memory asked of the system: work that would need more than it has is refused before anything
is allocated, with a message giving both sizes, instead of a ``MemoryError`` (or the system
killing the process) part-way through."""

from __future__ import annotations

__all__ = ["available_memory", "check_memory", "refuse_beyond"]


def available_memory() -> int | None:
    """Bytes the system can still give without swapping (psutil's ``available``: Linux's
    MemAvailable, and its counterpart on macOS and Windows, where there is no /proc/meminfo);
    None where unknown."""
    import psutil

    try:
        return int(psutil.virtual_memory().available)
    except (OSError, RuntimeError, NotImplementedError):
        return None


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
