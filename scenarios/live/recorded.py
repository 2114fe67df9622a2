"""Sessions on recordings: the calibration fit, a virtual subject's grasp, the offline episode.

A live session and an offline episode must be comparable, so both start from the
same pieces:

- :func:`fit_calibration` fits the estimator on a calibration recording (a
  virtual subject's paper session, a file from ``griploop calibrate --lsl`` or a
  lab's recording) exactly as :func:`scenarios.runners.calibration.calibrate` fits it
  on a simulated session: features of the chosen channels, the first 50 % of the
  windows identify, the rest scores, ``mvc_cal_n`` is the largest measured force;
- :func:`grasp_session` records a virtual subject grasping an object, aiming at the
  force an episode's user aims at through that calibration's force mapping, and
  lifting it with their own arm (the forearm's pitch, as an armband's IMU reads it);
- :func:`episode_on_recording` is the offline episode driven by a given recording
  instead of a freshly simulated one: :func:`estimation.features.extract_features`,
  :func:`scenarios.runners.reference.stream_estimates`, the held reference, and the
  episode's closed loop on the MuJoCo hand;
- :func:`grasp_metrics` scores a run (offline or live) the way an episode is scored.

The time base is the episode's: control step ``k`` at ``t = k * control_dt_s`` uses
the latest feature window that ended at or before ``t``; the offline episode's wrist
lifts at ``episode_s - hold_s - 0.6 s`` once the grip is established, which is when
a virtual subject's recorded arm lifts.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from controllers.design_cache import grasp_design
from estimation.features import PAPER_CHANNELS, align_to_windows, extract_features
from estimation.paper import PAPER_ORDER
from estimation.threads import one_blas_thread
from scenarios.live.arm import FOREARM_M, LIFT_HEIGHT_M, forearm_pitch_rad
from scenarios.live.errors import SessionError
from scenarios.runners.calibration import Calibration, fit_on_features
from scenarios.runners.dispatch import DivergedError
from scenarios.runners.episode import (
    HAND_FORCE_AT_MVC_N,
    LIFT_DURATION_S,
    _closed_loop,
    _lift_time_s,
)
from scenarios.runners.episode_metrics import (
    CONTACT_N,
    contact_peak_ratio,
    episode_metrics,
)
from scenarios.runners.reference import (
    RAMP_S,
    REST_S,
    intended_grip_n,
    reference_from_windows,
    stream_estimates,
)
from scenarios.runners.trial_outcome import judge_trial
from scenarios.schema import ORACLE
from sim.hand.objects import ObjectSpec
from sim.hand.wrist import min_jerk
from sim.recording import Recording, RecordingError
from sim.user.intent import grasp_lift_hold
from sim.user.subjects import VirtualSubject

FS_HZ = 200.0
IMU_NOISE_RAD = float(np.radians(0.2))
"""SD of the noise on a virtual subject's recorded forearm pitch, rad."""


@dataclass
class RecordedCalibration:
    """An estimator fitted on a calibration recording, with the layout a stream must match.

    Attributes
    ----------
    calibration : scenarios.runners.calibration.Calibration
        Estimator name, mode, fitted pipeline, ``mvc_cal_n`` (N), validation R^2, fit time.
    recording : Recording
        The calibration recording.
    channels : list or None
        The channels used, as given (``None``: all).
    channel_index : list of int
        Their zero-based columns.
    """

    calibration: Calibration
    recording: Recording
    channels: list[int | str] | None
    channel_index: list[int] = field(default_factory=list)

    @property
    def fs_hz(self) -> float:
        """Sampling rate a stream must have, Hz."""
        return self.recording.fs_hz

    @property
    def n_channels(self) -> int:
        """Channel count a stream must have."""
        return self.recording.n_channels

    @property
    def integer(self) -> bool:
        """Whether samples are int8 counts (MYO): features are then exact integer sums."""
        return self.recording.emg.dtype == np.int8

    def to_hand(self, hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N) -> float:
        """The force mapping: hand newtons per estimated user newton."""
        return hand_force_at_mvc_n / self.calibration.mvc_cal_n

    def summary(self) -> dict[str, Any]:
        """JSON-ready description."""
        c = self.calibration
        return {"file": self.recording.source, "estimator": c.name, "mode": c.mode,
                "channels": "all" if self.channels is None else [str(ch) for ch in self.channels],
                "r2": c.r2, "mvc_cal_n": c.mvc_cal_n, "fit_s": c.fit_s,
                "n_channels": self.n_channels, "fs_hz": self.fs_hz}


