"""The user who follows the script: the plan's intent, whatever the hand does."""

from __future__ import annotations

from typing import Any

import numpy as np

from sim.user.operator import OperatorError, OperatorParams, Plan, TrialMemory, started, take


class ScriptedOperator:
    """The user who follows the script: the plan's intent, whatever the hand does.

    Takes no feedback (``feedback`` must be ``None`` or ``"none"``); makes no
    corrections and does not move the arm (the wrist follows its schedule); the
    paper's calibration session is this user.
    """

    name = "scripted"

    def __init__(self, params: OperatorParams | None = None, feedback: Any = None) -> None:
        if feedback is not None and getattr(feedback, "name", feedback) != "none":
            name = getattr(feedback, "name", feedback)
            raise OperatorError(
                f"feedback applies to the reacting user only: the scripted user takes "
                f"feedback none (found {name})")
        self.params = params or OperatorParams()
        self.corrections = 0
        self.correction_times: list[float] = []
        self._plan: Plan | None = None
        self._n = 0

    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None:
        """Begin a trial (the scripted user ignores ``rng``)."""
        self._plan, self._n, self.corrections = plan, 0, 0

    def perceive(self, scene: Any) -> None:
        """Nothing: the scripted user does not look."""

    def intent(self, n_samples: int) -> np.ndarray:
        """The plan's next ``n_samples`` of intent."""
        plan = started(self._plan)
        i0 = self._n
        self._n += n_samples
        return take(plan.intent, i0, n_samples)

    def finish(self) -> TrialMemory:
        """The trial as planned (nothing learnt)."""
        plan = started(self._plan)
        return TrialMemory(plan.hold_level, plan.hold_level)
