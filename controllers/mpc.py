"""Slip-aware linear MPC of grip force, a condensed QP solved by DAQP (or osqp/proxqp).

Prediction model: the sampled plant with its computation delay, augmented
with a constant output disturbance ``d`` (offset-free tracking)::

    x+ = A x + B u,   y = C x + d,   d+ = d

Each step minimizes over the horizon ``N``::

    sum_k q (y_k - r)^2 + rho (u_k - u_{k-1})^2  +  w (s_lo + s_hi + s_lo^2 + s_hi^2)

subject to ``u_min <= u_k <= u_max``, ``|u_k - u_{k-1}| <= du_max`` (hard) and
``f_min - s_lo <= y_k <= f_max + s_hi``, ``s >= 0`` (soft, exact L1 penalty: the
hard-bound solution whenever one exists), for the outputs ``y_k`` the first move
can still change (those fixed by the delay are not constrained). The problem is
condensed (``Y = Phi x0 + Gamma U``) once per design (:class:`controllers.qp.CondensedQP`:
the Hessian and constraint matrices are constant, the linear term and the bounds
affine in the state, previous command, reference and force bounds).

Solvers (``solver=``): ``"daqp"`` (default) first tries the unconstrained law
``U* = K p`` and keeps it when it meets every constraint (it is then the QP's
solution exactly), and otherwise calls DAQP directly, warm-started from the
previous step's working set; ``"osqp"`` and ``"proxqp"`` solve the same QP
through ``casadi.conic``, warm-started with the shifted plan (the reference).
``f_min`` is the slip bound (active while the reference asks to hold, ``r > 0``):
by default sensed online (:class:`controllers.bounds.SensedSlipBound`: the
load the digits carry and the slips felt, never the object's true mass or
friction); ``f_max`` is the user's force limit (a "fragile" setting; none by
default). A fixed :class:`~controllers.bounds.ForceBounds` can be given too. The
state is estimated by a steady-state Kalman filter.

A solve that fails (solver status, non-finite result, or a returned point
violating a constraint by more than :data:`controllers.qp.FEASIBILITY_TOL`:
an infeasible QP is a failure, never a silent move) falls back to the
unconstrained law clipped to the amplitude and rate limits; every fallback is
recorded in ``MPC.stats_``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from controllers.analysis import loop_margins
from controllers.base import Implementation, Observation, as_observation
from controllers.bounds import ForceBounds, SensedSlipBound
from controllers.errors import PlantError, SpecificationError
from controllers.plant import check_plant, frequency_response, loop_plant, plant_dt
from controllers.qp import (
    FEASIBILITY_TOL,
    CasadiSolver,
    CondensedQP,
    DaqpSolver,
    QPWeights,
    make_solver,
    prediction_matrices,
)
from controllers.report import DesignReport

if TYPE_CHECKING:
    import control

#: Selectable QP solvers: DAQP called directly (with the unconstrained fast path), or
#: osqp / proxqp through ``casadi.conic``. (qrqp was dropped: it failed 672 of 2000
#: closed-loop solves of this QP.)
QP_SOLVERS = ("daqp", "osqp", "proxqp")
_SLACK_TOL_N = 1e-3


@dataclass(frozen=True)
class FallbackEvent:
    """One failed solve: when, why and what was applied instead."""

    time_s: float
    reason: str
    action: float


@dataclass(frozen=True)
class MPCTuning:
    """The MPC's cost weights, move limit and Kalman filter noise model.

    Attributes
    ----------
    rate_weight : float
        ``rho / (q g^2)`` with ``g`` the plant's peak gain (N per unit command):
        the dimensionless price of command moves; larger is slower and more robust.
    du_max : float
        Largest command change per control period (normalized command).
    slack_weight : float
        Linear and quadratic weight of force-bound violations (per N).
    input_noise_std : float
        Kalman filter: std of command noise (normalized command).
    disturbance_std_n : float
        Kalman filter: std of the per-step output-disturbance increment, N.
    measurement_noise_std_n : float
        Kalman filter: std of force measurement noise, N.
    """

    rate_weight: float = 0.05
    du_max: float = 0.25
    slack_weight: float = 1e4
    input_noise_std: float = 0.02
    disturbance_std_n: float = 0.5
    measurement_noise_std_n: float = 0.5


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
    n_fast : int
        Solves answered by the unconstrained law (it met every constraint; daqp only).
    solve_times_s : list of float
        Wall time of every solve in seconds.
    fallbacks : list of FallbackEvent
    """

    n_solves: int = 0
    n_failures: int = 0
    n_softened: int = 0
    n_fast: int = 0
    solve_times_s: list[float] = field(default_factory=list)
    fallbacks: list[FallbackEvent] = field(default_factory=list)


