"""Simulated observers say where they stop: a study whose stimuli lie outside those the
observers were fitted on (kernel widths, levels, disk sizes, luminances) warns once per observer,
naming each value and its fitted range; the papers' own studies do not warn; docs/observers.md
lists the ranges."""

import re
import warnings
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from glarelab.experiments.engine import LookingObserver
from glarelab.experiments.paradigms import PARADIGMS
from glarelab.experiments.session import make_observer
from glarelab.observers.fitted_range import (
    FITTED_DISK_CD_M2,
    FITTED_DISK_DIAMETER_DEG,
    FITTED_GAUSSIAN_SIGMA_DEG,
    FITTED_LEVEL_RATIO,
    OutsideFittedRangeWarning,
    fitted_range_departures,
    warn_outside_fitted_range,
)
from glarelab.observers.looking import ObservedSet
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import StimulusSet, cached_stimulus_set

ROOT = Path(__file__).parents[2]
YOSHIDA_GEOMETRY = {"disk_diameter_deg": 0.3}
SPENCER_GEOMETRY = {"source_diameter_deg": 0.10653827731485196}  # 4 px of 0.0266° (§4)


def matching(sigma_deg: float = 0.34, *, levels=None, clamp: float = 220.0, model=None) -> dict:
    """Yoshida's protocol data with one Gaussian method of ``sigma_deg`` (or ``model``)."""
    data = load_protocol("yoshida2008").data
    method = dict(data["glare"]["methods"][0])
    method["parameters"] = {"sigma_deg": sigma_deg}
    if model is not None:
        method["model"], method["parameters"] = model
    if levels is not None:
        method["levels_cd_m2"] = list(levels)
    return {**data, "glare": {**data["glare"], "l_dmax_cd_m2": clamp, "methods": [method]}}


def judged(protocol, geometry: dict):
    """What the protocol's paradigm's observers judge (a protocol or its data)."""
    paradigm = getattr(protocol, "paradigm", None) or protocol["study"]["paradigm"]
    return PARADIGMS[paradigm].observer.judged(protocol, geometry)


def departures(protocol, geometry: dict) -> list[str]:
    return fitted_range_departures(judged(protocol, geometry))


def _outside_warnings(record) -> list:
    return [w for w in record if issubclass(w.category, OutsideFittedRangeWarning)]


def test_the_papers_studies_are_inside_the_fitted_range_but_spencers_own_conditions():
    assert departures(load_protocol("yoshida2008"), YOSHIDA_GEOMETRY) == []
    # a rating study's observers look at no glare: they are no LookingObserver
    assert not issubclass(PARADIGMS["rating"].observer, LookingObserver)
    # the observers were fitted on Spencer's Figure 13 through a photopic PSF on a 100 cd/m²
    # display; the protocol now follows the paper (mesopic by §3.1's rule, 50 cd/m² as §1)
    assert departures(load_protocol("spencer1995"), SPENCER_GEOMETRY) == [
        "glare: Vos regime 'mesopic' (fitted on photopic only)",
        "disk luminance 37.5 cd/m² (the clamp; fitted on 75-220 cd/m²)",
    ]


def test_the_issue_study_of_two_gaussian_widths_is_named():
    # issue 23: sigma = 0.2 deg vs 0.5 deg, judged over a glow band fitted on 0.34 deg only
    data = matching(0.2)
    wide = {**data["glare"]["methods"][0], "name": "wide", "parameters": {"sigma_deg": 0.5}}
    data["glare"]["methods"] = [{**data["glare"]["methods"][0], "name": "narrow"}, wide]
    assert departures(data, YOSHIDA_GEOMETRY) == [
        "method 'narrow': Gaussian sigma_deg = 0.2° (fitted on 0.34° only)",
        "method 'wide': Gaussian sigma_deg = 0.5° (fitted on 0.34° only)",
    ]


def test_glare_methods2026_names_its_wave_models_and_high_levels():
    found = departures(load_protocol("glare_methods2026"), YOSHIDA_GEOMETRY)
    assert found == [
        "method 'gaussian': levels of 45.45 × the clamp luminance "
        "(fitted on 1-31.82 × for gaussian)",
        "method 'kakimoto': glare model 'wave' (fitted on gaussian, vos only)",
        "method 'luidolt': glare model 'wave' (fitted on gaussian, vos only)",
    ]


def test_vos_regime_age_disk_size_and_luminance_are_checked():
    data = matching(model=("vos", {"regime": "scotopic", "age": 70.0}), clamp=300.0)
    found = departures(data, {"disk_diameter_deg": 1.0})
    assert found == [
        "method 'gaussian': Vos regime 'scotopic' (fitted on photopic only)",
        "method 'gaussian': Vos age = 70 years (fitted at the default age)",
        "method 'gaussian': levels of 0.7333 × the clamp luminance (fitted on 1-285 × for vos)",
        "disk diameter 1° (fitted on 0.1065-0.3°)",
        "disk luminance 300 cd/m² (the clamp; fitted on 75-220 cd/m²)",
    ]


