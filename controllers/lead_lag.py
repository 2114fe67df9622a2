"""Lead-lag compensator designed from phase margin and crossover, run as a saturating
linear controller with Hanus (conditioning) anti-windup.

Continuous prototype, discretized by Tustin prewarped at the crossover (so the
designed gain and phase at ``wc`` are exact on the discrete loop)::

    C(s) = K * ((s + wl) / s) * ((1 + s/wz) / (1 + s/wp))**n,
    wz = wc / sqrt(beta), wp = wc sqrt(beta), beta = (1 + sin phi) / (1 - sin phi)

with ``phi`` the lead per stage (a negative ``phi`` makes the stage a lag) and
``wl = wc / lag_ratio`` the integral (PI-lag) corner.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from controllers.analysis import loop_margins
from controllers.base import COMMAND_LIMITS, Implementation, Observation, as_observation
from controllers.errors import SpecificationError
from controllers.pid import required_controller_phase
from controllers.plant import check_plant, loop_plant, plant_dt
from controllers.report import DesignReport
from sim.codec import stored_systems

if TYPE_CHECKING:
    import control


@stored_systems("_ss")
class LinearController:
    """A biproper discrete SISO controller ``C(z)`` from error (N) to command, with saturation.

    Anti-windup by conditioning (Hanus): the state is driven by the applied
    (saturated) command, ``x+ = (A - B D^-1 C) x + B D^-1 u_sat``, which equals
    ``x+ = A x + B e`` whenever the command is not saturated.

    Parameters
    ----------
    controller : control.LTI
        Discrete, SISO, with ``D != 0`` and zeros inside the unit circle.
    u_limits : (float, float)
        Command saturation.
    computation_delay_samples : int
        Used by :meth:`loop`.
    name : str
        Registered name reported in results.
    """

    def __init__(
        self,
        controller: control.LTI,
        *,
        u_limits: tuple[float, float] = COMMAND_LIMITS,
        computation_delay_samples: int = 1,
        name: str = "lead_lag",
    ) -> None:
        import control
        if not controller.isdtime(strict=True):
            raise SpecificationError(
                "LinearController: expected a discrete controller, found continuous")
        ss = control.ss(controller)
        d = float(np.asarray(ss.D).item())
        if d == 0.0:
            raise SpecificationError(
                "LinearController: expected a biproper controller (D != 0), found D = 0"
            )
        self.name = name
        self.dt_s = float(controller.dt)
        self.u_limits = (float(u_limits[0]), float(u_limits[1]))
        self.computation_delay_samples = int(computation_delay_samples)
        self._ss = ss
        self._A = np.asarray(ss.A, float)
        self._B = np.asarray(ss.B, float).ravel()
        self._C = np.asarray(ss.C, float).ravel()
        self._D = d
        self._Baw = self._B / d
        self._Al = self._A.tolist()
        self._Bl = self._B.tolist()
        self._Cl = self._C.tolist()
        self._Bawl = self._Baw.tolist()
        zeros_map = self._A - np.outer(self._Baw, self._C)
        if self._A.size and np.max(np.abs(np.linalg.eigvals(zeros_map))) >= 1.0:
            raise SpecificationError(
                "LinearController: conditioning anti-windup needs controller zeros inside the "
                "unit circle, found a zero on or outside it"
            )
        # Integrator direction: a steady state (x = A x) with unit output, used to
        # absorb the output change of a bumpless switch (None without one).
        w, v = np.linalg.eig(self._A) if self._A.size else (np.zeros(0), np.zeros((0, 0)))
        near_one = np.flatnonzero(np.abs(w - 1.0) < 1e-9)
        self._integrator_dir = None
        if near_one.size:
            direction = np.real(v[:, near_one[0]])
            gain = float(self._C @ direction)
            if abs(gain) > 1e-12:
                self._integrator_dir = direction / gain
        self.report_: DesignReport | None = None
        self.reset()

    def take_state_from(self, other: LinearController, observation: Observation | Mapping[str, Any],
                        u: float) -> bool:
        """Bumpless switch from ``other`` (same order): copy its state, let the integrator absorb
        the output difference so that the command for this error is ``u``.

        Returns False (and changes nothing) when the realizations are not compatible.
        """
        if (not isinstance(other, LinearController) or other._A.shape != self._A.shape
                or self._integrator_dir is None):
            return False
        obs = as_observation(observation)
        e = obs.reference_n - obs.grip_force_n
        x = other._x.copy()
        x += (float(u) - float(self._C @ x) - self._D * e) * self._integrator_dir
        self._x = x
        self.last_u = float(u)
        return True

    def reset(self, u0: float = 0.0) -> None:
        """Set a steady state whose output for zero error is ``u0`` (clipped)."""
        u0 = float(np.clip(u0, *self.u_limits))
        n = self._A.shape[0]
        lhs = np.vstack([self._C[None, :], np.eye(n) - self._A])
        rhs = np.concatenate([[u0], np.zeros(n)])
        self._x = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
        self.last_u = u0

    def step(
        self, reference_n: float, grip_force_n: float, applied_u: float | None = None
    ) -> float:
        """One control step; returns the saturated command.

        With ``applied_u`` the state is conditioned on that command instead
        (the controller tracks a command applied by someone else).
        """
        # plain floats: for the two or three states of a compensator this is several
        # times faster than numpy's per-call overhead (the step runs every period)
        e = reference_n - grip_force_n
        x = self._xl
        v = self._D * e
        for c, xi in zip(self._Cl, x, strict=True):
            v += c * xi
        lo, hi = self.u_limits
        if applied_u is None:
            u = lo if v < lo else hi if v > hi else v
        else:
            u = min(max(float(applied_u), lo), hi)
        w = u - v
        self._xl = [sum(a * xj for a, xj in zip(row, x, strict=True)) + b * e + g * w
                    for row, b, g in zip(self._Al, self._Bl, self._Bawl, strict=True)]
        self.last_u = u
        return u

    @property
    def _x(self) -> np.ndarray:
        """Controller state, shape (n,)."""
        return np.array(self._xl, dtype=float)

    @_x.setter
    def _x(self, value: np.ndarray) -> None:
        self._xl = [float(v) for v in np.asarray(value, dtype=float).ravel()]

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Follow a command applied by someone else (bumpless hand-over later)."""
        obs = as_observation(observation)
        self.step(obs.reference_n, obs.grip_force_n, applied_u)

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Command in ``u_limits`` for an observation (uses reference and grip force)."""
        obs = as_observation(observation)
        return self.step(obs.reference_n, obs.grip_force_n)

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Take over from someone else's command ``u``: the next command continues from it."""
        self.reset(u)
        self.track(observation, u)

    def transfer_function(self) -> control.TransferFunction:
        """``C(z)`` from error (N) to command."""
        import control
        return control.tf(self._ss)

    def loop(self, plant: control.LTI) -> control.TransferFunction:
        """Open loop ``C(z) P(z) z**-d`` with sample-and-hold and computation delay."""
        return self.transfer_function() * loop_plant(
            plant, self.dt_s, computation_delay_samples=self.computation_delay_samples
        )


