"""Measure glarelab power on this machine: replications per second on 1 and 2 workers of a
local Dask cluster and, as the peer, of a multiprocessing.Pool, the scheduler's cost per task,
and the memory of a worker.

    python scripts/measure_power.py --out docs/power/measurements.json

Each measurement runs a fresh cluster (or pool); the replications are the same in every run
(seed 1), so the runs differ only in how they are executed. Neither is warmed up: each worker
reads the stimulus set and computes its first percepts within the run, as in a user's run.
The machine may be shared: runs on 1 and 2 workers alternate, and the best of each is kept,
so the speed-up is a ratio of runs made under the same load. The cost per task is measured
with tasks that do nothing (a job whose run returns at once) as wall time × workers / tasks.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

from glarelab.planning.execute import ResultLog, dask_client, run_tasks
from glarelab.planning.simulate import PowerJob
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import cached_stimulus_set


class TimedJob:
    """A job whose results also say the CPU time of the worker's process for the task: what
    the task costs, whatever else shares the machine."""

    kind = "timed"

    def __init__(self, job):
        self.job = job

    def run(self, task: int) -> dict:
        start = time.process_time()
        result = self.job.run(task)
        return {"cpu_s": time.process_time() - start, "effects": len(result["results"])}


class NothingJob:
    """Tasks that do nothing: what the scheduler and the result log cost."""

    kind = "nothing"

    def run(self, task: int) -> dict:
        return {"task": task}


def _rss_mb() -> float:
    import psutil

    return psutil.Process().memory_info().rss / 2**20


def replications_per_second(protocol, *, workers: int, replications: int, participants) -> dict:
    stimuli = cached_stimulus_set(protocol, progress=None)
    job = TimedJob(PowerJob(protocol, participants=participants, seed=1, stimuli=stimuli))
    with dask_client(workers=workers) as client, tempfile.TemporaryDirectory() as folder:
        client.run(_rss_mb)  # workers up; each sets up (reads the set) within the run
        log = ResultLog(Path(folder) / "log.jsonl")
        load = os.getloadavg()[0]
        start = time.perf_counter()
        run_tasks(job, range(replications), log, client=client, progress=None)
        seconds = time.perf_counter() - start
        memory = client.run(_rss_mb)
        cpu = [r["cpu_s"] for r in log.sorted()]
    return {
        "load_before": load,
        "load_after": os.getloadavg()[0],
        "cpu_s_per_replication": sum(cpu) / len(cpu),
        "cpu_s_median": statistics.median(cpu),
        "cpu_s_first_of_worker": sorted(cpu)[-workers:],
        "study": protocol.study,
        "workers": workers,
        "replications": replications,
        "participants": list(participants),
        "seconds": seconds,
        "replications_per_s": replications / seconds,
        "worker_rss_mb": sorted(memory.values()),
    }


_POOL_JOB = None


def _pool_start(job) -> None:
    global _POOL_JOB
    _POOL_JOB = job


def _pool_run(task: int) -> dict:
    return _POOL_JOB.run(task)


def pool_replications_per_second(
    protocol, *, workers: int, replications: int, participants
) -> dict:
    """The peer a user could write without Dask: the same replications on a
    multiprocessing.Pool of single-threaded processes (BLAS limited to one thread each, as
    Dask's workers are)."""
    import multiprocessing

    stimuli = cached_stimulus_set(protocol, progress=None)
    job = TimedJob(PowerJob(protocol, participants=participants, seed=1, stimuli=stimuli))
    context = multiprocessing.get_context("spawn")
    threads = {k: os.environ.get(k) for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")}
    os.environ.update({k: "1" for k in threads})
    try:
        with context.Pool(workers, initializer=_pool_start, initargs=(job,)) as pool:
            load = os.getloadavg()[0]
            start = time.perf_counter()
            results = pool.map(_pool_run, range(replications), chunksize=1)
            seconds = time.perf_counter() - start
    finally:
        for key, value in threads.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    return {
        "load_before": load,
        "cpu_s_per_replication": sum(r["cpu_s"] for r in results) / len(results),
        "cpu_s_median": statistics.median(r["cpu_s"] for r in results),
        "workers": workers,
        "replications": replications,
        "seconds": seconds,
        "replications_per_s": replications / seconds,
    }


def task_overhead(*, workers: int, tasks: int) -> dict:
    with dask_client(workers=workers) as client, tempfile.TemporaryDirectory() as folder:
        run_tasks(
            NothingJob(),
            range(-workers, 0),
            ResultLog(Path(folder) / "w"),
            client=client,
            progress=None,
        )
        log = ResultLog(Path(folder) / "log.jsonl")
        start = time.perf_counter()
        run_tasks(NothingJob(), range(tasks), log, client=client, progress=None)
        seconds = time.perf_counter() - start
        idle = client.run(_rss_mb)
    return {
        "workers": workers,
        "tasks": tasks,
        "seconds": seconds,
        "ms_per_task": 1000 * seconds * workers / tasks,
        "idle_worker_rss_mb": sorted(idle.values()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--study", default="yoshida2008")
    parser.add_argument("--replications", type=int, default=16)
    parser.add_argument("--rounds", type=int, default=2, help="interleaved rounds; best kept")
    parser.add_argument("--participants", type=int, nargs="+", default=[6, 8, 10, 12, 16, 20])
    args = parser.parse_args()
    protocol = load_protocol(args.study)
    results = {"overhead": [], "throughput": [], "pool": []}
    for _ in range(args.rounds):  # 1 and 2 workers interleaved: both see the same machine load
        for workers in (1, 2):
            results["overhead"].append(task_overhead(workers=workers, tasks=400))
            results["throughput"].append(
                replications_per_second(
                    protocol,
                    workers=workers,
                    replications=args.replications,
                    participants=args.participants,
                )
            )
            print(json.dumps(results["throughput"][-1]), flush=True)
            results["pool"].append(
                pool_replications_per_second(
                    protocol,
                    workers=workers,
                    replications=args.replications,
                    participants=args.participants,
                )
            )
            print(json.dumps(results["pool"][-1]), flush=True)
    best = {
        w: max(r["replications_per_s"] for r in results["throughput"] if r["workers"] == w)
        for w in (1, 2)
    }
    results["best_replications_per_s"] = best
    results["speed_up"] = best[2] / best[1]
    pool = {
        w: max(r["replications_per_s"] for r in results["pool"] if r["workers"] == w)
        for w in (1, 2)
    }
    results["pool_best_replications_per_s"] = pool
    results["pool_speed_up"] = pool[2] / pool[1]
    results["cpu_s_per_replication"] = min(
        r["cpu_s_per_replication"] for r in results["throughput"]
    )
    results["best_ms_per_task"] = {
        w: min(r["ms_per_task"] for r in results["overhead"] if r["workers"] == w) for w in (1, 2)
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n")
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
