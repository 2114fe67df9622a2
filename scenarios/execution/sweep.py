"""Resumable sweep execution: local worker processes or dask, recorded as results arrive.

A sweep is planned (:func:`plan`: each expanded scenario gets its content
hash), the hashes already finished in the store are skipped, and the rest are
run by :func:`execute` -- in worker processes forked from the driver
(:func:`local_outcomes`: one :class:`Sandbox` per worker, fed by the driver, no
cluster to start) or on an existing dask scheduler given by address. Results
are recorded by the driver in completion order, one commit each.
:func:`execute` turns any exception of the task into a ``failed`` outcome with
its traceback, so one bad scenario never stops a sweep; a lost worker is
recorded the same way.

Tasks are importable callables ``task(scenario) -> ResultRow`` given as a
callable or as ``"package.module:function"``; the default is
:func:`scenarios.runners.dispatch.run_scenario`.
"""

from __future__ import annotations

import gc
import itertools
import json
import math
import os
import signal
import socket
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TextIO

import numpy as np

from scenarios.execution.interrupt import Interrupted, raise_on_stop
from scenarios.plugins import load_plugins
from scenarios.runners.dispatch import require_runners
from scenarios.schema import DEFAULT_TIME_LIMIT_S, ExpandedScenario, Scenario
from scenarios.store import Outcome, ResultStore, content_hash, encode_traces, package_version
from sim.errors import GriploopError
from sim.registry import UnresolvableEntryError, import_reference

DEFAULT_TASK = "scenarios.runners.dispatch:run_scenario"
Task = str | Callable[[Scenario], Mapping[str, Any]]
_SCALARS = (bool, int, float, str, type(None))


class SweepError(GriploopError, ValueError):
    """A sweep cannot run as asked (bad task reference, worker count, options)."""


@dataclass(frozen=True)
class PlannedScenario:
    """An expanded scenario with its store key.

    Attributes
    ----------
    hash : str
        :func:`scenarios.store.content_hash` of config, version and task.
    index : int
        Position in the sweep.
    scenario : Scenario
        The scenario (seed set).
    config_json : str
        Its canonical JSON.
    overrides : dict
        Design values of this point.
    """

    hash: str
    index: int
    scenario: Scenario
    config_json: str
    overrides: dict[str, Any]


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


def task_name(task: Task) -> str:
    """``"package.module:function"`` of a task (part of every content hash).

    Raises
    ------
    SweepError
        A callable that cannot be imported by name (lambda, nested function).
    """
    if isinstance(task, str):
        if task.count(":") != 1 or not all(task.split(":")):
            raise SweepError(f"task must be 'package.module:function' (found {task!r})")
        return task
    module, qualname = getattr(task, "__module__", None), getattr(task, "__qualname__", "")
    if not module or "<" in qualname:
        raise SweepError(f"task must be an importable module-level function (found {task!r})")
    return f"{module}:{qualname}"


def resolve_task(task: Task) -> Callable[[Scenario], Mapping[str, Any]]:
    """The callable behind a task reference.

    Raises
    ------
    SweepError
        The module cannot be imported or has no such callable.
    """
    if not isinstance(task, str):
        return task
    try:
        return import_reference(task_name(task))
    except UnresolvableEntryError as exc:
        raise SweepError(f"task {task!r}: {exc}") from None


def plan(
    expanded: Iterable[ExpandedScenario], task: Task = DEFAULT_TASK, version: str | None = None
) -> list[PlannedScenario]:
    """Attach content hashes to expanded scenarios.

    Raises
    ------
    SweepError
        Two scenarios have the same hash (the expansion produced duplicates).
    """
    return list(iter_plan(expanded, task, version))


def iter_plan(
    expanded: Iterable[ExpandedScenario], task: Task = DEFAULT_TASK, version: str | None = None
) -> Iterator[PlannedScenario]:
    """:func:`plan` one scenario at a time (the task is named eagerly)."""
    name = task_name(task)
    version = package_version() if version is None else version
    return _iter_plan(expanded, name, version)


