"""Resumable sweep execution: local worker processes or dask, recorded as results arrive.

A sweep is planned (:func:`~scenarios.execution.planning.plan`: each expanded
scenario gets its content hash), the hashes already finished in the store are
skipped, and the rest are run by :func:`~scenarios.execution.sandbox.execute` -- in
worker processes forked from the driver (one
:class:`~scenarios.execution.sandbox.Sandbox` per worker, fed by the driver, no
cluster to start: :mod:`scenarios.execution.workers`) or on an existing dask
scheduler. Results
are recorded by the driver in completion order, one commit each.

Scenarios are taken from the plan in chunks (registered, checked against the
store and claimed chunk by chunk), so a generator from
:func:`~scenarios.execution.planning.iter_plan` is never held in memory whole. A scenario is
claimed in the store before it runs:
one another live driver is running is left to it and waited for, so two
drivers on one store run each scenario once and both return when the sweep is
done. :func:`~scenarios.execution.sandbox.execute` turns any exception of the task
into a ``failed`` outcome with its traceback, so one bad scenario never stops a sweep; a lost
worker is
recorded the same way.

Tasks are importable callables ``task(scenario) -> ResultRow`` given as a
callable or as ``"package.module:function"``; the default is
:func:`scenarios.runners.dispatch.run_scenario`.
"""

from __future__ import annotations

import itertools
import math
import os
import socket
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from scenarios.execution.interrupt import Interrupted, raise_on_stop
from scenarios.execution.planning import (  # noqa: F401  (the sweep's public names)
    DEFAULT_TASK,
    PlannedScenario,
    SweepError,
    Task,
    iter_plan,
    plan,
    resolve_task,
    task_name,
)
from scenarios.execution.progress import Progress
from scenarios.execution.sandbox import (  # noqa: F401  (the sweep's public names)
    Sandbox,
    execute,
    execute_limited,
    failed_outcome,
    split_result,
)
from scenarios.execution.workers import outcomes
from scenarios.plugins import load_plugins
from scenarios.runners.dispatch import require_runners
from scenarios.schema import DEFAULT_TIME_LIMIT_S
from scenarios.store import Outcome, ResultStore, package_version


@dataclass(frozen=True)
class SweepSummary:
    """Counts and timing of one :func:`run_sweep` call.

    Attributes
    ----------
    total : int
        Scenarios in the sweep.
    skipped : int
        Already finished in the store, not run again.
    ok, failed : int
        Outcomes of the scenarios run by this call.
    elapsed_s : float
        Wall time of the execution phase, s (cluster start included).
    """

    total: int
    skipped: int
    ok: int
    failed: int
    elapsed_s: float

    @property
    def rate_per_min(self) -> float:
        """Scenarios run per minute of wall time."""
        ran = self.ok + self.failed
        return 60.0 * ran / self.elapsed_s if self.elapsed_s > 0 else math.nan


@dataclass(frozen=True)
class SweepExecution:
    """How and where :func:`run_sweep` runs the scenarios.

    Attributes
    ----------
    task : str or callable
        ``task(scenario) -> ResultRow``; default :func:`scenarios.runners.dispatch.run_scenario`.
    workers : int
        Worker processes, forked from the driver after the task's modules are imported.
    scheduler : str, optional
        Address of an existing dask scheduler (``workers`` is then ignored).
    time_limit_s : float or None
        Wall-time limit of one scenario, s (``None``: none).
    plugins : sequence of str
        Plugin modules the scenarios need (:func:`scenarios.plugins.load_plugins`),
        loaded by the driver before workers fork and by every dask worker.
    poll_s : float
        How often to look at scenarios another driver is running, s.
    """

    task: Task = DEFAULT_TASK
    workers: int = 1
    scheduler: str | None = None
    time_limit_s: float | None = DEFAULT_TIME_LIMIT_S
    plugins: Sequence[str] = ()
    poll_s: float = 0.25


