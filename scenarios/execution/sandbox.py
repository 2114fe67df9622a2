"""Running one scenario safely: in a forked child process that can be stopped.

:func:`execute` turns any exception of the task into a ``failed`` outcome with
its traceback, so one bad scenario never stops a sweep. A :class:`Sandbox` is a
child forked from the driver (or a Dask worker) that runs scenarios one after
another and is killed when one overruns its time limit or the driver stops;
:func:`run_guarded` runs a scenario once more in a fresh child if its process
dies, then records it as killed.
"""

from __future__ import annotations

import gc
import math
import os
import signal
import socket
import sys
import threading
import time
import traceback
from collections.abc import Mapping
from typing import Any

import numpy as np

from scenarios.execution.planning import PlannedScenario, Task, resolve_task
from scenarios.schema import Scenario
from scenarios.store import Outcome, encode_traces

_SCALARS = (bool, int, float, str, type(None))


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


def lost_worker(p: PlannedScenario, exc: BaseException) -> Outcome:
    """The failed outcome of a scenario whose worker was lost with ``exc``."""
    return failed_outcome(p.hash, f"worker lost: {_one_line(exc)}", time.time(), 0.0, "",
                   trace_text="".join(traceback.format_exception(exc)))


def failed_outcome(hash_: str, error: str, started: float, duration: float, worker: str, *,
                   trace_text: str | None = None) -> Outcome:
    """A failed scenario's outcome: ``error`` in one line, ``duration`` s from ``started``."""
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


class SandboxCrashed(Exception):
    """The sandbox's child process died while running a scenario."""


class Sandbox:
    """A forked child process that runs tasks and can be stopped.

    ``blas_threads`` limits the child's BLAS thread pools (one worker among
    several on a machine's cores). The child is forked on first use and kept
    for the following scenarios
    (so caches warmed by one scenario serve the next, as in-process); a
    scenario past its time limit is stopped by killing the child, which is
    forked again for the next one. The child runs exactly the code the
    parent would, on a copy of its memory, so results are the same as
    in-process. The parent holds no simulation state.
    """

    def __init__(self, *, blas_threads: int | None = None) -> None:
        self.blas_threads = blas_threads
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
                if self.blas_threads is not None:
                    _limit_blas(self.blas_threads)
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
        SandboxCrashed
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
        raise SandboxCrashed(f"its process died ({how}) after {duration:.1f} s")

    def time_out(self, time_limit_s: float | None) -> Outcome:
        """Stop the child running an overdue scenario; its ``timeout`` failure."""
        self._conn.close()
        self._kill()
        return failed_outcome(
            self._hash,
            f"timeout: still running after {time_limit_s:g} s (time_limit_s); stopped",
            self._started, time.perf_counter() - self._t0, self._worker,
        )

    def run(self, task: Task, scenario: Scenario, hash_: str,
            time_limit_s: float | None) -> Outcome:
        """Run one scenario in the child; a ``timeout`` failure past ``time_limit_s``.

        Raises
        ------
        SandboxCrashed
            The child died (killed by a signal, or exited) during the scenario.
        """
        self.submit(task, scenario, hash_, time_limit_s)
        try:
            ready = self._conn.poll(time_limit_s)
        except (EOFError, OSError):
            ready = True
        return self.collect() if ready else self.time_out(time_limit_s)


def _limit_blas(threads: int) -> None:
    """Limit BLAS and OpenMP thread pools in this process (a worker beside others).

    With several workers on few cores, each worker's BLAS starting a thread per
    core only makes the threads wait for each other: a sweep of 36 cold
    episodes spent 49 s of CPU with two workers against 46 s in one thread each.
    """
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads)


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
        except SandboxCrashed as exc:
            reasons.append(str(exc))
    return killed_twice(hash_, reasons, started)


def killed_twice(hash_: str, reasons: list[str], started: float) -> Outcome:
    """The failed outcome of a scenario that killed its process twice, with both reasons."""
    return failed_outcome(
        hash_,
        f"killed: the scenario killed its process twice ({'; '.join(reasons)})",
        started, time.time() - started, f"{socket.gethostname()}:{os.getpid()}",
    )
