"""What every test run shares, the doctests of the package included.

**Caches.** Every run keeps its caches (digitised kernels, observers' stimulus sets) and its
sessions' locks in a temporary folder: never the user's, and never one test run's entries in
another's.

**PsychoPy's plugin modules.** glarelab.frontend.psychopy_plugin subclasses PsychoPy's
ImageStim, so importing it imports psychopy.visual, which opens a hidden window: its doctests are
collected only where PsychoPy is installed and a display is there (tests/experiments test it on
its own X screen); the Builder module needs PsychoPy alone.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
import tempfile
from pathlib import Path

_PREVIOUS = {}


def pytest_configure(config):
    folder = tempfile.mkdtemp(prefix="glarelab-test-cache-")
    _PREVIOUS["GLARELAB_CACHE"] = os.environ.get("GLARELAB_CACHE")
    _PREVIOUS["GLARELAB_LOCKS"] = os.environ.get("GLARELAB_LOCKS")
    _PREVIOUS["folder"] = folder
    os.environ["GLARELAB_CACHE"] = folder
    os.environ["GLARELAB_LOCKS"] = os.path.join(folder, "locks")  # this run's sessions only


def pytest_unconfigure(config):
    for name in ("GLARELAB_CACHE", "GLARELAB_LOCKS"):
        previous = _PREVIOUS.pop(name, None)
        if previous is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = previous
    shutil.rmtree(_PREVIOUS.pop("folder", ""), ignore_errors=True)


def pytest_ignore_collect(collection_path: Path, config):
    """Skip the PsychoPy plugin's modules where they cannot be imported."""
    name = collection_path.name
    if name not in ("psychopy_plugin.py", "psychopy_builder.py"):
        return None
    if importlib.util.find_spec("psychopy") is None:
        return True
    if name == "psychopy_plugin.py" and sys.platform.startswith("linux"):
        return True if not os.environ.get("DISPLAY") else None
    return None