def design_lead_lag(
    plant: control.LTI,
    *,
    phase_margin_deg: float = 50.0,
    crossover_rad_s: float,
    integral: bool = True,
    lag_ratio: float = 10.0,
    n_lead_stages: int = 1,
    max_stage_lead_deg: float = 65.0,
    implementation: Implementation | None = None,
) -> LinearController:
    """Design a lead-lag compensator meeting a phase margin at a crossover frequency.

    Parameters
    ----------
    plant : control.LTI
        Design plant, command (-1..1) to grip force (N).
    phase_margin_deg : float
        Target phase margin in degrees.
    crossover_rad_s : float
        Target gain crossover in rad/s.
    integral : bool
        Include the PI-lag ``(s + wl)/s`` (zero steady-state force error).
    lag_ratio : float
        ``wc / wl``.
    n_lead_stages : int
        Identical lead stages sharing the lead.
    max_stage_lead_deg : float
        Largest lead one stage may give (``beta`` grows fast beyond ~65 deg).
    implementation : Implementation, optional
        Control period in seconds (required for a continuous plant; default the
        plant's), whole samples of computation delay in the loop (default 1) and
        command saturation (default ``(-1, 1)``).

    Returns
    -------
    LinearController
        With ``report_``.

    Raises
    ------
    PlantError
        Unstable or non-minimal plant.
    SpecificationError
        If the lead needed exceeds ``n_lead_stages * max_stage_lead_deg``.
    """
    import control
    plant_report = check_plant(plant)
    impl = Implementation() if implementation is None else implementation
    dt = plant_dt(plant, impl.dt_s)
    computation_delay_samples = impl.computation_delay_samples
    wc = float(crossover_rad_s)
    theta, gain = required_controller_phase(
        plant, phase_margin_deg, wc, dt, computation_delay_samples
    )
    wl = wc / lag_ratio
    lag_phase = -np.rad2deg(np.arctan(wl / wc)) if integral else 0.0
    lead = theta - lag_phase
    per_stage = lead / n_lead_stages
    if abs(per_stage) > max_stage_lead_deg:
        kind = "lead" if per_stage > 0 else "lag"
        stages = "a single lead stage gives" if n_lead_stages == 1 else (
            f"{n_lead_stages} stages give")
        raise SpecificationError(
            f"phase margin {phase_margin_deg} deg at {wc} rad/s needs {abs(lead):.1f} deg of "
            f"{kind}; {stages} at most {n_lead_stages * max_stage_lead_deg:.0f} deg"
        )
    sin_phi = np.sin(np.deg2rad(per_stage))
    beta = (1.0 + sin_phi) / (1.0 - sin_phi)
    wz, wp = wc / np.sqrt(beta), wc * np.sqrt(beta)
    s = control.tf("s")
    shape = ((1 + s / wz) / (1 + s / wp)) ** n_lead_stages
    if integral:
        shape = shape * (s + wl) / s
    k = gain / np.abs(shape(1j * wc))
    c_cont = k * shape
    c_disc = control.c2d(c_cont, dt, method="tustin", prewarp_frequency=wc)
    controller = LinearController(
        c_disc, u_limits=impl.u_limits, computation_delay_samples=computation_delay_samples
    )
    notes = []
    if wp > 0.5 * np.pi / dt:
        notes.append(f"lead pole {wp:.4g} rad/s is above half the Nyquist frequency")
    controller.report_ = DesignReport(
        controller="lead_lag",
        spec={"phase_margin_deg": phase_margin_deg, "crossover_rad_s": wc,
              "integral": integral, "n_lead_stages": n_lead_stages,
              "computation_delay_samples": computation_delay_samples},
        parameters={"gain": float(k), "lead_per_stage_deg": float(per_stage),
                    "zero_rad_s": float(wz), "pole_rad_s": float(wp),
                    "integral_corner_rad_s": float(wl) if integral else 0.0, "dt_s": dt},
        plant=plant_report,
        margins=loop_margins(controller.loop(plant)),
        notes=notes,
    )
    return controller
