"""Loop analysis: margins at every crossover, delay margin, Ms, closed-loop poles, bandwidth.

All functions take the open loop ``L = C P`` (negative feedback, SISO), with the
sample-and-hold and computation delay already in ``P`` (see
:func:`controllers.plant.loop_plant`). Frequencies are in rad/s; for discrete
loops they run up to the Nyquist frequency ``pi / dt``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from controllers.plant import frequency_response
from sim.codec import StoredSystem, state_space_matrices, stored_systems

if TYPE_CHECKING:
    import control

_GRID_POINTS = 4000
_CONFIRM_RTOL = 1e-4


@stored_systems("loop")
@dataclass(frozen=True)
class LoopMargins:
    """Stability and robustness figures of one open loop.

    Attributes
    ----------
    gain_margin_db : float
        Tightest gain margin in dB over all phase crossovers (``inf`` if none).
    phase_margin_deg : float
        Tightest phase margin in degrees over all gain crossovers (``inf`` if none).
    delay_margin_s : float
        Smallest extra loop delay in seconds that destabilizes the loop,
        ``min_i (pm_i mod 360) / w_i`` over gain crossovers (``inf`` if none).
    delay_margin_samples : int or None
        Largest whole number of extra control periods the loop tolerates
        (discrete loops; ``None`` for continuous ones).
    crossover_rad_s : list of float
        Every gain crossover (``|L| = 1``), ascending.
    phase_margins_deg : list of float
        Phase margin at each gain crossover.
    phase_crossover_rad_s : list of float
        Every phase crossover (L real and negative), ascending.
    gain_margins_db : list of float
        Gain margin at each phase crossover.
    ms : float
        Peak sensitivity ``max |1 / (1 + L)|``.
    ms_frequency_rad_s : float
        Frequency of the peak.
    closed_loop_poles : ndarray of complex
        Poles of ``L / (1 + L)``.
    stable : bool
        Whether every closed-loop pole lies inside the unit circle (or left half-plane).
    bandwidth_rad_s : float
        First frequency where ``|T|`` falls 3 dB below ``|T(0)|`` (``nan`` if it never does).
    dt : float or None
        Sampling period of the loop in seconds.
    loop : control.StateSpace
        The open loop analysed.
    """

    gain_margin_db: float
    phase_margin_deg: float
    delay_margin_s: float
    delay_margin_samples: int | None
    crossover_rad_s: list[float]
    phase_margins_deg: list[float]
    phase_crossover_rad_s: list[float]
    gain_margins_db: list[float]
    ms: float
    ms_frequency_rad_s: float
    closed_loop_poles: np.ndarray
    stable: bool
    bandwidth_rad_s: float
    dt: float | None
    loop: control.StateSpace = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (the ``margins`` object of the CLI contract)."""

        def num(x: float) -> float | None:
            return None if not np.isfinite(x) else float(x)

        return {
            "gain_margin_db": num(self.gain_margin_db),
            "phase_margin_deg": num(self.phase_margin_deg),
            "delay_margin_s": num(self.delay_margin_s),
            "delay_margin_samples": self.delay_margin_samples,
            "crossover_rad_s": [float(w) for w in self.crossover_rad_s],
            "phase_margins_deg": [float(p) for p in self.phase_margins_deg],
            "phase_crossover_rad_s": [float(w) for w in self.phase_crossover_rad_s],
            "gain_margins_db": [num(g) for g in self.gain_margins_db],
            "ms": num(self.ms),
            "ms_frequency_rad_s": float(self.ms_frequency_rad_s),
            "closed_loop_poles": [[float(p.real), float(p.imag)] for p in self.closed_loop_poles],
            "stable": bool(self.stable),
            "bandwidth_rad_s": num(self.bandwidth_rad_s),
            "loop": state_space_dict(self, "loop"),
        }


