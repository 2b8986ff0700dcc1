"""Output folders that are replaced whole or not at all, and never over someone else's files.

A stimulus set or a report is written into a staging folder next to its destination and moved
into place only when complete: a failed build leaves the earlier output as it was, and a
rebuild leaves no file of the earlier output behind. The destination must be new, empty, or an
earlier output of the same kind (it holds the kind's ``marker`` file); anything else is refused
before anything is written.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

__all__ = ["check_replaceable", "replace_folder", "staging_folder"]


def check_replaceable(out: str | Path, *, marker: str, what: str) -> Path:
    """``out`` as the folder of a ``what`` (a stimulus set, a report): new, empty, or an earlier
    one (it holds ``marker``).

    Raises
    ------
    ValueError
        If ``out`` is a file, or a folder holding files but no ``marker``.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out} is a file; a {what} needs a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / marker).is_file():
        raise ValueError(
            f"{out} holds files but no {what} (no {marker}): give a new or empty folder "
            "(nothing was changed)"
        )
    return out


def staging_folder(final: Path) -> Path:
    """A new, empty folder next to ``final`` to build its replacement in."""
    final.parent.mkdir(parents=True, exist_ok=True)
    staging = final.with_name(f".{final.name}.building-{os.getpid()}")
    shutil.rmtree(staging, ignore_errors=True)  # a build of this process that was cut short
    staging.mkdir()
    return staging


def replace_folder(staging: Path, final: Path) -> None:
    """Move the finished ``staging`` folder to ``final``; the earlier ``final`` is removed only
    once the new one is in place."""
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.old-{os.getpid()}")
        shutil.rmtree(old, ignore_errors=True)
        final.rename(old)
    staging.rename(final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
