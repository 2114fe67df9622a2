"""Discrete PID with derivative filter, back-calculation anti-windup and bumpless switching,
designed from a phase-margin and crossover specification.

Control law at step k (``e = r - y``, ``T`` the control period)::

    u_k   = sat(kp e_k + I_k + kd D_k)
    D_k   = a D_{k-1} + (s_k - s_{k-1}) / (Tf + T),  a = Tf / (Tf + T)
    I_k+1 = I_k + ki T e_k + (T / Tt) (u_k - v_k)            (back-calculation)

with ``s = e`` or ``s = -y`` (derivative on measurement, no setpoint kick) and
``v`` the unsaturated output. Its linear part from ``e`` to ``u`` is::

    C(z) = kp + ki T / (z - 1) + kd (z - 1) / ((Tf + T) z - Tf)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from controllers.analysis import loop_margins
from controllers.base import Implementation, Observation, as_observation
from controllers.errors import SpecificationError
from controllers.plant import check_plant, frequency_response, loop_plant, plant_dt
from controllers.report import DesignReport

if TYPE_CHECKING:
    import control


class PID:
    """Discrete PID controller acting on grip force.

    Parameters
    ----------
    kp : float
        Proportional gain, command units per N.
    ki_per_s : float
        Integral gain, command units per (N s).
    kd_s : float
        Derivative gain, command units s per N.
    derivative_filter_s : float
        Time constant ``Tf`` of the first-order derivative filter in seconds.
    implementation : Implementation
        Control period ``dt_s`` in seconds (required), computation delay (samples
        between measuring and applying, used by :meth:`loop`) and command
        saturation ``u_limits`` (default ``(-1, 1)``).
    tracking_time_s : float, optional
        Back-calculation time constant ``Tt`` (>= ``dt_s``); default
        ``sqrt(Ti Td)`` with ``Ti = kp/ki``, ``Td = kd/kp`` (``Ti`` for a PI).
    derivative_on : {"measurement", "error"}
        Differentiate ``-y`` (no kick on reference steps) or ``e``.
    """

    name = "pid"

    def __init__(
        self,
        *,
        kp: float,
        ki_per_s: float,
        kd_s: float,
        derivative_filter_s: float,
        implementation: Implementation,
        tracking_time_s: float | None = None,
        derivative_on: Literal["measurement", "error"] = "measurement",
    ) -> None:
        dt_s, u_limits = implementation.dt_s, implementation.u_limits
        if dt_s is None or dt_s <= 0:
            raise SpecificationError(f"PID: expected implementation.dt_s > 0, found {dt_s}")
        if derivative_filter_s < 0:
            raise SpecificationError(
                f"PID: expected derivative_filter_s >= 0, found {derivative_filter_s}")
        if derivative_on not in ("measurement", "error"):
            raise SpecificationError(
                f"PID: expected derivative_on 'measurement' or 'error', found {derivative_on!r}"
            )
        if not u_limits[0] < u_limits[1]:
            raise SpecificationError(
                f"PID: expected u_limits (low, high) with low < high, found {u_limits}"
            )
        self.dt_s = float(dt_s)
        self.derivative_filter_s = float(derivative_filter_s)
        self.u_limits = (float(u_limits[0]), float(u_limits[1]))
        self.derivative_on = derivative_on
        self.computation_delay_samples = int(implementation.computation_delay_samples)
        self._tracking_time_s = tracking_time_s
        self.kp, self.ki_per_s, self.kd_s = float(kp), float(ki_per_s), float(kd_s)
        self._update_tracking()
        self.manual_u: float | None = None
        self.report_: DesignReport | None = None
        self.reset()

    def _update_tracking(self) -> None:
        if self._tracking_time_s is not None:
            tt = float(self._tracking_time_s)
        elif self.ki_per_s > 0 and self.kp > 0:
            ti = self.kp / self.ki_per_s
            tt = np.sqrt(ti * self.kd_s / self.kp) if self.kd_s > 0 else ti
        else:
            tt = np.inf
        self.tracking_time_s = max(tt, self.dt_s)

    def reset(self, u0: float = 0.0) -> None:
        """Zero the state; the first output for zero error is ``u0`` (clipped).

        The first step after a reset takes its own derivative signal as the past
        value, so starting on a nonzero force gives no derivative kick.
        """
        self._integral = float(np.clip(u0, *self.u_limits))
        self._deriv = 0.0
        self._s_prev: float | None = None
        self._e_last = 0.0
        self.last_u = self._integral

    def set_gains(self, *, kp: float, ki_per_s: float, kd_s: float) -> None:
        """Change gains without a bump: the integrator absorbs the change in P and D terms."""
        self._integral += (self.kp - kp) * self._e_last + (self.kd_s - kd_s) * self._deriv
        self.kp, self.ki_per_s, self.kd_s = float(kp), float(ki_per_s), float(kd_s)
        self._update_tracking()

    def set_manual(self, u: float | None) -> None:
        """Hold the output at ``u`` (manual mode), or return to automatic with ``None``.

        In manual mode the integrator tracks the held output, so switching back
        to automatic is bumpless.
        """
        self.manual_u = None if u is None else float(np.clip(u, *self.u_limits))

    def step(self, reference_n: float, grip_force_n: float) -> float:
        """One control step; returns the saturated command."""
        e = reference_n - grip_force_n
        s = e if self.derivative_on == "error" else -grip_force_n
        tf, dt = self.derivative_filter_s, self.dt_s
        if self._s_prev is None:
            self._s_prev = s
        self._deriv = (tf * self._deriv + (s - self._s_prev)) / (tf + dt)
        self._s_prev = s
        pd = self.kp * e + self.kd_s * self._deriv
        if self.manual_u is not None:
            u = self.manual_u
            self._integral = u - pd
        else:
            v = pd + self._integral
            u = min(max(v, self.u_limits[0]), self.u_limits[1])
            self._integral += self.ki_per_s * dt * e + (dt / self.tracking_time_s) * (u - v)
        self._e_last = e
        self.last_u = u
        return u

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Command in ``u_limits`` for an observation (uses reference and grip force)."""
        obs = as_observation(observation)
        return self.step(obs.reference_n, obs.grip_force_n)

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Follow a command applied by someone else (bumpless hand-over later)."""
        obs = as_observation(observation)
        held, self.manual_u = self.manual_u, float(np.clip(applied_u, *self.u_limits))
        self.step(obs.reference_n, obs.grip_force_n)
        self.manual_u = held

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Take over from someone else's command ``u``: the next command continues from it."""
        self.reset(u)
        self.track(observation, u)

    def transfer_function(self) -> control.TransferFunction:
        """Linear part ``C(z)`` from error (N) to command, discrete with ``dt``."""
        import control
        dt, tf = self.dt_s, self.derivative_filter_s
        c = control.tf([self.kp], [1.0], dt)
        if self.ki_per_s:
            c = c + control.tf([self.ki_per_s * dt], [1.0, -1.0], dt)
        if self.kd_s:
            c = c + control.tf([self.kd_s, -self.kd_s], [tf + dt, -tf], dt)
        return c

    def loop(self, plant: control.LTI) -> control.TransferFunction:
        """Open loop ``C(z) P(z) z**-d`` with sample-and-hold and computation delay."""
        return self.transfer_function() * loop_plant(
            plant, self.dt_s, computation_delay_samples=self.computation_delay_samples
        )


