"""Sessions on recordings: the calibration fit, a virtual subject's grasp, the replayed trial.

A live session and an offline replay of its recording must be comparable, so both run
the one trial loop (:mod:`scenarios.runners.trial_loop`) from the same pieces:

- :func:`~scenarios.live.calibration_fit.fit_calibration` fits the estimator (and an
  open/close decoder) on a calibration recording (:mod:`scenarios.live.calibration_fit`, re-exported
  here);
- :func:`grasp_session` records a virtual subject grasping an object, aiming at the
  force an episode's user aims at through that calibration's force mapping, and
  lifting it with their own arm (the forearm's pitch, as an armband's IMU reads it);
- :class:`RecordedPerson` is a recording in a trial: its samples reach the hand's
  reference as the trial's clock reaches them (the live session's windows, estimator,
  gate and mapping: :class:`~scenarios.runners.semg_reference.SemgReference`; with a
  decoder, every window's MAV of all the armband's channels decoded, ``decoded``), and the
  wrist follows the recorded forearm's pitch through the live session's arm mapping
  (:func:`recorded_arm`); only a recording without a pitch lifts on
  the scripted user's schedule (``episode_s - hold_s - 0.6 s``, once the grip is
  established: :class:`~sim.user.scripted.ScriptedArm`);
- :func:`episode_on_recording` replays a recording in a trial;
- :func:`grasp_metrics` scores a run (replayed or live) the way an episode is scored,
  judged by the same referee (:func:`scenarios.runners.trial_outcome.judge`).

The time base is the live session's: control step ``k`` at ``t = k * control_dt_s``
uses every sample at or before ``t`` and the latest feature window that ended by then.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from controllers.design_cache import grasp_design
from estimation.threads import one_blas_thread
from scenarios.live.arm import (
    FOREARM_M,
    LIFT_HEIGHT_M,
    LIFT_S,
    ArmPoses,
    OrientationChannels,
    PitchArm,
    forearm_pitch_rad,
    virtual_arm_poses,
)
from scenarios.live.calibration_fit import (  # noqa: F401 - re-exported: the replay's API
    OPEN_ON,
    RecordedCalibration,
    calibration_decoder,
    fit_calibration,
    has_open_contractions,
    require_open_contractions,
    squeeze_part,
    with_open_contractions,
)
from scenarios.live.errors import ArmPosesError
from scenarios.live.reference_windows import ReferenceWindows
from scenarios.runners.episode import HAND_FORCE_AT_MVC_N
from scenarios.runners.episode_metrics import contact_peak_ratio, episode_metrics
from scenarios.runners.reference import RAMP_S, REST_S, intended_grip_n, reference_from_windows
from scenarios.runners.semg_reference import SemgReference
from scenarios.runners.trial_loop import DEFAULT_HAND, Frames, HandSettings, TrialLoop
from scenarios.runners.trial_outcome import TrialReferee, judge
from sim.hand.objects import ObjectSpec
from sim.hand.wrist import min_jerk
from sim.recording import Recording, RecordingError
from sim.user.intent import GraspLiftTiming, grasp_lift_hold
from sim.user.operator import Scene, WristMove
from sim.user.scripted import ScriptedArm
from sim.user.subjects import VirtualSubject

FS_HZ = 200.0
IMU_NOISE_RAD = float(np.radians(0.2))
"""SD of the noise on a virtual subject's recorded forearm pitch, rad."""


@dataclass(frozen=True)
class GraspScript:
    """What a virtual subject does while a grasp is recorded (:func:`grasp_session`).

    Attributes
    ----------
    rest_s : float
        Rest before the squeeze, s (jittered by 10 %, as the ramp and the hold).
    hold_s : float
        The in-air hold the default arm leaves at the end of the session, s.
    arm_moves : tuple of (float, float), optional
        ``(start_s, height_m)`` of each move of the arm, each a 0.6 s minimum-jerk move
        from where the previous one ended; default: one lift of 8 cm at
        ``duration_s - hold_s - 0.6 s``, as the scripted user's.
    safety_factor : float
        The user's grip target, times the object's slip threshold.
    hand_force_at_mvc_n : float
        The force mapping's scale, N.
    forearm_m : float
        Elbow-to-wrist length, m.
    generator : str
        The sEMG model.
    fs_hz : float
        Sampling rate, Hz.
    tail_s : float
        Recorded beyond the session, s.
    """

    rest_s: float = REST_S
    hold_s: float = 2.0
    arm_moves: tuple[tuple[float, float], ...] | None = None
    safety_factor: float = 1.5
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N
    forearm_m: float = FOREARM_M
    generator: str = "noise"
    fs_hz: float = FS_HZ
    tail_s: float = 1.0

    def moves(self, duration_s: float) -> tuple[tuple[float, float], ...]:
        """The arm's moves in a session of ``duration_s``."""
        if self.arm_moves is not None:
            return tuple((float(t), float(h)) for t, h in self.arm_moves)
        return ((duration_s - self.hold_s - LIFT_S, LIFT_HEIGHT_M),)


