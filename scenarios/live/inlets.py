"""Feeding a live session from LSL inlets: the sEMG paces it, the IMU and the watches follow.

:func:`run_session` runs a :class:`~scenarios.live.session.LiveGrasp` on an open sEMG
inlet (the arm's orientation inlet beside it), asking each stream's
:class:`~scenarios.live.lsl.SourceWatch` during its gaps whether another source took
over its name.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from estimation.threads import one_blas_thread
from scenarios.live.session import LiveGrasp


def run_session(grasp: LiveGrasp, connect: Callable[[], Any], *,
                imu: Any = None, watches: Sequence[tuple[str, Any]] = (),
                stop: Callable[[], bool] | None = None, max_chunk: int = 64) -> Any:
    """Feed ``grasp`` from LSL inlets until the session ends.

    The hand is reset and the garbage collected before the inlet connects, so that
    the first samples (a player such as ``griploop stream`` starts when a consumer
    connects) do not queue behind the preparations. Automatic garbage collection
    is off during the session (young objects are collected every 5 s of session
    time between two control steps), and BLAS runs one thread.

    Each turn of the loop waits for sEMG samples (at most until the wall clock has
    work), reads whatever orientation samples have arrived without waiting, feeds
    both, and lets the wall clock act. During a gap of the sEMG or a stall of the
    IMU, the stream's :class:`~scenarios.live.lsl.SourceWatch` is asked whether
    another source took over its name (:meth:`scenarios.live.session.LiveGrasp.source_changed`).

    Parameters
    ----------
    grasp : LiveGrasp
        Started here.
    connect : callable
        Returns the open sEMG inlet (:func:`scenarios.live.lsl.open_inlet`), time
        stamps on this machine's clock.
    imu : pylsl.StreamInlet, optional
        The open orientation inlet (same clock), for a :class:`~scenarios.live.arm.PitchArm`.
    watches : sequence of (str, SourceWatch)
        ``("emg", watch)`` and ``("imu", watch)``: each asked during its stream's gaps.
    stop : callable, optional
        Polled every loop; the session ends (``interrupted``) when it returns True.

    Returns
    -------
    pylsl.StreamInlet
        The sEMG inlet, its stream closed.
    """
    from pylsl.util import LostError as lost_error

    from scenarios.live.lsl import identity, pylsl_module

    lsl = pylsl_module()
    clock = grasp._clock
    local_clock = lsl.local_clock
    was_enabled = gc.isenabled()
    inlet = None
    watch_of = dict(watches)
    try:
        with one_blas_thread():
            grasp.start()
            gc.collect()
            gc.disable()
            inlet = connect()
            numeric = inlet.channel_format != lsl.cf_string
            buf = (np.zeros((max_chunk, inlet.channel_count), dtype=inlet.np_dtype) if numeric
                   else None)
            imu_buf = None
            if imu is not None and imu.channel_format != lsl.cf_string:
                imu_buf = np.zeros((max_chunk, imu.channel_count), dtype=imu.np_dtype)
            grasp.started_wall = clock()
            while not grasp.finished:
                if stop is not None and stop():
                    grasp.finish("interrupted")
                    break
                wait = grasp.wait_s(clock())
                try:
                    if numeric:
                        samples, stamps = inlet.pull_chunk(timeout=wait, max_samples=max_chunk,
                                                           dest_obj=buf, min_samples=1,
                                                           as_numpy=True)
                    else:
                        samples, stamps = inlet.pull_chunk(timeout=wait, max_samples=max_chunk,
                                                           min_samples=1)
                except lost_error:  # a stream without a source_id is gone for good
                    samples, stamps = None, []
                    time.sleep(wait)  # what the pull would have waited
                arrival = clock()
                if imu is not None:
                    _pull_imu(grasp, imu, imu_buf, max_chunk, arrival, lost_error)
                if len(stamps):
                    grasp.feed(samples, np.asarray(stamps), arrival, local_clock())
                now = clock()
                grasp.tick(now)
                if watch_of and not grasp.finished:
                    _watch(grasp, watch_of, now, identity)
    except KeyboardInterrupt:
        grasp.finish("interrupted")
        raise
    finally:
        if inlet is not None:
            inlet.close_stream()
        if imu is not None:
            imu.close_stream()
        for watch in watch_of.values():
            watch.close()
        if was_enabled:
            gc.enable()
    return inlet


def _pull_imu(grasp: LiveGrasp, imu: Any, buf: np.ndarray | None, max_chunk: int,
              arrival: float, lost_error: type[Exception]) -> None:
    """Whatever orientation samples have arrived, to the arm (never waits)."""
    try:
        if buf is not None:
            samples, stamps = imu.pull_chunk(timeout=0.0, max_samples=max_chunk, dest_obj=buf,
                                             as_numpy=True)
        else:
            samples, stamps = imu.pull_chunk(timeout=0.0, max_samples=max_chunk)
    except lost_error:
        return
    if len(stamps):
        grasp.feed_imu(samples[:len(stamps)], np.asarray(stamps), arrival)


def _watch(grasp: LiveGrasp, watches: Mapping[str, Any], now: float,
           identity: Callable[[Any], dict[str, Any]]) -> None:
    """During a gap (sEMG) or a stall (IMU), whether another source took over the name."""
    stalled = {"emg": grasp.in_gap, "imu": bool(getattr(grasp.arm, "in_gap", False))}
    for label, watch in watches.items():
        if not stalled.get(label, False):
            continue
        found = watch.replacement(now)
        if found is not None:
            grasp.source_changed(label, watch.identity, identity(found))
            return
