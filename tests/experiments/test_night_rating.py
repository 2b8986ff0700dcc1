"""A rating study that shows what it asks about: the night scene of each condition, frame-exact,
before its questions; simulated observers; the report with the stimulus next to its ratings."""

import csv
import tomllib

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.analysis.report import write_report
from glarelab.experiments.rating import RatingEngine, RatingObserver, shift_down
from glarelab.experiments.session import SimulatedFrontend, make_observer, run_session
from glarelab.protocols import load_protocol, parse_protocol
from glarelab.stimuli.stimulus_set import build_stimulus_set
from tests.conftest import small_night_protocol


@pytest.fixture(scope="module")
def night():
    return load_protocol("night2026")


def test_each_condition_is_shown_before_its_questions(night):
    engine = RatingEngine(night, "P01", refresh_hz=60.0)
    categories = night["questionnaire"]["categories"]
    assert engine.total_trials == len(categories) * len(night["conditions"])
    assert engine.screen()["kind"] == "instructions"
    engine.press("space")
    shown = []
    while not engine.done:
        screen = engine.screen()
        if screen["kind"] == "present":
            sequence = screen["sequence"]
            assert len(sequence) == 30 and all(step["frames"] == 6 for step in sequence)
            assert screen["frames"] == 180  # 3 s at 60 Hz, frame-exact
            assert sequence[0]["images"][0]["terms"] == [[f"{screen['condition']}_f000", 1.0]]
            assert screen["category"] == categories[0] and "1" in screen["keys"]
            assert screen["prompt"].startswith(categories[0])
            shown.append(screen["condition"])
        else:
            assert screen["kind"] in ("rate", "comment")
        row = engine.press("4" if screen["kind"] != "comment" else "return", 1.0)
        if screen["kind"] == "comment":
            assert row["condition"] == shown[-1]
    assert sorted(shown) == sorted(c["name"] for c in night["conditions"])


def test_the_order_of_conditions_is_the_participants_own_and_fixed(night):
    order = {p: RatingEngine(night, p).conditions for p in ("P01", "P02", "P03", "P04")}
    assert order["P01"] == RatingEngine(night, "P01").conditions
    assert len({tuple(o) for o in order.values()}) > 1


def test_a_resume_with_another_order_is_refused(night):
    engine = RatingEngine(night, "P01")
    other = next(c for c in engine.conditions if c != engine.conditions[0])
    with pytest.raises(ValueError, match="seeded order"):
        engine.replay([{"condition": other}])


def test_the_questionnaire_without_a_scene_is_as_before():
    engine = RatingEngine(load_protocol("luidolt2020"), "P01")
    engine.press("space")
    assert engine.screen()["kind"] == "rate" and engine.conditions == [None]


@pytest.mark.parametrize("points", [0.0, 0.3, 1.0, 2.5, 9.0])
def test_shift_down_keeps_the_probability_and_lowers_the_mean(points):
    p = np.array([0.0, 0.0, 0.20, 0.30, 0.25, 0.15, 0.10])
    moved = shift_down(p, points)
    scale = np.arange(1, 8)
    assert_allclose(moved.sum(), 1.0, atol=1e-12)
    assert moved.min() >= 0.0
    if points <= 2.0:  # nothing reaches the floor yet
        assert_allclose(scale @ p - scale @ moved, points, atol=1e-12)
    assert scale @ moved <= scale @ p + 1e-12


def test_the_observer_rates_a_category_lower_without_its_effect(night):
    observer = RatingObserver(night, "sim01", seed=1)
    full = observer.expected("Scotopic Vision", "full")
    assert_allclose(full, 5.5, atol=1e-9)  # Luidolt's stated mean (luidolt2020.toml)
    assert_allclose(observer.expected("Scotopic Vision", "no_scotopic"), full - 2.0, atol=1e-9)
    assert observer.expected("Scotopic Vision", "no_glare") == full
    assert observer.expected("Overall", "no_glare") == observer.expected("Overall", "full")


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    folder = tmp_path_factory.mktemp("night-study")
    path = folder / "night_small.toml"
    path.write_text(small_night_protocol())
    protocol = load_protocol(path)
    build_stimulus_set(protocol, folder / "set", progress=None)
    return protocol, folder


