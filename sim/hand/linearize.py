"""Linear model of the grasp: motor command -> grip force, around a steady grasp.

Procedure (:func:`linearize_grasp`):

1. Bring :class:`sim.hand.grasp_env.GraspEnv` to a steady grasp of the object at
   the requested grip force (``GraspEnv.steady_grasp``).
2. ``mujoco.mjd_transitionFD`` gives one physics step ``x+ = A x + B u`` in
   MuJoCo's tangent space (``2 nv`` states: positions, velocities).
3. The grip-force reading is a nonlinear function of state and command (it
   comes out of the constraint solver): its gradient ``y = C x + D u`` is taken
   by centred finite differences of ``mj_forward`` (positions perturbed with
   ``mj_integratePos``, the solver warm start held fixed).
4. Lift to the control period (``n`` substeps, command held)::

       Ad = A^n,  Bd = sum_{i<n} A^i B,  Cd = C A^(n-1),  Dd = D + C sum_{i<n-1} A^i B

   because ``GraspEnv.step`` reports the contact forces of its last substep:
   ``y[k]`` belongs to ``u[k]`` (``Dd != 0``).
5. Reduce: an ordered real Schur form separates the asymptotically stable
   modes from the marginal ones (the free object's unit eigenvalues); the
   stable part is balanced and truncated by its Hankel singular values (square
   root method on the discrete Gramians); the marginal part keeps only its
   minimal (controllable and observable) realization, from the SVD of its
   Hankel matrix. Uncontrollable or unobservable modes have zero Hankel
   singular values and drop out of both.

The result is a ``control.StateSpace`` with ``dt`` = the control period, in
deviation variables: input ``u - u0`` (normalized command), output
``grip - y0`` (N).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np
import scipy.linalg as sla

from sim.hand.contact import read_contacts
from sim.hand.env_spec import GraspTask, HandSpec
from sim.hand.grasp_env import GraspEnv, WristSchedule

if TYPE_CHECKING:
    import control


@dataclass(frozen=True)
class LinearizationSettings:
    """How :func:`linearize_grasp` settles the grasp, differentiates and reduces.

    Attributes
    ----------
    settle_s : float
        Settling time of each grip correction before linearizing, s
        (:meth:`~sim.hand.grasp_env.GraspEnv.hold_grip`).
    eps : float
        Finite-difference step for ``mjd_transitionFD`` and the output gradient.
    hsv_rtol : float
        Relative Hankel singular value threshold of the truncation.
    """

    settle_s: float = 0.5
    eps: float = 1e-6
    hsv_rtol: float = 1e-4


@dataclass
class LinearGrasp:
    """A linearized grasp.

    Attributes
    ----------
    sys : control.StateSpace
        Reduced model, input ``u - u0``, output grip force ``- y0`` (N), ``dt`` set.
    u0 : float
        Motor command of the operating point.
    y0_n : float
        Grip force of the operating point, N.
    hankel_sv : ndarray, shape (n_stable,)
        Hankel singular values of the stable part (descending).
    n_full : int
        State dimension before reduction (``2 nv``).
    full : tuple of ndarray
        ``(Ad, Bd, Cd, Dd)`` before reduction (control period).
    env : GraspEnv
        The environment left at the operating point (for comparisons).
    """

    sys: control.StateSpace
    u0: float
    y0_n: float
    hankel_sv: np.ndarray
    n_full: int
    full: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    env: GraspEnv


def grip_force_gradient(model: mujoco.MjModel, data: mujoco.MjData, env: GraspEnv,
                        eps: float = 1e-6) -> tuple[np.ndarray, float]:
    """Finite-difference gradient of the grip-force reading.

    Parameters
    ----------
    model, data : the environment's model and data at the operating point.
    env : GraspEnv
        Supplies the ids and the reading.
    eps : float
        Perturbation (rad, m, rad/s, m/s, or command units).

    Returns
    -------
    C : ndarray, shape (1, 2 nv)
        d grip / d state (tangent space: ``dq`` then ``dv``), N per unit.
    D : float
        d grip / d command, N.
    """
    ids = env.ids
    scratch = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    warm = data.qacc_warmstart.copy()
    ctrl = data.ctrl.copy()
    qpos0 = data.qpos.copy()
    qvel0 = data.qvel.copy()
    nv = model.nv

    def reading(dq: np.ndarray | None = None, dv: np.ndarray | None = None,
                du: float = 0.0) -> float:
        mujoco.mj_setState(model, scratch, state, spec)
        scratch.qacc_warmstart[:] = warm
        if dq is not None:
            scratch.qpos[:] = qpos0
            mujoco.mj_integratePos(model, scratch.qpos, dq, 1.0)
        if dv is not None:
            scratch.qvel[:] = qvel0 + dv
        scratch.ctrl[:] = ctrl
        scratch.ctrl[ids.motor] += du
        mujoco.mj_forward(model, scratch)
        return read_contacts(model, scratch, ids).grip_force_n

    C = np.zeros((1, 2 * nv))
    e = np.zeros(nv)
    for i in range(nv):
        e[:] = 0.0
        e[i] = eps
        C[0, i] = (reading(dq=e) - reading(dq=-e)) / (2 * eps)
        C[0, nv + i] = (reading(dv=e) - reading(dv=-e)) / (2 * eps)
    D = (reading(du=eps) - reading(du=-eps)) / (2 * eps)
    return C, float(D)


def lift_to_period(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
                   n_substeps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Hold the command over ``n_substeps`` physics steps; see the module docstring.

    Returns
    -------
    Ad, Bd, Cd, Dd : ndarrays
        Control-period model whose output is read at the start of the last substep.
    """
    n = A.shape[0]
    power = np.eye(n)  # A^i
    acc = np.zeros_like(B)  # sum_{j<i} A^j B
    Cd = C
    Dd = D
    for i in range(n_substeps):
        if i == n_substeps - 1:
            Cd = C @ power
            Dd = D + C @ acc
        acc = acc + power @ B
        power = power @ A
    return power, acc, Cd, Dd


