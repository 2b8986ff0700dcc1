import copy
import datetime
import json
import pickle
import re
import tomllib
from pathlib import Path

import pytest

from glarelab.protocols import (
    PARADIGMS,
    ProtocolError,
    columns,
    describe_schema,
    load_protocol,
    parse_protocol,
    pixel_deg,
    shipped_protocols,
)

PROTOCOLS = Path(__file__).parents[2] / "src" / "glarelab" / "protocols"


def raw(study):
    return tomllib.loads((PROTOCOLS / f"{study}.toml").read_text())


@pytest.mark.parametrize("study", shipped_protocols())
def test_shipped_protocols_are_valid(study):
    protocol = load_protocol(study)
    assert protocol.study == study and protocol.paradigm in PARADIGMS
    assert len(protocol.sha256) == 64
    assert load_protocol(PROTOCOLS / f"{study}.toml").sha256 == protocol.sha256


def test_the_papers_are_protocols_of_the_three_paradigms():
    paradigms = {name: load_protocol(name).paradigm for name in shipped_protocols()}
    assert paradigms["yoshida2008"] == "matching"
    assert paradigms["spencer1995"] == "staircase"
    assert paradigms["luidolt2020"] == "rating"


def test_yoshida_values_are_the_papers():
    p = load_protocol("yoshida2008")
    gaussian, vos = p["glare"]["methods"]
    # Yoshida 2008 §3
    assert gaussian["levels_cd_m2"] == [220, 1165, 2110, 3055, 4000, 7000]
    assert vos["levels_cd_m2"] == [220, 1480, 2740, 4000, 7000, 10000]
    assert (gaussian["model"], gaussian["parameters"]) == ("gaussian", {"sigma_deg": 0.34})
    assert p["display"]["max_cd_m2"] == 433.0 and p["display"]["bit_depth"] == 10
    # 20.8" 4:3 2048 × 1536 at 1 m: pitch 0.2064 mm → 0.011824° per pixel (hand calculation)
    assert pixel_deg(p) == pytest.approx(0.0118244, rel=1e-5)


def method(data, index):
    return data["glare"]["methods"][index]


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: d["stimulus"].update(disk_degg=0.3), r"stimulus\.disk_degg: unknown key"),
        (
            lambda d: d["stimulus"].update(disk_deg=-0.3),
            r"stimulus\.disk_deg = -0\.3: must be float, in \[0\.01, 10\] deg",
        ),
        (
            lambda d: d["stimulus"].update(target_start_cd_m2=[100.0, 500.0]),
            r"stimulus\.target_start_cd_m2\[1\] = 500\.0: above what the display shows",
        ),
        (
            lambda d: d["glare"].update(l_dmax_cd_m2=500.0),
            r"glare\.l_dmax_cd_m2 = 500\.0: above what the display shows",
        ),
        (
            lambda d: method(d, 0)["parameters"].update(sigma_deg=-1.0),
            r"glare\.methods\[0\]\.parameters: sigma_deg must be",
        ),
        (
            lambda d: method(d, 0)["parameters"].update(sigma=0.3),
            r"glare\.methods\[0\]\.parameters: 'gaussian' has no parameter 'sigma'; its parameters",
        ),
        (
            lambda d: method(d, 1).update(model="kakimoto"),
            r"glare\.methods\[1\]\.model = 'kakimoto': must be one of",
        ),
        (lambda d: d["glare"].pop("methods"), r"\[\[glare\.methods\]\]: missing"),
        (
            lambda d: d["display"].update(bit_depth=9),
            r"display\.bit_depth = 9: must be int, one of 8, 10, 12, 16",
        ),
        (
            lambda d: d["display"].update(max_cd_m2="bright"),
            r"display\.max_cd_m2 = 'bright': must be a number",
        ),
        (
            lambda d: method(d, 1).update(labels=["a", "b"]),
            r"glare\.methods\[1\]: 2 labels for 6 levels_cd_m2",
        ),
        (
            lambda d: method(d, 1).update(labels=["a", "b", "c", "d", "e", "e"]),
            r"glare\.methods\[1\]\.labels repeats 'e': must be all different",
        ),
        (
            lambda d: method(d, 1).update(labels=["a", "b", "c", "d", "e", "../../escaped"]),
            r"glare\.methods\[1\]\.labels\[5\] = '\.\./\.\./escaped': must be 1-64 letters",
        ),
        (
            lambda d: method(d, 1).update(name="gaussian"),
            r"glare\.methods: method names repeat \['gaussian'\]",
        ),
        (
            lambda d: d["display"].update(pixel_pitch_mm=0.2),
            "give exactly one of diagonal_in and pixel_pitch_mm",
        ),
        (
            lambda d: d["study"].update(paradigm="kakimoto2004"),
            r"study\.paradigm = 'kakimoto2004': must be one of",
        ),
        (
            lambda d: d["study"].update(name="my study"),
            r"study\.name = 'my study': must be 1-64 letters",
        ),
        (
            lambda d: d["background"].update(kind="cloud"),
            r"background\.kind = 'cloud': must be one of 'sky', 'uniform', 'lamp', 'exr'",
        ),
        (
            lambda d: d.update(background={"kind": "exr", "path": "none.exr", "pixel_deg": 0.01}),
            r"background\.path = 'none\.exr': no such file",
        ),
        (
            lambda d: d["analysis"].update(compare_methods_at=[4, 7]),
            r"analysis\.compare_methods_at: 7 is beyond the 6 levels",
        ),
        (
            lambda d: d["questionnaire"]["questions"][1].update(column="match_cd_m2"),
            r"questions\[1\]\.column = 'match_cd_m2': already a column of the session CSV",
        ),
        (
            lambda d: method(d, 1).update(
                labels=["a", "b", "c"], levels_cd_m2=[220.0, 1000.0, 2000.0]
            ),
            "every method needs the same number of levels",
        ),
        (
            # answers and times would share one header name (q1_glow_time_s twice)
            lambda d: d["questionnaire"]["questions"][1].update(column="q1_glow_time_s"),
            r"questions\[1\]\.column = 'q1_glow_time_s': already a column of the session CSV",
        ),
        (
            lambda d: d["questionnaire"]["questions"][0].update(column="q2_ring_time_s"),
            r"questions\[1\]\.column = 'q2_ring': already a column of the session CSV",
        ),
        (
            lambda d: d["questionnaire"]["questions"][1].update(column="Q1_Glow"),
            r"questions\[1\]\.column = 'Q1_Glow': already a column of the session CSV",
        ),
    ],
)
def test_bad_protocols_are_refused_with_the_key_named(edit, match):
    data = copy.deepcopy(raw("yoshida2008"))
    edit(data)
    with pytest.raises(ProtocolError, match=match):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


