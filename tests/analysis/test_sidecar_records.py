"""A session's sidecar agrees with itself, its CSV and its protocol, and the sessions of one
analysis ran on one stimulus set: a block order that contradicts ``counterbalance``, a
``refresh_hz`` no session of the protocol times at, a last run whose status or trial count is
not the session's, and sessions of two sets are refused naming the file, the field, the value
and what is allowed."""

import json
import re
from pathlib import Path

import pytest

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.analysis.methods import provenance
from glarelab.protocols import load_protocol


@pytest.fixture
def spencer(simulated):
    """Two simulated Spencer sessions (counterbalance 0 and 1: sim01 and sim02)."""
    return load_protocol("spencer1995"), sorted(simulated.glob("sim0[12]_spencer1995_s1_*.csv"))


def with_sidecar(source: Path, folder: Path, change) -> Path:
    """A copy of a session in ``folder`` whose sidecar is edited by ``change`` (in place)."""
    target = folder / source.name
    target.write_bytes(source.read_bytes())
    sidecar = json.loads(source.with_suffix(".json").read_text())
    change(sidecar)
    target.with_suffix(".json").write_text(json.dumps(sidecar))
    return target


def test_the_untouched_sessions_load(spencer):
    protocol, files = spencer
    dataset = load_sessions(protocol, files)
    assert [s["counterbalance"] for s in dataset.sidecars.values()] == [0, 1]


def _set(key, value):
    return lambda sidecar: sidecar.__setitem__(key, value)


def _run(key, value):
    return lambda sidecar: sidecar["runs"][-1].__setitem__(key, value)


@pytest.mark.parametrize(
    ("change", "named"),
    [
        (
            _set("counterbalance", 1),
            "counterbalance is 1, but its CSV's blocks begin in the order none, lamp: "
            "counterbalance 1 runs them lamp, none",
        ),
        (
            _set("refresh_hz", 60.0),
            "refresh_hz is 60.0; must be within 2 % of the protocol's display.refresh_hz 76 Hz",
        ),
        (
            _run("status", "aborted"),
            'runs[0].status is "aborted", but the session\'s status is "completed"',
        ),
        (
            _run("trials_after", 100),
            "runs[0].trials_after is 100, but the session recorded 321 trials",
        ),
        (
            _run("trials_before", 400),
            "runs[0].trials_after is 321, below its trials_before 400: must be ≥ 400",
        ),
        (
            _run("ended_by", "escape"),
            'runs[0].ended_by is "escape", but the run\'s status is "completed": must be null',
        ),
    ],
)
def test_a_sidecar_contradicting_itself_its_csv_or_its_protocol_is_refused(
    spencer, tmp_path, change, named
):
    protocol, files = spencer
    bad = with_sidecar(files[0], tmp_path, change)
    with pytest.raises(DataError, match=re.escape(f"{bad.with_suffix('.json')}: {named}")):
        load_sessions(protocol, [bad, *files[1:]])


def test_a_refresh_measured_within_the_tolerance_is_accepted(spencer, tmp_path):
    protocol, files = spencer
    measured = with_sidecar(files[0], tmp_path, _set("refresh_hz", 75.9))
    load_sessions(protocol, [measured, *files[1:]])


def test_sessions_of_two_stimulus_sets_are_refused_naming_each(spencer, tmp_path):
    protocol, files = spencer
    other = with_sidecar(files[0], tmp_path, _set("stimulus_set_manifest_sha256", "f" * 64))
    with pytest.raises(
        DataError,
        match=re.escape(
            f"the sessions ran on 2 stimulus sets (stimulus_set_manifest_sha256 of their "
            f"sidecars): ffffffffffff…: {other.name}; "
        ),
    ) as refused:
        load_sessions(protocol, [other, *files[1:]])
    assert f"…: {files[1].name}; must be one set" in str(refused.value)


def test_provenance_records_the_set_each_session_ran_on(spencer):
    _, files = spencer
    sidecars = {str(f): json.loads(f.with_suffix(".json").read_text()) for f in files}
    record = provenance(sidecars, None, None)
    used = {s["stimulus_set_manifest_sha256"] for s in sidecars.values()}
    assert record["stimulus_set_manifest_sha256_in_sessions"] == sorted(used)
    assert [s["stimulus_set_manifest_sha256"] for s in record["sessions"]] == [
        sidecars[str(f)]["stimulus_set_manifest_sha256"] for f in files
    ]
