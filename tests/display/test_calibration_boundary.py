"""fit_calibration at its boundary: a bit depth that is not one of the integers 8, 10, 12, 16,
fractional or bool codes, and luminances that are not numbers are refused naming what is wrong
(they were truncated and accepted); valid readings give a finite, increasing table."""

import math
import re
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.display.calibration import fit_calibration, read_readings

SETTINGS = settings(max_examples=30, deadline=None)
READINGS = [(0, 0.1), (85, 5.0), (170, 40.0), (255, 100.0)]


@SETTINGS
@given(bit_depth=st.one_of(
    st.floats(allow_nan=True),
    st.booleans(),
    st.integers().filter(lambda n: n not in (8, 10, 12, 16)),
    st.text(max_size=3),
    st.none(),
))  # fmt: skip
def test_a_bit_depth_that_is_not_a_known_integer_is_refused(bit_depth):
    with pytest.raises(ValueError, match=r"^bit_depth must be one of 8, 10, 12, 16; got"):
        fit_calibration(READINGS, bit_depth=bit_depth)


BAD_CODE = st.one_of(
    st.floats(0.0, 255.0).filter(lambda x: x != int(x)),
    st.sampled_from([85.0, True, "85", None, math.nan]),
)
BAD_LUMINANCE = st.one_of(
    st.text(max_size=4), st.booleans(), st.none(),
    st.complex_numbers(allow_nan=False, allow_infinity=False),
)  # fmt: skip


@SETTINGS
@given(data=st.data(), which=st.integers(0, 3))
def test_a_reading_that_is_not_a_code_and_a_number_is_refused(data, which):
    readings = list(READINGS)
    part = data.draw(st.sampled_from(["code", "luminance", "pair"]), label="part")
    code, value = readings[which]
    if part == "code":
        readings[which] = (data.draw(BAD_CODE, label="code"), value)
        match = r"^readings: a reading's code must be a whole number"
    elif part == "luminance":
        readings[which] = (code, data.draw(BAD_LUMINANCE, label="luminance"))
        match = r"^readings: a reading's luminance must be a number"
    else:
        readings[which] = data.draw(st.sampled_from([(code,), (code, value, 1), code, "ab"]))
        match = r"^readings: each reading must be a pair"
    with pytest.raises(ValueError, match=match) as raised:
        fit_calibration(readings, bit_depth=8, method=data.draw(st.sampled_from(["pchip", "gog"])))
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(
    ("readings", "bit_depth", "match"),
    [
        (READINGS, 8.0, r"bit_depth must be one of 8, 10, 12, 16; got 8.0"),
        ([(0, 0.1), (300, 5.0), (600, 40.0), (1023, 100.0)], 10.9, "got 10.9"),
        ([(0, 0.1), (85.5, 5.0), (170, 40.0), (255, 100.0)], 8, r"whole number .* got 85.5"),
    ],
)
def test_the_issue_cases_are_refused(readings, bit_depth, match):
    with pytest.raises(ValueError, match=match):
        fit_calibration(readings, bit_depth=bit_depth)


@SETTINGS
@given(
    steps=st.lists(st.floats(1e-3, 1e3), min_size=3, max_size=8),
    black=st.one_of(st.just(0.0), st.floats(1e-6, 1.0)),
    method=st.sampled_from(["pchip-log", "pchip"]),
    given_as=st.sampled_from(["python", "numpy scalars", "an (N, 2) array"]),
)
def test_valid_readings_give_a_finite_increasing_table(steps, black, method, given_as):
    codes = np.unique(np.linspace(0, 255, len(steps) + 1).round().astype(int))
    values = black + np.concatenate([[0.0], np.cumsum(steps[: codes.size - 1])])
    readings = list(zip(codes.tolist(), values.tolist(), strict=True))
    fitted = fit_calibration(readings, bit_depth=8, method=method)
    assert np.isfinite(fitted.lut).all() and (np.diff(fitted.lut) >= 0).all()
    if given_as == "numpy scalars":  # np.int64 and np.float64 are numbers
        readings = list(zip(codes, values, strict=True))
    elif given_as == "an (N, 2) array":  # one dtype: the codes are whole floats
        readings = np.column_stack([codes, values])
    assert fit_calibration(readings, bit_depth=8, method=method).readings == fitted.readings


