"""glarelab bench --live: the per-frame renderer timed and measured against render_night."""

from glarelab.bench.live import live_bench, live_table


def test_live_bench_times_frames_and_measures_them_against_render_night():
    # compared on frames 0, 2 and 4: the gaze at the top-left corner, the bottom-right, the top-left
    rows = live_bench(
        frames=5, compared=3, workloads={"street_240x150": (240, 150)}, log=lambda line: None
    )
    (row,) = rows
    assert row["max_codes_exact"] < 0.5 and row["max_codes"] < 1.0  # offline 0.5 + ours
    assert row["fps"] == 1e3 / row["render_ms_median"] and row["bank_entries"] > 0
    assert "| street_240x150 |" in live_table(rows)
