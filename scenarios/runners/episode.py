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

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.base import controller_stats
from controllers.bounds import slip_threshold_n
from controllers.design import ControllerDesign, OperatingAnalysis, design_for_object, worst_case
from controllers.drive import HandLoop
from estimation.features import PAPER_CHANNELS, FeatureSet, align_to_windows, extract_features
from estimation.metrics import total_variation_rate
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.operator_loop import LiveUser, scene_from_info
from scenarios.runners.subject import calibration_session, subject_for
from scenarios.schema import ORACLE, Scenario
from sim.hand.grasp_env import GraspEnv, WristSchedule
from sim.hand.objects import ObjectSpec, make_object
from sim.user.causal import NotCausalError
from sim.user.intent import IntentProfile, grasp_lift_hold
from sim.user.operator import Operator, OperatorParams, Plan, ScriptedOperator
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject

HAND_FORCE_AT_MVC_N = 30.0
MIN_GRIP_N = 2.0
FRAGILE_MARGIN = 0.7
REST_S = 1.0
RAMP_S = 0.5
LIFT_DURATION_S = 0.6
SETTLE_BAND = 0.05  # settling band: 5 % of the hold reference (at least SETTLE_FLOOR_N)
SETTLE_FLOOR_N = 0.2
CONTACT_N = 0.5  # grip force that counts as contact in the metrics
CONTACT_PEAK_WINDOW_S = 0.5  # contact_peak_ratio: peak within this long after both sides touch
LIFTED_FRACTION = 0.5  # lifted: the object rose at least this fraction of the lift height
OUTCOMES = ("held", "not_lifted", "dropped", "crushed")


# --------------------------------------------------------------------- calibration
@dataclass
class Calibration:
    """An estimator fitted on a subject's calibration session.

    Attributes
    ----------
    name : str
        Estimator name (or ``"oracle"``).
    mode : {"one_step", "free_run"}
    pipeline : object or None
        Fitted :class:`estimation.pipeline.ForcePipeline` (``None`` for the oracle).
    mvc_cal_n : float
        Largest FSR force of the calibration session, N.
    r2 : float or None
        Validation R^2 in ``mode`` on the session's last part (None for the oracle).
    fit_s : float
        Time to fit, s.
    """

    name: str
    mode: str
    pipeline: Any
    mvc_cal_n: float
    r2: float | None
    fit_s: float


def calibrate(
    subject: VirtualSubject,
    estimator: str,
    mode: str,
    *,
    rng: np.random.Generator,
    generator: str = "noise",
    order: int = PAPER_ORDER,
    identification_fraction: float = 0.5,
    calibration_s: float | None = None,
) -> Calibration:
    """Record a calibration session and fit ``estimator`` on its first part.

    Raises
    ------
    UnsupportedScenarioError
        ``mode`` is not one of the estimator's modes.
    DivergedError
        The identified model is unstable and ``mode`` would run it open loop.
    """
    session_rng, estimator_rng = rng.spawn(2)
    recording, features = calibration_session(subject, session_rng, generator=generator,
                                              min_duration_s=calibration_s)
    mvc_cal_n = float(np.max(recording.force_n))
    if estimator == ORACLE:
        return Calibration(ORACLE, mode, None, mvc_cal_n, None, 0.0)
    return fit_on_features(features, estimator, mode, rng=estimator_rng, order=order,
                           identification_fraction=identification_fraction,
                           mvc_cal_n=mvc_cal_n)