def fit_calibration(recording: Recording, estimator: str = "ridge", *, mode: str = "free_run",
                    channels: Sequence[int | str] | None = PAPER_CHANNELS,
                    order: int = PAPER_ORDER, identification_fraction: float = 0.5,
                    seed: int = 0) -> RecordedCalibration:
    """Fit ``estimator`` on a calibration recording's first part and score it on the rest.

    Parameters
    ----------
    recording : Recording
        sEMG with the measured force (N).
    estimator : str
        A registered estimator (not the oracle: a person's recording has no true force).
    mode : {"free_run", "one_step"}
        The mode it will stream in (a live session runs ``free_run``: sEMG only).
    channels : sequence of int or str, or None
        Channels (1-based numbers or names); ``None``: all. Default: the paper's 6, 7, 8.
    order : int
        State-space order of the estimators that take one.
    identification_fraction : float
        Share of the windows that identify (paper: 0.5).
    seed : int
        Seeds the estimators that draw random numbers (networks, trees).

    Raises
    ------
    RecordingError
        No force, or no positive force.
    SessionError
        ``estimator`` is the oracle.
    UnsupportedScenarioError, DivergedError
        As :func:`scenarios.runners.calibration.calibrate`.
    """
    if estimator == ORACLE:
        raise SessionError("estimator: the oracle needs the user's true force, which a "
                           "recording of a person does not have; expected a fitted estimator")
    if recording.force_n is None:
        raise RecordingError(
            f"{recording.source}: no force; a calibration recording needs the measured force "
            "(record one with griploop calibrate --lsl)"
        )
    mvc_cal_n = float(np.max(recording.force_n))
    if not mvc_cal_n > 0:
        raise RecordingError(f"{recording.source}: force never rises above 0 N; expected the "
                             "calibration squeezes")
    channel_list = None if channels is None else list(channels)
    index = (list(range(recording.n_channels)) if channel_list is None
             else [recording.channel_index(ch) for ch in channel_list])
    features = extract_features(recording, channels=channel_list)
    with one_blas_thread():
        cal = fit_on_features(features, estimator, mode, rng=np.random.default_rng(seed),
                              order=order, identification_fraction=identification_fraction,
                              mvc_cal_n=mvc_cal_n)
    return RecordedCalibration(cal, recording, channel_list, index)


def grasp_session(subject: VirtualSubject, obj: ObjectSpec, *, mvc_cal_n: float,
                  duration_s: float = 8.0, rng: np.random.Generator | int | None = 0,
                  generator: str = "noise", safety_factor: float = 1.5,
                  hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N,
                  tail_s: float = 1.0, fs_hz: float = FS_HZ, hold_s: float = 2.0,
                  forearm_m: float = FOREARM_M) -> Recording:
    """A virtual subject's sEMG and forearm pitch while they grasp ``obj`` and lift it.

    The user aims at :func:`scenarios.runners.reference.intended_grip_n` on the hand,
    which they reach through the calibration's mapping (``mvc_cal_n``, the largest
    force of the calibration recording): rest 1 s, a 0.5 s ramp, then a hold lasting
    beyond the session (timings jittered by 10 %). Their arm lifts the wrist as the
    episode's scripted wrist does, at ``duration_s - hold_s - 0.6 s`` by 8 cm along a
    0.6 s minimum-jerk path, and stays up; the forearm pivots at the elbow, so its
    pitch is ``asin(height / forearm_m)`` (:func:`scenarios.live.arm.forearm_pitch_rad`),
    with :data:`IMU_NOISE_RAD` of noise drawn after the sEMG from the same generator.

    Parameters
    ----------
    subject : VirtualSubject
    obj : ObjectSpec
    mvc_cal_n : float
        Largest measured force of the calibration recording, N.
    duration_s : float
        The session the recording is for, s; it lasts ``duration_s + tail_s``.
    rng : numpy.random.Generator, int or None
        Timing jitter and session noise.
    generator : str
        The sEMG model.
    safety_factor, hand_force_at_mvc_n : float
        The user's grip target (times the slip threshold) and the force mapping's scale.
    tail_s : float
        Recorded beyond ``duration_s``, s.
    fs_hz : float
        Sampling rate, Hz.
    hold_s : float
        The in-air hold the arm leaves at the end of ``duration_s``, s.
    forearm_m : float
        Elbow-to-wrist length, m.

    Returns
    -------
    Recording
        int8 sEMG at ``fs_hz`` with FSR force, ground truth and the forearm's pitch
        (``pitch_rad``); metadata ``protocol`` ``grasp_lift_hold``, the object, the
        target and ``arm_lift_s`` (when the arm starts the lift, s).
    """
    g = np.random.default_rng(rng) if not isinstance(rng, np.random.Generator) else rng
    target_n = intended_grip_n(obj, safety_factor)
    hold_level = float(np.clip(target_n / hand_force_at_mvc_n * mvc_cal_n / subject.mvc_n,
                               0.0, 1.0))
    profile = grasp_lift_hold(g, fs_hz=fs_hz, hold_level=hold_level, rest_s=REST_S,
                              ramp_s=RAMP_S, hold_s=duration_s, jitter=0.1)
    recording = subject.record(profile, generator=generator, fs_hz=fs_hz, rng=g)
    recording = recording.slice(0, min(recording.n_samples,
                                       int(round((duration_s + tail_s) * fs_hz))))
    lift_s = _lift_time_s(duration_s, hold_s)
    height = LIFT_HEIGHT_M * np.array([min_jerk((t - lift_s) / LIFT_DURATION_S)
                                       for t in recording.t_s])
    pitch = forearm_pitch_rad(height, forearm_m=forearm_m) + g.normal(0.0, IMU_NOISE_RAD,
                                                                      recording.n_samples)
    recording = replace(recording, pitch_rad=pitch)  # checked as any recording's series
    recording.metadata.update({"protocol": "grasp_lift_hold", "object": obj.name,
                               "object_mass_kg": obj.mass_kg, "object_friction": obj.friction,
                               "target_grip_n": target_n, "mvc_cal_n": mvc_cal_n,
                               "hand_force_at_mvc_n": hand_force_at_mvc_n,
                               "arm_lift_s": lift_s, "forearm_m": forearm_m})
    return recording


