"""Speed of the MuJoCo hand: raw ``mj_step`` versus ``GraspEnv.step``.

Both run the same model (hand + object + table) in the same held grasp, with
the same number of physics substeps per control period; the environment's
overhead (contact reading, outcomes, reward, observation, info) must stay
within 25 % of raw stepping.

It also measures creep (the slow slide of a held object) of a 0.2 kg box,
mu = 1, squeezed with 5 N per pad by the reference pinch, for each friction
setting: the numbers behind the contact-physics choice in docs/HAND.md.

Run: ``.venv/bin/python benchmarks/bench_hand.py [--object can] [--steps 2000]``
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import mujoco
import numpy as np

from sim.hand.grasp_env import GraspEnv
from sim.hand.model import build_pinch_model
from sim.hand.objects import make_object

FRICTION_SETTINGS = (
    ("pyramidal, impratio 1", mujoco.mjtCone.mjCONE_PYRAMIDAL, 1.0, 0),
    ("elliptic, impratio 1", mujoco.mjtCone.mjCONE_ELLIPTIC, 1.0, 0),
    ("elliptic, impratio 10", mujoco.mjtCone.mjCONE_ELLIPTIC, 10.0, 0),
    ("elliptic, impratio 10, noslip 5 (used)", mujoco.mjtCone.mjCONE_ELLIPTIC, 10.0, 5),
)


def measure_creep(cone: int, impratio: float, noslip: int, pad_force_n: float = 5.0,
                  hold_s: float = 1.0) -> tuple[float, float]:
    """Creep speed (m/s) of a 0.2 kg, mu = 1 box in the pinch, and physics steps/s."""
    model = build_pinch_model(make_object("block", mass_kg=0.2, friction=1.0), pad_force_n)
    model.opt.cone, model.opt.impratio, model.opt.noslip_iterations = cone, impratio, noslip
    data = mujoco.MjData(model)
    data.ctrl[:] = 1.0
    gravity = model.opt.gravity.copy()
    model.opt.gravity[:] = 0.0
    mujoco.mj_step(model, data, 100)
    model.opt.gravity[:] = gravity
    mujoco.mj_step(model, data, 50)  # let the load transient pass
    z_adr = model.joint("object").qposadr[0] + 2
    z0 = data.qpos[z_adr]
    n = int(round(hold_s / model.opt.timestep))
    t0 = time.perf_counter()
    mujoco.mj_step(model, data, n)
    rate = n / (time.perf_counter() - t0)
    return (z0 - data.qpos[z_adr]) / hold_s, rate


def _time(fn, n: int) -> float:
    """Seconds to call ``fn`` ``n`` times."""
    t0 = time.perf_counter()
    for _ in range(n):
        fn()
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="can")
    parser.add_argument("--steps", type=int, default=2000, help="control steps per repeat")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--physics-dt", type=float, default=0.002)
    args = parser.parse_args(argv)

    env = GraspEnv(args.object, 15.0, physics_dt_s=args.physics_dt, episode_s=1e6)
    env.reset(seed=0)
    u = env.steady_grasp(15.0, lifted=True)
    m, d, n_sub = env.model, env.data, env.n_substeps
    action = np.array([u], dtype=np.float32)
    state = np.empty(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)

    def raw_loop() -> None:
        for _ in range(n_sub):
            mujoco.mj_step(m, d)

    def raw_nstep() -> None:
        mujoco.mj_step(m, d, n_sub)

    def env_step() -> None:
        env.step(action)

    # Interleave the candidates and keep each one's best repeat, so that load
    # from other processes on a shared machine affects them alike.
    cases = (("raw mj_step x n_sub (python loop)", raw_loop),
             ("raw mj_step(m, d, n_sub)", raw_nstep),
             ("GraspEnv.step", env_step))
    best = {name: np.inf for name, _ in cases}
    for _ in range(args.repeats):
        for name, fn in cases:
            mujoco.mj_setState(m, d, state, mujoco.mjtState.mjSTATE_INTEGRATION)
            best[name] = min(best[name], _time(fn, args.steps))
    rates = {name: args.steps / t for name, t in best.items()}
    # The environment's own Python work alone: the same step with no physics.
    env.n_substeps = 0
    overhead_s = min(_time(env_step, args.steps) for _ in range(args.repeats)) / args.steps
    env.n_substeps = n_sub

    print(f"command: {' '.join([os.path.basename(sys.executable), *sys.argv])}")
    print(f"object={args.object} physics_dt={args.physics_dt * 1e3:.1f} ms "
          f"substeps={n_sub} contacts={d.ncon} grip={env.last_info['grip_force_n']:.2f} N")
    for name, rate in rates.items():
        print(f"{name:36s} {rate:9.0f} control steps/s  ({rate * n_sub:9.0f} physics steps/s, "
              f"{1e6 / rate:7.1f} us/control step)")
    raw = rates["raw mj_step(m, d, n_sub)"]
    ratio = raw / rates["GraspEnv.step"]
    print(f"env overhead vs raw mj_step(m, d, n_sub): x{ratio:.3f} (+{100 * (ratio - 1):.1f} %), "
          f"goal <= +25 %")
    print(f"env Python work alone (substeps=0): {overhead_s * 1e6:.1f} us/step = "
          f"+{100 * overhead_s * raw:.1f} % of raw stepping")
    print(f"load average while measuring: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    env.close()

    print("creep of a held 0.2 kg box, mu = 1, 5 N per pad (pinch; reference "
          "CALIBRATION.md: pyramidal 4.3, elliptic 2.1, impratio 10 0.21, noslip ~0 mm/s)")
    for label, cone, impratio, noslip in FRICTION_SETTINGS:
        creep, steps = measure_creep(cone, impratio, noslip)
        print(f"  {label:40s} creep {creep * 1e3:9.5f} mm/s   {steps:8.0f} steps/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
