"""``run --simulate --participants N --resume`` goes on with a batch where it stopped: the
sessions that completed are kept as they are, the others resumed or run, and the batch ends as
an uninterrupted one would."""

import csv
import json

from glarelab.cli import main

# the columns a session's clock writes (times differ between runs); every other cell is equal
CLOCK = {"onset_s", "time_s"}


def answers(folder):
    rows = {}
    for path in sorted(folder.glob("*.csv")):
        with path.open(newline="") as handle:
            rows[path.name.split("_")[0]] = [
                {k: v for k, v in row.items() if k not in CLOCK} for row in csv.DictReader(handle)
            ]
    return rows


def test_a_batch_resumed_keeps_what_completed_and_runs_the_rest(tmp_path, capsys):
    run = ["run", "luidolt2020", "--simulate", "--seed", "4"]
    assert main([*run, "--participants", "3", "--out", str(tmp_path / "whole")]) == 0
    stopped = tmp_path / "stopped"
    assert main([*run, "--participants", "1", "--out", str(stopped)]) == 0  # sim01 only
    (first,) = stopped.glob("sim01_*.csv")
    written = first.read_bytes()
    capsys.readouterr()
    assert main([*run, "--participants", "3", "--out", str(stopped), "--resume"]) == 0
    err = capsys.readouterr().err
    assert "[1/3] sim01: completed before, kept" in err and "[3/3] sim03: 6 trials" in err
    assert first.read_bytes() == written
    assert answers(stopped) == answers(tmp_path / "whole")


def test_a_batch_resumed_with_another_seed_is_refused(tmp_path, capsys):
    """Resumed with --seed 9, sim01-02 (seed 4) were kept and sim03 run with seed 9: a batch
    of two seeds, without a word; with --seed 6 'completed before, kept' said nothing either."""
    out = tmp_path / "batch"
    run = ["run", "luidolt2020", "--simulate", "--out", str(out)]
    assert main([*run, "--seed", "4", "--participants", "2"]) == 0
    before = sorted(p.name for p in out.iterdir())
    capsys.readouterr()
    assert main([*run, "--seed", "9", "--participants", "3", "--resume"]) == 2
    err = capsys.readouterr().err
    assert "--seed 9: sim01, sim02 of this batch" in err and "give --seed 4" in err
    assert sorted(p.name for p in out.iterdir()) == before
    assert main([*run, "--seed", "4", "--participants", "3", "--resume"]) == 0


def test_a_batch_resumed_on_a_stimulus_set_rebuilt_since_is_refused(tmp_path, capsys):
    """Resumed on a set rebuilt since (another manifest), a batch added a participant of the
    new set without a word, although a seed change is refused; the analysis then refused the
    mix."""
    out = tmp_path / "batch"
    run = ["run", "yoshida2008", "--simulate", "--seed", "4", "--out", str(out)]
    assert main([*run, "--participants", "1"]) == 0
    (sidecar,) = out.glob("sim01_*.json")
    data = json.loads(sidecar.read_text())
    now = data["stimulus_set_manifest_sha256"]
    data["stimulus_set_manifest_sha256"] = "c" * 64  # as the set was when sim01 ran
    sidecar.write_text(json.dumps(data))
    before = sorted(p.name for p in out.iterdir())
    capsys.readouterr()
    assert main([*run, "--participants", "2", "--resume"]) == 2
    err = capsys.readouterr().err
    assert (
        f"(manifest sha256 {now[:12]}…): sim01 of this batch in {out} ran on the set with "
        "manifest sha256 cccccccccccc… (rebuilt since?); a batch goes on with the set it began "
        "with: give that set (--stimuli), or another --out for a batch on this one"
    ) in err
    assert sorted(p.name for p in out.iterdir()) == before


def test_an_out_folder_that_cannot_be_made_is_named_as_out(tmp_path, capsys):
    """'[Errno 2] No such file or directory: '/proc/x'' named neither --out nor the folder."""
    (tmp_path / "a-file").write_text("")
    out = tmp_path / "a-file" / "x"  # under a file: no folder can be made there
    run = ["run", "luidolt2020", "--simulate", "--participants", "1", "--out", str(out)]
    assert main(run) == 2
    err = capsys.readouterr().err
    assert f"--out {out}: cannot create the folder (" in err, err


def test_a_completed_session_that_lost_or_changed_rows_is_not_kept(tmp_path, capsys):
    """It was "completed before, kept" (exit 0) with half its rows; analyse refused it later."""
    run = ["run", "luidolt2020", "--simulate", "--seed", "4", "--participants", "2"]
    for damage in ("cut", "edited"):
        out = tmp_path / damage
        assert main([*run, "--out", str(out)]) == 0
        (second,) = out.glob("sim02_*.csv")
        lines = second.read_text().splitlines(keepends=True)
        if damage == "cut":
            second.write_text("".join(lines[:3]))  # the header and two of the six trials
        else:
            cells = lines[2].rstrip("\r\n").split(",")
            cells[-2] = "1" if cells[-2] != "1" else "2"  # one rating changed
            lines[2] = ",".join(cells) + "\n"
            second.write_text("".join(lines))
        capsys.readouterr()
        assert main([*run, "--out", str(out), "--resume"]) == 2
        err = capsys.readouterr().err
        assert "sim01: completed before, kept" in err
        named = "trials 3-6 of the 6" if damage == "cut" else "trial 2 is not the row"
        assert f"{second.name}: {named}" in err and "give another --out" in err, err


def test_a_session_whose_csv_was_deleted_is_named_not_taken_for_a_new_one(tmp_path, capsys):
    """It was refused as 'already has data; ... or --resume', with --resume given."""
    run = ["run", "luidolt2020", "--simulate", "--seed", "5", "--participants", "2"]
    assert main([*run, "--out", str(tmp_path)]) == 0
    (second,) = tmp_path.glob("sim02_*.csv")
    second.unlink()
    capsys.readouterr()
    assert main([*run, "--out", str(tmp_path), "--resume"]) == 2
    err = capsys.readouterr().err
    assert f"{second.with_suffix('.json').name} has no CSV beside it" in err, err
    assert "or --resume to continue it" not in err