@pytest.mark.parametrize(
    ("array", "named"),
    [
        ([[0.5, 0.4], [100, 20], [200, 120], [255, 200]], "code must be a whole number"),
        ([[0, 0.4j], [100, 20], [200, 120], [255, 200]], "real numbers of shape (N, 2)"),
        (np.ones((4, 3)), "real numbers of shape (N, 2), one (code, cd/m²) per row; got float64"),
    ],
    ids=["fractional code", "complex", "three columns"],
)
def test_readings_as_an_array_that_is_not_codes_and_luminances_are_refused(array, named):
    with pytest.raises(ValueError, match=re.escape(named)):
        fit_calibration(np.asarray(array), bit_depth=8)


@pytest.mark.parametrize(
    ("cell", "named"),
    [
        ("5e-324", "luminance_cd_m2 5e-324"),  # attack case c031: a subnormal float
        ("1e-9", "luminance_cd_m2 1e-9"),
        ("1e300", "luminance_cd_m2 1e300"),  # attack case c030: named as written
        ("-0.5", "luminance_cd_m2 -0.5"),
    ],
)
def test_a_luminance_no_photometer_reads_is_refused_naming_file_line_and_value(
    cell, named, tmp_path
):
    path = tmp_path / "r.csv"
    path.write_text(f"code,luminance_cd_m2\n0,{cell}\n85,5\n170,40\n255,100\n")
    with pytest.raises(ValueError, match=rf"r\.csv, line 2: code 0 has {named}; must be 0 "):
        read_readings(path)


def test_a_subnormal_luminance_is_refused_by_the_fit_too():
    with pytest.raises(ValueError, match=r"code 0 has luminance 5e-324; must be 0 \("):
        fit_calibration([(0, 5e-324), *READINGS[1:]], bit_depth=8)
    assert fit_calibration([(0, 0.0), *READINGS[1:]], bit_depth=8).black_cd_m2 == 0


@pytest.mark.parametrize(
    ("row", "shown", "fix"),
    [("48,1,176", "'48,1,176'", "write 48,1.176 (luminance 1.176)"),
     ("512,94,830825", "'512,94,830825'", "write 512,94.830825 (luminance 94.830825)")],
)  # fmt: skip
def test_a_decimal_comma_is_shown_as_written_with_its_own_fix(tmp_path, row, shown, fix):
    # '48,1,176' was answered with a canned 'a decimal comma (94,83) ...: write 94.83'
    path = tmp_path / "r.csv"
    path.write_text(f"code,luminance_cd_m2\n0,0.1\n16,0.186\n32,0.5233\n{row}\n64,2.185\n")
    with pytest.raises(ValueError, match=r"line 5: 3 cells for 2 columns") as refused:
        read_readings(path)
    assert shown in str(refused.value) and str(refused.value).endswith(fix)
    assert "94,83)" not in str(refused.value)


def test_empty_cells_after_the_last_column_are_ignored(tmp_path):
    # a spreadsheet export ending each row in ',' was refused as a decimal comma, its fix
    # ('write 0,0.42') the line as it stood
    path = tmp_path / "r.csv"
    path.write_text("code,luminance_cd_m2\n0,0.42,\n85,10.5, \n170,40.2,,\n255,100,\n")
    assert read_readings(path) == [(0, 0.42), (85, 10.5), (170, 40.2), (255, 100.0)]
    path.write_text("code,luminance_cd_m2\n0,0.42,\n85,10,5,\n")  # a decimal comma still is
    with pytest.raises(ValueError, match=r"line 3: 4 cells for 2 columns .* decimal comma"):
        read_readings(path)


