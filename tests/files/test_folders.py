"""A folder replaced whole while another process puts its own output at the same place."""

from pathlib import Path

from glarelab.files.folders import listed_files, replace_folder


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