@dataclass
class RecordedEpisode:
    """An offline episode on a recording: its metrics, traces and controller design."""

    metrics: dict[str, Any]
    traces: dict[str, np.ndarray]
    design: Any
    timings: dict[str, float]


def check_layout(recording: Recording, cal: RecordedCalibration) -> None:
    """Refuse a recording whose channel count or rate differs from the calibration's."""
    if recording.n_channels != cal.n_channels or recording.fs_hz != cal.fs_hz:
        raise RecordingError(
            f"{recording.source} has {recording.n_channels} channels at {recording.fs_hz:g} Hz "
            f"but the calibration recording {cal.recording.source} has {cal.n_channels} "
            f"channels at {cal.fs_hz:g} Hz; expected the same channel count and rate"
        )


def episode_on_recording(recording: Recording, cal: RecordedCalibration, obj: ObjectSpec, *,
                         controller: str = "pid",
                         controller_spec: Mapping[str, Any] | None = None,
                         episode_s: float = 8.0, hold_s: float = 2.0,
                         control_dt_s: float = 0.01,
                         hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N, seed: int = 0,
                         record_frames: bool = False) -> RecordedEpisode:
    """The offline episode driven by ``recording``: what a live session of it should give.

    Parameters
    ----------
    recording : Recording
        The user's sEMG during the grasp (same channels and rate as the calibration).
    cal : RecordedCalibration
    obj : ObjectSpec
    controller : str
        Controller family.
    controller_spec : mapping, optional
        Keyword arguments of :func:`controllers.design.design_for_object`.
    episode_s, hold_s : float
        Episode length and in-air hold, s.
    control_dt_s : float
        Control period, s.
    seed : int
        Seeds the environment's reset, as a live session with the same seed does.
    record_frames : bool
        Also return rendered frames every 40 ms under ``traces["frames"]``.

    Raises
    ------
    RecordingError
        Another layout than the calibration's, or shorter than the episode.
    DivergedError
        Physics divergence.
    """
    check_layout(recording, cal)
    if recording.duration_s < episode_s:
        raise RecordingError(f"{recording.source} lasts {recording.duration_s:.2f} s; expected "
                             f"at least the episode's {episode_s:g} s")
    lift_after_s = _lift_time_s(episode_s, hold_s)
    timings = dict.fromkeys(("t_features_s", "t_estimator_s", "t_controller_s",
                             "t_physics_s"), 0.0)
    with one_blas_thread():
        design = grasp_design(obj, controller, control_dt_s, controller_spec)
        rec = recording.slice(0, min(recording.n_samples,
                                     int(round((episode_s + 0.5) * recording.fs_hz))))
        t0 = time.perf_counter()
        features = extract_features(rec, channels=cal.channels)
        timings["t_features_s"] = time.perf_counter() - t0
        to_hand = cal.to_hand(hand_force_at_mvc_n)
        ceiling = 1.2 * hand_force_at_mvc_n
        t0 = time.perf_counter()
        gated = cal.calibration.rest_gate().run(stream_estimates(cal.calibration, features))
        estimates = np.clip(gated * to_hand, 0.0, ceiling)
        timings["t_estimator_s"] = time.perf_counter() - t0
        n_steps = int(round(episode_s / control_dt_s))
        t_ctrl = np.arange(n_steps) * control_dt_s
        reference = reference_from_windows(estimates, features.t_s, t_ctrl)
        oracle = None
        if rec.intent_force_n is not None:
            true_n = np.clip(align_to_windows(rec.intent_force_n, rec.fs_hz) * to_hand, 0.0,
                             ceiling)
            oracle = reference_from_windows(true_n, features.t_s, t_ctrl)
        traces, failure, info = _closed_loop(obj, design, reference, t_ctrl, control_dt_s,
                                             episode_s, lift_after_s,
                                             np.random.SeedSequence(seed), timings,
                                             record_frames)
    if failure is not None:
        raise DivergedError(f"physics diverged at t = {info['time_s']:.3f} s: {failure}")
    n_run = traces["t_s"].size
    metrics = grasp_metrics(traces, info, lift_after_s=lift_after_s,
                            hold_from_s=episode_s - hold_s,
                            window_values_n=estimates[features.t_s <= episode_s],
                            window_dt_s=features.dt_s,
                            oracle_n=None if oracle is None else oracle[:n_run])
    return RecordedEpisode(metrics, traces, design, timings)


