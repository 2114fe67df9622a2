"""Gain scheduling must not slow the loop: a scheduled controller step stays under 10 us.

Measures, in the same run, one step of the scheduled PI (gains interpolated and
changed bumplessly every step), of the scheduled lead-lag (bank switched on the
force), and of the fixed PI they replace, with a grip force that sweeps the
operating range so the schedule moves; and the build time of the can's plant
family (linearizations over the force grid, cached per object afterwards).

Run: .venv/bin/python benchmarks/bench_control.py
"""

from __future__ import annotations

import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line, time_call  # noqa: E402

from controllers.base import Observation  # noqa: E402
from controllers.design import cached_plant_family, design_for_object  # noqa: E402
from controllers.design_spec import DesignSpec  # noqa: E402
from sim.hand.objects import make_object  # noqa: E402

TARGET_STEP_US = 10.0


def step_time_us(core, forces: np.ndarray) -> float:
    """Median time of one ``act`` over a sweep of the operating range, us."""
    obs = [Observation(time_s=0.01 * k, reference_n=float(f), grip_force_n=float(f) * 0.98,
                       thumb_contact=True, finger_contact=True)
           for k, f in enumerate(forces)]
    core.reset()
    i = [0]

    def one() -> None:
        core.act(obs[i[0] % len(obs)])
        i[0] += 1

    return 1e6 * time_call(one, repeat=5)


def main() -> int:
    can = make_object("can", mass_kg=0.4, friction=0.5)
    start = time.perf_counter()
    family = cached_plant_family(can, 0.01)
    build_s = time.perf_counter() - start
    forces = 3.0 + 17.0 * (0.5 + 0.5 * np.sin(np.linspace(0, 20 * np.pi, 2000)))
    fixed = design_for_object(can, "pid", DesignSpec(scheduled=False)).core.designs[0]
    rows = [("fixed PI (reference)", step_time_us(fixed, forces))]
    for kind in ("pid", "lead_lag"):
        core = design_for_object(can, kind).core
        rows.append((f"scheduled {kind}", step_time_us(core, forces)))
    print(f"python {sys.version.split()[0]} on {platform.machine()}")
    print(f"plant family of the can ({len(family.points)} grid forces): built in "
          f"{build_s:.2f} s (cached per object afterwards)")
    ok = True
    for name, us in rows:
        met = us <= TARGET_STEP_US or name.startswith("fixed")
        ok &= met
        goal = "" if name.startswith("fixed") else (
            f"  goal <= {TARGET_STEP_US:g} us: {'met' if met else 'NOT MET'}")
        print(f"{name:24s} {us:6.2f} us per step ({us / rows[0][1]:.2f}x the fixed PI){goal}")
    print("command: .venv/bin/python benchmarks/bench_control.py")
    for name, us in rows[1:]:
        goal_line(f"{name} controller step <= {TARGET_STEP_US:g} us", us, "us",
                  limit=TARGET_STEP_US, reference=f"fixed PI {rows[0][1]:.2f} us")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