def fit_on_features(features: FeatureSet, estimator: str, mode: str, *,
                    rng: np.random.Generator, order: int, identification_fraction: float,
                    mvc_cal_n: float) -> Calibration:
    """Fit ``estimator`` on the identification part of a calibration's features and score it.

    The one fit-then-score of a calibration, for a simulated session (:func:`calibrate`) and
    a recording (:mod:`scenarios.live.recorded`).

    Raises
    ------
    UnsupportedScenarioError
        ``mode`` is not one of the estimator's modes.
    DivergedError
        The identified model is unstable and ``mode`` would run it open loop.
    """
    # the estimators (scikit-learn's models) load here: the oracle reference fits nothing
    from estimation.evaluation import split_index
    from estimation.metrics import r2_score
    from estimation.registry import make_estimator
    from estimation.reproduce import estimator_params

    split = split_index(features.n_windows, identification_fraction)
    params = estimator_params([estimator], rng, order, dt_s=features.dt_s)[estimator]
    start = time.perf_counter()
    pipeline = make_estimator(estimator, **params).fit(features.X[:split], features.y[:split])
    fit_s = time.perf_counter() - start
    if mode not in pipeline.modes:
        raise UnsupportedScenarioError(
            f"estimator {estimator} has modes {pipeline.modes} (found mode {mode})"
        )
    reason = pipeline.divergence(mode)
    if reason is not None:
        raise DivergedError(f"estimator {estimator}: {reason}")
    y_val = features.y[split:]
    y_hat = pipeline.predict(features.X[split:], y_val if mode == "one_step" else None, mode=mode)
    return Calibration(estimator, mode, pipeline, mvc_cal_n, r2_score(y_val, y_hat), fit_s)


# ------------------------------------------------------------------------ reference
def intended_grip_n(obj: ObjectSpec, safety_factor: float) -> float:
    """Hand grip force the user aims at for ``obj``, N (see module notes)."""
    target = max(safety_factor * slip_threshold_n(obj.mass_kg, obj.friction), MIN_GRIP_N)
    if obj.break_force_n is not None:
        target = min(target, FRAGILE_MARGIN * obj.break_force_n)
    return float(target)


def reference_from_windows(values_n: np.ndarray, window_t_s: np.ndarray,
                           control_t_s: np.ndarray) -> np.ndarray:
    """Hold each window's value from its end time until the next one (0 before the first)."""
    idx = np.searchsorted(window_t_s, control_t_s + 1e-9, side="right") - 1
    held = np.where(idx >= 0, values_n[np.clip(idx, 0, None)], 0.0)
    return held


def stream_estimates(calibration: Calibration, features: FeatureSet) -> np.ndarray:
    """Run the fitted estimator's stream over the episode's windows, N per window.

    ``one_step`` feeds the previous window's measured FSR force; ``free_run`` feeds nothing.
    """
    stream = calibration.pipeline.streaming(calibration.mode)
    stream.reset()
    out = np.empty(features.n_windows)
    y = features.y
    one_step = calibration.mode == "one_step"
    for k in range(features.n_windows):
        y_prev = (float(y[k - 1]) if k > 0 else 0.0) if one_step else None
        out[k] = stream.step(features.X[k], y_prev)
    return out


# ------------------------------------------------------------------------ metrics
def contact_peak_ratio(t_s: np.ndarray, reference_n: np.ndarray, grip_n: np.ndarray,
                       both_sides: np.ndarray, window_s: float = CONTACT_PEAK_WINDOW_S
                       ) -> tuple[float | None, float | None]:
    """Peak grip within ``window_s`` after both sides first touch, over the reference then.

    The reference is the one the controller tracks: the user's, or more where
    the controller raises it on purpose (the MPC's sensed slip bound, the slip
    reflex), so a deliberate rise is not counted as a slam.

    Returns
    -------
    ratio : float or None
        ``max grip / reference at the peak`` (None if both sides never touch or
        the reference is zero at the peak).
    both_sides_s : float or None
        When both sides first touched, s.
    """
    touching = np.flatnonzero(both_sides)
    if touching.size == 0:
        return None, None
    t0 = float(t_s[touching[0]])
    window = np.flatnonzero((t_s >= t0) & (t_s <= t0 + window_s))
    i = window[int(np.argmax(grip_n[window]))]
    ref = float(reference_n[i])
    return (float(grip_n[i] / ref) if ref > 0 else None), t0


def outcome_of(*, lifted: bool, dropped: bool, crushed: bool) -> str:
    """The episode's outcome category, one of :data:`OUTCOMES` (crush first)."""
    if crushed:
        return "crushed"
    if not lifted:
        return "not_lifted"
    return "dropped" if dropped else "held"


