"""Anticipatory grip-load coupling: the intact user's grip planned from the load they expect.

People lifting an object raise their grip in parallel with the load force during the
loading phase, planned from the weight and friction they expect, and keep the grip/load
ratio a margin above the slip ratio (Johansson and Westling 1984, Exp Brain Res 56:550;
Westling and Johansson 1984, Exp Brain Res 53:277). While the arm moves the object, the
grip follows the load the movement's acceleration adds, without lag: it is planned from an
internal model of the arm and the object (Flanagan and Wing 1993, Exp Brain Res 95:131;
1997, J Neurosci 17:1519). The intact user plans (:class:`LoadPlan`,
:func:`anticipated_grip_n`)::

    G(t) = preload + (1 + margin) * L(t + lead) * slip_ratio,   slip_ratio = 1 / (2 mu)

* ``L`` the load they expect from their own arm's planned moves: ``m |g + a(t)|`` while
  the object is in the hand (from the lift's start to the end of the set-down), ``a`` the
  minimum-jerk acceleration of each move; 0 before the lift and once the object is put
  down. ``m g / (2 mu)`` is the plan's ``need_n`` (the user knows the object from handling
  it), so ``L * slip_ratio = need_n * |g + a| / g``;
* ``margin`` the safety margin of their belief (:meth:`sim.user.belief.ProsthesisBelief.margin`);
* ``preload`` the grip built at contact (``OperatorParams.preload_n``);
* ``lead`` the user's own delay from command to force (``OperatorParams.grip_lead_s``): the
  command leads by it so that the force and the load rise together, and the arm's lift
  starts that long after the user decides to lift (the loading phase).

The planned grip obeys the rule every user's aim does (:func:`sim.user.operator.grip_aim_n`):
at least ``MIN_GRIP_N`` (2 N), at most ``FRAGILE_MARGIN`` of a fragile object's break force.
The floor is the least grip the simulated hand holds steadily on an object resting on the
table: on the can, both sides of the hand touch it 26-43 % of the time at a reference of
0.5-1.5 N and 85-100 % at 2 N (prosthesis and intact digits alike: the first digit to
touch pushes the can against the table's friction), so below it the grasp never feels
secure and the user never lifts. A person's pre-load is smaller; here it only shows where
the coupled grip exceeds the floor.

Nothing here reads the simulation: the held grip, the slip force and so the margin that
results come out of the physics, and can differ from the plan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim.user.operator import FRAGILE_MARGIN, MIN_GRIP_N

G_M_S2 = 9.81
"""The acceleration of gravity the user expects the weight with, m/s^2 (the simulated world's)."""


def min_jerk_acceleration_m_s2(t_s: float, height_m: float, duration_s: float) -> float:
    """Acceleration of a minimum-jerk move of ``height_m`` over ``duration_s`` at ``t_s`` after
    its start, m/s^2 (0 outside the move): ``h / T^2 (60 s - 180 s^2 + 120 s^3)``, ``s = t / T``
    (Flash and Hogan 1985, J Neurosci 5:1688)."""
    if duration_s <= 0 or not 0.0 <= t_s <= duration_s:
        return 0.0
    s = t_s / duration_s
    return height_m / duration_s ** 2 * (60.0 * s - 180.0 * s * s + 120.0 * s ** 3)


@dataclass(frozen=True)
class LoadPlan:
    """The load a user expects from their own arm: lift, hold, set down (module notes).

    Attributes
    ----------
    lift_start_s : float
        When the arm starts lifting the object from the table, s.
    height_m : float
        How high it is lifted, m.
    move_s : float
        Duration of the lift and of the set-down, s.
    hold_s : float
        How long it is held at the top before the set-down, s.
    place : bool
        Put down after the hold (else held to the end).
    """

    lift_start_s: float
    height_m: float
    move_s: float
    hold_s: float
    place: bool = True

    def load_factor(self, t_s: float) -> float:
        """The load expected at ``t_s`` relative to the object's weight, ``|g + a| / g``
        while it is in the hand, 0 while it is on the table."""
        s = t_s - self.lift_start_s
        if s < 0.0:
            return 0.0
        if s <= self.move_s:
            a = min_jerk_acceleration_m_s2(s, self.height_m, self.move_s)
        else:
            down = s - self.move_s - self.hold_s
            if down < 0.0 or not self.place:
                return 1.0
            if down > self.move_s:
                return 0.0
            a = -min_jerk_acceleration_m_s2(down, self.height_m, self.move_s)
        return abs(G_M_S2 + a) / G_M_S2


def anticipated_grip_n(need_n: float, margin: float, preload_n: float, load_factor: float,
                       break_n: float | None = None) -> float:
    """The grip the user plans for a load of ``load_factor`` times the object's weight, N:
    ``preload_n + (1 + margin) * need_n * load_factor``, at least ``MIN_GRIP_N`` and at most
    ``FRAGILE_MARGIN`` of a fragile object's break force ``break_n`` (module notes).

    Parameters
    ----------
    need_n : float
        The grip the object needs not to slip under its weight, ``m g / (2 mu)``, N.
    margin : float
        The user's safety margin (0.25: 25 % above the slip force).
    preload_n : float
        The grip built at contact, N.
    load_factor : float
        The expected load over the weight (:meth:`LoadPlan.load_factor`).
    break_n : float or None
        A fragile object's break force, N.
    """
    grip = max(preload_n + (1.0 + margin) * need_n * load_factor, MIN_GRIP_N)
    if break_n is not None:
        grip = min(grip, FRAGILE_MARGIN * break_n)
    return float(grip) if math.isfinite(grip) else 0.0
