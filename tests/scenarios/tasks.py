"""Small real tasks for testing the sweep engine (imported by workers as ``tasks``).

Each takes a :class:`scenarios.schema.Scenario` and returns a flat result row
that depends only on the scenario (its seed and fields), as a real runner does.
"""

from __future__ import annotations

import time

import numpy as np

from scenarios.schema import Scenario

SLEEP_S = 0.15


def seeded(scenario: Scenario) -> dict:
    """Seeded draws plus a trace: the result is a pure function of the scenario."""
    rng = np.random.default_rng(scenario.seed)
    draws = rng.standard_normal(3)
    return {
        "draw": float(draws[0]),
        "draw_sum": float(draws.sum()),
        "mass_kg": scenario.object.mass_kg,
        "controller": scenario.controller.kind,
        "n_draws": np.int64(3),
        "traces": {"force_n": rng.standard_normal((50, 2))},
    }


def sleepy(scenario: Scenario) -> dict:
    """:func:`seeded` after sleeping :data:`SLEEP_S` seconds (for kill/resume tests)."""
    time.sleep(SLEEP_S)
    return seeded(scenario)


def heavy_fails(scenario: Scenario) -> dict:
    """:func:`seeded`, but raises for objects heavier than 1 kg."""
    mass_kg = scenario.object.mass_kg
    if mass_kg is not None and mass_kg > 1.0:
        raise ValueError(f"object of {mass_kg} kg slipped out of the hand")
    return seeded(scenario)


def returns_array(scenario: Scenario) -> dict:
    """Returns an array outside ``traces``: an invalid result row."""
    return {"force_n": np.zeros(3)}


def sleeps_past_limit(scenario: Scenario) -> dict:
    """:func:`seeded`, but objects heavier than 1 kg sleep a minute (past any test limit)."""
    mass_kg = scenario.object.mass_kg
    if mass_kg is not None and mass_kg > 1.0:
        time.sleep(60)
    return seeded(scenario)


def kills_itself(scenario: Scenario) -> dict:
    """:func:`seeded`, but objects heavier than 1 kg SIGKILL the process running them."""
    import os
    import signal

    mass_kg = scenario.object.mass_kg
    if mass_kg is not None and mass_kg > 1.0:
        os.kill(os.getpid(), signal.SIGKILL)
    return seeded(scenario)


def counted(scenario: Scenario) -> dict:
    """:func:`sleepy`, appending ``seed driver_pid`` to ``$GRIPLOOP_TEST_RUNS`` (count runs).

    With ``$GRIPLOOP_TEST_DRIVERS`` set to ``n``, waits (up to a minute) until ``n``
    drivers have each started a scenario, so that every one of them runs some
    however slowly the later ones start.
    """
    import os

    path = os.environ["GRIPLOOP_TEST_RUNS"]
    with open(path, "a") as fh:
        fh.write(f"{scenario.seed} {os.getppid()}\n")
    drivers = int(os.environ.get("GRIPLOOP_TEST_DRIVERS", "1"))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        with open(path) as fh:
            if len({line.split()[1] for line in fh if line.strip()}) >= drivers:
                break
        time.sleep(0.05)
    return sleepy(scenario)


def solves_qps(scenario: Scenario) -> dict:
    """:func:`seeded` after solving small OSQP problems (as the MPC does) for about a second.

    OSQP installs its own SIGINT handler while it solves: an interrupt that reaches
    this process turns into a solver failure, which the sweep must never store.
    """
    import casadi

    rng = np.random.default_rng(scenario.seed)
    n = 30
    m = rng.standard_normal((n, n))
    qp = {"x": casadi.SX.sym("x", n)}
    qp["f"] = 0.5 * casadi.dot(qp["x"], casadi.mtimes(casadi.DM(m @ m.T + n * np.eye(n)), qp["x"]))
    qp["g"] = qp["x"]
    solver = casadi.qpsol("s", "osqp", qp, {"error_on_fail": True, "osqp": {"verbose": False}})
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < 1.0:
        solver(lbg=-1.0, ubg=rng.uniform(0.5, 1.0, n))
    return seeded(scenario)


def signal_state(scenario: Scenario) -> dict:
    """How the process running the scenario would receive a terminal's Ctrl-C."""
    import os
    import signal

    return {"pgid": os.getpgid(0), "pid": os.getpid(),
            "sigint_ignored": signal.getsignal(signal.SIGINT) is signal.SIG_IGN}


def spawns_then_hangs(scenario: Scenario) -> dict:
    """Starts a ``sleep`` subprocess (pid to ``$GRIPLOOP_TEST_RUNS``), then sleeps a minute."""
    import os
    import subprocess

    proc = subprocess.Popen(["sleep", "120"])
    with open(os.environ["GRIPLOOP_TEST_RUNS"], "a") as fh:
        fh.write(f"{proc.pid}\n")
    time.sleep(60)
    return seeded(scenario)
