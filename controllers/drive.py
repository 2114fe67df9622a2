"""A controller driving the MuJoCo hand, as the prosthesis runs it.

At every control step the controller computes its command from the last
observation (:func:`controllers.base.observation_from_info`); the hand receives
it one control period later, which is the computation delay every loop
analysis here includes. An episode and a loop measurement both drive the hand
through :class:`HandLoop`, so they run the same loop.
"""

from __future__ import annotations

import time
from typing import Any, Protocol

import numpy as np

from controllers.base import observation_from_info
from sim.hand.grasp_env import GraspEnv


class _Acting(Protocol):
    def reset(self) -> None: ...

    def act(self, observation: Any) -> float: ...


class HandLoop:
    """Closes a controller around a :class:`sim.hand.grasp_env.GraspEnv` with one period of delay.

    Parameters
    ----------
    env : GraspEnv
        The hand and its object; :meth:`reset` resets it.
    controller : object
        ``reset()`` and ``act(observation) -> command`` (normalized, -1..1).

    Attributes
    ----------
    info : dict
        The environment's ``info`` after the last reset or step.
    observation : Observation or None
        What the controller acted on at the last step.
    computed : float
        The command the controller computed at the last step (the hand receives it
        at the next).
    controller_s, physics_s : float
        Wall time spent in ``controller.act`` and in ``env.step`` since the reset, s.
    """

    def __init__(self, env: GraspEnv, controller: _Acting) -> None:
        self.env = env
        self.controller = controller
        self.info: dict[str, Any] = {}
        self.controller_s = 0.0
        self.physics_s = 0.0
        self._pending = 0.0
        self._action = np.zeros(1, dtype=np.float32)
        self.observation: Any = None
        self.computed = 0.0

    def reset(self, seed: int) -> dict[str, Any]:
        """Reset the controller, then the environment with ``seed``; return its ``info``."""
        self.controller.reset()
        _, self.info = self.env.reset(seed=seed)
        self._pending = 0.0
        self.controller_s = self.physics_s = 0.0
        return self.info

    def step(self, reference_n: float, disturbance: float = 0.0,
             bounds: tuple[float, float] | None = None) -> tuple[float, float, bool]:
        """One control period: compute the next command, apply the previous one.

        Parameters
        ----------
        reference_n : float
            Grip-force reference the controller tracks at this step, N.
        disturbance : float
            Added to the delivered command at the plant input (command units).
        bounds : (float, float), optional
            Clip the computed command to ``lo..hi`` (a paradigm's speed and direction:
            :func:`controllers.paradigms.command_range`); ``None``: the controller's own.

        Returns
        -------
        delivered : float
            The command the controller computed one period ago (the hand's input
            before the disturbance).
        applied : float
            The plant input, ``delivered + disturbance`` as the float32 action sent.
        done : bool
            The environment terminated or truncated the episode.
        """
        t0 = time.perf_counter()
        self.observation = observation = observation_from_info(self.info, reference_n)
        u = self.controller.act(observation)
        if bounds is not None:
            lo, hi = bounds
            u = lo if u < lo else hi if u > hi else u
        t1 = time.perf_counter()
        delivered = self._pending
        self._action[0] = delivered + disturbance
        _, _, terminated, truncated, self.info = self.env.step(self._action)
        self.physics_s += time.perf_counter() - t1
        self.controller_s += t1 - t0
        self._pending = self.computed = u
        return delivered, float(self._action[0]), bool(terminated or truncated)
