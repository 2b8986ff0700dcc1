"""Files written whole (glarelab.files.atomic): a legal long name gets a legal temporary
name, so that it is written, not refused after the work with ENAMETOOLONG."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest

from glarelab.files.atomic import NAME_MAX_BYTES, _temporary, short_name, write_text
from glarelab.files.folders import replace_folder, staging_folder


@pytest.mark.parametrize("length", [200, 240, NAME_MAX_BYTES])
def test_a_legal_long_file_name_is_written(tmp_path, length):
    path = tmp_path / ("é" * ((length - 5) // 2) + "x" * ((length - 5) % 2) + ".json")
    assert len(path.name.encode()) == length
    write_text(path, "{}\n")
    assert path.read_text() == "{}\n" and os.listdir(tmp_path) == [path.name]
    assert len(_temporary(path).name.encode()) <= NAME_MAX_BYTES
    assert _temporary(path).suffix == ".json"


def test_a_legal_long_folder_name_is_built_and_replaced(tmp_path):
    final = tmp_path / ("s" * NAME_MAX_BYTES)
    for text in ("first\n", "second\n"):  # new, then replaced whole
        staging = staging_folder(final)
        (staging / "a.txt").write_text(text)
        replace_folder(staging, final, kind="test")
        assert (final / "a.txt").read_text() == text
    assert sorted(os.listdir(tmp_path)) == [final.name]


def test_short_names_stay_distinct():
    first, second = ("x" * 250 + "1"), ("x" * 250 + "2")
    assert short_name(first, room=40) != short_name(second, room=40)
    assert short_name("table", room=40) == "table"


def test_a_file_that_cannot_be_created_is_named_not_its_temporary_name(tmp_path):
    # export-monitor --monitor a/b said "No such file or directory: 'mf/a/.b.partial-….json'"
    target = tmp_path / "missing" / "b.json"
    with pytest.raises(FileNotFoundError) as missing:
        write_text(target, "{}")
    assert missing.value.filename == str(target)
    assert "partial" not in str(missing.value)


def _special(path: Path, kind: str) -> None:
    if kind == "fifo":
        os.mkfifo(path)
    else:  # a private /dev/null: a character device (root only)
        os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 3))


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_a_device_or_pipe_at_the_path_is_refused_and_kept(tmp_path, kind):
    """write_exr('/dev/null', …) as root renamed a file over /dev/null: the device was gone."""
    from glarelab.stimuli.exr import write_exr

    if kind == "device" and os.geteuid() != 0:
        pytest.skip("making a device takes root")
    target = tmp_path / "out.exr"
    _special(target, kind)
    with pytest.raises(ValueError, match=r"out\.exr: a (named pipe|character device).* not a "
                       "file; .*give a file's path"):  # fmt: skip
        write_exr(target, np.ones((2, 2)))
    mode = os.lstat(target).st_mode
    assert stat.S_ISFIFO(mode) if kind == "fifo" else stat.S_ISCHR(mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.exr"]


@pytest.mark.parametrize(("name", "room"), [(None, 5), (b"table", 5), ("table", -1), ("t", 2.0)])
def test_short_name_refuses_what_is_no_name_or_room(name, room):
    with pytest.raises(ValueError, match=r"^(name|room) must be"):
        short_name(name, room=room)
