import io
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.planning.execute import Progress, ResultLog, dask_client, run_tasks


class Squares:
    kind = "squares"

    def run(self, task):
        return {"square": task * task}


@settings(max_examples=25, deadline=None)
@given(done=st.lists(st.integers(0, 50), unique=True, max_size=20), cut=st.integers(0, 40))
def test_a_line_cut_short_is_dropped_and_the_rest_kept(tmp_path_factory, done, cut):
    path = tmp_path_factory.mktemp("log") / "results.jsonl"
    with ResultLog(path) as log:
        for task in done:
            log.add(task, {"value": task / 3})
    whole = path.read_bytes()
    partial = json.dumps({"task": 99, "result": {"value": 1.5}}).encode()[:cut]
    path.write_bytes(whole + partial)  # a kill in the middle of a write
    with ResultLog(path) as log:
        assert sorted(log.results) == sorted(done)
        assert all(log.results[t] == {"value": t / 3} for t in done)
        log.add(100, {"value": 0.1})
    assert (
        path.read_bytes()
        == whole
        + json.dumps({"result": {"value": 0.1}, "task": 100}, sort_keys=True).encode()
        + b"\n"
    )


def test_tasks_in_the_log_are_not_run_again(tmp_path):
    class Counting(Squares):
        def __init__(self):
            self.calls = []

        def run(self, task):
            self.calls.append(task)
            return super().run(task)

    job = Counting()
    with ResultLog(tmp_path / "log.jsonl") as log:
        run_tasks(job, range(3), log, progress=None)
    with ResultLog(tmp_path / "log.jsonl") as log:
        run_tasks(job, range(5), log, progress=None)
        assert [r["square"] for r in log.sorted()] == [0, 1, 4, 9, 16]
    assert job.calls == [0, 1, 2, 3, 4]


def test_progress_shows_tasks_done_rate_and_time_left(monkeypatch):
    import glarelab.planning.execute as execute

    now = [0.0]
    clock = type("Clock", (), {"perf_counter": staticmethod(lambda: now[0])})
    monkeypatch.setattr(execute, "time", clock)  # this module's clock only
    stream = io.StringIO()
    bar = Progress(10, done=4, what="replications", stream=stream)
    assert bar.line().endswith("4/10 replications")
    for t in (5.0, 7.0, 9.0):
        now[0] = t
        bar.update()
    line = bar.line()
    assert "7/10 replications, " in line and line.endswith("0.5/s, 6s left"), line


def test_the_first_time_left_waits_for_a_rate_without_the_start_up(monkeypatch):
    """The issue's "24h42m left": 1 of 3,000 tasks done after 30 s of workers starting up."""
    import glarelab.planning.execute as execute

    now = [0.0]
    clock = type("Clock", (), {"perf_counter": staticmethod(lambda: now[0])})
    monkeypatch.setattr(execute, "time", clock)
    bar = Progress(3000, what="replications", stream=io.StringIO())
    now[0] = 30.0
    bar.update()
    assert bar.line().endswith("time left: estimating"), bar.line()
    now[0] = 30.01  # a second worker's first task, at once: no rate yet either
    bar.update()
    assert bar.line().endswith("time left: estimating"), bar.line()
    for t in (31.0, 32.0, 33.0):
        now[0] = t
        bar.update(4)
    # 12 + 1 tasks in 3 s after the first: 4.33/s, 2,986 left
    assert bar.line().endswith("4.33/s, 11m29s left"), bar.line()


def test_the_same_results_on_dask_as_here(tmp_path):
    with dask_client(workers=1) as client, ResultLog(tmp_path / "dask.jsonl") as log:
        run_tasks(Squares(), range(6), log, client=client, progress=None)
        assert log.sorted() == [{"square": t * t} for t in range(6)]


def test_workers_and_a_scheduler_together_are_refused():
    with (
        pytest.raises(ValueError, match="not both"),
        dask_client(workers=2, scheduler="tcp://x:1"),
    ):
        pass