def _iter_plan(
    expanded: Iterable[ExpandedScenario], name: str, version: str
) -> Iterator[PlannedScenario]:
    seen: dict[str, int] = {}
    for item in expanded:
        config = item.scenario.canonical_json()
        key = content_hash(config, version, name)
        if key in seen:
            raise SweepError(
                f"scenarios {seen[key]} and {item.index} are identical "
                "(expected distinct scenarios)"
            )
        seen[key] = item.index
        yield PlannedScenario(key, item.index, item.scenario, config, dict(item.overrides))


def split_result(raw: Any) -> tuple[dict[str, Any], bytes | None]:
    """Validate a task's return value and split it into scalars and encoded traces.

    Numpy scalars become Python scalars. Raises ``TypeError`` for anything
    that is not a flat mapping of scalars with optional ``"traces"``.
    """
    if not isinstance(raw, Mapping):
        raise TypeError(f"a task must return a mapping (found {type(raw).__name__})")
    scalars: dict[str, Any] = {}
    traces = None
    for key, value in raw.items():
        if not isinstance(key, str):
            raise TypeError(f"result keys must be str (found {key!r})")
        if key == "traces":
            traces = encode_traces(value) if value else None
            continue
        if isinstance(value, np.generic):
            value = value.item()
        if not isinstance(value, _SCALARS):
            raise TypeError(
                f"result {key!r} must be a scalar (found {type(value).__name__}); "
                "put arrays under 'traces'"
            )
        scalars[key] = value
    return scalars, traces


def execute(task: Task, scenario: Scenario, hash_: str) -> Outcome:
    """Run one scenario and return its outcome; never raises for a failing task.

    Runs in a worker process (or the driver for one worker). Exceptions of the
    task, and invalid return values, give a ``failed`` outcome with
    ``"Type: message"`` and the formatted traceback.
    """
    started = time.time()
    t0 = time.perf_counter()
    try:
        result, traces = split_result(resolve_task(task)(scenario))
        status, error, trace_text = "ok", None, None
    except Exception as exc:  # every task error becomes a failed row
        result, traces, status = {}, None, "failed"
        error = _one_line(exc)
        trace_text = traceback.format_exc()
    duration = time.perf_counter() - t0
    return Outcome(
        hash=hash_,
        status=status,
        result=result,
        traces=traces,
        error=error,
        traceback=trace_text,
        started_at=started,
        finished_at=started + duration,
        duration_s=duration,
        worker=f"{socket.gethostname()}:{os.getpid()}",
    )


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _lost(p: PlannedScenario, exc: BaseException) -> Outcome:
    return _failed(p.hash, f"worker lost: {_one_line(exc)}", time.time(), 0.0, "",
                   trace_text="".join(traceback.format_exception(exc)))


def _failed(hash_: str, error: str, started: float, duration: float, worker: str, *,
            trace_text: str | None = None) -> Outcome:
    return Outcome(
        hash=hash_,
        status="failed",
        result={},
        traces=None,
        error=error,
        traceback=trace_text,
        started_at=started,
        finished_at=started + duration,
        duration_s=duration,
        worker=worker,
    )


class _Crashed(Exception):
    """The sandbox's child process died while running a scenario."""