class MPC:
    """Linear MPC of grip force with slip and fragility bounds.

    Parameters
    ----------
    plant : control.LTI
        Design plant, command (-1..1) to grip force (N), continuous or discrete.
    horizon : int
        Prediction horizon N in control periods.
    solver : {"daqp", "osqp", "proxqp"}
        QP solver: DAQP called directly after the unconstrained fast path
        (default), or osqp / proxqp through ``casadi.conic`` (reference).
    implementation : Implementation, optional
        Control period in seconds (required for a continuous plant; default the
        plant's), whole samples between measurement and actuation (part of the
        model; default 1) and command amplitude limits (default ``(-1, 1)``).
    force_bounds : ForceBounds, optional
        Slip and fragility bounds; ``None`` leaves force unconstrained.
    tuning : MPCTuning, optional
        Move price, move limit, slack weight and Kalman filter noise (default
        ``MPCTuning()``).
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
        horizon: int = 20,
        solver: str = "daqp",
        implementation: Implementation | None = None,
        force_bounds: ForceBounds | None = None,
        tuning: MPCTuning | None = None,
        slip_sensing: SensedSlipBound | None = None,
        force_max_n: float = float("inf"),
    ) -> None:
        import control
        impl = Implementation() if implementation is None else implementation
        tune = MPCTuning() if tuning is None else tuning
        u_limits, du_max = impl.u_limits, tune.du_max
        computation_delay_samples = impl.computation_delay_samples
        if solver not in QP_SOLVERS:
            raise SpecificationError(
                f"MPC: unknown QP solver {solver!r}; valid: {list(QP_SOLVERS)}"
            )
        if horizon < 1:
            raise SpecificationError(f"MPC: expected horizon >= 1, found {horizon}")
        if du_max <= 0:
            raise SpecificationError(f"MPC: expected du_max > 0, found {du_max}")
        self.plant_report_ = check_plant(plant)
        self.dt_s = plant_dt(plant, impl.dt_s)
        self.horizon = int(horizon)
        self.rate_weight = float(tune.rate_weight)
        self.force_bounds = force_bounds
        self.u_limits = (float(u_limits[0]), float(u_limits[1]))
        self.du_max = float(du_max)
        self.solver = solver
        self.computation_delay_samples = int(computation_delay_samples)
        self.slack_weight = float(tune.slack_weight)
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
        qn = np.diag([tune.input_noise_std**2, tune.disturbance_std_n**2])
        rn = np.array([[tune.measurement_noise_std_n**2]])
        predictor_gain, p_prior, _ = control.dlqe(self.A_, g, self.C_, qn, rn)
        self.predictor_gain_ = np.asarray(predictor_gain, float)
        pc = p_prior @ self.C_.T
        self.filter_gain_ = (pc / (self.C_ @ pc + rn)).ravel()

        self._build_unconstrained_law()
        # built at the first solve: analysis needs only the law
        self._qp: DaqpSolver | CasadiSolver | None = None
        self.report_: DesignReport | None = None
        # the predicted state, always written in place: an ObserverBank may hold it as a view
        self._xp = np.zeros(self.A_.shape[0])
        self.reset()

    # -- unconstrained law -------------------------------------------------
    def _prediction_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``Y = Phi x0 + Gamma U`` for outputs y_1..y_N, shapes (N, nx) and (N, N)."""
        return prediction_matrices(self.A_, self.B_, self.C_, self.horizon)

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
        """Condense the QP (:class:`controllers.qp.CondensedQP`) and set up its solver."""
        weights = QPWeights(q=self.q_, rho=self.rho_, slack_weight=self.slack_weight)
        self.qp_ = CondensedQP(self.A_, self.B_, self.C_, horizon=self.horizon, weights=weights,
                               u_limits=self.u_limits, du_max=self.du_max)
        self.first_constrained_step_ = self.qp_.first_constrained_step
        self._qp = make_solver(self.qp_, self.solver)
        self._params = np.zeros(self.A_.shape[0] + 2)

    def __getstate__(self) -> dict[str, Any]:
        """State for copy/pickle without the solver (DAQP's workspace cannot be copied).

        The solver is set up again at the next solve (a cold start).
        """
        state = self.__dict__.copy()
        state["_qp"] = None
        return state

    # -- controller interface ----------------------------------------------
    def reset(self, u0: float = 0.0) -> None:
        """Zero the state estimate and the plan; the previous command is ``u0``."""
        self._xp[:] = 0.0
        self.last_u = float(np.clip(u0, *self.u_limits))
        self._u_guess = np.full(self.horizon, self.last_u)
        self.stats_ = MPCStats()
        self.last_slack_n = 0.0
        self.last_reference_n = 0.0
        if self.slip_sensing is not None:
            self.slip_sensing.reset()

    def stats(self) -> dict[str, float]:
        """Counters of the run since :meth:`reset`: QP ``n_solves``, ``n_failures``
        (fallbacks to the unconstrained law), ``n_softened`` and ``n_fast`` (steps
        answered by the checked unconstrained law)."""
        return {"n_solves": self.stats_.n_solves, "n_failures": self.stats_.n_failures,
                "n_softened": self.stats_.n_softened, "n_fast": self.stats_.n_fast}

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
        self._xp[:n] = x
        self._xp[n] = obs.grip_force_n - float(c @ x)
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
        ref = min(max(float(reference_n), f_lo), f_hi)  # NaN stays NaN (reference first)
        self.last_reference_n = ref
        self.stats_.n_solves += 1
        start = time.perf_counter()
        reason = ""
        params = self._params
        nx = params.size - 2
        params[:nx] = state
        params[nx] = self.last_u
        params[nx + 1] = ref
        z: np.ndarray | None = None
        if not math.isfinite(params.sum()):
            reason = "non-finite state estimate or reference"
        else:
            if self.solver == "daqp":
                z = self.qp_.unconstrained_if_feasible(params, f_lo, f_hi)
            if z is not None:
                self.stats_.n_fast += 1
            else:
                data = self.qp_.data(params, f_lo, f_hi)
                guess = None if self.solver == "daqp" else np.r_[self._u_guess, 0.0, 0.0]
                z, reason = self._qp.solve(data, guess)
                if not reason and not math.isfinite(z.sum()):
                    reason = f"{self.solver}: non-finite solution"
                elif not reason and self.qp_.violation(z, data) > FEASIBILITY_TOL:
                    reason = f"{self.solver}: returned an infeasible point"
            u_opt, s_lo, s_hi = z[: self.horizon], z[-2], z[-1]
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
        u = min(max(float(u_opt[0]), self.last_u - self.du_max), self.last_u + self.du_max)
        return min(max(u, self.u_limits[0]), self.u_limits[1])

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Estimate the state from the measured force, solve, and return the command."""
        return self._advance(as_observation(observation), None)

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Update the state estimate with a command applied by someone else (no solve)."""
        lo, hi = self.u_limits
        self._advance(as_observation(observation), min(max(float(applied_u), lo), hi))

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
        self._xp[:] = self.A_ @ x_filt + self.B_.ravel() * u
        self.last_u = u
        return u

    @staticmethod
    def observer_bank(designs: Sequence[Any]) -> ObserverBank | None:
        """An :class:`ObserverBank` over ``designs`` if they can be batched, else ``None``."""
        return ObserverBank.for_designs(designs)

    # -- analysis ----------------------------------------------------------
    def feedback_law(self) -> control.StateSpace:
        """The unconstrained MPC with its Kalman filter as a linear controller ``C(z)``.

        ``u = -C(z) y + (reference terms)``, so ``C(z) P(z)`` is the loop
        transfer with the usual negative-feedback sign.
        """
        import control
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