def arm_height_m(t_s: np.ndarray, moves: Sequence[tuple[float, float]]) -> np.ndarray:
    """The wrist's height at ``t_s`` after ``moves`` (:attr:`GraspScript.arm_moves`), m."""
    height = np.zeros(np.shape(t_s))
    for start_s, to_m in moves:
        s = np.clip((np.asarray(t_s) - start_s) / LIFT_S, 0.0, 1.0)
        height = np.where(s > 0.0, height + (to_m - height) * np.vectorize(min_jerk)(s), height)
    return height


def grasp_session(subject: VirtualSubject, obj: ObjectSpec, *, mvc_cal_n: float,
                  duration_s: float = 8.0, rng: np.random.Generator | int | None = 0,
                  script: GraspScript = GraspScript()) -> Recording:
    """A virtual subject's sEMG and forearm pitch while they grasp ``obj`` and lift it.

    The user aims at :func:`scenarios.runners.reference.intended_grip_n` on the hand,
    which they reach through the calibration's mapping (``mvc_cal_n``, the largest
    force of the calibration recording): rest ``script.rest_s``, a 0.5 s ramp, then a
    hold lasting beyond the session (timings jittered by 10 %). Their arm moves the
    wrist as ``script`` says (by default it lifts as the scripted user's does, at
    ``duration_s - hold_s - 0.6 s`` by 8 cm along a 0.6 s minimum-jerk path, and stays
    up); the forearm pivots at the elbow, so its pitch is ``asin(height / forearm_m)``
    (:func:`scenarios.live.arm.forearm_pitch_rad`), with :data:`IMU_NOISE_RAD` of noise
    drawn after the sEMG from the same generator.

    Parameters
    ----------
    subject : VirtualSubject
    obj : ObjectSpec
    mvc_cal_n : float
        Largest measured force of the calibration recording, N.
    duration_s : float
        The session the recording is for, s; it lasts ``duration_s + script.tail_s``.
    rng : numpy.random.Generator, int or None
        Timing jitter and session noise.
    script : GraspScript
        What the subject does.

    Returns
    -------
    Recording
        int8 sEMG at ``script.fs_hz`` with FSR force, ground truth and the forearm's pitch
        (``pitch_rad``); metadata ``protocol`` ``grasp_lift_hold``, the object, the
        target, ``arm_moves`` and ``arm_lift_s`` (when the arm first starts up, s).
    """
    g = np.random.default_rng(rng) if not isinstance(rng, np.random.Generator) else rng
    fs_hz = script.fs_hz
    target_n = intended_grip_n(obj, script.safety_factor)
    hold_level = float(np.clip(target_n / script.hand_force_at_mvc_n * mvc_cal_n
                               / subject.mvc_n, 0.0, 1.0))
    timing = GraspLiftTiming(rest_s=script.rest_s, ramp_s=RAMP_S, hold_s=duration_s)
    profile = grasp_lift_hold(g, fs_hz=fs_hz, hold_level=hold_level, timing=timing,
                              jitter=0.1)
    recording = subject.record(profile, generator=script.generator, fs_hz=fs_hz, rng=g)
    recording = recording.slice(0, min(recording.n_samples,
                                       int(round((duration_s + script.tail_s) * fs_hz))))
    moves = script.moves(duration_s)
    height = arm_height_m(recording.t_s, moves)
    pitch = forearm_pitch_rad(height, forearm_m=script.forearm_m) + g.normal(
        0.0, IMU_NOISE_RAD, recording.n_samples)
    recording = replace(recording, pitch_rad=pitch)  # checked as any recording's series
    up = [t for t, h in moves if h > 0.0]
    recording.metadata.update({"protocol": "grasp_lift_hold", "object": obj.name,
                               "object_mass_kg": obj.mass_kg, "object_friction": obj.friction,
                               "target_grip_n": target_n, "mvc_cal_n": mvc_cal_n,
                               "hand_force_at_mvc_n": script.hand_force_at_mvc_n,
                               "arm_moves": [list(m) for m in moves],
                               "arm_lift_s": up[0] if up else None,
                               "forearm_m": script.forearm_m})
    return recording


