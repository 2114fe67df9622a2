"""The user in the loop: perception, intent, sEMG, features, estimate, reference, causally.

A scripted user's reference can be computed for the whole episode before the
physics runs (:func:`scenarios.runners.reference.scripted_reference`). A user who
reacts cannot: what they intend at time t depends on what the hand did before
t. :class:`LiveUser` interleaves, at every control step::

    hand (info after the last step) --Scene: plain numbers--> operator.act
        -> intent samples of this control period
        -> sEMG chunk (sim.user.causal.CausalSession, noise drawn up front)
        -> every feature window that has ended: MAV/RMS/WL -> estimator.step
        -> hand reference (held between windows) -> controller -> GraspEnv

The operator sees only the :class:`~sim.user.operator.Scene` (through its
channels' delays, thresholds and noise); ``sim.user`` never imports the hand.
Fed a scripted operator, the live path gives the batch path's references bit
for bit (``tests/scenarios/test_operator_loop.py``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from estimation.features import PAPER_CHANNELS, window_samples
from scenarios.schema.names import INTACT
from sim.user.causal import CausalSession
from sim.user.operator import Operator, Plan, Scene
from sim.user.subjects import VirtualSubject

WINDOW_MS = 400.0
"""The paper's feature window, ms (the default of ``estimator.window_ms``)."""
STEP_MS = 125.0
"""The paper's window increment, ms (the default of ``estimator.step_ms``)."""


def scene_from_info(t_s: float, info: Mapping[str, Any]) -> Scene:
    """What there is to perceive after a control step, from the environment's ``info``."""
    # positional and unconverted: GraspEnv's info holds plain floats and bools already,
    # and this runs at every control step
    return Scene(t_s, info["thumb_contact"] and info["finger_contact"],
                 info["object_in_palm_z_m"], info["object_height_m"],
                 info["object_out_of_hand"], info["crushed"], info["grip_force_n"],
                 info["slip_speed_m_s"], abs(info["finger_velocity_rad_s"]),
                 info["thumb_contact"] or info["finger_contact"])


