"""Deferred modules: python-control imports pyplot and scipy.stats; they load when used."""

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

CODE = """
import sys
from scenarios.cli.deferred import DeferredModule, defer_plotting
defer_plotting()  # what the griploop process does first
import control  # imports matplotlib, matplotlib.pyplot and matplotlib.transforms at its top
assert isinstance(sys.modules["matplotlib.pyplot"], DeferredModule)
assert isinstance(sys.modules["matplotlib"], DeferredModule)  # the package did not run
assert "matplotlib.figure" not in sys.modules and "mpl_toolkits.axisartist" not in sys.modules
assert "matplotlib.rcsetup" not in sys.modules and "matplotlib.colors" not in sys.modules
assert isinstance(sys.modules["scipy.stats"], DeferredModule)  # imported by scipy.signal
import numpy as np
import scipy.signal
peaks = scipy.signal.find_peaks_cwt(np.sin(np.linspace(0, 20, 400)) + 1.0, np.arange(5, 30))
assert len(peaks) >= 2  # through the deferred scoreatpercentile
from scipy import stats
assert stats.norm.cdf(0.0) == 0.5 and not isinstance(sys.modules["scipy.stats"], DeferredModule)
from matplotlib.figure import Figure  # a submodule that is not deferred: the package runs
import matplotlib
assert not isinstance(sys.modules["matplotlib"], DeferredModule)
assert matplotlib.__spec__.name == "matplotlib" and callable(Figure().add_subplot)
import matplotlib.pyplot as plt
from matplotlib import pyplot
assert pyplot is plt
fig = plt.figure()  # first use: the real pyplot loads
assert not isinstance(sys.modules["matplotlib.pyplot"], DeferredModule)
assert plt.gcf() is fig and sys.modules["matplotlib.pyplot"].gcf() is fig
assert sys.modules["matplotlib"].pyplot is sys.modules["matplotlib.pyplot"]
control.nichols_plot(control.tf([1], [1, 1]))  # through the deferred matplotlib.transforms
control.bode_plot(control.tf([1], [1, 1]))
control.pzmap(control.tf([1], [1, 1, 1]), grid=True)  # the deferred grid functions
assert "mpl_toolkits.axisartist" in sys.modules
print("ok")
"""


def test_pyplot_loads_on_first_use_only():
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_importing_the_library_defers_nothing():
    """Only the griploop process defers: a user's ``import sim, control`` gets real modules."""
    code = ("import sys, sim, controllers.plant, control\n"
            "from scenarios.cli.deferred import DeferredModule\n"
            "bad = [n for n, m in sys.modules.items() if isinstance(m, DeferredModule)]\n"
            "assert not bad, bad\n"
            "assert 'matplotlib.pyplot' in sys.modules\nprint('ok')\n")
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_the_griploop_process_defers_pyplot():
    """``python -m scenarios.cli`` (the console script's path) defers before any command."""
    code = ("import sys, runpy\n"
            "sys.argv = ['griploop', '--version']\n"
            "try:\n    runpy.run_module('scenarios.cli', run_name='__main__')\n"
            "except SystemExit:\n    pass\n"
            "import control\n"
            "from scenarios.cli.deferred import DeferredModule\n"
            "assert isinstance(sys.modules['matplotlib.pyplot'], DeferredModule)\n"
            "print('ok')\n")
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=120)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr
