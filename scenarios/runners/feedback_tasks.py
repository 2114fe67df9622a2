"""The benchmarks prosthetics research uses, as scenario kinds: eggs, slip recovery, force matching.

Each kind runs one virtual user (a calibrated subject and an operator model,
:mod:`sim.user.operators`) with one feedback mode through several closed-loop
trials on the MuJoCo hand, and returns a flat result row; the commands
(``griploop eggs``, ``slip-recovery``, ``force-matching``) sweep subjects x
feedback modes (x eggs or targets) and compare the modes side by side with
95 % confidence intervals (:func:`scenarios.feedback_summary.aggregate`).
A reacting user practises ``user.practice`` lifts of the object's class with the
same prosthesis first (:mod:`scenarios.runners.practice`) and paces each trial
with their own arm (:mod:`sim.user.reacting`): they lift when the grip looks
secure and try again when the object stays behind. :class:`TaskSetup` holds what
the trials share; the timed transfers are :mod:`scenarios.runners.transfers`.

``eggs`` (protocol ``virtual_eggs``), after the Virtual Eggs Test (Controzzi et al.)
    One block (``vet_block``, breaking at ``object.break_force_n``) is grasped,
    lifted, held ``protocol.hold_s`` and put down ``protocol.trials`` times by the
    same user, who plans each transfer from the last. A transfer is *broken*
    (the grip exceeded the break force), *dropped* (fell, or not lifted within
    the trial's time) or a *success*. The test's 11 eggs break at 0.4-11.5 N;
    :data:`EGG_BREAK_FORCES_N` spaces them logarithmically over that range (the
    spacing is ours).
``slip_recovery`` (protocol ``slip_recovery``)
    The user lifts the object and holds it; half a second after the wrist reached
    the top of the lift a load hung on the object rises at
    ``protocol.load_rate_n_s`` until the object starts to slip (the hand's slip
    speed exceeds 5 mm/s: the disturbance is the task's, the user perceives only
    through their channels), then stays. The trial is *recovered* when the object
    is still in the hand
    :data:`~scenarios.runners.slip_perturbations.RECOVERY_WINDOW_S` later. Trials whose
    object was not lifted, or never slipped, are counted apart (not in ``n``). With
    ``protocol.perturbation: opening`` the hand opens involuntarily instead, at an
    unannounced time (Aboseria et al. 2018's protocol;
    :mod:`scenarios.runners.slip_perturbations`), and is counted the same way.
``force_matching`` (protocol ``force_matching``)
    The hand closes on an object resting on the table (no lift) and the user
    holds ``protocol.target_fraction`` of the hand force at their MVC for
    ``protocol.hold_s``; the row has the mean grip force over that hold, its
    absolute error from the target and its coefficient of variation.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from controllers.design_cache import grasp_design
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.runners.calibration import CalibrationSettings
from scenarios.runners.dispatch import UnsupportedScenarioError
from scenarios.runners.episode import (
    HAND_FORCE_AT_MVC_N,
    controller_spec,
    hand_settings,
    scenario_object,
)
from scenarios.runners.practice import Interface, practice_object_for, practise
from scenarios.runners.reference import Task, force_task, grasp_task
from scenarios.runners.slip_perturbations import LOAD_DELAY_S as LOAD_DELAY_S
from scenarios.runners.slip_perturbations import RECOVERY_WINDOW_S as RECOVERY_WINDOW_S
from scenarios.runners.slip_perturbations import SLIP_ONSET_M_S as SLIP_ONSET_M_S
from scenarios.runners.slip_perturbations import (
    HeldPerturbation,
    perturbation_for,
    row_fields,
)
from scenarios.runners.slip_perturbations import RisingLoad as RisingLoad
from scenarios.runners.subject import subject_for
from scenarios.runners.trial import TIMING_KEYS, Trial, TrialSetup, run_trial
from scenarios.runners.trial_loop import NO_HOOKS, TrialHooks
from scenarios.schema import Scenario
from sim.user.operators import make_operator

EGG_BREAK_FORCES_N = tuple(float(f) for f in np.round(np.geomspace(0.4, 11.5, 11), 2))
"""The 11 eggs' break forces, N: 0.4-11.5 N (Controzzi et al.), log-spaced here."""
TARGET_FRACTIONS = (0.2, 0.4, 0.6)
"""Force-matching targets, fractions of the hand force at the user's MVC."""
FORCE_MATCH_CONTACT_N = 0.5
TARGET_BAND = 0.1
"""Force matching: the grip has reached its target once within this fraction of it."""


