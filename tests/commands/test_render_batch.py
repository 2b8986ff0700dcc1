"""``glarelab render`` of several files into a folder: an input that cannot be rendered is
refused before the first output is written (exit 2 means nothing written)."""

from __future__ import annotations

import numpy as np
import pytest

from glarelab.cli import main
from glarelab.files.folders import LISTING
from glarelab.stimuli.exr import write_exr


def _scene() -> np.ndarray:
    image = np.full((17, 17), 10.0)
    image[8, 8] = 1e5
    return image


@pytest.mark.parametrize(
    ("second", "named"),
    [
        (b"hi\n", "is not an OpenEXR file"),
        ("negative", "must be >= 0 cd/m²"),
    ],
)
def test_a_bad_second_input_leaves_no_output_of_the_first(
    tmp_path, monkeypatch, capsys, second, named
):
    monkeypatch.chdir(tmp_path)
    write_exr("in.exr", _scene())
    if second == "negative":
        import OpenEXR

        values = np.full(
            (17, 17), -1.0, np.float32
        )  # write_exr refuses it; a foreign tool does not
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {"Y": values}) as exr:
            exr.write("second.exr")
    else:
        (tmp_path / "second.exr").write_bytes(second)
    assert main(["render", "in.exr", "second.exr", "outdir/", "--pixel-deg", "0.05"]) == 2
    err = capsys.readouterr().err
    assert "input second.exr: " in err and named in err and "nothing was rendered" in err, err
    assert not (tmp_path / "outdir").exists() or not list((tmp_path / "outdir").iterdir())


def test_good_inputs_are_all_rendered(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_exr("a.exr", _scene())
    write_exr("b.exr", _scene())
    assert main(["render", "a.exr", "b.exr", "outdir/", "--pixel-deg", "0.05"]) == 0
    assert sorted(p.name for p in (tmp_path / "outdir").glob("*.exr")) == ["a.exr", "b.exr"]


def test_several_inputs_into_a_file_name_are_refused(tmp_path, monkeypatch, capsys):
    """``render a.exr b.exr out.exr`` made a folder named out.exr holding both."""
    monkeypatch.chdir(tmp_path)
    write_exr("a.exr", _scene())
    write_exr("b.exr", _scene())
    assert main(["render", "a.exr", "b.exr", "out.exr", "--pixel-deg", "0.05"]) == 2
    err = capsys.readouterr().err
    assert "2 inputs and the output out.exr, a file's name" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr", "b.exr"]
    (tmp_path / "out.exr").mkdir()  # a folder of that name is a folder
    assert main(["render", "a.exr", "b.exr", "out.exr", "--pixel-deg", "0.05"]) == 0


@pytest.mark.parametrize(
    "refused",
    [
        ["--age", "90"],  # the Vos model's age range, checked when the renderer is made
        ["--regime", "scotopic", "--age", "82"],
        ["--calibration", "missing.json"],
    ],
)
def test_a_refusal_after_the_inputs_are_read_leaves_the_folder_as_it_was(
    tmp_path, monkeypatch, capsys, refused
):
    monkeypatch.chdir(tmp_path)
    write_exr("a.exr", _scene())
    write_exr("b.exr", _scene())
    options = ["--pixel-deg", "0.05", "--model", "vos"]
    assert main(["render", "a.exr", "b.exr", "new/", *options, *refused]) == 2
    assert not (tmp_path / "new").exists()  # made for the outputs, gone with them
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "notes.txt").write_text("a lab's notes")
    assert main(["render", "a.exr", "b.exr", "kept", *options, *refused]) == 2
    assert sorted(p.name for p in kept.iterdir()) == ["notes.txt"]
    # rendered once: a refused run keeps what was recorded, so an edit is still named
    assert main(["render", "a.exr", "b.exr", "kept", *options]) == 0
    listing = (kept / LISTING).read_bytes()
    assert main(["render", "a.exr", "b.exr", "kept", *options, *refused, "--force"]) == 2
    assert (kept / LISTING).read_bytes() == listing
    with (kept / "a.exr").open("ab") as edited:
        edited.write(b"edited")
    capsys.readouterr()
    assert main(["render", "a.exr", "b.exr", "kept", *options, *refused, "--force"]) == 2
    assert main(["render", "a.exr", "b.exr", "kept", *options]) == 2
    assert "a.exr was edited since glarelab wrote it" in capsys.readouterr().err


def test_a_gallery_refused_for_memory_makes_no_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("glarelab.commands.common.available_memory", lambda: 2**30)
    assert main(["gallery", "--out", "G", "--size", "4097"]) == 2
    assert "GiB of memory" in capsys.readouterr().err
    assert not (tmp_path / "G").exists()
