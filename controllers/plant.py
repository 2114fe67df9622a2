"""Design plants: checks before design and the sampled loop plant with its delays.

A design plant maps the normalized motor command (``-1..1``) to grip force in
newtons. Continuous plants are sampled with a zero-order hold (the DAC's
sample-and-hold); the controller's computation delay adds whole samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from controllers.errors import PlantError, SpecificationError
from controllers.response import state_space_response

if TYPE_CHECKING:
    import control

# |z| above 1 + _UNIT_TOL (or Re s above _UNIT_TOL) counts as unstable; on the
# boundary only integrators (z = 1, s = 0) are accepted.
_UNIT_TOL = 1e-9
_INTEGRATOR_TOL = 1e-6
# A mode whose PBH matrix has a relative smallest singular value below this is
# treated as uncontrollable/unobservable.
_PBH_RTOL = 1e-9


def plant_dt(plant: control.LTI, dt_s: float | None) -> float:
    """The control period of a design: the plant's own sample time, else ``dt_s``.

    Parameters
    ----------
    plant : control.LTI
        Design plant, discrete (its ``dt`` wins) or continuous.
    dt_s : float or None
        Control period, s, for a continuous plant.

    Raises
    ------
    PlantError
        A continuous plant and no ``dt_s``.
    """
    if plant.isdtime(strict=True):
        return float(plant.dt)
    if dt_s is None:
        raise PlantError("design: a continuous plant needs dt_s (the control period)")
    return float(dt_s)


@dataclass(frozen=True)
class PlantReport:
    """What :func:`check_plant` found.

    Attributes
    ----------
    poles, zeros : ndarray of complex
        Poles and zeros of the minimal realization (z-plane if ``dt`` is set).
    dc_gain : float
        Steady-state gain in N per unit command (``inf`` with an integrator).
    n_integrators : int
        Poles at ``z = 1`` (``s = 0``).
    dt : float or None
        Sampling period in seconds; ``None`` for a continuous plant.
    order : int
        Number of states of the minimal realization.
    """

    poles: np.ndarray
    zeros: np.ndarray
    dc_gain: float
    n_integrators: int
    dt: float | None
    order: int


def _pbh_margins(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[float, float]:
    """Smallest relative singular values of ``[A - lI, B]`` and ``[A - lI; C]`` over eigenvalues.

    The Popov-Belevitch-Hautus test is well conditioned where Kalman's
    controllability matrix is not (modes close to 1 make its columns nearly
    parallel).
    """
    n = a.shape[0]
    scale = max(np.linalg.norm(a, 2), 1.0)
    worst_c = worst_o = np.inf
    for lam in np.linalg.eigvals(a):
        shifted = a - lam * np.eye(n)
        bn = b / max(np.linalg.norm(b), 1e-300) * scale
        cn = c / max(np.linalg.norm(c), 1e-300) * scale
        worst_c = min(worst_c, np.linalg.svd(np.hstack([shifted, bn]), compute_uv=False)[-1])
        worst_o = min(worst_o, np.linalg.svd(np.vstack([shifted, cn]), compute_uv=False)[-1])
    return float(worst_c / scale), float(worst_o / scale)


def _is_discrete(sys: control.LTI) -> bool:
    return sys.dt is not None and sys.dt is not True and sys.dt > 0


def check_plant(plant: control.LTI, *, name: str = "plant") -> PlantReport:
    """Check that ``plant`` is a SISO, stable (integrators allowed), minimal model.

    Parameters
    ----------
    plant : control.LTI
        Command (normalized, -1..1) to grip force (N); continuous or discrete.
    name : str
        Used in error messages.

    Returns
    -------
    PlantReport

    Raises
    ------
    PlantError
        If the plant is not SISO, has poles outside the stability region (other
        than integrators), or its realization is not minimal (pole-zero
        cancellation or an uncontrollable/unobservable mode).
    """
    import control
    if not isinstance(plant, control.LTI):
        raise PlantError(f"{name}: expected a control.LTI, found {type(plant).__name__}")
    if plant.ninputs != 1 or plant.noutputs != 1:
        raise PlantError(
            f"{name}: expected a SISO plant, found {plant.ninputs} inputs, {plant.noutputs} outputs"
        )
    discrete = _is_discrete(plant)
    ss = control.ss(plant)
    n_states = ss.nstates
    if n_states:
        weakest_c, weakest_o = _pbh_margins(
            np.asarray(ss.A, float), np.asarray(ss.B, float), np.asarray(ss.C, float)
        )
        if weakest_c < _PBH_RTOL or weakest_o < _PBH_RTOL:
            raise PlantError(
                f"{name}: expected a minimal realization, found a mode that is "
                f"{'uncontrollable' if weakest_c < _PBH_RTOL else 'unobservable'} "
                f"(PBH test: relative singular values {weakest_c:.2e} (B), {weakest_o:.2e} (C), "
                f"threshold {_PBH_RTOL:.0e})"
            )
    tf = control.tf(plant)
    minimal = control.minreal(tf, tol=1e-7, verbose=False)
    n_poles_tf = len(tf.poles())
    if len(minimal.poles()) < n_poles_tf:
        raise PlantError(
            f"{name}: expected no pole-zero cancellation, found {n_poles_tf} poles reducing "
            f"to {len(minimal.poles())}"
        )
    poles = np.asarray(plant.poles(), dtype=complex)
    if discrete:
        integrators = np.abs(poles - 1.0) < _INTEGRATOR_TOL
        unstable = (np.abs(poles) > 1.0 - _UNIT_TOL) & ~integrators
    else:
        integrators = np.abs(poles) < _INTEGRATOR_TOL
        unstable = (poles.real > -_UNIT_TOL) & ~integrators
    if unstable.any():
        region = "|z| < 1" if discrete else "Re(s) < 0"
        raise PlantError(
            f"{name}: expected poles in {region} (integrators allowed), found "
            f"{np.array2string(poles[unstable], precision=4)}"
        )
    n_int = int(integrators.sum())
    dc = float("inf") if n_int else float(np.real(control.dcgain(plant)))
    return PlantReport(
        poles=poles,
        zeros=np.asarray(plant.zeros(), dtype=complex),
        dc_gain=dc,
        n_integrators=n_int,
        dt=float(plant.dt) if discrete else None,
        order=n_states,
    )


def delay(n_samples: int, dt_s: float) -> control.TransferFunction:
    """A pure delay of ``n_samples`` control periods, ``z**-n``.

    Parameters
    ----------
    n_samples : int
        Non-negative number of samples.
    dt_s : float
        Sampling period in seconds.
    """
    import control
    if n_samples < 0:
        raise SpecificationError(f"delay: expected n_samples >= 0, found {n_samples}")
    den = np.zeros(n_samples + 1)
    den[0] = 1.0
    return control.tf([1.0], den, dt_s)


def loop_plant(
    plant: control.LTI, dt_s: float | None = None, *, computation_delay_samples: int = 1
) -> control.TransferFunction:
    """The plant as the controller sees it: sample-and-hold, then the computation delay.

    Parameters
    ----------
    plant : control.LTI
        Continuous or discrete SISO plant (command to force, N).
    dt_s : float, optional
        Control period in seconds. Required for a continuous plant; for a
        discrete plant it must equal ``plant.dt`` if given.
    computation_delay_samples : int, default 1
        Whole control periods between reading the force and applying the
        command computed from it.

    Returns
    -------
    control.TransferFunction
        Discrete ``P(z) z**-d`` with ``dt`` set.

    Raises
    ------
    PlantError
        If the sampling period is missing or disagrees with the plant's.
    """
    import control
    if _is_discrete(plant):
        if dt_s is not None and not np.isclose(dt_s, plant.dt, rtol=1e-9):
            raise PlantError(
                f"loop_plant: expected dt_s equal to the plant's dt {plant.dt} s, found {dt_s} s"
            )
        sampled = control.tf(plant)
        dt_s = float(plant.dt)
    else:
        if dt_s is None or dt_s <= 0:
            raise PlantError(
                f"loop_plant: a continuous plant needs dt_s > 0 for the zero-order hold, "
                f"found {dt_s}"
            )
        sampled = control.tf(control.c2d(plant, dt_s, method="zoh"))
    if computation_delay_samples:
        sampled = sampled * delay(computation_delay_samples, dt_s)
    return sampled


def frequency_response(sys: control.LTI, omega_rad_s: np.ndarray) -> np.ndarray:
    """Complex response of a SISO system on ``omega_rad_s`` (rad/s), shape (n_freqs,).

    A state-space system is evaluated as ``C (pI - A)^-1 B + D`` with one batched
    linear solve over all frequencies (:func:`controllers.response.state_space_response`;
    python-control solves one system per point, which dominated the margin analysis of
    the MPC's 20-state loops); transfer functions, and a frequency on a pole, go through
    python-control.
    """
    import control
    omega = np.asarray(omega_rad_s, dtype=float)
    point = np.exp(1j * omega * sys.dt) if _is_discrete(sys) else 1j * omega
    if isinstance(sys, control.StateSpace) and sys.nstates:
        try:
            return state_space_response(sys.A, sys.B, sys.C, sys.D,
                                        sys.dt if _is_discrete(sys) else None, omega)
        except np.linalg.LinAlgError:  # a frequency on a pole: fall back point by point
            pass
    return np.asarray(sys(point), dtype=complex).reshape(-1)


def truncate_slow_modes(
    plant: control.LTI, min_rate_rad_s: float
) -> tuple[control.StateSpace, np.ndarray]:
    """Remove modes slower than ``min_rate_rad_s`` by modal truncation.

    The state matrix is brought to an ordered real Schur form (fast modes
    first) and block-diagonalized with a Sylvester equation; the slow block is
    dropped. Truncation keeps the feedthrough and the response above the
    removed modes' frequencies exactly, and discards their low-frequency
    contribution (slow creep that an integrating controller rejects as a
    disturbance).

    Parameters
    ----------
    plant : control.LTI
        Discrete or continuous SISO plant.
    min_rate_rad_s : float
        Modes with rate ``|ln|z|| / dt`` (discrete) or ``|s|`` (continuous) below
        this, in rad/s, are removed.

    Returns
    -------
    reduced : control.StateSpace
    removed_poles : ndarray of complex
        The poles that were dropped (z- or s-plane).
    """
    import control
    import scipy.linalg as sla

    ss = control.ss(plant)
    a, b, c, d = (np.asarray(m, float) for m in (ss.A, ss.B, ss.C, ss.D))
    discrete = _is_discrete(plant)
    dt = float(plant.dt) if discrete else None

    def is_fast(re: float, im: float) -> bool:
        lam = complex(re, im)
        rate = abs(np.log(abs(lam))) / dt if discrete and lam != 0 else abs(lam)
        if discrete and lam == 0:
            return True
        return bool(rate >= min_rate_rad_s)

    t, z, n_fast = sla.schur(a, output="real", sort=is_fast)
    removed = np.linalg.eigvals(t[n_fast:, n_fast:]) if n_fast < a.shape[0] else np.zeros(0)
    if n_fast == a.shape[0]:
        return ss, removed
    bz, cz = z.T @ b, c @ z
    t11, t12, t22 = t[:n_fast, :n_fast], t[:n_fast, n_fast:], t[n_fast:, n_fast:]
    x = sla.solve_sylvester(t11, -t22, -t12) if n_fast else np.zeros((0, t22.shape[0]))
    b1 = bz[:n_fast] - x @ bz[n_fast:]
    c1 = cz[:, :n_fast]
    reduced = control.ss(t11, b1, c1, d, plant.dt) if n_fast else control.ss([], [], [], d,
                                                                              plant.dt)
    return reduced, removed
