import json

import pandas as pd
import pytest

from glarelab.planning.grid import parse_setting
from glarelab.planning.sweep import prepare, sweep
from glarelab.stimuli.stimulus_set import verify_stimulus_set

SILENT = {"log": lambda message: None, "progress": False}


def test_a_sweep_builds_one_verified_set_per_point_and_resumes(tmp_path):
    settings = [parse_setting("stimulus.disk_deg=0.2,0.4")]
    index = sweep("yoshida2008", settings, tmp_path, **SILENT)
    assert list(index["stimulus.disk_deg"]) == ["0.2", "0.4"]
    for row in index.itertuples():
        folder = tmp_path / row.folder
        assert not verify_stimulus_set(folder)
        manifest = json.loads((folder / "manifest.json").read_text())
        assert manifest["protocol_sha256"] == row.protocol_sha256
        assert manifest["protocol"]["stimulus"]["disk_deg"] == [0.2, 0.4][row.point]
    assert index["manifest_sha256"].nunique() == 2
    written = (tmp_path / "sets" / "000" / "manifest.json").stat().st_mtime_ns
    (tmp_path / "points.jsonl").unlink()  # the sets stay: they are verified, not rebuilt
    again = sweep("yoshida2008", settings, tmp_path, **SILENT)
    assert (tmp_path / "sets" / "000" / "manifest.json").stat().st_mtime_ns == written
    pd.testing.assert_frame_equal(again.drop(columns="build_s"), index.drop(columns="build_s"))
    with pytest.raises(ValueError, match=r"other inputs \(stimulus.disk_deg = 0.2,0.4 then, 0.3 "):
        sweep("yoshida2008", [parse_setting("stimulus.disk_deg=0.3")], tmp_path, **SILENT)
    # another seed was refused as "another grid, protocol or simulation", not naming it
    with pytest.raises(ValueError, match=r"other inputs \(seed 1 then, 7 now\): give another"):
        sweep("yoshida2008", settings, tmp_path, seed=7, **SILENT)


def test_a_sweep_of_another_grid_or_study_is_named_with_what_differs(tmp_path):
    """A sweep re-run into an earlier --out with another value, the same values in another
    order or another study was refused only as "another grid or protocol"."""
    seeds = [parse_setting("study.seed=1,2")]
    _, record = prepare("luidolt2020", seeds, tmp_path, simulate=3)
    (tmp_path / "sweep.json").write_text(json.dumps(record))
    assert prepare("luidolt2020", seeds, tmp_path, simulate=3)[1] == record
    for study, text, said in [
        ("luidolt2020", "study.seed=1,3", "study.seed = 1,2 then, 1,3 now"),
        ("yoshida2008", "study.seed=1,2", "protocol luidolt2020 then, yoshida2008 now"),
        (
            "luidolt2020",
            "study.seed=2,1",
            "the same points in another order, study.seed = 1,2 then, 2,1 now: give them in "
            "the earlier order to resume it",
        ),
    ]:
        with pytest.raises(ValueError) as refused:
            prepare(study, [parse_setting(text)], tmp_path, simulate=3)
        assert str(refused.value) == (
            f"{tmp_path} holds a sweep of other inputs ({said}): give another --out, or delete "
            "it to start again"
        )
    # a sweep.json written before the grid was recorded in it resumes on the same points
    older = {k: v for k, v in record.items() if k not in ("study", "grid")}
    (tmp_path / "sweep.json").write_text(json.dumps(older))
    assert prepare("luidolt2020", seeds, tmp_path, simulate=3)[1] == record
    with pytest.raises(ValueError, match=r"other inputs \(another grid or protocol\)"):
        prepare("luidolt2020", [parse_setting("study.seed=1,3")], tmp_path, simulate=3)


def test_a_questionnaire_sweep_needs_simulation_and_gives_its_tests(tmp_path):
    setting = [parse_setting("study.seed=1,2")]
    with pytest.raises(ValueError, match=r"shows no images.*--simulate N"):
        sweep("luidolt2020", setting, tmp_path / "a", **SILENT)
    sweep("luidolt2020", setting, tmp_path / "b", simulate=5, **SILENT)
    effects = pd.read_csv(tmp_path / "b" / "effects.csv")
    assert set(effects["point"]) == {0, 1}
    assert "Wilcoxon Overall vs 4 (Holm)" in set(effects["effect"])
    assert (tmp_path / "b" / "simulated" / "001" / "report" / "report.html").is_file()


def test_a_sweep_run_again_after_a_kill_leaves_no_half_built_set(tmp_path):
    """SIGKILL during a sweep left ``sets/.building-XXXX`` and a staging folder inside it that
    the run started again never removed."""
    import subprocess
    import sys

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()  # fmt: skip
    staging = tmp_path / "sets" / f".000.building-{dead}"
    staging.mkdir(parents=True)
    (staging / "reference_vos_b_10bit.png").write_bytes(b"half")
    sweep("yoshida2008", [parse_setting("stimulus.disk_deg=0.2")], tmp_path, **SILENT)
    assert sorted(p.name for p in (tmp_path / "sets").iterdir()) == ["000"]
    assert not verify_stimulus_set(tmp_path / "sets" / "000")
