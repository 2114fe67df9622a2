"""The MPC's condensed quadratic program, built once per design, and its solvers.

Decision vector ``z = [U; s_lo; s_hi]``, shape (N + 2,): the N commands
``U = [u_0 .. u_(N-1)]`` and the two slacks of the force bounds (N). With the
prediction ``Y = Phi x0 + Gamma U`` (``Phi`` (N, nx), ``Gamma`` (N, N) lower
triangular Toeplitz of the Markov parameters) and the move operator ``D``
(``(D U)_k = u_k - u_(k-1)``, ``D`` (N, N) with ones on the diagonal and minus
ones below it, ``e1`` the first unit vector), the MPC's cost::

    q |Y - r 1|^2 + rho |D U - e1 u_prev|^2 + w (s_lo + s_hi + s_lo^2 + s_hi^2)

is, up to a constant, ``0.5 z' H z + f' z`` with::

    H = blkdiag(2 (q Gamma'Gamma + rho D'D), 2 w I_2)                 (constant)
    f = [2 q Gamma'(Phi x0 - r 1) - 2 rho D' e1 u_prev;  w 1_2]       (affine in p)

where ``p = [x0; u_prev; r]`` is the parameter vector, shape (nx + 2,). The
constraints, in DAQP's layout ``lower <= [I; A] z <= upper`` (the first N + 2
rows are simple bounds)::

    u_min <= u_k <= u_max,  0 <= s                       simple bounds (constant)
    -du_max + e1 u_prev <= D U <= du_max + e1 u_prev       N rate rows
    Gamma_c U + s_lo >= f_lo - Phi_c x0                   n_c slip rows
    Gamma_c U - s_hi <= f_hi - Phi_c x0                   n_c fragility rows

with ``Phi_c, Gamma_c`` the rows of the outputs the first move can still change
(those fixed by the computation delay are left out). Only ``f`` and the bound
vectors change from step to step; both are a few numpy operations on ``p``.

Fast path. Without constraints the optimum is ``U* = -H_uu^-1 f_u = K p`` and
``s = 0`` (the slacks' gradient ``w`` is positive). If ``U*`` satisfies every
constraint (amplitude, rate, and both force bounds with ``s = 0``), it
satisfies the KKT conditions of the constrained QP with all multipliers zero
except the slacks' bound multipliers ``w``, so it *is* the QP's solution
(unique: ``H`` is positive definite). The check is one (2 N + n_c, nx + 2)
matrix-vector product and two comparisons.

Solvers. :class:`DaqpSolver` calls DAQP (a dual active-set solver) directly on
a :class:`daqp.Model` set up once: per step only ``f`` and the bounds are
updated, and the model starts from the previous step's working set (warm start).
:class:`CasadiSolver` passes the same matrices to ``casadi.conic`` with osqp or
proxqp, warm-started with the shifted plan (the reference path).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import daqp
import numpy as np

#: Constraint violation (in the row's units: command, or N) beyond which a solver's
#: returned point is not accepted. The solvers' own tolerances are ~1e-6 (DAQP's
#: primal tolerance; osqp's eps_abs + eps_rel ``|Az|`` <= 3e-5 N on the force rows), and
#: a wrong move is off by orders of magnitude more.
FEASIBILITY_TOL = 1e-4

DAQP_EXITFLAGS = {-1: "infeasible", -2: "cycling", -3: "unbounded", -4: "iteration limit",
                  -5: "non-convex", -6: "overdetermined initial active set"}


def prediction_matrices(a: np.ndarray, b: np.ndarray, c: np.ndarray,
                        horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """``Y = Phi x0 + Gamma U`` for the outputs ``y_1 .. y_N``.

    Parameters
    ----------
    a, b, c : ndarray, shapes (nx, nx), (nx, 1), (1, nx)
        Discrete state-space model ``x+ = a x + b u, y = c x``.
    horizon : int
        N.

    Returns
    -------
    phi : ndarray, shape (N, nx)
    gamma : ndarray, shape (N, N)
        Lower-triangular Toeplitz matrix of the Markov parameters ``c a^k b``.
    """
    nx = a.shape[0]
    phi = np.zeros((horizon, nx))
    gamma = np.zeros((horizon, horizon))
    a_pow = np.eye(nx)
    markov = []
    for k in range(horizon):
        markov.append((c @ a_pow @ b).item())
        a_pow = a @ a_pow
        phi[k] = (c @ a_pow).ravel()
    for k in range(horizon):
        gamma[k, : k + 1] = markov[k::-1]
    return phi, gamma


@dataclass(frozen=True)
class QPWeights:
    """Weights of the condensed QP's cost.

    Attributes
    ----------
    q : float
        Output-error weight, per N^2.
    rho : float
        Move weight, per unit command^2.
    slack_weight : float
        w: linear and quadratic weight of force-bound violations (per N, per N^2).
    """

    q: float
    rho: float
    slack_weight: float


@dataclass
class QPData:
    """One step's QP: ``min 0.5 z'Hz + f'z`` s.t. ``lower <= [I; A] z <= upper``.

    Attributes
    ----------
    f : ndarray, shape (n,)
    lower, upper : ndarray, shape (n + m,)
        Simple bounds first (n rows), then the m rows of ``A``; infinite where absent.
    """

    f: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


class CondensedQP:
    """The MPC's condensed QP (see the module notes), built once per design.

    Parameters
    ----------
    a, b, c : ndarray, shapes (nx, nx), (nx, 1), (1, nx)
        Augmented prediction model (plant with delay and output disturbance).
    horizon : int
        N, control periods.
    weights : QPWeights
        Output-error, move and slack weights.
    u_limits : (float, float)
        Command amplitude limits.
    du_max : float
        Largest command change per period.

    Attributes
    ----------
    H : ndarray, shape (n, n)
        Hessian, n = N + 2.
    A : ndarray, shape (m, n)
        General constraint rows, m = N + 2 n_c.
    first_constrained_step : int
        Index (1-based) of the first output the force bounds apply to.
    gain : ndarray, shape (N, nx + 2)
        Unconstrained optimum ``U* = gain @ p``.
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, c: np.ndarray, *, horizon: int,
                 weights: QPWeights, u_limits: tuple[float, float], du_max: float) -> None:
        q, rho = weights.q, weights.rho
        n_h, nx = int(horizon), a.shape[0]
        phi, gamma = prediction_matrices(a, b, c, n_h)
        affected = np.nonzero(np.abs(gamma[:, 0]) > 1e-12 * np.abs(gamma).max())[0]
        self.first_constrained_step = int(affected[0]) + 1 if affected.size else 1
        rows = slice(self.first_constrained_step - 1, None)
        phi_c, gamma_c = phi[rows], gamma[rows]
        n_c = phi_c.shape[0]
        self.horizon, self.nx, self.n_c = n_h, nx, n_c
        self.n = n_h + 2
        self.m = n_h + 2 * n_c
        self.u_limits = (float(u_limits[0]), float(u_limits[1]))
        self.du_max = float(du_max)
        diff = np.eye(n_h) - np.eye(n_h, k=-1)
        e1 = np.eye(n_h)[:, 0]
        w = float(weights.slack_weight)

        h_uu = 2.0 * (q * gamma.T @ gamma + rho * diff.T @ diff)
        self.H = np.zeros((self.n, self.n))
        self.H[:n_h, :n_h] = h_uu
        self.H[n_h:, n_h:] = 2.0 * w * np.eye(2)
        # f = F p + f0 with p = [x0; u_prev; r]
        self.F = np.zeros((self.n, nx + 2))
        self.F[:n_h, :nx] = 2.0 * q * gamma.T @ phi
        self.F[:n_h, nx] = -2.0 * rho * diff.T @ e1
        self.F[:n_h, nx + 1] = -2.0 * q * gamma.T @ np.ones(n_h)
        self.f0 = np.r_[np.zeros(n_h), w, w]

        self.A = np.zeros((self.m, self.n))
        self.A[:n_h, :n_h] = diff
        self.A[n_h:n_h + n_c, :n_h] = gamma_c
        self.A[n_h:n_h + n_c, n_h] = 1.0
        self.A[n_h + n_c:, :n_h] = gamma_c
        self.A[n_h + n_c:, n_h + 1] = -1.0
        self.phi_c = phi_c
        # constant parts of the bounds; per-step entries are overwritten in ``data``
        lo_u, hi_u = self.u_limits
        self._lower0 = np.r_[np.full(n_h, lo_u), 0.0, 0.0, np.full(n_h, -du_max),
                             np.full(2 * n_c, -np.inf)]
        self._upper0 = np.r_[np.full(n_h, hi_u), np.inf, np.inf, np.full(n_h, du_max),
                             np.full(2 * n_c, np.inf)]
        self._rate0 = self.n  # row of the first move's rate constraint
        self._slip = slice(self.n + n_h, self.n + n_h + n_c)
        self._fragile = slice(self.n + n_h + n_c, self.n + self.m)

        # unconstrained optimum and the quantities the fast path checks, all linear in p
        self.gain = -np.linalg.solve(h_uu, self.F[:n_h])
        moves = diff @ self.gain
        moves[0, nx] -= 1.0
        outputs = gamma_c @ self.gain
        outputs[:, :nx] += phi_c
        self._check = np.vstack([self.gain, moves, outputs])
        self._check_lo = np.r_[np.full(n_h, lo_u), np.full(n_h, -du_max), np.full(n_c, -np.inf)]
        self._check_hi = np.r_[np.full(n_h, hi_u), np.full(n_h, du_max), np.full(n_c, np.inf)]
        self._outputs = slice(2 * n_h, 2 * n_h + n_c)
        self._z_fast = np.zeros(self.n)

    def data(self, p: np.ndarray, f_lo: float, f_hi: float) -> QPData:
        """The step's ``f`` and bounds for parameters ``p = [x0; u_prev; r]`` and force bounds.

        Parameters
        ----------
        p : ndarray, shape (nx + 2,)
        f_lo, f_hi : float
            Force bounds, N (``-inf`` / ``inf`` when absent).
        """
        lower = self._lower0.copy()
        upper = self._upper0.copy()
        u_prev = p[self.nx]
        lower[self._rate0] += u_prev
        upper[self._rate0] += u_prev
        free = self.phi_c @ p[: self.nx]
        lower[self._slip] = f_lo - free
        upper[self._fragile] = f_hi - free
        return QPData(f=self.F @ p + self.f0, lower=lower, upper=upper)

    def unconstrained_if_feasible(self, p: np.ndarray, f_lo: float,
                                  f_hi: float) -> np.ndarray | None:
        """The QP's solution ``z = [K p; 0; 0]`` if it satisfies every constraint, else ``None``.

        Exact: such a point meets the KKT conditions (see the module notes).
        Returns a view of an internal buffer (copy it to keep it past the next call).
        """
        v = self._check @ p
        lo, hi = self._check_lo, self._check_hi
        lo[self._outputs] = f_lo
        hi[self._outputs] = f_hi
        if not ((v >= lo).all() and (v <= hi).all()):
            return None
        z = self._z_fast
        z[: self.horizon] = v[: self.horizon]
        return z

    def violation(self, z: np.ndarray, data: QPData) -> float:
        """Largest constraint violation of a finite ``z`` in the rows' units (<= 0 if feasible).

        Parameters
        ----------
        z : ndarray, shape (n,)
            Finite point.
        data : QPData
            The step's bounds.
        """
        rows = np.concatenate([z, self.A @ z])
        return max((rows - data.upper).max(), (data.lower - rows).max())


