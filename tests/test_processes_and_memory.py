"""The process-liveness probe (stale temporary files and folders of killed processes) and the
memory check work through psutil, on every system: a process that ended is dead, this one is
alive, and the memory available is a positive number no larger than the machine's."""

from __future__ import annotations

import os
import subprocess
import sys

import psutil

from glarelab.commands.common import available_memory
from glarelab.files.atomic import _alive


def test_a_process_that_ended_is_not_alive():
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    assert not _alive(child.pid)
    assert _alive(os.getpid())


def test_the_memory_available_is_the_systems():
    free = available_memory()
    assert free is not None and 0 < free <= psutil.virtual_memory().total
