"""The reference an episode's controller tracks: the user's intended grip, through the estimator.

The user's intent becomes sEMG, features every 125 ms, the fitted estimator's
output and the hand reference, held between updates
(:mod:`scenarios.runners.episode` explains the force mapping). For a scripted
user the whole reference is computed before the hand runs; a reacting user
(:class:`scenarios.runners.operator_loop.LiveUser`) produces it chunk by chunk.
"""

import time
from dataclasses import dataclass

import numpy as np

from controllers.bounds import slip_threshold_n
from estimation.features import PAPER_CHANNELS, FeatureSet, align_to_windows, extract_features
from scenarios.runners.calibration import Calibration
from scenarios.runners.dispatch import UnsupportedScenarioError
from scenarios.runners.operator_loop import STEP_MS, WINDOW_MS, LiveUser
from scenarios.schema.names import INTACT
from sim.hand.objects import ObjectSpec
from sim.hand.wrist import WristSchedule
from sim.user.causal import NotCausalError
from sim.user.intent import IntentProfile, grasp_lift_hold
from sim.user.operator import FRAGILE_MARGIN, MIN_GRIP_N, Operator, OperatorParams, Plan
from sim.user.subjects import VirtualSubject

REST_S = 1.0  # rest before the grasp, s
RAMP_S = 0.5  # ramp to the hold level, s
LIFT_HEIGHT_M = WristSchedule().lift_height_m
"""How high a grasp-lift-hold trial lifts the object, m."""
NOVICE_SAFETY_FACTOR = 1.0 + OperatorParams().novice_margin
"""Grip over the slip force a user aims at without practice (the scripted user's aim)."""


def intended_grip_n(obj: ObjectSpec, safety_factor: float = NOVICE_SAFETY_FACTOR) -> float:
    """Hand grip force a user with ``safety_factor`` aims at for ``obj``, N (module notes).

    ``safety_factor`` times the slip threshold ``m g / (2 mu)``, at least
    :data:`~sim.user.operator.MIN_GRIP_N`, at most
    :data:`~sim.user.operator.FRAGILE_MARGIN` of a fragile object's break force.
    """
    target = max(safety_factor * slip_threshold_n(obj.mass_kg, obj.friction), MIN_GRIP_N)
    if obj.break_force_n is not None:
        target = min(target, FRAGILE_MARGIN * obj.break_force_n)
    return float(target)


@dataclass(frozen=True)
class Task:
    """What a trial asks of the user besides a grip (the :class:`~sim.user.operator.Plan`'s task).

    Attributes
    ----------
    need_n : float or None
        The grip the object needs not to slip, N (``None``: the task gives a
        force target instead).
    break_n : float or None
        A fragile object's break force, N.
    lift_height_m : float or None
        How high to lift, m (``None``: hold on the table).
    hold_s : float
        How long to hold before putting the object down, s.
    place : bool
        Put the object down and let go after the hold.
    move_s : float or None
        Duration of the lift and the set-down when the task sets it, s.
    """

    need_n: float | None
    break_n: float | None = None
    lift_height_m: float | None = LIFT_HEIGHT_M
    hold_s: float = 2.0
    place: bool = True
    move_s: float | None = None


def grasp_task(obj: ObjectSpec, *, hold_s: float, lift_height_m: float | None = LIFT_HEIGHT_M,
               place: bool = True) -> Task:
    """The task of grasping, lifting and holding ``obj``: its slip force and break force."""
    return Task(need_n=slip_threshold_n(obj.mass_kg, obj.friction), break_n=obj.break_force_n,
                lift_height_m=lift_height_m, hold_s=hold_s, place=place)


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


@dataclass
class ReferenceStream:
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


def level_per_newton(cal: Calibration, subject: VirtualSubject,
                     hand_force_at_mvc_n: float) -> float:
    """Intent (fraction of MVC) per newton of hand force, through the calibration's mapping."""
    return float(cal.mvc_cal_n / subject.mvc_n / hand_force_at_mvc_n)


def hold_level_for(target_n: float, cal: Calibration, subject: VirtualSubject,
                   hand_force_at_mvc_n: float) -> float:
    """The intent (fraction of MVC) asking for ``target_n`` through the calibration's mapping."""
    return float(np.clip(target_n * level_per_newton(cal, subject, hand_force_at_mvc_n),
                         0.0, 1.0))


def episode_profile(rng: np.random.Generator, hold_level: float, episode_s: float
                    ) -> tuple[IntentProfile, float]:
    """The scripted grasp-lift-hold intent of an episode at 200 Hz, and its ramp onset, s."""
    profile = grasp_lift_hold(rng, fs_hz=200.0, hold_level=hold_level, rest_s=REST_S,
                              ramp_s=RAMP_S, hold_s=episode_s, jitter=0.1)
    return profile, next(t for kind, t in profile.cues if kind == "start")