@dataclass(frozen=True)
class ReplaySpec:
    """How a recording is replayed in a trial.

    Attributes
    ----------
    controller : str
        Controller family.
    controller_spec : mapping, optional
        The flat design specification (:meth:`~controllers.design_spec.DesignSpec.from_mapping`).
    episode_s : float
        The trial's time limit, s (the recording must last that long).
    hold_s : float
        The in-air hold of the scripted lift (a recording without a pitch), s.
    control_dt_s : float
        Control period, s.
    hand_force_at_mvc_n : float
        Hand force at the calibration's strongest squeeze, N.
    seed : int
        Seeds the environment's reset, as a live session with the same seed does.
    lift_height_m : float or None
        The lift the task asks for (the referee's secure lift), m; ``None``: held on the
        table (and a recording without a pitch is not lifted).
    hand : HandSettings
        The hand's drive, paradigm and own slip response.
    """

    controller: str = "pid"
    controller_spec: Mapping[str, Any] | None = None
    episode_s: float = 8.0
    hold_s: float = 2.0
    control_dt_s: float = 0.01
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N
    seed: int = 0
    lift_height_m: float | None = LIFT_HEIGHT_M
    hand: HandSettings = DEFAULT_HAND


def recorded_arm_poses(recording: Recording, calibration: Recording | None = None) -> ArmPoses:
    """The poses that map a recording's forearm pitch to the wrist's height.

    The recording's own (a live session's ``--record`` keeps its arm's; a calibration
    recording its ``arm_poses``), else the calibration recording's, else, for a virtual
    subject's grasp (``griploop subjects --grasp``, metadata ``forearm_m``), the
    virtual forearm's.

    Raises
    ------
    ArmPosesError
        None of them: the pitch cannot be mapped (one line naming the column).
    """
    meta = recording.metadata
    arm = meta.get("arm")
    if isinstance(arm, Mapping) and arm.get("poses") is not None:
        return ArmPoses.from_metadata({"arm_poses": arm["poses"]}, recording.source)
    for rec in (recording, calibration):
        poses = None if rec is None else ArmPoses.from_metadata(rec.metadata, rec.source)
        if poses is not None:
            return poses
    if "forearm_m" in meta:
        return virtual_arm_poses(forearm_m=float(meta["forearm_m"]))
    raise ArmPosesError(
        f"{recording.source}: column pitch_rad has no arm poses to map it to the wrist's "
        "height; expected metadata arm_poses (griploop calibrate --lsl with the IMU stream) "
        "in it or in the calibration recording, or --arm-poses REST_DEG:RAISED_DEG")


def recorded_arm(pitch_rad: np.ndarray, fs_hz: float, poses: ArmPoses) -> PitchArm:
    """A :class:`~scenarios.live.arm.PitchArm` fed a recorded forearm pitch: sample ``i`` at
    ``i / fs_hz`` of the session, as a live session's arm would have received it."""
    arm = PitchArm(poses, OrientationChannels("pitch", (0,), 1.0, ("pitch_rad",)),
                   imu_fs_hz=fs_hz)
    arm.feed(np.asarray(pitch_rad, dtype=float)[:, None],
             np.arange(len(pitch_rad)) / float(fs_hz), 0.0, 0.0)
    return arm


class RecordedPerson:
    """A recording in a trial: its sEMG as the clock reaches it, its recorded arm (module notes).

    Parameters
    ----------
    recording : Recording
        The sEMG (the calibration's layout), with the forearm's pitch when it has one.
    cal : RecordedCalibration
    spec : ReplaySpec
    poses : ArmPoses, optional
        Map the pitch (default: :func:`recorded_arm_poses` of the recording and the
        calibration recording).
    start_s : float
        Recording time of the trial's first step, s (earlier samples warm the windows and
        the estimator up).

    Raises
    ------
    ArmPosesError
        A pitch without poses to map it.
    """

    done = False

    def __init__(self, recording: Recording, cal: RecordedCalibration, spec: ReplaySpec, *,
                 poses: ArmPoses | None = None, start_s: float = 0.0) -> None:
        self.recording, self.start_s, self.dt = recording, float(start_s), spec.control_dt_s
        self.reference = SemgReference(
            cal.calibration, fs_hz=recording.fs_hz, channel_index=cal.channel_index,
            hand_force_at_mvc_n=spec.hand_force_at_mvc_n, integer=cal.integer,
            forces=None if recording.force_n is None else self.forces)
        self.arm = self.scripted = None
        if recording.pitch_rad is not None:
            poses = poses or recorded_arm_poses(recording, cal.recording)
            self.arm = recorded_arm(recording.pitch_rad, recording.fs_hz, poses)
            self.wrist_tremor_m = self.arm.tremor_m
        else:
            self.scripted = ScriptedArm(LIFT_S)
            if spec.lift_height_m is not None:
                self.scripted.time_lift(spec.episode_s - spec.hold_s - LIFT_S,
                                        spec.lift_height_m)
            self.wrist_tremor_m = 0.0
        self.pushed = 0

    @property
    def decoded(self) -> Any:
        """The latest window's open and close signals
        (:class:`controllers.paradigms.Decoded`; ``None`` without a decoder)."""
        return self.reference.decoded

    def act(self, k: int, scene: Scene, setpoint_m: float) -> tuple[float, WristMove | None]:
        """The reference at step ``k`` from every sample by then, and the recorded arm's move."""
        t = self.start_s + k * self.dt
        self.samples_to(t)
        if self.arm is not None:
            return self.reference.reference_n, self.arm.command(t, setpoint_m)
        self.scripted.perceive(scene)
        return self.reference.reference_n, self.scripted.wrist_move()

    def forces(self) -> tuple[np.ndarray, np.ndarray]:
        """The true force (NaN where the recording has none) and the measured force, N."""
        rec = self.recording
        true_n = (rec.intent_force_n if rec.intent_force_n is not None
                  else np.full(rec.n_samples, np.nan))
        return true_n, rec.force_n

    def samples_to(self, t_s: float) -> None:
        """Push every sample at or before ``t_s`` (recording time)."""
        rec = self.recording
        n = min(int(math.floor((t_s + 1e-9) * rec.fs_hz)) + 1, rec.n_samples)
        if n > self.pushed:
            self.reference.push(rec.emg[self.pushed:n])
            self.pushed = n


@dataclass
class RecordedEpisode:
    """A replayed trial: its metrics, traces, controller design and timings."""

    metrics: dict[str, Any]
    traces: dict[str, np.ndarray]
    design: Any
    timings: dict[str, float]
    referee: TrialReferee | None = None


def check_layout(recording: Recording, cal: RecordedCalibration) -> None:
    """Refuse a recording whose channel count or rate differs from the calibration's."""
    if recording.n_channels != cal.n_channels or recording.fs_hz != cal.fs_hz:
        raise RecordingError(
            f"{recording.source} has {recording.n_channels} channels at {recording.fs_hz:g} Hz "
            f"but the calibration recording {cal.recording.source} has {cal.n_channels} "
            f"channels at {cal.fs_hz:g} Hz; expected the same channel count and rate"
        )


def episode_on_recording(recording: Recording, cal: RecordedCalibration, obj: ObjectSpec,
                         spec: ReplaySpec = ReplaySpec(), *, record_frames: bool = False,
                         poses: ArmPoses | None = None) -> RecordedEpisode:
    """A recording replayed in a trial: what a live session of it should give.

    Parameters
    ----------
    recording : Recording
        The user's sEMG during the grasp (same channels and rate as the calibration),
        with the forearm's pitch when it was recorded.
    cal : RecordedCalibration
    obj : ObjectSpec
    spec : ReplaySpec
    record_frames : bool
        Also return rendered frames every 40 ms under ``traces["frames"]``.
    poses : ArmPoses, optional
        Map the pitch (default: the recording's, the calibration's, a virtual forearm's).

    Raises
    ------
    RecordingError
        Another layout than the calibration's, or shorter than the episode.
    ArmPosesError
        A pitch without poses to map it.
    DivergedError
        Physics divergence.
    """
    from scenarios.runners.dispatch import DivergedError
    from scenarios.runners.trial_loop import TrialHooks, TrialTiming

    check_layout(recording, cal)
    if recording.duration_s < spec.episode_s:
        raise RecordingError(f"{recording.source} lasts {recording.duration_s:.2f} s; expected "
                             f"at least the episode's {spec.episode_s:g} s")
    with one_blas_thread():
        design = grasp_design(obj, spec.controller, spec.control_dt_s,
                              spec.hand.check().controller_spec(spec.controller_spec))
        person = RecordedPerson(recording, cal, spec, poses=poses)
        loop = TrialLoop(obj, design, person, TrialTiming(spec.episode_s, spec.control_dt_s),
                         lift_height_m=spec.lift_height_m, seed=session_seed(spec.seed),
                         hooks=TrialHooks(frames=Frames() if record_frames else None),
                         hand=spec.hand)
        loop.run()
        person.samples_to(spec.episode_s)  # the windows of the whole episode, for the metrics
    if loop.failure is not None:
        raise DivergedError(f"physics diverged at t = {loop.info['time_s']:.3f} s: "
                            f"{loop.failure}")
    traces = loop.traces()
    chain = person.reference
    window_t = np.asarray(chain.window_t_s)
    oracle = None
    if recording.intent_force_n is not None:
        true_n = np.clip(recording.intent_force_n[np.asarray(chain.window_end, dtype=int)]
                         * chain.to_hand, 0.0, chain.ceiling)
        oracle = reference_from_windows(true_n, window_t, traces["t_s"])
    metrics = grasp_metrics(traces, loop.info, loop.referee, obj,
                            control_dt_s=spec.control_dt_s,
                            wrist_tremor_m=person.wrist_tremor_m,
                            windows=ReferenceWindows.of(chain, spec.episode_s), oracle_n=oracle)
    metrics.update(chain.decoder_counts(recording.open_intent))
    timings = {**chain.timings, "t_controller_s": loop.controller_s,
               "t_physics_s": loop.physics_s}
    return RecordedEpisode(metrics, traces, design, timings, loop.referee)


