"""glarelab.bench.timing: contenders timed in alternating rounds, short calls in batches."""

import time

from glarelab.bench.timing import BATCH_SECONDS, round_ratio, timed


def test_short_calls_are_timed_as_a_batch_and_long_ones_once():
    calls = {"short": 0, "long": 0}

    def short():
        calls["short"] += 1
        return "s"

    def long():
        calls["long"] += 1
        time.sleep(BATCH_SECONDS * 1.2)
        return "l"

    rounds = {}
    measured = timed({"short": short, "long": long}, 2, rounds=rounds)
    assert calls["long"] == 2  # one call a round
    assert calls["short"] > 2 * 10  # the first of each round, then a batch
    assert measured["long"][1] == "l" and measured["short"][1] == "s"
    assert measured["long"][0] >= BATCH_SECONDS * 1.2
    assert all(len(times) == 2 for times in rounds.values())
    assert max(rounds["short"]) < BATCH_SECONDS  # a call's share of the batch
    assert round_ratio(rounds, "long", "short") > 1.0
