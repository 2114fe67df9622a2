"""Closed-loop episodes: a virtual subject's intent, through sEMG and an estimator, to a grasp.

One episode joins every layer of griploop::

    VirtualSubject --paper session + FSR--> fitted estimator          (calibration)
    VirtualSubject --grasp-lift-hold intent--> sEMG --features every 125 ms-->
        estimator.step --> reference (held between updates) --> controller at the
        control rate --> GraspEnv (MuJoCo) --> grip force, slip, drop, crush

Conventions (documented choices):

- **Force mapping.** The estimator outputs the user's grip force in newtons
  (FSR scale). The prosthesis maps it to a hand reference proportionally:
  ``reference_n = estimate_n / mvc_cal_n * hand_force_at_mvc_n``, where
  ``mvc_cal_n`` is the largest FSR force of the calibration session (the
  user's strongest squeeze) and ``hand_force_at_mvc_n`` (default 30 N) is the
  hand force commanded at that effort. References are clipped to
  ``0..1.2 * hand_force_at_mvc_n``.
- **What the user intends.** The user aims at their safety margin over the
  object's slip threshold ``m g / (2 mu)``, at least 2 N, at most 70 % of a
  fragile object's break force, through the calibration's mapping and what
  they learnt of the prosthesis (:mod:`sim.user.belief`). By default a reacting
  user practises ``practice`` lifts of the object's class first
  (:mod:`scenarios.runners.practice`); ``practice=0`` is the novice, who aims at
  1.5 x the slip threshold as every user of griploop 0.4 did. The scripted user
  aims at that too. The controller's ``safety_factor`` is the controller's own
  (the MPC's sensed slip bound), not the user's.
- **Oracle.** ``estimator = "oracle"`` is a perfect force estimator: the user's
  true grip force (before the FSR) at each window, through the same mapping and
  hold. Its estimation error is zero by construction; it isolates the controller.
- **Modes.** ``free_run`` (default) uses sEMG only. ``one_step`` feeds the
  user's measured FSR force of the previous window, which assumes the user
  wears a force sensor (the paper's evaluation setting).
- **Timing.** Features every 125 ms; the reference is held between updates
  (zero before the first 400 ms window ends). The controller's command is
  applied one control period after the observation it was computed from,
  which is the computation delay its margins include.
- **Episode.** The reacting user paces the trial with their own arm
  (:mod:`sim.user.reacting`): they close the hand, lift once it looks secure,
  try again when the object stays behind, hold it ``hold_s`` in the air, put
  it down and let go; ``episode_s`` is the time limit (15 s by default) and a
  trial that runs out before a secure lift is ``not_lifted``
  (:mod:`scenarios.runners.trial_outcome`). The scripted user rests, ramps to
  the hold level in 0.5 s and holds, and the wrist lifts at ``episode_s -
  hold_s - 0.6 s`` once the grip is established (6 s episodes by default).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.design import ControllerDesign, worst_case
from controllers.design_cache import grasp_design
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.deploy.compiled import maybe_compiled
from scenarios.outcomes import PHASE_CODES
from scenarios.rows import WORST_FIELDS, EpisodeRow
from scenarios.runners.calibration import Calibration, CalibrationSettings
from scenarios.runners.episode_metrics import (
    contact_peak_ratio,
    episode_metrics,
    margin_fields,
    mpc_failures,
    operating_forces,
)
from scenarios.runners.operator_loop import STEP_MS, WINDOW_MS
from scenarios.runners.practice import (
    DEFAULT_PRACTICE,
    Interface,
    practice_object_for,
    practise,
)
from scenarios.runners.reference import grasp_task, intended_grip_n
from scenarios.runners.subject import subject_for
from scenarios.runners.trial import (  # noqa: F401  (re-exported: the episode's pieces)
    LIFT_DURATION_S,
    TIMING_KEYS,
    Trial,
    closed_loop,
    default_episode_s,
    lift_time_s,
    paces_itself,
    run_trial,
)
from scenarios.runners.trial_outcome import hold_window, judge_trial, safety_margin_pct
from scenarios.schema import Scenario
from sim.codec import state_space_matrices
from sim.hand.objects import ObjectSpec, make_object
from sim.user.belief import ProsthesisBelief
from sim.user.operator import Operator, OperatorParams
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject

#: Earlier names of :func:`closed_loop` and :func:`lift_time_s`, used across the runners.
_closed_loop = closed_loop
_lift_time_s = lift_time_s

HAND_FORCE_AT_MVC_N = 30.0


# ------------------------------------------------------------------------ episode
@dataclass
class EpisodeResult:
    """Outcome of :func:`run_episode`: a flat ``row`` of scalars and ``traces``."""

    row: dict[str, Any]
    traces: dict[str, np.ndarray] = field(default_factory=dict)
    design: ControllerDesign | None = None

    def as_result_row(self) -> dict[str, Any]:
        """The sweep store's format: scalars plus ``"traces"``."""
        return {**self.row, "traces": self.traces}