def required_controller_phase(
    plant: control.LTI,
    phase_margin_deg: float,
    crossover_rad_s: float,
    dt_s: float,
    computation_delay_samples: int,
) -> tuple[float, float]:
    """Phase (deg) and gain a controller needs at the crossover.

    ``arg C(wc) = -180 + PM - arg P(wc)`` and ``|C(wc)| = 1 / |P(wc)|`` for the
    sampled, delayed plant. ``arg P`` is the plant's *unwrapped* phase, followed
    continuously from low frequency: a plant lagging 250 deg at ``wc`` needs
    250 - 180 + PM deg of lead, not a small lag (wrapping the requirement into
    (-180, 180] would pass designs whose loop encircles -1 and is unstable).

    Raises
    ------
    SpecificationError
        If the crossover is at or above the Nyquist frequency or not positive.
    """
    nyquist = np.pi / dt_s
    if not 0 < crossover_rad_s < nyquist:
        raise SpecificationError(
            f"crossover {crossover_rad_s} rad/s must lie in (0, {nyquist:.4g}) rad/s "
            f"(Nyquist at dt = {dt_s} s)"
        )
    if not 0 < phase_margin_deg < 90:
        raise SpecificationError(
            f"phase margin must lie in (0, 90) deg, found {phase_margin_deg}"
        )
    lp = loop_plant(plant, dt_s, computation_delay_samples=computation_delay_samples)
    grid = np.geomspace(crossover_rad_s * 1e-4, crossover_rad_s, 400)
    response = frequency_response(lp, grid)
    phase = np.rad2deg(np.unwrap(np.angle(response)))
    # anchor the unwrapped curve at low frequency in (-360, 0]: a causal plant
    # (with integrators) starts between 0 and -270 deg
    phase += 360.0 * np.ceil(-phase[0] / 360.0 - 1e-9) if phase[0] > 1e-9 else 0.0
    theta = -180.0 + phase_margin_deg - phase[-1]
    return float(theta), float(1.0 / np.abs(response[-1]))


