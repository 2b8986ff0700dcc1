"""A folder replaced whole while another process puts its own output at the same place."""

import json
import re
from pathlib import Path

import pytest

from glarelab.files.folders import (
    LISTING,
    check_replaceable,
    edited_since,
    files_claimed,
    listed_files,
    record_files,
    record_written,
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
            record_files(final, "stimulus set")  # a build lists what it wrote
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


def _a_report_being_rebuilt(tmp_path: Path) -> tuple[Path, Path]:
    """An earlier report (one table, recorded) and its replacement begun beside it."""
    from glarelab.files.folders import record_files, staging_folder

    final = tmp_path / "report"
    final.mkdir()
    (final / "table.csv").write_text("old\n")
    record_files(final, "report")
    staging = staging_folder(final)
    (staging / "table.csv").write_text("new\n")
    return final, staging


@pytest.mark.parametrize("exchange", [True, False], ids=["swapped", "renamed"])
def test_files_saved_into_a_folder_while_its_replacement_is_made_are_kept(
    tmp_path, monkeypatch, exchange
):
    """A note saved into a report folder during the analysis, and a table edited there, were
    deleted with the earlier report when the new one was swapped in (the start's check had
    passed): they are now moved into the new folder, the edited table as ``NAME.kept``."""
    from glarelab.files import folders
    from glarelab.files.folders import replace_folder

    final, staging = _a_report_being_rebuilt(tmp_path)
    (staging / "results.md").write_text("# new\n")
    # meanwhile, a person at work in the earlier report
    (final / "my-notes.txt").write_text("keep me\n")
    (final / "sub").mkdir()
    (final / "sub" / "draft.md").write_text("draft\n")
    (final / "table.csv").write_text("old, with my edit\n")
    if not exchange:
        monkeypatch.setattr(folders, "_exchange", lambda first, second: False)
    with pytest.warns(UserWarning, match="kept in it"):
        replace_folder(staging, final, kind="report")
    assert (final / "table.csv").read_text() == "new\n"
    assert (final / "results.md").read_text() == "# new\n"
    assert (final / "my-notes.txt").read_text() == "keep me\n"
    assert (final / "sub" / "draft.md").read_text() == "draft\n"
    assert (final / "table.csv.kept").read_text() == "old, with my edit\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]  # nothing else left


def test_an_unchanged_earlier_output_is_replaced_without_a_word(tmp_path, recwarn):
    from glarelab.files.folders import replace_folder

    final, staging = _a_report_being_rebuilt(tmp_path)
    replace_folder(staging, final, kind="report")
    assert sorted(p.name for p in final.iterdir() if p.name != ".glarelab-files.json") == [
        "table.csv"
    ]
    assert not [w for w in recwarn if issubclass(w.category, UserWarning)]


def test_a_file_browsers_own_files_do_not_make_a_folder_foreign(tmp_path):
    """A .DS_Store in an earlier report folder (opened in Finder) made `analyse --out` refuse
    it as holding files glarelab did not write."""
    out = tmp_path / "report"
    out.mkdir()
    (out / "table.csv").write_text("a\n")
    record_files(out, "report")
    (out / ".DS_Store").write_bytes(b"Bud1")
    (out / "._table.csv").write_bytes(b"\x00")
    assert check_replaceable(out, kind="report", what="report") == out
    (out / "mine.txt").write_text("x")
    with pytest.raises(ValueError, match=r"mine\.txt"):
        check_replaceable(out, kind="report", what="report")


def test_a_shared_file_edited_since_glarelab_wrote_it_is_not_overwritten(tmp_path):
    """``docs``, ``gallery`` and ``looks`` wrote their files again over a user's edits (notes
    added to data.md, a retouched figure) without a word."""
    from glarelab.files.folders import claim_files, record_written

    claim_files(tmp_path, ["a.md", "b.png"], "docs")
    (tmp_path / "a.md").write_text("generated\n")
    (tmp_path / "b.png").write_bytes(b"png")
    record_written(tmp_path, ["a.md", "b.png"])
    claim_files(tmp_path, ["a.md", "b.png"], "docs")  # unedited: written again
    (tmp_path / "a.md").write_text("generated\n")
    record_written(tmp_path, ["a.md", "b.png"])
    (tmp_path / "a.md").write_text("generated\nthe lab's notes\n")
    with pytest.raises(ValueError, match=r"a\.md was edited since glarelab wrote it; docs would"):
        claim_files(tmp_path, ["a.md", "b.png"], "docs")
    assert (tmp_path / "a.md").read_text() == "generated\nthe lab's notes\n"


def test_docs_run_again_keeps_a_file_edited_since(tmp_path, capsys):
    from glarelab.cli import main

    out = tmp_path / "docs"
    assert main(["docs", "--out", str(out)]) == 0
    assert main(["docs", "--out", str(out)]) == 0  # its own files, unedited: written again
    edited = (out / "data.md").read_text(encoding="utf-8") + "\nOur lab's notes.\n"
    (out / "data.md").write_text(edited, encoding="utf-8")
    capsys.readouterr()
    assert main(["docs", "--out", str(out)]) == 2
    assert "data.md was edited since glarelab wrote it" in capsys.readouterr().err
    assert (out / "data.md").read_text(encoding="utf-8") == edited


@pytest.mark.parametrize("claim", ["claim_files", "list_files"])
def test_a_name_whose_write_failed_does_not_make_a_later_file_glarelabs(tmp_path, claim):
    """A write that failed on a full disk left the name listed: a user's file saved under it
    later was taken for glarelab's and overwritten without --force."""
    from glarelab.files import folders

    getattr(folders, claim)(tmp_path, ["out.exr"], "render")  # the write then fails
    assert listed_files(tmp_path) == {"out.exr": "render"}  # nothing there: nothing to take
    (tmp_path / "out.exr").write_text("participant data\n")
    assert listed_files(tmp_path) == {}
    with pytest.raises(ValueError, match=r"out\.exr exists and glarelab did not write it"):
        folders.claim_files(tmp_path, ["out.exr"], "render")
    folders.claim_files(tmp_path, ["new.exr"], "render")
    (tmp_path / "new.exr").write_text("written\n")
    folders.record_written(tmp_path, ["new.exr"])  # written: glarelab's
    folders.claim_files(tmp_path, ["new.exr"], "render")


@pytest.mark.parametrize("command", ["render", "psf"])
def test_render_and_psf_whose_write_fails_leave_a_later_user_file_alone(
    tmp_path, monkeypatch, capsys, command
):
    import errno

    import numpy as np

    from glarelab.cli import main
    from glarelab.commands import render
    from glarelab.stimuli.exr import write_exr

    monkeypatch.chdir(tmp_path)
    scene = np.full((17, 17), 10.0)
    scene[8, 8] = 1e5
    write_exr("in.exr", scene)
    out = "out.exr" if command == "render" else "psf.png"
    args = {
        "render": ["render", "in.exr", out, "--pixel-deg", "0.05", "--model", "gaussian"],
        "psf": ["psf", "--model", "gaussian", "--size", "31", "--out", out],
    }[command]

    def full(path, *_args, **_kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    with monkeypatch.context() as patch:
        patch.setattr(render, "write_exr" if command == "render" else "psf_png", full)
        assert main(args) != 0
    assert not (tmp_path / out).exists()
    (tmp_path / out).write_text("participant data\n")
    capsys.readouterr()
    assert main(args) == 2
    assert "glarelab did not write it there" in capsys.readouterr().err
    assert (tmp_path / out).read_text() == "participant data\n"


def test_a_name_written_but_not_yet_recorded_stays_listed_when_another_is_claimed(tmp_path):
    """psf claims its image, writes it, then claims its axes figure before recording the
    image: the axes' claim dropped the image from the listing, and a second psf run took
    its own image for a user's file ("exists and glarelab did not write it there")."""
    from glarelab.files.folders import claim_files, listed_files, record_written

    claim_files(tmp_path, ["p.png"], "psf")
    (tmp_path / "p.png").write_bytes(b"image")
    claim_files(tmp_path, ["p_axes.png"], "psf")
    (tmp_path / "p_axes.png").write_bytes(b"axes")
    record_written(tmp_path, ["p.png", "p_axes.png"])
    assert {"p.png", "p_axes.png"} <= set(listed_files(tmp_path))
    claim_files(tmp_path, ["p.png", "p_axes.png"], "psf")  # the second run: its own files


def test_claims_of_work_that_failed_leave_the_listing_as_the_work_found_it(tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()
    with files_claimed(folder, ["a.txt", "b.txt"], "render"):
        for name in ("a.txt", "b.txt"):
            (folder / name).write_text("first")
    record_written(folder, ["a.txt", "b.txt"])
    before = json.loads((folder / LISTING).read_text())
    with pytest.raises(RuntimeError), files_claimed(folder, ["a.txt", "b.txt", "c.txt"], "render"):
        (folder / "b.txt").write_text("second")  # written, then the work fails
        raise RuntimeError("refused")
    after = json.loads((folder / LISTING).read_text())
    assert after["files"] == before["files"]  # c.txt, never written, is not claimed
    assert after["sha256"]["a.txt"] == before["sha256"]["a.txt"]  # untouched: as recorded
    assert after["sha256"]["b.txt"] != before["sha256"]["b.txt"]  # rewritten: recorded anew
    assert not edited_since(folder, "b.txt")
    new = tmp_path / "new"
    new.mkdir()
    with pytest.raises(KeyboardInterrupt), files_claimed(new, ["x"], "render", created=True):
        raise KeyboardInterrupt
    assert not new.exists()


def test_a_listing_nested_too_deeply_is_read_as_no_listing(tmp_path):
    """A listing of '{"a":' * 100000 stopped every write into the folder with a
    RecursionError; an unreadable listing is an empty one, as a corrupt one is."""
    (tmp_path / LISTING).write_text('{"a":' * 100000 + "1" + "}" * 100000)
    assert listed_files(tmp_path) == {}
    assert not edited_since(tmp_path, "out.exr")
    (tmp_path / "out.exr").write_text("participant data\n")
    from glarelab.files.folders import claim_files

    with pytest.raises(ValueError, match=r"out\.exr exists and glarelab did not write it"):
        claim_files(tmp_path, ["out.exr"], "render")
    record_files(tmp_path, "render")
    assert json.loads((tmp_path / LISTING).read_text())["files"]


def test_an_output_held_refuses_a_second_holder_and_leaves_no_folder_it_made(tmp_path):
    from glarelab.files.folders import output_lock

    out = tmp_path / "new" / "deeper" / "report"
    with output_lock(out, "analysis"):
        assert (out.parent / ".report.output.lock").is_file()
        with pytest.raises(ValueError, match=rf"^{re.escape(str(out))} is in use by another "
                           r"glarelab analysis \(pid \d+ on .*\): wait for it to end, or give "
                           r"another --out \(nothing was changed\)$"):  # fmt: skip
            output_lock(out, "analysis").acquire()
    assert sorted(tmp_path.iterdir()) == []  # the folders made for the lock are gone
    with output_lock(out, "analysis"):
        out.mkdir()  # the work wrote there: kept
    assert sorted(p.name for p in out.parent.iterdir()) == ["report"]
