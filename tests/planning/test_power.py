import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats as sps

from glarelab.planning.execute import dask_client
from glarelab.planning.power import binomial_interval, power_analysis, recommend, summarise
from glarelab.protocols import load_protocol

SILENT = {"log": lambda message: None, "progress": False}


@settings(max_examples=50, deadline=None)
@given(trials=st.integers(1, 3000), share=st.floats(0, 1))
def test_the_interval_is_the_exact_binomial_one(trials, share):
    successes = round(share * trials)
    expected = sps.binomtest(successes, trials).proportion_ci(0.95, method="exact")
    assert_allclose(binomial_interval(successes, trials), (expected.low, expected.high), atol=1e-9)
    low, high = binomial_interval(successes, trials)
    assert 0 <= low <= successes / trials <= high <= 1


def _record(replication, p_by_n):
    return {
        "replication": replication,
        "results": [
            {"n": n, "effect": "e", "test": "t", "p": p, "size": p, "size_name": "d"}
            for n, p in p_by_n.items()
        ],
        "failures": [],
    }


def test_power_counts_replications_below_alpha_and_failures_count_as_misses():
    records = [_record(r, {4: 0.5, 8: 0.01 if r < 7 else 0.2}) for r in range(10)]
    records[9]["results"] = [records[9]["results"][0]]  # n = 8 refused by the analysis
    power, sizes = summarise(records, alpha=0.05)
    row = power.set_index("participants").loc[8]
    assert (row["power"], row["significant"], row["failed"], row["replications"]) == (
        0.7,
        7,
        1,
        10,
    )
    assert power.set_index("participants").loc[4, "power"] == 0.0
    assert sizes.set_index("participants").loc[8, "q50"] == pytest.approx(0.01)


def test_recommended_sample_sizes():
    table = pd.DataFrame(
        {
            "effect": ["a"] * 3 + ["b"] * 3,
            "participants": [6, 8, 10] * 2,
            "power": [0.5, 0.85, 0.95, 0.1, 0.2, 0.3],
            "ci_low": [0.4, 0.79, 0.9, 0.05, 0.1, 0.2],
        }
    )
    result = recommend(table, target=0.8).set_index("effect")
    assert result.loc["a", "n_power"] == 8 and result.loc["a", "n_confident"] == 10
    assert pd.isna(result.loc["b", "n_power"]) and result.loc["b", "power_at_largest"] == 0.3


@pytest.mark.parametrize(
    "bad, message",
    [
        ({"participants": [1, 4]}, "participants must be sample sizes from 2 to 999"),
        ({"participants": [4, 1000]}, "participants must be sample sizes from 2 to 999"),
        ({"seed": -1}, "seed must be a whole number >= 0"),
        ({"replications": 0}, "replications must be an integer >= 1"),
        ({"alpha": 0.0}, "alpha must be in"),
        ({"correction": "greenhouse"}, "correction must be one of"),
        ({"target": 1.0}, "target must be in"),
    ],
)
def test_bad_arguments_are_refused_before_anything_runs(tmp_path, bad, message):
    arguments = {"participants": [4], "replications": 2, "seed": 1} | bad
    with pytest.raises(ValueError, match=message):
        power_analysis(load_protocol("luidolt2020"), tmp_path / "out", **arguments, **SILENT)
    assert not (tmp_path / "out").exists()  # refused before anything is written


