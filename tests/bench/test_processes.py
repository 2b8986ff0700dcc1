"""glarelab bench's one-call workload in fresh processes and its start-up section: what they
report (the times themselves are the benchmark's, not a test's)."""

import numpy as np

from glarelab.bench.processes import (
    FRESH_EMPTY,
    FRESH_WARM,
    STARTUP_BASELINE,
    STARTUP_CASES,
    fresh_bench,
    startup_bench,
)
from glarelab.bench.report import tables


def test_a_fresh_process_renders_the_same_image_with_an_empty_and_a_warm_cache():
    results = fresh_bench("street_256", "vos", repeats=1, log=lambda line: None)
    (empty_s, empty), (warm_s, warm) = results[FRESH_EMPTY], results[FRESH_WARM]
    assert empty_s > 0 and warm_s > 0
    np.testing.assert_array_equal(empty, warm)  # the cached kernel is the digitised one
    assert empty.shape == (256, 256) and float(empty.max()) <= 220.0


def test_startup_rows_are_ratios_to_numpy_and_scipy_fft():
    rows = startup_bench(repeats=1, log=lambda line: None)
    assert [r["case"] for r in rows] == list(STARTUP_CASES)
    baseline = next(r for r in rows if r["case"] == STARTUP_BASELINE)
    assert baseline["import_ratio"] == 1.0 and baseline["process_ratio"] == 1.0
    assert all(r["import_s"] > 0 and r["process_s"] > 0 for r in rows)
    assert "× import numpy, scipy.fft" in tables([], startup_rows=rows)


def test_the_bench_writes_the_fresh_process_rows_beside_the_others(tmp_path, monkeypatch):
    from glarelab.bench import run

    monkeypatch.setattr(run, "FRESH_WORKLOADS", ("street_256",))
    rows = run.run_bench(
        tmp_path, only=["street_256"], spectral=False, startup=False, repeats=1, log=lambda _: None
    )
    fresh = {r["variant"]: r for r in rows if r["variant"] in (FRESH_EMPTY, FRESH_WARM)}
    assert set(fresh) == {FRESH_EMPTY, FRESH_WARM}
    assert all(r["speed_vs_peer"] > 0 and r["max_error_codes"] <= 0.5 for r in fresh.values())
    assert FRESH_WARM in (tmp_path / "bench.md").read_text()