class Sandbox:
    """A forked child process that runs tasks and can be stopped.

    The child is forked on first use and kept for the following scenarios
    (so caches warmed by one scenario serve the next, as in-process); a
    scenario past its time limit is stopped by killing the child, which is
    forked again for the next one. The child runs exactly the code the
    parent would, on a copy of its memory, so results are the same as
    in-process. The parent holds no simulation state.
    """

    def __init__(self) -> None:
        self._pid: int | None = None
        self._conn: Any = None
        self._started = self._t0 = 0.0
        self._deadline = math.inf
        self._worker = self._hash = ""

    def __enter__(self) -> Sandbox:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _start(self) -> None:
        import multiprocessing

        parent, child = multiprocessing.Pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        # The child shares the parent's imported modules page by page (copy on write);
        # frozen objects are never traversed by the child's garbage collector, so their
        # pages stay shared instead of being copied by the collector's bookkeeping.
        gc.freeze()
        pid = os.fork()
        if pid != 0:
            gc.unfreeze()
        if pid == 0:  # the child: serve tasks until the parent goes away
            code = 0
            try:
                parent.close()
                _shield_from_stop_signals()
                _die_with_parent()
                _serve(child)
            except BaseException:
                code = 1
            finally:
                os._exit(code)
        child.close()
        self._pid, self._conn = pid, parent

    def close(self) -> None:
        """Stop the child process."""
        if self._pid is None:
            return
        self._conn.close()
        self._kill()

    def _kill(self) -> int:
        pid, self._pid = self._pid, None
        try:  # its process group (pgid == pid): subprocesses the scenario started go too
            os.killpg(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass  # no such group yet (killed before setpgid) or already gone
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        _, status = os.waitpid(pid, 0)
        return os.waitstatus_to_exitcode(status)

    @property
    def connection(self) -> Any:
        """The parent's end of the pipe to the child (readable when a result is ready)."""
        return self._conn

    @property
    def deadline(self) -> float:
        """``time.perf_counter()`` value by which the running scenario must finish."""
        return self._deadline

    def submit(self, task: Task, scenario: Scenario, hash_: str,
               time_limit_s: float | None) -> None:
        """Send one scenario to the child (forked now if needed) without waiting for it.

        Its outcome is then read with :meth:`collect` once :attr:`connection` is
        readable, or the child is stopped with :meth:`time_out` past :attr:`deadline`.
        """
        if self._pid is None:
            self._start()
        self._started, self._t0 = time.time(), time.perf_counter()
        self._deadline = math.inf if time_limit_s is None else self._t0 + time_limit_s
        self._worker = f"{socket.gethostname()}:{self._pid}"
        self._hash = hash_
        try:
            self._conn.send((task, scenario, hash_))
        except OSError:
            pass  # the child is gone: the pipe reads as closed and collect() says so

    def collect(self) -> Outcome:
        """The outcome of the submitted scenario (blocks until the child answers).

        Raises
        ------
        _Crashed
            The child died (killed by a signal, or exited) during the scenario.
        """
        try:
            return self._conn.recv()
        except (EOFError, OSError):
            pass
        self._conn.close()
        code = self._kill()
        duration = time.perf_counter() - self._t0
        how = f"signal {-code} ({signal.Signals(-code).name})" if code < 0 else f"exit {code}"
        raise _Crashed(f"its process died ({how}) after {duration:.1f} s")

    def time_out(self, time_limit_s: float | None) -> Outcome:
        """Stop the child running an overdue scenario; its ``timeout`` failure."""
        self._conn.close()
        self._kill()
        return _failed(
            self._hash,
            f"timeout: still running after {time_limit_s:g} s (time_limit_s); stopped",
            self._started, time.perf_counter() - self._t0, self._worker,
        )

    def run(self, task: Task, scenario: Scenario, hash_: str,
            time_limit_s: float | None) -> Outcome:
        """Run one scenario in the child; a ``timeout`` failure past ``time_limit_s``.

        Raises
        ------
        _Crashed
            The child died (killed by a signal, or exited) during the scenario.
        """
        self.submit(task, scenario, hash_, time_limit_s)
        try:
            ready = self._conn.poll(time_limit_s)
        except (EOFError, OSError):
            ready = True
        return self.collect() if ready else self.time_out(time_limit_s)


def _serve(conn: Any) -> None:
    while True:
        try:
            task, scenario, hash_ = conn.recv()
        except EOFError:
            return
        conn.send(execute(task, scenario, hash_))


def _shield_from_stop_signals() -> None:
    """Keep Ctrl-C away from a sandbox child: the driver decides when it stops.

    The child leaves the terminal's foreground process group (Ctrl-C signals
    that group) and ignores SIGINT, so a solver inside a scenario (OSQP installs
    its own SIGINT handler) never sees the interrupt, never turns it into a
    failed scenario and never prints its matrices. SIGTERM gets its default
    action back (the driver's handler raises). The driver stops the child with
    SIGKILL; it also dies with its parent (:func:`_die_with_parent`).
    """
    try:
        os.setpgid(0, 0)
    except OSError:
        pass
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (no-op elsewhere)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


_SANDBOXES = threading.local()


def execute_limited(task: Task, scenario: Scenario, hash_: str,
                    time_limit_s: float | None) -> Outcome:
    """:func:`execute` in this thread's :class:`Sandbox`, stopped after ``time_limit_s``.

    A scenario whose process dies is run once more in a fresh process; if it
    dies again it is recorded as failed. Never raises for a failing task.
    One sandbox per thread: a dask worker with several threads runs several
    scenarios at once, and they must not share one child and its pipe.
    """
    box = getattr(_SANDBOXES, "box", None)
    if box is None:
        box = _SANDBOXES.box = Sandbox()
    return run_guarded(box, task, scenario, hash_, time_limit_s)


def run_guarded(box: Sandbox, task: Task, scenario: Scenario, hash_: str,
                time_limit_s: float | None) -> Outcome:
    """:meth:`Sandbox.run`, retried once if the process dies, then a failed outcome."""
    started = time.time()
    reasons = []
    for _ in range(2):
        try:
            return box.run(task, scenario, hash_, time_limit_s)
        except _Crashed as exc:
            reasons.append(str(exc))
    return _killed_twice(hash_, reasons, started)


class Progress:
    """Progress bar of a sweep (:mod:`tqdm`): done, failed, rate and ETA.

    On a terminal tqdm redraws the line in place at most every
    ``min_interval_s``; otherwise (a log file, CI) tqdm's line is printed
    whole every tenth of the sweep or every ``log_interval_s``, whichever comes
    first. ``total`` may change while the sweep runs (scenarios found stored or
    run by another driver are taken off).

    Parameters
    ----------
    total : int
        Scenarios to run (skipped ones excluded).
    label : str
        Prefix of the line (the sweep name).
    stream : text stream, optional
        Where to write; default ``sys.stderr``.
    """

    FORMAT = ("{desc} {percentage:3.0f}%|{bar:24}| {n_fmt}/{total_fmt} done{postfix} "
              "[{elapsed}<{remaining}, {rate_fmt}]")

    def __init__(
        self,
        total: int,
        label: str = "sweep",
        stream: TextIO | None = None,
        *,
        min_interval_s: float = 0.1,
        log_interval_s: float = 10.0,
    ) -> None:
        from tqdm import tqdm

        class _Bar(tqdm):  # no monitor thread: sandbox children are forked from this process
            monitor_interval = 0

        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.log_interval_s = log_interval_s
        self.failed = 0
        self._bar = _Bar(total=total, desc=label, file=self.stream, bar_format=self.FORMAT,
                         unit="scenario", mininterval=min_interval_s, ascii=not self.tty,
                         dynamic_ncols=self.tty, disable=False, leave=True,
                         postfix="0 failed", delay=0 if self.tty else float("inf"))
        self._last = time.perf_counter()
        self._last_done = 0

    @property
    def total(self) -> int:
        """Scenarios to run."""
        return int(self._bar.total or 0)

    @total.setter
    def total(self, value: int) -> None:
        self._bar.total = max(0, int(value))

    @property
    def done(self) -> int:
        """Scenarios finished so far."""
        return int(self._bar.n)

    def update(self, status: str) -> None:
        """Count one finished scenario and redraw if due."""
        self.failed += status == "failed"
        self._bar.set_postfix_str(f"{self.failed} failed", refresh=False)
        self._bar.update(1)
        if self.tty:
            return
        now = time.perf_counter()
        step = max(1, self.total // 10)
        if (self.done - self._last_done >= step or now - self._last >= self.log_interval_s
                or self.done >= self.total):
            self._last, self._last_done = now, self.done
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def line(self) -> str:
        """The current progress line (tqdm's meter)."""
        return str(self._bar)

    def close(self) -> None:
        """Finish the line."""
        self._bar.close()


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
    *,
    task: Task = DEFAULT_TASK,
    workers: int = 1,
    scheduler: str | None = None,
    sweep_name: str = "sweep",
    retry_failed: bool = False,
    progress: Progress | bool = True,
    version: str | None = None,
    time_limit_s: float | None = DEFAULT_TIME_LIMIT_S,
    total: int | None = None,
    poll_s: float = 0.25,
    plugins: Sequence[str] = (),
) -> SweepSummary:
    """Run the unfinished scenarios of a planned sweep and record each outcome.

    Scenarios are taken from ``planned`` in chunks (registered, checked
    against the store and claimed chunk by chunk), so a generator from
    :func:`iter_plan` is never held in memory whole. Each runs in a child
    process (:class:`Sandbox`) on the driver or on a dask worker, stopped and
    recorded as a ``timeout`` failure after ``time_limit_s``. A scenario is
    claimed in the store before it runs: a scenario another live driver is
    running is left to it and waited for, so two drivers on one store run
    each scenario once and both return when the sweep is done.

    Parameters
    ----------
    planned : iterable of PlannedScenario
        From :func:`plan` or :func:`iter_plan` with the same ``task``.
    store : ResultStore
        Where outcomes are recorded (by this process only).
    task : str or callable
        ``task(scenario) -> ResultRow``; default :func:`scenarios.runners.dispatch.run_scenario`.
    workers : int
        Number of worker processes, each a child of this one forked after the
        task's modules are imported (:func:`local_outcomes`).
    scheduler : str, optional
        Address of an existing dask scheduler (``workers`` is then ignored).
    sweep_name : str
        Name under which the scenarios are registered in the store.
    retry_failed : bool
        Run scenarios stored as failed again.
    progress : Progress or bool
        Progress bar (``True``: on stderr; ``False``: none).
    version : str, optional
        Package version recorded with each row; default the installed one.
    time_limit_s : float or None
        Wall-time limit of one scenario, s (``None``: none).
    total : int, optional
        Number of scenarios in ``planned`` when it is an iterator (for the
        progress bar); default ``len(planned)``.
    poll_s : float
        How often to look at scenarios another driver is running, s.
    plugins : sequence of str
        Plugin modules (:func:`scenarios.plugins.load_plugins`) the scenarios
        need: loaded here before the local workers are forked, and by every
        dask worker before its first scenario.

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
    if workers < 1:
        raise SweepError(f"workers must be >= 1 (found {workers})")
    plugins = load_plugins(plugins)
    if time_limit_s is not None and not time_limit_s > 0:
        raise SweepError(f"time_limit_s must be > 0 (found {time_limit_s})")
    name = task_name(task)
    version = package_version() if version is None else version
    if total is None:
        total = len(planned) if isinstance(planned, Sequence) else 0
    owner = _owner()
    lease_s = 24 * 3600.0 if time_limit_s is None else 2 * time_limit_s + 60.0
    bar = progress if isinstance(progress, Progress) else None
    if progress is True:
        bar = Progress(total, sweep_name)
    counts = {"ok": 0, "failed": 0, "seen": 0, "skipped": 0}
    busy: list[PlannedScenario] = []

    stopping: list[Any] = [None]

    def record(p: PlannedScenario, outcome: Outcome) -> None:
        if stopping[0] and outcome.status == "failed":
            raise Interrupted(stopping[0].signum)  # a casualty of the stop: run it again later
        store.record(
            outcome, kind=p.scenario.kind, config_json=p.config_json, task=name, version=version
        )
        store.renew_claims(owner, lease_s)
        counts[outcome.status] += 1
        if bar is not None:
            bar.update(outcome.status)

    def claimed(items: Iterable[PlannedScenario]) -> Iterator[PlannedScenario]:
        for p in items:
            state = store.claim(p.hash, owner, lease_s, retry_failed=retry_failed)
            if state == "run":
                yield p
            elif state == "busy":
                busy.append(p)
            elif state == "orphaned":
                now = time.time()
                record(p, _failed(p.hash, "killed: its driver process died twice while running "
                                  "it (not run again)", now, 0.0, ""))
            else:
                counts["skipped"] += 1
                _untally(bar)

    def stream() -> Iterator[PlannedScenario]:
        for chunk in _chunks(planned, _CHUNK):
            counts["seen"] += len(chunk)
            store.add_members(sweep_name, ((p.hash, p.index, p.overrides) for p in chunk))
            todo = pending(chunk, store, retry_failed=retry_failed)
            counts["skipped"] += len(chunk) - len(todo)
            if bar is not None and not total:
                bar.total += len(todo)
            elif bar is not None:
                bar.total -= len(chunk) - len(todo)
            if name == DEFAULT_TASK:
                require_runners({p.scenario.kind for p in todo})
            yield from claimed(todo)

    t0 = time.perf_counter()
    with raise_on_stop() as stop:
        stopping[0] = stop
        try:
            for p, outcome in _outcomes(stream(), task, workers, scheduler, time_limit_s,
                                         plugins):
                record(p, outcome)
            while busy:  # run by another driver: wait for its rows, or take over its claims
                time.sleep(poll_s)
                waiting, busy[:] = list(busy), []
                stored = store.statuses(p.hash for p in waiting)
                mine = [p for p in waiting if p.hash not in stored]  # others: done elsewhere
                counts["skipped"] += len(waiting) - len(mine)
                for _ in range(len(waiting) - len(mine)):
                    _untally(bar)
                for p, outcome in _outcomes(claimed(mine), task, workers, scheduler,
                                            time_limit_s, plugins):
                    record(p, outcome)
        finally:
            store.release_claims(owner)
            if bar is not None:
                bar.close()
    elapsed = time.perf_counter() - t0
    return SweepSummary(
        max(total, counts["seen"]), counts["skipped"], counts["ok"], counts["failed"], elapsed
    )


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

    The driver's main thread feeds every :class:`Sandbox` (no dask cluster to
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

    boxes = [Sandbox() for _ in range(workers)]
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
                    except _Crashed as exc:
                        reasons.append(str(exc))
                        if len(reasons) < 2:
                            box.submit(task, p.scenario, p.hash, time_limit_s)
                            continue
                        outcome = _killed_twice(p.hash, reasons, started)
                elif time.perf_counter() >= box.deadline:
                    outcome = box.time_out(time_limit_s)
                else:
                    continue
                del running[i]
                yield p, outcome
    finally:
        for box in boxes:
            box.close()


def _killed_twice(hash_: str, reasons: list[str], started: float) -> Outcome:
    return _failed(
        hash_,
        f"killed: the scenario killed its process twice ({'; '.join(reasons)})",
        started, time.time() - started, f"{socket.gethostname()}:{os.getpid()}",
    )


def _untally(bar: Progress | None) -> None:
    if bar is not None:
        bar.total -= 1


def execute_with_plugins(plugins: Sequence[str], task: Task, scenario: Scenario, hash_: str,
                         time_limit_s: float | None) -> Outcome:
    """:func:`execute_limited` after loading ``plugins`` (on a dask worker; once per process)."""
    load_plugins(plugins)
    return execute_limited(task, scenario, hash_, time_limit_s)


def _outcomes(
    todo: Iterable[PlannedScenario], task: Task, workers: int, scheduler: str | None,
    time_limit_s: float | None, plugins: Sequence[str] = (),
) -> Iterator[tuple[PlannedScenario, Outcome]]:
    items = iter(todo)
    first = next(items, None)
    if first is None:
        return
    items = itertools.chain([first], items)
    if scheduler is None:
        if isinstance(task, str):
            resolve_task(task)  # fail in the driver rather than in the children
        yield from local_outcomes(items, task, workers, time_limit_s)
        return
    from distributed import as_completed

    if isinstance(task, str):
        resolve_task(task)  # fail in the driver, once, rather than in every worker
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
                outcome = _lost(p, exc)
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
