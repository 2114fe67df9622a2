"""Closing phase before force control: close at a fixed command until contact.

The force controllers are designed around a steady grasp. Before the digits
touch the object the measured force is zero whatever the command, so a force
loop winds up and the hand hits the object at full speed (a 400 N impact
transient on the simulated can with a PI, versus an 8 N target). Real hands
close under position or speed control and switch to force control on contact;
:class:`ContactGate` does that, with a bumpless hand-over (the force controller
tracks the closing command through its ``track`` method).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import control

from controllers.base import Observation, as_observation


class ContactGate:
    """Apply ``closing_command`` until the grip force reaches ``contact_force_n``.

    Parameters
    ----------
    controller : object
        A force controller with ``reset()``, ``act(obs)``, ``track(obs, u)`` and ``loop(plant)``.
    closing_command : float
        Normalized command while closing (real hands close fully in 0.4-1 s).
    contact_force_n : float
        Grip force that counts as contact, N.
    release_below_n : float
        A reference below this (N) opens the hand: the gate re-arms, and
        ``opening_command`` is applied once the force has gone.
    opening_command : float
        Normalized command while open or opening (negative opens).
    force_per_command_n : float, optional
        Static grip force per unit command at the operating point (N), e.g.
        ``y0_n / u0`` of the design plant. When given, the hand-over at contact
        starts the force controller from the feedforward command
        ``reference_n / force_per_command_n`` instead of the closing command:
        the closing command holds far more force than a light grasp needs, and
        a controller that starts from it overshoots while it unwinds.
    """

    def __init__(
        self,
        controller: Any,
        *,
        closing_command: float = 0.2,
        contact_force_n: float = 0.5,
        release_below_n: float = 0.1,
        opening_command: float = -0.3,
        force_per_command_n: float | None = None,
    ) -> None:
        if contact_force_n <= 0:
            raise ValueError(f"ContactGate: expected contact_force_n > 0, found {contact_force_n}")
        self.controller = controller
        self.closing_command = float(closing_command)
        self.contact_force_n = float(contact_force_n)
        self.release_below_n = float(release_below_n)
        self.opening_command = float(opening_command)
        if force_per_command_n is not None and not force_per_command_n > 0:
            raise ValueError(
                f"ContactGate: expected force_per_command_n > 0, found {force_per_command_n}"
            )
        self.force_per_command_n = force_per_command_n
        self.name = getattr(controller, "name", "controller")
        self.reset()

    def reset(self) -> None:
        """Back to the closing phase; resets the wrapped controller."""
        self.in_contact = False
        self.controller.reset()

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Closing command before contact, the force controller's command after."""
        obs = as_observation(observation)
        if obs.reference_n < self.release_below_n:
            self.in_contact = False
            if obs.grip_force_n < self.contact_force_n:
                self.controller.track(obs, self.opening_command)
                return self.opening_command
            return self.controller.act(obs)
        if not self.in_contact and obs.grip_force_n >= self.contact_force_n:
            # Hand over: the wrapped controller's state (integrator, filter, the
            # MPC's observer) was fed a free-closing hand whose dynamics are not
            # the grasp's, so it restarts from the hand-over command.
            self.in_contact = True
            handover = self.closing_command
            if self.force_per_command_n is not None:
                handover = min(handover, obs.reference_n / self.force_per_command_n)
            self.controller.reset()
            self.controller.track(obs, handover)
        if self.in_contact:
            return self.controller.act(obs)
        self.controller.track(obs, self.closing_command)
        return self.closing_command

    def loop(self, plant: control.LTI) -> control.LTI:
        """The wrapped controller's loop (the gate is inactive around a steady grasp)."""
        return self.controller.loop(plant)
