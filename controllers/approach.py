"""Closing phase before force control: close, slow down at the first touch, hand over.

The force controllers are designed around a steady grasp. Before the digits
touch the object the measured force is zero whatever the command, so a force
loop winds up and the hand hits the object at full speed (a 400 N impact
transient on the simulated can with a PI, versus an 8 N target). Real hands
close under position or speed control and switch to force control on contact;
:class:`ContactGate` does that, with a bumpless hand-over (the force controller
tracks the closing command through its ``track`` method).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from controllers.base import Observation, as_observation
from controllers.errors import SpecificationError

if TYPE_CHECKING:
    import control


@dataclass(frozen=True)
class GateSpec:
    """How a :class:`ContactGate` releases, approaches and hands over (see its phases).

    Attributes
    ----------
    release_below_n : float
        A reference below this (N) opens the hand and re-arms the gate.
    opening_command : float
        Normalized command while open or opening (negative opens).
    approach_speed_rad_s : float
        Finger closing speed after the first touch, rad/s.
    approach_gain : float
        Integral gain of the speed servo, command units per rad.
    force_rate_n_s : float
        Largest rise rate of the reference after the hand-over, N/s.
    lost_contact_s : float
        Time without both sides touching after which force control stops, s.
    handover_fraction : float
        Grip, as a fraction of the reference, at which force control starts.
    """

    release_below_n: float = 0.1
    opening_command: float = -0.3
    approach_speed_rad_s: float = 0.15
    approach_gain: float = 8.0
    force_rate_n_s: float = 15.0
    lost_contact_s: float = 0.1
    handover_fraction: float = 0.5


class ContactGate:
    """Close onto the object, slow down at the first touch, force control once both sides touch.

    Phases (each control step, in order):

    1. *Release*: a reference below ``release_below_n`` opens the hand
       (``opening_command`` once the force has gone) and re-arms the gate.
    2. *Closing*: no digit touches the object: ``closing_command``.
    3. *Approach*: one side touches (the thumb alone pushes the object against
       the table's friction, or the fingers alone): a finger-speed servo closes
       at ``approach_speed_rad_s``. It starts from the reference's feedforward
       command and integrates the speed error,
       ``u <- clip(u + approach_gain * (v_a - v) * T, u_ff, closing_command)``,
       so the second side arrives slowly (the first impact stays small) and
       the hand does not stall with one side pressing the object against the
       table's friction (with friction 1.0 that friction equals the grip a
       light can needs, and a force-controlled thumb stopped there).
    4. *Force control*: once both sides touch (``Observation.both_sides``) and
       the grip reaches ``handover_fraction`` of the reference (a light touch of
       a soft object is not yet a grasp: the force controller would race the
       slack out of the foam and overshoot),
       the force controller takes over from the feedforward command
       ``feedforward(r)`` (``handover``), and the reference it sees rises from
       the grip at the hand-over to the user's reference at no more than
       ``force_rate_n_s`` (it falls at once), so the loop never faces the
       whole contact step at once. If both sides stop touching for
       ``lost_contact_s``, the gate goes back to the approach.

    Outside force control the wrapped controller only tracks the applied
    command (``track``): its integrator does not wind up while the force reads
    zero or while one side pushes alone.

    Parameters
    ----------
    controller : object
        A force controller with ``reset()``, ``act(obs)``, ``track(obs, u)``,
        ``handover(obs, u)`` and ``loop(plant)``.
    closing_command : float
        Normalized command while closing (real hands close fully in 0.4-1 s).
    feedforward : callable, optional
        ``feedforward(reference_n) -> command`` holding that force in steady
        state (:meth:`controllers.design.ControllerDesign.feedforward`). Without
        it the approach and the hand-over start from ``closing_command``.
    dt_s : float
        Control period, s.
    spec : GateSpec, optional
        Release threshold and opening command, approach servo, hand-over fraction,
        reference rise rate and contact-loss time (default ``GateSpec()``); kept
        as the gate's attributes of the same names.
    """

    def __init__(
        self,
        controller: Any,
        *,
        closing_command: float = 0.2,
        feedforward: Callable[[float], float] | None = None,
        dt_s: float = 0.01,
        spec: GateSpec | None = None,
    ) -> None:
        g = GateSpec() if spec is None else spec
        approach_speed_rad_s, approach_gain = g.approach_speed_rad_s, g.approach_gain
        force_rate_n_s, lost_contact_s = g.force_rate_n_s, g.lost_contact_s
        handover_fraction = g.handover_fraction
        if not 0 < closing_command <= 1:
            raise SpecificationError(
                f"ContactGate: expected 0 < closing_command <= 1, found {closing_command}"
            )
        self.controller = controller
        self.closing_command = float(closing_command)
        self.release_below_n = float(g.release_below_n)
        self.opening_command = float(g.opening_command)
        self.feedforward = feedforward
        if min(approach_speed_rad_s, approach_gain, force_rate_n_s, lost_contact_s, dt_s) <= 0:
            raise SpecificationError(
                "ContactGate: expected positive approach_speed_rad_s, approach_gain, "
                f"force_rate_n_s, lost_contact_s and dt_s, found {approach_speed_rad_s}, "
                f"{approach_gain}, {force_rate_n_s}, {lost_contact_s}, {dt_s}"
            )
        self.approach_speed_rad_s = float(approach_speed_rad_s)
        self.approach_gain = float(approach_gain)
        self.force_rate_n_s = float(force_rate_n_s)
        self.lost_contact_s = float(lost_contact_s)
        if not 0 <= handover_fraction <= 1:
            raise SpecificationError(
                f"ContactGate: expected 0 <= handover_fraction <= 1, found {handover_fraction}"
            )
        self.handover_fraction = float(handover_fraction)
        self.dt_s = float(dt_s)
        self.name = getattr(controller, "name", "controller")
        self.reset()

    def reset(self) -> None:
        """Back to the closing phase; resets the wrapped controller."""
        self.in_contact = False
        self.phase = "closing"
        self._u_approach: float | None = None
        self._ref_limited = 0.0
        self._lost_s = 0.0
        self.controller.reset()

    def feedforward_command(self, reference_n: float) -> float:
        """Command that holds ``reference_n`` in steady state (``closing_command`` without one)."""
        if self.feedforward is None:
            return self.closing_command
        return float(min(1.0, max(0.0, self.feedforward(reference_n))))

    def _handover(self, obs: Observation, u: float) -> None:
        if hasattr(self.controller, "handover"):
            self.controller.handover(obs, u)
        else:
            self.controller.reset()
            self.controller.track(obs, u)

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """The command of the current phase (see the class notes)."""
        obs = as_observation(observation)
        if obs.reference_n < self.release_below_n:
            self.in_contact = False
            if not (obs.thumb_contact or obs.finger_contact):
                self.phase = "open"
                self.controller.track(obs, self.opening_command)
                return self.opening_command
            self.phase = "releasing"
            return self.controller.act(obs)
        if self.in_contact:
            self._lost_s = 0.0 if obs.both_sides else self._lost_s + self.dt_s
            if self._lost_s >= self.lost_contact_s:
                self.in_contact = False
                self._u_approach = None
        if (not self.in_contact and obs.both_sides
                and obs.grip_force_n >= self.handover_fraction * obs.reference_n):
            self.handover(obs, self.feedforward_command(obs.reference_n))
        if self.in_contact:
            self._ref_limited = min(obs.reference_n,
                                    self._ref_limited + self.force_rate_n_s * self.dt_s)
            return self.controller.act(replace(obs, reference_n=self._ref_limited))
        if obs.thumb_contact or obs.finger_contact:
            self.phase = "approach"
            u_ff = min(self.feedforward_command(obs.reference_n), self.closing_command)
            u = u_ff if self._u_approach is None else self._u_approach
            u += self.approach_gain * (self.approach_speed_rad_s - obs.finger_velocity) * self.dt_s
            u = min(max(u, u_ff), self.closing_command)
            self._u_approach = u
        else:
            self.phase = "closing"
            u = self.closing_command
        self.controller.track(obs, u)
        return u

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Force control from command ``u`` now (the caller knows the grasp is closed)."""
        obs = as_observation(observation)
        self.in_contact = True
        self.phase = "force"
        self._lost_s = 0.0
        self._ref_limited = min(obs.reference_n, obs.grip_force_n)
        self._handover(replace(obs, reference_n=self._ref_limited), u)

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Follow a command applied by someone else."""
        self.controller.track(observation, applied_u)

    def loop(self, plant: control.LTI) -> control.LTI:
        """The wrapped controller's loop (the gate is inactive around a steady grasp)."""
        return self.controller.loop(plant)