def calibration_settings(scenario: Scenario) -> CalibrationSettings:
    """How the scenario's estimator is calibrated."""
    e, p = scenario.estimator, scenario.protocol
    return CalibrationSettings(e.name, e.mode, PAPER_ORDER if e.order is None else e.order,
                               scenario.subject.generator, p.identification_fraction,
                               p.calibration_s, e.options, e.window_ms, e.step_ms,
                               hand_settings(scenario).effective_decoder)


class TaskSetup:
    """What every trial of a task scenario shares: the user, their practice, the object, the loop.

    The user practises ``user.practice`` lifts of the object's class first
    (:mod:`scenarios.runners.practice`), then runs the task's trials in a row, each
    planned from the last. The seeds of the calibration, the practice and the trials
    derive from the scenario's seed.
    """

    def __init__(self, scenario: Scenario) -> None:
        u = scenario.user
        self.scenario = scenario
        self.params = u.operator_params()
        self.operator = make_operator(u.kind, feedback=u.feedback, params=self.params)
        self.subject = subject_for(scenario)
        self.obj = scenario_object(scenario)
        self.spec = controller_spec(scenario)
        self.dt = 1.0 / scenario.controller.control_hz
        p = scenario.protocol
        self.episode_s = float(self.operator.default_trial_s if p.episode_s is None
                               else p.episode_s)
        root = np.random.SeedSequence(int(scenario.seed or 0))
        cal_seq, trial_seq, practice_seq = root.spawn(3)
        self.trial_seqs = [s.spawn(3) for s in trial_seq.spawn(p.trials)]
        settings = calibration_settings(scenario)
        self.cal = settings.fit(self.subject, cal_seq)
        self.hand = hand_settings(scenario).check()
        design = grasp_design(self.obj, scenario.controller.kind, self.dt,
                              self.hand.controller_spec(self.spec))
        self.practice = practise(self.operator, self.subject, self.cal, Interface(
            settings, scenario.controller.kind, self.spec, practice_object_for(self.obj), u.kind,
            u.feedback, self.params, self.dt, HAND_FORCE_AT_MVC_N, self.hand),
            cal_seq=cal_seq, n_lifts=int(u.practice), seed_seq=practice_seq)
        e = scenario.estimator
        self.setup = TrialSetup(self.subject, self.obj, self.cal, design,
                                scenario.subject.generator, self.dt, HAND_FORCE_AT_MVC_N,
                                e.window_ms, e.step_ms, self.hand)
        self.timings = dict.fromkeys(TIMING_KEYS, 0.0)

    def grasp_task(self, *, hold_s: float, place: bool = True) -> Task:
        """Grasping, lifting and holding the object ``hold_s`` within the trial's limit."""
        return grasp_task(self.obj, hold_s=hold_s, place=place, limit_s=self.episode_s)

    def trial(self, i: int, task: Task, hooks: TrialHooks = NO_HOOKS) -> Trial:
        """Trial ``i`` of ``task`` (:func:`scenarios.runners.trial.run_trial`); physics
        divergence raises; its timings add to ``timings``."""
        if not self.scenario.user.vision:  # vision occluded in the measured trials only
            task = replace(task, sees=False)
        t = run_trial(self.setup, self.operator, task, tuple(self.trial_seqs[i]), hooks)
        t.raise_if_diverged()
        for key, value in t.timings.items():
            self.timings[key] += value
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
                "practice": self.practice, "window_ms": s.estimator.window_ms,
                "step_ms": s.estimator.step_ms, "trials": s.protocol.trials,
                "cal_r2": self.cal.r2, **self.hand.fields()}


# ---------------------------------------------------------------------- eggs
def run_eggs_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``eggs``: ``protocol.trials`` transfers of one egg (module notes).

    Returns
    -------
    dict
        The identity fields, ``break_force_n``, ``transfers``, ``success``,
        ``broken``, ``dropped`` (dropped, or not lifted within the trial),
        ``success_rate``, ``user_corrections`` (over the transfers) and
        ``peak_force_n`` (mean over transfers of the peak grip), plus timings.
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = TaskSetup(scenario)
        if setup.obj.break_force_n is None:
            raise UnsupportedScenarioError("eggs: the object needs a break_force_n (found none)")
        task = setup.grasp_task(hold_s=p.hold_s)
        goal_n = task.goal_n
        counts = {"success": 0, "broken": 0, "dropped": 0}
        corrections, peaks = 0, []
        for i in range(p.trials):
            t = setup.trial(i, task)
            outcome = t.referee.outcome
            key = {"held": "success", "crushed": "broken"}.get(outcome, "dropped")
            counts[key] += 1
            corrections += setup.operator.corrections
            peaks.append(float(np.max(t.traces["grip_force_n"])))
    return {**setup.identity(), "break_force_n": float(setup.obj.break_force_n),
            "intended_grip_n": goal_n, "transfers": p.trials, **counts,
            "success_rate": counts["success"] / p.trials, "user_corrections": corrections,
            "peak_force_n": float(np.mean(peaks)), **setup.timings}


