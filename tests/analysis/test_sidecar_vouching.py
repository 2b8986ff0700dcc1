"""Each session file is vouched for by its sidecar: a file given twice is named, a sidecar of a
data format this version does not know, with a field of the wrong type or a value no session
writes (NaN, counterbalance 7), or that calls a simulated observer's session real is refused
naming the file and the field; a CSV without its sidecar is refused unless admitted, and then
listed."""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.protocols import load_protocol


@pytest.fixture(scope="module")
def luidolt(tmp_path_factory):
    """Two simulated Luidolt sessions (6 trials each)."""
    folder = tmp_path_factory.mktemp("luidolt")
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "run", "luidolt2020", "--simulate",
         "--participants", "2", "--seed", "1", "--out", str(folder)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return load_protocol("luidolt2020"), sorted(folder.glob("*.csv"))


def edited(files, folder: Path, change: dict) -> list[Path]:
    """Copies of the sessions in ``folder``, the first one's sidecar with ``change``."""
    copies = []
    for path in files:
        shutil.copy(path, folder / path.name)
        shutil.copy(path.with_suffix(".json"), folder / path.with_suffix(".json").name)
        copies.append(folder / path.name)
    sidecar = copies[0].with_suffix(".json")
    sidecar.write_text(json.dumps(json.loads(sidecar.read_text()) | change))
    return copies


def test_the_same_file_given_twice_is_named(luidolt):
    protocol, files = luidolt
    with pytest.raises(DataError, match=re.escape(f"{files[0]}: given twice")):
        load_sessions(protocol, [*files, files[0]])


def test_a_data_format_this_version_does_not_know_is_refused(luidolt, tmp_path):
    protocol, files = luidolt
    copies = edited(files, tmp_path, {"data_format": "9.9"})
    with pytest.raises(
        DataError, match=re.escape('data_format "9.9" is not a format this version of glarelab')
    ) as refused:
        load_sessions(protocol, copies)
    assert str(copies[0].with_suffix(".json")) in str(refused.value)
    assert "0.1, 0.2, 0.3, 0.4" in str(refused.value)


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"resumed": float("nan")}, "resumed is NaN; must be a whole number ≥ 0"),
        ({"trials": "6"}, 'trials is "6"; must be a whole number ≥ 0'),
        ({"counterbalance": 7}, "counterbalance is 7; must be null (no counterbalancing), 0"),
        ({"refresh_hz": float("inf")}, "refresh_hz is Infinity; must be null or a finite"),
        ({"status": "done"}, 'status is "done"; must be one of running, completed'),
        ({"calibration": "none"}, 'calibration is "none"; must be null or an object'),
        ({"participant_info": {"age": -5}}, "participant_info.age is -5; must be null or whole"),
        ({"participant_info": {"age": "31"}}, 'participant_info.age is "31"; must be null'),
        ({"started": "yesterday"}, 'started is "yesterday"; must be null or an ISO date'),
        ({"ended": "2020-01-01T00:00:00+00:00"}, "ended 2020-01-01T00:00:00+00:00 is before"),
        ({"runs": []}, "runs is empty; every session records its first run"),
        ({"resumed": 1}, "resumed is 1, but it records 1 run(s)"),
        (
            {"bit_depth": 10, "runs": [{"display": {"bits_per_channel": 8}}]},
            "bit_depth is 10, but its last run's display showed 8 bits per channel",
        ),
        # a rating session records no order (protocols.rating.SESSION_ORDER)
        ({"trial_order": [3, 1, 2]}, "trial_order is [3, 1, 2]; must be null: a rating session"),
        ({"counterbalance": 1}, "counterbalance is 1; must be null: a rating session records no"),
        (  # a status comes only from a calibration file's readings and verification pass
            {"calibration": {"calibrated": True, "readings_sha256": None, "status": "passed"}},
            "calibration.readings_sha256 is null, but its status is passed: must be the sha256",
        ),
        (
            {"calibration": {"calibrated": True, "readings_sha256": "ab", "status": "unverified"}},
            'calibration.readings_sha256 is "ab", but its status is unverified',
        ),
        (
            {
                "calibration": {
                    "calibrated": True,
                    "readings_sha256": "a" * 64,
                    "curve_sha256": None,
                    "status": "passed",
                }
            },
            "calibration.curve_sha256 is null, but its status is passed: must be the sha256",
        ),
        (
            {
                "calibration": {
                    "calibrated": False,
                    "readings_sha256": None,
                    "curve_sha256": "a" * 64,
                    "status": "simulated",
                }
            },
            'calibration.curve_sha256 is "aaaa',
        ),
        (
            {"calibration": {"calibrated": True, "readings_sha256": None, "status": "missing"}},
            "calibration.calibrated is true; a session whose calibration is missing records false",
        ),
        (
            {"calibration": {"calibrated": False, "readings_sha256": "a" * 64, "status": "none"}},
            'calibration.status is "none"; must be one of "passed", "unverified"',
        ),
        (
            {
                "simulated": False,
                "calibration": {
                    "calibrated": True,
                    "readings_sha256": "a" * 64,
                    "status": "unverified",
                    "accepted_unverified_by": "--pilot",
                },
            },
            'calibration.accepted_unverified_by is "--pilot"; must be --allow-uncalibrated (in',
        ),
    ],
)
def test_a_sidecar_field_no_session_writes_is_refused_naming_it(luidolt, tmp_path, change, named):
    protocol, files = luidolt
    copies = edited(files, tmp_path, change)
    with pytest.raises(DataError, match=re.escape(f"{copies[0].with_suffix('.json')}: {named}")):
        load_sessions(protocol, copies)


def test_a_simulated_session_relabelled_real_is_refused(luidolt, tmp_path):
    protocol, files = luidolt
    copies = edited(files, tmp_path, {"simulated": False})
    with pytest.raises(
        DataError,
        match=re.escape(
            f"{copies[0].with_suffix('.json')}: simulated is false, but its calibration status "
            "is 'simulated', its participant_info holds simulated_observer_seed, its runs' "
            "keyboard is 'simulated observer'"
        ),
    ):
        load_sessions(protocol, copies)


def test_a_csv_without_its_sidecar_is_refused_unless_admitted_and_then_listed(luidolt, tmp_path):
    from glarelab.analysis.report import write_report

    protocol, files = luidolt
    copies = edited(files, tmp_path, {})
    copies[0].with_suffix(".json").unlink()
    with pytest.raises(DataError, match=re.escape(f"{copies[0]}: no sidecar")) as refused:
        load_sessions(protocol, copies)
    assert "--include-no-sidecar" in str(refused.value)
    dataset = load_sessions(protocol, copies, include_no_sidecar=True)
    assert [s["status"] for s in dataset.sessions] == ["no sidecar", "completed"]
    report = write_report(protocol, copies, tmp_path / "report", include_no_sidecar=True)
    assert "no sidecar" in report.read_text()
