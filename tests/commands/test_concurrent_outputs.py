"""Processes started at once on one output never lose a file: each calibration gets its own
name, chosen by an exclusive create; the others below each name what two runs on one output
do."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from glarelab.display.calibration import Calibration
from glarelab.files.folders import LISTING, listed_files

ROOT = Path(__file__).parents[2]
READINGS = ROOT / "calibrations" / "example-readings.csv"
PYTHON = [sys.executable, "-m", "glarelab"]


def at_once(argvs: list[list[str]], **options) -> list[subprocess.CompletedProcess]:
    """Start every command before waiting for any (real processes, racing for the output)."""
    running = [
        subprocess.Popen(
            [*PYTHON, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **options
        )
        for argv in argvs
    ]
    done = []
    for process in running:
        out, err = process.communicate(timeout=600)
        done.append(subprocess.CompletedProcess(process.args, process.returncode, out, err))
    return done


def test_calibrations_fitted_at_once_to_one_out_are_all_kept(tmp_path):
    out = tmp_path / "lab.json"
    labels = [f"run{i}" for i in range(4)]
    fit = ["calibrate", "fit", str(READINGS), "--out", str(out)]
    for rounds in range(2):  # a free --out, then one that exists
        done = at_once([[*fit, "--label", f"{label}-{rounds}"] for label in labels])
        assert all(d.returncode == 0 for d in done), [d.stderr for d in done]
    files = sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".json")
    files.remove(LISTING)  # glarelab's own record of the files it wrote there
    assert len(files) == 8, files
    # each run listed its calibration as glarelab's, none lost another's entry, so a later
    # measure or --replace may take any of them
    assert sorted(listed_files(tmp_path)) == files
    kept = {Calibration.load(tmp_path / name).label for name in files}
    assert kept == {f"{label}-{rounds}" for label in labels for rounds in range(2)}
    said = [
        line for d in done for line in d.stderr.splitlines() if "the new calibration is" in line
    ]
    assert len({line.rsplit(" is ", 1)[-1] for line in said}) == 4  # four names, none shared


def test_replacing_one_calibration_at_once_keeps_every_calibration(tmp_path):
    out = tmp_path / "lab.json"
    fit = ["calibrate", "fit", str(READINGS), "--out", str(out)]
    assert subprocess.run([*PYTHON, *fit, "--label", "first"], check=False).returncode == 0
    done = at_once([[*fit, "--replace", "--label", f"new{i}"] for i in range(3)])
    ended = [d.returncode for d in done]
    assert set(ended) <= {0, 2}, [d.stderr for d in done]
    labels = [
        json.loads(p.read_text()).get("label") for p in tmp_path.iterdir() if p.suffix == ".json"
    ]
    # the first calibration is kept once per replacement made; each new one made is there
    made = {f"new{i}" for i, code in enumerate(ended) if code == 0}
    assert made and made <= set(labels)
    assert labels.count("first") >= 1
    for d in done:
        if d.returncode == 2:
            assert "another glarelab" in d.stderr and "Traceback" not in d.stderr


def one_held_the_other_refused(done: list[subprocess.CompletedProcess], kind: str) -> None:
    """Two runs on one folder replaced whole: one made it; the other, if it started while the
    first held the folder, was refused naming it (each said "done" of an output the later
    one then replaced, with another calibration's images)."""
    codes = [d.returncode for d in done]
    assert set(codes) <= {0, 2} and 0 in codes, [d.stderr for d in done]
    for refused in (d for d in done if d.returncode == 2):
        assert f"is in use by another glarelab {kind} (pid " in refused.stderr, refused.stderr
        assert "nothing was changed" in refused.stderr and "Traceback" not in refused.stderr


def test_sets_built_at_once_into_one_folder_end_as_one_whole_set(tmp_path):
    out = tmp_path / "set"
    build = ["stimuli", "build", "spencer1995", "--out", str(out)]
    for _rounds in range(2):  # a new folder, then an earlier set replaced
        done = at_once([build, build])
        one_held_the_other_refused(done, "stimulus set build")
        verify = subprocess.run(
            [*PYTHON, "stimuli", "verify", str(out)], capture_output=True, text=True, check=False
        )
        assert verify.returncode == 0, verify.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set"]  # nothing left beside it


def test_sessions_and_reports_at_once_lose_nothing(tmp_path):
    data = tmp_path / "data"
    run = ["run", "luidolt2020", "--simulate", "--out", str(data)]
    done = at_once([[*run, "--participant", p] for p in ("P01", "P02", "P01")])
    codes = sorted(d.returncode for d in done)
    assert codes == [0, 0, 2], [d.stderr for d in done]  # one P01 is held by the other
    assert any("P01" in d.stderr and d.returncode == 2 for d in done)
    csvs = sorted(data.glob("*.csv"))
    assert [p.name.split("_")[0] for p in csvs] == ["P01", "P02"]
    report = tmp_path / "report"
    analyse = ["analyse", "luidolt2020", *map(str, csvs), "--out", str(report)]
    done = at_once([analyse, analyse])
    one_held_the_other_refused(done, "analysis")
    assert (report / "results.md").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "report"]


def test_a_name_claimed_between_the_look_and_the_check_sends_the_run_to_the_next(
    tmp_path, monkeypatch
):
    # another run creates lab.json (its empty claim, not yet listed) after this one saw the
    # name free and before its check: this run takes lab-2.json (it was refused as "glarelab
    # did not write it there", one run in four at once on a loaded machine)
    from glarelab.commands import calibrate

    out = tmp_path / "lab.json"
    real = calibrate.output_file

    def raced(path, *args, **options):
        if Path(path) == out and not out.exists():
            out.touch()  # the other run's claim
        return real(path, *args, **options)

    monkeypatch.setattr(calibrate, "output_file", raced)
    assert calibrate.calibration_out(out, replace=False, claim=True) == tmp_path / "lab-2.json"
    assert out.stat().st_size == 0  # the other run's name, left to it


def test_simulated_sessions_started_at_once_share_one_cached_set(tmp_path):
    """Simulated sessions at once on an empty cache each built the protocol's set into it; with
    one build into a folder at a time the second would be refused, so the others wait for the
    first build and use its set."""
    import os

    env = {**os.environ, "GLARELAB_CACHE": str(tmp_path / "cache")}
    run = ["run", "spencer1995", "--simulate", "--out", str(tmp_path / "data")]
    done = at_once([[*run, "--participant", p] for p in ("P01", "P02")], env=env)
    assert [d.returncode for d in done] == [0, 0], [d.stderr for d in done]
    (cached,) = (tmp_path / "cache" / "sets").iterdir()
    assert [p.name for p in (tmp_path / "cache" / "sets").glob(".*")] == []  # no lock left
    assert len(list((tmp_path / "data").glob("P0*_spencer1995_s1_*.csv"))) == 2
    assert cached.name.startswith("spencer1995-")