def state_space_dict(owner: Any, name: str) -> dict[str, Any] | None:
    """``{A, B, C, D, dt}`` of the system in ``owner.<name>`` as JSON-ready lists.

    ``dt`` is None if continuous; None if there is no system. A system a cache file
    left as matrices is not built (:func:`sim.codec.state_space_matrices`).
    """
    stored = owner.__dict__.get(name)
    if stored is None:
        return None
    A, B, C, D = state_space_matrices(owner, name)
    return {"A": A.tolist(), "B": B.tolist(), "C": C.tolist(), "D": D.tolist(),
            "dt": _dt(stored if isinstance(stored, StoredSystem) else getattr(owner, name))}


def _dt(loop: control.LTI | StoredSystem) -> float | None:
    dt = loop.dt
    return float(dt) if dt not in (None, 0, True) and dt > 0 else None


def frequency_grid(loop: control.LTI, n_points: int = _GRID_POINTS, *,
                   tf: control.TransferFunction | None = None) -> np.ndarray:
    """Log-spaced frequencies in rad/s covering the loop's dynamics (to Nyquist if discrete).

    From a hundredth of the slowest pole/zero rate, but at most five decades
    below the fastest, to Nyquist (discrete) or 100x the fastest (continuous).
    ``tf`` is the loop's :func:`minimal_tf`, if the caller has it already.
    """
    dt = _dt(loop)
    tf = minimal_tf(loop) if tf is None else tf
    roots = np.concatenate([tf.poles(), tf.zeros()])
    if dt is not None:
        roots = roots[np.abs(roots) > 0]
        rates = np.abs(np.log(roots)) / dt
        hi = np.pi / dt
    else:
        rates = np.abs(roots)
        hi = 100.0 * max(1.0, rates.max(initial=1.0))
    rates = rates[rates > 0]
    lo = max(0.01 * min(rates.min(initial=1.0), 1.0), 1e-5 * hi)
    return np.geomspace(lo, hi * (1 - 1e-9), n_points)


def minimal_tf(loop: control.LTI, tol: float = 1e-9) -> control.TransferFunction:
    """Minimal SISO transfer function of ``loop``, with round-off coefficients removed.

    Pole-zero pairs closer than ``1e-7`` cancel (:func:`control.minreal`).
    Controllers built in state space (the MPC's law with its observer) give
    non-minimal products whose state-space-to-polynomial conversion leaves
    coefficients of order 1e-16 in place of exact zeros; those create spurious
    far-away roots for the polynomial margin method, so they are stripped.
    """
    import control
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tf = control.tf(loop)
    num = np.asarray(tf.num[0][0], float)
    den = np.asarray(tf.den[0][0], float)
    scale = max(np.max(np.abs(num)), np.max(np.abs(den)))
    num = np.trim_zeros(np.where(np.abs(num) < tol * scale, 0.0, num), "f")
    den = np.trim_zeros(np.where(np.abs(den) < tol * scale, 0.0, den), "f")
    # common factors of z (or s) at the end of both polynomials cancel exactly
    while num.size > 1 and den.size > 1 and num[-1] == 0.0 and den[-1] == 0.0:
        num, den = num[:-1], den[:-1]
    num = num if num.size else np.zeros(1)
    return control.minreal(control.tf(num, den, loop.dt), tol=1e-7, verbose=False)


def delay_margin(phase_margins_deg: np.ndarray, crossovers_rad_s: np.ndarray) -> float:
    """Smallest destabilizing extra delay in s: ``min_i (pm_i mod 360) [rad] / w_i``."""
    if len(crossovers_rad_s) == 0:
        return float("inf")
    lag_rad = np.deg2rad(np.mod(np.asarray(phase_margins_deg, dtype=float), 360.0))
    return float(np.min(lag_rad / np.asarray(crossovers_rad_s, dtype=float)))


def closed_loop_bandwidth(loop: control.LTI, omega_rad_s: np.ndarray | None = None, *,
                          response: np.ndarray | None = None) -> float:
    """First frequency (rad/s) where ``|L/(1+L)|`` drops 3 dB below its low-frequency value.

    ``response`` is ``L`` on ``omega_rad_s``, if the caller has it already.
    """
    import scipy.optimize
    omega = frequency_grid(loop) if omega_rad_s is None else omega_rad_s
    lval = frequency_response(loop, omega) if response is None else response
    t_mag = np.abs(lval / (1.0 + lval))
    level = t_mag[0] / np.sqrt(2.0)
    below = np.nonzero(t_mag < level)[0]
    if below.size == 0:
        return float("nan")
    i = below[0]
    if i == 0:
        return float(omega[0])

    def excess(w: float) -> float:
        lw = frequency_response(loop, np.array([w]))[0]
        return abs(lw / (1.0 + lw)) - level

    return float(scipy.optimize.brentq(excess, omega[i - 1], omega[i]))


