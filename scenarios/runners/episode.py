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
- **What the user intends.** The user grips the object with
  ``safety_factor`` times its slip threshold ``m g / (2 mu)``, at least
  ``min_grip_n`` (2 N), and at most 70 % of a fragile object's break force.
  Their intent (fraction of MVC) is that hand force mapped back through the
  calibration.
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
- **Episode.** Rest, a 0.5 s ramp to the hold level, hold. The wrist lifts at
  ``episode_s - hold_s - lift_duration_s`` once the grip is established and
  the object is held in the air for ``hold_s``; the episode ends while holding.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.design import ControllerDesign, worst_case
from controllers.design_cache import grasp_design
from controllers.drive import HandLoop
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.deploy.compiled import maybe_compiled
from scenarios.outcomes import outcome_of
from scenarios.rows import WORST_FIELDS, EpisodeRow
from scenarios.runners.calibration import Calibration, shared_calibration
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.episode_metrics import (
    contact_peak_ratio,
    episode_metrics,
    margin_fields,
    mpc_failures,
    operating_forces,
    was_lifted,
)
from scenarios.runners.operator_loop import LiveUser, scene_from_info
from scenarios.runners.reference import (
    RAMP_S,
    REST_S,
    ReferenceStream,
    intended_grip_n,
    live_stream,
    live_user,
    scripted_reference,
)
from scenarios.runners.subject import subject_for
from scenarios.schema import Scenario
from sim.codec import state_space_matrices
from sim.hand.grasp_env import GraspEnv, WristSchedule
from sim.hand.objects import ObjectSpec, make_object
from sim.user.operator import Operator, OperatorParams, ScriptedOperator
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject

HAND_FORCE_AT_MVC_N = 30.0
LIFT_DURATION_S = 0.6


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
    episode_s: float = 6.0,
    hold_s: float = 2.0,
    control_dt_s: float = 0.01,
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N,
    record_frames: bool = False,
    user: str = "reacting",
    feedback: str = "none",
    operator_params: OperatorParams | None = None,
    estimator_options: Mapping[str, Any] | None = None, compiled: bool = False,
) -> EpisodeResult:
    """Calibrate, then run one closed-loop grasp-lift-hold episode.

    Parameters
    ----------
    subject, obj : VirtualSubject, ObjectSpec
        The user (with any electrode shift, noise or fatigue applied) and the object.
    estimator : str
        Estimator name (:func:`estimation.registry.estimator_names`) or ``"oracle"``.
    mode : {"free_run", "one_step"}
        Estimator mode (see module notes).
    controller : str
        Registered controller kind (``pid``, ``lead_lag``, ``mpc``, a plugin's).
    controller_spec : mapping, optional
        Keyword arguments of :func:`controllers.design.design_for_object`.
    seed : int
        Seeds the calibration session, the episode session, the networks'
        initialization and the environment.
    episode_s, hold_s : float
        Episode length and in-air hold, s.
    control_dt_s : float
        Control period, s (a whole multiple of the 2 ms physics step).
    record_frames : bool
        Also return rendered RGB frames every 40 ms under ``traces["frames"]``.
    user, feedback : str
        User kind (:mod:`sim.user.operators`: ``reacting``, the default, sees
        the hand and corrects; ``scripted`` follows the intent profile) and a
        reacting user's feedback (``none``, ``force_vibration``, ``slip_vibration``).
    operator_params, estimator_options, compiled : optional
        The reacting user's parameters (default :class:`OperatorParams`); the estimator's
        ``estimator.options``; run both as C compiled here (:mod:`scenarios.deploy.compiled`).

    Returns
    -------
    EpisodeResult

    Raises
    ------
    UnsupportedScenarioError
        Episode timing that leaves no time to grasp before the lift, an
        estimator mode that does not exist, or a reacting user with an sEMG
        generator that cannot run causally (``motor_units``).
    DivergedError
        Unstable identified model in free run, or physics divergence.
    sim.user.operators.UnknownOperatorError, sim.user.operators.UnknownFeedbackError
        Unknown user kind or feedback mode.
    sim.user.operator.OperatorError
        A feedback mode for the scripted user.
    """
    operator = make_operator(user, feedback=feedback, params=operator_params)
    lift_after_s = _lift_time_s(episode_s, hold_s)
    root = np.random.SeedSequence(seed)
    cal_seq, episode_seq, env_seq, operator_seq = root.spawn(4)
    timings = dict.fromkeys(("t_semg_s", "t_features_s", "t_estimator_s", "t_operator_s",
                             "t_controller_s", "t_physics_s"), 0.0)
    with one_blas_thread():
        cal = shared_calibration(subject, estimator, mode, seed_seq=cal_seq,
                                 generator=generator, order=order,
                                 identification_fraction=identification_fraction,
                                 calibration_s=calibration_s, options=estimator_options)
        design = grasp_design(obj, controller, control_dt_s, controller_spec)
        cal, design = maybe_compiled(compiled, cal, design, hand_force_at_mvc_n)
        target_n = intended_grip_n(obj, float((controller_spec or {}).get("safety_factor", 1.5)))
        trial = run_trial(subject, obj, cal, design, operator, goal_n=target_n,
                          seeds=(episode_seq, env_seq, operator_seq), generator=generator,
                          episode_s=episode_s, lift_after_s=lift_after_s,
                          control_dt_s=control_dt_s, hand_force_at_mvc_n=hand_force_at_mvc_n,
                          timings=timings, record_frames=record_frames)
    if trial.failure is not None:
        raise DivergedError(f"physics diverged at t = {trial.info['time_s']:.3f} s: "
                            f"{trial.failure}")
    row = {"subject_id": subject.subject_id, "seed": int(seed), **_object_fields(obj),
           "controller": controller, "estimator": estimator, "mode": mode,
           "scheduled": bool(design.scheduled), "user": user, "feedback": feedback,
           **_operator_fields(operator)}
    return _episode_result(row, cal, design, trial.stream, trial.traces, trial.info, timings,
                           target_n=target_n, lift_after_s=lift_after_s,
                           hold_from_s=episode_s - hold_s, control_dt_s=control_dt_s)


