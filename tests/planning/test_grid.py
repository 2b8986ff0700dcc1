import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.planning.grid import GridError, apply_setting, grid, parse_setting


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0.01, 1e6, allow_nan=False), min_size=1, max_size=6, unique=True))
def test_numbers_come_back_as_written(values):
    setting = parse_setting("stimulus.disk_deg=" + ",".join(repr(v) for v in values))
    assert setting.values == tuple(values)


def test_names_and_positions_reach_the_same_table():
    by_name, by_position = {"glare": {"methods": [{"name": "a"}, {"name": "vos", "x": 1}]}}, None
    by_position = {"glare": {"methods": [{"name": "a"}, {"name": "vos", "x": 1}]}}
    apply_setting(by_name, "glare.methods.vos.parameters.regime", "mesopic")
    apply_setting(by_position, "glare.methods[1].parameters.regime", "mesopic")
    assert by_name == by_position
    assert by_name["glare"]["methods"][1]["parameters"] == {"regime": "mesopic"}
    apply_setting(by_name, "glare.methods.vos.levels_cd_m2", [1.0, 2.0])
    apply_setting(by_name, "glare.methods.vos.levels_cd_m2[1]", 5.0)
    assert by_name["glare"]["methods"][1]["levels_cd_m2"] == [1.0, 5.0]


@pytest.mark.parametrize(
    "key, message",
    [
        (
            "glare.methods.nope.levels_cd_m2",
            "glare.methods has no table named 'nope' \\(names: a, vos",
        ),
        ("glare.methods[2].levels_cd_m2", "glare.methods has 2 entries, positions 0-1; got 2"),
        ("glare.methods[x].levels_cd_m2", "\\[x\\] must be a position from 0"),
        ("glare.methods.vos", "names a whole table"),
        ("glare.l_dmax_cd_m2.x", "glare.l_dmax_cd_m2 is a value, not a table"),
        ("glare..x", "'' is not a key|is not a key"),
    ],
)
def test_bad_paths_are_refused_naming_the_key(key, message):
    data = {"glare": {"l_dmax_cd_m2": 220.0, "methods": [{"name": "a"}, {"name": "vos"}]}}
    with pytest.raises(GridError, match=message):
        apply_setting(data, key, 1.0)


@pytest.mark.parametrize("text", ["stimulus.disk_deg", "stimulus.disk_deg=", "x=[1,"])
def test_bad_settings_are_refused(text):
    with pytest.raises(GridError, match="--set"):
        parse_setting(text)


@pytest.mark.parametrize(
    ("text", "twice"),
    [("trials.reversals=6,6", "6"), ("stimulus.disk_deg=0.2,0.3,0.20", "0.2"),
     ("trials.reversals=6,6.0", "6.0"), ("a.b=[1, 2],[1, 2]", r"\[1, 2\]")],
)  # fmt: skip
def test_a_value_given_twice_is_refused(text, twice):
    # trials.reversals=6,6 built the same stimulus set twice without a word
    with pytest.raises(GridError, match=rf"^--set [a-z._]+: the value {twice} is given twice"):
        parse_setting(text)
    assert parse_setting("a.b=true,1").values == (True, 1)  # a bool and a number differ


def test_a_grid_is_every_combination_each_validated():
    points = grid(
        "yoshida2008",
        [
            parse_setting("stimulus.disk_deg=0.2,0.5"),
            parse_setting("glare.methods.vos.parameters.regime=photopic,mesopic,scotopic"),
        ],
    )
    assert len(points) == 6
    assert points[1].values == {
        "stimulus.disk_deg": 0.2,
        "glare.methods.vos.parameters.regime": "mesopic",
    }
    assert points[1].protocol["glare"]["methods"][1]["parameters"]["regime"] == "mesopic"
    assert len({p.protocol.sha256 for p in points}) == 6


def test_a_grid_point_that_does_not_validate_names_the_key_and_values():
    with pytest.raises(GridError) as error:
        grid(
            "yoshida2008",
            [
                parse_setting("stimulus.disk_deg=0.3,99.0"),
                parse_setting("glare.methods[0].levelz=1"),
            ],
        )
    text = str(error.value)
    assert "glare.methods[0].levelz: unknown key" in text
    assert (
        "stimulus.disk_deg = 99.0" in text
        and "stimulus.disk_deg = 99.0: must be float, in [0.01, 10] deg" in text
    )
    with pytest.raises(GridError, match=r"each key once; repeated stimulus\.disk_deg"):
        grid(
            "yoshida2008",
            [parse_setting("stimulus.disk_deg=0.3"), parse_setting("stimulus.disk_deg=0.2")],
        )
