"""The example scenes and readings glarelab ships, where they are: inside the installed
package (``glarelab/shipped``, put there when the wheel is built: setup.py), or in the source
checkout's ``examples/`` and ``calibrations/``."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Literal

__all__ = ["SHIPPED", "copy_shipped", "shipped_folder"]

# what is shipped of each folder (setup.py and MANIFEST.in list the same)
SHIPPED: dict[str, tuple[str, ...]] = {
    "examples": ("*.exr",),
    "calibrations": ("README.md", "example-readings*.csv", "SYNTHETIC-*.json"),
}


def shipped_folder(kind: Literal["examples", "calibrations"]) -> Path:
    """The folder of the shipped ``examples`` or ``calibrations``.

    Parameters
    ----------
    kind : {"examples", "calibrations"}
        Which folder: the example scenes (OpenEXR) or the calibration readings and
        synthetic calibrations (a key of ``SHIPPED``).

    Returns
    -------
    pathlib.Path
        The folder inside the installed package (``glarelab/shipped/KIND``), else the source
        checkout's ``KIND/``.

    Raises
    ------
    ValueError
        For another ``kind``.
    FileNotFoundError
        Where neither the installed package nor a source checkout has them.

    Examples
    --------
    >>> sorted(p.name for p in shipped_folder("examples").glob("*.exr"))
    ['night.exr', 'scene.exr']
    """
    if kind not in SHIPPED:
        raise ValueError(f"kind must be one of {', '.join(SHIPPED)}; got {kind!r}")
    package = Path(__file__).resolve().parents[1]
    for folder in (package / "shipped" / kind, package.parents[1] / kind):
        if folder.is_dir():
            return folder
    raise FileNotFoundError(
        f"no shipped {kind} beside {package} (an installation without them: reinstall glarelab)"
    )


def copy_shipped(destination: str | Path) -> list[Path]:
    """Copy the shipped examples and calibrations into ``destination/examples`` and
    ``destination/calibrations`` (made if missing); an existing file is never replaced.

    Parameters
    ----------
    destination
        The folder to copy into (made if missing); the files go to its ``examples/`` and
        ``calibrations/`` subfolders.

    Returns
    -------
    list of pathlib.Path
        The files written.

    Raises
    ------
    FileExistsError
        Naming every file that exists already (nothing is written then).
    """
    destination = Path(destination)
    plan = []
    for kind, patterns in SHIPPED.items():
        folder = shipped_folder(kind)  # type: ignore[arg-type]
        for pattern in patterns:
            for source in sorted(folder.glob(pattern)):
                plan.append((source, destination / kind / source.name))
    existing = [str(target) for _, target in plan if target.exists()]
    if existing:
        raise FileExistsError(
            f"{', '.join(existing)} exist(s): the examples are never copied over a file; give "
            "another folder"
        )
    written = []
    for source, target in plan:
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source, target)
        written.append(target)
    return written
