"""Running many independent tasks on Dask, streaming each result to disk as it finishes.

A *job* is a picklable object with ``run(task) -> dict`` (a task is a number: a replication,
a grid point) that keeps what its worker may reuse between tasks (a stimulus set read once,
its percepts). The job is sent to every worker once, as a worker plugin
(:class:`distributed.diagnostics.plugin.WorkerPlugin`, Dask's place for per-worker state);
each task then sends only its number. Tasks are whole replications or stimulus sets, seconds
each, so the scheduler's cost per task (milliseconds; ``docs/power.md``) is negligible.

Results go to a :class:`ResultLog`, one JSON line per task, flushed and fsync'ed as each task
finishes, in whatever order they finish. A run that is interrupted (Ctrl-C, SIGKILL, a lost
cluster) keeps every finished task; run again, it does only the tasks missing. Everything
computed from the log is sorted by task first, so the order in which tasks finished (and so
the number of workers) never shows in a result.

:func:`dask_client` starts a :class:`distributed.LocalCluster` (one single-threaded worker
process per core by default: the work is Python and numpy on small arrays, bound by the GIL, so
processes scale and threads do not) or connects to an existing scheduler by address.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import sys
import time
import uuid
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from distributed.diagnostics.plugin import WorkerPlugin

from glarelab.files.inputs import loads_json

__all__ = ["JobPlugin", "Progress", "ResultLog", "available_cores", "dask_client", "run_tasks"]


def available_cores() -> int:
    """The cores this process may run on (the machine's size for a local cluster)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


class ResultLog:
    """Finished tasks' results as JSON lines, each one on disk before the next is written.

    A line cut short by a kill (the only line that can be: each is written and fsync'ed
    whole) is dropped when the log is opened again.

    Parameters
    ----------
    path
        The log file (created with its folder).
    key
        What the results depend on (a hash of the run's inputs): with it, every line carries
        the key and a checksum, and a log holding a line of another key or an edited line is
        refused when opened.

    Raises
    ------
    ValueError
        When opened with a ``key``: naming the first line that was edited or made with other
        inputs.
    """

    def __init__(self, path: str | Path, *, key: str | None = None):
        self.path = Path(path)
        self.key = key
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.results: dict[int, dict] = {}
        good = 0
        if self.path.is_file():
            data = self.path.read_bytes()
            offset = 0
            for line in data.splitlines(keepends=True):
                if not line.endswith(b"\n"):
                    break  # cut short: dropped below
                try:
                    record = loads_json(line)
                except json.JSONDecodeError:
                    break
                if key is not None:
                    self._check(record, len(self.results) + 1)
                self.results[int(record["task"])] = record["result"]
                offset += len(line)
                good = offset
            if good < len(data):
                with self.path.open("r+b") as handle:
                    handle.truncate(good)
        self._handle = self.path.open("ab")

    @staticmethod
    def _checksum(record: dict) -> str:
        body = {k: record.get(k) for k in ("task", "result", "run")}
        text = json.dumps(body, sort_keys=True, allow_nan=True)
        return hashlib.sha256(text.encode()).hexdigest()

    def _check(self, record: dict, number: int) -> None:
        if not isinstance(record, dict) or "sha256" not in record:
            return  # a line of a log written before lines had checksums
        if record["sha256"] != self._checksum(record):
            raise ValueError(
                f"{self.path}, line {number}: edited after it was written (its checksum "
                "differs); delete the folder to start again"
            )
        if record.get("run") != self.key:
            raise ValueError(
                f"{self.path}, line {number}: made with other inputs than this run's (run.json "
                "edited?); give another --out, or delete it to start again"
            )

    def __contains__(self, task: int) -> bool:
        return task in self.results

    def add(self, task: int, result: dict) -> None:
        """Write a finished task's result (flushed and fsync'ed before returning).

        Parameters
        ----------
        task
            The task's number.
        result
            Its result, JSON-serialisable (NaN allowed).
        """
        record = {"task": task, "result": result}
        if self.key is not None:
            record["run"] = self.key
            record["sha256"] = self._checksum(json.loads(json.dumps(record)))
        # a replication's test that could not be computed (p = NaN: every rating at the
        # midpoint, say) is kept as NaN, which Python's json writes and reads back; it counts as
        # no rejection when the power is taken
        line = json.dumps(record, sort_keys=True)
        self._handle.write(line.encode() + b"\n")
        self._handle.flush()
        os.fsync(self._handle.fileno())
        self.results[task] = json.loads(line)["result"]  # as a resumed run reads it

    def sorted(self, tasks: Iterable[int] | None = None) -> list[dict]:
        """The results of ``tasks`` (default: all) in task order.

        Parameters
        ----------
        tasks
            The task numbers wanted; those not finished are left out. Default None: every
            finished task.

        Returns
        -------
        list of dict
            Their results, as read back from the log.
        """
        keys = sorted(self.results if tasks is None else set(tasks) & set(self.results))
        return [self.results[k] for k in keys]

    def close(self) -> None:
        self._handle.close()

    def __enter__(self) -> ResultLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# the time left is estimated from the tasks finished after the first: at least this many, over
# at least this long (workers that started together finish their first tasks together)
ETA_AFTER_TASKS = 2
ETA_AFTER_S = 1.0


class Progress:
    """A one-line progress bar on stderr: tasks done, rate and the estimated time left (from
    the tasks finished in this run).

    Parameters
    ----------
    total
        Tasks in the whole run.
    done
        Tasks already finished before this run (a resumed run).
    what
        What a task is, plural ("replications").
    stream
        Default stderr.
    """

    def __init__(self, total: int, *, done: int = 0, what: str = "tasks", stream=None):
        self.total, self.done, self.what = total, done, what
        self.before = done
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.first: tuple[float, int] | None = None  # when the first task of this run ended
        self.show()

    def update(self, count: int = 1) -> None:
        """Count tasks finished and redraw the bar.

        Parameters
        ----------
        count
            Tasks finished since the last update; default 1.
        """
        self.done += count
        if self.first is None:
            self.first = (time.perf_counter(), self.done)
        self.show()

    def line(self) -> str:
        width = 30
        filled = round(width * self.done / self.total) if self.total else width
        elapsed = time.perf_counter() - self.start
        new = self.done - self.before
        parts = [f"[{'#' * filled}{'-' * (width - filled)}] {self.done}/{self.total} {self.what}"]
        if new and elapsed > 0 and self.done < self.total:
            # only from the tasks finished after the first: the time before it is the
            # workers' start-up and set-up (seconds to minutes), which the remaining tasks do
            # not pay again, so a rate over it promises hours for a run of minutes
            since = time.perf_counter() - self.first[0] if self.first is not None else 0.0
            after = self.done - self.first[1] if self.first is not None else 0
            if after >= ETA_AFTER_TASKS and since >= ETA_AFTER_S:
                rate = after / since
                left = (self.total - self.done) / rate
                parts.append(f"{rate:.3g}/s, {_duration(left)} left")
            else:
                parts.append("time left: estimating")
        elif new and elapsed > 0:
            parts.append(f"{new / elapsed:.3g}/s")
        return ", ".join(parts)

    def show(self) -> None:
        end = "\n" if self.done >= self.total else ""
        print(f"\r{self.line():<90}", end=end, file=self.stream, flush=True)


def _duration(seconds: float) -> str:
    """``1h02m``, ``3m05s`` or ``12s``.

    Examples
    --------
    >>> _duration(3725), _duration(185), _duration(12.4)
    ('1h02m', '3m05s', '12s')
    """
    seconds = round(seconds)
    if seconds >= 3600:
        return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"
    if seconds >= 60:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds}s"


