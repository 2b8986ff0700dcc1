import pytest

from glarelab.experiments.matching import MatchingEngine as BrightnessMatching
from glarelab.experiments.rating import RatingEngine as LikertQuestionnaire
from glarelab.experiments.staircase import Staircase
from glarelab.experiments.staircase import StaircaseEngine as StaircaseExperiment
from glarelab.protocols import load_protocol


@pytest.fixture(scope="module")
def protocols():
    return {s: load_protocol(s) for s in ("yoshida2008", "spencer1995", "luidolt2020")}


# --- Yoshida 2008 ---------------------------------------------------------------------------


def test_yoshida_scripted_trial_records_exactly_what_was_set(protocols):
    engine = BrightnessMatching(protocols["yoshida2008"], "P01")
    assert engine.screen()["kind"] == "instructions"
    engine.press("space")
    shown = engine.screen()
    assert shown["kind"] == "adjust" and shown["settings_cd_m2"] == {"left": 100.0, "right": 400.0}
    left, reference, _right = shown["images"]
    assert reference["terms"][0][0].startswith("reference_") and shown["marker"] == "left"
    assert left["terms"] == [("target_background", 1.0), ("target_coverage", 100.0)]
    # left: +3 coarse (10) +2 fine (1) = 132; right: -5 coarse, -1 fine = 349
    script = ["up", "up", "up", "pageup", "pageup", "right", *["down"] * 5, "pagedown"]
    for key in script:
        assert engine.press(key, 1.0) is None
    assert engine.screen()["selected"] == "right"
    assert engine.press("return", 7.5) is None
    assert engine.screen()["question"] == "Does the reference image glow?"
    engine.press("y")
    engine.press("x")  # not an answer: ignored
    engine.press("n")
    row = engine.press("y")
    assert row["darker_cd_m2"] == 132.0 and row["brighter_cd_m2"] == 349.0
    assert row["match_cd_m2"] == 240.5 and row["adjustments"] == 11 and row["time_s"] == 7.5
    assert (row["q1_glow"], row["q2_ring"], row["q3_same_size"]) == (True, False, True)
    assert row["block"] == "training" and row["trial"] == 1


def test_yoshida_targets_stay_in_the_display_range(protocols):
    engine = BrightnessMatching(protocols["yoshida2008"], "P02")
    engine.press("space")
    for _ in range(60):
        engine.press("down")
    engine.press("right")
    for _ in range(60):
        engine.press("up")
    shown = engine.screen()
    assert shown["settings_cd_m2"] == {"left": 0.5, "right": 433.0}  # black .. max


def test_yoshida_order_is_random_per_participant_and_fixed_by_seed(protocols):
    p = protocols["yoshida2008"]
    a, b, c = (
        BrightnessMatching(p, "P01"),
        BrightnessMatching(p, "P01"),
        BrightnessMatching(p, "P02"),
    )
    assert a.order == b.order and a.order != c.order
    main = [t for t in a.order if t.startswith("main")]
    assert len(main) == 12 and len(set(main)) == 12  # every reference once
    assert sum(t.startswith("training") for t in a.order) == 3


# --- Spencer 1995 ---------------------------------------------------------------------------


def test_staircase_trajectory_with_scripted_responses():
    s = Staircase(
        level=1,
        strength=1.0,
        fraction=1.0,
        steps=(0.16, 0.08, 0.04),
        reversals_needed=3,
        neither="hold",
    )
    tested = []
    for response in ["glare", "disc", "disc", "glare", "neither"]:
        tested.append(round(s.fraction, 10))
        s.update(response)
    # glare at 1.0 (up, clamped), disc: reversal 1, step 0.08 → 0.92, disc → 0.84,
    # glare: reversal 2, step 0.04 → 0.88, neither: hold at 0.88, reversal 3 → done
    assert tested == [1.0, 1.0, 0.92, 0.84, 0.88]
    assert [r for _, r in s.history] == [False, True, False, True, True]
    assert s.done and round(s.fraction, 10) == 0.88


def test_neither_alternate_steps_against_the_last_direction():
    s = Staircase(
        level=1, strength=1.0, fraction=0.5, steps=(0.1,), reversals_needed=10, neither="alternate"
    )
    s.update("glare")  # up to 0.6
    s.update("neither")  # reversal: down to 0.5
    s.update("neither")  # reversal again: up to 0.6
    assert round(s.fraction, 10) == 0.6 and s.reversals == 2