def session_seed(seed: int) -> int:
    """The environment's reset seed of a session or replay with ``seed``."""
    return int(np.random.SeedSequence(seed).generate_state(1)[0])


def grasp_metrics(traces: Mapping[str, np.ndarray], info: Mapping[str, Any],
                  referee: TrialReferee, obj: ObjectSpec, *, control_dt_s: float,
                  wrist_tremor_m: float, windows: ReferenceWindows,
                  oracle_n: np.ndarray | None = None) -> dict[str, Any]:
    """The metrics of a person's trial (replayed or live), judged as every trial is.

    Parameters
    ----------
    traces : mapping of ndarray, shape (n_steps,)
        ``t_s``, ``reference_n``, ``grip_force_n``, ``tracked_reference_n``,
        ``both_sides``, ``object_height_m``, ``wrist_height_m`` at the control rate.
    info : mapping
        The environment's last ``info`` (slip counters).
    referee : TrialReferee
        The trial's referee (:func:`scenarios.runners.trial_outcome.judge`).
    obj : ObjectSpec
        The object (its slip force, for the safety margin).
    control_dt_s : float
        Control period, s.
    wrist_tremor_m : float
        How much the person's wrist moves when held still, m (the hold's end).
    windows : ReferenceWindows
        The hand reference at each feature window and their increment (for the
        volatility).
    oracle_n : ndarray, optional
        The user's true force mapped to the hand; without it (a person) the
        estimation error is ``None``.

    Returns
    -------
    dict
        The verdict (``outcome``, ``lifted``, ``dropped``, ``crushed``, ``attempts``,
        ``time_to_lift_s``, ``safety_margin_pct``, ``released``), ``peak_force_n``,
        ``hold_grip_n`` (median grip in the in-air hold), ``contact_peak_ratio``,
        ``slip_events``, ``slip_distance_m``, ``grasp_start_s`` and
        :func:`scenarios.runners.episode_metrics.episode_metrics`'s figures, with the
        grasp starting when the reference first reaches 0.5 N (a person gives no cue).
        Values that do not exist are ``None``.
    """
    from scenarios.runners.episode_metrics import grasp_start_s
    from scenarios.runners.reference import ReferenceStream

    t, ref, grip = traces["t_s"], traces["reference_n"], traces["grip_force_n"]
    if t.size == 0:
        return {"outcome": None, "lifted": False, "dropped": False, "crushed": False,
                "attempts": 0, "time_to_lift_s": None, "safety_margin_pct": None,
                "released": False, "peak_force_n": None, "hold_grip_n": None,
                "contact_peak_ratio": None, "slip_events": 0, "slip_distance_m": 0.0}
    verdict = judge(traces, referee, obj, control_dt_s=control_dt_s,
                    wrist_tremor_m=wrist_tremor_m)
    start_s = grasp_start_s(t, ref)
    oracle = np.full(t.size, np.nan) if oracle_n is None else oracle_n
    stream = ReferenceStream(start_s, np.asarray(windows.values_n), windows.dt_s, t, ref, oracle)
    base = episode_metrics(stream, grip, lift_s=verdict.lift_start_s, hold=verdict.hold)
    ratio, _ = contact_peak_ratio(t, traces["tracked_reference_n"], grip, traces["both_sides"])
    held = verdict.hold
    out: dict[str, Any] = {
        **verdict.fields(),
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
