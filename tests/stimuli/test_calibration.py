import json
import re

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.display.calibration import (
    Calibration,
    fit_calibration,
    read_readings,
    synthetic_calibration,
)


def measured_looking(bit_depth=10):
    """A display with a non-gamma response: a knee near black, a soft shoulder at the top."""
    top = 2**bit_depth - 1
    codes = np.unique(np.round(np.linspace(0, top, 24)).astype(int))
    x = codes / top
    luminance = 0.35 + 300.0 * (0.6 * x**2.6 + 0.4 * (1 - np.exp(-3.0 * x)) / (1 - np.exp(-3.0)))
    return list(zip(codes.tolist(), luminance.tolist(), strict=True))


def half_step_check(calibration):
    lut = calibration.lut
    targets = np.linspace(lut[0], lut[-1], 200_001)
    codes, report = calibration.encode(targets)
    assert report.clipped == 0
    # the interval each target falls in, and its step
    k = np.clip(np.searchsorted(lut, targets, side="right") - 1, 0, lut.size - 2)
    step = lut[k + 1] - lut[k]
    error = np.abs(calibration.decode(codes) - targets)
    assert (error <= step / 2 + 1e-12).all()


def test_synthetic_display_encodes_within_half_a_code_step():
    calibration = synthetic_calibration(max_cd_m2=433.0, black_cd_m2=0.5, bit_depth=10)
    assert calibration.status == "synthetic" and "SYNTHETIC" in calibration.label
    assert_allclose([calibration.black_cd_m2, calibration.max_cd_m2], [0.5, 433.0])
    half_step_check(calibration)


@pytest.mark.parametrize("bit_depth", [8, 10])
def test_measured_looking_display_encodes_within_half_a_code_step(bit_depth):
    readings = measured_looking(bit_depth)
    calibration = fit_calibration(readings, bit_depth=bit_depth)
    half_step_check(calibration)
    # the curve passes through the readings
    codes = np.array([c for c, _ in readings])
    assert_allclose(calibration.decode(codes), [v for _, v in readings], rtol=1e-12)


def test_out_of_range_luminance_is_clipped_and_counted_never_wrapped():
    calibration = synthetic_calibration(max_cd_m2=100.0, black_cd_m2=0.1, bit_depth=8)
    codes, report = calibration.encode(np.array([0.0, 50.0, 100.0, 1e6]))
    assert codes.tolist()[0] == 0 and codes.tolist()[-1] == 255
    assert (report.above_max, report.below_black) == (1, 1)


def test_gain_offset_gamma_fit_reports_residuals():
    exact = fit_calibration(
        list(synthetic_calibration(max_cd_m2=433.0, black_cd_m2=0.5, bit_depth=10).readings),
        bit_depth=10,
        method="gog",
    )
    assert_allclose(exact.model["gamma"], 2.2, rtol=1e-6)
    assert exact.model["rms_residual_cd_m2"] < 1e-6
    curved = fit_calibration(measured_looking(), bit_depth=10, method="gog")
    assert curved.model["max_residual_cd_m2"] > 1.0  # a non-gamma display does not fit a gamma
    assert len(curved.model["residuals_cd_m2"]) == len(measured_looking())


@pytest.mark.parametrize(
    ("readings", "match"),
    [
        (
            [(0, 0.1), (300, 50.0), (600, 40.0), (1023, 300.0)],
            r"not increasing: code 600 → 40 cd/m² is not above code 300 → 50",
        ),
        ([(0, 0.1), (300, 50.0), (300, 51.0), (1023, 300.0)], "code 300 is measured twice"),
        ([(0, 0.1), (300, 50.0), (1023, 300.0)], "at least 4 readings"),
        ([(0, 0.1), (300, 50.0), (600, 90.0), (2000, 300.0)], "code 2000 is outside 0-1023"),
        (
            [(10, 0.1), (300, 50.0), (600, 90.0), (1023, 300.0)],
            "must include code 0 and code 1023",
        ),
        ([(0, -1.0), (300, 50.0), (600, 90.0), (1023, 300.0)], "luminance -1.0"),
    ],
)
def test_bad_readings_are_refused(readings, match):
    with pytest.raises(ValueError, match=match):
        fit_calibration(readings, bit_depth=10)


def test_round_trip_through_a_file_and_tamper_detection(tmp_path):
    calibration = fit_calibration(measured_looking(), bit_depth=10, label="test display")
    path = calibration.save(tmp_path / "display.json")
    loaded = Calibration.load(path)
    assert np.array_equal(loaded.lut, calibration.lut)
    data = json.loads(path.read_text())
    data["readings"][3][1] += 1.0
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="do not match their recorded hash"):
        Calibration.load(path)


def test_verification_marks_passed_or_failed():
    calibration = fit_calibration(measured_looking(), bit_depth=10)
    good = calibration.verified([(10.0, 100, 10.1), (100.0, 500, 99.0)], tolerance_fraction=0.03)
    bad = calibration.verified([(10.0, 100, 10.1), (100.0, 500, 90.0)], tolerance_fraction=0.03)
    assert good.status == "passed" and bad.status == "failed"
    assert bad.verification["max_relative_error"] == pytest.approx(0.1)


def test_readings_csv(tmp_path):
    path = tmp_path / "readings.csv"
    path.write_text("code,luminance_cd_m2\n0,0.2\n512,80.5\n1023,300\n")
    assert read_readings(path) == [(0, 0.2), (512, 80.5), (1023, 300.0)]
    path.write_text("code,lum\n0,1\n")
    with pytest.raises(ValueError, match="missing column"):
        read_readings(path)
    path.write_text("code,luminance_cd_m2\n0,abc\n")
    with pytest.raises(ValueError, match="line 2"):
        read_readings(path)


