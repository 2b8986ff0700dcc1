"""Every test run, the doctests of the packages included, keeps its caches (digitised kernels,
observers' stimulus sets) in a temporary folder: never the user's cache, and never one test
run's entries in another's."""

import os
import shutil
import tempfile

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