def test_the_same_power_on_one_or_two_workers_or_none(tmp_path):
    protocol = load_protocol("luidolt2020")
    arguments = {"participants": [5, 8], "replications": 8, "seed": 2} | SILENT
    power_analysis(protocol, tmp_path / "here", **arguments)
    for workers in (1, 2):
        with dask_client(workers=workers) as client:
            power_analysis(protocol, tmp_path / f"w{workers}", client=client, **arguments)
    for name in ("power.csv", "effect_sizes.csv", "recommended.csv"):
        here = (tmp_path / "here" / name).read_bytes()
        assert (
            here == (tmp_path / "w1" / name).read_bytes() == (tmp_path / "w2" / name).read_bytes()
        )
    power = pd.read_csv(tmp_path / "here" / "power.csv")
    assert len(power) == 6 * 2 and (power["replications"] == 8).all()
    # more replications later: the first eight are reused, not run again
    before = (tmp_path / "here" / "replications.jsonl").read_text().splitlines()
    power_analysis(protocol, tmp_path / "here", **(arguments | {"replications": 10}))
    after = (tmp_path / "here" / "replications.jsonl").read_text().splitlines()
    assert after[:8] == before and len(after) == 10


def test_a_folder_of_other_inputs_is_refused(tmp_path):
    protocol = load_protocol("luidolt2020")
    power_analysis(protocol, tmp_path, participants=[4], replications=1, seed=1, **SILENT)
    with pytest.raises(ValueError, match="seed 1 then, 2 now"):
        power_analysis(protocol, tmp_path, participants=[4], replications=1, seed=2, **SILENT)
    run = json.loads((tmp_path / "run.json").read_text())
    assert run["protocol_sha256"] == protocol.sha256 and run["participants"] == [4]


def test_spencer_with_fewer_participants_than_levels_uses_the_lower_bound(tmp_path):
    protocol = load_protocol("spencer1995")
    power_analysis(protocol, tmp_path, participants=[3], replications=1, seed=1, **SILENT)
    power = pd.read_csv(tmp_path / "power.csv").set_index("effect")
    assert power.loc["ANOVA: glare_level", "p_used"] == "lower bound"
    assert power.loc["ANOVA: context", "p_used"] == "GG"  # 1 df: sphericity holds
    assert (tmp_path / "power_curves.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("arguments", "match"),
    [
        ((1, 10, 95), r"level must be a confidence level in \(0, 1\), e\.g\. 0\.95; got 95"),
        ((1, 10, 0), r"level must be a confidence level in \(0, 1\)"),
        ((1.5, 10, 0.95), r"successes must be a whole number; got 1\.5"),
        (("1", 10, 0.95), r"successes must be a whole number; got '1'"),
        ((1, True, 0.95), r"trials must be a whole number; got True"),
    ],
)
def test_binomial_interval_refuses_what_is_no_count_or_level(arguments, match):
    # a level of 95 gave (nan, nan) and a level of 0 a narrow interval, without a word
    successes, trials, level = arguments
    with pytest.raises(ValueError, match=match):
        binomial_interval(successes, trials, level=level)


@pytest.mark.parametrize("level", [np.complex128(0.95), 0.95 + 0j, "0.95", True])
def test_binomial_interval_names_a_level_that_is_not_a_real_number(level):
    """A complex level gave scipy's "ufunc '_beta_ppf' not supported for the input types"."""
    with pytest.raises(ValueError, match=r"^level must be a confidence level in"):
        binomial_interval(1, 2, level=level)


@pytest.mark.parametrize("target", ["0.8", 0.8 + 0j, True])
def test_recommend_names_a_target_that_is_not_a_number(target):
    """'<' not supported between instances of 'int' and 'str'."""
    table = pd.DataFrame({"effect": ["a"], "participants": [6], "power": [0.7], "ci_low": [0.6]})
    with pytest.raises(ValueError, match=r"^target must be a number in \(0, 1\); got"):
        recommend(table, target=target)


@pytest.mark.parametrize(
    ("power", "pattern"),
    [
        ([1, 2, 3], r"^power must be the power table .*got list"),  # 'list' has no groupby
        (pd.DataFrame({"effect": ["a"], "participants": [6], "power": [0.7]}), "has no ci_low"),
    ],
)
def test_recommend_names_a_power_table_it_cannot_read(power, pattern):
    with pytest.raises(ValueError, match=pattern):
        recommend(power)
