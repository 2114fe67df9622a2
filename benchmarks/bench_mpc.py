"""MPC step time at horizon 20 on QPs recorded from a MuJoCo grasp: daqp against osqp and proxqp.

Goals: MPC step median <= 0.05 ms and p99 <= 0.5 ms, the reference
being osqp through ``casadi.conic`` measured in the same run.

1. Record. A scheduled MPC (the library design for a 0.3 kg can at friction 0.5,
   user force limit 10 N) grasps, lifts and holds the can on the MuJoCo hand for
   ``EPISODE_S`` with a reference that steps and swings from below the slip
   bound to above the force limit, so both force bounds become active. Every
   call the contact gate makes on the scheduled bank (``act``, ``track``,
   ``handover``) is recorded with its observation, and every QP solved (design,
   parameters ``p = [x0; u_prev; r]``, force bounds).
2. MPC step. The recorded calls are replayed on a fresh bank with each solver
   (same observations; the commands differ by the solvers' tolerances only),
   timing each ``act`` (Kalman filter, slip bound, schedule, QP, bank tracking)
   and each QP solve inside it (``MPC.stats_.solve_times_s``: vectors + solve).
3. Bare solve. Each recorded QP's vectors are built once, then each solver is
   timed on them in sequence (DAQP warm-started from the previous working set).

Each call is timed alone with ``time.perf_counter`` (median and p99 of the
per-call times; the first call of each solver, its setup, is excluded).

Run: .venv/bin/python benchmarks/bench_mpc.py
"""

from __future__ import annotations

import platform
import sys
import time
from importlib import metadata
from pathlib import Path

import daqp
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

from controllers.design import design_for_object  # noqa: E402
from controllers.design_spec import DesignSpec  # noqa: E402
from controllers.mpc import MPC  # noqa: E402
from controllers.qp import CasadiSolver, DaqpSolver  # noqa: E402
from scenarios.runners.trial_loop import given_reference_trial  # noqa: E402
from sim.hand.objects import make_object  # noqa: E402

DT_S = 0.01
EPISODE_S = 30.0
LIFT_AFTER_S = 2.5
FORCE_MAX_N = 10.0
SOLVERS = ("daqp", "osqp", "proxqp")
GOAL_MEDIAN_MS = 0.05
GOAL_P99_MS = 0.5


