"""Where a sweep's scenarios run: worker processes forked from the driver, or Dask.

:func:`local_outcomes` feeds one :class:`~scenarios.execution.sandbox.Sandbox`
per worker from the driver's main thread (no cluster to start); scenarios of
one design group (:func:`design_group`) go to the worker that holds it.
:func:`dask_outcomes` submits them to an existing Dask scheduler, whose
workers load the sweep's plugins before their first scenario.
"""

from __future__ import annotations

import gc
import itertools
import json
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from scenarios.execution.planning import PlannedScenario, SweepError, Task, resolve_task
from scenarios.execution.sandbox import (
    Sandbox,
    SandboxCrashed,
    execute_limited,
    killed_twice,
    lost_worker,
)
from scenarios.plugins import load_plugins
from scenarios.schema import Scenario
from scenarios.store import Outcome


def design_group(scenario: Scenario) -> str:
    """What a worker can reuse between scenarios: the object and the control rate (JSON).

    Scenarios of one group share the object's plant family (linearized over the
    force grid at the control period), which a worker keeps in memory once it
    has built or loaded it, with the controller designs made on it.
    """
    return json.dumps([scenario.kind, scenario.object.model_dump(mode="json"),
                       scenario.controller.control_hz], sort_keys=True)


class _Lookahead:
    """The next few scenarios of a stream, handed out so that workers keep their groups.

    A worker gets the next scenario of the group it ran last; else the first
    scenario of a group no other worker holds; else the first one. Only
    ``size`` scenarios are taken (and claimed) from the stream ahead of time.
    """

    def __init__(self, items: Iterator[PlannedScenario], size: int,
                 group: Callable[[Scenario], str]) -> None:
        self._items = items
        self._size = size
        self._group = group
        self._buffer: list[tuple[str, PlannedScenario]] = []

    def take(self, prefer: str | None, held: set[str]) -> tuple[str, PlannedScenario] | None:
        """The next scenario for a worker whose last group was ``prefer``, and its group."""
        while len(self._buffer) < self._size:
            p = next(self._items, None)
            if p is None:
                break
            self._buffer.append((self._group(p.scenario), p))
        if not self._buffer:
            return None
        pick = next((i for i, (g, _) in enumerate(self._buffer) if g == prefer), None)
        if pick is None:
            pick = next((i for i, (g, _) in enumerate(self._buffer) if g not in held), 0)
        return self._buffer.pop(pick)


def local_outcomes(
    todo: Iterable[PlannedScenario], task: Task, workers: int, time_limit_s: float | None,
    *, group: Callable[[Scenario], str] = design_group, lookahead: int = 8,
) -> Iterator[tuple[PlannedScenario, Outcome]]:
    """Run scenarios on ``workers`` sandbox processes forked from this one, as they finish.

    The driver's main thread feeds every :class:`~scenarios.execution.sandbox.Sandbox` (no dask
    cluster to
    start or stop): each child is forked from the driver, which has already
    imported the task's modules, so a worker starts in milliseconds and shares
    those modules' memory with the driver and the other workers. A worker keeps
    its child (and the plant families and designs it holds) from one scenario
    to the next and is handed scenarios of the group it ran last
    (:func:`design_group`), so two workers do not build one object's plants. A
    scenario past ``time_limit_s`` is a ``timeout`` failure; one whose child
    dies is run once more in a fresh child, then recorded as ``killed``.
    Stopping the generator (or an exception in it, e.g. Ctrl-C) kills every child.

    Yields
    ------
    (PlannedScenario, Outcome)
        In completion order.
    """
    from multiprocessing.connection import wait

    # several workers: one BLAS thread each, so they do not oversubscribe the cores
    boxes = [Sandbox(blas_threads=1 if workers > 1 else None) for _ in range(workers)]
    last: list[str | None] = [None] * workers
    running: dict[int, tuple[PlannedScenario, list[str], float]] = {}
    queue = _Lookahead(iter(todo), max(lookahead * workers, 1), group)
    try:
        while True:
            for i, box in enumerate(boxes):
                if i in running:
                    continue
                held = {last[j] for j in range(workers) if j != i and last[j] is not None}
                taken = queue.take(last[i], held)
                if taken is None:
                    break
                last[i], p = taken
                box.submit(task, p.scenario, p.hash, time_limit_s)
                running[i] = (p, [], time.time())
            if not running:
                return
            timeout = None
            if time_limit_s is not None:
                soonest = min(boxes[i].deadline for i in running)
                timeout = max(0.0, soonest - time.perf_counter())
            ready = wait([boxes[i].connection for i in running], timeout)
            for i in sorted(running):
                box = boxes[i]
                p, reasons, started = running[i]
                if box.connection in ready:
                    try:
                        outcome = box.collect()
                    except SandboxCrashed as exc:
                        reasons.append(str(exc))
                        if len(reasons) < 2:
                            box.submit(task, p.scenario, p.hash, time_limit_s)
                            continue
                        outcome = killed_twice(p.hash, reasons, started)
                elif time.perf_counter() >= box.deadline:
                    outcome = box.time_out(time_limit_s)
                else:
                    continue
                del running[i]
                yield p, outcome
    finally:
        for box in boxes:
            box.close()


