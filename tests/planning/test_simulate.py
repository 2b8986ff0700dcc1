import pandas as pd
import pytest

from glarelab.analysis.load import load_sessions
from glarelab.analysis.paradigms import PARADIGMS
from glarelab.experiments.data import session_files
from glarelab.experiments.session import SimulatedFrontend, make_observer, run_session
from glarelab.observers.looking import ObservedSet
from glarelab.planning.simulate import participant_id, simulate_replication
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import StimulusSet, cached_stimulus_set


@pytest.fixture(scope="module")
def yoshida():
    protocol = load_protocol("yoshida2008")
    return protocol, cached_stimulus_set(protocol, progress=None)


def _session(protocol, participant, stimuli, looked, out):
    observer = make_observer(protocol, participant, seed=4, stimuli=looked)
    run_session(
        protocol,
        participant,
        out=out,
        frontend=SimulatedFrontend(observer),
        stimuli=stimuli,
        simulated=True,
    )
    (csv,) = [f for f in session_files(out, participant, protocol.study, 1) if f.suffix == ".csv"]
    return pd.read_csv(csv)


def test_observers_sharing_a_displayed_set_answer_as_observers_alone(yoshida, tmp_path):
    protocol, stimuli = yoshida
    shared = ObservedSet(StimulusSet(stimuli))
    for participant in ("a1", "a2"):
        alone = _session(protocol, participant, stimuli, stimuli, tmp_path / "alone")
        together = _session(protocol, participant, stimuli, shared, tmp_path / "shared")
        pd.testing.assert_frame_equal(alone, together)
    assert shared._percepts  # they did share


def test_the_tests_alone_are_the_full_analysis_tests(yoshida, tmp_path):
    protocol, stimuli = yoshida
    for number in range(1, 4):
        _session(protocol, f"s{number}", stimuli, stimuli, tmp_path)
    dataset = load_sessions(protocol, sorted(tmp_path.glob("*.csv")))
    full = PARADIGMS["matching"].analyse(dataset, protocol)["tables"]
    tests = PARADIGMS["matching"].tests(dataset, protocol)
    assert set(tests) == {"anova", "methods_at_levels", "boost_test"}
    for name, table in tests.items():
        pd.testing.assert_frame_equal(table, full[name])


def test_a_replication_is_fixed_by_the_seed_and_its_number(yoshida):
    protocol, stimuli = yoshida
    first = simulate_replication(protocol, 3, participants=(2, 3), seed=5, stimuli=stimuli)
    again = simulate_replication(protocol, 3, participants=(3, 2), seed=5, stimuli=stimuli)
    other = simulate_replication(protocol, 4, participants=(2, 3), seed=5, stimuli=stimuli)
    assert first == again and first["results"] != other["results"]
    effects = {r["effect"] for r in first["results"]}
    assert "6 × 2 (all levels): L_disk" in effects
    assert "t-test F/f: gaussian > vos (Welch, one-sided)" in effects
    assert {r["n"] for r in first["results"]} == {2, 3} and not first["failures"]


def test_participant_ids_are_file_name_safe_and_refuse_bad_numbers():
    assert participant_id(0, 1) == "rep000000-p001"
    with pytest.raises(ValueError, match="replication must be >= 0 and number >= 1"):
        participant_id(-1, 1)


def test_a_ctrl_c_during_a_simulated_session_stops_the_study_not_one_replication(
    yoshida, monkeypatch
):
    # the session took the SIGINT as its end (status aborted), the analysis refused the short
    # session, and power counted a failed replication, went on and ended with 0
    import os
    import signal

    import glarelab.planning.simulate as simulate

    class Interrupted(SimulatedFrontend):
        shown = 0

        def show(self, screen):
            Interrupted.shown += 1
            if Interrupted.shown == 5:
                os.kill(os.getpid(), signal.SIGINT)
            return super().show(screen)

    monkeypatch.setattr(simulate, "SimulatedFrontend", Interrupted)
    protocol, stimuli = yoshida
    with pytest.raises(KeyboardInterrupt, match="SIGINT"):
        simulate_replication(protocol, 0, participants=(2,), seed=5, stimuli=stimuli)


def test_scratch_left_by_a_killed_run_is_removed_and_a_live_ones_kept(yoshida, tmp_path):
    """A power run killed by SIGKILL left its sessions in /dev/shm (memory) until a reboot."""
    import os

    from glarelab.planning.simulate import _own_prefix

    protocol, stimuli = yoshida
    own = _own_prefix()
    dead = tmp_path / f"{own}999999999-x1"  # beyond any process id
    live = tmp_path / f"{own}{os.getppid()}-x2"
    other = tmp_path / "glarelab-power-notapid"
    elsewhere = tmp_path / "glarelab-power-otherhost.1-999999999-x3"  # ids of its own
    for folder in (dead, live, other, elsewhere):
        folder.mkdir()
        (folder / "P1.csv").write_text("trial\n")
    simulate_replication(protocol, 0, participants=(2,), seed=1, stimuli=stimuli, scratch=tmp_path)
    kept = sorted([live.name, other.name, elsewhere.name])
    assert sorted(p.name for p in tmp_path.iterdir()) == kept
