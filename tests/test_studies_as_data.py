"""A study no code knows about runs from its protocol file alone, through every command."""

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from glarelab.experiments.matching import MatchingObserver
from glarelab.protocols import load_protocol
from glarelab.stimuli.matching import target_terms
from glarelab.stimuli.stimulus_set import StimulusSet

ROOT = Path(__file__).parents[1]

NEW_STUDY = """
[study]
name = "wave_vs_gaussian"
paradigm = "matching"
title = "A disk with Gaussian or wave-optics glare"
seed = 11

[display]
name = "a lab LCD"
resolution_px = [1920, 1200]
diagonal_in = 24.0
max_cd_m2 = 350.0
black_cd_m2 = 0.3
bit_depth = 10

[viewing]
distance_m = 0.8
room_lux = 10.0

[stimulus]
size_deg = 1.6
disk_deg = 0.24
supersample = 1
target_start_cd_m2 = [150.0]
gap_deg = 0.3

[background]
kind = "uniform"
cd_m2 = 40.0

[glare]
l_dmax_cd_m2 = 200.0

[[glare.methods]]
name = "gauss"
model = "gaussian"
parameters = { sigma_deg = 0.2 }
labels = ["g200", "g900", "g3000", "g9000"]
levels_cd_m2 = [200.0, 900.0, 3000.0, 9000.0]

[[glare.methods]]
name = "eye"
model = "wave"
parameters = { pupil_mm = 4.0, eyelashes = false, eyelid = false, particles = 300, seed = 5 }
labels = ["w200", "w900", "w3000", "w9000"]
levels_cd_m2 = [200.0, 900.0, 3000.0, 9000.0]

[trials]
settings = "single"
training_trials = 1
order = "random"
coarse_step_cd_m2 = 10.0
fine_step_cd_m2 = 1.0

[instructions]
text = "Set the disk on the right to look as bright as the one on the left."

[[questionnaire.questions]]
column = "halo"
text = "Do you see a halo?"
simulated_by = "glow"

[analysis]
compare_methods_at = [3, 4]
"""


def glarelab(*args, timeout=900):
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return done


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    protocol = folder / "wave_vs_gaussian.toml"
    protocol.write_text(NEW_STUDY)
    glarelab("protocol", "check", protocol)
    glarelab("stimuli", "build", protocol, "--out", folder / "set")
    return protocol, folder


def test_a_new_study_builds_simulates_and_analyses_through_the_cli(study):
    protocol, folder = study
    glarelab(
        "run", protocol, "--simulate", "--participants", 6, "--seed", 3,
        "--stimuli", folder / "set", "--out", folder / "data",
    )  # fmt: skip
    csvs = sorted((folder / "data").glob("sim*_wave_vs_gaussian_s1_*.csv"))
    assert len(csvs) == 6
    data = pd.concat([pd.read_csv(p) for p in csvs])
    assert set(data["method"]) == {"gauss", "eye"} and "halo" in data
    assert "darker_cd_m2" not in data  # one target: the protocol's "single" setting
    glarelab("analyse", protocol, *csvs, "--out", folder / "report")
    report = (folder / "report" / "report.html").read_text()
    assert "A disk with Gaussian or wave-optics glare" in report
    anova = pd.read_csv(folder / "report" / "anova.csv")
    assert list(anova["source"]) == ["L_disk", "method", "L_disk × method"]
    assert anova["df1"].tolist() == [3, 1, 3]  # 4 levels × 2 methods
    tests = pd.read_csv(folder / "report" / "methods_at_levels.csv")
    assert set(tests["level"]) == {"g3000/w3000", "g9000/w9000"}
    methods = (folder / "report" / "methods.md").read_text()
    assert "wave (pupil_mm = 4.0" in methods and "uniform field of 40 cd/m²" in methods


def test_simulated_observers_answer_from_the_images_not_the_labels(study, tmp_path):
    """The same images under other method names and labels are perceived the same; levels at
    or below L_dmax show no boost; more glare light around the disk, a larger boost."""
    protocol_path, folder = study
    protocol = load_protocol(protocol_path)
    observer = MatchingObserver(protocol, "sim01", seed=1, stimuli=StimulusSet(folder / "set"))

    def percept(name):
        return observer._percept([(name, 1.0)])

    low = percept("reference_gauss_g200")
    plain = observer._percept(target_terms(200.0))  # the glare-free disk at the same level
    assert low == plain and abs(low.boost) < 0.005  # nothing above L_dmax: no glare, no boost
    boosts = [percept(f"reference_gauss_g{x}").boost for x in (900, 3000, 9000)]
    assert all(b > 0 for b in boosts) and boosts == sorted(boosts)
    # the same study with its methods renamed and relabelled: the same images, the same percepts
    renamed = (
        NEW_STUDY.replace('name = "gauss"', 'name = "first"')
        .replace('"g200", "g900", "g3000", "g9000"', '"L1", "L2", "L3", "L4"')
        .replace('name = "eye"', 'name = "second"')
    )
    (tmp_path / "renamed.toml").write_text(renamed)
    glarelab("stimuli", "build", tmp_path / "renamed.toml", "--out", tmp_path / "set")
    other = MatchingObserver(
        load_protocol(tmp_path / "renamed.toml"),
        "sim01",
        seed=1,
        stimuli=StimulusSet(tmp_path / "set"),
    )
    assert other._percept([("reference_first_L4", 1.0)]) == percept("reference_gauss_g9000")
    assert other._percept([("reference_second_w9000", 1.0)]) == percept("reference_eye_w9000")


def test_the_shipped_study_of_four_glare_models_runs_from_its_file(tmp_path):
    out = tmp_path / "demo"
    glarelab(
        "demo", "--protocol", "glare_methods2026", "--participants", 4, "--out", out,
        timeout=1800,
    )  # fmt: skip
    anova = pd.read_csv(out / "report" / "anova.csv")
    main = anova[anova["analysis"] == "5 × 4 (all levels)"]
    assert list(main["df1"]) == [4, 3, 12]  # 5 levels × 4 methods
    manifest = json.loads((out / "stimuli" / "manifest.json").read_text())
    assert {r.get("method") for r in manifest["images"].values()} >= {
        "gaussian",
        "vos",
        "kakimoto",
        "luidolt",
    }