def pending(
    planned: Iterable[PlannedScenario], store: ResultStore, *, retry_failed: bool = False
) -> list[PlannedScenario]:
    """The planned scenarios not finished in ``store`` (failed ones too if ``retry_failed``)."""
    out: list[PlannedScenario] = []
    for chunk in _chunks(planned, _CHUNK):
        stored = store.statuses(p.hash for p in chunk)
        keep = ("failed",) if retry_failed else ()
        out.extend(p for p in chunk if p.hash not in stored or stored[p.hash] in keep)
    return out


def count_pending(
    planned: Iterable[PlannedScenario], store: ResultStore, *, retry_failed: bool = False
) -> tuple[int, int]:
    """``(total, pending)`` of a stream of planned scenarios, holding one chunk at a time."""
    total = todo = 0
    for chunk in _chunks(planned, _CHUNK):
        total += len(chunk)
        todo += len(pending(chunk, store, retry_failed=retry_failed))
    return total, todo


_CHUNK = 1024


def _chunks(items: Iterable[Any], size: int) -> Iterator[list[Any]]:
    it = iter(items)
    while chunk := list(itertools.islice(it, size)):
        yield chunk


def _owner() -> str:
    return f"{socket.gethostname()}:{os.getpid()}:{os.urandom(4).hex()}"


def run_sweep(
    planned: Iterable[PlannedScenario],
    store: ResultStore,
    execution: SweepExecution = SweepExecution(),
    *,
    sweep_name: str = "sweep",
    retry_failed: bool = False,
    progress: Progress | bool = True,
    version: str | None = None,
    total: int | None = None,
) -> SweepSummary:
    """Run the unfinished scenarios of a planned sweep and record each outcome.

    Scenarios are registered, checked against the store and claimed chunk by
    chunk (see the module notes). Each runs in a child process
    (:class:`~scenarios.execution.sandbox.Sandbox`) on the driver or on a dask worker, and
    is a ``timeout`` failure after ``execution.time_limit_s``.

    Parameters
    ----------
    planned : iterable of PlannedScenario
        From ``plan`` or ``iter_plan`` (:mod:`scenarios.execution.planning`), same task.
    store : ResultStore
        Where outcomes are recorded (by this process only).
    execution : SweepExecution
        The task, the workers or dask scheduler, the time limit, the plugins (default:
        :func:`scenarios.runners.dispatch.run_scenario` on one local worker).
    sweep_name : str
        Name under which the scenarios are registered in the store.
    retry_failed : bool
        Run scenarios stored as failed again.
    progress : Progress or bool
        Progress bar (``True``: on stderr; ``False``: none).
    version : str, optional
        Package version recorded with each row (default: installed).
    total : int, optional
        Scenarios in an iterator ``planned`` (for the bar); default ``len(planned)``.

    Returns
    -------
    SweepSummary

    Raises
    ------
    SweepError
        ``workers < 1`` or a task that cannot be named.
    scenarios.execution.interrupt.Interrupted
        SIGINT or SIGTERM arrived (in the main thread): the running scenarios
        are stopped, nothing is recorded for them and the claims are released,
        so the next run of the sweep runs them.
    scenarios.runners.dispatch.RunnerUnavailableError
        The default task has no runner for a kind in the sweep.
    """
    task, workers, scheduler = execution.task, execution.workers, execution.scheduler
    time_limit_s = execution.time_limit_s
    if workers < 1:
        raise SweepError(f"workers must be >= 1 (found {workers})")
    if time_limit_s is not None and not time_limit_s > 0:
        raise SweepError(f"time_limit_s must be > 0 (found {time_limit_s})")
    plugins = load_plugins(execution.plugins)
    if total is None:
        total = len(planned) if isinstance(planned, Sequence) else 0
    bar = progress if isinstance(progress, Progress) else None
    if progress is True:
        bar = Progress(total, sweep_name)
    run = _SweepRun(store, task_name(task), package_version() if version is None else version,
                    sweep_name, retry_failed, total, time_limit_s, bar)

    def execute_all(todo: Iterable[PlannedScenario]) -> None:
        for p, outcome in outcomes(todo, task, workers, scheduler, time_limit_s, plugins):
            run.record(p, outcome)

    t0 = time.perf_counter()
    with raise_on_stop() as stop:
        run.stopping = stop
        try:
            execute_all(run.stream(planned))
            while run.busy:  # run by another driver: wait for its rows, or take over its claims
                time.sleep(execution.poll_s)
                execute_all(run.claimed(run.taken_over()))
        finally:
            store.release_claims(run.owner)
            if bar is not None:
                bar.close()
    c = run.counts
    return SweepSummary(max(total, c["seen"]), c["skipped"], c["ok"], c["failed"],
                        time.perf_counter() - t0)


