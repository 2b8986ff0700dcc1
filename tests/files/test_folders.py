"""A folder replaced whole while another process puts its own output at the same place."""

import json
from pathlib import Path

import pytest

from glarelab.files.folders import (
    LISTING,
    check_replaceable,
    listed_files,
    record_files,
    replace_folder,
    staging_folder,
)


def test_an_output_put_in_place_meanwhile_is_replaced_not_a_crash(tmp_path, monkeypatch):
    final = tmp_path / "set"
    staging = tmp_path / ".set.building-1"
    staging.mkdir()
    (staging / "a.txt").write_text("this build")
    real = Path.rename
    raced = []

    def racing(self, target):  # another build finishes between the check and the rename
        if not raced and Path(target) == final.resolve():
            raced.append(True)
            final.mkdir()
            (final / "b.txt").write_text("the other build")
        return real(self, target)

    monkeypatch.setattr(Path, "rename", racing)
    replace_folder(staging, final, kind="stimulus set")
    assert raced
    assert (final / "a.txt").read_text() == "this build"
    assert not (final / "b.txt").exists()
    assert "a.txt" in listed_files(final)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set"]


def test_a_whole_folder_output_refuses_a_file_edited_since_it_was_written(tmp_path):
    """Issue 38 item 3: a file glarelab wrote and a user edited since is kept, the command
    refused, naming the file; an untouched folder is still replaced."""
    staging = tmp_path / ".set.building-1"
    staging.mkdir()
    (staging / "README.md").write_text("# the set\n")
    (staging / "a.exr").write_bytes(b"pixels")
    replace_folder(staging, tmp_path / "set", kind="stimulus set")
    final = tmp_path / "set"
    assert check_replaceable(final, kind="stimulus set", what="stimulus set") == final
    with (final / "README.md").open("a") as readme:
        readme.write("LAB NOTE\n")
    with pytest.raises(ValueError, match=r"edited since glarelab wrote them \(README\.md\)"):
        check_replaceable(final, kind="stimulus set", what="stimulus set")
    record_files(final, "report")  # listed anew: its content now is what glarelab wrote
    assert check_replaceable(final, kind="report", what="report") == final


def test_a_folder_listed_before_contents_were_recorded_is_still_replaceable(tmp_path):
    (tmp_path / "a.txt").write_text("older output")
    (tmp_path / LISTING).write_text(json.dumps({"files": {"a.txt": "report"}}))
    assert check_replaceable(tmp_path, kind="report", what="report") == tmp_path


def test_a_folder_of_other_files_is_refused_naming_the_out_option(tmp_path):
    """Attack case b003: the refusal says which option to change."""
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(ValueError, match=r"\(keep\.txt\).*give a new or empty folder as --out"):
        check_replaceable(tmp_path, kind="stimulus set", what="stimulus set")


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
def test_a_folder_that_takes_no_new_folder_is_named_not_the_staging_name():
    # analyse --out /proc/rep said "No such file or directory: '/proc/.rep.building-31384'"
    with pytest.raises(
        ValueError, match=r"^--out /proc/rep: no folder can be made in /proc"
    ) as no:
        staging_folder(Path("/proc/rep"))
    assert "building" not in str(no.value)


def test_a_folder_where_the_listing_goes_is_named_not_a_raw_error(tmp_path):
    (tmp_path / LISTING).mkdir()
    (tmp_path / "out.exr").write_bytes(b"x")
    with pytest.raises(ValueError, match=r"\.glarelab-files\.json is not a file \(a folder\?\)"):
        record_files(tmp_path, "render")
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == [LISTING]
