"""Low-order plant identification from step-response data.

Fits ``K e^{-d T s} / ((tau_1 s + 1) ... (tau_n s + 1))`` (n = 1 or 2, d whole
samples) to sampled input/output data by output-error least squares: the model
is sampled with a zero-order hold and simulated on the measured command, so the
fit is that of the free-run response, not of a one-step predictor.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from controllers.errors import IdentificationError

if TYPE_CHECKING:
    import control

_MIN_SAMPLES = 20


@dataclass(frozen=True)
class IdentifiedPlant:
    """A low-order model and how well it reproduces the data.

    Attributes
    ----------
    model : control.StateSpace
        Discrete model (``dt`` set) from command increment to force increment
        in N, including the delay.
    continuous : control.TransferFunction
        The continuous rational part ``K / prod(tau_i s + 1)`` (without delay).
    gain_n : float
        Static gain K in N per unit command.
    time_constants_s : tuple of float
        Time constants in seconds, largest first.
    delay_samples : int
        Input delay in whole samples.
    fit_percent : float
        ``100 (1 - ||y - y_hat|| / ||y - mean(y)||)`` of the simulated response.
    r2 : float
        Coefficient of determination of the simulated response.
    rms_error_n : float
        RMS of ``y - y_hat`` in N.
    u0, y0 : float
        Operating point removed before fitting (first sample of each signal).
    """

    model: control.StateSpace
    continuous: control.TransferFunction
    gain_n: float
    time_constants_s: tuple[float, ...]
    delay_samples: int
    fit_percent: float
    r2: float
    rms_error_n: float
    u0: float
    y0: float


def _validate(u: np.ndarray, y: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    u = np.asarray(u, dtype=float)
    y = np.asarray(y, dtype=float)
    if u.ndim != 1 or y.ndim != 1 or u.shape != y.shape:
        raise IdentificationError(
            f"identify: expected 1-D u and y of equal length, found shapes {u.shape} and {y.shape}"
        )
    if u.size < _MIN_SAMPLES:
        raise IdentificationError(
            f"identify: expected at least {_MIN_SAMPLES} samples, found {u.size}"
        )
    if not (np.isfinite(u).all() and np.isfinite(y).all()):
        raise IdentificationError("identify: expected finite u and y, found NaN or inf")
    if not dt_s > 0:
        raise IdentificationError(f"identify: expected dt_s > 0, found {dt_s}")
    if np.ptp(u) == 0:
        raise IdentificationError("identify: expected a command that changes, found a constant u")
    if np.ptp(y) == 0:
        raise IdentificationError("identify: expected a force response, found a constant y")
    return u, y


def _step_samples(gain: float, taus: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """Continuous step response of ``K / prod(tau s + 1)`` at times ``t_s`` (closed form)."""
    if taus.size == 1:
        return gain * (1.0 - np.exp(-t_s / taus[0]))
    t1, t2 = taus
    if abs(t1 - t2) <= 1e-6 * max(t1, t2):
        return gain * (1.0 - (1.0 + t_s / t1) * np.exp(-t_s / t1))
    return gain * (1.0 - (t1 * np.exp(-t_s / t1) - t2 * np.exp(-t_s / t2)) / (t1 - t2))


def _discrete_coeffs(
    gain: float, taus: np.ndarray, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """ZOH-sampled numerator and denominator (in powers of z) of K / prod(tau s + 1).

    The denominator has the sampled poles ``exp(-T / tau)``; the numerator
    follows from the step response at ``T`` and ``2T``, which a ZOH model
    reproduces exactly.
    """
    poles = np.exp(-dt_s / taus)
    den = np.poly(poles)
    steps = _step_samples(gain, taus, dt_s * np.arange(1, taus.size + 1))
    if taus.size == 1:
        return np.array([0.0, steps[0]]), den
    b1 = steps[0]
    b2 = steps[1] + den[1] * steps[0] - b1
    return np.array([0.0, b1, b2]), den


def _simulate(params: np.ndarray, du: np.ndarray, dt_s: float, delay_samples: int) -> np.ndarray:
    import scipy.signal
    gain, taus = params[0], np.exp(params[1:])
    num, den = _discrete_coeffs(gain, taus, dt_s)
    shifted = np.concatenate([np.zeros(delay_samples), du[: du.size - delay_samples]])
    return scipy.signal.lfilter(num, den, shifted)


def identify_low_order(
    u: np.ndarray,
    y: np.ndarray,
    dt_s: float,
    *,
    order: int | str = "auto",
    max_delay_samples: int = 5,
) -> IdentifiedPlant:
    """Identify a first- or second-order-plus-delay model from step-response data.

    Parameters
    ----------
    u : ndarray, shape (n_samples,)
        Normalized motor command (-1..1) applied at each sample (held).
    y : ndarray, shape (n_samples,)
        Grip force in N measured at each sample.
    dt_s : float
        Sampling period in seconds.
    order : {1, 2, "auto"}
        Number of real poles. ``"auto"`` fits both and keeps the second order
        only if it raises the fit by more than 0.5 percentage points and its
        faster time constant exceeds a tenth of ``dt_s`` (otherwise the extra
        pole is not identifiable from the data).
    max_delay_samples : int
        Input delays ``0..max_delay_samples`` are tried; the best fit wins.

    Returns
    -------
    IdentifiedPlant

    Raises
    ------
    IdentificationError
        On malformed data or a non-excited command.
    """
    import control
    import scipy.optimize
    if order not in (1, 2, "auto"):
        raise IdentificationError(f"identify: expected order 1, 2 or 'auto', found {order!r}")
    if order == "auto":
        first = identify_low_order(u, y, dt_s, order=1, max_delay_samples=max_delay_samples)
        second = identify_low_order(u, y, dt_s, order=2, max_delay_samples=max_delay_samples)
        useful = (second.fit_percent > first.fit_percent + 0.5
                  and min(second.time_constants_s) > 0.1 * dt_s)
        return second if useful else first
    u, y = _validate(u, y, dt_s)
    u0, y0 = float(u[0]), float(y[0])
    du, dy = u - u0, y - y0
    tail = max(1, u.size // 10)
    gain0 = float(np.mean(dy[-tail:]) / np.mean(du[-tail:])) if np.mean(du[-tail:]) else 1.0
    step_at = int(np.argmax(np.abs(du) > 0.5 * np.max(np.abs(du))))
    target = 0.63 * np.mean(dy[-tail:])
    reached = np.nonzero(np.abs(dy[step_at:]) >= abs(target))[0]
    tau0 = max((reached[0] if reached.size else u.size / 3) * dt_s, 2 * dt_s)
    taus0 = [tau0] if order == 1 else [0.7 * tau0, 0.3 * tau0]
    x0 = np.concatenate([[gain0], np.log(taus0)])
    # time constants between dt/100 and 1000 s (log-parametrized)
    lower = np.concatenate([[-np.inf], np.full(order, np.log(dt_s / 100.0))])
    upper = np.concatenate([[np.inf], np.full(order, np.log(1e3))])
    x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)
    best = None
    for d in range(min(max_delay_samples, u.size // 4) + 1):
        result = scipy.optimize.least_squares(
            lambda p, d=d: _simulate(p, du, dt_s, d) - dy, x0, bounds=(lower, upper)
        )
        if best is None or result.cost < best[0].cost:
            best = (result, d)
    result, delay_samples = best
    residual = result.fun
    gain = float(result.x[0])
    taus = np.sort(np.exp(result.x[1:]))[::-1]
    ss_res = float(residual @ residual)
    ss_tot = float(np.sum((dy - dy.mean()) ** 2))
    num, den = _discrete_coeffs(gain, taus, dt_s)
    den_delayed = np.concatenate([den, np.zeros(delay_samples)])
    model = control.ss(control.tf(np.trim_zeros(num, "f"), den_delayed, dt_s))
    den_s = np.array([1.0])
    for tau in taus:
        den_s = np.polymul(den_s, [tau, 1.0])
    return IdentifiedPlant(
        model=model,
        continuous=control.tf([gain], den_s),
        gain_n=gain,
        time_constants_s=tuple(float(t) for t in taus),
        delay_samples=delay_samples,
        fit_percent=float(100.0 * (1.0 - np.sqrt(ss_res / ss_tot))),
        r2=1.0 - ss_res / ss_tot,
        rms_error_n=float(np.sqrt(ss_res / dy.size)),
        u0=u0,
        y0=y0,
    )