class _SweepRun:
    """The driver's bookkeeping of one :func:`run_sweep` call: claims, records, counts."""

    def __init__(self, store: ResultStore, task: str, version: str, sweep_name: str,
                 retry_failed: bool, total: int, time_limit_s: float | None,
                 bar: Progress | None) -> None:
        self.store, self.task, self.version = store, task, version
        self.sweep_name, self.retry_failed, self.total, self.bar = (
            sweep_name, retry_failed, total, bar)
        self.owner = _owner()
        self.lease_s = 24 * 3600.0 if time_limit_s is None else 2 * time_limit_s + 60.0
        self.counts = {"ok": 0, "failed": 0, "seen": 0, "skipped": 0}
        self.busy: list[PlannedScenario] = []
        self.stopping: Any = None

    def record(self, p: PlannedScenario, outcome: Outcome) -> None:
        """Store one outcome (a failure caused by a stop is not stored: it runs again later)."""
        if self.stopping and outcome.status == "failed":
            raise Interrupted(self.stopping.signum)
        self.store.record(outcome, kind=p.scenario.kind, config_json=p.config_json,
                          task=self.task, version=self.version)
        self.store.renew_claims(self.owner, self.lease_s)
        self.counts[outcome.status] += 1
        if self.bar is not None:
            self.bar.update(outcome.status)

    def claimed(self, items: Iterable[PlannedScenario]) -> Iterator[PlannedScenario]:
        """The scenarios this driver claims; others' go to :attr:`busy`, orphans are failed."""
        for p in items:
            state = self.store.claim(p.hash, self.owner, self.lease_s,
                                     retry_failed=self.retry_failed)
            if state == "run":
                yield p
            elif state == "busy":
                self.busy.append(p)
            elif state == "orphaned":
                self.record(p, failed_outcome(p.hash, "killed: its driver process died twice while "
                                       "running it (not run again)", time.time(), 0.0, ""))
            else:
                self.counts["skipped"] += 1
                _untally(self.bar)

    def stream(self, planned: Iterable[PlannedScenario]) -> Iterator[PlannedScenario]:
        """Register the sweep's members chunk by chunk and claim the unfinished ones."""
        for chunk in _chunks(planned, _CHUNK):
            self.counts["seen"] += len(chunk)
            self.store.add_members(self.sweep_name,
                                   ((p.hash, p.index, p.overrides) for p in chunk))
            todo = pending(chunk, self.store, retry_failed=self.retry_failed)
            self.counts["skipped"] += len(chunk) - len(todo)
            if self.bar is not None and not self.total:
                self.bar.total += len(todo)
            elif self.bar is not None:
                self.bar.total -= len(chunk) - len(todo)
            if self.task == DEFAULT_TASK:
                require_runners({p.scenario.kind for p in todo})
            yield from self.claimed(todo)

    def taken_over(self) -> list[PlannedScenario]:
        """Scenarios another driver held: those it finished are skipped, the rest returned."""
        waiting, self.busy = self.busy, []
        stored = self.store.statuses(p.hash for p in waiting)
        mine = [p for p in waiting if p.hash not in stored]
        self.counts["skipped"] += len(waiting) - len(mine)
        for _ in range(len(waiting) - len(mine)):
            _untally(self.bar)
        return mine


def _untally(bar: Progress | None) -> None:
    if bar is not None:
        bar.total -= 1