def test_every_problem_is_reported_at_once():
    data = copy.deepcopy(raw("spencer1995"))
    data["stimulus"]["window_pxx"] = 300
    data["glare"]["peak_fraction"] = 2.0
    data["trials"]["neither"] = "maybe"
    with pytest.raises(ProtocolError) as caught:
        parse_protocol(data)
    assert len(caught.value.problems) == 3


def test_a_file_that_is_not_toml_is_named(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text("[study\nname = 1")
    with pytest.raises(ProtocolError, match=r"broken\.toml: 1 problem(?s:.*)not valid TOML"):
        load_protocol(path)
    with pytest.raises(FileNotFoundError, match="no protocol file"):
        load_protocol(tmp_path / "missing.toml")
    with pytest.raises(FileNotFoundError, match="no protocol 'yoshida2009': give a TOML file"):
        load_protocol("yoshida2009")


def test_the_hash_follows_the_content():
    a = parse_protocol(raw("luidolt2020"))
    changed = raw("luidolt2020")
    changed["questionnaire"]["comments"] = False
    assert parse_protocol(changed).sha256 != a.sha256
    assert parse_protocol(raw("luidolt2020")).sha256 == a.sha256


@pytest.mark.parametrize("paradigm", list(PARADIGMS))
def test_schema_documents_every_key(paradigm):
    rows = describe_schema(paradigm)
    assert all(r[4] for r in rows)  # every key has a description
    keys = {r[0] for r in rows}
    assert "study.paradigm" in keys


def test_the_csv_columns_follow_the_protocol():
    yoshida = load_protocol("yoshida2008")
    names = [c.name for c in columns(yoshida)]
    assert names[-6:-3] == ["q1_glow", "q2_ring", "q3_same_size"]
    assert names[-3:] == ["q1_glow_time_s", "q2_ring_time_s", "q3_same_size_time_s"]
    data = raw("yoshida2008")
    data["questionnaire"]["questions"] = [
        *data["questionnaire"]["questions"][:2],
        {"column": "q4_flicker", "text": "Did it flicker?"},
        {"column": "q5_colour", "text": "Was it coloured?"},
    ]
    data["trials"]["settings"] = "single"
    data["stimulus"]["target_start_cd_m2"] = [150.0]
    five = parse_protocol(data)
    names = [c.name for c in columns(five)]
    assert names[-8:-4] == ["q1_glow", "q2_ring", "q4_flicker", "q5_colour"]
    assert "darker_cd_m2" not in names and "match_cd_m2" in names
    method = {c.name: c for c in columns(five)}["method"]
    assert method.choices == ("gaussian", "vos")
    spencer = {c.name: c for c in columns(load_protocol("spencer1995"))}
    assert spencer["context"].choices == ("none", "lamp") and spencer["glare_level"].high == 12


def test_single_settings_take_one_start():
    data = raw("yoshida2008")
    data["trials"]["settings"] = "single"
    with pytest.raises(ProtocolError, match="'single' has 1 target"):
        parse_protocol(data)


def test_any_registered_glare_model_with_its_parameters():
    data = raw("yoshida2008")
    data["glare"]["methods"].append(
        {
            "name": "hybrid",
            "model": "hybrid",
            "parameters": {"regime": "mesopic", "wave": {"pupil_mm": 4.0, "particles": 0}},
            "labels": ["h1", "h2", "h3", "h4", "h5", "h6"],
            "levels_cd_m2": [220.0, 1000.0, 2000.0, 3000.0, 4000.0, 5000.0],
        }
    )
    protocol = parse_protocol(data)
    from glarelab.protocols.common import glare_model

    model = glare_model("hybrid", protocol["glare"]["methods"][2]["parameters"])
    assert model.wave.pupil_mm == 4.0 and model.regime == "mesopic"
    data["glare"]["methods"][2]["parameters"]["wave"]["pupil_mm"] = -1.0
    with pytest.raises(ProtocolError, match=r"glare\.methods\[2\]\.parameters: pupil_mm"):
        parse_protocol(data)


def test_a_wave_models_counts_are_bounded_in_a_protocol_as_in_the_model():
    data = raw("yoshida2008")
    data["glare"]["methods"].append(
        {
            "name": "wave",
            "model": "wave",
            "parameters": {"particles": 10**9},
            "labels": ["w1", "w2", "w3", "w4", "w5", "w6"],
            "levels_cd_m2": [220.0, 1000.0, 2000.0, 3000.0, 4000.0, 5000.0],
        }
    )
    with pytest.raises(ProtocolError, match=r"particles must be an integer from 0 to 100000"):
        parse_protocol(data)


@pytest.mark.parametrize("value", [3, "x"])
def test_a_halo_spectrum_that_is_no_table_is_refused_at_load(value):
    """vos halo_spectrum = 3 passed protocol check, and the build died with an
    AttributeError deep in the halo's spectrum."""
    data = raw("yoshida2008")
    method = next(m for m in data["glare"]["methods"] if m["model"] == "vos")
    method["parameters"] = {**method.get("parameters", {}), "regime": "mesopic"}
    method["parameters"]["halo_spectrum"] = value
    with pytest.raises(ProtocolError, match=r"halo_spectrum must be a HaloSpectrum"):
        parse_protocol(data)


@pytest.mark.parametrize(
    ("study", "edit", "match"),
    [
        ("yoshida2008", lambda d: d["glare"]["methods"][1].update(name="Gaussian"),
         r"glare\.methods: method names repeat \['Gaussian', 'gaussian'\]: each must be "
         r"different \(ignoring case"),
        ("spencer1995", lambda d: d["contexts"][1].update(name=d["contexts"][0]["name"].upper()),
         r"contexts: names repeat \['NONE', 'none'\]"),
        ("night2026", lambda d: d["conditions"][1].update(name=d["conditions"][0]["name"].title()),
         r"conditions: names repeat \[.*\]: each must be different \(ignoring case\)"),
    ],
    ids=["methods", "contexts", "conditions"],
)  # fmt: skip
def test_names_that_differ_only_by_case_are_refused(study, edit, match):
    data = copy.deepcopy(raw(study))
    edit(data)
    with pytest.raises(ProtocolError, match=match):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


@pytest.mark.parametrize(
    ("study", "edit", "match"),
    [
        ("spencer1995", lambda d: d["trials"].update(step_fractions=[0.02, 0.04, 0.08, 0.16]),
         r"trials\.step_fractions = \[0\.02, 0\.04, 0\.08, 0\.16\]: must run from coarse to fine"),
        ("spencer1995", lambda d: d["glare"].update(strengths=[0.01, 0.1, 0.1, 1.0]),
         r"glare\.strengths repeats 0\.1: must be all different"),
        ("yoshida2008", lambda d: d["background"].update(mean_cd_m2=0.0),
         r"background\.mean_cd_m2 = 0\.0: must be above 0 cd/m²"),
        # glare_level 1 is the weakest strength in the data and the report's level axis
        ("spencer1995", lambda d: d["glare"].update(strengths=[2.0, 1.0, 0.5]),
         r"glare\.strengths = \[2\.0, 1\.0, 0\.5\]: must be a list of float of length "
         r"1-50, ascending, in \[0, 1e\+09\] \(each above the one before\)"),
        ("spencer1995", lambda d: d["trials"].update(presentation_ms=[400.0, 400.0]),
         r"trials\.presentation_ms repeats 400\.0: must be all different$"),
        # at the protocol's 76 Hz both are 30 frames: one flash under two names
        ("spencer1995", lambda d: d["trials"].update(presentation_ms=[400.0, 401.0]),
         r"trials\.presentation_ms\[1\] = 401: 30 frames at 76 Hz, as 400 ms is: the two "
         r"durations would show the same flash"),
        # label A is the dimmest level: the follow-ups {A, B, C} and the level axis run up
        ("yoshida2008",
         lambda d: d["glare"]["methods"][0].update(
             levels_cd_m2=[1165.0, 220.0, 2110.0, 3055.0, 4000.0, 7000.0]),
         r"glare\.methods\[0\]\.levels_cd_m2 = \[1165\.0, 220\.0, .*\]: must be a list of "
         r"float of length 1-26, ascending, in \[0, 1e\+09\] cd/m² \(each above the one "
         r"before\)"),
        ("yoshida2008",
         lambda d: d["glare"]["methods"][1].update(
             levels_cd_m2=[220.0, 1480.0, 1480.0, 4000.0, 7000.0, 10000.0]),
         r"glare\.methods\[1\]\.levels_cd_m2 = .*: must be .*ascending"),
        # a field brighter than the display's maximum cannot be shown
        ("spencer1995",
         lambda d: d["contexts"][0].update(background={"kind": "uniform", "cd_m2": 500.0}),
         r"contexts\[0\]\.background\.cd_m2 = 500\.0: above what the display shows "
         r"\(display\.max_cd_m2 = 50\.0\); must be in \[0, 50\] cd/m²"),
        ("yoshida2008",
         lambda d: d.update(background={"kind": "uniform", "cd_m2": 1000.0}),
         r"background\.cd_m2 = 1000\.0: above what the display shows \(display\.max_cd_m2"),
        # a disk of 0.85 display pixels is drawn as the render pixels whose centres it holds:
        # 1.78 × its light; on a 16 × 16 display it vanished (every reference the background)
        ("yoshida2008", lambda d: d["stimulus"].update(disk_deg=0.01),
         r"stimulus\.disk_deg = 0\.01: 0\.85 display pixels across at 0\.01182°/px, so drawn "
         r"in pixels \(supersample = 2\) the disk holds 1\.780 × its light \(allowed: within 5%\)"),
        ("yoshida2008", lambda d: d["stimulus"].update(disk_deg=0.05, supersample=1),
         r"stimulus\.disk_deg = 0\.05: 4\.23 display pixels .* holds 0\.926 × its light"),
    ],
    ids=["steps fine to coarse", "duplicate strengths", "sky of mean 0",
         "strengths descending", "duplicate presentation_ms", "presentation_ms one flash",
         "levels out of order",
         "levels repeat", "uniform field above the display",
         "uniform background above the display", "disk below a pixel", "disk of 4 pixels"],
)  # fmt: skip
def test_values_that_cannot_mean_what_they_say_are_refused(study, edit, match):
    data = copy.deepcopy(raw(study))
    edit(data)
    with pytest.raises(ProtocolError, match=match):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


@pytest.mark.parametrize("data", [None, [], "yoshida2008", 3])
def test_a_protocol_that_is_not_a_table_is_named(data):
    with pytest.raises(ProtocolError, match=r"must be a table \(a mapping of keys\)"):
        parse_protocol(data, source="api")


@pytest.mark.parametrize("name", ["yoshida2008", "Yoshida2008", "luidolt2020"])
def test_a_shipped_studys_name_is_refused_for_another_paradigm(name):
    # its sessions would be named P01_<name>_s1_* like the shipped study's own
    data = copy.deepcopy(raw("spencer1995"))
    data["study"]["name"] = name
    with pytest.raises(ProtocolError, match=rf"study\.name = '{name}': the name of the shipped "
                       r"'(matching|rating)' study, but study\.paradigm = 'staircase'; must be a "
                       r"name of its own"):  # fmt: skip
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


def test_a_lab_copy_keeps_its_shipped_studys_name():
    data = copy.deepcopy(raw("yoshida2008"))
    data["display"]["max_cd_m2"] = 500.0  # the lab's own display
    assert parse_protocol(data, source="lab.toml", folder=PROTOCOLS).study == "yoshida2008"


@pytest.mark.parametrize("sequence", ["still", "gaze"])
def test_start_cd_m2_on_a_scene_that_does_not_enter_the_dark_is_refused(sequence):
    data = copy.deepcopy(raw("night2026"))  # enter_dark from start_cd_m2 = 100
    data["scene"]["sequence"] = sequence
    with pytest.raises(
        ProtocolError,
        match=rf"scene\.start_cd_m2 = 100\.0: only an 'enter_dark' sequence uses it .*"
        rf"scene\.sequence = '{sequence}'; remove it",
    ):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)
    del data["scene"]["start_cd_m2"]
    if sequence == "still":  # one frame: a frame rate would do nothing either
        del data["scene"]["frame_rate_hz"]
    assert (
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)["scene"]["start_cd_m2"] == 100
    )


