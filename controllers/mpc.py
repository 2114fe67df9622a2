"""Slip-aware linear MPC of grip force, solved as a QP through CasADi (``qpsol``).

Prediction model: the sampled plant with its computation delay, augmented
with a constant output disturbance ``d`` (offset-free tracking)::

    x+ = A x + B u,   y = C x + d,   d+ = d

Each step minimizes over the horizon ``N``::

    sum_k q (y_k - r)^2 + rho (u_k - u_{k-1})^2  +  w (s_lo + s_hi + s_lo^2 + s_hi^2)

subject to ``u_min <= u_k <= u_max``, ``|u_k - u_{k-1}| <= du_max`` (hard) and
``f_min - s_lo <= y_k <= f_max + s_hi``, ``s >= 0`` (soft, exact L1 penalty: the
hard-bound solution whenever one exists), for the outputs ``y_k`` the first move
can still change (those fixed by the delay are not constrained). The problem is
condensed (``Y = Phi x0 + Gamma U``) and warm-started with the shifted plan.
``f_min`` is the slip bound (active while the reference asks to hold, ``r > 0``):
by default sensed online (:class:`controllers.bounds.SensedSlipBound`: the
load the digits carry and the slips felt, never the object's true mass or
friction); ``f_max`` is the user's force limit (a "fragile" setting; none by
default). A fixed :class:`~controllers.bounds.ForceBounds` can be given too. The
state is estimated by a steady-state Kalman filter.

A solve that fails (solver status, non-finite result) falls back to the
unconstrained law clipped to the amplitude and rate limits; every fallback is
recorded in :attr:`MPC.stats_`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import control
import numpy as np

from controllers.analysis import loop_margins
from controllers.base import COMMAND_LIMITS, Observation, as_observation
from controllers.bounds import ForceBounds, SensedSlipBound
from controllers.errors import PlantError, SpecificationError
from controllers.plant import check_plant, frequency_response, loop_plant, plant_dt
from controllers.report import DesignReport

QP_SOLVERS = ("osqp", "qrqp", "proxqp")
_SLACK_TOL_N = 1e-3


@dataclass(frozen=True)
class FallbackEvent:
    """One failed solve: when, why and what was applied instead."""

    time_s: float
    reason: str
    action: float


@dataclass
class MPCStats:
    """Counters of one run (reset by :meth:`MPC.reset`).

    Attributes
    ----------
    n_solves : int
        QP solves attempted.
    n_failures : int
        Solves that failed and used the fallback.
    n_softened : int
        Successful solves whose force bounds could not be met (slack above 1e-3 N).
    solve_times_s : list of float
        Wall time of every solve in seconds.
    fallbacks : list of FallbackEvent
    """

    n_solves: int = 0
    n_failures: int = 0
    n_softened: int = 0
    solve_times_s: list[float] = field(default_factory=list)
    fallbacks: list[FallbackEvent] = field(default_factory=list)


def _solver_options(solver: str) -> dict[str, Any]:
    common: dict[str, Any] = {"error_on_fail": False}  # failures are read from stats()
    if solver == "osqp":
        return {**common, "warm_start_primal": True,
                "osqp": {"verbose": False, "eps_abs": 1e-6, "eps_rel": 1e-6, "polish": True,
                         "max_iter": 4000}}
    if solver == "qrqp":
        return {**common, "print_iter": False, "print_header": False, "print_info": False}
    return {**common, "proxqp": {"eps_abs": 1e-7}}


class MPC:
    """Linear MPC of grip force with slip and fragility bounds.

    Parameters
    ----------
    plant : control.LTI
        Design plant, command (-1..1) to grip force (N), continuous or discrete.
    dt_s : float, optional
        Control period in seconds (required for a continuous plant).
    horizon : int
        Prediction horizon N in control periods.
    rate_weight : float
        ``rho / (q g^2)`` with ``g`` the plant's peak gain (N per unit command):
        the dimensionless price of command moves; larger is slower and more robust.
    force_bounds : ForceBounds, optional
        Slip and fragility bounds; ``None`` leaves force unconstrained.
    u_limits : (float, float)
        Command amplitude limits.
    du_max : float
        Largest command change per control period.
    solver : {"osqp", "qrqp", "proxqp"}
        CasADi conic plugin.
    computation_delay_samples : int
        Whole samples between measurement and actuation (part of the model).
    input_noise_std, disturbance_std_n, measurement_noise_std_n : float
        Kalman filter tuning: std of command noise (units), of the per-step
        output-disturbance increment (N) and of force measurement noise (N).
    slack_weight : float
        Linear and quadratic weight of force-bound violations (per N).
    slip_sensing : SensedSlipBound, optional
        Lower force bound from sensed load and slip (updated every step).
    force_max_n : float
        The user's force limit, N (``inf``: none).
    """

    name = "mpc"

    def __init__(
        self,
        plant: control.LTI,
        *,
        dt_s: float | None = None,
        horizon: int = 20,
        rate_weight: float = 0.05,
        force_bounds: ForceBounds | None = None,
        u_limits: tuple[float, float] = COMMAND_LIMITS,
        du_max: float = 0.25,
        solver: str = "osqp",
        computation_delay_samples: int = 1,
        input_noise_std: float = 0.02,
        disturbance_std_n: float = 0.5,
        measurement_noise_std_n: float = 0.5,
        slack_weight: float = 1e4,
        slip_sensing: SensedSlipBound | None = None,
        force_max_n: float = float("inf"),
    ) -> None:
        if solver not in QP_SOLVERS:
            raise SpecificationError(
                f"MPC: unknown QP solver {solver!r}; valid: {list(QP_SOLVERS)}"
            )
        if horizon < 1:
            raise SpecificationError(f"MPC: expected horizon >= 1, found {horizon}")
        if du_max <= 0:
            raise SpecificationError(f"MPC: expected du_max > 0, found {du_max}")
        self.plant_report_ = check_plant(plant)
        self.dt_s = plant_dt(plant, dt_s)
        self.horizon = int(horizon)
        self.rate_weight = float(rate_weight)
        self.force_bounds = force_bounds
        self.u_limits = (float(u_limits[0]), float(u_limits[1]))
        self.du_max = float(du_max)
        self.solver = solver
        self.computation_delay_samples = int(computation_delay_samples)
        self.slack_weight = float(slack_weight)
        self.slip_sensing = slip_sensing
        self.force_max_n = float(force_max_n)

        model = control.ss(loop_plant(plant, self.dt_s,
                                      computation_delay_samples=computation_delay_samples))
        if np.any(np.asarray(model.D) != 0):
            raise PlantError("MPC: expected a strictly proper sampled plant, found D != 0")
        a, b, c = (np.asarray(m, float) for m in (model.A, model.B, model.C))
        n = a.shape[0]
        self.A_ = np.block([[a, np.zeros((n, 1))], [np.zeros((1, n)), np.ones((1, 1))]])
        self.B_ = np.vstack([b, [[0.0]]])
        self.C_ = np.hstack([c, [[1.0]]])
        omega = np.geomspace(1e-3, np.pi / self.dt_s, 400)
        self.gain_scale_ = float(np.max(np.abs(frequency_response(model, omega))))
        self.q_ = 1.0
        self.rho_ = self.rate_weight * self.gain_scale_**2

        g = np.hstack([self.B_, np.vstack([np.zeros((n, 1)), [[1.0]]])])
        qn = np.diag([input_noise_std**2, disturbance_std_n**2])
        rn = np.array([[measurement_noise_std_n**2]])
        predictor_gain, p_prior, _ = control.dlqe(self.A_, g, self.C_, qn, rn)
        self.predictor_gain_ = np.asarray(predictor_gain, float)
        pc = p_prior @ self.C_.T
        self.filter_gain_ = (pc / (self.C_ @ pc + rn)).ravel()

        self._build_unconstrained_law()
        self._qp: Any = None  # built at the first solve: analysis needs only the law
        self.report_: DesignReport | None = None
        self.reset()

    # -- unconstrained law -------------------------------------------------
    def _prediction_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``Y = Phi x0 + Gamma U`` for outputs y_1..y_N, shapes (N, nx) and (N, N)."""
        n_h, nx = self.horizon, self.A_.shape[0]
        phi = np.zeros((n_h, nx))
        gamma = np.zeros((n_h, n_h))
        a_pow = np.eye(nx)
        markov = []
        for k in range(n_h):
            markov.append((self.C_ @ a_pow @ self.B_).item())
            a_pow = self.A_ @ a_pow
            phi[k] = (self.C_ @ a_pow).ravel()
        for k in range(n_h):
            gamma[k, : k + 1] = markov[k::-1]
        return phi, gamma

    def _build_unconstrained_law(self) -> None:
        n_h = self.horizon
        phi, gamma = self._prediction_matrices()
        diff = np.eye(n_h) - np.eye(n_h, k=-1)
        e1 = np.zeros(n_h)
        e1[0] = 1.0
        hessian = self.q_ * gamma.T @ gamma + self.rho_ * diff.T @ diff
        first = np.linalg.solve(hessian, np.eye(n_h)[:, 0])  # first row of H^-1 (symmetric)
        self.gain_state_ = -self.q_ * first @ gamma.T @ phi
        self.gain_reference_ = float(self.q_ * first @ gamma.T @ np.ones(n_h))
        self.gain_previous_ = float(self.rho_ * first @ diff.T @ e1)

    def unconstrained_action(self, state: np.ndarray, u_prev: float, reference_n: float) -> float:
        """First move of the unconstrained optimum, ``Kx x + Ku u_prev + Kr r``."""
        return float(self.gain_state_ @ state + self.gain_previous_ * u_prev
                     + self.gain_reference_ * reference_n)

    # -- QP ----------------------------------------------------------------
    def _build_qp(self) -> None:
        """Condensed QP in the moves only (``Y = Phi x0 + Gamma U`` substituted).

        Built with :func:`casadi.qpsol` rather than ``Opti.to_function``: the
        latter hides the solver status (its ``stats()`` are unavailable), and
        with ``error_on_fail`` it dumps the whole problem to the C++ stderr.
        """
        n_h, nx = self.horizon, self.A_.shape[0]
        phi, gamma = self._prediction_matrices()
        # outputs the first move can still change: skip the samples fixed by the delay
        affected = np.nonzero(np.abs(gamma[:, 0]) > 1e-12 * np.abs(gamma).max())[0]
        self.first_constrained_step_ = int(affected[0]) + 1 if affected.size else 1
        u = ca.MX.sym("u", n_h)
        s_lo = ca.MX.sym("s_lo")
        s_hi = ca.MX.sym("s_hi")
        x0 = ca.MX.sym("x0", nx)
        u_prev = ca.MX.sym("u_prev")
        ref = ca.MX.sym("ref")
        y = ca.DM(phi) @ x0 + ca.DM(gamma) @ u
        y_con = y[self.first_constrained_step_ - 1 :]
        moves = u - ca.vertcat(u_prev, u[:-1])
        cost = self.q_ * ca.sumsqr(y - ref) + self.rho_ * ca.sumsqr(moves)
        cost += self.slack_weight * (s_lo + s_hi + s_lo**2 + s_hi**2)
        n_con = y_con.shape[0]
        self._qp = ca.qpsol(
            "grip_mpc",
            self.solver,
            {
                "x": ca.vertcat(u, s_lo, s_hi),
                "p": ca.vertcat(x0, u_prev, ref),
                "f": cost,
                "g": ca.vertcat(moves, y_con + s_lo, y_con - s_hi),
            },
            _solver_options(self.solver),
        )
        self._lbx = np.concatenate([np.full(n_h, self.u_limits[0]), [0.0, 0.0]])
        self._ubx = np.concatenate([np.full(n_h, self.u_limits[1]), [np.inf, np.inf]])
        # force-bound rows get their bounds per solve (infinite when inactive)
        self._lbg = np.concatenate([np.full(n_h, -self.du_max), np.full(2 * n_con, -np.inf)])
        self._ubg = np.concatenate([np.full(n_h, self.du_max), np.full(2 * n_con, np.inf)])
        self._lower_rows = slice(n_h, n_h + n_con)
        self._upper_rows = slice(n_h + n_con, n_h + 2 * n_con)

    # -- controller interface ----------------------------------------------
    def reset(self, u0: float = 0.0) -> None:
        """Zero the state estimate and the plan; the previous command is ``u0``."""
        self._xp = np.zeros(self.A_.shape[0])
        self.last_u = float(np.clip(u0, *self.u_limits))
        self._u_guess = np.full(self.horizon, self.last_u)
        self.stats_ = MPCStats()
        self.last_slack_n = 0.0
        self.last_reference_n = 0.0
        if self.slip_sensing is not None:
            self.slip_sensing.reset()

    def stats(self) -> dict[str, float]:
        """Counters of the run since :meth:`reset`: QP ``n_solves``, ``n_failures``
        (fallbacks to the unconstrained law) and ``n_softened``."""
        return {"n_solves": self.stats_.n_solves, "n_failures": self.stats_.n_failures,
                "n_softened": self.stats_.n_softened}

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Take over at command ``u``: the state estimate is the steady state of ``u``.

        The plant states are set to their steady state under a constant ``u`` and
        the output disturbance to the measured force minus the plant's output, so
        the first prediction equals the measurement (no observer transient). Run
        statistics are kept.
        """
        obs = as_observation(observation)
        u = float(np.clip(u, *self.u_limits))
        n = self.A_.shape[0] - 1
        a, b, c = self.A_[:n, :n], self.B_[:n, 0], self.C_[0, :n]
        x = np.linalg.solve(np.eye(n) - a, b * u) if n else np.zeros(0)
        self._xp = np.concatenate([x, [obs.grip_force_n - float(c @ x)]])
        self.last_u = u
        self._u_guess = np.full(self.horizon, u)

    def bounds_for(self, reference_n: float) -> tuple[float, float]:
        """Force bounds (N) used for a reference: the slip bound applies only while holding."""
        low, high = -np.inf, self.force_max_n
        if self.force_bounds is not None:
            low, high = self.force_bounds.min_n, min(high, self.force_bounds.max_n)
        if self.slip_sensing is not None:
            low = max(low, self.slip_sensing.min_n)
        if not reference_n > 0:
            low = -np.inf
        return min(low, high), high

    def _fallback(self, state: np.ndarray, reference_n: float) -> float:
        """Unconstrained law clipped to the rate and amplitude limits (hold if undefined)."""
        u = self.unconstrained_action(state, self.last_u, reference_n)
        if not np.isfinite(u):
            return self.last_u
        u = float(np.clip(u, self.last_u - self.du_max, self.last_u + self.du_max))
        return float(np.clip(u, *self.u_limits))

    def solve(
        self, state: np.ndarray, reference_n: float, *, time_s: float = float("nan")
    ) -> float:
        """Solve the QP from an (augmented) state estimate; returns the first move.

        Parameters
        ----------
        state : ndarray, shape (n_states,)
            Augmented state ``[x; d]``.
        reference_n : float
            Force reference in N (clipped into the force bounds).
        time_s : float
            Recorded with a fallback.
        """
        if self._qp is None:
            self._build_qp()
        f_lo, f_hi = self.bounds_for(reference_n)
        ref = float(np.clip(reference_n, f_lo, f_hi))
        self.last_reference_n = ref
        self._lbg[self._lower_rows] = f_lo
        self._ubg[self._upper_rows] = f_hi
        self.stats_.n_solves += 1
        start = time.perf_counter()
        reason = ""
        params = np.concatenate([state, [self.last_u, ref]])
        guess = np.concatenate([self._u_guess, [0.0, 0.0]])
        if not np.all(np.isfinite(params)):
            reason = "non-finite state estimate or reference"
        else:
            sol = self._qp(x0=guess, p=params, lbx=self._lbx, ubx=self._ubx,
                           lbg=self._lbg, ubg=self._ubg)
            stats = self._qp.stats()
            z = np.asarray(sol["x"], float).ravel()
            u_opt, s_lo, s_hi = z[: self.horizon], z[-2], z[-1]
            if not stats.get("success", False):
                reason = f"{self.solver}: {stats.get('return_status', 'failed')}"
            elif not np.all(np.isfinite(z)):
                reason = f"{self.solver}: non-finite solution"
        self.stats_.solve_times_s.append(time.perf_counter() - start)
        if reason:
            u = self._fallback(state, ref)
            self.stats_.n_failures += 1
            self.stats_.fallbacks.append(FallbackEvent(time_s=float(time_s), reason=reason,
                                                       action=u))
            self._u_guess = np.full(self.horizon, u)
            return u
        slack = max(float(s_lo), float(s_hi))
        self.last_slack_n = slack
        if slack > _SLACK_TOL_N:
            self.stats_.n_softened += 1
        self._u_guess = np.concatenate([u_opt[1:], u_opt[-1:]])
        # project onto the hard limits: removes the solver's tolerance (~1e-6)
        u = min(max(u_opt[0], self.last_u - self.du_max), self.last_u + self.du_max)
        return float(np.clip(u, *self.u_limits))

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Estimate the state from the measured force, solve, and return the command."""
        return self._advance(as_observation(observation), None)

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Update the state estimate with a command applied by someone else (no solve)."""
        self._advance(as_observation(observation), float(np.clip(applied_u, *self.u_limits)))

    def _advance(self, obs: Observation, applied_u: float | None) -> float:
        if self.slip_sensing is not None and applied_u is None:
            # only the MPC in charge senses: a bank of designs shares one bound, and the
            # designs that merely track the applied command must not update it again
            self.slip_sensing.update(obs.grip_force_n, obs.lift_force_n, obs.slip_speed_m_s,
                                     obs.both_sides)
        innovation = obs.grip_force_n - (self.C_ @ self._xp).item()
        x_filt = self._xp + self.filter_gain_ * innovation
        if applied_u is None:
            u = self.solve(x_filt, obs.reference_n, time_s=obs.time_s)
        else:
            u = applied_u
        self._xp = self.A_ @ x_filt + self.B_.ravel() * u
        self.last_u = u
        return u

    # -- analysis ----------------------------------------------------------
    def feedback_law(self) -> control.StateSpace:
        """The unconstrained MPC with its Kalman filter as a linear controller ``C(z)``.

        ``u = -C(z) y + (reference terms)``, so ``C(z) P(z)`` is the loop
        transfer with the usual negative-feedback sign.
        """
        nx = self.A_.shape[0]
        m = self.filter_gain_.reshape(-1, 1)
        kx = self.gain_state_.reshape(1, -1)
        ku = self.gain_previous_
        i_mc = np.eye(nx) - m @ self.C_
        c_u = np.hstack([kx @ i_mc, [[ku]]])
        d_u = kx @ m
        b_next = np.vstack([self.B_, [[1.0]]])
        a_c = np.block([[self.A_ @ i_mc, np.zeros((nx, 1))], [np.zeros((1, nx + 1))]])
        a_c = a_c + b_next @ c_u
        b_c = np.vstack([self.A_ @ m, [[0.0]]]) + b_next @ d_u
        return control.ss(a_c, -b_c, c_u, -d_u, self.dt_s)

    def loop(self, plant: control.LTI) -> control.LTI:
        """Open loop ``C(z) P(z) z**-d`` of the unconstrained law."""
        return self.feedback_law() * loop_plant(
            plant, self.dt_s, computation_delay_samples=self.computation_delay_samples
        )


def design_mpc(plant: control.LTI, **kwargs: Any) -> MPC:
    """Build an :class:`MPC` and attach a design report with its unconstrained loop's margins.

    Keyword arguments are those of :class:`MPC`.
    """
    controller = MPC(plant, **kwargs)
    margins = loop_margins(controller.loop(plant))
    fb = controller.force_bounds
    controller.report_ = DesignReport(
        controller="mpc",
        spec={"horizon": controller.horizon, "rate_weight": controller.rate_weight,
              "du_max": controller.du_max, "solver": controller.solver,
              "force_min_n": None if fb is None else fb.min_n,
              "force_max_n": None if fb is None else fb.max_n,
              "slip_bound": "sensed" if controller.slip_sensing is not None else (
                  "fixed" if fb is not None else "none"),
              "user_force_max_n": None if not np.isfinite(controller.force_max_n)
              else controller.force_max_n,
              "computation_delay_samples": controller.computation_delay_samples},
        parameters={"q": controller.q_, "rho": controller.rho_,
                    "gain_reference": controller.gain_reference_,
                    "gain_previous": controller.gain_previous_, "dt_s": controller.dt_s},
        plant=controller.plant_report_,
        margins=margins,
        notes=["margins are those of the unconstrained law with its Kalman filter"],
    )
    return controller
