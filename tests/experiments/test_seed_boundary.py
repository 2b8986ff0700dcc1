"""The seed-taking functions at their boundary: a seed that is not an integer >= 0 (a float, a
bool, a negative number) and a participant that is not a string id are refused naming the
argument; they used to name another random stream silently (participant 7 and "7" shared
one, seed 1.5 made an observer of its own)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.bench.scenes import glints_scene, leaves_scene, sun_scene
from glarelab.experiments.engine import LookingObserver, participant_rng

SETTINGS = settings(max_examples=30, deadline=None)
NOT_A_SEED = st.one_of(
    st.integers(max_value=-1),
    st.floats(allow_nan=True),
    st.booleans(),
    st.text(max_size=3),
    st.none(),
    st.just(math.inf),
)
NOT_AN_ID = st.one_of(st.integers(), st.floats(), st.none(), st.just(""), st.booleans())


@SETTINGS
@given(data=st.data())
def test_participant_rng_refuses_a_bad_argument_naming_it(data):
    arguments = {"seed": 1, "participant": "p01", "purpose": "conditions"}
    name = data.draw(st.sampled_from(sorted(arguments)), label="argument")
    arguments[name] = data.draw(NOT_A_SEED if name == "seed" else NOT_AN_ID, label=name)
    with pytest.raises(ValueError, match=rf"^{name} must be"):
        participant_rng(**arguments)


@SETTINGS
@given(seed=st.integers(0, 2**62), participant=st.text(min_size=1, max_size=8))
def test_participant_rng_takes_any_integer_seed_and_text_id(seed, participant):
    first = participant_rng(seed, participant, "conditions").random()
    assert first == participant_rng(np.int64(seed), participant, "conditions").random()


class _Observer(LookingObserver):
    @staticmethod
    def judged(protocol, geometry):
        raise AssertionError("not reached: the arguments are refused first")


@SETTINGS
@given(data=st.data())
def test_an_observer_refuses_a_bad_seed_or_participant(data):
    name = data.draw(st.sampled_from(["seed", "participant"]), label="argument")
    arguments = {"seed": 0, "participant": "p01"}
    arguments[name] = data.draw(NOT_A_SEED if name == "seed" else NOT_AN_ID, label=name)
    with pytest.raises(ValueError, match=rf"^{name} must be"):
        _Observer(None, arguments.pop("participant"), stimuli=None, **arguments)


@pytest.mark.parametrize("scene", [sun_scene, leaves_scene, glints_scene])
@SETTINGS
@given(seed=NOT_A_SEED)
def test_a_bench_scene_refuses_a_bad_seed(scene, seed):
    with pytest.raises(ValueError, match=r"^seed must be an integer >= 0"):
        scene(8, seed=seed)
