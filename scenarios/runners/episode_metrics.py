"""What an episode measured: tracking and transient figures, lift, margins where it ran.

Pure functions of an episode's traces and its controller design, shared by the
simulated episode (:mod:`scenarios.runners.episode`) and the live and recorded
sessions (:mod:`scenarios.live`).
"""

from collections.abc import Mapping
from typing import Any

import numpy as np

from controllers.base import controller_stats
from controllers.design import ControllerDesign, OperatingAnalysis
from estimation.metrics import total_variation_rate
from scenarios.runners.reference import ReferenceStream

SETTLE_BAND = 0.05  # settling band: 5 % of the hold reference (at least SETTLE_FLOOR_N)
SETTLE_FLOOR_N = 0.2
CONTACT_N = 0.5  # grip force that counts as contact in the metrics
CONTACT_PEAK_WINDOW_S = 0.5  # contact_peak_ratio: peak within this long after both sides touch


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


def grasp_start_s(t_s: np.ndarray, reference_n: np.ndarray) -> float:
    """When a grasp without a cue started: the reference first reaches 0.5 N, s (a person
    gives no cue; the start of the trial if it never does)."""
    rising = np.flatnonzero(reference_n >= CONTACT_N)
    return float(t_s[rising[0]]) if rising.size else float(t_s[0])


def episode_metrics(stream: ReferenceStream, grip_n: np.ndarray, *, lift_s: float,
                    hold: np.ndarray) -> dict[str, Any]:
    """Tracking, estimation and transient figures of one episode.

    Parameters
    ----------
    stream : ReferenceStream
        The episode's reference: ``t_s``, ``reference_n`` and ``oracle_n``, shape
        (n_steps,), the control-rate time, s, the reference and the oracle reference, N,
        at the steps of ``grip_n``; ``start_s``, the start of the grasp (the user's ramp
        onset), s, or ``None`` when no cue is known (a person: when the reference first
        reaches 0.5 N); ``window_values_n``, shape (n_windows,), the reference at the
        estimator's update rate, every ``window_dt_s`` s (for volatility).
    grip_n : ndarray, shape (n_steps,)
        Measured grip force, N.
    lift_s : float
        When the wrist first rose, s: the grasp phase is ``start_s..lift_s``.
    hold : ndarray of bool, shape (n_steps,)
        The in-air hold's steps (:func:`scenarios.runners.trial_outcome.hold_window`);
        the hold reference is the mean reference there.

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
    t_s, reference_n, oracle_n = stream.t_s, stream.reference_n, stream.oracle_n
    window_values_n, window_dt_s = stream.window_values_n, stream.window_dt_s
    start_s = stream.start_s
    if start_s is None:
        start_s = grasp_start_s(t_s, reference_n)
    touching = np.flatnonzero(grip_n >= CONTACT_N)
    contact_s = float(t_s[touching[0]]) if touching.size else None
    track = (t_s >= contact_s + 0.5) if contact_s is not None else np.zeros(t_s.size, bool)
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


def operating_forces(traces: Mapping[str, np.ndarray], design: ControllerDesign, *,
                     hold: np.ndarray, both_sides_s: float | None
                     ) -> tuple[float | None, list[float]]:
    """The force an episode held and the forces it visited, N.

    The held force is the mean grip in the in-air hold (the steps of ``hold``;
    the mean, not the median: a grip that follows a
    fluctuating estimate spreads over a few newtons, and its median jumps between
    clusters with a change in the last digit of the command);
    the visited forces are the design grid points between the 5th and 95th
    percentiles of the grip once both sides touched, plus the held force. Both
    are clamped into the analysed range and rounded to 0.1 N.
    """
    if both_sides_s is None:
        return None, []
    lo_range, hi_range = design.family.range_n
    t, grip = traces["t_s"], traces["grip_force_n"]
    after = t >= both_sides_s
    if not hold.any() or not after.any():
        return None, []

    def clamp(f: float) -> float:
        return float(np.clip(round(f, 1), lo_range, hi_range))

    held = clamp(float(np.mean(grip[hold])))
    p5, p95 = np.percentile(grip[after], [5, 95])
    visited = {clamp(f) for f in design.family.forces_n if p5 <= f <= p95} | {held}
    return held, sorted(visited)


def mpc_failures(design: ControllerDesign) -> int:
    """QP solves that fell back to the unconstrained law, summed over the bank."""
    return int(controller_stats(design.core).get("n_failures", 0))


def margin_fields(analysis: OperatingAnalysis | None) -> dict[str, Any]:
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