def scenario_object(scenario: Scenario) -> ObjectSpec:
    """The scenario's object: a library object with its overrides applied.

    ``stiffness_n_per_m`` becomes MuJoCo's contact time constant
    ``sqrt(mass_kg / stiffness)`` (a mass-spring with the object's mass), with
    the library's damping ratio.
    """
    o = scenario.object
    overrides: dict[str, Any] = {}
    for key in ("shape", "mass_kg", "friction", "break_force_n"):
        value = getattr(o, key)
        if value is not None:
            overrides[key] = value
    if o.size_m is not None:
        overrides["size_m"] = tuple(o.size_m)
    obj = make_object(o.name, **overrides)
    if o.stiffness_n_per_m is not None:
        timeconst = float(np.sqrt(obj.mass_kg / o.stiffness_n_per_m))
        obj = obj.replace(solref=(timeconst, obj.solref[1]))
    return obj


def run_episode(
    subject: VirtualSubject,
    obj: ObjectSpec,
    *,
    estimator: str = "ss_kf",
    mode: str = "free_run",
    controller: str = "pid",
    controller_spec: Mapping[str, Any] | None = None,
    seed: int = 0,
    generator: str = "noise",
    order: int = PAPER_ORDER,
    identification_fraction: float = 0.5,
    calibration_s: float | None = None,
    episode_s: float | None = None,
    hold_s: float = 2.0,
    control_dt_s: float = 0.01,
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N,
    record_frames: bool = False,
    user: str = "reacting",
    feedback: str = "none",
    operator_params: OperatorParams | None = None,
    estimator_options: Mapping[str, Any] | None = None, practice: int = DEFAULT_PRACTICE,
    window_ms: float = WINDOW_MS, step_ms: float = STEP_MS, compiled: bool = False,
) -> EpisodeResult:
    """Calibrate, let the user practise, then run one closed-loop grasp-lift-hold trial.

    Parameters
    ----------
    subject, obj : VirtualSubject, ObjectSpec
        The user (with any electrode shift, noise or fatigue applied) and the object.
    estimator, mode : str
        Estimator name (:func:`estimation.registry.estimator_names`, ``"oracle"`` or
        ``"intact"``) and mode (``free_run``, ``one_step``; module notes).
    controller, controller_spec : str, mapping
        Registered controller kind and the keywords of
        :func:`controllers.design.design_for_object`.
    seed : int
        Seeds the calibration, the practice, the trial's sEMG, the networks and the hand.
    episode_s, hold_s : float
        The trial's time limit (a user who paces it; default 15 s) or the
        scripted episode's length (default 6 s), and the in-air hold, s.
    control_dt_s, record_frames : float, bool
        Control period, s (a multiple of the 2 ms physics step); also return RGB frames.
    user, feedback : str
        User kind (:mod:`sim.user.operators`: ``reacting``, the default, sees, corrects
        and moves their own arm; ``scripted`` follows the intent profile) and feedback.
    operator_params, estimator_options : optional
        The user's parameters (default ``OperatorParams``); the estimator's own.
    practice, window_ms, step_ms : int, float, float
        Practice lifts of the object's class first (a user who learns; 0: the novice);
        the feature window and its increment, ms (the paper's 400 and 125).
    compiled : bool
        Run the trial's estimator and controller as C (:mod:`scenarios.deploy.compiled`).

    Raises
    ------
    UnsupportedScenarioError
        No time to grasp before a scripted lift, an estimator mode that does not exist,
        or a reacting user with a generator that cannot run causally (``motor_units``).
    DivergedError
        Unstable identified model in free run, or physics divergence.
    sim.user.operators.UnknownOperatorError, sim.user.operators.UnknownFeedbackError, \
sim.user.operator.OperatorError
        Unknown user kind or feedback mode, or a feedback mode for the scripted user.
    """
    operator = make_operator(user, feedback=feedback, params=operator_params)
    self_paced = paces_itself(operator)
    episode_s = default_episode_s(operator) if episode_s is None else float(episode_s)
    lift_after_s = float("inf") if self_paced else lift_time_s(episode_s, hold_s)
    cal_seq, episode_seq, env_seq, operator_seq, practice_seq = seed_sequences(seed)
    timings, params = dict.fromkeys(TIMING_KEYS, 0.0), operator_params or OperatorParams()
    settings = CalibrationSettings(estimator, mode, order, generator, identification_fraction,
                                   calibration_s, estimator_options, window_ms, step_ms)
    with one_blas_thread():
        cal = settings.fit(subject, cal_seq)
        design = grasp_design(obj, controller, control_dt_s, controller_spec)
        if self_paced and practice > 0:
            practise(operator, subject, cal, Interface(
                settings, controller, dict(controller_spec or {}), practice_object_for(obj),
                user, feedback, params, control_dt_s, hand_force_at_mvc_n),
                cal_seq=cal_seq, n_lifts=practice, seed_seq=practice_seq)
        cal, design = maybe_compiled(compiled, cal, design, hand_force_at_mvc_n)
        belief = getattr(operator, "belief", None)  # what the trial is planned with
        trial = run_trial(subject, obj, cal, design, operator, goal_n=intended_grip_n(obj),
                          seeds=(episode_seq, env_seq, operator_seq), generator=generator,
                          episode_s=episode_s, lift_after_s=lift_after_s,
                          control_dt_s=control_dt_s, hand_force_at_mvc_n=hand_force_at_mvc_n,
                          timings=timings, record_frames=record_frames,
                          task=grasp_task(obj, hold_s=hold_s) if self_paced else None,
                          window_ms=window_ms, step_ms=step_ms)
    trial.raise_if_diverged()
    row = {"subject_id": subject.subject_id, "seed": int(seed), **_object_fields(obj),
           "controller": controller, "estimator": estimator, "mode": mode,
           "scheduled": bool(design.scheduled), "user": user, "feedback": feedback,
           "practice": int(practice) if self_paced else 0, **_belief_fields(belief, params),
           "window_ms": float(window_ms), "step_ms": float(step_ms),
           **_operator_fields(operator)}
    return _episode_result(row, cal, design, trial, obj, timings, target_n=_aim_n(
        belief, params, obj), lift_after_s=lift_after_s, hold_from_s=episode_s - hold_s,
        control_dt_s=control_dt_s)


