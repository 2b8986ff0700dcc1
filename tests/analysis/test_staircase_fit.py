"""The psychometric fit of a staircase against R's glm (``tests/analysis/R``:
``psychometric_glm.csv``, fitted to ``psychometric_staircases.csv``), its refusals, and the
reversal match's bootstrap interval."""

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from glarelab.analysis.staircase import psychometric_fit, reversal_match, reversal_range

from .test_stats import read_r

ANSWERS = {1.0: "glare", 0.0: "disc", 0.5: "neither"}
STEEP = 300  # per unit of the display maximum: flatter fits agree with glm to rounding


def staircases():
    data = read_r("psychometric_staircases.csv")
    return {
        name: pd.DataFrame(
            {"disc_fraction": part["disc_fraction"], "response": part["y"].map(ANSWERS)}
        )
        for name, part in data.groupby("staircase", sort=False)
    }


@pytest.fixture(scope="module")
def fits():
    glm = read_r("psychometric_glm.csv").set_index("staircase")
    return {name: (psychometric_fit(s), glm.loc[name]) for name, s in staircases().items()}


def test_fits_match_rs_glm_where_the_likelihood_has_a_maximum(fits):
    compared = 0
    for name, (ours, theirs) in fits.items():
        if ours["status"] != "estimated" or not math.isfinite(ours["slope"]):
            continue
        if abs(theirs["b1"]) < STEEP:
            assert_allclose(ours["match"], theirs["centre"], rtol=1e-9, err_msg=name)
            assert_allclose(ours["slope"], theirs["b1"], rtol=1e-9, err_msg=name)
            assert_allclose(ours["slope_p"], theirs["lr_p"], rtol=1e-6, err_msg=name)
            compared += 1
        else:  # a flat ridge: both stop on it; the 50 % point agrees
            assert_allclose(ours["match"], theirs["centre"], atol=2e-4, err_msg=name)
    assert compared >= 20


def test_separated_answers_are_not_estimable_where_glm_warns(fits):
    separated = [n for n, (ours, _) in fits.items() if "separated" in ours["status"]]
    assert separated
    for name in separated:
        ours, theirs = fits[name]
        assert theirs["fitted_0_or_1"], name  # glm's own warning of separation
        assert math.isnan(ours["match"])
        low, high = (float(v) for v in ours["status"].split("between ")[1].split(" and "))
        assert low < theirs["centre"] < high  # glm's number is somewhere in the gap


def test_one_changing_intensity_gives_the_limit_of_the_fit(fits):
    quasi = [n for n, (ours, _) in fits.items() if "one disc intensity" in ours["status"]]
    assert quasi
    for name in quasi:
        ours, theirs = fits[name]
        # glm stops on its way to the limit (where its deviance stops changing by 1e-14),
        # and warns of fitted probabilities of 0 or 1
        assert theirs["fitted_0_or_1"], name
        assert abs(theirs["b1"]) > 100, name  # glm on its way to an infinite slope
        assert_allclose(ours["match"], theirs["centre"], atol=2e-3, err_msg=name)
        assert ours["match"] in set(staircases()[name]["disc_fraction"])


@pytest.mark.parametrize(
    ("name", "why"),
    [
        ("flat_all_glare", "never change"),
        ("rising_wrong_sign", "wrong sign"),
        ("centre_outside", "outside the tested range"),
        ("separated_neither_none", "separated"),
    ],
)
def test_staircases_without_a_usable_slope_say_why(fits, name, why):
    ours, _ = fits[name]
    assert math.isnan(ours["match"])
    assert why in ours["status"]


def test_a_flat_staircase_has_no_slope():
    x = np.tile([0.4, 0.45, 0.5, 0.55, 0.6], 4)
    answers = ["glare", "disc"] * 10
    fit = psychometric_fit(pd.DataFrame({"disc_fraction": x, "response": answers}))
    assert "no slope" in fit["status"] and math.isnan(fit["match"])


def test_the_reversal_range_is_the_lowest_and_highest_reversal_the_match_averages():
    reversal = [False, True, False, True, True, False, True, True, True, False, True]
    staircase = pd.DataFrame(
        {
            "disc_fraction": [0.9, 0.5, 0.6, 0.55, 0.6, 0.5, 0.58, 0.52, 0.6, 0.5, 0.57],
            "reversal": reversal,
        }
    )
    low, high = reversal_range(staircase)
    # the reversals after the first two: 0.6, 0.58, 0.52, 0.6, 0.57
    assert (low, high) == (0.52, 0.6)
    assert low < reversal_match(staircase) < high
    none = staircase.assign(reversal=[False] * 11)
    assert all(math.isnan(v) for v in reversal_range(none))