# ------------------------------------------------------------- slip recovery
def slip_trials(setup: TaskSetup, scenario: Scenario) -> Iterator[tuple[Any, HeldPerturbation]]:
    """The slip-recovery trials of ``scenario``, each with its perturbation, as they end.

    Yields ``(trial, perturbation)`` for each of ``protocol.trials`` perturbations of
    the held object (:mod:`scenarios.runners.slip_perturbations`: a rising load or an
    involuntary opening; :func:`run_slip_recovery_scenario` counts them; an analysis
    reads their traces: ``perturbation.onset_s`` is the slip onset, ``None`` when it
    never slipped).
    """
    p = scenario.protocol
    task = setup.grasp_task(hold_s=p.hold_s, place=False)  # held to the end
    for i in range(p.trials):
        perturbation, hooks = perturbation_for(p, task.lift_height_m, setup.trial_seqs[i])
        yield setup.trial(i, task, hooks), perturbation


def run_slip_recovery_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``slip_recovery``: ``protocol.trials`` perturbations (module notes).

    Returns
    -------
    dict
        The identity fields, the perturbation's own
        (:func:`~scenarios.runners.slip_perturbations.row_fields`: ``load_rate_n_s`` and
        ``slip_load_n`` (mean load at the slip onset) for the rising load;
        ``perturbation``, ``opening``, ``opening_window_s`` and ``drop_n`` for the
        opening), ``n`` (trials that slipped), ``recovered``, ``not_lifted`` (the
        object was not lifted or fell before the perturbation), ``no_slip`` (the
        perturbation did not make it slip), ``recovered_rate`` (``recovered / n``, None
        when ``n`` is 0), ``user_corrections`` and ``reaction_s`` (mean time from the
        onset to the user's first correction decided after it, over trials with one).
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = TaskSetup(scenario)
        n = recovered = not_lifted = no_slip = corrections = 0
        slipped: list[HeldPerturbation] = []
        reactions: list[float] = []
        for t, perturbation in slip_trials(setup, scenario):
            corrections += setup.operator.corrections
            if not perturbation.started:
                not_lifted += 1
                continue
            if perturbation.onset_s is None:
                no_slip += 1
                continue
            n += 1
            slipped.append(perturbation)
            recovered += int(perturbation.recovered(t.info))
            after = [c for c in setup.operator.correction_times if c >= perturbation.onset_s]
            if after:
                reactions.append(after[0] - perturbation.onset_s)
    before, own = row_fields(p, slipped)
    return {**setup.identity(), **before, "n": n,
            "recovered": recovered, "not_lifted": not_lifted, "no_slip": no_slip,
            "recovered_rate": recovered / n if n else None, "user_corrections": corrections,
            **own, "reaction_s": float(np.mean(reactions)) if reactions else None,
            **setup.timings}


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
        ``time_to_target_s`` (from the user's contraction onset to the first step where
        the grip is within :data:`TARGET_BAND` of the target; ``None`` when it never is),
        ``user_corrections``; means over ``protocol.trials``.
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = TaskSetup(scenario)
        goal_n = p.target_fraction * HAND_FORCE_AT_MVC_N
        on_table = force_task(goal_n, limit_s=setup.episode_s)
        means, errors, cvs, user_cvs, reach, corrections = [], [], [], [], [], 0
        for i in range(p.trials):
            t = setup.trial(i, on_table)
            within = np.flatnonzero(np.abs(t.traces["grip_force_n"] - goal_n)
                                    <= TARGET_BAND * goal_n)
            reach.append(float(t.traces["t_s"][within[0]]) - t.stream.start_s
                         if within.size else None)
            hold = t.traces["t_s"] >= setup.episode_s - p.hold_s
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
            "user_cv": mean_of(user_cvs), "time_to_target_s": mean_of(reach),
            "user_corrections": corrections, **setup.timings}