def _no_glare(data):
    for condition in data["conditions"]:
        condition["effects"] = [e for e in condition["effects"] if e != "glare"] or ["acuity"]


def _no_conditions(data):
    for key in ("scene", "conditions", "display", "viewing"):
        del data[key]
    del data["observer"]["category_effects"]


@pytest.mark.parametrize(
    ("edit", "named"),
    [(_no_glare, r"scene\.glare_model = 'vos': no condition's effects include 'glare'"),
     (_no_conditions, r"observer\.missing_effect_shift: only a study with \[\[conditions\]\]"),
     (lambda d: d["observer"].pop("category_effects"),
      r"observer\.missing_effect_shift = 2\.0: no observer\.category_effects names"),
     (lambda d: d["observer"].pop("missing_effect_shift"),
      r"observer\.category_effects: without observer\.missing_effect_shift")],
    ids=["glare model, no glare", "shift, no conditions", "shift, no effects", "effects, no shift"],
)  # fmt: skip
def test_a_rating_key_that_shapes_nothing_is_refused(edit, named):
    """Each passed protocol check and changed nothing: a glare model no condition renders, a
    shift of ratings with no condition to lack an effect, or no effect or shift to apply."""
    data = copy.deepcopy(raw("night2026"))
    edit(data)
    with pytest.raises(ProtocolError, match=named):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