class LiveUser:
    """A virtual subject and an operator producing the hand reference step by step.

    Parameters
    ----------
    subject : VirtualSubject
        The user's body (muscles, armband, FSR).
    calibration : scenarios.runners.calibration.Calibration
        The fitted estimator (or the oracle) and the force mapping.
    operator : Operator
        The user's mind (:mod:`sim.user.operators`), started here with ``plan``.
    plan : Plan
        The trial's scripted intent and goal.
    session_rng : numpy.random.Generator
        The sEMG session's noise (drawn up front, as ``VirtualSubject.record`` draws it).
    operator_rng : numpy.random.Generator
        The operator's motor and perception noise.
    n_samples : int
        Samples of sEMG to draw noise for (the scripted profile's length, so
        a scripted user sees ``record``'s very noise).
    control_dt_s : float
        Control period, s.
    hand_force_at_mvc_n : float
        Hand reference at the user's calibration MVC, N.
    generator : str
        A causal sEMG generator (``noise``).
    window_ms, step_ms : float
        The feature window and its increment, ms (the calibration's).
    """

    def __init__(self, subject: VirtualSubject, calibration: Any, operator: Operator,
                 plan: Plan, *, session_rng: np.random.Generator,
                 operator_rng: np.random.Generator, n_samples: int, control_dt_s: float,
                 hand_force_at_mvc_n: float, generator: str = "noise",
                 window_ms: float = WINDOW_MS, step_ms: float = STEP_MS) -> None:
        self.fs_hz = float(plan.fs_hz)
        self.session = CausalSession(subject, n_samples, generator=generator, fs_hz=self.fs_hz,
                                     rng=session_rng)
        self.operator = operator
        operator.start(plan, control_dt_s=control_dt_s, rng=operator_rng)
        self.dt = float(control_dt_s)
        self.cal = calibration
        self.win, self.hop = window_samples(self.fs_hz, window_ms, step_ms)
        cols = [c - 1 for c in PAPER_CHANNELS]
        contiguous = cols == list(range(cols[0], cols[0] + len(cols)))
        self._channels = slice(cols[0], cols[-1] + 1) if contiguous else np.array(cols)
        n = int(n_samples)
        self.n_samples = n
        self.intent = np.zeros(n)
        self.emg = np.zeros((n, 8), dtype=np.int8)
        self._n_intent = 0
        self._stream = None
        if calibration.pipeline is not None:
            self._stream = calibration.pipeline.streaming(calibration.mode)
            self._stream.reset()
        self._one_step = calibration.mode == "one_step"
        self._intact = calibration.name == INTACT  # no sEMG path: the true force, every step
        self._gate = calibration.rest_gate()  # the hand acts above the rest threshold
        self.to_hand = hand_force_at_mvc_n / calibration.mvc_cal_n
        self.ceiling = 1.2 * hand_force_at_mvc_n
        self._next_window = 0
        self._next_end = self.win - 1  # last sample of the next window
        self._x = np.empty(3 * len(PAPER_CHANNELS))
        self.window_t_s: list[float] = []
        self.window_end: list[int] = []
        self.window_estimate_n: list[float] = []
        self._reference = 0.0
        self.timings = dict.fromkeys(("t_semg_s", "t_features_s", "t_estimator_s",
                                      "t_operator_s"), 0.0)

    def step(self, k: int, scene: Scene) -> float:
        """The hand reference for control step ``k`` (time ``k * dt``), N.

        The operator perceives ``scene`` (the hand after step ``k - 1``) and
        decides; every feature window that has ended by ``k * dt`` is then
        recorded (the intent of its samples asked of the operator, all decided
        by now), computed and estimated.
        """
        t = k * self.dt
        t0 = time.perf_counter()
        self.operator.perceive(scene)
        self.timings["t_operator_s"] += time.perf_counter() - t0
        # every window whose last sample is no later than t (the batch's rule)
        while self._next_end < self.n_samples and self._next_end / self.fs_hz <= t + 1e-9:
            self._window(self._next_end)
            self._next_end += self.hop
        if self._intact:  # the hand follows the user's own force as it is now
            n = min(int(t * self.fs_hz + 1e-9) + 1, self.n_samples)
            self._record_to(n)
            t0 = time.perf_counter()
            grip_n, _ = self.session.read_forces()
            self.timings["t_semg_s"] += time.perf_counter() - t0
            self._reference = float(np.clip(grip_n[n - 1] * self.to_hand, 0.0, self.ceiling))
        return self._reference

    def intent_until(self, n: int) -> None:
        """Ask the operator for the intent of every sample before ``n`` (decided by now)."""
        n = min(n, self.n_samples)
        if n > self._n_intent:
            t0 = time.perf_counter()
            self.intent[self._n_intent:n] = self.operator.intent(n - self._n_intent)
            self._n_intent = n
            self.timings["t_operator_s"] += time.perf_counter() - t0

    def _record_to(self, n: int) -> None:
        """Record the sEMG of every sample before ``n`` (its intent decided by now)."""
        self.intent_until(n)
        t0 = time.perf_counter()
        done = self.session.n_done
        if n > done:
            self.emg[done:n] = self.session.advance(self.intent[done:n])
        self.timings["t_semg_s"] += time.perf_counter() - t0

    def _window(self, end: int) -> None:
        """Record up to sample ``end``, compute that window's features, step the estimator."""
        self._record_to(end + 1)
        t0 = time.perf_counter()
        live_force = self._stream is None or self._one_step
        if live_force:  # the oracle or the one-step estimator reads forces now
            grip_n, force_n = self.session.read_forces()
        t1 = time.perf_counter()
        # MAV, RMS, WL per channel, channel-major, from exact integer sums as
        # estimation.features.emg_features computes them (the same floats)
        x = self._x
        w = self.emg[end + 1 - self.win:end + 1, self._channels].astype(np.int32)
        x[0::3] = np.abs(w).sum(axis=0) / self.win
        x[1::3] = np.sqrt(np.einsum("ij,ij->j", w, w) / self.win)
        x[2::3] = np.abs(np.diff(w, axis=0)).sum(axis=0)
        t2 = time.perf_counter()
        if self._stream is None:
            estimate = grip_n[end] * self.to_hand
        else:
            y_prev = None
            if self._one_step:
                y_prev = float(force_n[end - self.hop]) if self._next_window > 0 else 0.0
            estimate = self._gate.step(self._stream.step(x, y_prev)) * self.to_hand
        t3 = time.perf_counter()
        value = float(np.clip(estimate, 0.0, self.ceiling))
        if not self._intact:
            self._reference = value
        self.window_t_s.append(end / self.fs_hz)
        self.window_end.append(end)
        self.window_estimate_n.append(value)
        self._next_window += 1
        self.timings["t_semg_s"] += t1 - t0
        self.timings["t_features_s"] += t2 - t1
        self.timings["t_estimator_s"] += t3 - t2

    def forces(self) -> tuple[np.ndarray, np.ndarray]:
        """The user's true grip force and FSR reading of every sample so far, N."""
        t0 = time.perf_counter()
        out = self.session.read_forces()
        self.timings["t_semg_s"] += time.perf_counter() - t0
        return out

    def window_oracle_n(self) -> np.ndarray:
        """The hand force the user truly produced at each window so far (mapped, clipped), N."""
        grip_n, _ = self.forces()
        oracle = grip_n[np.asarray(self.window_end, dtype=int)] * self.to_hand
        return np.clip(oracle, 0.0, self.ceiling)