def loop_margins(loop: control.LTI) -> LoopMargins:
    """Analyse an open loop ``L = C P`` (negative unit feedback).

    Crossovers come from :func:`control.stability_margins` with
    ``returnall=True`` (polynomial method, exact for rational loops); Ms and the
    bandwidth from the frequency response on a dense grid refined by a local
    optimizer.

    Parameters
    ----------
    loop : control.LTI
        SISO open loop, continuous or discrete.

    Returns
    -------
    LoopMargins
    """
    import control
    import scipy.optimize
    tf = minimal_tf(loop)  # computed once: the grid and the refinement use it too
    dt = _dt(loop)
    with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
        warnings.simplefilter("ignore", UserWarning)  # 'poly' is exact for rational loops
        gms, pms, _, w_pc, w_gc, _ = control.stability_margins(tf, returnall=True, method="poly")
    gms, pms = np.asarray(gms, float), np.asarray(pms, float)
    w_pc, w_gc = np.asarray(w_pc, float), np.asarray(w_gc, float)
    if dt is not None:  # the polynomial method may return the Nyquist point twice
        keep_gc = w_gc <= np.pi / dt + 1e-9
        w_gc, pms = w_gc[keep_gc], pms[keep_gc]
        keep_pc = w_pc <= np.pi / dt + 1e-9
        w_pc, gms = w_pc[keep_pc], gms[keep_pc]
    # refine every crossover on the loop's own frequency response (its state-space
    # form is better conditioned than the polynomials) and keep only those it
    # confirms: the polynomial method can return spurious roots for
    # ill-conditioned high-order loops
    w_gc, pms = _refine_gain_crossovers(loop, w_gc, pms)
    w_pc, gms = _refine_phase_crossovers(loop, w_pc, gms, dt, tf.poles())
    # a near pole-zero cancellation (a slow creep mode of the plant against the
    # controller's integrator) can make the polynomial method miss a crossover
    # altogether; the dense grid of the frequency response finds it
    omega = frequency_grid(loop, tf=tf)
    resp = frequency_response(loop, omega)  # on the grid once: crossovers, Ms, bandwidth
    w_gc, pms, w_pc, gms = _add_grid_crossovers(loop, omega, w_gc, pms, w_pc, gms, resp)
    with np.errstate(divide="ignore"):
        gms_db = 20.0 * np.log10(gms)
    order = np.argsort(w_gc)
    w_gc, pms = w_gc[order], pms[order]
    order = np.argsort(w_pc)
    w_pc, gms_db = w_pc[order], gms_db[order]
    finite_gm = gms_db[np.isfinite(gms_db)]
    gm_db = float(finite_gm[np.argmin(np.abs(finite_gm))]) if finite_gm.size else float("inf")
    pm = float(pms[np.argmin(np.abs(pms))]) if pms.size else float("inf")
    dm = delay_margin(pms, w_gc)
    dm_samples = None
    if dt is not None and np.isfinite(dm):
        dm_samples = int(np.ceil(dm / dt - 1e-12) - 1)

    s_mag = np.abs(1.0 / (1.0 + resp))
    i = int(np.argmax(s_mag))
    lo, hi = omega[max(i - 1, 0)], omega[min(i + 1, omega.size - 1)]
    refined = scipy.optimize.minimize_scalar(
        lambda w: -abs(1.0 / (1.0 + frequency_response(loop, np.array([w]))[0])),
        bounds=(lo, hi),
        method="bounded",
    )
    ms, w_ms = (-refined.fun, refined.x) if -refined.fun > s_mag[i] else (s_mag[i], omega[i])

    cl = control.feedback(control.ss(loop), 1)
    cl_poles = np.asarray(cl.poles(), dtype=complex)
    if dt is not None:
        stable = bool(np.all(np.abs(cl_poles) < 1.0))
    else:
        stable = bool(np.all(cl_poles.real < 0.0))
    return LoopMargins(
        gain_margin_db=gm_db,
        phase_margin_deg=pm,
        delay_margin_s=dm,
        delay_margin_samples=dm_samples,
        crossover_rad_s=w_gc.tolist(),
        phase_margins_deg=pms.tolist(),
        phase_crossover_rad_s=w_pc.tolist(),
        gain_margins_db=gms_db.tolist(),
        ms=float(ms),
        ms_frequency_rad_s=float(w_ms),
        closed_loop_poles=cl_poles,
        stable=stable,
        bandwidth_rad_s=closed_loop_bandwidth(loop, omega, response=resp),
        dt=dt,
        loop=control.ss(loop),
    )