def _object_fields(obj: ObjectSpec) -> dict[str, Any]:
    """The object's columns of an episode row."""
    return {"object_name": obj.name, "object_mass_kg": obj.mass_kg,
            "object_friction": obj.friction, "object_break_force_n": obj.break_force_n}


def _operator_fields(operator: Operator) -> dict[str, Any]:
    """How the user corrected the grasp: the count and the time of the first correction."""
    times = operator.correction_times
    return {"user_corrections": int(operator.corrections),
            "first_correction_s": float(times[0]) if times else None}


@dataclass
class Trial:
    """One closed-loop trial: the traces, how it ended, and the reference it ran on.

    Attributes
    ----------
    traces : dict of ndarray
        :func:`_closed_loop`'s traces (plus ``user_intent`` for a user in the loop).
    failure : str or None
        MuJoCo's warning if the physics diverged.
    info : dict
        The environment's last ``info``.
    stream : ReferenceStream
        The reference and the user's true force at the control rate (for the metrics).
    """

    traces: dict[str, np.ndarray]
    failure: str | None
    info: dict[str, Any]
    stream: ReferenceStream


def run_trial(subject: VirtualSubject, obj: ObjectSpec, cal: Calibration,
              design: ControllerDesign, operator: Operator, *, goal_n: float,
              seeds: tuple[np.random.SeedSequence, np.random.SeedSequence,
                           np.random.SeedSequence],
              generator: str, episode_s: float, lift_after_s: float, control_dt_s: float,
              hand_force_at_mvc_n: float, timings: dict[str, float],
              record_frames: bool = False, hold_level: float | None = None,
              load: Callable[[float, Mapping[str, Any]], float] | None = None,
              schedule: WristSchedule | None = None,
              until: Callable[[float, Mapping[str, Any]], bool] | None = None) -> Trial:
    """One grasp of ``obj`` by a calibrated user, scripted or in the loop.

    A :class:`~sim.user.operator.ScriptedOperator` (the class itself) runs the
    batch path (the whole reference computed before the physics, any sEMG
    generator); any other operator runs in the loop (:class:`LiveUser`, causal generators
    only) and is finished here (what it learnt plans its next trial).

    Parameters
    ----------
    goal_n : float
        Hand grip force the user aims at, N.
    seeds : (SeedSequence, SeedSequence, SeedSequence)
        The sEMG session (profile and noise), the environment and the operator.
    hold_level : float, optional
        The scripted hold level (default: ``goal_n`` through the calibration).
    load, schedule, until
        See :func:`_closed_loop`.

    Raises
    ------
    UnsupportedScenarioError
        A user in the loop with an sEMG generator that cannot run causally.
    """
    episode_seq, env_seq, operator_seq = seeds
    if type(operator) is ScriptedOperator and hold_level is None:  # not a subclass: it may act
        stream = scripted_reference(subject, cal, goal_n, np.random.default_rng(episode_seq),
                                   generator=generator, episode_s=episode_s,
                                   control_dt_s=control_dt_s,
                                   hand_force_at_mvc_n=hand_force_at_mvc_n, timings=timings)
        traces, failure, info = _closed_loop(obj, design, stream.reference_n, stream.t_s,
                                             control_dt_s, episode_s, lift_after_s, env_seq,
                                             timings, record_frames, load=load,
                                             schedule=schedule, until=until)
        return Trial(traces, failure, info, stream)
    person, start_s = live_user(subject, cal, operator, goal_n, np.random.default_rng(episode_seq),
                                np.random.default_rng(operator_seq), generator=generator,
                                episode_s=episode_s, control_dt_s=control_dt_s,
                                hand_force_at_mvc_n=hand_force_at_mvc_n, hold_level=hold_level)
    t_ctrl = np.arange(int(round(episode_s / control_dt_s))) * control_dt_s
    reference = np.zeros(t_ctrl.size)
    traces, failure, info = _closed_loop(obj, design, reference, t_ctrl, control_dt_s, episode_s,
                                         lift_after_s, env_seq, timings, record_frames,
                                         user=person, load=load, schedule=schedule,
                                         until=until)
    person.intent_until(int(round(t_ctrl.size * control_dt_s * person.fs_hz)))
    stream = live_stream(person, start_s, t_ctrl, reference, episode_s, timings)
    traces["user_intent"] = person.intent[
        np.minimum((traces["t_s"] * person.fs_hz).round().astype(int), person.n_samples - 1)]
    operator.finish()
    return Trial(traces, failure, info, stream)