def seed_sequences(seed: int) -> list[np.random.SeedSequence]:
    """The episode's five seeds: calibration, the trial's sEMG, the hand, the user, practice."""
    return np.random.SeedSequence(seed).spawn(5)


def _belief_fields(belief: ProsthesisBelief | None, params: OperatorParams) -> dict[str, Any]:
    """What the user believed of the prosthesis (None for a user who does not learn)."""
    if belief is None:
        return {"belief_gain": None, "belief_margin_pct": None}
    return {"belief_gain": float(belief.gain), "belief_margin_pct": 100.0 * belief.margin(params)}


def _aim_n(belief: ProsthesisBelief | None, params: OperatorParams, obj: ObjectSpec) -> float:
    """The grip force the user aimed at, N (their margin; the novice's for a user without one)."""
    return intended_grip_n(obj) if belief is None else intended_grip_n(
        obj, 1.0 + belief.margin(params))


def _object_fields(obj: ObjectSpec) -> dict[str, Any]:
    """The object's columns of an episode row."""
    return {"object_name": obj.name, "object_mass_kg": obj.mass_kg,
            "object_friction": obj.friction, "object_break_force_n": obj.break_force_n}


def _operator_fields(operator: Operator) -> dict[str, Any]:
    """How the user corrected the grasp: the count and the time of the first correction."""
    times = operator.correction_times
    return {"user_corrections": int(operator.corrections),
            "first_correction_s": float(times[0]) if times else None}


