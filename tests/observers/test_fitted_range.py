"""Simulated observers say where they stop: a study whose stimuli lie outside those the
observers were fitted on (kernel widths and PSF normalisations, a Vos halo's pupil, wavelength
and spectrum, flare lines, levels, disk sizes, luminances, backgrounds, a sky's contrast,
cloud sizes and spectrum, pixel sizes, bit depths, room light) warns once per observer,
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
    FITTED_BACKGROUND_RATIO,
    FITTED_BIT_DEPTH,
    FITTED_DISK_CD_M2,
    FITTED_DISK_DIAMETER_DEG,
    FITTED_GAUSSIAN_SIGMA_DEG,
    FITTED_LEVEL_RATIO,
    FITTED_PIXEL_DEG,
    FITTED_ROOM_LUX,
    FITTED_SKY_CLOUD_DEG,
    FITTED_SKY_SPECTRUM_SLOPE,
    FITTED_VOS_FLARE_LINES,
    OutsideFittedRangeWarning,
    fitted_range_departures,
    warn_outside_fitted_range,
)
from glarelab.observers.looking import ObservedSet
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import StimulusSet, cached_stimulus_set

ROOT = Path(__file__).parents[2]
YOSHIDA_PIXEL_DEG = 0.011824416329142544  # 20.8-inch 2048 × 1536 at 1 m (§3-4)
YOSHIDA_GEOMETRY = {"disk_diameter_deg": 0.3, "pixel_deg": YOSHIDA_PIXEL_DEG}
SPENCER_GEOMETRY = {  # 4 px of 0.0266° (§4)
    "source_diameter_deg": 0.10653827731485196,
    "pixel_deg": 0.02663456932871299,
}


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


def warned(protocol, geometry: dict) -> list[str]:
    """The departures, checked to come as one warning from the caller's line (stacklevel=2)."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        found = warn_outside_fitted_range("a study", judged(protocol, geometry))
    (warning,) = _outside_warnings(record)
    assert all(line in str(warning.message) for line in found)
    assert warning.filename == __file__
    return found


def test_the_papers_studies_are_inside_the_fitted_range():
    assert departures(load_protocol("yoshida2008"), YOSHIDA_GEOMETRY) == []
    # a rating study's observers look at no glare: they are no LookingObserver
    assert not issubclass(PARADIGMS["rating"].observer, LookingObserver)
    # fitted on the protocol as shipped: mesopic by §3.1's rule, each filter renormalised
    # (§3.2), 50 cd/m² as §1
    assert departures(load_protocol("spencer1995"), SPENCER_GEOMETRY) == []


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
        # its sky's clouds stop at its 2.4° image, Yoshida's at 3.2°
        "background: sky cloud_max_deg = 2.4° (fitted on 3.2° only)",
    ]


def test_vos_regime_age_disk_size_and_luminance_are_checked():
    data = matching(model=("vos", {"regime": "scotopic", "age": 70.0}), clamp=300.0)
    data["background"] = {**data["background"], "mean_cd_m2": 300.0 * 150.0 / 220.0}
    found = departures(data, {"disk_diameter_deg": 1.0, "pixel_deg": YOSHIDA_PIXEL_DEG})
    assert found == [
        "method 'gaussian': Vos regime 'scotopic' with normalisation 'psf' (fitted on "
        "photopic with 'psf', mesopic with 'Spencer1995' only)",
        "method 'gaussian': Vos age = 70 years (fitted at the default age)",
        "method 'gaussian': levels of 0.7333 × the clamp luminance (fitted on 1-285 × for vos)",
        "disk diameter 1° (fitted on 0.1065-0.3°)",
        "disk luminance 300 cd/m² (the clamp; fitted on 37.5-220 cd/m²)",
    ]


def test_a_staircase_study_is_checked_on_its_glare_and_source():
    data = load_protocol("spencer1995").data
    strengths = [*data["glare"]["strengths"], 1000.0]
    data = {**data, "glare": {**data["glare"], "strengths": strengths, "peak_fraction": 0.5}}
    found = departures(data, {**SPENCER_GEOMETRY, "source_diameter_deg": 0.05})
    assert found == [
        "glare: levels of 1001 × the clamp luminance (fitted on 1-285 × for vos)",
        "disk diameter 0.05° (fitted on 0.1065-0.3°)",
        "disk luminance 25 cd/m² (the clamp; fitted on 37.5-220 cd/m²)",
        # the black field at the display's black and the lamp scene, now over a dimmer peak
        "context 'none': uniform background at 0.004 × the disk's luminance "
        "(fitted on 0-0.002667 × for uniform)",
        "context 'lamp': lamp background at 3 × the disk's luminance (fitted on 2 × only for lamp)",
    ]


def with_background(**background) -> dict:
    """Yoshida's protocol data on another background."""
    data = load_protocol("yoshida2008").data
    return {**data, "background": background}