def scripted_reference(subject: VirtualSubject, cal: Calibration, target_n: float,
                      rng: np.random.Generator, *, generator: str, episode_s: float,
                      control_dt_s: float, hand_force_at_mvc_n: float,
                      timings: dict[str, float], window_ms: float = WINDOW_MS,
                      step_ms: float = STEP_MS) -> ReferenceStream:
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
    features = extract_features(recording, channels=PAPER_CHANNELS, window_ms=window_ms,
                                step_ms=step_ms)
    timings["t_features_s"] = time.perf_counter() - t0

    # Estimates at the window rate, then the held reference at the control rate.
    to_hand = hand_force_at_mvc_n / cal.mvc_cal_n
    # the user's true grip force (before the FSR) at each window's end
    oracle_windows = align_to_windows(recording.intent_force_n, recording.fs_hz,
                                      window_ms=window_ms, step_ms=step_ms) * to_hand
    t0 = time.perf_counter()
    if cal.pipeline is None:
        estimate_windows = oracle_windows
    else:  # the hand acts above the rest threshold
        estimate_windows = cal.rest_gate().run(stream_estimates(cal, features)) * to_hand
    timings["t_estimator_s"] = time.perf_counter() - t0
    ceiling = 1.2 * hand_force_at_mvc_n
    estimate_windows = np.clip(estimate_windows, 0.0, ceiling)
    n_steps = int(round(episode_s / control_dt_s))
    t_ctrl = np.arange(n_steps) * control_dt_s
    reference = reference_from_windows(estimate_windows, features.t_s, t_ctrl)
    oracle = reference_from_windows(np.clip(oracle_windows, 0, ceiling), features.t_s, t_ctrl)
    if cal.name == INTACT:  # no sEMG path: the user's own force at every control step
        idx = np.minimum((t_ctrl * recording.fs_hz + 1e-9).astype(int), recording.n_samples - 1)
        reference = np.clip(recording.intent_force_n[idx] * to_hand, 0.0, ceiling)
    return ReferenceStream(start_s, estimate_windows[features.t_s <= episode_s],
                            features.dt_s, t_ctrl, reference, oracle)


def live_user(subject: VirtualSubject, cal: Calibration, operator: Operator, goal_n: float,
              rng: np.random.Generator, operator_rng: np.random.Generator, *, generator: str,
              episode_s: float, control_dt_s: float, hand_force_at_mvc_n: float,
              hold_level: float | None = None, task: Task | None = None,
              window_ms: float = WINDOW_MS, step_ms: float = STEP_MS
              ) -> tuple[LiveUser, float]:
    """A user in the loop for one episode, and their ramp onset, s.

    Draws the same profile and the same sEMG noise from ``rng`` as
    :func:`scripted_reference` does (a scripted operator so gives its very
    references); the script aims at ``goal_n``, and a user who plans by
    themselves reads the object's needs and the arm's part from ``task``.

    Parameters
    ----------
    hold_level : float, optional
        The scripted hold level; default: ``goal_n`` through the calibration.
    task : Task, optional
        The object's slip and break forces and the lift; default: a force
        target of ``goal_n`` held on the table.
    window_ms, step_ms : float
        The feature window and its increment, ms.
    """
    if hold_level is None:
        hold_level = hold_level_for(goal_n, cal, subject, hand_force_at_mvc_n)
    task = task or Task(need_n=None, lift_height_m=None, hold_s=episode_s, place=False)
    profile, start_s = episode_profile(rng, hold_level, episode_s)
    plan = Plan(intent=profile.intent, fs_hz=profile.fs_hz, hold_level=hold_level,
                goal_n=float(goal_n), force_range_n=float(hand_force_at_mvc_n),
                need_n=task.need_n, break_n=task.break_n,
                level_per_n=level_per_newton(cal, subject, hand_force_at_mvc_n),
                lift_height_m=task.lift_height_m, hold_s=task.hold_s, place=task.place,
                move_s=task.move_s)
    try:
        user = LiveUser(subject, cal, operator, plan, session_rng=rng,
                        operator_rng=operator_rng, n_samples=profile.n_samples,
                        control_dt_s=control_dt_s, hand_force_at_mvc_n=hand_force_at_mvc_n,
                        generator=generator, window_ms=window_ms, step_ms=step_ms)
    except NotCausalError as exc:
        raise UnsupportedScenarioError(f"user {operator.name}: {exc}") from None
    return user, start_s


def live_stream(user: LiveUser, start_s: float, t_ctrl: np.ndarray, reference_n: np.ndarray,
                episode_s: float, timings: dict[str, float]) -> ReferenceStream:
    """The :class:`ReferenceStream` a live user produced (for the metrics), timings added."""
    window_t = np.asarray(user.window_t_s)
    estimates = np.asarray(user.window_estimate_n)
    oracle = reference_from_windows(user.window_oracle_n(), window_t, t_ctrl)
    for key, value in user.timings.items():
        timings[key] = timings.get(key, 0.0) + value
    return ReferenceStream(start_s, estimates[window_t <= episode_s], user.hop / user.fs_hz,
                            t_ctrl, reference_n, oracle)