def _episode_result(row: dict[str, Any], cal: Calibration, design: ControllerDesign,
                    trial: Trial, obj: ObjectSpec, timings: dict[str, float], *,
                    target_n: float, lift_after_s: float, hold_from_s: float,
                    control_dt_s: float) -> EpisodeResult:
    """Metrics, outcome, margins at the forces visited and timings of a finished episode.

    Parameters
    ----------
    row : dict
        The episode's identity (subject, object, controller, estimator), extended here.
    trial : Trial
        The trial's traces (``n_run`` steps, fewer than the stream's if it ended
        early), the environment's last ``info`` and, for a trial the user paced,
        its referee.
    target_n : float
        The grip force the user intended, N.
    lift_after_s, hold_from_s : float
        The scripted schedule's lift and in-air hold, s (a trial the user paced
        reads both from its referee).
    """
    traces, info, stream, referee = trial.traces, trial.info, trial.stream, trial.referee
    n_run = traces["grip_force_n"].size
    t = traces["t_s"]
    hold = None
    if referee is not None:
        hold = hold_window(t, traces["wrist_height_m"], referee.secure_lift_s, referee.fell_s)
        rising = np.flatnonzero(traces["wrist_height_m"] > 0.0)
        lift_after_s = float(t[rising[0]]) if rising.size else float(t[-1]) + control_dt_s
    lifted, dropped, crushed, outcome = judge_trial(traces, info, referee)
    metrics = episode_metrics(stream.t_s[:n_run], stream.reference_n[:n_run],
                              traces["grip_force_n"], stream.oracle_n[:n_run],
                              start_s=stream.start_s, lift_s=lift_after_s,
                              hold_from_s=hold_from_s, hold=hold,
                              window_values_n=stream.window_values_n,
                              window_dt_s=stream.window_dt_s)
    ratio, both_s = contact_peak_ratio(t, traces["tracked_reference_n"],
                                       traces["grip_force_n"], traces["both_sides"])
    held_n, visited_n = operating_forces(traces, design, hold_from_s=hold_from_s,
                                         both_sides_s=both_s, hold=hold)
    analysed = design.analyse_many([*visited_n, *([] if held_n is None else [held_n])])
    held = analysed[-1] if held_n is not None else None
    worst = worst_case(analysed[:len(visited_n)]) if visited_n else {}
    simulated = t[-1] + control_dt_s
    loop_time = sum(timings[k] for k in TIMING_KEYS)
    if hold is None:  # the scripted schedule: the last hold_s, where the object was in the air
        hold = (t >= hold_from_s) if lifted and not dropped else np.zeros(t.size, dtype=bool)
    row = EpisodeRow.build(**{
        **row,
        **metrics,
        "intended_grip_n": target_n,
        "slip_events": int(info["slip_events"]), "slip_distance_m": float(info["slip_distance_m"]),
        "lifted": lifted, "dropped": dropped, "crushed": crushed, "outcome": outcome,
        "attempts": trial.attempts,
        "time_to_lift_s": None if referee is None else referee.time_to_lift_s,
        "safety_margin_pct": safety_margin_pct(traces["grip_force_n"], hold, obj)
        if outcome == "held" else None,
        "contact_peak_ratio": ratio, "both_sides_time_s": both_s,
        "held_force_n": held_n,
        "visited_forces_n": ",".join(f"{f:g}" for f in visited_n),
        **margin_fields(held),
        **dict.fromkeys(WORST_FIELDS),  # no visited force: no worst case
        **{f"worst_{k}": v for k, v in worst.items()},
        "loop_dt_s": float(control_dt_s),
        "mpc_failures": mpc_failures(design),
        "cal_r2": cal.r2, "cal_mvc_n": cal.mvc_cal_n, "fit_s": cal.fit_s,
        **timings,
        "simulated_s": float(simulated),
        "realtime_factor": float(simulated / loop_time) if loop_time > 0 else None,
    }).as_dict()
    traces["intent_n"] = stream.oracle_n[:n_run]
    if trial.phases is not None:
        traces["phase"] = _phase_trace(t, trial.phases)
    if held is not None and held.ok:
        A, B, C, D = state_space_matrices(held.margins, "loop")
        traces.update(loop_A=A, loop_B=B, loop_C=C, loop_D=D)
    return EpisodeResult(row=row, traces=traces, design=design)