class ObserverBank:
    """The Kalman filters of a bank of MPC designs, updated in one numpy operation.

    A gain-scheduled MPC keeps every banked design's filter conditioned on the
    applied command (:meth:`MPC.track`), so that any of them takes over
    converged. Doing that design by design costs about 5 us each (20 designs:
    0.1 ms a step); here the predicted states of all designs are the rows of one
    array, shape (n_designs, nx_max), and each design's ``_xp`` is a view of
    its row's first ``nx_i`` entries, so one batched update serves all of them
    and a design that takes over simply continues from its row. Designs of
    fewer states (the plant's order changes over force) are padded with zero
    rows and columns of ``A_i`` and zero ``B_i, C_i, L_i``: the padding states
    stay zero and do not touch the others. For design ``i``::

        e_i  = y - C_i xp_i
        xp_i = A_i (xp_i + L_i e_i) + B_i clip(u)

    which is :meth:`MPC.track` exactly (same operations, batched).

    Parameters
    ----------
    designs : sequence of MPC
        Same command limits.
    """

    def __init__(self, designs: Sequence[MPC]) -> None:
        self.designs = list(designs)
        self.sizes = [d.A_.shape[0] for d in self.designs]
        k, nx = len(self.designs), max(self.sizes)
        self.A = np.zeros((k, nx, nx))
        self.B, self.C, self.L = (np.zeros((k, nx)) for _ in range(3))
        for j, (d, n) in enumerate(zip(self.designs, self.sizes, strict=True)):
            self.A[j, :n, :n] = d.A_
            self.B[j, :n] = d.B_.ravel()
            self.C[j, :n] = d.C_.ravel()
            self.L[j, :n] = d.filter_gain_
        self.u_limits = self.designs[0].u_limits
        self.states = np.zeros((k, nx))
        self.bind()

    @classmethod
    def for_designs(cls, designs: Sequence[Any]) -> ObserverBank | None:
        """A bank if every design is an MPC and all have the same command limits."""
        if not designs or not all(isinstance(d, MPC) for d in designs):
            return None
        if any(d.u_limits != designs[0].u_limits for d in designs):
            return None
        return cls(designs)

    def bind(self) -> None:
        """Make each design's state a view of its row (after a copy or unpickling broke it)."""
        states = np.zeros_like(self.states)
        for j, (d, n) in enumerate(zip(self.designs, self.sizes, strict=True)):
            states[j, :n] = d._xp
            d._xp = states[j, :n]
        self.states = states

    def track(self, grip_force_n: float, applied_u: float, *, skip: int | None = None) -> None:
        """Update every design's filter with the measured force and the applied command.

        Parameters
        ----------
        grip_force_n : float
            Measured grip force, N.
        applied_u : float
            The command applied this step (clipped into the designs' limits).
        skip : int, optional
            A design left untouched (the active one, which updated itself in ``act``).
        """
        states = self.states
        if self.designs[0]._xp.base is not states:  # a copy or unpickling (all at once)
            self.bind()
            states = self.states
        u = min(max(float(applied_u), self.u_limits[0]), self.u_limits[1])
        kept = states[skip].copy() if skip is not None else None
        innovation = grip_force_n - np.einsum("ij,ij->i", self.C, states)
        filtered = states + self.L * innovation[:, None]
        np.einsum("ijk,ik->ij", self.A, filtered, out=states)
        states += self.B * u
        if kept is not None:
            states[skip] = kept
        for d in self.designs:  # the skipped (active) design applied this very command
            d.last_u = u


def solver_note(solver: str) -> str:
    """One line naming how the MPC's QP is solved (for design reports)."""
    if solver == "daqp":
        return ("QP: condensed once per design, solved each step by the unconstrained law when "
                "it meets every constraint, else by DAQP (dual active set, called directly, "
                "warm-started from the last working set)")
    return f"QP: condensed once per design, solved each step by {solver} through casadi.conic"


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
        notes=["margins are those of the unconstrained law with its Kalman filter",
               solver_note(controller.solver)],
    )
    return controller