class DaqpSolver:
    """DAQP on a :class:`daqp.Model` set up once; warm-started from the last working set.

    :meth:`daqp.Model.update` with ``f`` and the bounds only (no ``sense``) keeps
    the working set of the previous solve, so a step whose active constraints
    are those of the last one finishes in one or two iterations.
    """

    name = "daqp"

    def __init__(self, qp: CondensedQP) -> None:
        self.qp = qp
        self.model = daqp.Model()
        self._set_up = False
        self.last_iterations = 0

    def solve(self, data: QPData, guess: np.ndarray | None = None) -> tuple[np.ndarray, str]:
        """Solve; returns ``(z, reason)`` with ``reason == ""`` on success.

        ``guess`` is unused: the warm start is the previous working set.
        """
        if not self._set_up:
            flag, _ = self.model.setup(self.qp.H, data.f, self.qp.A, data.upper, data.lower)
            if flag < 0:
                return np.full(self.qp.n, np.nan), f"daqp: setup failed ({flag})"
            self._set_up = True
        else:
            self.model.update(f=data.f, bupper=data.upper, blower=data.lower)
        z, _, flag, info = self.model.solve()
        self.last_iterations = int(info["iterations"])
        if flag != 1:
            self._set_up = False  # a fresh setup (cold working set) next time
            return z, f"daqp: {DAQP_EXITFLAGS.get(flag, f'exit flag {flag}')}"
        return z, ""


