"""glarelab bench --live: the per-frame renderer timed and measured against render_night."""

from glarelab.bench.live import live_bench, live_table


def test_live_bench_times_frames_and_measures_them_against_render_night():
    rows = live_bench(
        frames=4, compared=1, workloads={"street_240x150": (240, 150)}, log=lambda line: None
    )
    (row,) = rows
    assert row["max_codes_exact"] < 0.5 and row["max_codes"] < 1.0  # offline 0.5 + ours
    assert row["fps"] == 1e3 / row["render_ms_median"] and row["bank_entries"] > 0
    assert "| street_240x150 |" in live_table(rows)
