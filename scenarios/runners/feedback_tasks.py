"""The benchmarks prosthetics research uses, as scenario kinds: eggs, slip recovery, force matching.

Each kind runs one virtual user (a calibrated subject and an operator model,
:mod:`sim.user.operator`) with one feedback mode through several closed-loop
trials on the MuJoCo hand, and returns a flat result row; the commands
(``griploop eggs``, ``slip-recovery``, ``force-matching``) sweep subjects x
feedback modes (x eggs or targets) and compare the modes side by side with
95 % confidence intervals (:func:`aggregate`).

``eggs`` (protocol ``virtual_eggs``), after the Virtual Eggs Test (Controzzi et al.)
    One block (``vet_block``, breaking at ``object.break_force_n``) is grasped,
    lifted and held ``protocol.trials`` times by the same user, who plans each
    transfer from the last (anticipatory scaling). A transfer is *broken*
    (the grip exceeded the break force), *dropped* (not lifted, or fell) or a
    *success*. The test's 11 eggs break at 0.4-11.5 N; :data:`EGG_BREAK_FORCES_N`
    spaces them logarithmically over that range (the spacing is ours).
``slip_recovery`` (protocol ``slip_recovery``)
    The user lifts the object and holds it; half a second after the lift a
    load hung on the object rises at ``protocol.load_rate_n_s`` until the
    object starts to slip (the hand's slip speed exceeds 5 mm/s: the
    disturbance is the task's, the user perceives only through their
    channels), then stays. The trial is *recovered* when the object is still
    in the hand :data:`RECOVERY_WINDOW_S` later. Trials whose object was not
    lifted, or never slipped, are counted apart (not in ``n``).
``force_matching`` (protocol ``force_matching``)
    The hand closes on an object resting on the table (no lift) and the user
    holds ``protocol.target_fraction`` of the hand force at their MVC for
    ``protocol.hold_s``; the row has the mean grip force over that hold, its
    absolute error from the target and its coefficient of variation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from controllers.design_cache import grasp_design
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.runners.calibration import Calibration, shared_calibration
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.episode import (
    HAND_FORCE_AT_MVC_N,
    LIFT_DURATION_S,
    _lift_time_s,
    controller_spec,
    run_trial,
    scenario_object,
)
from scenarios.runners.episode_metrics import was_lifted
from scenarios.runners.reference import hold_level_for, intended_grip_n
from scenarios.runners.subject import subject_for
from scenarios.schema import Scenario
from sim.hand.grasp_env import WristSchedule
from sim.user.operators import make_operator

EGG_BREAK_FORCES_N = tuple(float(f) for f in np.round(np.geomspace(0.4, 11.5, 11), 2))
"""The 11 eggs' break forces, N: 0.4-11.5 N (Controzzi et al.), log-spaced here."""
TARGET_FRACTIONS = (0.2, 0.4, 0.6)
"""Force-matching targets, fractions of the hand force at the user's MVC."""
RECOVERY_WINDOW_S = 2.0
"""Slip recovery: the object must still be held this long after the slip started, s."""
LOAD_DELAY_S = 0.5
"""Slip recovery: the load starts rising this long after the lift ends, s."""
SLIP_ONSET_M_S = 0.005
"""Slip recovery: slip speed at which the object has started to slip (a slip event), m/s."""
FORCE_MATCH_CONTACT_N = 0.5

def _calibration(scenario: Scenario, subject: Any, rng_seq: np.random.SeedSequence
                 ) -> Calibration:
    """:func:`~scenarios.runners.calibration.shared_calibration` for the scenario."""
    e, p = scenario.estimator, scenario.protocol
    return shared_calibration(
        subject, e.name, e.mode, seed_seq=rng_seq, generator=scenario.subject.generator,
        order=PAPER_ORDER if e.order is None else e.order,
        identification_fraction=p.identification_fraction, calibration_s=p.calibration_s,
        options=e.options)


