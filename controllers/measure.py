"""Measure the loop gain on the nonlinear hand, as a lab measures a real one.

:func:`measure_loop` holds the object in the air at a grip force with the
designed controller running on the MuJoCo hand (:class:`sim.hand.grasp_env.GraspEnv`),
then injects small sines ``d = a sin(w t)`` at the plant input, one frequency
at a time. With ``u_c`` the controller's command as the hand receives it (one
period after it was computed: the computation delay) and ``u = u_c + d`` the
plant input, the loop gain and the sensitivity at ``w`` are::

    L(jw) = -U_c(jw) / U(jw),      S(jw) = U(jw) / D(jw)

(``u = d - L u``). The phasors come from a least-squares fit of
``c0 + c1 t + A cos(w t) + B sin(w t)`` to a whole number of periods after the
transient has settled (the trend absorbs slow creep of the grasp). The measured
crossover is interpolated (log-log) between the frequencies that bracket
``|L| = 1``, the phase margin at it by interpolating the phase in log
frequency. The prediction beside it is the analysis of the same controller with
the plant linearized at the force actually held
(:meth:`controllers.design.ControllerDesign.analyse`).

The MPC is measured with its constraints inactive (the injection is small and
the force well inside its bounds); its margins are those of its unconstrained
law, which is what is then measured.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.design import ControllerDesign, OperatingAnalysis
from controllers.drive import HandLoop
from controllers.errors import SpecificationError
from controllers.plant import frequency_response
from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec, WristSchedule

#: Injection frequencies, as multiples of the predicted crossover.
DEFAULT_FREQUENCY_FACTORS = (0.5, 0.7, 0.85, 1.0, 1.2, 1.4, 2.0)


@dataclass(frozen=True)
class MeasuredFrequency:
    """One injection frequency.

    Attributes
    ----------
    frequency_rad_s : float
    loop : complex
        Measured ``L(jw)``.
    sensitivity : complex
        Measured ``S(jw)``.
    predicted_loop : complex
        ``L(jw)`` of the analysis at the held force.
    amplitude : float
        Injected sine amplitude, command units.
    """

    frequency_rad_s: float
    loop: complex
    sensitivity: complex
    predicted_loop: complex
    amplitude: float

    def to_dict(self) -> dict[str, float]:
        """JSON-ready dict (magnitudes in dB, phases in degrees)."""
        return {"frequency_rad_s": self.frequency_rad_s,
                "loop_gain_db": float(20 * np.log10(abs(self.loop))),
                "loop_phase_deg": float(np.angle(self.loop, deg=True)),
                "sensitivity_abs": float(abs(self.sensitivity)),
                "predicted_loop_gain_db": float(20 * np.log10(abs(self.predicted_loop))),
                "predicted_loop_phase_deg": float(np.angle(self.predicted_loop, deg=True)),
                "predicted_sensitivity_abs": float(abs(1.0 / (1.0 + self.predicted_loop))),
                "amplitude": self.amplitude}


@dataclass
class LoopMeasurement:
    """The measured loop at one requested grip force.

    Attributes
    ----------
    force_n : float
        Requested hold force, N.
    held_force_n : float
        Mean grip during the injections, N (the prediction is made here).
    points : list of MeasuredFrequency
    crossover_rad_s, phase_margin_deg : float or None
        Measured (interpolated); None if ``|L|`` never crosses 1 in the band.
    predicted_crossover_rad_s, predicted_phase_margin_deg : float or None
        From the analysis at ``held_force_n``.
    gain_at_predicted_crossover_db : float or None
        Measured ``|L|`` interpolated at the predicted crossover, dB.
    reason : str
        Why the measurement failed (empty if it did not).
    """

    force_n: float
    held_force_n: float = float("nan")
    points: list[MeasuredFrequency] = field(default_factory=list)
    crossover_rad_s: float | None = None
    phase_margin_deg: float | None = None
    predicted_crossover_rad_s: float | None = None
    predicted_phase_margin_deg: float | None = None
    gain_at_predicted_crossover_db: float | None = None
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        return {"force_n": self.force_n, "held_force_n": self.held_force_n,
                "measured": {"crossover_rad_s": self.crossover_rad_s,
                             "phase_margin_deg": self.phase_margin_deg,
                             "gain_at_predicted_crossover_db":
                                 self.gain_at_predicted_crossover_db},
                "predicted": {"crossover_rad_s": self.predicted_crossover_rad_s,
                              "phase_margin_deg": self.predicted_phase_margin_deg},
                "points": [p.to_dict() for p in self.points],
                "failed": bool(self.reason), "reason": self.reason}


def phasor(t_s: np.ndarray, x: np.ndarray, w: float) -> complex:
    """Complex amplitude ``X`` of ``x(t) ~ c0 + c1 t + Re(X e^{jwt})`` by least squares."""
    basis = np.column_stack([np.ones_like(t_s), t_s - t_s.mean(), np.cos(w * t_s),
                             np.sin(w * t_s)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return complex(coef[2], -coef[3])


def _crossing(w: np.ndarray, mag_db: np.ndarray) -> tuple[int, float] | None:
    """First bracket where ``mag_db`` falls through 0 and the log-interpolated frequency."""
    for i in range(w.size - 1):
        if mag_db[i] >= 0.0 > mag_db[i + 1]:
            f = mag_db[i] / (mag_db[i] - mag_db[i + 1])
            return i, float(np.exp(np.log(w[i]) + f * (np.log(w[i + 1]) - np.log(w[i]))))
    return None


def _near(angle_deg: float, target_deg: float) -> float:
    """``angle_deg`` plus the multiple of 360 that brings it closest to ``target_deg``."""
    return float(angle_deg + 360.0 * np.round((target_deg - angle_deg) / 360.0))


def measure_loop(design: ControllerDesign, force_n: float, *,
                 frequencies_rad_s: np.ndarray | None = None, amplitude: float | None = None,
                 periods: int = 6, settle_periods: int = 2, hold_settle_s: float = 1.0,
                 drive: str = "backdrivable") -> LoopMeasurement:
    """Hold the object in the air at ``force_n`` and measure ``L(jw)`` by sine injection.

    Parameters
    ----------
    design : ControllerDesign
        The designed controller (its runtime controller is driven as in an episode).
    force_n : float
        Grip-force reference of the hold, N (inside the design's analysed range).
    frequencies_rad_s : array, optional
        Injection frequencies; default :data:`DEFAULT_FREQUENCY_FACTORS` times
        the predicted crossover (below 0.8 x Nyquist).
    amplitude : float, optional
        Sine amplitude in command units; default 5 % of the feedforward
        command of ``force_n`` (at least 0.002).
    periods, settle_periods : int
        Periods fitted, and periods discarded before them, per frequency.
    hold_settle_s : float
        Hold after the lift before the first injection, s.
    drive : str
        The hand's transmission (:mod:`sim.hand.drive`): the loop is measured on the
        hand that runs it (the prediction is the same design's analysis).

    Returns
    -------
    LoopMeasurement
        ``reason`` says why, if the object was not held in the air.
    """
    design.check_force(force_n)
    dt = design.family.control_dt_s
    predicted = design.analyse(force_n)
    if not predicted.ok:
        return LoopMeasurement(force_n, reason=f"no analysis at {force_n:g} N: {predicted.reason}")
    w_all = _injection_frequencies(predicted, dt, frequencies_rad_s)
    a = amplitude if amplitude is not None else max(0.002, 0.05 * design.feedforward(force_n))

    schedule = WristSchedule(lift_after_s=0.8)
    n_lift = int(round((schedule.lift_after_s + schedule.lift_duration_s + hold_settle_s) / dt))
    blocks = [(w, int(round(settle_periods * 2 * np.pi / w / dt)),
               int(round(periods * 2 * np.pi / w / dt))) for w in w_all]
    n_total = n_lift + sum(s + m for _, s, m in blocks)
    t = np.arange(n_total) * dt
    inject = np.zeros(n_total)
    k = n_lift
    for w, n_settle, n_meas in blocks:
        inject[k:k + n_settle + n_meas] = a * np.sin(w * t[k:k + n_settle + n_meas])
        k += n_settle + n_meas
    run = _run_injection(design, force_n, schedule, t, inject, drive)
    if isinstance(run, str):
        return LoopMeasurement(force_n, reason=run)
    u_ctrl, u_applied, grip = run
    held = float(np.mean(grip[n_lift:]))
    at_held = design.analyse(float(np.clip(round(held, 1), *design.family.range_n)))
    pred = at_held if at_held.ok else predicted
    points = []
    k = n_lift
    for w, n_settle, n_meas in blocks:
        window = slice(k + n_settle, k + n_settle + n_meas)
        big_u = phasor(t[window], u_applied[window], w)
        big_uc = phasor(t[window], u_ctrl[window], w)
        big_d = phasor(t[window], inject[window], w)
        l_pred = complex(frequency_response(pred.margins.loop, np.array([w]))[0])
        points.append(MeasuredFrequency(float(w), -big_uc / big_u, big_u / big_d, l_pred, a))
        k += n_settle + n_meas
    result = LoopMeasurement(force_n, held_force_n=held, points=points)
    m = pred.margins
    if m.crossover_rad_s:
        result.predicted_crossover_rad_s = float(m.crossover_rad_s[0])
        result.predicted_phase_margin_deg = float(m.phase_margins_deg[0])
    _measured_margins(result)
    return result


def _injection_frequencies(predicted: OperatingAnalysis, dt_s: float,
                           frequencies_rad_s: np.ndarray | None) -> np.ndarray:
    """The injection frequencies, rad/s, sorted.

    Default: :data:`DEFAULT_FREQUENCY_FACTORS` times the predicted crossover
    (10 rad/s if there is none), those below 0.8 x Nyquist.

    Raises
    ------
    SpecificationError
        Given frequencies outside ``(0, Nyquist)``.
    """
    wc = predicted.margins.crossover_rad_s[0] if predicted.margins.crossover_rad_s else 10.0
    nyquist = np.pi / dt_s
    if frequencies_rad_s is None:
        w_all = np.array(DEFAULT_FREQUENCY_FACTORS) * wc
        return w_all[w_all < 0.8 * nyquist]
    w_all = np.sort(np.asarray(frequencies_rad_s, dtype=float))
    if w_all.size == 0 or w_all[0] <= 0 or w_all[-1] >= nyquist:
        raise SpecificationError(
            f"frequencies: expected values in (0, {nyquist:.4g}) rad/s (Nyquist), found "
            f"{w_all.tolist()}"
        )
    return w_all


def _run_injection(design: ControllerDesign, force_n: float, schedule: WristSchedule,
                   t_s: np.ndarray, inject: np.ndarray, drive: str = "backdrivable"
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | str:
    """Grasp, lift and hold at ``force_n`` with ``inject`` added at the plant input.

    Parameters
    ----------
    t_s, inject : ndarray, shape (n_steps,)
        Control-rate time, s, and the injected signal, command units.

    Returns
    -------
    (u_ctrl, u_applied, grip_n) : tuple of ndarray, shape (n_steps,)
        The controller's command as the hand received it, the plant input
        (command plus injection), and the grip force, N.
    str
        Why the run failed instead: the hold ended early or the object was not lifted.
    """
    dt = design.family.control_dt_s
    n_total = t_s.size
    env = GraspEnv(design.object, force_n, control_dt_s=dt, wrist=schedule,
                   hand=HandSpec(drive=drive), task=GraspTask(episode_s=(n_total + 10) * dt))
    loop = HandLoop(env, design.controller)
    u_applied = np.zeros(n_total)
    u_ctrl = np.zeros(n_total)
    grip = np.zeros(n_total)
    try:
        loop.reset(seed=0)
        for k in range(n_total):
            u_ctrl[k], u_applied[k], done = loop.step(force_n, inject[k])
            info = loop.info
            grip[k] = info["grip_force_n"]
            if done:
                return (f"the hold ended at t = {t_s[k]:.2f} s (dropped {info['dropped']}, "
                        f"crushed {info['crushed']}, failure {info.get('failure')})")
        lifted = loop.info["object_height_m"] > 0.5 * schedule.lift_height_m
    finally:
        env.close()
    if not lifted:
        return "the object was not lifted"
    return u_ctrl, u_applied, grip


def _measured_margins(result: LoopMeasurement) -> None:
    """Fill in the measured crossover, phase margin and gain at the predicted crossover.

    The crossover is log-log interpolated between the frequencies that bracket
    ``|L| = 1``, the phase at it interpolated in log frequency, each measured
    phase unwrapped towards the predicted one.
    """
    points = result.points
    w = np.array([p.frequency_rad_s for p in points])
    mag_db = np.array([20 * np.log10(abs(p.loop)) for p in points])
    phase = np.array([_near(np.angle(p.loop, deg=True), np.angle(p.predicted_loop, deg=True))
                      for p in points])
    crossing = _crossing(w, mag_db)
    if crossing is not None:
        i, wx = crossing
        f = (np.log(wx) - np.log(w[i])) / (np.log(w[i + 1]) - np.log(w[i]))
        result.crossover_rad_s = wx
        result.phase_margin_deg = float(180.0 + phase[i] + f * (phase[i + 1] - phase[i]))
    wp = result.predicted_crossover_rad_s
    if wp is not None and w.size >= 2 and w[0] <= wp <= w[-1]:
        result.gain_at_predicted_crossover_db = float(np.interp(np.log(wp), np.log(w), mag_db))
