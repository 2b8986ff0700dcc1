"""Test-wide settings: one cache of simulated observers' stimulus sets per test run, in a
temporary folder (never the user's ~/.cache)."""

import os

import pytest


@pytest.fixture(scope="session", autouse=True)
def stimulus_set_cache(tmp_path_factory):
    folder = tmp_path_factory.mktemp("glarelab-cache")
    previous = os.environ.get("GLARELAB_CACHE")
    os.environ["GLARELAB_CACHE"] = str(folder)
    yield folder
    if previous is None:
        os.environ.pop("GLARELAB_CACHE", None)
    else:
        os.environ["GLARELAB_CACHE"] = previous
