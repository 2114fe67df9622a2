"""How the wrist moves in an episode: a scripted schedule, or its user's own commands.

A transradial prosthesis user moves their own elbow and shoulder: the wrist's
vertical motion is theirs. :class:`GraspEnv <sim.hand.grasp_env.GraspEnv>` takes it in
one of two forms:

:class:`WristSchedule`
    A scripted trajectory: lift once the grip is established after an earliest
    time, hold, optionally shake and put down. Used by controller measurements,
    linearization and the scripted user.
:class:`CommandedWrist`
    Moves commanded while the episode runs (``GraspEnv.move_wrist``): each command
    starts a minimum-jerk move from wherever the wrist's set-point is to a new
    height over a given duration, as point-to-point arm movements are (Flash and
    Hogan 1985, J Neurosci 5:1688). A command given mid-move starts from the
    current set-point with zero velocity assumed (a new submovement). A move
    may instead ``follow`` a measured arm: the set-point approaches the new height
    as a critically damped second-order system of time constant ``duration_s``,
    from where it is at the speed it has. A stream of them, one per sample of
    the arm, keeps the set-point's position and speed continuous (restarting a
    minimum-jerk move at every sample would stop the wrist at each one, and
    straight segments between samples would jolt it at each one: both shake a
    held object).

Heights are offsets from the approach pose, m; times are episode time, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.hand.errors import HandSpecError

LIFT_HEIGHT_M = 0.08
"""How high a grasp-lift-hold trial lifts the object, m (the wrist's offset)."""
MAX_WRIST_HEIGHT_M = 0.2
"""Highest wrist offset a command may ask for, m (the scene's free space above the table)."""
#: Paths a commanded move may take.
PATHS = ("min_jerk", "follow")
FOLLOW_SETTLE = 20.0
"""A follow move has ended after this many time constants (within 1e-7 of its height)."""


@dataclass(frozen=True)
class WristSchedule:
    """Wrist trajectory of an episode (offsets from the approach pose, m and s).

    Parameters
    ----------
    lift_after_s : float
        Earliest lift time. The lift starts at the first control step at or
        after it where the grip force reaches ``lift_min_grip_n`` with both
        sides touching (the grip is established); without a grip, no lift.
    lift_min_grip_n : float
        Grip force that counts as established, N.
    lift_height_m : float
        Lift height, reached along a minimum-jerk path in ``lift_duration_s``.
    lift_duration_s : float
        Duration of the lift, s.
    shake_amplitude_m : float
        Vertical shake amplitude (0 = no shake), m.
    shake_frequency_hz : float
        Shake frequency, Hz.
    shake_delay_s : float
        Shake starts this long after the lift ends, s.
    shake_duration_s : float
        Shake duration, s; the amplitude is windowed by ``sin^2`` so the wrist
        velocity stays continuous.
    place_delay_s : float or None
        If set, the object is put back down this long after the lift ends.
    """

    lift_after_s: float = 0.8
    lift_min_grip_n: float = 1.0
    lift_height_m: float = LIFT_HEIGHT_M
    lift_duration_s: float = 0.6
    shake_amplitude_m: float = 0.0
    shake_frequency_hz: float = 3.0
    shake_delay_s: float = 0.3
    shake_duration_s: float = 1.0
    place_delay_s: float | None = None

    def height_m(self, t_s: float, lift_start_s: float | None) -> float:
        """Wrist height offset at ``t_s`` given when the lift started (or ``None``)."""
        if lift_start_s is None:
            return 0.0
        tau = t_s - lift_start_s
        z = self.lift_height_m * min_jerk(tau / self.lift_duration_s)
        if self.shake_amplitude_m <= 0 and self.place_delay_s is None:
            return z  # the common schedule: lift and hold (called every substep of a lift)
        after = tau - self.lift_duration_s
        if self.shake_amplitude_m > 0 and 0 < after - self.shake_delay_s < self.shake_duration_s:
            s = after - self.shake_delay_s
            window = math.sin(math.pi * s / self.shake_duration_s) ** 2
            phase = 2 * math.pi * self.shake_frequency_hz * s
            z += self.shake_amplitude_m * window * math.sin(phase)
        if self.place_delay_s is not None and after > self.place_delay_s:
            z -= self.lift_height_m * min_jerk((after - self.place_delay_s) / self.lift_duration_s)
        return z

    def moves_during(self, t0_s: float, t1_s: float, lift_start_s: float | None) -> bool:
        """Whether the wrist set-point changes anywhere in ``[t0_s, t1_s]``.

        Parameters
        ----------
        t0_s, t1_s : float
            Interval, episode time in s.
        lift_start_s : float or None
            When the lift started (``None``: not yet; ``-inf``: lifted by
            :meth:`~sim.hand.grasp_env.GraspEnv.steady_grasp`).

        Returns
        -------
        bool
            True when the interval overlaps the lift, the shake or the place
            motion; outside them :meth:`height_m` is constant.
        """
        if lift_start_s is None:
            return False
        return any(t0_s < b and a < t1_s for a, b in self.motion_windows(lift_start_s))

    def motion_windows(self, lift_start_s: float) -> tuple[tuple[float, float], ...]:
        """``(start_s, end_s)`` of the lift and, if configured, the shake and the place motion."""
        end = lift_start_s + self.lift_duration_s
        windows = [(lift_start_s, end)]
        if self.shake_amplitude_m > 0:
            windows.append((end + self.shake_delay_s,
                            end + self.shake_delay_s + self.shake_duration_s))
        if self.place_delay_s is not None:
            windows.append((end + self.place_delay_s,
                            end + self.place_delay_s + self.lift_duration_s))
        return tuple(windows)


def min_jerk(s: float) -> float:
    """Minimum-jerk position ``10 s^3 - 15 s^4 + 6 s^5`` of a move, ``s`` clipped to 0..1."""
    s = 0.0 if s < 0 else 1.0 if s > 1 else s
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


class CommandedWrist:
    """The wrist moved by its user: minimum-jerk moves to commanded heights (module notes).

    Attributes
    ----------
    target_m : float
        Height the current (or last) move ends at, m.
    first_rise_s : float or None
        When a move first took the wrist above the table pose, s (the lift's start).
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Back at the approach pose, not moving."""
        self._from_m = 0.0
        self.target_m = 0.0
        self._t0_s = 0.0
        self._duration_s = 0.0
        self._follow = False
        self._v0 = 0.0  # a follow move's initial speed, m/s
        self.first_rise_s: float | None = None

    def move(self, t_s: float, height_m: float, duration_s: float,
             path: str = "min_jerk") -> None:
        """Start a move at ``t_s`` to ``height_m`` taking ``duration_s``.

        Parameters
        ----------
        t_s : float
            Start, episode time, s.
        height_m : float
            Where the move ends, m above the approach pose.
        duration_s : float
            How long it takes, s; for ``follow``, the time constant.
        path : {"min_jerk", "follow"}
            Minimum-jerk (a point-to-point movement, from rest to rest), or
            following a measured arm (module notes).

        Raises
        ------
        HandSpecError
            A height outside ``0..MAX_WRIST_HEIGHT_M``, a non-positive or
            non-finite duration, an unknown path.
        """
        if path not in PATHS:
            raise HandSpecError(f"wrist move path: expected one of {', '.join(PATHS)}, "
                                f"found {path!r}")
        h, d = float(height_m), float(duration_s)
        if not (math.isfinite(h) and 0.0 <= h <= MAX_WRIST_HEIGHT_M):
            raise HandSpecError(f"wrist height: expected 0..{MAX_WRIST_HEIGHT_M:g} m, "
                                f"found {height_m!r}")
        if not (math.isfinite(d) and d > 0.0):
            raise HandSpecError(f"wrist move duration: expected a positive time in s, "
                                f"found {duration_s!r}")
        from_m = self.height_m(t_s)
        follow = path == "follow"
        self._v0 = self.speed_m_s(t_s) if follow else 0.0
        self._from_m = from_m
        self.target_m = h
        self._t0_s = float(t_s)
        self._duration_s = d
        self._follow = follow
        if self.first_rise_s is None and h > self._from_m:
            self.first_rise_s = float(t_s)

    def height_m(self, t_s: float) -> float:
        """The wrist set-point at ``t_s``, m."""
        d = self._duration_s
        if d <= 0.0:
            return self.target_m
        if self._follow:
            tau = t_s - self._t0_s
            if tau <= 0.0:
                return self._from_m
            w = 1.0 / d
            e0 = self._from_m - self.target_m
            h = self.target_m + (e0 + (self._v0 + w * e0) * tau) * math.exp(-w * tau)
            return 0.0 if h < 0.0 else MAX_WRIST_HEIGHT_M if h > MAX_WRIST_HEIGHT_M else h
        s = (t_s - self._t0_s) / d
        if s >= 1.0:
            return self.target_m
        return self._from_m + (self.target_m - self._from_m) * min_jerk(s)

    def speed_m_s(self, t_s: float) -> float:
        """The set-point's vertical speed at ``t_s``, m/s (0 once a minimum-jerk move ended)."""
        d = self._duration_s
        tau = t_s - self._t0_s
        if d <= 0.0 or tau < 0.0:
            return 0.0
        if self._follow:
            w = 1.0 / d
            b = self._v0 + w * (self._from_m - self.target_m)
            return (self._v0 - w * b * tau) * math.exp(-w * tau)
        s = tau / d
        if s >= 1.0:
            return 0.0
        return (self.target_m - self._from_m) * 30.0 * s * s * (1.0 - s) * (1.0 - s) / d

    def _end_s(self) -> float:
        """When the move has ended: a follow move after :data:`FOLLOW_SETTLE` time constants."""
        return self._t0_s + self._duration_s * (FOLLOW_SETTLE if self._follow else 1.0)

    def moves_during(self, t0_s: float, t1_s: float) -> bool:
        """Whether the set-point changes anywhere in ``[t0_s, t1_s]``."""
        return (self._duration_s > 0.0 and t0_s < self._end_s() and self._t0_s < t1_s
                and (self._from_m != self.target_m or self._v0 != 0.0))

    def settled(self, t_s: float) -> bool:
        """Whether the last move has ended by ``t_s``."""
        return t_s >= self._end_s() - 1e-9