def test_a_staircase_study_is_checked_on_its_glare_and_source():
    data = load_protocol("spencer1995").data
    strengths = [*data["glare"]["strengths"], 1000.0]
    data = {**data, "glare": {**data["glare"], "strengths": strengths, "peak_fraction": 0.5}}
    found = departures(data, {"source_diameter_deg": 0.05})
    assert found == [
        "glare: Vos regime 'mesopic' (fitted on photopic only)",
        "glare: levels of 1001 × the clamp luminance (fitted on 1-285 × for vos)",
        "disk diameter 0.05° (fitted on 0.1065-0.3°)",
        "disk luminance 25 cd/m² (the clamp; fitted on 75-220 cd/m²)",
    ]


@given(st.floats(0.01, 3.0))
def test_a_gaussian_width_departs_exactly_when_outside_the_fitted_one(sigma_deg):
    low, high = FITTED_GAUSSIAN_SIGMA_DEG
    inside = low * (1 - 1e-3) <= sigma_deg <= high * (1 + 1e-3)
    assert (departures(matching(sigma_deg), YOSHIDA_GEOMETRY) == []) == inside


@pytest.mark.parametrize("factor, departs", [(1.0, False), (1.002, True), (0.998, True)])
def test_the_borders_of_the_level_range(factor, departs):
    low, high = FITTED_LEVEL_RATIO["gaussian"]
    levels = [220.0 * low, 220.0 * high * factor] if factor > 1 else [220.0 * low * factor]
    assert bool(departures(matching(levels=levels), YOSHIDA_GEOMETRY)) == departs
    for diameter in FITTED_DISK_DIAMETER_DEG:  # both ends of the sizes are inside
        assert departures(matching(), {"disk_diameter_deg": diameter}) == []
    for clamp in FITTED_DISK_CD_M2:
        levels = [clamp * r for r in FITTED_LEVEL_RATIO["gaussian"]]
        assert departures(matching(levels=levels, clamp=clamp), YOSHIDA_GEOMETRY) == []


def test_the_warning_names_the_ranges_and_points_at_its_caller():
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        found = warn_outside_fitted_range("yoshida2008", judged(matching(0.5), YOSHIDA_GEOMETRY))
        yoshida = judged(load_protocol("yoshida2008"), YOSHIDA_GEOMETRY)
        assert warn_outside_fitted_range("yoshida2008", yoshida) == []
    (warning,) = _outside_warnings(record)
    assert found == ["method 'gaussian': Gaussian sigma_deg = 0.5° (fitted on 0.34° only)"]
    assert "yoshida2008" in str(warning.message)
    assert found[0] in str(warning.message)
    assert issubclass(warning.category, UserWarning)
    assert warning.filename == __file__  # stacklevel=2: the caller's line


@pytest.fixture(scope="module")
def yoshida_set():
    folder = cached_stimulus_set(load_protocol("yoshida2008"), progress=None)
    return ObservedSet(StimulusSet(folder))


def test_an_observer_outside_the_range_warns_once(tmp_path, yoshida_set):
    text = (ROOT / "src" / "glarelab" / "protocols" / "yoshida2008.toml").read_text()
    text = text.replace("sigma_deg = 0.34", "sigma_deg = 0.5")
    assert "sigma_deg = 0.5" in text
    path = tmp_path / "wide.toml"
    path.write_text(text)
    protocol = load_protocol(path)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        observers = [
            make_observer(protocol, f"p{k}", seed=1, stimuli=yoshida_set) for k in range(3)
        ]
        make_observer(load_protocol("yoshida2008"), "p0", seed=1, stimuli=yoshida_set)
    found = _outside_warnings(record)
    assert len(found) == 3  # once per observer, and none for the paper's own study
    assert all("sigma_deg = 0.5° (fitted on 0.34° only)" in str(w.message) for w in found)
    assert all(o.departures == observers[0].departures for o in observers)


def test_docs_list_the_fitted_range():
    text = (ROOT / "docs" / "observers.md").read_text()
    section = text.split("## Where the observers were fitted", 1)[1].split("\n## ", 1)[0]
    for value in (
        f"{FITTED_GAUSSIAN_SIGMA_DEG[0]:g}°",
        f"{FITTED_LEVEL_RATIO['gaussian'][1]:.1f}",
        f"{FITTED_LEVEL_RATIO['vos'][1]:g}",
        f"{FITTED_DISK_DIAMETER_DEG[0]:g}-{FITTED_DISK_DIAMETER_DEG[1]:g}°",
        f"{FITTED_DISK_CD_M2[0]:g}-{FITTED_DISK_CD_M2[1]:g} cd/m²",
        "photopic",
        "OutsideFittedRangeWarning",
    ):
        assert value in section, value
    assert re.search(r"\bwave\b", section)