def test_a_calibration_made_in_python_is_admitted_only_as_its_file_would_be(tmp_path):
    """A status ``passed`` without a verification pass (or with one not its own) is refused by
    a session and a build, as it is in a file (``Calibration.load``)."""
    from dataclasses import replace

    from glarelab.display.calibration import usable_calibration
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import build_stimulus_set

    fitted = fit_calibration(READINGS, bit_depth=8)
    white = float(fitted.decode(np.array([255]))[0])
    passed = fitted.verified([(white, 255, white)])
    assert usable_calibration(passed) == {
        "calibrated": True,
        "status": "passed",
        "readings_sha256": fitted.readings_sha256,
        "curve_sha256": fitted.curve_sha256,
    }
    forged = replace(fitted, status="passed")
    with pytest.raises(ValueError, match="status 'passed' without verification measurements"):
        usable_calibration(forged)
    with pytest.raises(ValueError, match="status 'passed' without verification measurements"):
        build_stimulus_set(load_protocol("spencer1995"), tmp_path / "set", calibration=forged)
    assert not (tmp_path / "set").exists()
    invented = replace(forged, verification={"measurements": [], "tolerance_fraction": 0.5})
    with pytest.raises(ValueError, match="without verification measurements"):
        usable_calibration(invented)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        # the second luminance column was read and the first ignored
        ("code,luminance_cd_m2,luminance_cd_m2\n0,0.5,1\n255,100,2\n",
         r"line 1: the column\(s\) \['luminance_cd_m2'\] appear more than once"),
        # Python's int() reads '12_8' as 128
        ("code,luminance_cd_m2\n0,0.5\n12_8,50\n255,100\n",
         r"line 3: code must be a whole number .*got code '12_8'"),
        ("code,luminance_cd_m2\n0,0.5\n128,5_0\n255,100\n",
         r"line 3: .*luminance_cd_m2 '5_0'"),
        ("code,luminance_cd_m2\n0,0.5\n128.0,50\n255,100\n", r"line 3: .*got code '128\.0'"),
        # empty lines are the file's lines too (they were not counted: 'line 5')
        ("code,luminance_cd_m2\n0,0.5\n\n64,10\n\n\n128,abc\n255,100\n",
         r"readings\.csv, line 7: .*luminance_cd_m2 'abc'"),
    ],
)  # fmt: skip
def test_a_readings_cell_is_read_as_written_not_as_python_reads_numbers(tmp_path, text, match):
    path = tmp_path / "readings.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        read_readings(path)


def test_numbers_as_people_write_them_are_read(tmp_path):
    path = tmp_path / "readings.csv"
    path.write_text("code,luminance_cd_m2\n0, 0.5\n+128,5e1\n255,1.0E2\n")
    assert read_readings(path) == [(0, 0.5), (128, 50.0), (255, 100.0)]


@pytest.mark.parametrize(
    ("arguments", "match"),
    [
        ({"max_cd_m2": 100.0, "black_cd_m2": -1.0}, r"^black_cd_m2 must be 0 .*got -1\.0$"),
        ({"max_cd_m2": 1.0, "black_cd_m2": 5.0}, r"^black_cd_m2 = 5\.0 must be below max_cd_m2"),
        ({"max_cd_m2": math.nan, "black_cd_m2": 0.5}, r"^max_cd_m2 must be .*got nan$"),
        ({"max_cd_m2": "100", "black_cd_m2": 0.5}, r"^max_cd_m2 must be .*got '100'$"),
        ({"max_cd_m2": 100.0, "black_cd_m2": 0.5, "bit_depth": 9}, r"^bit_depth must be one"),
    ],
)
def test_a_synthetic_display_is_refused_naming_the_argument_not_readings(arguments, match):
    # the messages spoke of readings and codes the caller never gave
    from glarelab.display.calibration import synthetic_calibration

    with pytest.raises(ValueError, match=match):
        synthetic_calibration(**({"bit_depth": 8} | arguments))


