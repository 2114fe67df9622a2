"""Start-up of ``griploop episode``: a process that only runs cached designs loads no more
than it needs (issue 22; its time is measured by ``benchmarks/bench_startup.py``).

A cached design holds python-control systems (the plants of its family, each design's
loop and the analyses made so far). Reading the file leaves them as matrices
(:func:`sim.codec.stored_systems`), so an episode that only runs the design, with its
loop analyses on disk too, never imports python-control.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: Run ``griploop ARGV`` as the console script does, then list what it imported for real.
PROBE = """
import json, runpy, sys
sys.argv = ["griploop", *json.loads(sys.argv[1])]
try:
    runpy.run_module("scenarios.cli", run_name="__main__")
except SystemExit as exit:
    assert not exit.code, exit.code
from scenarios.cli.deferred import DeferredModule
real = sorted({n.split(".")[0] for n, m in sys.modules.items()
               if m is not None and not isinstance(m, DeferredModule)})
print(json.dumps(real))
"""

#: Never needed to run a cached design: plotting, the MPC's QP builder, clusters, the
#: report's templates, live streams.
NEVER = {"matplotlib", "mpl_toolkits", "casadi", "dask", "distributed", "jinja2", "pylsl"}


def _imported(argv: list[str], cache: Path) -> set[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "GRIPLOOP_CACHE_DIR": str(cache),
           "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argv)], capture_output=True,
                         text=True, env=env, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    return set(json.loads(out.stdout.strip().splitlines()[-1]))


@pytest.fixture(scope="module")
def warm_cache(tmp_path_factory) -> Path:
    """A cache directory holding the plant family and the PID design of the can."""
    cache = tmp_path_factory.mktemp("startup-cache")
    _imported(["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
               "--seed", "3"], cache)
    assert list((cache / "designs").glob("can-pid-*.design"))
    return cache


def test_an_oracle_episode_on_a_cached_design_loads_no_plotting_and_no_estimators(warm_cache):
    mods = _imported(["episode", "--controller", "pid", "--estimator", "oracle", "--object",
                      "can", "--seed", "3"], warm_cache)
    assert not mods & NEVER, mods & NEVER
    assert "sklearn" not in mods  # the oracle reference fits no estimator
    assert "control" not in mods  # the design is only run: its systems stay matrices
    assert {"mujoco", "scenarios"} <= mods


def test_an_estimated_episode_on_a_cached_design_loads_no_plotting(warm_cache):
    mods = _imported(["episode", "--controller", "pid", "--estimator", "ss_kf", "--object",
                      "can"], warm_cache)
    assert not mods & NEVER, mods & NEVER
    assert "sklearn" in mods  # the estimators are scikit-learn regressors


def test_a_figure_still_loads_matplotlib(tmp_path):
    png = tmp_path / "log.png"
    code = ("import runpy, sys\n"
            "from sim.user.subjects import VirtualSubject\n"
            f"VirtualSubject.sample(0, 1).paper_session().save({str(tmp_path / 's.npz')!r})\n"
            f"sys.argv = ['griploop', 'plot-recording', {str(tmp_path / 's.npz')!r}, "
            f"'--out', {str(png)!r}]\n"
            "try:\n    runpy.run_module('scenarios.cli', run_name='__main__')\n"
            "except SystemExit as exit:\n    assert not exit.code, exit.code\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
