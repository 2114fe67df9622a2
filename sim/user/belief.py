"""What a user believes of their prosthesis: how hard to contract for it, and how far to trust it.

A person who has practised with a myoelectric hand knows two things about it that a
novice does not:

* **how hard to contract** for a given grip: the calibration maps their contraction to a
  hand force, but the estimator may read low or high, so the practised user scales their
  contraction by a learnt ``gain``;
* **how variable it is**: the grip a contraction gives varies from lift to lift (the
  estimator's error and noise), and people keep a safety margin that grows with the
  variability they have met (Hadjiosif and Smith 2015, J Neurosci 35:9106).

The model, in log units of contraction (``sim.user.operator_params.OperatorParams`` holds
every parameter and its source):

* after a lift the user compares the level it needed with the one they planned:
  ``e = log(final_level / planned_level)``, one squeeze more (``log(1 + correction_gain)``)
  when the object was dropped, one less when it broke;
* the gain moves towards what was needed, ``log g <- log g + k_n e``, with a learning rate
  that falls as lifts accumulate, ``k_n = max(anticipation_weight / (n + 1),
  min_learning_rate)`` after ``n`` earlier lifts: the first lift programs the next one
  (Johansson and Westling 1984, 1988: after one lift of a new weight the grip is set for
  it), later errors are averaged, as an estimate of a device's bias from noisy outcomes
  should be (adaptation rates follow the measurement noise: Burge, Ernst and Banks 2008,
  J Vis 8(4):20); the floor keeps the belief following a device that changes;
* the variability estimate is a running mean square of the errors,
  ``u^2 <- (1 - uncertainty_rate) u^2 + uncertainty_rate e^2``;
* the safety margin covers it: ``1 + margin = (1 + intact_margin) exp(margin_per_uncertainty u)``.
  A novice's ``u`` is the prior that gives ``novice_margin``; a user whose lifts all go as
  planned (an intact hand, the oracle reference) sees ``u`` shrink and their margin come
  down to the intact hand's; a noisy estimator keeps it up.

A user whose plan couples grip to load (``Plan.couples_load``, the intact hand) aims, while
holding still, at the coupled grip of :mod:`sim.user.grip_load` (their pre-load plus the
margin over the weight's slip force); :meth:`ProsthesisBelief.aim_n` gives either aim.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from sim.user.grip_load import anticipated_grip_n
from sim.user.operator import Plan, TrialMemory
from sim.user.operator_params import OperatorParams


@dataclass(frozen=True)
class ProsthesisBelief:
    """A user's internal model of their prosthesis (module notes).

    Attributes
    ----------
    gain : float
        Contraction per newton asked, relative to the calibration's mapping
        (1: the user contracts as the calibration promises).
    uncertainty : float
        The user's estimate of the prosthesis's variability: the RMS of the log
        errors met (log units of contraction).
    lifts : int
        Trials this belief was learnt from.
    """

    gain: float
    uncertainty: float
    lifts: int = 0

    @classmethod
    def novice(cls, params: OperatorParams) -> ProsthesisBelief:
        """A user who has not practised: gain 1 and the prior that gives ``novice_margin``."""
        prior = math.log((1.0 + params.novice_margin) / (1.0 + params.intact_margin))
        return cls(1.0, prior / params.margin_per_uncertainty, 0)

    def margin(self, params: OperatorParams) -> float:
        """Safety margin over the slip force the user keeps (0.25 = 25 % above it)."""
        return (1.0 + params.intact_margin) * math.exp(
            params.margin_per_uncertainty * self.uncertainty) - 1.0

    def aim_n(self, plan: Plan, params: OperatorParams) -> float:
        """The hand grip the user aims at while holding the object still, N: the plan's
        aim at this belief's margin, or for a plan that couples grip to load
        (``plan.couples_load`` with an object to hold)
        :func:`sim.user.grip_load.anticipated_grip_n` under the object's weight alone
        (module notes)."""
        margin = self.margin(params)
        if plan.couples_load and plan.need_n is not None:
            return anticipated_grip_n(plan.need_n, margin, params.preload_n, 1.0, plan.break_n)
        return plan.aim_n(margin)

    def level(self, plan: Plan, params: OperatorParams) -> float:
        """The contraction (fraction of MVC, 0..1) the user plans for ``plan``."""
        base = plan.level_of(self.aim_n(plan, params))
        return float(min(max(self.gain * base, 0.0), 1.0))

    def learn(self, memory: TrialMemory, params: OperatorParams) -> ProsthesisBelief:
        """The belief after a trial (module notes); a trial with nothing planned teaches nothing."""
        if not (memory.planned_level > 0 and memory.final_level > 0):
            return self
        error = math.log(memory.final_level / memory.planned_level)
        squeeze = math.log1p(params.correction_gain)
        if memory.drop_seen:
            error += squeeze
        elif memory.break_seen:
            error -= squeeze
        rate = max(params.anticipation_weight / (self.lifts + 1), params.min_learning_rate)
        gain = self.gain * math.exp(rate * error)
        r = params.uncertainty_rate
        u = math.sqrt((1.0 - r) * self.uncertainty ** 2 + r * error ** 2)
        return ProsthesisBelief(gain, u, self.lifts + 1)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ProsthesisBelief:
        """The belief :meth:`to_dict` wrote (ValueError if a field is missing or not finite)."""
        gain, u, lifts = float(data["gain"]), float(data["uncertainty"]), int(data["lifts"])
        if not (math.isfinite(gain) and gain > 0 and math.isfinite(u) and u >= 0 and lifts >= 0):
            raise ValueError(f"belief: expected gain > 0, uncertainty >= 0, lifts >= 0, "
                             f"found {data!r}")
        return cls(gain, u, lifts)