@pytest.mark.parametrize(
    ("call", "name"),
    [
        # each was encoded: the mask dropped, '50' read as 50 cd/m², True as 1 cd/m²
        (lambda c: c.encode(np.ma.array([50.0, 500.0], mask=[0, 1])), "luminance_cd_m2"),
        (lambda c: c.encode(np.array(["50", "1"])), "luminance_cd_m2"),
        (lambda c: c.encode(np.array([True, False])), "luminance_cd_m2"),
        (lambda c: c.encode(np.array([50.0, np.inf])), "luminance_cd_m2"),
        # each was decoded: 10.7 as code 10, True as code 1
        (lambda c: c.decode([10.7]), "codes"),
        (lambda c: c.decode(np.array([True])), "codes"),
        (lambda c: c.decode([256]), "codes"),
    ],
)
def test_encode_and_decode_refuse_what_is_not_a_luminance_or_a_code(call, name):
    from glarelab.display.calibration import synthetic_calibration

    calibration = synthetic_calibration(max_cd_m2=100.0, black_cd_m2=0.1, bit_depth=8)
    with pytest.raises(ValueError, match=f"^{name} must"):
        call(calibration)


def test_a_code_out_of_range_is_named():
    from glarelab.display.calibration import synthetic_calibration

    calibration = synthetic_calibration(max_cd_m2=100.0, black_cd_m2=0.1, bit_depth=8)
    with pytest.raises(ValueError, match=r"in \[0, 255\].*got 300"):
        calibration.decode([10, 300])
    with pytest.raises(ValueError, match="got -1"):
        calibration.decode([-1])


def test_a_luminance_at_the_top_or_bottom_reading_is_not_counted_as_clipped():
    """433 cd/m², the top reading, was counted above the maximum: the fitted table ends at
    432.9999999999998."""
    from glarelab.display.calibration import fit_calibration

    readings = [(0, 0.5), (256, 30.0), (512, 120.0), (768, 270.0), (1023, 433.0)]
    calibration = fit_calibration(readings, bit_depth=10)
    codes, report = calibration.encode(np.array([433.0, 0.5, 0.0, 1000.0]))
    assert codes.tolist() == [1023, 0, 0, 1023]
    assert (report.above_max, report.below_black) == (1, 1)  # 1000 and 0 only


def test_several_dark_codes_at_the_photometers_floor_are_named_with_the_fix(tmp_path):
    """An OLED's darkest codes all read 0 on the photometer: refused as 'not increasing
    (photometer drift or a misread value?)', which no re-measurement can mend."""
    with pytest.raises(ValueError, match=r"codes 0, 32, 64 all read 0 cd/m², below the "
                       r"photometer's floor: keep the reading of code 0 and leave out"):  # fmt: skip
        fit_calibration([(0, 0.0), (32, 0.0), (64, 0.0), (128, 10.0), (255, 100.0)], bit_depth=8)
    fit_calibration([(0, 0.0), (128, 10.0), (255, 100.0), (64, 1.0)], bit_depth=8)


def test_a_header_typed_with_spaces_after_the_commas_is_read(tmp_path):
    """'code, luminance_cd_m2' was refused as missing luminance_cd_m2."""
    plain, spaced = tmp_path / "plain.csv", tmp_path / "spaced.csv"
    plain.write_text("code,luminance_cd_m2\n0,0.5\n128,20\n255,100\n64,5\n")
    spaced.write_text("code, luminance_cd_m2 \n0,0.5\n128,20\n255,100\n64,5\n")
    assert read_readings(spaced) == read_readings(plain)


def test_masked_readings_are_refused_in_one_line():
    """numpy's MaskError "Cannot convert masked element to a Python int" was all a user saw."""
    readings = np.array(READINGS, dtype=float)
    mask = np.zeros_like(readings, dtype=bool)
    mask[1] = True
    with pytest.raises(
        TypeError, match=r"^readings: readings must be a plain array, not a masked"
    ):
        fit_calibration(np.ma.masked_array(readings, mask), bit_depth=8)


