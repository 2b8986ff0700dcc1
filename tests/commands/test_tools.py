"""``glarelab bench``'s options: --live and --acuity are benches of their own, so the standard
bench's options given with them are refused naming those options, never an --only that was
not given."""

from __future__ import annotations

import pytest

from glarelab.cli import main


@pytest.mark.parametrize(
    ("options", "message"),
    [(["--acuity", "--live"], "--live and --acuity are two benches of their own: give one"),
     (["--acuity", "--large"], "--acuity runs its own workloads: --large (of the standard "
      "bench) would do nothing; leave it out"),
     (["--live", "--large", "--no-fresh"], "--live runs its own workloads: --large and "
      "--no-fresh (of the standard bench) would do nothing; leave them out"),
     (["--acuity", "--no-spectral"], "--acuity runs its own workloads: --no-spectral")],
)  # fmt: skip
def test_options_the_bench_would_ignore_are_named(options, message, tmp_path, capsys):
    # --acuity --live said "--only --acuity is not one", naming an --only not given
    assert main(["bench", "--out", str(tmp_path / "b"), *options]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"glarelab bench: {message}"), err
    assert "--only" not in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def fake_live_bench(monkeypatch):
    """--live's bench without its minutes: the passes asked for, and two files written."""
    import glarelab.bench.live as live

    asked = []

    def bench(*, only=None, repeats=3, log=print):
        asked.append(repeats)
        return [{"workload": "street", "frames": 60 * repeats}]

    def write(out, rows):
        (out / "live.csv").write_text(f"frames\n{rows[0]['frames']}\n")
        (out / "live.md").write_text(f"{rows[0]['frames']} frames\n")

    monkeypatch.setattr(live, "live_bench", bench)
    monkeypatch.setattr(live, "write_live_bench", write)
    return asked


def test_live_bench_times_the_passes_asked_for(fake_live_bench, tmp_path):
    # --live --repeats N was ignored: always three passes, 180 frames
    assert main(["bench", "--live", "--repeats", "1", "--out", str(tmp_path / "b")]) == 0
    assert fake_live_bench == [1]
    assert (tmp_path / "b" / "live.csv").read_text() == "frames\n60\n"


@pytest.mark.parametrize("name", ["live.md", "live.csv"])
def test_live_bench_refuses_to_overwrite_its_table_edited_since(
    fake_live_bench, name, tmp_path, capsys
):
    # a note added to live.md (or live.csv) was overwritten without a word
    out = tmp_path / "b"
    assert main(["bench", "--live", "--out", str(out)]) == 0
    with (out / name).open("a") as handle:
        handle.write("MY EDIT\n")
    assert main(["bench", "--live", "--out", str(out)]) == 2
    assert f"{out / name} was edited since glarelab wrote it" in capsys.readouterr().err
    assert (out / name).read_text().endswith("MY EDIT\n") and len(fake_live_bench) == 1
