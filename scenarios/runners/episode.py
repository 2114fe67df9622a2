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
  the hold level in 0.5 s and holds, and lifts their arm at ``episode_s -
  hold_s - 0.6 s`` once the grip is established (6 s episodes by default),
  holding until the end. Every trial runs the one trial loop and is judged by
  one referee (:mod:`scenarios.runners.trial_loop`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
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
from scenarios.runners.practice import (
    DEFAULT_PRACTICE,
    Interface,
    practice_object_for,
    practise,
)
from scenarios.runners.reference import grasp_task
from scenarios.runners.semg_reference import STEP_MS, WINDOW_MS
from scenarios.runners.subject import subject_for
from scenarios.runners.trial import (
    HAND_FORCE_AT_MVC_N,
    TIMING_KEYS,
    Trial,
    TrialSetup,
    run_trial,
)
from scenarios.runners.trial_loop import DEFAULT_HAND, Frames, HandSettings, TrialHooks
from scenarios.runners.trial_outcome import judge
from scenarios.schema import Scenario
from sim.codec import state_space_matrices
from sim.hand.objects import ObjectSpec, make_object
from sim.user.belief import ProsthesisBelief
from sim.user.operator import Operator, OperatorParams
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject

__all__ = ["EpisodeResult", "EpisodeSpec", "HAND_FORCE_AT_MVC_N", "controller_spec",
           "episode_from_scenario", "episode_spec", "run_episode", "run_episode_scenario",
           "hand_settings", "scenario_object", "seed_sequences"]


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


@dataclass(frozen=True)
class EpisodeSpec:
    """How one episode runs, besides its subject and object (a scenario's fields:
    :func:`episode_spec`).

    Attributes
    ----------
    estimator, mode : str
        Estimator name (:func:`estimation.registry.estimator_names`, ``"oracle"``,
        ``"intact"`` or ``"ideal_interface"``) and mode (``free_run``, ``one_step``; module
        notes).
    controller : str
        Registered controller kind.
    controller_spec : mapping, optional
        The flat design specification (:meth:`~controllers.design_spec.DesignSpec.from_mapping`).
    seed : int
        Seeds the calibration, the practice, the trial's sEMG, the networks and the hand.
    generator : str
        The sEMG generator.
    order, identification_fraction, calibration_s : int, float, float or None
        The calibration's model order, identifying share and session length.
    episode_s : float or None
        The trial's time limit, s (default: the user's own, 15 s for a user who paces
        the trial, 6 s for the scripted one).
    hold_s : float
        How long the object is held in the air, s.
    control_dt_s : float
        Control period, s (a multiple of the 2 ms physics step).
    hand_force_at_mvc_n : float
        Hand force at the user's calibration MVC, N.
    user, feedback : str
        User kind (:mod:`sim.user.operators`: ``reacting``, the default, sees, corrects
        and moves their own arm; ``scripted`` follows the intent profile and lifts at a
        set time) and feedback mode.
    operator_params : OperatorParams, optional
        The user's parameters (default ``OperatorParams()``).
    estimator_options : mapping, optional
        The estimator's own options.
    practice : int
        Practice lifts of the object's class first (a user who learns; 0: the novice).
    window_ms, step_ms : float
        The feature window and its increment, ms (the paper's 400 and 125).
    hand : HandSettings
        The hand's drive, paradigm and own slip response (default: today's hand).
    sees : bool
        The user sees the hand and the object (``False``: vision occluded,
        :attr:`sim.user.operator.Plan.sees`; practice is with vision).
    """

    estimator: str = "ss_kf"
    mode: str = "free_run"
    controller: str = "pid"
    controller_spec: Mapping[str, Any] | None = None
    seed: int = 0
    generator: str = "noise"
    order: int = PAPER_ORDER
    identification_fraction: float = 0.5
    calibration_s: float | None = None
    episode_s: float | None = None
    hold_s: float = 2.0
    control_dt_s: float = 0.01
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N
    user: str = "reacting"
    feedback: str = "none"
    operator_params: OperatorParams | None = None
    estimator_options: Mapping[str, Any] | None = None
    practice: int = DEFAULT_PRACTICE
    window_ms: float = WINDOW_MS
    step_ms: float = STEP_MS
    hand: HandSettings = DEFAULT_HAND
    sees: bool = True

    def calibration_settings(self) -> CalibrationSettings:
        """How the estimator is calibrated."""
        return CalibrationSettings(self.estimator, self.mode, self.order, self.generator,
                                   self.identification_fraction, self.calibration_s,
                                   self.estimator_options, self.window_ms, self.step_ms,
                                   self.hand.effective_decoder)


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


def run_episode(subject: VirtualSubject, obj: ObjectSpec, spec: EpisodeSpec = EpisodeSpec(),
                *, record_frames: bool = False, compiled: bool = False) -> EpisodeResult:
    """Calibrate, let the user practise, then run one closed-loop grasp-lift-hold trial.

    Parameters
    ----------
    subject, obj : VirtualSubject, ObjectSpec
        The user (with any electrode shift, noise or fatigue applied) and the object.
    spec : EpisodeSpec
        Everything else the episode runs with.
    record_frames : bool
        Also return RGB frames every 40 ms (``traces["frames"]``).
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
    hand = spec.hand.check()
    operator = make_operator(spec.user, feedback=spec.feedback, params=spec.operator_params)
    cal_seq, episode_seq, env_seq, operator_seq, practice_seq = seed_sequences(spec.seed)
    params = spec.operator_params or OperatorParams()
    settings = spec.calibration_settings()
    with one_blas_thread():
        cal = settings.fit(subject, cal_seq)
        design = grasp_design(obj, spec.controller, spec.control_dt_s,
                              hand.controller_spec(spec.controller_spec))
        practised = practise(operator, subject, cal, Interface(
            settings, spec.controller, dict(spec.controller_spec or {}),
            practice_object_for(obj), spec.user, spec.feedback, params, spec.control_dt_s,
            spec.hand_force_at_mvc_n, hand), cal_seq=cal_seq, n_lifts=spec.practice,
            seed_seq=practice_seq)
        cal, design = maybe_compiled(compiled, cal, design, spec.hand_force_at_mvc_n)
        belief = operator.belief  # what the trial is planned with
        setup = TrialSetup(subject, obj, cal, design, spec.generator, spec.control_dt_s,
                           spec.hand_force_at_mvc_n, spec.window_ms, spec.step_ms, hand)
        task = replace(grasp_task(obj, hold_s=spec.hold_s, limit_s=spec.episode_s),
                       sees=spec.sees)
        trial = run_trial(setup, operator, task, (episode_seq, env_seq, operator_seq),
                          TrialHooks(frames=Frames() if record_frames else None))
    trial.raise_if_diverged()
    row = {"subject_id": subject.subject_id, "seed": int(spec.seed), **_object_fields(obj),
           "controller": spec.controller, "estimator": spec.estimator, "mode": spec.mode,
           "scheduled": bool(design.scheduled), "user": spec.user, "feedback": spec.feedback,
           "practice": practised, **_belief_fields(belief, params),
           "window_ms": float(spec.window_ms), "step_ms": float(spec.step_ms),
           **hand.fields(), **_operator_fields(operator)}
    aim_n = trial.memory.aim_n if trial.memory.aim_n is not None else task.goal_n
    return _episode_result(row, cal, design, trial, obj, target_n=aim_n,
                           control_dt_s=spec.control_dt_s)


def seed_sequences(seed: int) -> list[np.random.SeedSequence]:
    """The episode's five seeds: calibration, the trial's sEMG, the hand, the user, practice."""
    return np.random.SeedSequence(seed).spawn(5)


def _belief_fields(belief: ProsthesisBelief | None, params: OperatorParams) -> dict[str, Any]:
    """What the user believed of the prosthesis (None for a user who does not learn)."""
    if belief is None:
        return {"belief_gain": None, "belief_margin_pct": None}
    return {"belief_gain": float(belief.gain), "belief_margin_pct": 100.0 * belief.margin(params)}


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
                    trial: Trial, obj: ObjectSpec, *, target_n: float,
                    control_dt_s: float) -> EpisodeResult:
    """Metrics, outcome, margins at the forces visited and timings of a finished episode.

    Parameters
    ----------
    row : dict
        The episode's identity (subject, object, controller, estimator), extended here.
    trial : Trial
        The trial's traces (``n_run`` steps, fewer than the stream's if it ended
        early), the environment's last ``info`` and its referee.
    target_n : float
        The grip force the user intended, N.
    """
    traces, info, stream = trial.traces, trial.info, trial.stream
    timings = trial.timings
    n_run = traces["grip_force_n"].size
    t = traces["t_s"]
    verdict = judge(traces, trial.referee, obj, control_dt_s=control_dt_s)
    hold = verdict.hold
    metrics = episode_metrics(stream.first(n_run), traces["grip_force_n"],
                              lift_s=verdict.lift_start_s, hold=hold)
    ratio, both_s = contact_peak_ratio(t, traces["tracked_reference_n"],
                                       traces["grip_force_n"], traces["both_sides"])
    held_n, visited_n = operating_forces(traces, design, hold=hold, both_sides_s=both_s)
    analysed = design.analyse_many([*visited_n, *([] if held_n is None else [held_n])])
    held = analysed[-1] if held_n is not None else None
    worst = worst_case(analysed[:len(visited_n)]) if visited_n else {}
    simulated = t[-1] + control_dt_s
    loop_time = sum(timings[k] for k in TIMING_KEYS)
    verdict_fields = verdict.fields()
    del verdict_fields["released"]
    row = EpisodeRow.build(**{
        **dict.fromkeys(("decoder", "decoder_windows", "unrequested_opens")),  # no decoder
        **row,
        **metrics,
        "intended_grip_n": target_n,
        "slip_events": int(info["slip_events"]), "slip_distance_m": float(info["slip_distance_m"]),
        **verdict_fields,
        "contact_peak_ratio": ratio, "both_sides_time_s": both_s,
        "held_force_n": held_n,
        "visited_forces_n": ",".join(f"{f:g}" for f in visited_n),
        **margin_fields(held),
        **dict.fromkeys(WORST_FIELDS),  # no visited force: no worst case
        **{f"worst_{k}": v for k, v in worst.items()},
        "loop_dt_s": float(control_dt_s),
        "mpc_failures": mpc_failures(design),
        "cal_r2": cal.r2, "cal_mvc_n": cal.mvc_cal_n, "fit_s": cal.fit_s,
        **trial.decoding,
        **timings,
        "simulated_s": float(simulated),
        "realtime_factor": float(simulated / loop_time) if loop_time > 0 else None,
    }).as_dict()
    traces["intent_n"] = stream.oracle_n[:n_run]
    if trial.phases:
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
    """The flat design specification of a scenario
    (:meth:`~controllers.design_spec.DesignSpec.from_mapping`)."""
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


def episode_spec(scenario: Scenario) -> EpisodeSpec:
    """The :class:`EpisodeSpec` of a validated scenario."""
    p, e = scenario.protocol, scenario.estimator
    return EpisodeSpec(
        estimator=e.name, mode=e.mode, controller=scenario.controller.kind,
        controller_spec=controller_spec(scenario), seed=int(scenario.seed or 0),
        generator=scenario.subject.generator, order=PAPER_ORDER if e.order is None else e.order,
        identification_fraction=p.identification_fraction, calibration_s=p.calibration_s,
        episode_s=p.episode_s, hold_s=p.hold_s,
        control_dt_s=1.0 / scenario.controller.control_hz, user=scenario.user.kind,
        feedback=scenario.user.feedback, operator_params=scenario.user.operator_params(),
        estimator_options=e.options, practice=scenario.user.practice, window_ms=e.window_ms,
        step_ms=e.step_ms, hand=hand_settings(scenario), sees=scenario.user.vision)


def hand_settings(scenario: Scenario) -> HandSettings:
    """The scenario's hand: ``hand.drive``, ``paradigm``, ``auto_grip`` and ``decoder``."""
    return HandSettings(scenario.hand.drive, scenario.paradigm, scenario.auto_grip,
                        scenario.decoder)


def episode_from_scenario(scenario: Scenario, *, record_frames: bool = False,
                          compiled: bool = False) -> EpisodeResult:
    """:func:`run_episode` with everything taken from a validated scenario."""
    return run_episode(subject_for(scenario), scenario_object(scenario), episode_spec(scenario),
                       record_frames=record_frames, compiled=compiled)


def run_episode_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of scenario kind ``episode`` (see :mod:`scenarios.runners.dispatch`)."""
    return episode_from_scenario(scenario).as_result_row()