def test_two_conditions_of_the_same_effects_are_refused():
    data = copy.deepcopy(raw("night2026"))
    data["conditions"][1]["effects"] = list(data["conditions"][0]["effects"])
    first, second = data["conditions"][0]["name"], data["conditions"][1]["name"]
    with pytest.raises(ProtocolError, match=rf"conditions '{first}' and '{second}': the same "
                       r"effects \['acuity', 'adaptation', 'glare', 'scotopic'\]"):  # fmt: skip
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


def test_a_target_starting_below_the_displays_black_is_refused():
    data = copy.deepcopy(raw("yoshida2008"))
    data["display"]["black_cd_m2"] = 0.5
    data["stimulus"]["target_start_cd_m2"] = [0.2, 400.0]
    with pytest.raises(ProtocolError, match=r"stimulus\.target_start_cd_m2\[0\] = 0\.2: below "
                       r"what the display shows \(display\.black_cd_m2 = 0\.5\)"):  # fmt: skip
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


def test_a_list_of_tables_headed_as_a_single_table_is_named(tmp_path):
    # [contexts] typed for [[contexts]] got only the parser's "Cannot overwrite a value"
    text = (PROTOCOLS / "spencer1995.toml").read_text()
    first = text.index("[[contexts]]")
    path = tmp_path / "p.toml"
    path.write_text(text[:first] + text[first:].replace("[[contexts]]", "[contexts]", 1))
    line = text[:first].count("\n") + 1
    with pytest.raises(ProtocolError) as caught:
        load_protocol(path)
    (problem,) = caught.value.problems
    second = text[: text.index("[[contexts]]", first + 1)].count("\n") + 1
    assert problem.startswith(f"contexts (line {second}): headed [[contexts]] here"), problem
    assert f"and [contexts] on line {line}" in problem
    assert "a list of tables heads every entry [[contexts]]" in problem


