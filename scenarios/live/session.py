"""The real-time loop of a live session, paced by the incoming sEMG samples.

:class:`LiveGrasp` is the prosthesis side of a session with no LSL in it: it takes
samples with their time stamps and arrival times (:meth:`LiveGrasp.feed`) and the
wall clock (:meth:`LiveGrasp.tick`), and is the person of the one trial loop
(:class:`~scenarios.runners.trial_loop.TrialLoop`) that every trial runs: the same
windows, estimator stream, rest gate and mapping
(:class:`~scenarios.runners.semg_reference.SemgReference`), the cached controller
design, the hand, the recorder, the referee and the ending rule as the replay of its
recording (:func:`scenarios.live.recorded.episode_on_recording`), which therefore gives
the same trial from a stream that delivers every sample. The wrist is the person's: an
:class:`~scenarios.live.arm.Arm` moves it before each control step, from the forearm's
pitch on the armband's IMU stream (:class:`~scenarios.live.arm.PitchArm`, fed by
:meth:`LiveGrasp.feed_imu`) or from a key (:class:`~scenarios.live.arm.KeyArm`). The
referee judges the session as every trial: a lift that leaves the object behind is an
attempt and the session goes on; it ends when the object is crushed or falls after a
secure lift (the hand then holds its grip, as through a fault, and the report says
why), or at its duration. :func:`scenarios.live.inlets.run_session` feeds it from LSL
inlets.

Time base. Sample ``n`` of the stream is at session time ``n / fs_hz``, where ``n``
counts from the first sample and includes lost samples (a jump between consecutive
time stamps of more than 1.5 sample periods counts ``round(jump * fs) - 1`` lost).
Control step ``k`` (``t = k * control_dt_s``) runs as soon as the last sample at or
before ``t`` has arrived, with the latest window that ended by then, as offline.

Timing report. The latency of a control step is the wall time from the arrival of
the sample that released it (the return of the inlet's pull) to the end of the
step: window features, estimate, controller, the command applied to the simulated
motor and the physics advanced by one control period. A step misses its deadline
when that takes longer than one control period. The physics real-time factor is
simulated time over the wall time spent in ``GraspEnv.step``.

Safe when the stream is not:

- a step whose sample is ``late_s`` (50 ms) overdue runs on the wall clock with
  the reference held, so the hand never waits for the stream;
- after ``gap_hold_s`` (200 ms) with no sample the hand holds its current grip: the
  reference becomes the smaller of the last reference and the measured grip
  (it never opens mid-lift and never ramps up); the gap is logged (``gaps``,
  ``gap_start``/``gap_end`` events). When samples return, the windows restart on
  the fresh samples (no window spans the gap) and control resumes with the first
  window's estimate, 400 ms later; the estimator keeps its state;
- no sample for ``timeout_s`` ends the session (``ended: "timeout"``);
- the stream's source gone from the network while another source serves its name
  (:class:`~scenarios.live.lsl.SourceWatch`, asked during a gap) ends the session
  (``ended: "source_changed"``, event ``source_changed``) with the hand holding its
  grip: samples from another source are never used;
- a stall of the IMU stream holds the wrist still (:mod:`scenarios.live.arm`); the
  hand keeps following the sEMG; decoded signals (:attr:`LiveGrasp.decoded`) are relaxed
  while the hand holds its grip: under ``velocity`` the motor stops.

Bad samples (non-numeric or NaN, out of range) are counted and replaced by 0 or
clipped by :class:`~scenarios.live.samples.SampleGuard`; they never stop a session.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.design_cache import grasp_design
from controllers.paradigms import RELAXED
from scenarios.live.arm import LIFT_HEIGHT_M, Arm
from scenarios.live.hooks import DEFAULT_HOOKS, SessionHooks
from scenarios.live.recorded import RecordedCalibration, grasp_metrics, session_seed
from scenarios.live.reference_windows import ReferenceWindows
from scenarios.live.samples import SampleGuard
from scenarios.live.timing import percentile, warnings_for
from scenarios.runners.episode import HAND_FORCE_AT_MVC_N
from scenarios.runners.semg_reference import SemgReference
from scenarios.runners.trial_loop import (
    DEFAULT_HAND,
    Frames,
    HandSettings,
    TrialHooks,
    TrialLoop,
    TrialTiming,
)
from sim.hand.objects import ObjectSpec
from sim.recording import Recording
from sim.user.feedback import FeedbackDevice
from sim.user.operator import Scene, WristMove

GAP_HOLD_S = 0.2
"""No sample for this long: the hand holds its grip and a gap is logged, s."""
LATE_S = 0.05
"""A control step whose sample is this much overdue runs on the wall clock, s."""
TIMEOUT_S = 5.0
"""Default: no sample for this long ends the session, s."""
STALE_S = 0.5
"""Before the first sample is accepted, samples older than this are skipped, s."""


@dataclass(frozen=True)
class SessionSettings:
    """How a live session runs.

    Attributes
    ----------
    duration_s : float
        Session length in stream time, s (the episode length).
    control_dt_s : float
        Control period, s.
    hand_force_at_mvc_n : float
        Hand force commanded at the calibration's strongest squeeze, N.
    gap_hold_s, late_s, timeout_s : float
        See the module notes, s.
    frame_dt_s : float or None
        Store the hand's state every this many seconds of session time for a video
        (``None``: none).
    seed : int
        Seeds the environment's reset (as an offline episode with the same seed).
    hand : HandSettings
        The hand's drive, paradigm and own slip response.
    feedback : str
        The stimulator's mode (:attr:`sim.user.feedback.FeedbackDevice.MODES`; ``"none"``).
    """

    duration_s: float = 8.0
    control_dt_s: float = 0.01
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N
    gap_hold_s: float = GAP_HOLD_S
    late_s: float = LATE_S
    timeout_s: float = TIMEOUT_S
    frame_dt_s: float | None = None
    seed: int = 0
    hand: HandSettings = DEFAULT_HAND
    feedback: str = "none"


class LiveGrasp:
    """A grasp-lift-hold driven by samples as they arrive.

    Parameters
    ----------
    cal : RecordedCalibration
        The fitted estimator and the layout of the samples.
    obj : ObjectSpec
        The object.
    arm : Arm
        What moves the wrist: the person's forearm (IMU) or their key.
    controller : str
        Controller family.
    controller_spec : mapping, optional
        The flat design specification (:meth:`~controllers.design_spec.DesignSpec.from_mapping`).
    settings : SessionSettings
    hooks : SessionHooks
        Where the outlets' values, the markers and the terminal lines go, and the wall
        clock (default: nowhere; ``time.perf_counter``).
    viewer : object, optional
        Something with ``sync()`` (:class:`scenarios.live.display.Viewer`), called every
        40 ms of session time.

    Attributes
    ----------
    finished : bool
        The session has ended; ``ended`` says why (``duration``, ``dropped`` after a
        secure lift, ``crushed``, ``timeout``, ``diverged``, ``interrupted``,
        ``source_changed``).
    events : list of (float, str)
        Every marker emitted, with its session time, s.
    trial : TrialLoop
        The trial the session drives (its hand, recorder and referee).
    """

    done = False  # the person never signals the end: the session runs its duration

    def __init__(self, cal: RecordedCalibration, obj: ObjectSpec, *, arm: Arm, controller: str,
                 controller_spec: Mapping[str, Any] | None = None,
                 settings: SessionSettings = SessionSettings(),
                 hooks: SessionHooks = DEFAULT_HOOKS, viewer: Any = None) -> None:
        s = settings
        publish, event, notify, clock = hooks.publish, hooks.event, hooks.notify, hooks.clock
        self.settings, self.cal, self.obj, self.controller = s, cal, obj, controller
        self.arm = arm
        self.wrist_tremor_m = float(arm.tremor_m)
        self.design = grasp_design(obj, controller, s.control_dt_s,
                                   s.hand.check().controller_spec(controller_spec))
        self.chain = SemgReference(cal.calibration, fs_hz=cal.fs_hz,
                                   channel_index=cal.channel_index,
                                   hand_force_at_mvc_n=s.hand_force_at_mvc_n,
                                   integer=cal.integer)
        frames = None if s.frame_dt_s is None else Frames(s.frame_dt_s, "state")
        self.trial = TrialLoop(obj, self.design, self, TrialTiming(s.duration_s, s.control_dt_s),
                               lift_height_m=LIFT_HEIGHT_M, seed=session_seed(s.seed),
                               hooks=TrialHooks(frames=frames), hand=s.hand)
        self.env = self.trial.env
        self.guard = SampleGuard(cal.integer)
        self.fs_hz = cal.fs_hz
        self.n_steps = self.trial.n_steps
        self._publish, self._event, self._clock = publish, event, clock
        self.feedback = FeedbackDevice(s.feedback, force_range_n=s.hand_force_at_mvc_n)
        self.viewer = viewer
        self.viewer_every = max(1, int(round(0.04 / s.control_dt_s)))
        n = self.n_steps
        self._stimulus, self._latency = np.zeros(n), np.zeros(n)
        self._n_latency = 0
        capacity = int(np.ceil((s.duration_s + s.timeout_s + 2.0) * self.fs_hz))
        self._transport = np.zeros(capacity)
        self._n_transport = 0
        self._samples = np.zeros((capacity, cal.n_channels), dtype=self.guard.dtype)
        self._pitch = np.full(capacity, np.nan)  # the arm's latest pitch at each sample
        self.gaps: list[dict[str, float]] = []
        self.finished, self.ended = False, ""
        self.failure: str | None = None
        self.events: list[tuple[float, str]] = []
        self.source_changes: list[dict[str, Any]] = []
        self._notify = notify
        self.received = self.lost = self.deadline_misses = self.stale_skipped = 0
        self.wall_s = 0.0
        # what start() sets, so that an unstarted session reports (nothing happened)
        self.n, self.in_gap, self.holding = -1, False, False
        self.hold_n = 0.0
        self.ts0 = self.ts_last = self.last_arrival = math.nan
        self.started_wall = clock()
        arm.bind(self._emit, self._say)

    # ------------------------------------------------------------------ the person
    def act(self, k: int, scene: Scene, setpoint_m: float) -> tuple[float, WristMove | None]:
        """The person's part of control step ``k``: the latest window's reference and the
        move their arm starts now (:class:`~scenarios.runners.trial_loop.Person`)."""
        return self.chain.reference_n, self.arm.command(k * self.settings.control_dt_s,
                                                        setpoint_m)

    @property
    def decoded(self) -> Any:
        """The latest window's :class:`~controllers.paradigms.Decoded` (``None`` without a
        decoder), relaxed while the hand holds its grip (read before ``start()`` too)."""
        d = self.chain.decoded
        return RELAXED if d is not None and getattr(self, "holding", False) else d

    @property
    def k(self) -> int:
        """Control steps run."""
        return self.trial.k

    @property
    def info(self) -> dict[str, Any]:
        """The environment's ``info`` after the last step."""
        return self.trial.info

    @property
    def reference_n(self) -> float:
        """The reference the latest window asks for, N."""
        return self.chain.reference_n

    @property
    def referee(self) -> Any:
        """The session's referee."""
        return self.trial.referee

    @property
    def frames(self) -> list[tuple[np.ndarray, bool]]:
        """The hand's states kept for the video: ``(qpos, crushed)``."""
        return self.trial.recorder.frames

    @property
    def traces(self) -> dict[str, np.ndarray]:
        """The session's traces so far, with the stimulator's intensity (``feedback``)."""
        return {**self.trial.traces(), "feedback": self._stimulus[:self.trial.k]}

    def keep_frames(self, every_s: float) -> None:
        """Keep the hand's state every ``every_s`` of session time for a video."""
        self.trial.keep_frames(Frames(every_s, "state"))

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> None:
        """Reset the hand, the controller, the estimator and the windows."""
        self.trial.reset()
        self.chain.reset()
        self.arm.reset()
        self.events = []
        self.holding = False
        self.hold_n = 0.0
        self.in_gap = False
        self.n = -1  # index of the last sample (session time n / fs)
        self.ts0 = self.ts_last = math.nan
        self.last_arrival = math.nan
        self.started_wall = self._clock()
        self._stimulus[:] = 0.0
        self._lifted = False
        self._slips = 0
        self._dropped = self._crushed = False
        self._last_gc_t = 0.0

    def finish(self, why: str) -> None:
        """End the session (once): ``why`` goes to the report's ``ended``."""
        if not self.finished:
            now = self._clock()
            self.finished, self.ended = True, why
            self.wall_s = now - self.started_wall
            if self.in_gap and math.isnan(self.gaps[-1]["duration_s"]):
                self.gaps[-1]["duration_s"] = float(now - self.last_arrival)
            close = getattr(self.arm, "close", None)
            if close is not None:
                close(now)
            self._emit("session_end")

    # ------------------------------------------------------------------ input
    def feed(self, samples: np.ndarray, stamps: np.ndarray, arrival: float,
             lsl_now: float | None = None) -> None:
        """Take a chunk of samples that arrived at ``arrival`` (wall clock, s).

        Parameters
        ----------
        samples : array-like, shape (m, n_channels)
            As delivered (any dtype; strings are parsed): cleaned by the guard.
        stamps : ndarray, shape (m,)
            Their time stamps on the stream's clock, s.
        arrival : float
            When they arrived, on this object's clock.
        lsl_now : float, optional
            The stream clock at arrival: transport latency ``lsl_now - stamp``.
        """
        if self.finished:
            return
        x = self.guard.clean(samples)
        fs = self.fs_hz
        for i in range(x.shape[0]):
            ts = float(stamps[i])
            if self.n < 0:
                if lsl_now is not None and lsl_now - ts > STALE_S:
                    self.stale_skipped += 1
                    continue
                self.n, self.ts0 = 0, ts
                self._emit("session_start")
            else:
                jump = (ts - self.ts_last) * fs
                lost = int(round(jump)) - 1 if jump > 1.5 else 0
                self.lost += lost
                if self.in_gap or lost >= self.settings.gap_hold_s * fs:
                    self._close_gap(self.n, lost, arrival - self.last_arrival)
                self.n += 1 + lost
            self.ts_last = ts
            self.last_arrival = arrival
            if self.received < self._samples.shape[0]:
                self._samples[self.received] = x[i]
                self._pitch[self.received] = getattr(self.arm, "latest_pitch_rad", math.nan)
                if lsl_now is not None:
                    self._transport[self._n_transport] = lsl_now - ts
                    self._n_transport += 1
            self.received += 1
            if self.chain.push(x[i:i + 1]):  # a window with an estimate: control resumes
                self.holding = False
            # every control step whose time precedes the next sample's
            t_next = (self.n + 1) / fs
            dt = self.settings.control_dt_s
            while not self.finished and self.k * dt + 1e-9 < t_next:
                self._step(arrival, None)
            if self.finished:
                return

    def feed_imu(self, samples: np.ndarray, stamps: np.ndarray, arrival: float) -> None:
        """Take orientation samples for the arm (:meth:`scenarios.live.arm.PitchArm.feed`)."""
        if not self.finished:
            self.arm.feed(samples, stamps, arrival, self.ts0 if self.n >= 0 else None)

    def source_changed(self, stream: str, pinned: Mapping[str, Any],
                       found: Mapping[str, Any]) -> None:
        """Another source took over the name of a stream the session pinned: hold and end.

        Parameters
        ----------
        stream : str
            Which stream (``emg`` or ``imu``).
        pinned, found : mapping
            :func:`scenarios.live.lsl.identity` of the pinned stream and of the one
            now serving its name.
        """
        if self.finished:
            return
        self._hold_grip()
        t = max(self.k - 1, 0) * self.settings.control_dt_s
        self.source_changes.append({"t_s": round(t, 4), "stream": stream,
                                    "pinned": dict(pinned), "found": dict(found)})
        self._emit("source_changed")
        label = {"emg": "sEMG", "imu": "IMU"}.get(stream, stream)
        self._say(f"source_changed at {t:.2f} s: the {label} stream {found.get('name')!r} now "
                  f"comes from source_id {found.get('source_id')!r} on host "
                  f"{found.get('host')!r}, not the session's source_id "
                  f"{pinned.get('source_id')!r}: session ended, the hand holds its grip "
                  f"({self.hold_n:.1f} N)")
        self.finish("source_changed")

    def tick(self, now: float) -> None:
        """Let the wall clock act: overdue steps, gap detection, timeout."""
        if self.finished:
            return
        s = self.settings
        if self.n >= 0:
            self.arm.tick(now, max(self.k - 1, 0) * s.control_dt_s)
        if self.n < 0:
            if now - self.started_wall >= s.timeout_s:
                self.finish("timeout")
            return
        silent = now - self.last_arrival
        if silent >= s.timeout_s:
            self._open_gap(self.n)
            self.gaps[-1]["duration_s"] = float(silent)
            self.in_gap = False
            self.finish("timeout")
            return
        if silent >= s.gap_hold_s and not self.in_gap:
            self._open_gap(self.n)
        while not self.finished and now >= self._due(self.k) + s.late_s:
            self._step(None, self._due(self.k) + s.late_s)

    def wait_s(self, now: float) -> float:
        """How long the caller may block for samples before :meth:`tick` has work, s."""
        if self.n < 0:
            return 0.02
        s = self.settings
        wait = min(self._due(self.k) + s.late_s, self.last_arrival + s.timeout_s) - now
        if not self.in_gap:
            wait = min(wait, self.last_arrival + s.gap_hold_s - now)
        return float(min(max(0.0, wait), 0.02))

    # ------------------------------------------------------------------ internals
    def _due(self, k: int) -> float:
        """Wall time at which step ``k``'s sample is expected."""
        return self.last_arrival + (k * self.settings.control_dt_s - self.n / self.fs_hz)

    def _open_gap(self, n_last: int) -> None:
        """No sample after ``n_last`` for too long: hold the grip, log the gap."""
        if self.in_gap:
            return
        self.in_gap = True
        self._hold_grip()  # still holding since the previous gap: that force
        self.gaps.append({"t_s": float((n_last + 1) / self.fs_hz), "duration_s": math.nan})
        self._emit("gap_start")
        self._say(f"no sEMG since {self.gaps[-1]['t_s']:.2f} s: the hand holds its grip "
                  f"({self.hold_n:.1f} N) until samples come back")

    def _close_gap(self, n_last: int, lost: int, silent_s: float) -> None:
        """Samples came back after a gap (or jumped over one): log it, restart the windows.

        The gap lasted the longer of the samples lost and the silence on the wall clock
        beyond one sample period.
        """
        self._open_gap(n_last)
        self.gaps[-1]["duration_s"] = float(max(lost / self.fs_hz, silent_s - 1.0 / self.fs_hz))
        self.in_gap = False
        self.chain.restart_windows(n_last + 1 + lost)  # the next sample's index
        self._emit("gap_end")
        self._say(f"sEMG back after {self.gaps[-1]['duration_s']:.2f} s: control resumes with "
                  "the first full window")

    def _emit(self, marker: str) -> None:
        t = max(self.k - 1, 0) * self.settings.control_dt_s
        self.events.append((t, marker))
        if self._event is not None:
            self._event(t, marker)

    def _say(self, line: str) -> None:
        if self._notify is not None:
            self._notify(line)

    def _step(self, arrival: float | None, release: float | None) -> None:
        """Control step ``k``: released by a sample's ``arrival`` or by the wall clock."""
        k, s = self.k, self.settings
        ended = self.trial.step(self.hold_n if self.holding else None)
        end = self._clock()
        info = self.info
        grip = info["grip_force_n"]
        if arrival is not None:
            late = end - arrival
            self._latency[self._n_latency] = late
            self._n_latency += 1
        else:
            late = end - release
        if late > s.control_dt_s:
            self.deadline_misses += 1
        t = k * s.control_dt_s
        stimulus = self.feedback.output(t, grip, info["slip_speed_m_s"])
        self._stimulus[k] = stimulus
        if self._publish is not None:
            self._publish(t, float(self.trial.recorder.reference[k]), grip, stimulus)
        self._events(info)
        if self.viewer is not None and k % self.viewer_every == 0:
            self.viewer.sync()
        if ended:
            why = self.trial.ended
            if why == "diverged":
                self.failure = info["failure"]
            elif why in ("crushed", "dropped"):  # the referee's answer: the hand holds its grip
                self._hold_grip()
            self.finish(why)
        elif t - self._last_gc_t >= 5.0:  # automatic collection is off during a session
            self._last_gc_t = t
            gc.collect(0)

    def _hold_grip(self) -> None:
        """The hand holds its grip from now on: the smaller of the reference and the grip."""
        if not self.holding:
            self.hold_n = min(self.reference_n, float(self.info.get("grip_force_n", 0.0)))
            self.holding = True

    def _events(self, info: Mapping[str, Any]) -> None:
        if info["lifted"] and not self._lifted:
            self._lifted = True
            self._emit("lift")
        if info["slip_events"] > self._slips:
            self._slips = int(info["slip_events"])
            self._emit("slip")
        if info["dropped"] and not self._dropped:
            self._dropped = True
            self._emit("drop")
        if info["crushed"] and not self._crushed:
            self._crushed = True
            self._emit("crush")

    # ------------------------------------------------------------------ results
    def recording(self, source: str, metadata: Mapping[str, Any] | None = None) -> Recording:
        """The samples received (cleaned), as a recording with the calibration's layout."""
        n = min(self.received, self._samples.shape[0])
        emg = self._samples[:max(n, 1)]
        cal = self.cal.recording
        emg = emg.astype(np.int8) if self.cal.integer else emg
        pitch = self._pitch[:emg.shape[0]].copy()
        known = np.flatnonzero(np.isfinite(pitch))
        if known.size:  # before the first orientation sample: the first one
            pitch[:known[0]] = pitch[known[0]]
            pitch = np.where(np.isfinite(pitch), pitch, 0.0)
        meta = {"source": "lsl", "lost_samples": self.lost, "gaps": self.gaps,
                "events": [[round(t, 4), m] for t, m in self.events],
                "source_changes": self.source_changes, "arm": self.arm.summary(),
                **(metadata or {})}
        return Recording(emg=emg, fs_hz=self.fs_hz, channel_names=list(cal.channel_names),
                         emg_unit=cal.emg_unit, pitch_rad=pitch if known.size else None,
                         metadata=meta, source=source)

    def report(self) -> dict[str, Any]:
        """The session's figures: the ``live --json`` contract (docs/FORMAT.md).

        ``metrics`` holds what a simulated trial's row holds of the grasp (the referee's
        ``outcome``, ``attempts``, ``time_to_lift_s``, ``safety_margin_pct``, ``released``
        and the episode's figures: :func:`scenarios.live.recorded.grasp_metrics`);
        ``held_grip_n`` is the grip the hand holds at the end when the session ended on
        a fault or on the referee's answer (else ``None``).
        """
        s = self.settings
        k = self.k
        traces = self.traces
        info = self.info
        expected = max(self.n + 1, 0)
        if self.ended == "timeout" and self.n >= 0 and self.gaps:
            expected += int(self.gaps[-1]["duration_s"] * self.fs_hz)
        lat_ms = self._latency[:self._n_latency] * 1e3
        transport_ms = self._transport[:self._n_transport] * 1e3
        simulated = k * s.control_dt_s
        physics = self.trial.physics_s
        processing = self.trial.physics_s + self.trial.controller_s
        t, referee = traces["t_s"], self.referee
        rising = np.flatnonzero(traces["wrist_height_m"] > 0.0)
        metrics = {**grasp_metrics(traces, info, referee, self.obj, control_dt_s=s.control_dt_s,
                                   wrist_tremor_m=self.wrist_tremor_m,
                                   windows=ReferenceWindows.of(self.chain, s.duration_s)),
                   **self.chain.decoder_counts(None)}  # a person's: no open-intent label
        out: dict[str, Any] = {
            "samples": {"received": int(self.received), "expected": int(expected),
                        "lost": int(max(expected - self.received, 0))},
            "latency_ms": {"p50": percentile(lat_ms, 50), "p99": percentile(lat_ms, 99)},
            "deadline_misses": int(self.deadline_misses),
            "control_steps": int(k),
            "gaps": [{"t_s": round(g["t_s"], 4), "duration_s": round(g["duration_s"], 4)}
                     for g in self.gaps],
            "metrics": metrics,
            "bad_samples": {"non_numeric": self.guard.non_numeric,
                            "out_of_range": self.guard.out_of_range},
            "stale_skipped": self.stale_skipped,
            "transport_ms": {"p50": percentile(transport_ms, 50),
                             "p99": percentile(transport_ms, 99)},
            "latency_max_ms": float(lat_ms.max()) if lat_ms.size else None,
            "realtime_factor": {
                "physics": simulated / physics if physics > 0 else None,
                "controller_and_physics": simulated / processing if processing > 0 else None},
            "control_dt_s": s.control_dt_s,
            "session_s": simulated,
            "wall_s": self.wall_s,
            "ended": self.ended,
            "held_grip_n": self.hold_n if self.holding else None,
            "traces": {key: traces[key].tolist() for key in
                       ("t_s", "reference_n", "grip_force_n", "object_height_m",
                        "slip_speed_m_s", "feedback", "wrist_height_m")},
            "feedback": self.feedback.mode,
            **self.settings.hand.fields(),
            "arm": {**self.arm.summary(),
                    "lift_start_s": float(t[rising[0]]) if rising.size else None,
                    "secure_lift_s": referee.secure_lift_s},
            "events": [{"t_s": round(t_e, 4), "marker": m} for t_e, m in self.events],
            "source_changes": list(self.source_changes),
        }
        out["warnings"] = warnings_for(out)
        return out
