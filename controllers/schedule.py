"""Gain scheduling over grip force: one design per grid force, switched or interpolated.

The hand-object plant is about four times slower and softer below the pads'
knee (about 8 N) than above it (:mod:`controllers.design_plant`), so no fixed
linear controller keeps its specification over the range a user asks for.
:class:`ScheduledController` holds a bank of designs, one per grid force, and
picks the one for the current operating point.

Scheduling signal. The larger of the measured grip force ``y`` and the
reference ``r``, passed through an attack-release filter: it follows a rise at
once and a fall with time constant ``release_s``::

    v_k = max(y_k, r_k)
    s_k = v_k                                        if v_k >= s_(k-1)
    s_k = s_(k-1) + (T / release_s) (v_k - s_(k-1))  otherwise

Why the measured force: the plant's dynamics are set by how far the pads are
compressed, i.e. by the force actually applied, which during the contact
transient or an overshoot is far from the reference. Why also the reference,
and the fast attack: a design made for a *higher* force than the present one
has less gain, which is safe on the softer plant (lower crossover, more phase
margin), while a soft-pad design (about four times the gain) on a plant that
the loop is about to push onto the stops is not: at the hand-over of a 24 N
grasp, scheduling on the measured 5 N alone gave an 81 N slam. So the loop
always runs the design of the highest force it is at or heading to. The slow
release keeps the schedule from following the loop's own oscillation.

Blending. ``"interpolate"`` (PID): gains are interpolated linearly in force
between grid points and changed bumplessly every step (the integrator absorbs
the change of the proportional and derivative terms, :meth:`~controllers.pid.PID.set_gains`).
``"switch"`` (lead-lag, MPC: controllers whose states are not comparable from
one design to the next): the design whose cell contains the signal is active,
cells split at the geometric midpoints between grid forces, and a switch
happens only once the signal is ``hysteresis`` (relative) beyond the cell edge.
The two neighbours of the active design run beside it in tracking mode: they
see the same error and are conditioned on the command actually applied
(``track``), so when one of them takes over its state is the one it would have
had if it had been in charge, and the command continues without a bump and
without losing the loop's dynamics (restarting the new design from the last
command instead gave 50-64 % overshoot on a 5 -> 6 N step, against 3-7 % for
the fixed designs). A design that was not a neighbour takes over from the
last command (``handover``). With ``warm="all"`` (the MPC) every inactive design
tracks; designs that offer ``observer_bank`` (:class:`controllers.mpc.ObserverBank`)
do so in one batched update rather than one call each.

The controller the loop runs at a force ``F`` is
:meth:`ScheduledController.controller_at` ``(F)``:
the interpolated gains, or the design of ``F``'s cell. Margins at ``F`` are
computed on that controller with the plant linearized at ``F``.
"""

from __future__ import annotations

import bisect
import copy
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from controllers.base import Controller, Observation, as_observation, controller_stats
from controllers.errors import SpecificationError

if TYPE_CHECKING:
    import control

#: What the ``"interpolate"`` blend reads and sets on every design.
_INTERPOLATED = ("kp", "ki_per_s", "kd_s", "set_gains")


