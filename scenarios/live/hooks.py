"""Where a live session's outputs go, and the clock it reads."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field


@dataclass(frozen=True)
class SessionHooks:
    """The callables a :class:`~scenarios.live.session.LiveGrasp` calls out through.

    Attributes
    ----------
    publish : callable, optional
        ``publish(t_s, reference_n, grip_n, feedback)`` after every control step (the
        outlets; ``t_s`` session time in s, forces in N, ``feedback`` the stimulator's
        intensity 0..1).
    event : callable, optional
        ``event(t_s, marker)`` for lift, slip, drop, crush, gap_start, gap_end,
        source_changed, imu_gap_start, imu_gap_end ... (every marker is also kept in
        the session's ``events``).
    notify : callable, optional
        ``notify(line)``: one line for the person at the terminal when a fault begins
        or ends (a gap, a stall, a changed source).
    clock : callable
        Wall clock in seconds (``time.perf_counter``); arrival times use the same.
    """

    publish: Callable[[float, float, float, float], None] | None = None
    event: Callable[[float, str], None] | None = None
    notify: Callable[[str], None] | None = None
    # a factory: a function as the class's default would be documented as its method
    clock: Callable[[], float] = field(default_factory=lambda: time.perf_counter)


DEFAULT_HOOKS = SessionHooks()
"""Outputs nowhere, and the wall clock ``time.perf_counter``."""