def test_a_shipped_name_that_is_also_a_file_here_is_refused_and_a_folder_does_not_shadow_it(
    tmp_path, monkeypatch
):
    from glarelab.protocols import protocol_path
    from glarelab.protocols.core import SHIPPED

    monkeypatch.chdir(tmp_path)
    (tmp_path / "yoshida2008").write_text("the lab's notes\n")
    with pytest.raises(ValueError, match=r"give \./yoshida2008 for the file"):
        protocol_path("yoshida2008")
    assert protocol_path("./yoshida2008") == Path("yoshida2008")
    assert protocol_path(Path("yoshida2008")) == Path("yoshida2008")  # a Path is a path
    (tmp_path / "spencer1995").mkdir()  # e.g. a stimulus set built with --out spencer1995
    assert protocol_path("spencer1995") == SHIPPED / "spencer1995.toml"


@pytest.mark.parametrize(
    ("disk_deg", "pixel_deg", "supersample"),
    [(0.3, 0.01182, 2), (0.01, 0.01182, 2), (0.3, 0.2, 1), (0.05, 0.0118, 1), (0.1, 0.0118, 4),
     (1.0, 0.05, 3)],
)  # fmt: skip
def test_the_disks_light_is_counted_as_the_build_draws_it(disk_deg, pixel_deg, supersample):
    import math

    import numpy as np

    from glarelab.protocols.matching import disk_light_ratio

    sides = round(3.2 / pixel_deg)
    n = (sides + 1 - sides % 2) * supersample
    fine = pixel_deg / supersample
    axis = (np.arange(n) - (n - 1) / 2) * fine  # as build_matching places the render's pixels
    drawn = (np.hypot(axis[None, :], axis[:, None]) <= disk_deg / 2).sum() * fine**2
    expected = drawn / (math.pi * (disk_deg / 2) ** 2)
    assert disk_light_ratio(disk_deg, 3.2, pixel_deg, supersample) == pytest.approx(
        expected, rel=1e-12
    )