def execute_with_plugins(plugins: Sequence[str], task: Task, scenario: Scenario, hash_: str,
                         time_limit_s: float | None) -> Outcome:
    """:func:`~scenarios.execution.sandbox.execute_limited` after loading ``plugins`` (on a dask
    worker; once per process)."""
    load_plugins(plugins)
    return execute_limited(task, scenario, hash_, time_limit_s)


def outcomes(
    todo: Iterable[PlannedScenario], task: Task, workers: int, scheduler: str | None,
    time_limit_s: float | None, plugins: Sequence[str] = (),
) -> Iterator[tuple[PlannedScenario, Outcome]]:
    """``(scenario, outcome)`` in completion order, on local workers or a Dask scheduler.

    The task is resolved in the driver first, so a bad reference fails once,
    before any worker starts.
    """
    items = iter(todo)
    first = next(items, None)
    if first is None:
        return
    items = itertools.chain([first], items)
    if isinstance(task, str):
        resolve_task(task)
    if scheduler is None:
        yield from local_outcomes(items, task, workers, time_limit_s)
    else:
        yield from dask_outcomes(items, task, scheduler, workers, time_limit_s, plugins)


def dask_outcomes(
    items: Iterator[PlannedScenario], task: Task, scheduler: str, workers: int,
    time_limit_s: float | None, plugins: Sequence[str] = (),
) -> Iterator[tuple[PlannedScenario, Outcome]]:
    """Run scenarios on an existing Dask scheduler, a bounded window at a time.

    Each runs in the worker's own :class:`~scenarios.execution.sandbox.Sandbox`
    after the sweep's ``plugins`` are loaded there (:func:`execute_with_plugins`).
    A worker that dies or a task that cannot be shipped is a failed outcome.
    """
    from distributed import as_completed

    with _client(scheduler) as client:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})) or workers)
        futures: dict[Any, PlannedScenario] = {}
        queue = as_completed()

        def submit() -> bool:
            p = next(items, None)
            if p is None:
                return False
            future = client.submit(
                execute_with_plugins, tuple(plugins), task, p.scenario, p.hash, time_limit_s,
                pure=False)
            futures[future] = p
            queue.add(future)
            return True

        for _ in range(2 * n_workers):  # a bounded window: scenarios stream to the workers
            if not submit():
                break
        for future in queue:
            p = futures.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # the worker died or the task could not be shipped
                outcome = lost_worker(p, exc)
            future.release()
            yield p, outcome
            submit()


@contextmanager
def _client(scheduler: str) -> Iterator[Any]:
    """A dask client on an existing scheduler."""
    from distributed import Client

    # A half-built Client from an earlier failed connection closes itself in __del__;
    # if the garbage collector runs that inside a new client's IO-loop thread, the
    # loop never starts (distributed waits 10 s, then fails). Collect it here first.
    gc.collect()
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise SweepError(f"cannot connect to dask scheduler {scheduler} ({exc})") from None
    with client:
        yield client
