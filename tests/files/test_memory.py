"""The memory the system can still give: Linux's ``MemAvailable`` read from /proc/meminfo,
psutil elsewhere (and where the file has no such line)."""

import subprocess
import sys
from pathlib import Path

import psutil
import pytest

from glarelab.files import memory

LINUX = Path("/proc/meminfo").is_file()


@pytest.mark.skipif(not LINUX, reason="reads Linux's /proc/meminfo")
def test_the_file_says_what_psutil_says():
    # both read MemAvailable; the two readings are a moment apart
    free, theirs = memory.available_memory(), psutil.virtual_memory().available
    assert free is not None
    assert abs(free - theirs) <= 256 * 2**20


@pytest.mark.skipif(not LINUX, reason="reads Linux's /proc/meminfo")
def test_reading_it_does_not_import_psutil():
    code = (
        "import sys\n"
        "from glarelab.files.memory import available_memory\n"
        "assert available_memory() > 0\n"
        "print('psutil' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("MemTotal:       16384 kB\nMemAvailable:    2048 kB\n", 2048 * 1024),
        ("MemTotal:\t16384 kB\r\nMemFree: 9 kB\r\nMemAvailable:\t2048 kB", 2048 * 1024),
        # the first of each line counts
        ("MemTotal: 16384 kB\nMemAvailable: 2048 kB\nMemAvailable: 4096 kB\n", 2048 * 1024),
        ("MemTotal:       16384 kB\nMemFree:    2048 kB\n", None),  # kernels before 3.14
        ("MemAvailable:    2048 kB\n", None),  # no total to hold it to
        # 0: a kernel bug, which psutil works around by estimating it (psutil issue 1915)
        ("MemTotal:       16384 kB\nMemAvailable:       0 kB\n", None),
        # above the total: some containers, where psutil takes MemFree
        ("MemTotal:        8000 kB\nMemAvailable:    9000 kB\n", None),
        ("MemTotal:       16384 kB\nMemAvailable:    2048 MB\n", None),  # not the kernel's unit
        ("MemTotal:       16384 kB\nMemAvailable:    -5 kB\n", None),
        ("MemTotal:       16384 kB\nMemAvailable:\n", None),
        ("", None),
    ],
)
def test_the_line_is_read_or_refused(tmp_path, text, expected):
    path = tmp_path / "meminfo"
    path.write_text(text)
    assert memory._meminfo_available(path) == expected


def test_without_the_line_psutil_answers(tmp_path, monkeypatch):
    path = tmp_path / "meminfo"
    path.write_text("MemTotal:       16384 kB\n")
    monkeypatch.setattr(memory, "MEMINFO", path)
    free = memory.available_memory()
    assert free is not None and 0 < free <= psutil.virtual_memory().total


def test_without_the_file_psutil_answers(tmp_path, monkeypatch):
    monkeypatch.setattr(memory, "MEMINFO", tmp_path / "absent")
    free = memory.available_memory()
    assert free is not None and 0 < free <= psutil.virtual_memory().total


def test_a_folder_at_the_path_leaves_it_to_psutil(tmp_path, monkeypatch):
    assert memory._meminfo_available(tmp_path) is None  # IsADirectoryError: an OSError
    monkeypatch.setattr(memory, "MEMINFO", tmp_path)
    free = memory.available_memory()
    assert free is not None and 0 < free <= psutil.virtual_memory().total