def reference(t: np.ndarray) -> np.ndarray:
    """Steps and a swing from 2 N (below the slip bound) to 14 N (above the 10 N limit)."""
    r = 6.0 + 4.0 * np.sin(2 * np.pi * 0.2 * t) + np.where((t // 4.0) % 2 == 1, 4.0, -2.0)
    r = np.clip(r, 2.0, 14.0)
    return np.where(t > 1.0, r, 0.0)


def design(solver: str):
    """The library's scheduled MPC for the can, every banked design with ``solver``."""
    obj = make_object("can", mass_kg=0.3, friction=0.5)
    d = design_for_object(obj, "mpc", DesignSpec(force_max_n=FORCE_MAX_N), control_dt_s=DT_S)
    for mpc in d.core.designs:
        mpc.solver = solver
        mpc._qp = None  # set up again, with this solver, at the first solve
    return obj, d


def record() -> tuple[list[tuple[str, object, tuple]], list[tuple[MPC, np.ndarray, float, float]],
                      dict]:
    """Run the episode with daqp; returns the bank's calls, the QPs solved and the last info."""
    obj, d = design("daqp")
    core = d.core
    calls: list[tuple[str, object, tuple]] = []
    qps: list[tuple[MPC, np.ndarray, float, float]] = []
    for name in ("act", "track", "handover"):
        method = getattr(core, name)

        def hooked(obs, *args, _name=name, _method=method):
            calls.append((_name, obs, args))
            return _method(obs, *args)

        setattr(core, name, hooked)
    for mpc in core.designs:
        solve = mpc.solve

        def recorded_solve(state, reference_n, *, _mpc=mpc, _solve=solve, **kw):
            f_lo, f_hi = _mpc.bounds_for(reference_n)
            ref = float(np.clip(reference_n, f_lo, f_hi))
            qps.append((_mpc, np.r_[state, _mpc.last_u, ref], f_lo, f_hi))
            return _solve(state, reference_n, **kw)

        mpc.solve = recorded_solve
    t = np.arange(int(EPISODE_S / DT_S)) * DT_S
    loop = given_reference_trial(obj, d, reference(t), control_dt_s=DT_S,
                                 lift_at_s=LIFT_AFTER_S)
    info = {**loop.info, "failure": loop.failure, "n_designs": len(core.designs)}
    return calls, qps, info


def replay(calls, solver: str, *, batched: bool = True) -> dict[str, np.ndarray | int]:
    """Replay the recorded calls on a fresh bank; per-``act`` and per-solve times (ms)."""
    _, d = design(solver)
    core = d.core
    if not batched:
        core._bank = None
    core.reset()
    act_ms = []
    for name, obs, args in calls:
        if name == "act":
            start = time.perf_counter()
            core.act(obs)
            act_ms.append((time.perf_counter() - start) * 1e3)
        else:
            getattr(core, name)(obs, *args)
    solve_ms = np.concatenate([np.asarray(m.stats_.solve_times_s[1:]) * 1e3
                               for m in core.designs if len(m.stats_.solve_times_s) > 1])
    return {"act_ms": np.asarray(act_ms[1:]), "solve_ms": solve_ms,
            "failures": sum(m.stats_.n_failures for m in core.designs),
            "fast": sum(m.stats_.n_fast for m in core.designs),
            "solves": sum(m.stats_.n_solves for m in core.designs)}


def bare(qps, solver: str) -> tuple[np.ndarray, np.ndarray, int]:
    """Time each recorded QP's solve alone (ms); returns times, first moves and failures."""
    solvers: dict[int, DaqpSolver | CasadiSolver] = {}
    times, moves, failures = [], [], 0
    for mpc, p, f_lo, f_hi in qps:
        qp = mpc.qp_
        data = qp.data(p, f_lo, f_hi)
        key = id(mpc)
        if key not in solvers:
            solvers[key] = DaqpSolver(qp) if solver == "daqp" else CasadiSolver(qp, solver)
        start = time.perf_counter()
        z, reason = solvers[key].solve(data)
        times.append((time.perf_counter() - start) * 1e3)
        moves.append(z[0])
        failures += bool(reason)
    return np.asarray(times[1:]), np.asarray(moves), failures


def cold_iterations(qps) -> tuple[float, float]:
    """Mean DAQP iterations warm (working set kept) and cold (``daqp.solve``) on the QPs."""
    warm, cold = [], []
    solvers: dict[int, DaqpSolver] = {}
    for mpc, p, f_lo, f_hi in qps:
        qp = mpc.qp_
        data = qp.data(p, f_lo, f_hi)
        s = solvers.setdefault(id(mpc), DaqpSolver(qp))
        s.solve(data)
        warm.append(s.last_iterations)
        *_, info = daqp.solve(qp.H, data.f, qp.A, data.upper, data.lower)
        cold.append(info["iterations"])
    return float(np.mean(warm)), float(np.mean(cold))


def _stats(ms: np.ndarray) -> tuple[float, float, float]:
    return float(np.median(ms)), float(np.percentile(ms, 99)), float(ms.max())


def main() -> int:
    print(f"command: {sys.executable} {' '.join(sys.argv)}")
    print(f"machine: {platform.machine()} {platform.processor() or ''} python "
          f"{platform.python_version()} daqp {metadata.version('daqp')}")
    start = time.perf_counter()
    calls, qps, info = record()
    n_act = sum(name == "act" for name, _, _ in calls)
    print(f"recorded: {EPISODE_S:g} s scheduled-MPC episode on the MuJoCo hand in "
          f"{time.perf_counter() - start:.1f} s: {len(calls)} bank calls ({n_act} act), "
          f"{len(qps)} QPs over {len({id(m) for m, *_ in qps})} designs; held: "
          f"{not info['dropped'] and info['object_height_m'] > 0.1}, failure: {info['failure']}")
    qp0 = qps[0][0].qp_
    print(f"QP: {qp0.n} variables, {qp0.m} constraint rows + {qp0.n} bounds, horizon "
          f"{qp0.horizon}")

    print("\nMPC step (replayed calls, per act and per QP inside it), ms")
    print(f"{'solver':14s} {'act med':>8s} {'act p99':>8s} {'act max':>8s} {'QP med':>8s} "
          f"{'QP p99':>8s} {'QP max':>8s} {'fast':>6s} {'failed':>6s}")
    steps = {}
    for solver in SOLVERS:
        r = replay(calls, solver)
        steps[solver] = r
        a, s = _stats(r["act_ms"]), _stats(r["solve_ms"])
        print(f"{solver:14s} {a[0]:8.4f} {a[1]:8.4f} {a[2]:8.3f} {s[0]:8.4f} {s[1]:8.4f} "
              f"{s[2]:8.3f} {r['fast']:6d} {r['failures']:6d}")
    loop = replay(calls, "daqp", batched=False)
    a = _stats(loop["act_ms"])
    print(f"{'daqp, no batch':14s} {a[0]:8.4f} {a[1]:8.4f} {a[2]:8.3f}   (bank observers "
          f"tracked design by design)")

    print("\nbare solve on the recorded QPs (vectors built beforehand), ms")
    print(f"{'solver':14s} {'median':>8s} {'p99':>8s} {'max':>8s} {'failed':>6s} "
          f"{'max |du0 - osqp|':>17s}")
    moves = {}
    bare_stats = {}
    for solver in SOLVERS:
        t_ms, moves[solver], failed = bare(qps, solver)
        bare_stats[solver] = (*_stats(t_ms), failed)
    for solver in SOLVERS:
        med, p99, mx, failed = bare_stats[solver]
        diff = float(np.max(np.abs(moves[solver] - moves["osqp"])))
        print(f"{solver:14s} {med:8.4f} {p99:8.4f} {mx:8.3f} {failed:6d} {diff:17.2e}")
    warm, cold = cold_iterations(qps)
    print(f"DAQP iterations per QP: {warm:.2f} warm-started, {cold:.2f} cold")

    ok = True
    osqp_step, osqp_act = _stats(steps["osqp"]["solve_ms"]), _stats(steps["osqp"]["act_ms"])
    daqp_step, daqp_act = _stats(steps["daqp"]["solve_ms"]), _stats(steps["daqp"]["act_ms"])
    print()
    ok &= goal_line("MPC QP step median <= 0.05 ms (daqp, horizon 20)", daqp_step[0], "ms",
                    limit=GOAL_MEDIAN_MS, reference=f"osqp {osqp_step[0]:.3f} ms")
    ok &= goal_line("MPC QP step p99 <= 0.5 ms (daqp, horizon 20)", daqp_step[1], "ms",
                    limit=GOAL_P99_MS, reference=f"osqp {osqp_step[1]:.3f} ms")
    ok &= goal_line(f"scheduled MPC act median <= 0.05 ms (daqp, bank of {info['n_designs']})",
                    daqp_act[0], "ms", limit=GOAL_MEDIAN_MS,
                    reference=f"osqp {osqp_act[0]:.3f} ms")
    ok &= goal_line("scheduled MPC act p99 <= 0.5 ms (daqp)", daqp_act[1], "ms",
                    limit=GOAL_P99_MS, reference=f"osqp {osqp_act[1]:.3f} ms")
    return 1 if steps["daqp"]["failures"] else 0  # goals are reported, failures fail


if __name__ == "__main__":
    sys.exit(main())