class _Setup:
    """What every trial of a task scenario shares: the user, the object, the loop design."""

    def __init__(self, scenario: Scenario) -> None:
        u = scenario.user
        self.scenario = scenario
        self.operator = make_operator(u.kind, feedback=u.feedback, params=u.operator_params())
        self.subject = subject_for(scenario)
        self.obj = scenario_object(scenario)
        self.spec = controller_spec(scenario)
        self.dt = 1.0 / scenario.controller.control_hz
        root = np.random.SeedSequence(int(scenario.seed or 0))
        cal_seq, trial_seq = root.spawn(2)
        self.trial_seqs = [s.spawn(3) for s in trial_seq.spawn(scenario.protocol.trials)]
        self.cal = _calibration(scenario, self.subject, cal_seq)
        self.design = grasp_design(self.obj, scenario.controller.kind, self.dt, self.spec)
        self.timings = dict.fromkeys(("t_semg_s", "t_features_s", "t_estimator_s",
                                      "t_operator_s", "t_controller_s", "t_physics_s"), 0.0)

    def trial(self, i: int, *, goal_n: float, episode_s: float, lift_after_s: float,
              **kw: Any) -> Any:
        """Trial ``i`` (:func:`scenarios.runners.episode.run_trial`); physics divergence raises."""
        t = run_trial(self.subject, self.obj, self.cal, self.design, self.operator,
                      goal_n=goal_n, seeds=tuple(self.trial_seqs[i]),
                      generator=self.scenario.subject.generator, episode_s=episode_s,
                      lift_after_s=lift_after_s, control_dt_s=self.dt,
                      hand_force_at_mvc_n=HAND_FORCE_AT_MVC_N, timings=self.timings, **kw)
        if t.failure is not None:
            raise DivergedError(f"physics diverged at t = {t.info['time_s']:.3f} s: {t.failure}")
        return t

    def identity(self) -> dict[str, Any]:
        """The row fields naming the user, the object and the loop."""
        s = self.scenario
        return {"subject_id": self.subject.subject_id, "seed": int(s.seed or 0),
                "object_name": self.obj.name, "object_mass_kg": self.obj.mass_kg,
                "object_friction": self.obj.friction,
                "object_break_force_n": self.obj.break_force_n,
                "controller": s.controller.kind, "estimator": s.estimator.name,
                "mode": s.estimator.mode, "user": s.user.kind, "feedback": s.user.feedback,
                "trials": s.protocol.trials, "cal_r2": self.cal.r2}


# ---------------------------------------------------------------------- eggs
def run_eggs_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``eggs``: ``protocol.trials`` transfers of one egg (module notes).

    Returns
    -------
    dict
        The identity fields, ``break_force_n``, ``transfers``, ``success``,
        ``broken``, ``dropped``, ``success_rate``, ``user_corrections`` (over
        the transfers) and ``peak_force_n`` (mean over transfers of the peak
        grip), plus timings.
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = _Setup(scenario)
        if setup.obj.break_force_n is None:
            raise UnsupportedScenarioError("eggs: the object needs a break_force_n (found none)")
        lift_after_s = _lift_time_s(p.episode_s, p.hold_s)
        goal_n = intended_grip_n(setup.obj, scenario.controller.safety_factor)
        counts = {"success": 0, "broken": 0, "dropped": 0}
        corrections, peaks = 0, []
        for i in range(p.trials):
            t = setup.trial(i, goal_n=goal_n, episode_s=p.episode_s, lift_after_s=lift_after_s)
            lifted = was_lifted(t.traces["object_height_m"])
            if t.info["crushed"]:
                counts["broken"] += 1
            elif not lifted or t.info["dropped"]:
                counts["dropped"] += 1
            else:
                counts["success"] += 1
            corrections += setup.operator.corrections
            peaks.append(float(np.max(t.traces["grip_force_n"])))
    return {**setup.identity(), "break_force_n": float(setup.obj.break_force_n),
            "intended_grip_n": goal_n, "transfers": p.trials, **counts,
            "success_rate": counts["success"] / p.trials, "user_corrections": corrections,
            "peak_force_n": float(np.mean(peaks)), **setup.timings}


# ------------------------------------------------------------- slip recovery
class _RisingLoad:
    """The slip-recovery disturbance: a load that rises until the object slips, then stays.

    Reads the hand's ground truth (lift, slip speed): it is the task, not the user.
    """

    def __init__(self, start_s: float, rate_n_s: float) -> None:
        self.start_s = start_s
        self.rate = rate_n_s
        self.onset_s: float | None = None
        self.load_n = 0.0
        self._t0: float | None = None

    def __call__(self, t_s: float, info: Mapping[str, Any]) -> float:
        if self._t0 is None:
            if info["lifted"] and t_s >= self.start_s and not info["dropped"]:
                self._t0 = t_s
            return 0.0
        if self.onset_s is None:
            touching = info["thumb_contact"] or info["finger_contact"]
            if (touching and info["slip_speed_m_s"] > SLIP_ONSET_M_S) or info["dropped"]:
                self.onset_s = t_s
            else:
                self.load_n = self.rate * (t_s - self._t0)
        return self.load_n

    def done(self, t_s: float, info: Mapping[str, Any]) -> bool:
        """The trial has its answer: dropped, or held for the recovery window after the onset."""
        return self.onset_s is not None and (bool(info["dropped"])
                                             or t_s >= self.onset_s + RECOVERY_WINDOW_S)