def _casadi_options(solver: str) -> dict[str, Any]:
    common: dict[str, Any] = {"error_on_fail": False}  # failures are read from stats()
    if solver == "osqp":
        return {**common, "warm_start_primal": True,
                "osqp": {"verbose": False, "eps_abs": 1e-6, "eps_rel": 1e-6, "polish": True,
                         "max_iter": 4000}}
    return {**common, "proxqp": {"eps_abs": 1e-7}}


class CasadiSolver:
    """osqp or proxqp through ``casadi.conic`` on the same matrices, warm-started with a guess.

    Attributes
    ----------
    function : casadi.Function
        The conic solver (replaceable, e.g. by a wrapper in tests); its
        ``stats()`` give ``success`` and ``return_status``.
    """

    def __init__(self, qp: CondensedQP, solver: str) -> None:
        self.qp = qp
        self.name = solver
        self._h = ca.DM(qp.H)
        self._a = ca.DM(qp.A)
        self.function = ca.conic("grip_mpc", solver,
                                 {"h": self._h.sparsity(), "a": self._a.sparsity()},
                                 _casadi_options(solver))

    def solve(self, data: QPData, guess: np.ndarray | None = None) -> tuple[np.ndarray, str]:
        """Solve; returns ``(z, reason)`` with ``reason == ""`` on success."""
        n = self.qp.n
        sol = self.function(h=self._h, g=data.f, a=self._a,
                            lbx=data.lower[:n], ubx=data.upper[:n],
                            lba=data.lower[n:], uba=data.upper[n:],
                            x0=np.zeros(n) if guess is None else guess)
        stats = self.function.stats()
        z = np.asarray(sol["x"], float).ravel()
        if not stats.get("success", False):
            return z, f"{self.name}: {stats.get('return_status', 'failed')}"
        return z, ""


def make_solver(qp: CondensedQP, solver: str) -> DaqpSolver | CasadiSolver:
    """The solver object for a name in :data:`controllers.mpc.QP_SOLVERS`."""
    return DaqpSolver(qp) if solver == "daqp" else CasadiSolver(qp, solver)