def test_shipped_synthetic_calibrations_match_their_protocols():
    from pathlib import Path

    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import default_calibration

    root = Path(__file__).parents[2]
    for study, name in (("yoshida2008", "433cd-10bit"), ("spencer1995", "50cd-8bit")):
        shipped = Calibration.load(root / "calibrations" / f"SYNTHETIC-{study}-{name}.json")
        assert shipped.status == "synthetic" and "SYNTHETIC" in shipped.label
        expected = default_calibration(
            load_protocol(root / "src" / "glarelab" / "protocols" / f"{study}.toml")
        )
        # equal but for the last bits of numpy's float64 power, which differ between CPUs
        # (SVML on AVX-512, the C library's elsewhere: 1 ulp in a reading, up to 6 ulp in
        # the table); any change of gamma, black or white moves it by far more
        np.testing.assert_allclose(shipped.lut, expected.lut, rtol=1e-13, atol=0)


def test_sessions_refuse_missing_failed_or_synthetic_calibrations():
    from glarelab.display.calibration import usable_calibration

    synthetic = synthetic_calibration(max_cd_m2=433.0, black_cd_m2=0.5, bit_depth=10)
    fitted = fit_calibration(measured_looking(), bit_depth=10)
    passed = fitted.verified([(10.0, 100, 10.1)])
    failed = fitted.verified([(10.0, 100, 12.0)])
    for calibration, status in ((None, "missing"), (failed, "failed"), (synthetic, "synthetic")):
        with pytest.raises(ValueError, match=f"calibration is {status}"):
            usable_calibration(calibration)
        record = usable_calibration(calibration, allow_uncalibrated=True)
        assert record == {
            "calibrated": False,
            "status": status,
            "readings_sha256": None if calibration is None else calibration.readings_sha256,
            "curve_sha256": None if calibration is None else calibration.curve_sha256,
        }
    assert usable_calibration(passed)["calibrated"] is True
    with pytest.warns(UserWarning, match="not been verified"):
        assert usable_calibration(fitted)["calibrated"] is True


def _saved(tmp_path, calibration) -> dict:
    return json.loads(calibration.save(tmp_path / "display.json").read_text())


def _forge(tmp_path, data):
    path = tmp_path / "forged.json"
    path.write_text(json.dumps(data))
    return path


def _one_invented_measurement(data):
    data["status"] = "passed"
    data["verification"] = {
        "tolerance_fraction": 0.03,
        "max_relative_error": 0.0,
        "measurements": [
            {"target_cd_m2": 100.0, "code": 500, "measured_cd_m2": 100.0, "relative_error": 0.0}
        ],
        "date": "2026-01-01",
    }


def _tolerance_widened(data):  # a failed pass made to pass
    data["verification"]["tolerance_fraction"] = 0.5
    data["status"] = "passed"


def _nan_reading(data):
    data["verification"]["measurements"].append(
        {"target_cd_m2": 50.0, "code": 300, "measured_cd_m2": float("nan"), "relative_error": 0}
    )


@pytest.mark.parametrize(
    ("verified", "forge", "named"),
    [
        (False, _one_invented_measurement, "does not match its recorded hash"),
        (True, _tolerance_widened, "does not match its recorded hash"),
        (True, _nan_reading, "measured_cd_m2 is nan; must be a finite luminance"),
        (True, lambda d: d["verification"].update(tolerance_fraction=True),
         "tolerance_fraction is True; must be a number in (0, 1]"),
        (True, lambda d: d["verification"]["measurements"][0].update(code=100.7),
         "a verification code is 100.7; must be a whole number"),
        (False, lambda d: d["readings"][2].__setitem__(0, 256.5),
         "a reading's code is 256.5; must be a whole number"),
        (False, lambda d: d.update(bit_depth=10.9), "bit_depth is 10.9; must be a whole number"),
    ],
    ids=["invented pass", "tolerance 0.5", "NaN", "tolerance true", "fractional verify code",
         "fractional reading code", "bit depth 10.9"],
)  # fmt: skip
def test_a_forged_calibration_is_refused_naming_the_key(tmp_path, verified, forge, named):
    calibration = fit_calibration(measured_looking(), bit_depth=10)
    if verified:  # a pass that failed: 10 % off at code 500
        calibration = calibration.verified(
            [(10.0, 100, 10.1), (100.0, 500, 90.0)], tolerance_fraction=0.03
        )
    data = _saved(tmp_path, calibration)
    Calibration.from_json(json.loads(json.dumps(data)))  # the genuine one loads
    forge(data)
    with pytest.raises(ValueError, match=re.escape(named)):
        Calibration.load(_forge(tmp_path, data))


def test_a_readings_row_with_a_decimal_comma_is_refused(tmp_path):
    path = tmp_path / "readings.csv"
    path.write_text("code,luminance_cd_m2\n0,0.5\n512,94,830825\n1023,300\n")
    with pytest.raises(ValueError, match=r"line 3: 3 cells for 2 columns .*decimal comma"):
        read_readings(path)
    path.write_text("code,luminance_cd_m2\n0,0.5\n512,\n1023,300\n")
    with pytest.raises(ValueError, match=r"line 3: code and luminance_cd_m2 both need a value"):
        read_readings(path)
