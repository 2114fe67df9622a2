"""
Your own controller, as a plugin
================================

A controller is a design function that takes the plant (the hand holding the object,
linearized at one grip force, a discrete ``control.StateSpace``) and returns an object
with ``reset(u0)``, ``act(observation)`` and ``loop(plant)``. Registered under a name,
it becomes a choice of every command and sweep: griploop designs it at every force of
the object's grid, schedules the designs on the grip force, and analyses the loop where
it runs. A module of your own is loaded with ``griploop --plugin MODULE`` (or a sweep's
``plugins:`` list); :doc:`/EXTENDING` lists the other things a plugin can register.
"""

# %%
# The plugin module
# -----------------
# An integral controller whose gain is chosen for a phase margin, written to a file
# outside griploop, as yours would be.
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from scenarios.cli import main

PLUGIN = '''
"""An integral grip-force controller, designed for a phase margin."""
import control
import numpy as np

from controllers.registry import register_controller


class Integral:
    def __init__(self, ki_per_s, period_s):
        self.ki_per_s, self.period_s, self.u = ki_per_s, period_s, 0.0

    def reset(self, u0=0.0):
        self.u = float(u0)

    def act(self, observation):
        error = observation.reference_n - observation.grip_force_n
        self.u = float(np.clip(self.u + self.ki_per_s * self.period_s * error, -1.0, 1.0))
        return self.u

    def loop(self, plant):
        return control.tf([self.ki_per_s * self.period_s], [1.0, -1.0], self.period_s) * plant


def design(plant, *, phase_margin_deg=60.0, crossover_rad_s=20.0):
    """The largest integral gain with the phase margin, crossing over below crossover_rad_s."""
    dt = float(plant.dt)
    w = np.geomspace(0.05, crossover_rad_s, 400)
    z = np.exp(1j * w * dt)
    shape = np.array([complex(control.evalfr(plant, zi)) for zi in z]) * dt / (z - 1.0)
    phase_ok = np.degrees(np.unwrap(np.angle(shape))) >= phase_margin_deg - 180.0
    keep = np.flatnonzero(phase_ok)
    return Integral(1.0 / abs(shape[keep[-1] if keep.size else 0]), dt)


register_controller("my_integral", design)
'''

work = Path(tempfile.mkdtemp(prefix="griploop-plugin-"))
(work / "my_grip_plugin.py").write_text(PLUGIN)


def griploop(*args: str) -> None:
    """Run one griploop command; stop with its error line on a non-zero exit status."""
    errors = io.StringIO()  # the error line, and progress bars, go to stderr
    with contextlib.redirect_stderr(errors):
        status = main(list(args))
    if status != 0:
        raise RuntimeError(f"griploop {' '.join(args)}: exit status {status}: "
                           f"{errors.getvalue().strip()}")


# %%
# Its margins over the grip force
# -------------------------------
# ``griploop margins`` designs it on the can's plant family and prints the phase and
# gain margins at each grip force, on the plant linearized there, then the worst case.
sys.path.insert(0, str(work))  # the command line also finds it in the current directory
margins = work / "margins.json"
griploop("--plugin", "my_grip_plugin", "margins", "--controller", "my_integral",
         "--object", "can", "--json", str(margins))

# %%
# One closed-loop grasp
# ---------------------
# The oracle reference (the user's true intent) isolates the controller; replace it with
# ``--estimator mlp`` for the whole chain from sEMG.
episode = work / "episode.json"
griploop("--plugin", "my_grip_plugin", "episode", "--controller", "my_integral",
         "--estimator", "oracle", "--object", "can", "--json", str(episode))
run = json.loads(episode.read_text())
traces = run["traces"]
fig, ax = plt.subplots(figsize=(8, 3.5))
ax.plot(traces["t_s"], traces["reference_n"], label="reference")
ax.plot(traces["t_s"], traces["grip_force_n"], label="grip force")
ax.set_xlabel("time (s)")
ax.set_ylabel("N")
ax.set_title(f"my_integral on the can: {run['metrics']['outcome']}")
ax.legend()
fig.tight_layout()