def _phase_trace(t_s: np.ndarray, phases: list[tuple[float, str]]) -> np.ndarray:
    """The user's phase at each control step, coded by :data:`PHASE_CODES`."""
    out = np.zeros(t_s.size, dtype=np.int8)
    for t0, name in phases:
        out[t_s >= t0 - 1e-9] = PHASE_CODES.index(name)
    return out


# ------------------------------------------------------------------------ runners
def controller_spec(scenario: Scenario) -> dict[str, Any]:
    """Keyword arguments of :func:`controllers.design.design_for_object` from a scenario."""
    c = scenario.controller
    spec: dict[str, Any] = {"phase_margin_deg": c.phase_margin_deg,
                            "crossover_rad_s": c.crossover_rad_s,
                            "bandwidth_rad_s": c.bandwidth_rad_s,
                            "safety_factor": c.safety_factor}
    if c.horizon is not None:  # set by the schema for the kinds that take one
        spec["horizon"] = c.horizon
    if c.solver is not None:  # QP solver of the kinds that solve one (default: the kind's)
        spec["solver"] = c.solver
    if c.slip_reflex.enabled:
        spec["slip_reflex"] = {"latency_s": c.slip_reflex.latency_s, "gain": c.slip_reflex.gain}
    if not c.scheduled:
        spec["scheduled"] = False
    spec.update(c.options)  # the kind's own declared options (validated by the schema)
    return spec


def episode_from_scenario(scenario: Scenario, *, record_frames: bool = False,
                          compiled: bool = False) -> EpisodeResult:
    """:func:`run_episode` with every argument taken from a validated scenario."""
    p, e = scenario.protocol, scenario.estimator
    return run_episode(
        subject_for(scenario), scenario_object(scenario), estimator=e.name, mode=e.mode,
        controller=scenario.controller.kind, controller_spec=controller_spec(scenario),
        seed=int(scenario.seed or 0), generator=scenario.subject.generator,
        order=PAPER_ORDER if e.order is None else e.order,
        identification_fraction=p.identification_fraction, calibration_s=p.calibration_s,
        episode_s=p.episode_s, hold_s=p.hold_s,
        control_dt_s=1.0 / scenario.controller.control_hz, record_frames=record_frames,
        user=scenario.user.kind, feedback=scenario.user.feedback,
        operator_params=scenario.user.operator_params(), estimator_options=e.options,
        practice=scenario.user.practice, window_ms=e.window_ms, step_ms=e.step_ms,
        compiled=compiled)


def run_episode_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of scenario kind ``episode`` (see :mod:`scenarios.runners.dispatch`)."""
    return episode_from_scenario(scenario).as_result_row()