def reduce_model(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, *,
                 hsv_rtol: float = 1e-4, marginal_tol: float = 1e-6
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Drop marginal uncontrollable/unobservable modes and truncate the stable part.

    Parameters
    ----------
    A, B, C, D : ndarrays
        Discrete model, shapes (n, n), (n, m), (p, n), (p, m).
    hsv_rtol : float
        Keep stable balanced states whose Hankel singular value exceeds
        ``hsv_rtol`` times the largest.
    marginal_tol : float
        Eigenvalues with ``|lambda| >= 1 - marginal_tol`` are marginal.

    Returns
    -------
    Ar, Br, Cr, Dr : ndarrays
        Reduced model (stable part first).
    hsv : ndarray
        Hankel singular values of the stable part.
    """
    T, Z, sdim = sla.schur(A, output="real",
                           sort=lambda re, im: np.hypot(re, im) < 1.0 - marginal_tol)
    Bz, Cz = Z.T @ B, C @ Z
    T11, T12, T22 = T[:sdim, :sdim], T[:sdim, sdim:], T[sdim:, sdim:]
    # Block-diagonalize: with T11 X - X T22 = -T12, [[I, -X], [0, I]] decouples.
    X = sla.solve_sylvester(T11, -T22, -T12) if 0 < sdim < A.shape[0] else np.zeros(
        (sdim, A.shape[0] - sdim))
    B1 = Bz[:sdim] - X @ Bz[sdim:]
    B2 = Bz[sdim:]
    C1 = Cz[:, :sdim]
    C2 = Cz[:, :sdim] @ X + Cz[:, sdim:]

    blocks = []
    hsv = np.zeros(0)
    if sdim:
        Ar, Br, Cr, hsv = _balanced_truncation(T11, B1, C1, hsv_rtol)
        blocks.append((Ar, Br, Cr))
    if A.shape[0] - sdim:
        scale = hsv[0] if hsv.size else 1.0
        Am, Bm, Cm = _minimal_marginal(T22, B2, C2, hsv_rtol * scale)
        if Am.shape[0]:
            blocks.append((Am, Bm, Cm))
    if not blocks:
        return (np.zeros((0, 0)), np.zeros((0, B.shape[1])), np.zeros((C.shape[0], 0)),
                D.copy(), hsv)
    Ar = sla.block_diag(*[b[0] for b in blocks])
    Br = np.vstack([b[1] for b in blocks])
    Cr = np.hstack([b[2] for b in blocks])
    return Ar, Br, Cr, D.copy(), hsv


def _psd_factor(W: np.ndarray) -> np.ndarray:
    """A factor L with L L^T = W for a symmetric positive semidefinite W."""
    w, V = np.linalg.eigh(0.5 * (W + W.T))
    return V * np.sqrt(np.clip(w, 0.0, None))


def _balanced_truncation(A: np.ndarray, B: np.ndarray, C: np.ndarray, rtol: float
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    Wc = sla.solve_discrete_lyapunov(A, B @ B.T)
    Wo = sla.solve_discrete_lyapunov(A.T, C.T @ C)
    Lc, Lo = _psd_factor(Wc), _psd_factor(Wo)
    U, s, Vt = np.linalg.svd(Lo.T @ Lc)
    r = int(np.sum(s > rtol * s[0])) if s.size and s[0] > 0 else 0
    s_r = s[:r] ** -0.5
    Tl = (U[:, :r] * s_r).T @ Lo.T  # (r, n)
    Tr = Lc @ Vt[:r].T * s_r  # (n, r)
    return Tl @ A @ Tr, Tl @ B, C @ Tr, s


def _minimal_marginal(A: np.ndarray, B: np.ndarray, C: np.ndarray, atol: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = A.shape[0]
    Kc = np.hstack([np.linalg.matrix_power(A, i) @ B for i in range(n)])
    Ko = np.vstack([C @ np.linalg.matrix_power(A, i) for i in range(n)])
    U, s, Vt = np.linalg.svd(Ko @ Kc)
    r = int(np.sum(s > atol))
    if r == 0:
        return np.zeros((0, 0)), np.zeros((0, B.shape[1])), np.zeros((C.shape[0], 0))
    s_r = s[:r] ** -0.5
    Tl = (U[:, :r] * s_r).T @ Ko
    Tr = Kc @ Vt[:r].T * s_r
    return Tl @ A @ Tr, Tl @ B, C @ Tr


def linearize_grasp(object: Any = "ball", grip_force_n: float = 10.0, *,
                    lifted: bool = False, control_dt_s: float = 0.01, weightless: bool = False,
                    settings: LinearizationSettings | None = None, hand: HandSpec | None = None,
                    env_kwargs: dict[str, Any] | None = None) -> LinearGrasp:
    """Linear discrete model from motor command to grip force around a steady grasp.

    Parameters
    ----------
    object : ObjectSpec, str or dict
        The grasped object.
    grip_force_n : float
        Operating grip force, N.
    lifted : bool
        Linearize in the air (after the lift) instead of on the table.
    control_dt_s : float
        Control period, s.
    weightless : bool
        Cancel gravity on the object (MuJoCo's ``body_gravcomp``). A grip below
        the slip threshold cannot hold the object in the air, so there is no
        steady lifted grasp to linearize; the squeeze dynamics (pads, digits,
        drive) are those of the held object without its weight.
    settings : LinearizationSettings, optional
        Settling time, finite-difference step and truncation threshold (default
        ``LinearizationSettings()``).
    hand : HandSpec, optional
        The simulated hand, with its physics timestep (default ``HandSpec()``).
    env_kwargs : dict, optional
        Further :class:`~sim.hand.grasp_env.GraspEnv` arguments (default: the wrist
        lifts only when asked, ``wrist=WristSchedule(lift_after_s=inf)``, and a
        ``task`` of 1e4 s).

    Returns
    -------
    LinearGrasp
        ``sys`` maps ``u - u0`` to ``grip - y0`` with ``dt = control_dt_s``.
    """
    import control
    st = LinearizationSettings() if settings is None else settings
    kwargs = {"wrist": WristSchedule(lift_after_s=np.inf), "task": GraspTask(episode_s=1e4),
              **(env_kwargs or {})}
    env = GraspEnv(object, grip_force_n, control_dt_s=control_dt_s, hand=hand, **kwargs)
    env.reset(seed=0)
    if weightless:
        env.model.body_gravcomp[env.ids.object_body] = 1.0
    u0 = env.steady_grasp(grip_force_n, lifted=lifted, settle_s=st.settle_s)
    m, d = env.model, env.data
    y0 = read_contacts(m, d, env.ids).grip_force_n

    nx = 2 * m.nv + m.na
    A = np.zeros((nx, nx))
    B = np.zeros((nx, m.nu))
    mujoco.mjd_transitionFD(m, d, st.eps, True, A, B, None, None)
    B = B[:, [env.ids.motor]]
    C, D = grip_force_gradient(m, d, env, st.eps)
    Ad, Bd, Cd, Dd = lift_to_period(A, B, C, np.array([[D]]), env.n_substeps)
    Ar, Br, Cr, Dr, hsv = reduce_model(Ad, Bd, Cd, Dd, hsv_rtol=st.hsv_rtol)
    sys = control.ss(Ar, Br, Cr, Dr, control_dt_s, inputs=["motor_command"],
                     outputs=["grip_force_n"])
    return LinearGrasp(sys=sys, u0=u0, y0_n=y0, hankel_sv=hsv, n_full=nx,
                       full=(Ad, Bd, Cd, Dd), env=env)


def step_response_fit(y: np.ndarray, y_hat: np.ndarray) -> float:
    """How well a linear model's step response ``y_hat`` follows the simulated one ``y``.

    The NRMSE fit ``1 - ||y - y_hat|| / ||y - mean(y)||`` (1 is perfect), the
    same formula as the paper's eq. (20) that :func:`estimation.metrics.nrmse_fit`
    scores force estimates with. It is kept here, for the hand's linearizations
    and the controllers' design plants, because neither ``sim`` nor
    ``controllers`` may import ``estimation``; unlike that score it takes
    responses of any shape (flattened) and does not validate them.

    Parameters
    ----------
    y, y_hat : ndarray, shape (n_steps,) or (n_steps, 1)
        Simulated and modelled grip-force responses, N.
    """
    y = np.asarray(y, dtype=float).ravel()
    y_hat = np.asarray(y_hat, dtype=float).ravel()
    return float(1.0 - np.linalg.norm(y - y_hat) / np.linalg.norm(y - y.mean()))


def simulate_step(lin: LinearGrasp, du: float, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Nonlinear and linear responses to a command step ``du`` from the operating point.

    The nonlinear response is the difference between a run with ``u0 + du`` and
    a run with ``u0`` from the same saved state (so slow drift cancels).

    Returns
    -------
    y_nonlinear, y_linear : ndarray, shape (n_steps,)
        Grip-force deviation in N after each control step.
    """
    import control
    env = lin.env
    m, d = env.model, env.data
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    runs = []
    for u in (lin.u0 + du, lin.u0):
        mujoco.mj_setState(m, d, state, spec)
        action = np.array([u], dtype=np.float32)
        runs.append(np.array([env.step(action)[4]["grip_force_n"] for _ in range(n_steps)]))
    mujoco.mj_setState(m, d, state, spec)
    # float32 actions: use the command actually applied.
    du_applied = float(np.float32(lin.u0 + du)) - float(np.float32(lin.u0))
    t = np.arange(n_steps) * lin.sys.dt
    y_lin = control.forced_response(lin.sys, T=t, U=np.full(n_steps, du_applied)).outputs
    return runs[0] - runs[1], np.asarray(y_lin).ravel()