def test_spencer_counterbalancing_and_exact_trial_sequence(protocols):
    p = protocols["spencer1995"]
    first = StaircaseExperiment(p, "P01", counterbalance=0, refresh_hz=60.0)
    second = StaircaseExperiment(p, "P02", counterbalance=1, refresh_hz=60.0)
    assert first.contexts == ["none", "lamp"] and second.contexts == ["lamp", "none"]
    first.press("space")
    screens = []
    for _ in range(20):
        screen = first.screen()
        screens.append((screen["glare_level"], screen["glare_side"], screen["frames"]))
        first.press("left")
    again = StaircaseExperiment(p, "P01", counterbalance=0, refresh_hz=60.0)
    again.press("space")
    replayed = []
    for _ in range(20):
        screen = again.screen()
        replayed.append((screen["glare_level"], screen["glare_side"], screen["frames"]))
        again.press("left")
    assert screens == replayed  # fixed by seed and participant
    assert {f for _, _, f in screens} <= {24, 42}  # 400 and 700 ms at 60 Hz
    assert first.context == "none"


def test_spencer_keys_map_to_sides(protocols):
    engine = StaircaseExperiment(
        protocols["spencer1995"], "P01", counterbalance=0, refresh_hz=60.0
    )
    engine.press("space")
    side = engine.screen()["glare_side"]
    other = "left" if side == "right" else "right"
    assert engine.press(side)["response"] == "glare"
    engine2 = StaircaseExperiment(
        protocols["spencer1995"], "P01", counterbalance=0, refresh_hz=60.0
    )
    engine2.press("space")
    assert engine2.press(other)["response"] == "disc"
    assert engine2.press("down")["response"] == "neither"
    assert engine2.press("q") is None


def test_spencer_replay_rebuilds_the_staircases(protocols):
    p = protocols["spencer1995"]
    a = StaircaseExperiment(p, "P03", counterbalance=0, refresh_hz=60.0)
    a.press("space")
    rows = [a.press(k) for k in ["left", "right", "down", "left", "left", "right"] * 5]
    b = StaircaseExperiment(p, "P03", counterbalance=0, refresh_hz=60.0)
    b.replay([{k: str(v) for k, v in r.items()} for r in rows])
    assert b.screen() == a.screen()
    assert [s.fraction for s in b.staircases] == [s.fraction for s in a.staircases]


# --- Luidolt 2020 ---------------------------------------------------------------------------


def test_likert_ratings_and_comments(protocols):
    engine = LikertQuestionnaire(protocols["luidolt2020"], "P01")
    engine.press("space")
    assert engine.screen()["category"] == "Glare Appearance"
    assert engine.press("9") is None and engine.screen()["kind"] == "rate"  # outside 1-7
    engine.press("4", 3.0)
    assert engine.screen()["text_entry"] and set(engine.screen()["keys"]) == {"return"}
    engine.type_text("Too bright, isn't it.")
    row = engine.press("return")
    assert (row["category"], row["rating"], row["comment"], row["time_s"]) == (
        "Glare Appearance",
        4,
        "Too bright, isn't it.",
        3.0,
    )
    engine.press("num_7")
    row = engine.press("return")
    assert row["rating"] == 7 and row["comment"] is None
    rows = [row]
    while not engine.done:
        engine.press("5")
        rows.append(engine.press("return"))
    assert [r["category"] for r in rows][-1] == "Overall" and len(rows) == 5


@pytest.mark.parametrize(
    ("study", "key", "value"),
    [("yoshida2008", "neither_band", 0.5), ("yoshida2008", "block_sd", 0.5),
     ("spencer1995", "glow_criterion", 0.9), ("spencer1995", "margin", 0.2)],
)  # fmt: skip
def test_observer_noise_of_another_paradigm_is_refused(study, key, value):
    """A matching study's ``neither_band`` (a staircase answer) passed protocol check and
    changed nothing: its observers never compare."""
    import tomllib
    from pathlib import Path

    from glarelab.experiments.paradigms import paradigm_run
    from glarelab.protocols import load_protocol, parse_protocol

    shipped = Path(__file__).parents[2] / "src" / "glarelab" / "protocols" / f"{study}.toml"
    data = tomllib.loads(shipped.read_text(encoding="utf-8"))
    observer = paradigm_run(load_protocol(study)).observer
    protocol = parse_protocol({**data, "observer": {"gain_sd": 0.2, key: value}}, source="p")
    with pytest.raises(ValueError, match=rf"^p: observer\.{key} = {value}: the .* paradigm's "
                       "observers do not read it"):  # fmt: skip
        observer.check(protocol)
    observer.check(parse_protocol({**data, "observer": {"gain_sd": 0.2}}, source="p"))