def grasp_metrics(traces: Mapping[str, np.ndarray], info: Mapping[str, Any], *,
                  lift_after_s: float, hold_from_s: float, window_values_n: np.ndarray,
                  window_dt_s: float, oracle_n: np.ndarray | None = None,
                  hold: np.ndarray | None = None, referee: Any = None) -> dict[str, Any]:
    """An episode's metrics of a run, offline or live.

    Parameters
    ----------
    traces : mapping of ndarray, shape (n_steps,)
        ``t_s``, ``reference_n``, ``grip_force_n``, ``tracked_reference_n``,
        ``both_sides``, ``object_height_m`` at the control rate.
    info : mapping
        The environment's last ``info`` (drop, crush and slip counters).
    lift_after_s, hold_from_s : float
        Earliest lift (the scripted schedule's; the wrist's first rise in a session the
        person paced) and start of the in-air hold, s.
    window_values_n : ndarray
        The hand reference at each feature window, N (for the volatility).
    window_dt_s : float
        Window increment, s.
    oracle_n : ndarray, optional
        The user's true force mapped to the hand; without it (a person) the
        estimation error is ``None``.
    hold : ndarray of bool, shape (n_steps,), optional
        The in-air hold's steps when the person paced the lift
        (:func:`scenarios.runners.trial_outcome.hold_window`); overrides ``hold_from_s``.
    referee : scenarios.runners.trial_outcome.TrialReferee, optional
        The trial's judge when the person paced the lift: the outcome is its (a secure
        lift, a fall after one, a break) rather than the scripted schedule's.

    Returns
    -------
    dict
        ``outcome`` (held, not_lifted, dropped, crushed), ``lifted``, ``dropped``,
        ``crushed``, ``peak_force_n``, ``hold_grip_n`` (median grip in the in-air
        hold), ``contact_peak_ratio``, ``slip_events``, ``slip_distance_m`` and
        :func:`scenarios.runners.episode_metrics.episode_metrics`'s figures, with the grasp
        starting when the reference first reaches 0.5 N (a person gives no cue).
        Values that do not exist are ``None``.
    """
    t, ref, grip = traces["t_s"], traces["reference_n"], traces["grip_force_n"]
    if t.size == 0:
        return {"outcome": None, "lifted": False, "dropped": False, "crushed": False,
                "peak_force_n": None, "hold_grip_n": None, "contact_peak_ratio": None,
                "slip_events": 0, "slip_distance_m": 0.0}
    rising = np.flatnonzero(ref >= CONTACT_N)
    start_s = float(t[rising[0]]) if rising.size else float(t[0])
    oracle = np.full(t.size, np.nan) if oracle_n is None else oracle_n
    base = episode_metrics(t, ref, grip, oracle, start_s=start_s, lift_s=lift_after_s,
                           hold_from_s=hold_from_s, hold=hold,
                           window_values_n=np.asarray(window_values_n),
                           window_dt_s=window_dt_s)
    ratio, _ = contact_peak_ratio(t, traces["tracked_reference_n"], grip, traces["both_sides"])
    lifted, dropped, crushed, outcome = judge_trial(traces, info, referee)
    held = t >= hold_from_s if hold is None else hold
    out: dict[str, Any] = {
        "outcome": outcome,
        "lifted": lifted, "dropped": dropped, "crushed": crushed,
        "peak_force_n": float(np.max(grip)),
        "hold_grip_n": float(np.median(grip[held])) if held.any() else None,
        "contact_peak_ratio": ratio,
        "slip_events": int(info.get("slip_events", 0)),
        "slip_distance_m": float(info.get("slip_distance_m", 0.0)),
        "grasp_start_s": start_s,
    }
    for key, value in base.items():
        if key not in out:
            out[key] = None if isinstance(value, float) and not np.isfinite(value) else value
    return out