def run_slip_recovery_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``slip_recovery``: ``protocol.trials`` rising loads (module notes).

    Returns
    -------
    dict
        The identity fields, ``n`` (trials that slipped), ``recovered``,
        ``not_lifted`` (the object was not lifted or fell before the load),
        ``no_slip`` (the load never made it slip within the episode),
        ``recovered_rate`` (``recovered / n``, None when ``n`` is 0),
        ``user_corrections``, ``slip_load_n`` (mean load at the slip onset)
        and ``reaction_s`` (mean time from the onset to the user's first
        correction decided after it, over trials with one).
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = _Setup(scenario)
        lift_after_s = _lift_time_s(p.episode_s, p.hold_s)
        goal_n = intended_grip_n(setup.obj, scenario.controller.safety_factor)
        n = recovered = not_lifted = no_slip = corrections = 0
        slip_loads: list[float] = []
        reactions: list[float] = []
        for i in range(p.trials):
            load = _RisingLoad(lift_after_s + LIFT_DURATION_S + LOAD_DELAY_S, p.load_rate_n_s)
            t = setup.trial(i, goal_n=goal_n, episode_s=p.episode_s, lift_after_s=lift_after_s,
                            load=load, until=load.done)
            corrections += setup.operator.corrections
            if load._t0 is None:
                not_lifted += 1
                continue
            if load.onset_s is None:
                no_slip += 1
                continue
            n += 1
            slip_loads.append(load.load_n)
            recovered += int(not t.info["dropped"])
            after = [c for c in setup.operator.correction_times if c >= load.onset_s]
            if after:
                reactions.append(after[0] - load.onset_s)
    return {**setup.identity(), "load_rate_n_s": p.load_rate_n_s, "n": n,
            "recovered": recovered, "not_lifted": not_lifted, "no_slip": no_slip,
            "recovered_rate": recovered / n if n else None, "user_corrections": corrections,
            "slip_load_n": float(np.mean(slip_loads)) if slip_loads else None,
            "reaction_s": float(np.mean(reactions)) if reactions else None, **setup.timings}


# ------------------------------------------------------------ force matching
def run_force_matching_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``force_matching``: hold a target force on the table (module notes).

    Returns
    -------
    dict
        The identity fields, ``target_fraction``, ``target_n``, ``mean_force_n``
        (hand grip force over the last ``hold_s``), ``abs_error_n``
        (``|mean - target|``), ``cv`` (SD over mean of the grip in that hold),
        ``user_cv`` (the same for the user's own force, mapped to the hand),
        ``user_corrections``; means over ``protocol.trials``.
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = _Setup(scenario)
        goal_n = p.target_fraction * HAND_FORCE_AT_MVC_N
        hold_level = hold_level_for(goal_n, setup.cal, setup.subject, HAND_FORCE_AT_MVC_N)
        never = WristSchedule(lift_after_s=math.inf)
        means, errors, cvs, user_cvs, corrections = [], [], [], [], 0
        for i in range(p.trials):
            t = setup.trial(i, goal_n=goal_n, episode_s=p.episode_s,
                            lift_after_s=math.inf, schedule=never, hold_level=hold_level)
            hold = t.traces["t_s"] >= p.episode_s - p.hold_s
            grip = t.traces["grip_force_n"][hold]
            user = t.stream.oracle_n[:t.traces["t_s"].size][hold]
            mean = float(np.mean(grip)) if grip.size else 0.0
            means.append(mean)
            errors.append(abs(mean - goal_n))
            cvs.append(float(np.std(grip) / mean) if mean > FORCE_MATCH_CONTACT_N else None)
            mu = float(np.mean(user)) if user.size else 0.0
            user_cvs.append(float(np.std(user) / mu) if mu > 0 else None)
            corrections += setup.operator.corrections

    def mean_of(values: Sequence[float | None]) -> float | None:
        kept = [v for v in values if v is not None]
        return float(np.mean(kept)) if kept else None

    return {**setup.identity(), "target_fraction": p.target_fraction, "target_n": goal_n,
            "mean_force_n": mean_of(means), "abs_error_n": mean_of(errors), "cv": mean_of(cvs),
            "user_cv": mean_of(user_cvs), "user_corrections": corrections, **setup.timings}