def test_a_waves_obstacle_image_is_refused_naming_the_key_and_why():
    """'could not convert string to float: 'pic.png'' named neither the key nor the way."""
    data = copy.deepcopy(raw("yoshida2008"))
    data["glare"]["methods"][0]["model"] = "wave"
    data["glare"]["methods"][0]["parameters"] = {
        "obstacle_image": "pic.png",
        "obstacle_spacing_mm": 0.1,
    }
    with pytest.raises(ProtocolError) as refused:
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)
    assert (
        "glare.methods[0].parameters.obstacle_image = 'pic.png': an image array, which a "
        "protocol cannot give" in str(refused.value)
    ), refused.value
    assert "could not convert" not in str(refused.value)


def test_an_unknown_model_parameter_is_named_with_the_models_parameters():
    data = copy.deepcopy(raw("yoshida2008"))
    data["glare"]["methods"][0]["parameters"]["sigma"] = 1.0
    with pytest.raises(
        ProtocolError,
        match=r"glare\.methods\[0\]\.parameters: 'gaussian' has no parameter 'sigma'; its "
        r"parameters are sigma_deg, sampling, normalisation",
    ):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


def test_a_scale_of_one_rating_is_named_once_with_its_values():
    data = copy.deepcopy(raw("luidolt2020"))
    data["questionnaire"]["scale_max"] = data["questionnaire"]["scale_min"]
    with pytest.raises(ProtocolError) as raised:
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)
    text = str(raised.value)
    assert "questionnaire.scale_min = 1: must be below questionnaire.scale_max = 1" in text
    assert "1 problem(s)" in text  # not one more per category's rating probabilities


def test_a_table_whose_keys_all_have_defaults_may_be_left_out():
    # docs/protocols.md gives [[questionnaire.questions]] the default []; leaving the whole
    # [questionnaire] out was refused as a missing table
    data = copy.deepcopy(raw("yoshida2008"))
    del data["questionnaire"]
    protocol = parse_protocol(data, source="test.toml", folder=PROTOCOLS)
    assert protocol["questionnaire"]["questions"] == []
    data = copy.deepcopy(raw("yoshida2008"))
    del data["stimulus"]  # its disk and size are required
    with pytest.raises(ProtocolError, match=r"\[stimulus\]: missing table"):
        parse_protocol(data, source="test.toml", folder=PROTOCOLS)


@pytest.mark.parametrize(
    ("change", "named"),
    [
        (lambda d: d["display"].update(max_cd_m2=10**400), "display.max_cd_m2"),
        (
            lambda d: d["glare"]["methods"][0]["levels_cd_m2"].__setitem__(0, 10**400),
            "levels_cd_m2[0]",
        ),
        (
            lambda d: d.setdefault("observer", {}).update(when=datetime.datetime(1979, 5, 27)),
            "observer.when",
        ),
    ],
)
def test_a_huge_integer_or_a_toml_date_is_a_problem_named_not_a_traceback(change, named):
    """An integer of 401 digits ended `protocol check` in an OverflowError, a TOML date-time
    in a free-form table in a TypeError from the protocol's hash."""
    import copy
    import tomllib

    from glarelab.protocols import parse_protocol
    from glarelab.protocols.core import ProtocolError

    shipped = Path(__file__).resolve().parents[2] / "src/glarelab/protocols/yoshida2008.toml"
    data = copy.deepcopy(tomllib.loads(shipped.read_text(encoding="utf-8")))
    change(data)
    with pytest.raises(ProtocolError, match=re.escape(named)):
        parse_protocol(data)