def _lift_time_s(episode_s: float, hold_s: float) -> float:
    """When the wrist starts lifting, s: ``episode_s - hold_s`` less the lift's duration.

    Raises
    ------
    UnsupportedScenarioError
        That leaves no time to grasp (rest, ramp and closing) before the lift.
    """
    lift_after_s = episode_s - hold_s - LIFT_DURATION_S
    if lift_after_s < REST_S * 1.1 + RAMP_S + 0.3:
        raise UnsupportedScenarioError(
            f"episode_s - hold_s - {LIFT_DURATION_S} s lift = {lift_after_s:.2f} s leaves no time "
            f"to grasp before lifting: needs at least {REST_S * 1.1 + RAMP_S + 0.3:.2f} s"
        )
    return lift_after_s


def _episode_result(row: dict[str, Any], cal: Calibration, design: ControllerDesign,
                    stream: ReferenceStream, traces: dict[str, np.ndarray],
                    info: Mapping[str, Any], timings: dict[str, float], *, target_n: float,
                    lift_after_s: float, hold_from_s: float, control_dt_s: float
                    ) -> EpisodeResult:
    """Metrics, outcome, margins at the forces visited and timings of a finished episode.

    Parameters
    ----------
    row : dict
        The episode's identity (subject, object, controller, estimator), extended here.
    traces : dict of ndarray, shape (n_run,)
        :func:`_closed_loop`'s traces (``n_run`` <= the stream's steps if it ended early).
    info : mapping
        The environment's last ``info`` (drop, crush and slip counters).
    target_n : float
        The grip force the user intended, N.
    lift_after_s, hold_from_s : float
        Start of the lift and of the in-air hold, s.
    """
    n_run = traces["grip_force_n"].size
    metrics = episode_metrics(stream.t_s[:n_run], stream.reference_n[:n_run],
                              traces["grip_force_n"], stream.oracle_n[:n_run],
                              start_s=stream.start_s, lift_s=lift_after_s,
                              hold_from_s=hold_from_s,
                              window_values_n=stream.window_values_n,
                              window_dt_s=stream.window_dt_s)
    ratio, both_s = contact_peak_ratio(traces["t_s"], traces["tracked_reference_n"],
                                       traces["grip_force_n"], traces["both_sides"])
    lifted = was_lifted(traces["object_height_m"])
    dropped, crushed = bool(info["dropped"]), bool(info["crushed"])
    held_n, visited_n = operating_forces(traces, design, hold_from_s=hold_from_s,
                                         both_sides_s=both_s)
    analysed = design.analyse_many([*visited_n, *([] if held_n is None else [held_n])])
    held = analysed[-1] if held_n is not None else None
    worst = worst_case(analysed[:len(visited_n)]) if visited_n else {}
    simulated = traces["t_s"][-1] + control_dt_s
    loop_time = sum(timings[k] for k in ("t_estimator_s", "t_controller_s", "t_physics_s",
                                         "t_semg_s", "t_features_s", "t_operator_s"))
    row = EpisodeRow.build(**{
        **row,
        **metrics,
        "intended_grip_n": target_n,
        "slip_events": int(info["slip_events"]), "slip_distance_m": float(info["slip_distance_m"]),
        "lifted": lifted, "dropped": dropped, "crushed": crushed,
        "outcome": outcome_of(lifted=lifted, dropped=dropped, crushed=crushed),
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
    if held is not None and held.ok:
        A, B, C, D = state_space_matrices(held.margins, "loop")
        traces.update(loop_A=A, loop_B=B, loop_C=C, loop_D=D)
    return EpisodeResult(row=row, traces=traces, design=design)


def _closed_loop(obj: ObjectSpec, design: ControllerDesign, reference: np.ndarray | None,
                 t_ctrl: np.ndarray, control_dt_s: float, episode_s: float,
                 lift_after_s: float, env_seq: np.random.SeedSequence,
                 timings: dict[str, float], record_frames: bool, *,
                 user: LiveUser | None = None,
                 load: Callable[[float, Mapping[str, Any]], float] | None = None,
                 schedule: WristSchedule | None = None,
                 until: Callable[[float, Mapping[str, Any]], bool] | None = None,
                 ) -> tuple[dict[str, np.ndarray], str | None, dict[str, Any]]:
    """Drive GraspEnv with the designed controller; returns traces, failure, last info.

    Parameters
    ----------
    reference : ndarray, shape (n_steps,) or None
        The reference of a scripted user, computed before the physics; ``None``
        with ``user``.
    t_ctrl : ndarray, shape (n_steps,)
        Control-step times, s.
    user : LiveUser, optional
        A user in the loop: the reference of step k is ``user.step(k, scene)``
        with the scene after step k - 1. If the episode ends early (a drop, a
        crush), the user goes on to ``n_steps`` seeing the last scene, so the
        reference covers the episode as a scripted user's does.
    load : callable, optional
        ``load(t_s, info) -> N``: a load hung on the object before the step at
        ``t_s`` (:meth:`sim.hand.grasp_env.GraspEnv.set_object_load`).
    schedule : WristSchedule, optional
        The wrist's schedule (default: lift after ``lift_after_s``).
    until : callable, optional
        ``until(t_s, info) -> bool``: end the episode after the step at ``t_s``
        when true (a task that has its answer).
    """
    schedule = schedule or WristSchedule(lift_after_s=lift_after_s,
                                         lift_duration_s=LIFT_DURATION_S)
    env = GraspEnv(obj, 0.0, control_dt_s=control_dt_s, episode_s=episode_s,
                   schedule=schedule, render_mode="rgb_array" if record_frames else None)
    n = t_ctrl.size
    reference = np.zeros(n) if reference is None else reference
    grip = np.zeros(n)
    command = np.zeros(n)
    height = np.zeros(n)
    slip = np.zeros(n)
    both = np.zeros(n, dtype=bool)
    tracked = np.zeros(n)
    loads = np.zeros(n)
    frames: list[np.ndarray] = []
    frame_every = max(1, int(round(0.04 / control_dt_s)))
    loop = HandLoop(env, design.controller)
    load_n = 0.0
    try:
        info = loop.reset(seed=int(env_seq.generate_state(1)[0]))
        failure = None
        k = 0
        for k in range(n):
            if user is not None:
                reference[k] = user.step(k, scene_from_info(float(t_ctrl[k]), info))
            if load is not None:
                new_load = float(load(float(t_ctrl[k]), info))
                if new_load != load_n:
                    env.set_object_load(new_load)
                    load_n = new_load
                loads[k] = load_n
            ref = float(reference[k])
            env.set_reference(ref)
            _, command[k], done = loop.step(ref)
            tracked[k] = max(ref, design.core.last_reference_n)
            info = loop.info
            grip[k] = info["grip_force_n"]
            height[k], slip[k] = info["object_height_m"], info["slip_speed_m_s"]
            both[k] = info["thumb_contact"] and info["finger_contact"]
            if record_frames and k % frame_every == 0:
                frames.append(env.render())
            failure = info.get("failure")
            if done or (until is not None and until(float(t_ctrl[k]), info)):
                break
        k_end = k + 1
        if user is not None:  # the user goes on, seeing the last scene (module notes)
            for j in range(k_end, n):
                reference[j] = user.step(j, scene_from_info(float(t_ctrl[j]), info))
    finally:
        env.close()
    timings["t_controller_s"] += loop.controller_s
    timings["t_physics_s"] += loop.physics_s
    traces = {"t_s": t_ctrl[:k_end], "reference_n": reference[:k_end],
              "grip_force_n": grip[:k_end], "command": command[:k_end],
              "object_height_m": height[:k_end], "slip_speed_m_s": slip[:k_end],
              "both_sides": both[:k_end], "tracked_reference_n": tracked[:k_end]}
    if load is not None:
        traces["object_load_n"] = loads[:k_end]
    if record_frames:
        traces["frames"] = np.stack(frames)
    return traces, failure, info


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
        compiled=compiled)


def run_episode_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of scenario kind ``episode`` (see :mod:`scenarios.runners.dispatch`)."""
    return episode_from_scenario(scenario).as_result_row()