def design_pid(
    plant: control.LTI,
    *,
    phase_margin_deg: float = 60.0,
    crossover_rad_s: float,
    structure: Literal["pi", "pid"] = "pi",
    ti_over_td: float = 4.0,
    derivative_filter_ratio: float = 10.0,
    implementation: Implementation | None = None,
) -> PID:
    """Design a PI or PID so that the loop crosses over at ``crossover_rad_s`` with the given PM.

    The gains solve ``C(e^{j wc T}) P(e^{j wc T}) z^-d = -e^{j PM}`` exactly on the
    discrete loop. A PI has two gains for the two equations. A PID fixes
    ``Ti = ti_over_td * Td`` and the derivative filter at ``derivative_filter_ratio * wc``,
    and finds ``Td`` by root finding on the phase.

    Parameters
    ----------
    plant : control.LTI
        Design plant, command (-1..1) to grip force (N); continuous or discrete.
    phase_margin_deg : float
        Target phase margin in degrees.
    crossover_rad_s : float
        Target gain-crossover frequency in rad/s.
    structure : {"pi", "pid"}
    ti_over_td : float
        ``Ti / Td`` for the PID (4 is the classical choice).
    derivative_filter_ratio : float
        Derivative filter corner as a multiple of the crossover.
    implementation : Implementation, optional
        Control period in seconds (required for a continuous plant; default the
        plant's), whole samples of computation delay in the loop (default 1) and
        command saturation (default ``(-1, 1)``).

    Returns
    -------
    PID
        With ``report_`` (:class:`~controllers.report.DesignReport`).

    Raises
    ------
    PlantError
        Unstable or non-minimal plant (checked first).
    SpecificationError
        If the structure cannot give the phase the plant needs at that crossover.
    """
    if structure not in ("pi", "pid"):
        raise SpecificationError(f"structure must be 'pi' or 'pid', found {structure!r}")
    plant_report = check_plant(plant)
    impl = Implementation() if implementation is None else implementation
    dt = plant_dt(plant, impl.dt_s)
    computation_delay_samples = impl.computation_delay_samples
    wc = float(crossover_rad_s)
    theta, gain = required_controller_phase(
        plant, phase_margin_deg, wc, dt, computation_delay_samples
    )
    notes: list[str] = []
    if structure == "pi":
        kp, ki, kd, tf = _pi_gains(theta, gain, wc, dt, phase_margin_deg)
    else:
        kp, ki, kd, tf = _pid_gains(theta, gain, wc, dt, phase_margin_deg,
                                    ti_over_td=ti_over_td,
                                    derivative_filter_ratio=derivative_filter_ratio)
        notes.append(f"Ti = {ti_over_td} Td; derivative filter corner at "
                     f"{derivative_filter_ratio} x crossover")
    if kp < 0 or ki < 0 or kd < 0:
        raise SpecificationError(
            f"phase margin {phase_margin_deg} deg at {wc} rad/s needs negative gains "
            f"(kp {kp:.3g}, ki {ki:.3g}, kd {kd:.3g}); choose another crossover"
        )
    controller = PID(
        kp=float(kp),
        ki_per_s=float(ki),
        kd_s=float(kd),
        derivative_filter_s=float(tf),
        implementation=replace(impl, dt_s=dt),
    )
    margins = loop_margins(controller.loop(plant))
    controller.report_ = DesignReport(
        controller="pid",
        spec={"phase_margin_deg": phase_margin_deg, "crossover_rad_s": wc,
              "structure": structure, "computation_delay_samples": computation_delay_samples},
        parameters={"kp": float(kp), "ki_per_s": float(ki), "kd_s": float(kd),
                    "derivative_filter_s": float(tf),
                    "tracking_time_s": controller.tracking_time_s, "dt_s": dt},
        plant=plant_report,
        margins=margins,
        notes=notes,
    )
    return controller