@pytest.mark.parametrize(
    ("change", "named"),
    [
        (lambda q: q["prompts"].__setitem__(0, ""), "questionnaire.prompts[0] is empty"),
        (lambda q: q["prompts"].__setitem__(1, "   "), "questionnaire.prompts[1] is empty"),
        (lambda q: q["anchors"].__setitem__(0, ""), "questionnaire.anchors[0] is empty"),
        (lambda q: q.__setitem__("anchors", ["same", "same"]), "the scale's two ends"),
    ],
)
def test_a_questionnaire_a_participant_could_not_read_is_refused(change, named):
    """An empty prompt or anchor, and two anchors alike, were accepted and shown."""
    from glarelab.protocols.core import ProtocolError

    data = raw("luidolt2020")
    change(data["questionnaire"])
    with pytest.raises(ProtocolError, match=re.escape(named)):
        parse_protocol(data)


@pytest.mark.parametrize("key", ["source_radius_px", "disc_radius_px", "annulus_outer_px"])
def test_a_staircase_stimulus_larger_than_its_window_is_refused(key):
    """A source or annulus of 100 px in a 64 px window was accepted, and cut off."""
    from glarelab.protocols.core import ProtocolError

    data = raw("spencer1995")
    data["stimulus"]["window_px"] = 64
    data["stimulus"]["annulus_outer_px"] = 30.0
    data["stimulus"][key] = 40.0 if key == "annulus_outer_px" else 33.0
    with pytest.raises(ProtocolError, match=re.escape(f"stimulus.{key} = ")):
        parse_protocol(data)


@pytest.mark.parametrize(
    ("scene", "named"),
    [
        ({"seconds": 0.05}, "scene.seconds = 0.05"),  # half a frame at 10 Hz, shown for 0.1 s
        ({"seconds": 3.05}, "scene.seconds = 3.05"),
        ({"sequence": "still", "frame_rate_hz": 10.0}, "scene.frame_rate_hz = 10"),
    ],
)
def test_a_scene_shown_for_another_time_than_it_says_is_refused(scene, named):
    from glarelab.protocols.core import ProtocolError

    data = raw("night2026")
    data["scene"].update(scene)
    if scene.get("sequence") == "still":
        data["scene"].pop("start_cd_m2", None)
    with pytest.raises(ProtocolError, match=re.escape(named)):
        parse_protocol(data)


@pytest.mark.parametrize(
    ("study", "change", "named"),
    [
        ("spencer1995", lambda d: d["trials"].update(reversals=2), "would never be used"),
        ("spencer1995",
         lambda d: d["trials"].update(repeat_failed_presentations=False, repeat_limit=5),
         "trials.repeat_limit = 5"),
        ("yoshida2008",
         lambda d: d["analysis"].update(quote_welch_tests=True, compare_methods_at=[]),
         "quote_welch_tests = true without"),
    ],
)  # fmt: skip
def test_a_protocol_value_that_would_be_ignored_is_refused(study, change, named):
    """Each was accepted: the last steps never taken, a repeat limit of flashes never
    repeated, Welch tests quoted of no comparison."""
    from glarelab.protocols.core import ProtocolError

    data = raw(study)
    change(data)
    with pytest.raises(ProtocolError, match=re.escape(named)):
        parse_protocol(data)


@pytest.mark.parametrize(
    ("study", "other"), [("yoshida2008", "staircase"), ("spencer1995", "rating")]
)
def test_a_file_of_another_paradigm_is_named_as_such_first(study, other, tmp_path):
    """A matching file given paradigm = 'staircase' listed 30 problems of unknown and missing
    keys, none saying that the tables are a matching protocol's."""
    import tomllib

    from glarelab.protocols import ProtocolError, parse_protocol

    path = Path(__file__).parents[2] / "src" / "glarelab" / "protocols" / f"{study}.toml"
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    own = data["study"]["paradigm"]
    data["study"]["paradigm"] = other
    with pytest.raises(ProtocolError) as refused:
        parse_protocol(data)
    first = refused.value.problems[0]
    assert first.startswith(
        f"paradigm = {other!r}, but the file's tables are those of the {own!r}"
    )


@pytest.mark.parametrize(
    ("parameters", "named"),
    [
        ({"halo_spacing_deg": 0.005, "halo_lines": 200, "flare_lines": True}, None),
        ({"regime": "mesopic"}, "regime = 'mesopic'"),
        ({"wave": {"pupil_mm": 4.0}}, "wave.pupil_mm = 4.0"),
    ],
)
def test_a_scenes_glare_model_takes_its_halo_options_and_refuses_an_eye_state(parameters, named):
    """A night scene's Vos options of the halo were refused (the model was checked in the
    default photopic regime, which each frame replaces); a nested pupil passed the check and
    the build then refused it with advice no protocol key can follow."""
    from glarelab.protocols import ProtocolError, parse_protocol
    from glarelab.protocols.rating import scene_glare_model

    data = tomllib.loads((PROTOCOLS / "night2026.toml").read_text(encoding="utf-8"))
    if "wave" in parameters:
        data["scene"]["glare_model"] = "hybrid"
    data["scene"]["glare_parameters"] = parameters
    if named is None:
        protocol = parse_protocol(data)
        model = scene_glare_model(protocol["scene"])
        assert model.halo_spacing_deg == 0.005 and model.regime == "mesopic"
        return
    with pytest.raises(ProtocolError) as refused:
        parse_protocol(data)
    assert any(f"scene.glare_parameters: {named}" in p for p in refused.value.problems)


