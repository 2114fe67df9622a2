"""Speed of the MuJoCo hand: raw ``mj_step`` versus ``GraspEnv.step``, and the closed loop.

Both run the same model (hand + object + table) from the same state, with the
same number of physics substeps per control period:

- in a held grasp (wrist still: ``mj_step(m, d, n_sub)``), and
- during the lift (wrist moving: the raw reference sets the wrist set-point and
  calls ``mj_step`` at every substep, as ``GraspEnv.step`` does);

the environment's overhead (contact reading, outcomes, reward, observation,
info) must stay within 10 % of raw stepping. Then a whole
closed-loop episode (scheduled PI of ``controllers.design.design_for_object``
+ ``GraspEnv``, the episode runner's loop) is timed against the physics alone
(the recorded commands and wrist path replayed with raw ``mj_step`` from the same
reset state): goal >= 60x real time. Candidates are interleaved and each one's
best repeat is kept, so that load from other processes affects them alike.

It also measures creep (the slow slide of a held object) of a 0.2 kg box,
mu = 1, squeezed with 5 N per pad by the reference pinch, for each friction
setting: the numbers behind the contact-physics choice in docs/HAND.md.

Run: ``.venv/bin/python benchmarks/bench_hand.py [--object can] [--steps 2000]``
(``--options`` adds the raw speed of the cheaper physics options evaluated in
docs/HAND.md; ``--evaluate-options`` runs that evaluation instead: contact tests,
grip jumps during a lift and a few-seed drop/slip comparison per ``hand.xml`` variant.)
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

from controllers.base import observation_from_info  # noqa: E402
from controllers.design import design_for_object  # noqa: E402
from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec, WristSchedule  # noqa: E402
from sim.hand.model import build_pinch_model  # noqa: E402
from sim.hand.objects import make_object  # noqa: E402

FULL = mujoco.mjtState.mjSTATE_INTEGRATION

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


def _best_interleaved(cases: dict[str, object], reset, repeats: int) -> dict[str, float]:
    """Best wall time (s) of each candidate, ``reset()`` before each run, interleaved."""
    best = dict.fromkeys(cases, np.inf)
    for _ in range(repeats):
        for name, fn in cases.items():
            reset()
            t0 = time.perf_counter()
            fn()
            best[name] = min(best[name], time.perf_counter() - t0)
    return best


def lift_overhead(obj: str, n_steps: int, repeats: int) -> tuple[float, float, int]:
    """``GraspEnv.step`` vs raw stepping while the wrist lifts: us per control step.

    The episode closes at a constant command until the lift starts; from the
    state after the first lift step both candidates run ``n_steps`` control
    steps of the lift (the raw loop sets the same wrist set-points, precomputed,
    and calls ``mj_step`` every substep). Returns ``(env_us, raw_us, n_sub)``.
    """
    schedule = WristSchedule(lift_after_s=0.3, lift_duration_s=0.6)
    env = GraspEnv(obj, 10.0, wrist=schedule, task=GraspTask(episode_s=1e6))
    env.reset(seed=0)
    action = np.array([0.15], dtype=np.float32)
    info = env.last_info
    while not info["lifted"]:
        info = env.step(action)[4]
    m, d, n_sub, dt = env.model, env.data, env.n_substeps, env.physics_dt_s
    lift_start = env._lift_start_s
    if (d.time - lift_start) + n_steps * env.control_dt_s > schedule.lift_duration_s:
        raise ValueError(f"--lift-steps {n_steps}: the lift lasts only "
                         f"{schedule.lift_duration_s} s")
    state = np.empty(mujoco.mj_stateSize(m, FULL))
    mujoco.mj_getState(m, d, state, FULL)
    # the wrist set-points GraspEnv computes (from the episode clock d.time of each step)
    times = []
    for _ in range(n_steps):
        times.append(d.time)
        env.step(action)
    end = np.empty_like(state)
    mujoco.mj_getState(m, d, end, FULL)
    heights = [schedule.height_m(t + i * dt, lift_start)
               for t in times for i in range(1, n_sub + 1)]
    i_motor, i_wrist = int(env.ids.motor), int(env.ids.wrist_act[2])
    ctrl = d.ctrl
    u = float(action[0])

    def raw() -> None:
        j = 0
        for _ in range(n_steps):
            ctrl[i_motor] = u
            for _ in range(n_sub):
                ctrl[i_wrist] = heights[j]
                mujoco.mj_step(m, d)
                j += 1

    mujoco.mj_setState(m, d, state, FULL)
    raw()
    replay = np.empty_like(state)
    mujoco.mj_getState(m, d, replay, FULL)
    if not np.array_equal(replay, end):
        raise RuntimeError("the raw lift did not reproduce GraspEnv's lift")

    def env_steps() -> None:
        for _ in range(n_steps):
            env.step(action)

    best = _best_interleaved({"raw": raw, "env": env_steps},
                             lambda: mujoco.mj_setState(m, d, state, FULL), repeats)
    env.close()
    return best["env"] / n_steps * 1e6, best["raw"] / n_steps * 1e6, n_sub


def closed_loop_factor(obj_name: str, episode_s: float, repeats: int) -> tuple[float, float]:
    """Real-time factors of a scheduled-PI episode and of its physics alone.

    The loop is the episode runner's (``scenarios.runners.episode``): each
    control step builds the observation from ``info``, the controller acts, the
    command is applied one period later, ``GraspEnv.step`` advances. The
    reference ramps to 10 N over 0.5 s and holds; the wrist lifts at 1 s. The
    physics-alone run replays the recorded commands and wrist path with raw
    ``mj_step`` (``mj_step(m, d, n_sub)`` while the wrist is still) from the
    same reset state, and must end in the same state.

    Returns
    -------
    closed_loop_x, physics_x : float
        Simulated time over the best wall time.
    """
    obj = make_object(obj_name)
    design = design_for_object(obj, "pid")  # plant family from the cache after the first run
    schedule = WristSchedule(lift_after_s=1.0, lift_duration_s=0.6)
    env = GraspEnv(obj, 0.0, wrist=schedule, task=GraspTask(episode_s=episode_s))
    n = env.max_steps
    dt_c = env.control_dt_s
    ref = [min(1.0, k * dt_c / 0.5) * 10.0 for k in range(n)]
    ctl = design.controller
    actions: list[float] = []
    times: list[float] = []

    def loop() -> None:
        ctl.reset()
        obs, info = env.reset(seed=0)
        action = np.zeros(1, dtype=np.float32)
        pending = 0.0
        actions.clear()
        times.clear()
        for k in range(n):
            r = ref[k]
            env.set_reference(r)
            u = ctl.act(observation_from_info(info, r))
            action[0] = pending
            actions.append(float(action[0]))
            times.append(env.data.time)
            obs, _, terminated, truncated, info = env.step(action)
            pending = u
            if terminated or truncated:
                break

    loop()
    m, d, n_sub, dt = env.model, env.data, env.n_substeps, env.physics_dt_s
    lift_start = env._lift_start_s
    end_state = np.empty(mujoco.mj_stateSize(m, FULL))
    mujoco.mj_getState(m, d, end_state, FULL)
    # the wrist path per control step: None while still, else the substep set-points
    plan: list[tuple[float, list[float] | None]] = []
    for a, t in zip(actions, times, strict=True):
        if lift_start is not None and schedule.moves_during(t, t + dt_c, lift_start):
            plan.append((a, [schedule.height_m(t + i * dt, lift_start)
                             for i in range(1, n_sub + 1)]))
        else:
            plan.append((a, [schedule.height_m(t + dt_c, lift_start)]))
    env.reset(seed=0)
    start_state = np.empty_like(end_state)
    mujoco.mj_getState(m, d, start_state, FULL)
    i_motor, i_wrist = int(env.ids.motor), int(env.ids.wrist_act[2])
    ctrl = d.ctrl

    def physics() -> None:
        for a, heights in plan:
            ctrl[i_motor] = a
            if len(heights) == 1:
                ctrl[i_wrist] = heights[0]
                mujoco.mj_step(m, d, n_sub)
            else:
                for h in heights:
                    ctrl[i_wrist] = h
                    mujoco.mj_step(m, d)

    def reset_physics() -> None:
        mujoco.mj_setState(m, d, start_state, FULL)

    reset_physics()
    physics()
    replay = np.empty_like(end_state)
    mujoco.mj_getState(m, d, replay, FULL)
    if not np.array_equal(replay, end_state):
        raise RuntimeError("the physics-alone replay did not reproduce the episode")
    best = _best_interleaved({"loop": loop, "physics": physics}, reset_physics, repeats)
    simulated = len(actions) * dt_c
    env.close()
    return simulated / best["loop"], simulated / best["physics"]


PHYSICS_OPTIONS = {
    "used (noslip 5, ccd_tolerance 1e-6, multiccd on)": {},
    "ccd_tolerance 1e-9 (used before the physics evaluation)": {"ccd_tolerance": 1e-9},
    "noslip_iterations 0": {"noslip_iterations": 0},
    "multiccd off": {"multiccd": False},
    "noslip 0 and multiccd off": {"noslip_iterations": 0, "multiccd": False},
}


def _apply_options(model: mujoco.MjModel, base: tuple[int, float, int], options: dict) -> None:
    noslip, ccd_tol, disable = base
    model.opt.noslip_iterations = options.get("noslip_iterations", noslip)
    model.opt.ccd_tolerance = options.get("ccd_tolerance", ccd_tol)
    flag = int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
    model.opt.disableflags = disable | flag if options.get("multiccd") is False else disable


def physics_options(obj: str, repeats: int, n_steps: int = 500) -> None:
    """Raw ``mj_step`` speed of the cheaper physics options in a lifted, held grasp."""
    env = GraspEnv(obj, 10.0, task=GraspTask(episode_s=1e6))
    env.reset(seed=0)
    env.steady_grasp(10.0, lifted=True)
    m, d = env.model, env.data
    base = (m.opt.noslip_iterations, m.opt.ccd_tolerance, m.opt.disableflags)
    state = np.empty(mujoco.mj_stateSize(m, FULL))
    mujoco.mj_getState(m, d, state, FULL)
    best = dict.fromkeys(PHYSICS_OPTIONS, np.inf)
    for _ in range(repeats):
        for name, options in PHYSICS_OPTIONS.items():
            _apply_options(m, base, options)
            mujoco.mj_setState(m, d, state, FULL)
            t0 = time.perf_counter()
            mujoco.mj_step(m, d, n_steps)
            best[name] = min(best[name], time.perf_counter() - t0)
    _apply_options(m, base, {})
    ref = best[next(iter(PHYSICS_OPTIONS))]
    print(f"physics options, raw mj_step in a lifted {obj} grasp at 10 N ({d.ncon} contacts), "
          f"best of {repeats} x {n_steps} steps, interleaved:")
    for name, t in best.items():
        print(f"  {name:50s} {t / n_steps * 1e6:7.1f} us/step  x{ref / t:.2f}")
    env.close()


#: hand.xml edits evaluated by ``--evaluate-options`` (option text -> replacement).
XML_VARIANTS = {
    "used": {},
    "ccd_tolerance 1e-9": {'ccd_tolerance="1e-6"': 'ccd_tolerance="1e-9"'},
    "ccd_tolerance 1e-12": {'ccd_tolerance="1e-6"': 'ccd_tolerance="1e-12"'},
    "noslip_iterations 0": {'noslip_iterations="5"': 'noslip_iterations="0"'},
    "multiccd off": {'ccd_tolerance="1e-6"/>':
                     'ccd_tolerance="1e-6">\n    <flag multiccd="disable"/>\n  </option>'},
}
CONTACT_TESTS = ("tests/sim/test_contact_coulomb.py", "tests/sim/test_lift.py",
                 "tests/sim/test_contact.py", "tests/sim/test_grasp_env.py",
                 "tests/sim/test_impact.py")
_PLUGIN = (
    "import os\nimport sim.hand.model as model\n"
    "model.HAND_XML = os.environ['GRIPLOOP_BENCH_HAND_XML']\n"
)


def _lift_jumps(obj: str = "can", grip_n: float = 12.0) -> tuple[float, float, float]:
    """Grip range and largest one-substep change (N) during a smooth lift at a held command."""
    from sim.hand.contact import read_contacts

    env = GraspEnv(obj, grip_n, task=GraspTask(episode_s=1e6))
    env.reset(seed=0)
    env.steady_grasp(grip_n)
    m, d, ids, sch = env.model, env.data, env.ids, env.schedule
    n = int(round(sch.lift_duration_s / env.physics_dt_s))
    grip = []
    for i in range(n + 1):
        s = i / n
        d.ctrl[ids.wrist_act[2]] = sch.lift_height_m * s**3 * (10 - 15 * s + 6 * s * s)
        mujoco.mj_step(m, d)
        grip.append(read_contacts(m, d, ids).grip_force_n)
    g = np.array(grip)
    env.close()
    return float(g.min()), float(g.max()), float(np.abs(np.diff(g)).max())


def evaluate_options(seeds: int = 4) -> None:
    """Each hand.xml variant against the contact tests, the lift jumps and a drop/slip comparison.

    Every variant is a copy of ``hand.xml`` with one option edited, swapped in through
    ``sim.hand.model.HAND_XML``: in a pytest subprocess via a generated plugin (the contact
    tests), and in this process for the rest. Plant families are built once with the used
    physics (in a private cache directory) so that every variant runs the same controllers.
    """
    import subprocess
    import tempfile
    from importlib import resources

    import sim.hand.model as hand_model
    from scenarios.runners.episode import EpisodeSpec, run_episode
    from sim.user.subjects import VirtualSubject

    root = Path(__file__).resolve().parent.parent
    xml = resources.files("sim.hand").joinpath("assets", hand_model.HAND_XML).read_text()
    original = hand_model.HAND_XML
    subject = VirtualSubject.sample(0, 1)
    objects = (make_object("can", mass_kg=0.4, friction=0.5), make_object("egg"))
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "griploop_bench_xml.py").write_text(_PLUGIN)
        os.environ["GRIPLOOP_CACHE_DIR"] = str(Path(tmp, "cache"))
        print("variant | contact tests | lift at 12 N: grip range, largest step (N) | "
              "episodes per object: dropped, slip events / distance (mm)")
        for name, edits in XML_VARIANTS.items():
            text = xml
            for old, new in edits.items():
                if old not in text:
                    raise ValueError(f"hand.xml has no {old!r} to edit for {name!r}")
                text = text.replace(old, new)
            path = Path(tmp, f"hand_{len(os.listdir(tmp))}.xml")
            path.write_text(text)
            env = {**os.environ, "GRIPLOOP_BENCH_HAND_XML": str(path),
                   "PYTHONPATH": os.pathsep.join([tmp, str(root),
                                                  os.environ.get("PYTHONPATH", "")])}
            proc = subprocess.run(
                [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                 "-p", "griploop_bench_xml", *CONTACT_TESTS],
                cwd=root, env=env, capture_output=True, text=True, check=False)
            summary = proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else "?"
            hand_model.HAND_XML = str(path)
            try:
                lo, hi, jump = _lift_jumps()
                parts = []
                for obj in objects:
                    rows = [run_episode(subject, obj, EpisodeSpec(
                        estimator="ss_kf", controller="pid", seed=seed)).row
                        for seed in range(seeds)]
                    parts.append(f"{obj.name} " + " ".join(
                        f"{'D' if r['dropped'] else 'h'}{r['slip_events']}/"
                        f"{1e3 * r['slip_distance_m']:.0f}" for r in rows))
            finally:
                hand_model.HAND_XML = original
            print(f"{name} | {summary} | {lo:.2f}-{hi:.2f}, {jump:.2f} | {'; '.join(parts)}",
                  flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="can")
    parser.add_argument("--steps", type=int, default=2000, help="control steps per repeat")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--physics-dt", type=float, default=0.002)
    parser.add_argument("--lift-steps", type=int, default=50,
                        help="control steps of the lift timed per repeat")
    parser.add_argument("--episode-s", type=float, default=3.0,
                        help="closed-loop episode length, s")
    parser.add_argument("--options", action="store_true",
                        help="also time the cheaper physics options (docs/HAND.md)")
    parser.add_argument("--evaluate-options", action="store_true",
                        help="only evaluate the physics options against the contact tests, "
                             "the lift and a few-seed drop/slip comparison (minutes)")
    args = parser.parse_args(argv)
    if args.evaluate_options:
        evaluate_options()
        return 0

    env = GraspEnv(args.object, 15.0, hand=HandSpec(physics_dt_s=args.physics_dt),
                   task=GraspTask(episode_s=1e6))
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
          f"goal <= +10 %")
    print(f"env Python work alone (substeps=0): {overhead_s * 1e6:.1f} us/step = "
          f"+{100 * overhead_s * raw:.1f} % of raw stepping")
    print(f"load average while measuring: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    env.close()

    env_us, raw_us, n_sub_lift = lift_overhead(args.object, args.lift_steps, args.repeats)
    print(f"lift (wrist moving), {n_sub_lift} substeps: GraspEnv.step {env_us:.1f} us, raw "
          f"{raw_us:.1f} us per control step")
    loop_x, phys_x = closed_loop_factor(args.object, args.episode_s, args.repeats)
    print(f"closed loop, scheduled PI + GraspEnv, {args.episode_s:g} s episode with lift: "
          f"{loop_x:.1f}x real time; physics alone {phys_x:.1f}x "
          f"(load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores)")
    goal_line("GraspEnv.step overhead over raw mj_step, held grasp <= 10 %",
              100 * (ratio - 1), "%", limit=10.0,
              reference=f"raw mj_step(m, d, {n_sub}) {1e6 / raw:.1f} us")
    goal_line("GraspEnv.step overhead over raw mj_step, wrist lifting <= 10 %",
              100 * (env_us / raw_us - 1), "%", limit=10.0,
              reference=f"raw mj_step x {n_sub_lift} {raw_us:.1f} us")
    goal_line("closed loop (scheduled PI + GraspEnv) >= 60x real time", loop_x, "x",
              limit=60.0, better="higher", reference=f"physics alone {phys_x:.1f}x")
    if args.options:
        physics_options(args.object, args.repeats)

    print("creep of a held 0.2 kg box, mu = 1, 5 N per pad (pinch; reference "
          "CALIBRATION.md: pyramidal 4.3, elliptic 2.1, impratio 10 0.21, noslip ~0 mm/s)")
    for label, cone, impratio, noslip in FRICTION_SETTINGS:
        creep, steps = measure_creep(cone, impratio, noslip)
        print(f"  {label:40s} creep {creep * 1e3:9.5f} mm/s   {steps:8.0f} steps/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