def _add_grid_crossovers(loop: control.LTI, omega: np.ndarray, w_gc: np.ndarray,
                         pms: np.ndarray, w_pc: np.ndarray, gms: np.ndarray, resp: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Add the gain and phase crossovers a sign change of ``resp`` (``L`` on ``omega``)
    shows and the lists lack."""
    import scipy.optimize

    def known(w: float, ws: np.ndarray) -> bool:
        return bool(ws.size and np.min(np.abs(ws - w)) <= 1e-3 * w)

    def at(w: float) -> complex:
        return complex(frequency_response(loop, np.array([w]))[0])

    excess = np.abs(resp) - 1.0
    new_gc, new_pm = list(w_gc), list(pms)
    for i in np.nonzero(np.sign(excess[:-1]) * np.sign(excess[1:]) < 0)[0]:
        w = scipy.optimize.brentq(lambda x: abs(at(x)) - 1.0, omega[i], omega[i + 1],
                                  xtol=1e-14, rtol=1e-13)
        if not known(w, w_gc):
            new_gc.append(w)
            new_pm.append(float(np.mod(np.angle(at(w), deg=True), 360.0) - 180.0))
    new_pc, new_gm = list(w_pc), list(gms)
    im = resp.imag
    for i in np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) < 0)
                        & (resp.real[:-1] < 0) & (resp.real[1:] < 0))[0]:
        w = scipy.optimize.brentq(lambda x: at(x).imag, omega[i], omega[i + 1],
                                  xtol=1e-14, rtol=1e-13)
        if not known(w, w_pc):
            new_pc.append(w)
            new_gm.append(1.0 / abs(at(w)))
    return (np.asarray(new_gc, float), np.asarray(new_pm, float),
            np.asarray(new_pc, float), np.asarray(new_gm, float))


def _refine_gain_crossovers(
    loop: control.LTI, w_gc: np.ndarray, pms: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    import scipy.optimize
    def excess(w: float) -> float:
        return abs(frequency_response(loop, np.array([w]))[0]) - 1.0

    w_out, pm_out = [], []
    for w, pm in zip(w_gc, pms, strict=True):
        lo, hi = w * (1 - 1e-3), w * (1 + 1e-3)
        if w > 0 and excess(lo) * excess(hi) < 0:
            w = scipy.optimize.brentq(excess, lo, hi, xtol=1e-14, rtol=1e-13)
            resp = frequency_response(loop, np.array([w]))[0]
            pm = float(np.mod(np.angle(resp, deg=True), 360.0) - 180.0)
        elif abs(excess(w)) > _CONFIRM_RTOL:
            continue
        w_out.append(w)
        pm_out.append(pm)
    return np.asarray(w_out, float), np.asarray(pm_out, float)


def _refine_phase_crossovers(
    loop: control.LTI, w_pc: np.ndarray, gms: np.ndarray, dt: float | None, poles: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Refine the phase crossovers on the response; ``poles`` of the loop's minimal form."""
    import scipy.optimize

    def imag(w: float) -> float:
        return frequency_response(loop, np.array([w]))[0].imag

    w_out, gm_out = [], []
    for w, gm in zip(w_pc, gms, strict=True):
        # an integrator puts a pole at w = 0, where the polynomial method reports a
        # spurious "crossing" with a finite gain: no crossing happens at a pole
        point = np.exp(1j * w * dt) if dt is not None else 1j * w
        if np.min(np.abs(poles - point), initial=np.inf) < 1e-6:
            continue
        lo, hi = w * (1 - 1e-3), w * (1 + 1e-3)
        if dt is not None:
            hi = min(hi, np.pi / dt)
        if w > 0 and imag(lo) * imag(hi) < 0:
            w = scipy.optimize.brentq(imag, lo, hi, xtol=1e-14, rtol=1e-13)
            gm = 1.0 / abs(frequency_response(loop, np.array([w]))[0])
        else:
            resp = frequency_response(loop, np.array([w]))[0]
            if abs(resp.imag) > _CONFIRM_RTOL * max(abs(resp), 1e-300):
                continue
        w_out.append(w)
        gm_out.append(gm)
    return np.asarray(w_out, float), np.asarray(gm_out, float)


@dataclass(frozen=True)
class SweepMargins:
    """Margins found by a brute-force frequency sweep (see :func:`sweep_margins`)."""

    crossover_rad_s: np.ndarray
    phase_margins_deg: np.ndarray
    phase_crossover_rad_s: np.ndarray
    gain_margins_db: np.ndarray
    ms: float


def sweep_margins(loop: control.LTI, n_points: int = 200_000) -> SweepMargins:
    """Independent cross-check: margins from a dense linear frequency sweep.

    Evaluates ``C (zI - A)^-1 B + D`` of the loop's state-space form (no
    transfer-function conversion, no python-control frequency routine) on
    ``n_points`` frequencies up to Nyquist (discrete) or 1000x the fastest
    pole (continuous), finds sign changes of
    ``|L| - 1`` and of ``Im L`` (with ``Re L < 0``), and interpolates linearly.

    Parameters
    ----------
    loop : control.LTI
        SISO open loop.
    n_points : int
        Number of frequencies.

    Returns
    -------
    SweepMargins
    """
    import control
    ss = control.ss(loop)
    a, b, c, d = (np.asarray(m, float) for m in (ss.A, ss.B, ss.C, ss.D))
    dt = _dt(loop)
    if dt is not None:
        omega = np.linspace(1e-6, np.pi / dt, n_points)
        point = np.exp(1j * omega * dt)
    else:
        rate = np.max(np.abs(np.linalg.eigvals(a)), initial=1.0)
        omega = np.linspace(1e-6, 1000.0 * max(rate, 1.0), n_points)
        point = 1j * omega
    lval = np.full(point.shape, d.item(), dtype=complex)
    eye = np.eye(a.shape[0])
    for start in range(0, point.size, 8192):
        z = point[start : start + 8192, None, None]
        x = np.linalg.solve(z * eye - a, np.broadcast_to(b, (z.shape[0],) + b.shape))
        lval[start : start + 8192] += (c @ x)[:, 0, 0]
    mag = np.abs(lval)

    def crossings(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        idx = np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)[0]
        frac = f[idx] / (f[idx] - f[idx + 1])
        return idx, omega[idx] + frac * (omega[idx + 1] - omega[idx])

    idx, w_gc = crossings(mag - 1.0)
    frac = (w_gc - omega[idx]) / (omega[idx + 1] - omega[idx])
    ang = np.angle(lval[idx]) + frac * np.angle(lval[idx + 1] / lval[idx])
    pms = np.mod(np.rad2deg(ang), 360.0) - 180.0
    idx, w_pc = crossings(lval.imag)
    negative = lval.real[idx] < 0
    idx, w_pc = idx[negative], w_pc[negative]
    frac = (w_pc - omega[idx]) / (omega[idx + 1] - omega[idx])
    mag_pc = mag[idx] + frac * (mag[idx + 1] - mag[idx])
    return SweepMargins(
        crossover_rad_s=w_gc,
        phase_margins_deg=pms,
        phase_crossover_rad_s=w_pc,
        gain_margins_db=-20.0 * np.log10(mag_pc),
        ms=float(np.max(1.0 / np.abs(1.0 + lval))),
    )