def test_a_1_cd_m2_sky_is_named():
    data = with_background(**{**load_protocol("yoshida2008")["background"], "mean_cd_m2": 1.0})
    assert departures(data, YOSHIDA_GEOMETRY) == [
        "background: sky background at 0.004545 × the disk's luminance "
        "(fitted on 0.6818 × only for sky)"
    ]


@pytest.mark.parametrize("cd_m2", [0.0, 1.0, 150.0])
def test_a_uniform_background_behind_yoshidas_disk_is_named_unless_black(cd_m2):
    found = departures(with_background(kind="uniform", cd_m2=cd_m2), YOSHIDA_GEOMETRY)
    if cd_m2 == 0.0:  # the display's black, 0.5 cd/m², as dark as Spencer's black field
        assert found == []
    else:
        assert found == [
            f"background: uniform background at {cd_m2 / 220.0:.4g} × the disk's luminance "
            "(fitted on 0-0.002667 × for uniform)"
        ]


def test_a_sky_of_another_contrast_and_an_exr_are_named():
    sky = {**load_protocol("yoshida2008")["background"], "contrast": 0.3}
    assert departures(with_background(**sky), YOSHIDA_GEOMETRY) == [
        "background: sky contrast 0.3 (fitted on 0.15 only)"
    ]
    exr = with_background(kind="exr", path="lab.exr", pixel_deg=0.01)
    assert departures(exr, YOSHIDA_GEOMETRY) == [
        "background: exr background (fitted on sky, uniform, lamp only)"
    ]


def test_three_times_finer_pixels_are_named():
    finer = {**YOSHIDA_GEOMETRY, "pixel_deg": YOSHIDA_PIXEL_DEG / 3}
    assert departures(load_protocol("yoshida2008"), finer) == [
        "pixel size 0.003941° (fitted on 0.01182-0.02663°)"
    ]


def test_yoshidas_vos_with_spencers_normalisation_is_named():
    data = load_protocol("yoshida2008").data
    vos = data["glare"]["methods"][1]
    parameters = {**vos["parameters"], "normalisation": "Spencer1995"}
    methods = [data["glare"]["methods"][0], {**vos, "parameters": parameters}]
    data = {**data, "glare": {**data["glare"], "methods": methods}}
    assert departures(data, YOSHIDA_GEOMETRY) == [
        "method 'vos': Vos regime 'photopic' with normalisation 'Spencer1995' (fitted on "
        "photopic with 'psf', mesopic with 'Spencer1995' only)"
    ]
    # and Spencer's mesopic PSF normalised as a PSF was never fitted either
    spencer = load_protocol("spencer1995").data
    glare = {**spencer["glare"], "parameters": {**spencer["glare"]["parameters"]}}
    glare["parameters"]["normalisation"] = "psf"
    assert departures({**spencer, "glare": glare}, SPENCER_GEOMETRY) == [
        "glare: Vos regime 'mesopic' with normalisation 'psf' (fitted on "
        "photopic with 'psf', mesopic with 'Spencer1995' only)"
    ]


@pytest.mark.parametrize(
    "key, value, line",
    [
        ("cloud_min_deg", 0.2, "background: sky cloud_min_deg = 0.2° (fitted on 0.05° only)"),
        ("cloud_max_deg", 1.0, "background: sky cloud_max_deg = 1° (fitted on 3.2° only)"),
        ("spectrum_slope", 2.0, "background: sky spectrum_slope = 2 (fitted on 1 only)"),
    ],
)
def test_a_sky_of_other_cloud_sizes_or_spectrum_is_named(key, value, line):
    sky = {**load_protocol("yoshida2008")["background"], key: value}
    assert warned(with_background(**sky), YOSHIDA_GEOMETRY) == [line]


@pytest.mark.parametrize(
    "table, key, value, line",
    [
        ("display", "bit_depth", 12, "display bit depth 12 (fitted on 8-10)"),
        ("display", "bit_depth", 16, "display bit depth 16 (fitted on 8-10)"),
        ("viewing", "room_lux", 500.0, "room light 500 lx (fitted on 0-60 lx)"),
    ],
)
def test_another_bit_depth_or_room_light_is_named(table, key, value, line):
    for study, geometry in (("yoshida2008", YOSHIDA_GEOMETRY), ("spencer1995", SPENCER_GEOMETRY)):
        data = load_protocol(study).data
        data = {**data, table: {**data[table], key: value}}
        assert warned(data, geometry) == [line]


def with_spencer_glare(**parameters) -> dict:
    """Spencer's protocol data with these Vos parameters added to its own."""
    data = load_protocol("spencer1995").data
    glare = {**data["glare"], "parameters": {**data["glare"]["parameters"], **parameters}}
    return {**data, "glare": glare}


