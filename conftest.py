"""What every test run shares, the doctests of the package included.

**Caches.** Every run keeps its caches (digitised kernels, observers' stimulus sets) and its
sessions' locks in a temporary folder: never the user's, and never one test run's entries in
another's.
"""

from __future__ import annotations

import os
import shutil
import tempfile

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
