"""The simulated power of a design whose power is known: a one-way repeated-measures ANOVA with
sphericity holding (noncentral F), through the same tasks, result log and summary as a
protocol's power analysis."""

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats as sps

from glarelab.planning.analytic import OneWayJob, noncentrality, one_way_power
from glarelab.planning.execute import ResultLog, run_tasks
from glarelab.planning.power import summarise

MEANS = [0.0, 0.3, 0.6, 0.9]  # four conditions; σ = 1 within subjects


def test_without_an_effect_the_power_is_alpha():
    for alpha in (0.01, 0.05, 0.2):
        assert one_way_power([2.0] * 5, error_sd=0.5, subjects=9, alpha=alpha) == alpha


def test_noncentrality_scales_with_subjects_and_error_variance():
    # λ = n Σ(μ - μ̄)² / σ² (Muller & Barton 1989 under sphericity): 10 × 0.45 / 1
    assert_allclose(noncentrality(MEANS, error_sd=1.0, subjects=10), 4.5, rtol=1e-12)
    assert_allclose(noncentrality(MEANS, error_sd=2.0, subjects=20), 4.5 / 2, rtol=1e-12)


def test_power_is_the_noncentral_f_tail_and_grows_with_subjects():
    powers = [one_way_power(MEANS, error_sd=1.0, subjects=n) for n in (4, 8, 16, 32)]
    assert all(a < b for a, b in itertools.pairwise(powers))
    critical = sps.f.isf(0.05, 3, 3 * 15)
    assert_allclose(powers[2], sps.ncf.sf(critical, 3, 45, 16 * 0.45), rtol=1e-12)


@pytest.mark.parametrize("bad", [{"error_sd": 0.0}, {"subjects": 1}, {"alpha": 1.0}])
def test_bad_arguments_are_refused(bad):
    arguments = {"error_sd": 1.0, "subjects": 8, "alpha": 0.05} | bad
    with pytest.raises(ValueError, match=next(iter(bad))):
        one_way_power(MEANS, **arguments)


def test_simulated_power_agrees_with_the_noncentral_f(tmp_path):
    """The acceptance check: 500 simulated studies per sample size, analysed by rm_anova; the
    exact power lies in the simulated power's 99 % interval at every sample size (a 95 % one
    misses one sample size in twenty by chance), and the simulated power of the uncorrected
    test is within 3 binomial SDs of it."""
    sizes = (6, 12)
    job = OneWayJob(MEANS, error_sd=1.0, subject_sd=2.0, participants=sizes, seed=17)
    with ResultLog(tmp_path / "log.jsonl") as log:
        run_tasks(job, range(500), log, progress=None)
        records = log.sorted()
    power, sizes_table = summarise(records, alpha=0.05, correction="none", level=0.99)
    for row in power.itertuples():
        exact = one_way_power(MEANS, error_sd=1.0, subjects=row.participants)
        assert row.ci_low <= exact <= row.ci_high, (row.participants, row.power, exact)
        sd = np.sqrt(exact * (1 - exact) / row.replications)
        assert abs(row.power - exact) < 3 * sd
    # corrected for sphericity that holds, the test can only lose power
    corrected, _ = summarise(records, alpha=0.05, correction="gg")
    assert (corrected["power"].to_numpy() <= power["power"].to_numpy()).all()
    assert (sizes_table["size"] == "partial eta squared").all()


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        ({"subjects": 10.5}, r"subjects must be a whole number >= 2; got 10\.5"),
        ({"subjects": True}, r"subjects must be a whole number >= 2; got True"),
        ({"error_sd": "1"}, r"error_sd must be a finite number > 0; got '1'"),
        ({"error_sd": float("inf")}, r"error_sd must be a finite number > 0; got inf"),
        ({"alpha": "0.05"}, r"alpha must be a number in \(0, 1\); got '0\.05'"),
    ],
)
def test_values_that_cannot_mean_a_design_are_refused_naming_them(bad, match):
    arguments = {"error_sd": 1.0, "subjects": 8, "alpha": 0.05} | bad
    with pytest.raises(ValueError, match=match):
        one_way_power(MEANS, **arguments)


def test_an_overwhelming_effect_has_power_one_not_nan():
    # λ overflows to inf (1e200 / 1e-200), and scipy's ncf.sf is NaN near λ = 1e300
    assert one_way_power([0.0, 1e200], error_sd=1e-200, subjects=10) == 1.0
    assert one_way_power([0.0, 1e150], error_sd=1.0, subjects=10) == 1.0


@pytest.mark.parametrize(
    "means",
    [["1", "2", "3"], [True, False, True], np.ma.array([1.0, 2.0, 9.0], mask=[0, 0, 1])],
)
def test_means_that_are_not_plain_numbers_are_refused(means):
    """Strings were read as numbers, bools as 0 and 1, a masked mean counted (power 1.0)."""
    with pytest.raises(ValueError, match="means_per_condition"):
        one_way_power(means, error_sd=1.0, subjects=10)


def test_a_complex_error_sd_is_refused():
    """np.complex128(1 + 1j) was taken as 1 (with numpy's ComplexWarning)."""
    with pytest.raises(ValueError, match=r"^error_sd must be a finite number > 0"):
        one_way_power([0.0, 1.0], error_sd=np.complex128(1 + 1j), subjects=5)


@pytest.mark.parametrize("alpha", [np.complex128(0.05), 0.05 + 0j])
def test_one_way_power_names_a_complex_alpha(alpha):
    """scipy's "ufunc 'fdtri' not supported for the input types" was all a user saw."""
    with pytest.raises(ValueError, match=r"^alpha must be a number in \(0, 1\); got"):
        one_way_power([0, 0.5], error_sd=1, subjects=10, alpha=alpha)


@pytest.mark.parametrize(
    ("option", "value"),
    [("seed", -1), ("seed", 1.5), ("seed", "a"), ("seed", None), ("seed", True),
     ("participants", [2.5, 6]), ("participants", [float("nan")]), ("participants", "46"),
     ("participants", []), ("participants", [1, 6]), ("error_sd", float("inf")),
     ("error_sd", "1"), ("subject_sd", float("nan")), ("subject_sd", -0.1),
     ("error_sd", 10**400), ("subject_sd", 10**400), ("subject_sd", True)],
)  # fmt: skip
def test_a_job_refuses_what_would_fail_only_on_a_worker(option, value):
    # each was taken, and failed in run() on a Dask worker with a message of numpy's
    options = {"error_sd": 1.0, "subject_sd": 0.5, "participants": [4, 6], "seed": 1}
    with pytest.raises(ValueError, match=rf"^{option} must be"):
        OneWayJob([0.0, 1.0], **{**options, option: value})
    job = OneWayJob([0.0, 1.0], **{**options, "participants": np.array([6, 4, 6])})
    assert job.participants == (4, 6) and job.run(0)["replication"] == 0