@contextlib.contextmanager
def _workers_ignore_ctrl_c() -> Iterator[None]:
    """While the cluster's processes start, SIGINT is ignored, which they inherit: Ctrl-C
    (sent to the terminal's whole process group) then stops this process alone, which closes
    the cluster, instead of printing each worker's traceback. Restored when they run."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def dask_client(*, workers: int | None = None, scheduler: str | None = None) -> Iterator:
    """A :class:`distributed.Client`: of the scheduler at ``scheduler`` (an address such as
    ``tcp://10.0.0.5:8786``), or of a new :class:`distributed.LocalCluster` of ``workers``
    single-threaded worker processes (default: one per core), closed on exit.

    Parameters
    ----------
    workers
        Worker processes of a local cluster, >= 1; default None: one per available core.
    scheduler
        The address of a running scheduler to connect to instead; default None.

    Yields
    ------
    distributed.Client
        The client; closed, with its local cluster, when the block ends.

    Raises
    ------
    ValueError
        For both ``workers`` and ``scheduler``, or ``workers`` < 1.
    OSError
        If no scheduler answers at ``scheduler`` (within 30 s).
    """
    from distributed import Client, LocalCluster

    if scheduler is not None and workers is not None:
        raise ValueError("give the number of workers or a scheduler's address, not both")
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be >= 1; got {workers!r}")
    if scheduler is not None:
        client = Client(scheduler, timeout="30s")
        try:
            yield client
        finally:
            client.close()
        return
    with _workers_ignore_ctrl_c():  # the worker processes start here
        cluster = LocalCluster(
            n_workers=workers or available_cores(),
            threads_per_worker=1,
            processes=True,
            # the scheduler's HTTP server (health, metrics; the dashboard where bokeh is
            # installed) runs whatever this says: on a free port, two runs at once do not
            # fight over Dask's default 8787
            dashboard_address=":0",
            # a task's error reaches this process as its exception; what a worker logs at
            # ERROR is its lost scheduler as the cluster closes (Ctrl-C), a traceback a person
            # need not read
            silence_logs=logging.CRITICAL,
        )
    with cluster, Client(cluster) as client:
        yield client


class JobPlugin(WorkerPlugin):
    """Holds a job on each worker for its tasks (Dask's place for per-worker state).

    Parameters
    ----------
    job
        The job whose ``run(task)`` the worker's tasks call; it is pickled to each worker once.
    name
        The plugin's name on the workers, which the tasks look the job up by.
    """

    def __init__(self, job, name: str):
        self.job = job
        self.name = name


def _run_on_worker(name: str, task: int) -> dict:
    from distributed import get_worker

    return get_worker().plugins[name].job.run(task)


def run_tasks(
    job,
    tasks: Iterable[int],
    log: ResultLog,
    *,
    client=None,
    what: str = "tasks",
    progress: Callable[..., Progress] | None = Progress,
) -> None:
    """Run the tasks not yet in ``log`` and add each result to it as it finishes.

    Parameters
    ----------
    job
        Has ``run(task) -> dict`` (JSON-serialisable) and pickles.
    tasks
        Task numbers.
    log
        Where results go; tasks already in it are not run again.
    client
        A :class:`distributed.Client` (:func:`dask_client`), or None to run the tasks here,
        one after the other (no Dask).
    what, progress
        The progress bar (None for none) and what it counts.

    Raises
    ------
    Exception
        The first task's error (the results before it are kept).
    """
    tasks = list(tasks)
    todo = [t for t in tasks if t not in log]
    bar = progress(len(tasks), done=len(tasks) - len(todo), what=what) if progress else None
    if client is None:
        for task in todo:
            log.add(task, job.run(task))
            if bar:
                bar.update()
        return
    from distributed import as_completed

    name = f"glarelab-{getattr(job, 'kind', 'job')}-{uuid.uuid4().hex[:12]}"
    client.register_plugin(JobPlugin(job, name), name=name)
    try:
        futures = {
            client.submit(_run_on_worker, name, task, key=f"{name}-{task}", pure=False): task
            for task in todo
        }
        try:
            for future in as_completed(futures):
                log.add(futures[future], future.result())
                if bar:
                    bar.update()
        finally:
            client.cancel(list(futures))
    finally:
        with contextlib.suppress(Exception):
            client.unregister_worker_plugin(name)
