"""scripts/staircase_coverage.py: the coverage simulation of a staircase's interval with known
truth (docs/analysis.md gives its table); a quick run, and its pieces against known answers."""

import importlib.util
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from glarelab.protocols import load_protocol

SCRIPT = Path(__file__).parents[1] / "scripts" / "staircase_coverage.py"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("staircase_coverage", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_quick_run_gives_every_candidate_for_every_condition(script, tmp_path, capsys):
    out = tmp_path / "staircases.csv"
    assert script.main(["--per-condition", "2", "--seed", "3", "--out", str(out)]) == 0
    table = capsys.readouterr().out
    for name in script.CANDIDATES:
        assert name in table.splitlines()[0]
    data = pd.read_csv(out)
    assert len(data) == 2 * 2 * len(script.CONDITIONS)
    assert data["truth"].between(0.3, 0.9).all()


def test_the_staircases_follow_the_protocols_rules_on_its_grid(script):
    protocol = load_protocol("spencer1995")
    rng = np.random.default_rng(1)
    staircase = script.run(protocol, 0.6, 0.001, 0.0, "hold", rng)
    assert staircase["disc_fraction"].iloc[0] == protocol["trials"]["start_fraction"]
    assert np.all(np.isclose(staircase["disc_fraction"] * 50 % 1, 0) | np.isclose(
        staircase["disc_fraction"] * 50 % 1, 1))  # fmt: skip
    assert staircase["reversal"].sum() == protocol["trials"]["reversals"]
    # an observer without noise brackets its match within the finest step
    kept = script.kept_reversals(staircase)
    assert abs(kept.mean() - 0.6) <= 0.02


def test_fieller_holds_the_fits_match_and_is_unbounded_without_a_slope(script):
    rng = np.random.default_rng(5)
    x = np.repeat(np.linspace(0.3, 0.9, 13), 6)
    answer = rng.uniform(size=x.size) < 1 / (1 + np.exp(-(0.6 - x) / 0.05))
    staircase = pd.DataFrame({"disc_fraction": x, "response": np.where(answer, "glare", "disc")})
    low, high = script.fieller(staircase)
    match = script.psychometric_fit(staircase)["match"]
    assert low < match < high and math.isfinite(low) and math.isfinite(high)
    flat = staircase.assign(response=np.where(rng.uniform(size=x.size) < 0.5, "glare", "disc"))
    low, high = script.fieller(flat)  # no slope: no fit, or no bound
    assert not (math.isfinite(low) and math.isfinite(high))
