"""What every test run shares, the doctests of the packages included.

**Caches.** Every run keeps its caches (digitised kernels, observers' stimulus sets) in a
temporary folder: never the user's cache, and never one test run's entries in another's.

**Doctests under the installed names.** The repository keeps one folder per subpackage
(glare/, stimuli/, ...) that installs as ``glarelab.glare``, ``glarelab.stimuli``, ...
(pyproject.toml's package-dir). pytest's own ``--doctest-modules`` names a module after its
folders and would import glare/models/vos.py a second time, as a top-level ``glare`` package;
here each file's doctests run in the module that ``import glarelab.glare.models.vos`` gives,
the one the rest of the suite uses.
"""

from __future__ import annotations

import importlib
import os
import shutil
import tempfile
from pathlib import Path

from _pytest.doctest import DoctestModule  # pytest exposes no public name for it

ROOT = Path(__file__).resolve().parent
PACKAGE_DIRS = {
    "glarelab": "glarelab",
    "glare": "glarelab.glare",
    "stimuli": "glarelab.stimuli",
    "experiments": "glarelab.experiments",
    "analysis": "glarelab.analysis",
    "protocols": "glarelab.protocols",
    "planning": "glarelab.planning",
}
_PREVIOUS = {}


def pytest_configure(config):
    folder = tempfile.mkdtemp(prefix="glarelab-test-cache-")
    _PREVIOUS["GLARELAB_CACHE"] = os.environ.get("GLARELAB_CACHE")
    _PREVIOUS["folder"] = folder
    os.environ["GLARELAB_CACHE"] = folder


def pytest_unconfigure(config):
    previous = _PREVIOUS.pop("GLARELAB_CACHE", None)
    if previous is None:
        os.environ.pop("GLARELAB_CACHE", None)
    else:
        os.environ["GLARELAB_CACHE"] = previous
    shutil.rmtree(_PREVIOUS.pop("folder", ""), ignore_errors=True)


def installed_name(path: Path) -> str | None:
    """``glare/models/vos.py`` → ``glarelab.glare.models.vos``; None outside the package."""
    try:
        parts = list(path.resolve().relative_to(ROOT).with_suffix("").parts)
    except ValueError:
        return None
    if not parts or parts[0] not in PACKAGE_DIRS:
        return None
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([PACKAGE_DIRS[parts[0]], *parts[1:]])


class InstalledDoctestModule(DoctestModule):
    """The doctests of one module, imported by its installed name."""

    def _getobj(self):
        return importlib.import_module(installed_name(self.path))


def pytest_collect_file(file_path, parent):
    if file_path.name == "__main__.py":  # running it is the command line, as pytest skips it
        return None
    if file_path.suffix == ".py" and installed_name(file_path) is not None:
        return InstalledDoctestModule.from_parent(parent, path=file_path)
    return None
