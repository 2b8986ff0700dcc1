"""glarelab bench --live: the per-frame renderer timed and measured against render_night."""

import pytest

from glarelab.bench.live import live_bench, live_table, over_budget


def test_live_bench_times_frames_and_measures_them_against_render_night():
    # compared on frames 0, 2 and 4: the gaze at the top-left corner, the bottom-right, the top-left
    rows = live_bench(
        frames=5, compared=3, repeats=1, workloads={"street_240x150": (240, 150)},
        log=lambda line: None,
    )  # fmt: skip
    assert [row["pipeline"] for row in rows] == ["glare", "full"]
    for row in rows:
        assert row["max_codes_exact"] < 0.5 and row["max_codes"] < 1.0  # offline 0.5 + ours
        assert row["fps"] == 1e3 / row["render_ms_median"] and row["bank_entries"] > 0
        assert row["render_ms_p99"] >= row["render_ms_median"] and row["frames"] == 5
        assert 0 <= row["over_budget_frames"] <= 5
    assert "| street_240x150 | full |" in live_table(rows)


def test_an_unknown_pipeline_is_refused():
    with pytest.raises(ValueError, match="pipelines must be of"):
        live_bench(pipelines=("bloom",), log=lambda line: None)


def test_a_frame_over_the_refresh_period_is_counted():
    # 1/60 s is 16.667 ms: the frames beyond it are counted, those within it are not
    assert over_budget([1.0, 16.66, 16.666, 16.67, 40.0], 1 / 60) == 2
    assert over_budget([], 1 / 60) == 0
