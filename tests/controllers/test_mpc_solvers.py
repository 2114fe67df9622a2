"""The MPC's QP solvers agree: DAQP (direct), its unconstrained fast path, osqp and proxqp.

QPs are recorded from a closed loop of the MPC on the conftest grip plant with a
varying reference and force bounds that become active (slip bound 5.9 N,
fragility limit 12 N), so the set holds QPs with no, some and many active
constraints.

Tolerance. osqp runs with eps_abs = eps_rel = 1e-6 and solution polishing, DAQP
with primal tolerance 1e-6 on an exact active set; both answer in commands
(-1..1). The commands' sensitivity to the data is bounded by the plant's gain
(~100 N per unit), so 1e-5 in command is 1e-3 N of force: below the 0.2 N
noise of a force sensor and the 1e-3 N slack tolerance of the MPC itself. The
fast path and DAQP are the same exact optimum (a linear solve against an active
set solve), so they are compared at 1e-9.
"""

import copy

import control
import numpy as np
import pytest

from controllers import MPC, Implementation, MPCTuning, force_bounds
from controllers.qp import CasadiSolver, DaqpSolver
from controllers.schedule import ScheduledController

DT_S = 0.01
TOL_U = 1e-5


def _reference(k: int) -> float:
    return 8.0 + 6.0 * np.sin(2 * np.pi * 0.5 * k * DT_S) + (4.0 if (k // 150) % 2 else 0.0)


@pytest.fixture(scope="module")
def recorded():
    """(mpc, [(params, f_lo, f_hi)]) from 600 closed-loop steps with osqp."""
    s = control.tf("s")
    plant = control.c2d(100.0 / ((0.06 * s + 1) * (0.02 * s + 1)), DT_S)
    mpc = MPC(plant, solver="osqp", force_bounds=force_bounds(0.4, 0.5, fragility_limit_n=12.0))
    steps = []
    solve = mpc.solve

    def record(state, reference_n, **kw):
        f_lo, f_hi = mpc.bounds_for(reference_n)
        ref = float(np.clip(reference_n, f_lo, f_hi))
        steps.append((np.r_[state, mpc.last_u, ref], f_lo, f_hi))
        return solve(state, reference_n, **kw)

    mpc.solve = record
    ss = control.ss(plant)
    a, b, c = (np.asarray(m) for m in (ss.A, ss.B, ss.C))
    rng = np.random.default_rng(0)
    x, pending = np.zeros(a.shape[0]), 0.0
    for k in range(600):
        y = (c @ x).item() + 0.2 * rng.standard_normal()
        u = mpc.act({"time_s": k * DT_S, "reference_n": _reference(k), "grip_force_n": y})
        x = a @ x + b.ravel() * pending
        pending = u
    assert mpc.stats_.n_failures == 0
    return mpc, steps


def test_daqp_equals_osqp_and_proxqp_on_recorded_qps(recorded):
    mpc, steps = recorded
    qp = mpc.qp_
    daqp_solver = DaqpSolver(qp)  # warm-started along the sequence, as in the loop
    others = {name: CasadiSolver(qp, name) for name in ("osqp", "proxqp")}
    n_active = 0
    for p, f_lo, f_hi in steps:
        data = qp.data(p, f_lo, f_hi)
        z, reason = daqp_solver.solve(data)
        assert reason == ""
        assert qp.violation(z, data) <= 1e-6
        n_active += qp.unconstrained_if_feasible(p, f_lo, f_hi) is None
        for name, solver in others.items():
            z_ref, reason = solver.solve(data)
            assert reason == "", name
            assert z[: qp.horizon] == pytest.approx(z_ref[: qp.horizon], abs=TOL_U), name
    # the set exercises both cases: constraints active and none active
    assert 50 < n_active < len(steps) - 50


def test_fast_path_is_the_qp_solution_when_taken(recorded):
    mpc, steps = recorded
    qp = mpc.qp_
    solver = DaqpSolver(qp)
    taken = 0
    for p, f_lo, f_hi in steps:
        fast = qp.unconstrained_if_feasible(p, f_lo, f_hi)
        z, reason = solver.solve(qp.data(p, f_lo, f_hi))
        assert reason == ""
        if fast is not None:
            taken += 1
            assert fast == pytest.approx(z, abs=1e-9)
    assert taken > 50


def test_fast_path_refuses_a_violating_unconstrained_optimum(recorded):
    mpc, steps = recorded
    qp = mpc.qp_
    p, _, _ = next(s for s in steps if qp.unconstrained_if_feasible(*s) is not None)
    y_first = (qp._check @ p)[2 * qp.horizon]  # first constrained predicted force, N
    assert qp.unconstrained_if_feasible(p, y_first + 0.01, np.inf) is None  # slip bound
    assert qp.unconstrained_if_feasible(p, -np.inf, y_first - 0.01) is None  # fragility
    # a previous command far from the optimum: the first move u_0* - u_prev exceeds du_max
    tight = p.copy()
    for delta in np.linspace(0.0, 1.0, 101):
        tight[qp.nx] = p[qp.nx] + delta
        first_move = (qp.gain @ tight)[0] - tight[qp.nx]
        if abs(first_move) > qp.du_max:
            break
    assert abs(first_move) > qp.du_max
    assert qp.unconstrained_if_feasible(tight, -np.inf, np.inf) is None


def test_infeasible_qp_is_a_failure_not_a_wrong_move(plant):
    mpc = MPC(plant, implementation=Implementation(u_limits=(-1.0, 1.0)),
              tuning=MPCTuning(du_max=0.25))
    mpc._build_qp()
    p = np.r_[np.zeros(mpc.A_.shape[0]), 2.0, 5.0]  # previous command 2 > 1 + du_max
    data = mpc.qp_.data(p, -np.inf, np.inf)
    _, reason = DaqpSolver(mpc.qp_).solve(data)
    assert "infeasible" in reason
    # in the controller: counted, and the fallback (rate- then amplitude-clipped law) applied
    mpc.last_u = 2.0
    u = mpc.solve(np.zeros(mpc.A_.shape[0]), 5.0, time_s=0.3)
    assert mpc.stats_.n_failures == 1
    event = mpc.stats_.fallbacks[0]
    assert event.time_s == 0.3 and "daqp" in event.reason and "infeasible" in event.reason
    assert u == event.action and -1.0 <= u <= 1.0


def test_daqp_mpc_closed_loop_equals_osqp(recorded):
    # the same closed loop as the recording, run with daqp: the same commands
    _, steps = recorded
    s = control.tf("s")
    plant = control.c2d(100.0 / ((0.06 * s + 1) * (0.02 * s + 1)), DT_S)
    runs = {}
    for solver in ("daqp", "osqp"):
        mpc = MPC(plant, solver=solver,
                  force_bounds=force_bounds(0.4, 0.5, fragility_limit_n=12.0))
        ss = control.ss(plant)
        a, b, c = (np.asarray(m) for m in (ss.A, ss.B, ss.C))
        rng = np.random.default_rng(0)
        x, pending, us = np.zeros(a.shape[0]), 0.0, []
        for k in range(600):
            y = (c @ x).item() + 0.2 * rng.standard_normal()
            us.append(mpc.act({"time_s": k * DT_S, "reference_n": _reference(k),
                               "grip_force_n": y}))
            x = a @ x + b.ravel() * pending
            pending = us[-1]
        assert mpc.stats_.n_failures == 0
        runs[solver] = (np.array(us), mpc.stats_)
    assert runs["daqp"][0] == pytest.approx(runs["osqp"][0], abs=TOL_U)
    assert runs["daqp"][1].n_softened == runs["osqp"][1].n_softened
    assert 0 < runs["daqp"][1].n_fast < 600


def _bank(plant, gains):
    # every other design one order higher (an extra lag): the bank pads the smaller states
    lag = control.tf([0.5], [1.0, -0.5], DT_S)
    designs = [MPC(plant * g * (lag if i % 2 else 1)) for i, g in enumerate(gains)]
    return ScheduledController([10.0 * g for g in gains], designs, warm="all", name="mpc")


def test_bank_tracks_in_one_batch_as_each_design_would(plant):
    gains = (0.5, 1.0, 2.0, 4.0)
    batched = _bank(plant, gains)
    looped = _bank(plant, gains)
    looped._bank = None  # the design-by-design tracking
    assert batched._bank is not None
    assert len(set(batched._bank.sizes)) == 2
    rng = np.random.default_rng(3)
    for k in range(300):
        ref = 5.0 if k < 100 else (25.0 if k < 200 else 8.0)
        obs = {"time_s": k * DT_S, "reference_n": ref,
               "grip_force_n": ref * min(1.0, k / 50) + rng.normal(0, 0.3)}
        assert batched.act(obs) == pytest.approx(looped.act(obs), abs=1e-9)
        assert batched.index == looped.index
    assert batched.n_switches >= 2
    for d_b, d_l in zip(batched.designs, looped.designs, strict=True):
        assert d_b._xp == pytest.approx(d_l._xp, abs=1e-9)
        assert d_b.last_u == pytest.approx(d_l.last_u, abs=1e-12)


def test_bank_survives_a_copy(plant):
    bank = _bank(plant, (0.5, 1.0, 2.0))
    obs = {"time_s": 0.0, "reference_n": 5.0, "grip_force_n": 1.0}
    bank.act(obs)
    clone = copy.deepcopy(bank)  # the copy's design states are no longer views: rebound
    assert clone.act(obs) == pytest.approx(bank.act(obs), abs=1e-12)
    for d_c, d_b in zip(clone.designs, bank.designs, strict=True):
        assert d_c._xp == pytest.approx(d_b._xp, abs=1e-12)
        assert d_c._xp.base is clone._bank.states


@pytest.mark.slow
def test_episode_with_daqp_matches_osqp():
    """A scheduled MPC grasp and lift on the MuJoCo hand: same outcome, grip traces close."""
    from controllers.design import design_for_object
    from controllers.design_spec import DesignSpec
    from scenarios.runners.trial_loop import given_reference_trial
    from sim.hand.objects import make_object

    obj = make_object("can", mass_kg=0.3, friction=0.5)
    t = np.arange(500) * DT_S
    ref = np.where(t > 1.0, 6.0, 0.0)
    ref[t > 3.5] = 9.0
    results = {}
    for solver in ("daqp", "osqp"):
        design = design_for_object(obj, "mpc", DesignSpec(options={"solver": solver}),
                                   control_dt_s=DT_S)
        loop = given_reference_trial(obj, design, ref, control_dt_s=DT_S, lift_at_s=2.5)
        traces, info = loop.traces(), loop.info
        assert loop.failure is None
        assert all(d.solver == solver for d in design.core.designs)
        assert sum(d.stats_.n_failures for d in design.core.designs) == 0
        results[solver] = (traces, info)
    (tr_d, info_d), (tr_o, info_o) = results["daqp"], results["osqp"]
    assert not info_d["dropped"] and not info_o["dropped"]
    assert info_d["object_height_m"] > 0.1 and info_o["object_height_m"] > 0.1
    assert np.max(np.abs(tr_d["grip_force_n"] - tr_o["grip_force_n"])) <= 0.05
    held = (t > 3.0) & (t < 3.5)
    assert np.mean(tr_d["grip_force_n"][held]) == pytest.approx(6.0, abs=0.3)


def test_fast_path_gain_is_the_analytic_law(plant):
    # the fast path's first row and the law used for analysis and fallback are one law
    mpc = MPC(plant)
    mpc._build_qp()
    first = mpc.qp_.gain[0]
    nx = mpc.A_.shape[0]
    assert first[:nx] == pytest.approx(mpc.gain_state_, rel=1e-9, abs=1e-12)
    assert first[nx] == pytest.approx(mpc.gain_previous_, rel=1e-9)
    assert first[nx + 1] == pytest.approx(mpc.gain_reference_, rel=1e-9)