def episode_metrics(t_s: np.ndarray, reference_n: np.ndarray, grip_n: np.ndarray,
                    oracle_n: np.ndarray, *, start_s: float, lift_s: float, hold_from_s: float,
                    window_values_n: np.ndarray, window_dt_s: float) -> dict[str, Any]:
    """Tracking, estimation and transient figures of one episode.

    Parameters
    ----------
    t_s, reference_n, grip_n, oracle_n : ndarray, shape (n_steps,)
        Control-rate time, reference, measured grip force and the oracle reference.
    start_s : float
        Start of the grasp (the user's ramp onset), s.
    lift_s : float
        Earliest lift, s: the grasp phase is ``start_s..lift_s``.
    hold_from_s : float
        Start of the in-air hold, s; the hold reference is the mean reference after it.
    window_values_n : ndarray, shape (n_windows,)
        The reference at the estimator's update rate (for volatility).
    window_dt_s : float
        Estimator update period, s.

    Returns
    -------
    dict
        ``contact_time_s`` (first grip force >= 0.5 N; None if never),
        ``tracking_rmse_n`` (from contact + 0.5 s, past the closing impact, to
        the end; None without contact),
        ``estimation_rmse_n`` (reference vs oracle, whole episode),
        ``hold_reference_n`` (mean reference in the air), and over the grasp
        phase (on the table, before the lift): ``overshoot_pct`` (peak grip over
        the reference just before the lift), ``settling_time_s`` (from the start
        until the grip stays within 5 % or 0.2 N of the current reference; None
        if it never does), plus ``peak_force_n`` (whole episode) and
        ``reference_volatility_n_per_s``.
    """
    touching = np.flatnonzero(grip_n >= CONTACT_N)
    contact_s = float(t_s[touching[0]]) if touching.size else None
    track = (t_s >= contact_s + 0.5) if contact_s is not None else np.zeros(t_s.size, bool)
    hold = t_s >= hold_from_s
    hold_ref = float(np.mean(reference_n[hold])) if hold.any() else float("nan")
    grasp = (t_s >= start_s) & (t_s < lift_s)
    grasp_ref = float(reference_n[grasp][-1]) if grasp.any() else float("nan")
    peak_grasp = float(np.max(grip_n[grasp])) if grasp.any() else 0.0
    idx = np.flatnonzero(grasp)
    band = np.maximum(SETTLE_BAND * reference_n[idx], SETTLE_FLOOR_N)
    outside = idx[np.abs(grip_n[idx] - reference_n[idx]) > band]
    if outside.size == 0:
        settling = 0.0
    elif outside[-1] == idx[-1]:
        settling = None
    else:
        settling = float(t_s[outside[-1] + 1] - start_s)
    return {
        "contact_time_s": contact_s,
        "tracking_rmse_n": float(np.sqrt(np.mean((reference_n[track] - grip_n[track]) ** 2)))
        if track.any() else None,
        "estimation_rmse_n": float(np.sqrt(np.mean((reference_n - oracle_n) ** 2))),
        "hold_reference_n": hold_ref,
        "overshoot_pct": float(max(0.0, 100.0 * (peak_grasp - grasp_ref) / grasp_ref))
        if grasp_ref > 0 else None,
        "settling_time_s": settling,
        "peak_force_n": float(np.max(grip_n)),
        "reference_volatility_n_per_s": total_variation_rate(window_values_n, window_dt_s)
        if window_values_n.size >= 2 else 0.0,
    }


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
) -> EpisodeResult:
    """Calibrate, then run one closed-loop grasp-lift-hold episode.

    Parameters
    ----------
    subject : VirtualSubject
        The user (with any electrode shift, noise or fatigue already applied).
    obj : ObjectSpec
        The object.
    estimator : str
        Estimator name (:func:`estimation.registry.estimator_names`) or ``"oracle"``.
    mode : {"free_run", "one_step"}
        Estimator mode (see module notes).
    controller : {"pid", "lead_lag", "mpc"}
        Controller family.
    controller_spec : mapping, optional
        Keyword arguments of :func:`controllers.design.design_for_object`
        (``phase_margin_deg``, ``crossover_rad_s``, ``horizon``, ...).
    seed : int
        Seeds the calibration session, the episode session, the networks'
        initialization and the environment.
    episode_s, hold_s : float
        Episode length and in-air hold, s.
    control_dt_s : float
        Control period, s (a whole multiple of the 2 ms physics step).
    record_frames : bool
        Also return rendered RGB frames every 40 ms under ``traces["frames"]``.
    user : str
        User kind (:mod:`sim.user.operators`): ``reacting`` (default: sees the
        hand and corrects, :mod:`sim.user.operator`) or ``scripted`` (follows
        the intent profile whatever happens).
    feedback : str
        Feedback mode of a reacting user: ``none`` (vision only),
        ``force_vibration`` or ``slip_vibration``.
    operator_params : OperatorParams, optional
        The reacting user's parameters (default :class:`OperatorParams`).

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
        cal = calibrate(subject, estimator, mode, rng=np.random.default_rng(cal_seq),
                        generator=generator, order=order,
                        identification_fraction=identification_fraction,
                        calibration_s=calibration_s)
        design = cached_design(obj, controller, control_dt_s, controller_spec)
        target_n = intended_grip_n(obj, float((controller_spec or {}).get("safety_factor", 1.5)))
        trial = run_trial(subject, obj, cal, design, operator, goal_n=target_n,
                          seeds=(episode_seq, env_seq, operator_seq), generator=generator,
                          episode_s=episode_s, lift_after_s=lift_after_s,
                          control_dt_s=control_dt_s, hand_force_at_mvc_n=hand_force_at_mvc_n,
                          timings=timings, record_frames=record_frames)
    traces, failure, info, stream = trial.traces, trial.failure, trial.info, trial.stream
    if failure is not None:
        raise DivergedError(f"physics diverged at t = {info['time_s']:.3f} s: {failure}")
    row = {"subject_id": subject.subject_id, "seed": int(seed),
           "object_name": obj.name, "object_mass_kg": obj.mass_kg,
           "object_friction": obj.friction, "object_break_force_n": obj.break_force_n,
           "controller": controller, "estimator": estimator, "mode": mode,
           "scheduled": bool(design.scheduled), "user": user, "feedback": feedback,
           "user_corrections": int(operator.corrections),
           "first_correction_s": (float(operator.correction_times[0])
                                  if operator.correction_times else None)}
    return _episode_result(row, cal, design, stream, traces, info, timings,
                           target_n=target_n, lift_after_s=lift_after_s,
                           hold_from_s=episode_s - hold_s, control_dt_s=control_dt_s)


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
    stream : _ReferenceStream
        The reference and the user's true force at the control rate (for the metrics).
    """

    traces: dict[str, np.ndarray]
    failure: str | None
    info: dict[str, Any]
    stream: _ReferenceStream


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
        stream = _reference_stream(subject, cal, goal_n, np.random.default_rng(episode_seq),
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


@dataclass
class _ReferenceStream:
    """The force reference of one episode, at the estimator's and the control rate.

    Attributes
    ----------
    start_s : float
        The user's ramp onset, s.
    window_values_n : ndarray, shape (n_windows,)
        The hand reference at each feature window that ends within the episode
        (estimate mapped to the hand, clipped), N.
    window_dt_s : float
        Estimator update period, s.
    t_s : ndarray, shape (n_steps,)
        Control-rate time, s.
    reference_n, oracle_n : ndarray, shape (n_steps,)
        The held reference, and the same for the user's true grip force, N.
    """

    start_s: float
    window_values_n: np.ndarray
    window_dt_s: float
    t_s: np.ndarray
    reference_n: np.ndarray
    oracle_n: np.ndarray


def hold_level_for(target_n: float, cal: Calibration, subject: VirtualSubject,
                   hand_force_at_mvc_n: float) -> float:
    """The intent (fraction of MVC) asking for ``target_n`` through the calibration's mapping."""
    return float(np.clip(target_n / hand_force_at_mvc_n * cal.mvc_cal_n / subject.mvc_n, 0.0, 1.0))


def episode_profile(rng: np.random.Generator, hold_level: float, episode_s: float
                    ) -> tuple[IntentProfile, float]:
    """The scripted grasp-lift-hold intent of an episode at 200 Hz, and its ramp onset, s."""
    profile = grasp_lift_hold(rng, fs_hz=200.0, hold_level=hold_level, rest_s=REST_S,
                              ramp_s=RAMP_S, hold_s=episode_s, jitter=0.1)
    return profile, next(t for kind, t in profile.cues if kind == "start")


def _reference_stream(subject: VirtualSubject, cal: Calibration, target_n: float,
                      rng: np.random.Generator, *, generator: str, episode_s: float,
                      control_dt_s: float, hand_force_at_mvc_n: float,
                      timings: dict[str, float]) -> _ReferenceStream:
    """Record the user's sEMG while they grasp, estimate, and hold it at the control rate.

    The scripted user: the whole episode's sEMG and reference are computed
    before the physics runs. The user aims at ``target_n`` on the hand, which
    they reach through the calibration's mapping (module notes); sEMG,
    feature and estimator times are added to ``timings``.
    """
    # The user's intent and their sEMG during the episode.
    hold_level = hold_level_for(target_n, cal, subject, hand_force_at_mvc_n)
    profile, start_s = episode_profile(rng, hold_level, episode_s)
    t0 = time.perf_counter()
    recording = subject.record(profile, generator=generator, rng=rng)
    timings["t_semg_s"] = time.perf_counter() - t0
    n_keep = int(round((episode_s + 0.5) * recording.fs_hz))
    recording = recording.slice(0, min(n_keep, recording.n_samples))
    t0 = time.perf_counter()
    features = extract_features(recording, channels=PAPER_CHANNELS)
    timings["t_features_s"] = time.perf_counter() - t0

    # Estimates at the window rate, then the held reference at the control rate.
    to_hand = hand_force_at_mvc_n / cal.mvc_cal_n
    # the user's true grip force (before the FSR) at each window's end
    oracle_windows = align_to_windows(recording.intent_force_n, recording.fs_hz) * to_hand
    t0 = time.perf_counter()
    if cal.pipeline is None:
        estimate_windows = oracle_windows
    else:
        estimate_windows = stream_estimates(cal, features) * to_hand
    timings["t_estimator_s"] = time.perf_counter() - t0
    ceiling = 1.2 * hand_force_at_mvc_n
    estimate_windows = np.clip(estimate_windows, 0.0, ceiling)
    n_steps = int(round(episode_s / control_dt_s))
    t_ctrl = np.arange(n_steps) * control_dt_s
    reference = reference_from_windows(estimate_windows, features.t_s, t_ctrl)
    oracle = reference_from_windows(np.clip(oracle_windows, 0, ceiling), features.t_s, t_ctrl)
    return _ReferenceStream(start_s, estimate_windows[features.t_s <= episode_s],
                            features.dt_s, t_ctrl, reference, oracle)


def live_user(subject: VirtualSubject, cal: Calibration, operator: Operator, goal_n: float,
              rng: np.random.Generator, operator_rng: np.random.Generator, *, generator: str,
              episode_s: float, control_dt_s: float, hand_force_at_mvc_n: float,
              hold_level: float | None = None) -> tuple[LiveUser, float]:
    """A user in the loop for one episode, and their ramp onset, s.

    Draws the same profile and the same sEMG noise from ``rng`` as
    :func:`_reference_stream` does (a scripted operator so gives its very
    references); the operator plans from the profile and aims at ``goal_n``.

    Parameters
    ----------
    hold_level : float, optional
        The scripted hold level; default: ``goal_n`` through the calibration.
    """
    if hold_level is None:
        hold_level = hold_level_for(goal_n, cal, subject, hand_force_at_mvc_n)
    profile, start_s = episode_profile(rng, hold_level, episode_s)
    plan = Plan(intent=profile.intent, fs_hz=profile.fs_hz, hold_level=hold_level,
                goal_n=float(goal_n), force_range_n=float(hand_force_at_mvc_n))
    try:
        user = LiveUser(subject, cal, operator, plan, session_rng=rng,
                        operator_rng=operator_rng, n_samples=profile.n_samples,
                        control_dt_s=control_dt_s, hand_force_at_mvc_n=hand_force_at_mvc_n,
                        generator=generator)
    except NotCausalError as exc:
        raise UnsupportedScenarioError(f"user {operator.name}: {exc}") from None
    return user, start_s


def live_stream(user: LiveUser, start_s: float, t_ctrl: np.ndarray, reference_n: np.ndarray,
                episode_s: float, timings: dict[str, float]) -> _ReferenceStream:
    """The :class:`_ReferenceStream` a live user produced (for the metrics), timings added."""
    window_t = np.asarray(user.window_t_s)
    estimates = np.asarray(user.window_estimate_n)
    oracle = reference_from_windows(user.window_oracle_n(), window_t, t_ctrl)
    for key, value in user.timings.items():
        timings[key] = timings.get(key, 0.0) + value
    return _ReferenceStream(start_s, estimates[window_t <= episode_s], user.hop / user.fs_hz,
                            t_ctrl, reference_n, oracle)


def _episode_result(row: dict[str, Any], cal: Calibration, design: ControllerDesign,
                    stream: _ReferenceStream, traces: dict[str, np.ndarray],
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
    held = design.analyse(held_n) if held_n is not None else None
    worst = worst_case([design.analyse(f) for f in visited_n]) if visited_n else {}
    simulated = traces["t_s"][-1] + control_dt_s
    loop_time = sum(timings[k] for k in ("t_estimator_s", "t_controller_s", "t_physics_s",
                                         "t_semg_s", "t_features_s", "t_operator_s"))
    row = {
        **row,
        **metrics,
        "intended_grip_n": target_n,
        "slip_events": int(info["slip_events"]), "slip_distance_m": float(info["slip_distance_m"]),
        "lifted": lifted, "dropped": dropped, "crushed": crushed,
        "outcome": outcome_of(lifted=lifted, dropped=dropped, crushed=crushed),
        "contact_peak_ratio": ratio, "both_sides_time_s": both_s,
        "held_force_n": held_n,
        "visited_forces_n": ",".join(f"{f:g}" for f in visited_n),
        **_margin_fields(held),
        **{f"worst_{k}": v for k, v in worst.items()},
        "loop_dt_s": float(control_dt_s),
        "mpc_failures": mpc_failures(design),
        "cal_r2": cal.r2, "cal_mvc_n": cal.mvc_cal_n, "fit_s": cal.fit_s,
        **timings,
        "simulated_s": float(simulated),
        "realtime_factor": float(simulated / loop_time) if loop_time > 0 else None,
    }
    traces["intent_n"] = stream.oracle_n[:n_run]
    if held is not None and held.ok:
        A, B, C, D = (np.atleast_2d(np.asarray(M, dtype=float)) for M in
                      (held.margins.loop.A, held.margins.loop.B, held.margins.loop.C,
                       held.margins.loop.D))
        traces.update(loop_A=A, loop_B=B, loop_C=C, loop_D=D)
    return EpisodeResult(row=row, traces=traces, design=design)


_DESIGNS: dict[tuple, ControllerDesign] = {}


def cached_design(obj: ObjectSpec, controller: str, control_dt_s: float,
                  spec: Mapping[str, Any] | None) -> ControllerDesign:
    """:func:`controllers.design.design_for_object` memoized per object, kind, period and spec.

    In memory per process, and on disk for every process of the machine
    (:mod:`controllers.design_cache`, with the loop analyses made so far), so
    sweep workers and later commands load a design instead of redoing it.
    A design is reset at the start of every episode, so episodes in one process
    share it (and the analyses it has cached). A fragile object's break force
    is the user's force limit (the hand's "fragile" setting), which bounds the
    MPC and the slip reflex.
    """
    from controllers import design_cache
    from controllers.design_plant import DEFAULT_FORCE_GRID_N

    spec = dict(spec or {})
    if obj.break_force_n is not None:
        spec.setdefault("force_max_n", float(obj.break_force_n))
    key = (obj, controller, float(control_dt_s),
           tuple(sorted((k, tuple(sorted(v.items())) if isinstance(v, Mapping) else v)
                        for k, v in spec.items())))
    if key not in _DESIGNS:
        forces_n = tuple(float(f) for f in spec.get("forces_n", DEFAULT_FORCE_GRID_N))
        _DESIGNS[key], _ = design_cache.cached_design(
            obj, controller, float(control_dt_s), spec, forces_n,
            lambda: design_for_object(obj, controller, control_dt_s=control_dt_s, **spec))
    return _DESIGNS[key]


def was_lifted(object_height_m: np.ndarray) -> bool:
    """Whether the object rose :data:`LIFTED_FRACTION` of the wrist's lift height, at any time."""
    rise = np.asarray(object_height_m) - object_height_m[0]
    return bool(rise.size and np.max(rise) >= LIFTED_FRACTION * WristSchedule().lift_height_m)


def operating_forces(traces: Mapping[str, np.ndarray], design: ControllerDesign, *,
                     hold_from_s: float, both_sides_s: float | None
                     ) -> tuple[float | None, list[float]]:
    """The force an episode held and the forces it visited, N.

    The held force is the median grip in the in-air hold (the last ``hold_s``);
    the visited forces are the design grid points between the 5th and 95th
    percentiles of the grip once both sides touched, plus the held force. Both
    are clamped into the analysed range and rounded to 0.1 N.
    """
    if both_sides_s is None:
        return None, []
    lo_range, hi_range = design.family.range_n
    t, grip = traces["t_s"], traces["grip_force_n"]
    hold = t >= hold_from_s
    after = t >= both_sides_s
    if not hold.any() or not after.any():
        return None, []

    def clamp(f: float) -> float:
        return float(np.clip(round(f, 1), lo_range, hi_range))

    held = clamp(float(np.median(grip[hold])))
    p5, p95 = np.percentile(grip[after], [5, 95])
    visited = {clamp(f) for f in design.family.forces_n if p5 <= f <= p95} | {held}
    return held, sorted(visited)


def mpc_failures(design: ControllerDesign) -> int:
    """QP solves that fell back to the unconstrained law, summed over the bank."""
    return int(controller_stats(design.core).get("n_failures", 0))


def _margin_fields(analysis: OperatingAnalysis | None) -> dict[str, Any]:
    keys = ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "ms", "crossover_rad_s",
            "n_crossovers", "stable", "bandwidth_rad_s")
    if analysis is None or not analysis.ok:
        return dict.fromkeys(keys)
    m = analysis.margins
    return {"gain_margin_db": _finite(m.gain_margin_db),
            "phase_margin_deg": _finite(m.phase_margin_deg),
            "delay_margin_s": _finite(m.delay_margin_s), "ms": _finite(m.ms),
            "crossover_rad_s": float(m.crossover_rad_s[0]) if len(m.crossover_rad_s) else None,
            "n_crossovers": len(m.crossover_rad_s), "stable": bool(m.stable),
            "bandwidth_rad_s": _finite(m.bandwidth_rad_s)}


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


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
    return spec


def episode_from_scenario(scenario: Scenario, *, record_frames: bool = False) -> EpisodeResult:
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
        operator_params=scenario.user.operator_params())


def run_episode_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of scenario kind ``episode`` (see :mod:`scenarios.runners.dispatch`)."""
    return episode_from_scenario(scenario).as_result_row()


def run_calibration_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of scenario kind ``calibration``: fit on a session, score the rest, no grasp."""
    e, p = scenario.estimator, scenario.protocol
    subject = subject_for(scenario)
    with one_blas_thread():
        cal = calibrate(subject, e.name, e.mode,
                        rng=np.random.default_rng(np.random.SeedSequence(scenario.seed or 0)),
                        generator=scenario.subject.generator,
                        order=PAPER_ORDER if e.order is None else e.order,
                        identification_fraction=p.identification_fraction,
                        calibration_s=p.calibration_s)
    return {"subject_id": subject.subject_id, "estimator": e.name, "mode": e.mode,
            "r2": cal.r2, "mvc_cal_n": cal.mvc_cal_n, "fit_s": cal.fit_s}
