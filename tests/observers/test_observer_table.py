"""A protocol's ``[observer]`` table is refused naming the file, the key, its value and what
is allowed (glarelab.observers.noise.observer_parameters)."""

from __future__ import annotations

import pytest

from glarelab.observers.noise import observer_parameters


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"glow_gain": -1}, "lab.toml: observer.glow_gain must be in [0, 10], got -1"),
        ({"sectors": 2.5}, "lab.toml: observer.sectors must be an integer >= 1, got 2.5"),
        ({"margin": "wide"}, "lab.toml: observer.margin "),
        ({"glo_gain": 1}, "lab.toml: observer: unknown key(s) glo_gain (known: "),
    ],
)
def test_a_bad_key_is_named_with_its_file(table, message):
    with pytest.raises(ValueError) as raised:
        observer_parameters({"glow_gain": 0.3, **table}, source="lab.toml")
    assert str(raised.value).startswith(message), raised.value


@pytest.mark.parametrize("table", [None, [("glow_gain", 0.3)], "glow_gain = 0.3"])
def test_a_table_that_is_not_one_is_a_type_error(table):
    with pytest.raises(TypeError, match=r"^lab\.toml: observer must be a table of keys; got"):
        observer_parameters(table, source="lab.toml")