def test_a_monitor_applies_to_a_live_scene_whose_file_leaves_keys_out():
    """--monitor on luidolt2020-live was refused over scene.start_cd_m2 and
    scene.frame_rate_hz, keys the file does not give (its defaults were written back in)."""
    from glarelab.protocols.core import with_monitor

    protocol = load_protocol("luidolt2020-live")
    assert protocol["scene"]["live"]
    mounted = with_monitor(
        protocol, name="lab", resolution_px=(1920, 1080), width_cm=60.0, distance_cm=120.0
    )
    assert mounted["viewing"]["distance_m"] == 1.2
    assert mounted["scene"] == protocol["scene"]


@pytest.mark.parametrize("cells", [123, None, "p01,1,true"])
def test_row_digest_names_cells_that_are_not_a_row(cells):
    """'int' object is not iterable (and a string was digested as its characters)."""
    from glarelab.protocols import row_digest

    with pytest.raises(TypeError, match=r"^row_digest: cells must be the row's cells"):
        row_digest(cells)


@pytest.mark.parametrize(
    ("option", "value", "named"),
    [("resolution_px", (1920.5, 1080), "resolution_px"), ("resolution_px", ("1920", "1080"),
     "resolution_px"), ("resolution_px", (True, True), "resolution_px"),
     ("resolution_px", (1920,), "resolution_px"), ("width_cm", "53", "width_cm"),
     ("distance_cm", float("nan"), "distance_cm"), ("width_cm", 0.0, "width_cm")],
)  # fmt: skip
def test_a_monitor_of_values_no_display_has_is_refused_naming_them(option, value, named):
    # 1920.5 px was cut to 1920 and '53' cm read as 53, without a word; (True, True) was
    # refused as a disk of 20.48°/px
    from glarelab.protocols.core import with_monitor

    with pytest.raises(ValueError, match=rf"^--monitor m: {named} must be"):
        with_monitor(load_protocol("yoshida2008"), name="m", **{option: value})


@pytest.mark.parametrize(
    "change",
    [
        lambda p: p.data["viewing"].__setitem__("distance_m", 0.5),
        lambda p: p["viewing"].update(distance_m=-5.0),
        lambda p: p.data.pop("display"),
        lambda p: p.data["study"].setdefault("new", 1),
        lambda p: p.data["display"]["resolution_px"].__setitem__(0, 640),
        lambda p: p.data["display"]["resolution_px"].append(1),
        lambda p: p.data["display"]["resolution_px"].sort(),
        lambda p: p.data.__delitem__("study"),
        lambda p: p.data["study"].clear(),
    ],
)
def test_a_validated_protocol_cannot_be_changed(change):
    """``protocol.data["viewing"]["distance_m"] = 0.5`` changed the geometry and the sets
    built from it while ``sha256`` still named the file: a set so built failed its own
    verify, and -5 m gave a negative pixel size."""

    protocol = load_protocol("yoshida2008")
    before = json.dumps(protocol.data, sort_keys=True)
    with pytest.raises(TypeError, match=r"^a Protocol's tables cannot be changed"):
        change(protocol)
    assert json.dumps(protocol.data, sort_keys=True) == before
    assert protocol == load_protocol("yoshida2008")
    mine = copy.deepcopy(protocol.data)  # a copy is the user's to change
    mine["viewing"]["distance_m"] = 0.5
    mine["display"]["resolution_px"].append(1)
    assert type(mine) is dict and type(mine["display"]["resolution_px"]) is list
    assert pickle.loads(pickle.dumps(protocol)) == protocol  # to Dask's workers and back


@pytest.mark.parametrize("cells", [["a", 3], ["a", None], ["a", 1.5], [True]])
def test_a_row_digest_is_of_text_cells_only(cells):
    """``row_digest(["a", 3])`` gave the digest of JSON ``["a",3]``, which no CSV row (read
    as text, ``"3"``) can have."""
    from glarelab.protocols.columns import row_digest

    with pytest.raises(TypeError, match=r"^row_digest: cells must be the row's cells as written"):
        row_digest(cells)