def test_a_gog_fit_of_a_step_shows_no_warning_of_the_optimisers_trials():
    # a display jumping from black to white at code 2: the optimiser tries negative gammas,
    # whose power of zero drive is inf; those trials are not the user's concern
    readings = [(0, 0.5), (1, 0.6), (2, 399.0), (1023, 400.0)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fitted = fit_calibration(readings, bit_depth=10, method="gog")
    assert np.all(np.isfinite(fitted.lut))


def test_a_whole_float_code_in_a_list_is_refused_with_how_to_give_it():
    # refused as 'must be a whole number; got 32.0', while an array of floats was taken
    readings = [(0, 0.2), (32.0, 5.0), (64, 10.0), (128, 50.0), (255, 200.0)]
    with pytest.raises(ValueError, match=r"got 32\.0 .* \(a float: write 32; an \(N, 2\) array"):
        fit_calibration(readings, bit_depth=8)
    as_array = fit_calibration(np.array(readings), bit_depth=8)
    assert as_array.readings[1] == (32, 5.0)


def test_a_calibration_nested_too_deeply_is_refused_in_one_line(tmp_path):
    """'[' * 100000 made Calibration.load raise RecursionError, and render --calibration end
    as 'a bug in glarelab' (exit 70)."""
    import subprocess
    import sys

    from glarelab.display.calibration import Calibration
    from glarelab.stimuli.exr import write_exr

    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100000 + "]" * 100000)
    with pytest.raises(ValueError, match=r"deep\.json: .*arrays or objects nested too deeply"):
        Calibration.load(deep)
    image = np.ones((16, 16), np.float32)
    write_exr(tmp_path / "in.exr", image)
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "render", "--pixel-deg", "0.05", "--calibration",
         str(deep), str(tmp_path / "in.exr"), str(tmp_path / "out.exr")],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        f"glarelab render: {deep}: a calibration must be a JSON file; arrays or objects nested "
        "too deeply (glarelab's JSON files nest a few levels)"
    ]


def test_a_synthetic_calibration_relabelled_unverified_is_refused(tmp_path):
    """A synthetic gamma curve given status 'unverified' (by hand in its file, or with
    ``replace``) was admitted as a display's measured calibration."""
    import json
    from dataclasses import replace

    from glarelab.display.calibration import (
        Calibration,
        synthetic_calibration,
        usable_calibration,
    )

    synthetic = synthetic_calibration(max_cd_m2=200.0, black_cd_m2=0.2, bit_depth=10)
    path = synthetic.save(tmp_path / "synthetic.json")
    data = json.loads(path.read_text())
    data["status"] = "unverified"
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"status 'unverified' for a synthetic display"):
        Calibration.load(edited)
    relabelled = replace(synthetic, status="unverified")
    with pytest.raises(ValueError, match=r"status 'unverified' for a synthetic display"):
        usable_calibration(relabelled)
    with pytest.raises(ValueError, match=r"status 'unverified' for a synthetic display"):
        relabelled.save(tmp_path / "relabelled.json")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["edited.json", "synthetic.json"]


def test_save_refuses_what_load_would_refuse(tmp_path):
    """``Calibration.save`` wrote files the next ``Calibration.load`` refused: a status
    'passed' without a verification pass, a model added to a pchip calibration."""
    from dataclasses import replace

    readings = [(0, 0.5), (128, 40.0), (200, 120.0), (255, 200.0)]
    fitted = fit_calibration(readings, bit_depth=8)
    with pytest.raises(ValueError, match="status 'passed' without verification measurements"):
        replace(fitted, status="passed").save(tmp_path / "passed.json")
    fitted.model["gamma"] = 2.2  # its model dict is the caller's to change
    with pytest.raises(ValueError, match="has no model; it holds one"):
        fitted.save(tmp_path / "model.json")
    assert list(tmp_path.iterdir()) == []


def test_check_calibration_names_a_path_given_for_a_calibration():
    """``check_calibration(protocol, "file.json")`` ended in AttributeError: 'str' object has no
    attribute 'max_cd_m2'."""
    from glarelab.display.checks import check_calibration
    from glarelab.protocols import load_protocol

    with pytest.raises(TypeError, match=r"^calibration must be a Calibration \(Calibration.load"):
        check_calibration(load_protocol("yoshida2008"), "lab.json")