def test_a_simulated_study_and_its_report_show_the_stimulus_rated(small, tmp_path):
    protocol, folder = small
    stimuli = folder / "set"
    for number in range(1, 7):
        participant = f"sim{number:02d}"
        run_session(
            protocol, participant, out=tmp_path / "data",
            frontend=SimulatedFrontend(make_observer(protocol, participant, seed=1, stimuli=stimuli)),
            stimuli=stimuli, simulated=True,
        )  # fmt: skip
    csvs = sorted((tmp_path / "data").glob("*.csv"))
    with csvs[0].open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    categories = protocol["questionnaire"]["categories"]
    assert len(rows) == len(categories) * len(protocol["conditions"])
    first = [r for r in rows if r["category"] == categories[0]]
    # the presentation's timing is on the row of the condition's first category
    assert all(float(r["shown_ms"]) == pytest.approx(3 * 6 / 60 * 1000, abs=0.01) for r in first)
    assert all(r["shown_ms"] == "" for r in rows if r["category"] != categories[0])
    report = write_report(protocol, csvs, tmp_path / "report", stimuli=stimuli)
    summary = (report.parent / "summary.csv").read_text()
    assert summary.splitlines()[0].startswith("condition,category,n,mean")
    compared = (report.parent / "comparisons.csv").read_text().splitlines()
    assert len(compared) == 1 + (len(protocol["conditions"]) - 1) * len(categories)
    page = report.read_text()
    assert "night street" in page and "The scene of each condition" in page
    assert (report.parent / "ratings_by_condition.png").is_file()
    assert len(list(report.parent.glob("stimulus_*.png"))) == 1  # the conditions' frames
    # the observers rate the category of a missing effect two points lower, the others alike
    import pandas as pd

    table = pd.read_csv(report.parent / "comparisons.csv")
    effects = protocol["observer"]["category_effects"]
    about = table.apply(lambda r: r.condition == f"no_{effects.get(r.category)}", axis=1)
    assert -2.6 < table[about]["mean_difference"].mean() < -1.4
    assert abs(table[~about]["mean_difference"].mean()) < 0.5
    without = write_report(protocol, csvs, tmp_path / "bare")
    assert not list(without.parent.glob("stimulus_*.png"))


@pytest.mark.parametrize(
    ("change", "pattern"),
    [
        (lambda d: d.pop("display"), r"\[display\]: missing"),
        (lambda d: d.pop("conditions"), r"\[\[conditions\]\]: missing"),
        (lambda d: d.pop("scene"), r"\[\[conditions\]\]: need a \[scene\]"),
        (lambda d: d["conditions"][1].update(effects=["glow"]), "'glow'"),
        (lambda d: d["conditions"][1].update(name="full"), "names repeat"),
        (lambda d: d["scene"].update(size_px=[4000, 400]), "must fit the display"),
        (lambda d: d["scene"].update(sequence="sunrise"), "scene.sequence"),
        (
            lambda d: d["scene"].update(sequence="still", live=True, frame_rate_hz=30.0),
            r"scene.frame_rate_hz = 30.0: not used by a live scene",
        ),
        (
            lambda d: d["scene"].update(adapted_display_cd_m2=1e4),
            r"scene.adapted_display_cd_m2 = 10000: above the display's white",
        ),
        (lambda d: d["scene"].update(glare_model="sun"), "scene.glare_model = 'sun'"),
        (
            lambda d: d["scene"].update(glare_parameters={"age": 300}),
            "scene.glare_parameters: age must be",
        ),
        (
            lambda d: d["scene"].update(glare_parameters={"pupil_mm": 3.0}),
            r"scene.glare_parameters: pupil_mm = 3.0: a scene's eye state is each frame's",
        ),
        (lambda d: d["scene"].update(colour=1), "scene.colour: unknown key"),
        (lambda d: d["observer"]["category_effects"].update(Overall="glow"), "'glow'"),
    ],
)
def test_a_bad_night_protocol_is_refused_by_key(change, pattern):
    from glarelab.protocols.keys import ProtocolError

    data = tomllib.loads(small_night_protocol())
    change(data)
    with pytest.raises(ProtocolError, match=pattern):
        parse_protocol(data)


def test_keys_pressed_while_the_scene_shows_are_not_taken(night):
    from glarelab.experiments.engine import Press
    from glarelab.experiments.loop import SessionLoop, Shown

    class Device:  # the scene from 1.0 s to 4.0 s; a 3 during it, a 5 after it
        def __init__(self):
            self.presses = [
                Press("space", 0.5),
                Press("3", 2.0),
                Press("5", 4.5),
                Press("escape", 9),
            ]

        def show(self, screen):
            return 0.1

        def present(self, screen):
            return Shown(onset_s=1.0, offset_s=4.0, frames=screen["frames"])

        def wait_keys(self, anchor_s):
            return [self.presses.pop(0)]

        def typed(self):
            return ""

    rows = []
    loop = SessionLoop(Device(), rows.append, refresh_hz=60.0)
    from glarelab.experiments.loop import SessionAborted

    engine = RatingEngine(night, "P01")
    with pytest.raises(SessionAborted):
        loop.run(engine)
    assert loop.total_ignored == 1  # the 3, pressed during the scene
    assert (engine.phase, engine.rating, engine.time) == ("comment", 5, 3.5)  # from the onset
    assert rows == []