def _integrator_at(wc: float, dt: float) -> complex:
    """The discrete integrator ``T / (z - 1)`` at ``z = e^{j wc T}``."""
    return dt / (np.exp(1j * wc * dt) - 1.0)


def _pi_gains(theta: float, gain: float, wc: float, dt: float,
              phase_margin_deg: float) -> tuple[float, float, float, float]:
    """PI gains giving the controller phase ``theta`` (deg) and ``gain`` at ``wc`` (rad/s).

    Returns
    -------
    kp, ki_per_s, kd_s, derivative_filter_s : float
        ``kd_s`` and the filter are 0 for a PI.

    Raises
    ------
    SpecificationError
        ``theta`` needs lead, or more lag than the integrator gives at ``wc``.
    """
    g = _integrator_at(wc, dt)
    lag_limit = np.angle(g, deg=True)
    if theta > 0:
        raise SpecificationError(
            f"phase margin {phase_margin_deg} deg at {wc} rad/s needs {theta:.1f} deg of "
            f"lead; a PI gives at most 0 deg (use structure='pid', lead_lag or a lower "
            f"crossover)"
        )
    if theta < lag_limit:
        raise SpecificationError(
            f"phase margin {phase_margin_deg} deg at {wc} rad/s needs {-theta:.1f} deg of "
            f"lag; a PI gives at most {-lag_limit:.1f} deg (raise the crossover)"
        )
    target = gain * np.exp(1j * np.deg2rad(theta))
    ki = target.imag / g.imag
    kp = target.real - ki * g.real
    return kp, ki, 0.0, 0.0


def _pid_gains(theta: float, gain: float, wc: float, dt: float, phase_margin_deg: float, *,
               ti_over_td: float, derivative_filter_ratio: float
               ) -> tuple[float, float, float, float]:
    """PID gains (``Ti = ti_over_td Td``) giving phase ``theta`` (deg) and ``gain`` at ``wc``.

    ``Td`` is found by root finding on the controller's phase at ``wc`` over
    ``1e-4 / wc .. 1e3 / wc`` s; the derivative filter's corner is
    ``derivative_filter_ratio * wc``.

    Returns
    -------
    kp, ki_per_s, kd_s, derivative_filter_s : float

    Raises
    ------
    SpecificationError
        ``theta`` is outside the phases this PID shape reaches at ``wc``.
    """
    import scipy.optimize
    g = _integrator_at(wc, dt)
    tf = 1.0 / (derivative_filter_ratio * wc)
    zc = np.exp(1j * wc * dt)
    h = (zc - 1.0) / ((tf + dt) * zc - tf)

    def shape(td: np.ndarray) -> np.ndarray:
        return 1.0 + g / (ti_over_td * td) + td * h

    grid = np.geomspace(1e-4 / wc, 1e3 / wc, 4000)
    phase = np.angle(shape(grid), deg=True)
    i_max = int(np.argmax(phase))
    if theta > phase[i_max]:
        raise SpecificationError(
            f"phase margin {phase_margin_deg} deg at {wc} rad/s needs {theta:.1f} deg of "
            f"lead; a PID with Ti = {ti_over_td} Td and derivative filter at "
            f"{derivative_filter_ratio} wc gives at most {phase[i_max]:.1f} deg"
        )
    if theta < phase[0]:
        raise SpecificationError(
            f"phase margin {phase_margin_deg} deg at {wc} rad/s needs {-theta:.1f} deg of "
            f"lag; a PID gives at most {-phase[0]:.1f} deg (raise the crossover)"
        )
    j = int(np.nonzero(phase[: i_max + 1] >= theta)[0][0])
    if j == 0:
        td = grid[0]
    else:
        td = scipy.optimize.brentq(
            lambda t: np.angle(shape(np.array([t])), deg=True)[0] - theta,
            grid[j - 1],
            grid[j],
            xtol=1e-14,
        )
    kp = gain / np.abs(shape(np.array([td]))[0])
    ki, kd = kp / (ti_over_td * td), kp * td
    return kp, ki, kd, tf