class ScheduledController:
    """A bank of force controllers scheduled on grip force (see the module notes).

    Parameters
    ----------
    forces_n : sequence of float
        Grid forces, N, strictly ascending (one design each).
    designs : sequence of controller
        The designs, each with ``reset``, ``act``, ``track``, ``handover``,
        ``loop``, ``dt_s`` and ``computation_delay_samples``
        (:func:`controllers.base.complete_controller` adds the defaults).
    blend : {"interpolate", "switch"}
        ``"interpolate"`` needs PID designs (``kp``, ``ki_per_s``, ``kd_s``).
    release_s : float
        Release time constant of the scheduling filter, s.
    hysteresis : float
        Relative distance past a cell edge before a switch (``"switch"``).
    warm : {"neighbours", "all", "none"}
        ``"switch"`` only: which inactive designs track the applied command
        (``"all"`` for designs whose tracking is a state estimator, the MPC's
        Kalman filter, so that any of them can take over converged; ``"none"``
        for designs that take the state over from the active one at a switch,
        ``take_state_from``: the lead-lag compensators, all of one order).
    name : str
        Registered name of the controller family.
    """

    def __init__(self, forces_n: Sequence[float], designs: Sequence[Controller], *,
                 blend: Literal["interpolate", "switch"] = "switch", release_s: float = 0.2,
                 hysteresis: float = 0.03,
                 warm: Literal["neighbours", "all", "none"] = "neighbours",
                 name: str = "controller") -> None:
        forces = [float(f) for f in forces_n]
        if len(forces) != len(designs) or not forces:
            raise SpecificationError(
                f"ScheduledController: expected one design per grid force, found "
                f"{len(designs)} designs for {len(forces)} forces"
            )
        if any(b <= a for a, b in zip(forces, forces[1:], strict=False)):
            raise SpecificationError(
                f"ScheduledController: expected ascending forces, found {forces}")
        if blend not in ("interpolate", "switch"):
            raise SpecificationError(
                f"ScheduledController: expected blend 'interpolate' or 'switch', found {blend!r}"
            )
        if release_s <= 0 or hysteresis < 0:
            raise SpecificationError(
                f"ScheduledController: expected release_s > 0 and hysteresis >= 0, found "
                f"{release_s}, {hysteresis}"
            )
        self.forces_n = forces
        self.designs = list(designs)
        self.blend = blend
        self.release_s = float(release_s)
        self.hysteresis = float(hysteresis)
        if warm not in ("neighbours", "all", "none"):
            raise SpecificationError(
                f"ScheduledController: expected warm 'neighbours', 'all' or 'none', found {warm!r}"
            )
        self.warm = warm
        self.name = name
        self.dt_s = float(self.designs[0].dt_s)
        self.computation_delay_samples = int(self.designs[0].computation_delay_samples)
        # cell edges: geometric midpoints between neighbouring grid forces
        self._edges = [float(np.sqrt(a * b)) for a, b in zip(forces, forces[1:], strict=False)]
        if blend == "interpolate":
            lacking = [a for a in _INTERPOLATED if not hasattr(self.designs[0], a)]
            if lacking:
                raise SpecificationError(
                    f"{name}: blend 'interpolate' schedules PID gains, and a "
                    f"{type(self.designs[0]).__name__} has no {', '.join(lacking)}; "
                    "register the kind with blend='switch'")
            self._gains = [(d.kp, d.ki_per_s, d.kd_s) for d in self.designs]
            self._runner = copy.deepcopy(self.designs[0])
        self._alpha = min(1.0, self.dt_s / self.release_s)
        # designs that can batch their tracking (the MPC's Kalman filters) do it in one step
        make_bank = getattr(self.designs[0], "observer_bank", None)
        self._bank = (make_bank(self.designs)
                      if blend == "switch" and warm == "all" and make_bank else None)
        every = frozenset(range(len(self.designs)))
        self._all_but = [every - {i} for i in range(len(self.designs))]
        self.reset()

    # ------------------------------------------------------------------ schedule
    @property
    def active(self) -> Controller:
        """The controller computing the command now."""
        return self._runner if self.blend == "interpolate" else self.designs[self.index]

    def cell_of(self, force_n: float) -> int:
        """Index of the grid design whose cell contains ``force_n``."""
        return bisect.bisect_right(self._edges, float(force_n))

    def gains_at(self, force_n: float) -> tuple[float, float, float]:
        """Interpolated ``(kp, ki_per_s, kd_s)`` at ``force_n`` (clamped to the grid)."""
        f = self.forces_n
        x = min(max(float(force_n), f[0]), f[-1])
        j = min(max(bisect.bisect_right(f, x) - 1, 0), len(f) - 2) if len(f) > 1 else 0
        if len(f) == 1:
            return self._gains[0]
        w = (x - f[j]) / (f[j + 1] - f[j])
        a, b = self._gains[j], self._gains[j + 1]
        return (a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2]))

    def controller_at(self, force_n: float) -> Controller:
        """The linear controller the loop runs at a steady ``force_n`` (for analysis)."""
        if self.blend == "interpolate":
            pid = copy.deepcopy(self.designs[0])
            kp, ki, kd = self.gains_at(force_n)
            pid.kp, pid.ki_per_s, pid.kd_s = kp, ki, kd
            return pid
        return self.designs[self.cell_of(force_n)]

    def _update_schedule(self, grip_force_n: float, reference_n: float) -> None:
        y = max(float(grip_force_n), float(reference_n))
        s = self.signal_n
        self.signal_n = y if y >= s else s + self._alpha * (y - s)
        if self.blend == "interpolate":
            kp, ki, kd = self.gains_at(self.signal_n)
            self._runner.set_gains(kp=kp, ki_per_s=ki, kd_s=kd)
            return
        i = self.index
        lo = self._edges[i - 1] if i > 0 else -np.inf
        hi = self._edges[i] if i < len(self._edges) else np.inf
        h = self.hysteresis
        if self.signal_n > hi * (1.0 + h) or self.signal_n < lo * (1.0 - h):
            new = self.cell_of(self.signal_n)
            if new != i:
                self.index = new
                self.n_switches += 1
                self._pending_from = i
                self._pending_handover = new not in self._warm

    def _neighbours(self) -> tuple[int, ...]:
        i, n = self.index, len(self.designs)
        if self.warm == "none":
            return ()
        if self.warm == "all":
            return tuple(j for j in range(n) if j != i)
        return tuple(j for j in (i - 1, i + 1) if 0 <= j < n)

    def _follow(self, obs: Observation, u: float) -> None:
        """Neighbours track the applied command; newcomers start from it."""
        if self.blend != "switch":
            return
        if self._bank is not None:  # all inactive designs track in one batched update
            self._bank.track(obs.grip_force_n, u, skip=self.index)
            warm = self._all_but[self.index]
            if warm is not self._warm:
                for j in warm - self._warm:
                    self.designs[j].handover(obs, u)
                self._warm = warm
            return
        warm = self._neighbours()
        for j in warm:
            if j in self._warm:
                self.designs[j].track(obs, u)
            else:
                self.designs[j].handover(obs, u)
        self._warm = frozenset(warm)

    # ------------------------------------------------------------------ interface
    def reset(self, u0: float = 0.0) -> None:
        """Restart at the lowest grid force with every design reset."""
        self.signal_n = 0.0
        self.index = 0
        self.n_switches = 0
        self._pending_handover = False
        self._pending_from: int | None = None
        self._warm: frozenset[int] = frozenset()
        for d in self.designs:
            d.reset(u0)
        if self.blend == "interpolate":
            self._runner.set_gains(kp=self._gains[0][0], ki_per_s=self._gains[0][1],
                                   kd_s=self._gains[0][2])
            self._runner.reset(u0)
        self.last_u = float(u0)
        self.last_reference_n = 0.0

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Update the schedule from the measured force, then let the active design act."""
        obs = as_observation(observation)
        self._update_schedule(obs.grip_force_n, obs.reference_n)
        if self._pending_handover or self._pending_from is not None:
            new, old = self.active, self.designs[self._pending_from]
            copied = hasattr(new, "take_state_from") and new.take_state_from(old, obs, self.last_u)
            if self._pending_handover and not copied:
                new.handover(obs, self.last_u)
            self._pending_handover = False
            self._pending_from = None
        u = self.active.act(obs)
        self.last_u = u
        self.last_reference_n = float(getattr(self.active, "last_reference_n", obs.reference_n))
        self._follow(obs, u)
        return u

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Follow a command applied by someone else (the schedule still follows the force)."""
        obs = as_observation(observation)
        self._update_schedule(obs.grip_force_n, obs.reference_n)
        self._pending_handover = False
        self._pending_from = None
        self.active.track(obs, applied_u)
        self.last_u = float(applied_u)
        self.last_reference_n = float(obs.reference_n)
        self._follow(obs, float(applied_u))

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Take over at command ``u`` (contact): the schedule jumps to the measured force."""
        obs = as_observation(observation)
        self.signal_n = max(float(obs.grip_force_n), float(obs.reference_n))
        self.index = self.cell_of(self.signal_n)
        if self.blend == "interpolate":
            kp, ki, kd = self.gains_at(self.signal_n)
            self._runner.set_gains(kp=kp, ki_per_s=ki, kd_s=kd)
        self._pending_handover = False
        self._pending_from = None
        self._warm = frozenset()
        self.active.handover(obs, u)
        self.last_u = float(u)
        self.last_reference_n = float(obs.reference_n)
        self._follow(obs, float(u))

    def stats(self) -> dict[str, float]:
        """Run-time counters summed over the bank's designs (``{}`` if none reports any)."""
        total: dict[str, float] = {}
        for d in self.designs:
            for key, value in controller_stats(d).items():
                total[key] = total.get(key, 0) + value
        return total

    def loop(self, plant: control.LTI, force_n: float | None = None) -> control.LTI:
        """Open loop at ``force_n`` (default: the present scheduling signal)."""
        f = self.signal_n if force_n is None else force_n
        return self.controller_at(f).loop(plant)