@pytest.mark.parametrize(
    "parameters, line",
    [
        (
            {"pupil_mm": 2.5},
            "glare: Vos pupil_mm = 2.5 mm drops the lenticular halo (Spencer §2.1; fitted "
            "with the regime's halo, no pupil given)",
        ),
        (
            {"wavelength_nm": 550.0},
            "glare: Vos wavelength_nm = 550 nm, a monochromatic halo (fitted on the white "
            "halo only)",
        ),
        (
            {"halo_spectrum": {"n_wavelengths": 31, "wavelength_range_nm": [380.0, 780.0]}},
            "glare: Vos halo spectrum of 31 over 380-780 nm under D65 (fitted on 61 over "
            "400-700 nm under D65 only)",
        ),
        (
            {"corona_lines": 50},
            "glare: Vos flare lines corona_lines = 50, halo_lines = 300 (fitted on 150, 300 only)",
        ),
    ],
)
def test_a_vos_halo_of_another_pupil_wavelength_spectrum_or_streaks_is_named(parameters, line):
    assert warned(with_spencer_glare(**parameters), SPENCER_GEOMETRY) == [line]


def test_vos_parameters_that_leave_the_kernel_as_fitted_are_not_named():
    # a pupil of 3 mm or more keeps the halo (Spencer §2.1) and the halo's colourspace does
    # not enter the luminance kernel (the photopic PSF, which has no halo (eq. 5) for a pupil
    # to drop or a wavelength to colour, refuses both)
    same = {
        "pupil_mm": 6.0,
        "halo_spectrum": {"colourspace": "Display P3", "wavelength_range_nm": [400, 700]},
    }
    assert departures(with_spencer_glare(**same), SPENCER_GEOMETRY) == []


def test_the_shipped_sets_are_at_the_fitted_sky_bits_room_and_streaks():
    yoshida = load_protocol("yoshida2008")
    sky = yoshida["background"]
    assert (sky["cloud_min_deg"], sky["cloud_max_deg"]) == tuple(
        bounds[0] for bounds in FITTED_SKY_CLOUD_DEG.values()
    )
    assert sky["spectrum_slope"] == FITTED_SKY_SPECTRUM_SLOPE[0]
    spencer = load_protocol("spencer1995")
    depths = {yoshida["display"]["bit_depth"], spencer["display"]["bit_depth"]}
    assert depths == set(FITTED_BIT_DEPTH)
    rooms = {yoshida["viewing"]["room_lux"], spencer["viewing"]["room_lux"]}
    assert rooms == set(FITTED_ROOM_LUX)
    from glarelab.glare.models.flare import CORONA_LINES, HALO_LINES

    assert FITTED_VOS_FLARE_LINES == (CORONA_LINES, HALO_LINES)


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
        geometry = {**YOSHIDA_GEOMETRY, "disk_diameter_deg": diameter}
        assert departures(matching(), geometry) == []
    for pixel_deg in FITTED_PIXEL_DEG:  # and of the pixel sizes
        assert departures(matching(), {**YOSHIDA_GEOMETRY, "pixel_deg": pixel_deg}) == []
    for clamp in FITTED_DISK_CD_M2:
        levels = [clamp * r for r in FITTED_LEVEL_RATIO["gaussian"]]
        data = matching(levels=levels, clamp=clamp)
        ratio = FITTED_BACKGROUND_RATIO["sky"][0]
        data["background"] = {**data["background"], "mean_cd_m2": clamp * ratio}
        assert departures(data, YOSHIDA_GEOMETRY) == []


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
        f"{FITTED_PIXEL_DEG[0]:.4g}-{FITTED_PIXEL_DEG[1]:.4g}°",
        f"sky {FITTED_BACKGROUND_RATIO['sky'][0]:.4g} only",
        f"uniform 0-{FITTED_BACKGROUND_RATIO['uniform'][1]:.4g}",
        f"lamp scene {FITTED_BACKGROUND_RATIO['lamp'][0]:g} only",
        "FITTED_VOS_PSFS",
        "FITTED_VOS_FLARE_LINES",
        f"`cloud_min_deg` {FITTED_SKY_CLOUD_DEG['cloud_min_deg'][0]:g}° only",
        f"`cloud_max_deg` {FITTED_SKY_CLOUD_DEG['cloud_max_deg'][0]:g}° only",
        f"`spectrum_slope` {FITTED_SKY_SPECTRUM_SLOPE[0]:g} only",
        f"{FITTED_BIT_DEPTH[0]}-{FITTED_BIT_DEPTH[1]} bits",
        f"{FITTED_ROOM_LUX[0]:g}-{FITTED_ROOM_LUX[1]:g} lx",
        f"{FITTED_VOS_FLARE_LINES[0]} in the corona, {FITTED_VOS_FLARE_LINES[1]} in the halo",
        '"Spencer1995"',
        "photopic",
        "OutsideFittedRangeWarning",
    ):
        assert value in section, value
    assert re.search(r"\bwave\b", section)
