"""Plugins: a module outside griploop registers a controller or a kind and runs everywhere.

The plugin modules are written to a temporary directory, as a user's own files
would be, and loaded with ``griploop --plugin MODULE`` or a sweep file's
``plugins:``. A fixture removes their registrations and modules afterwards.
"""

from __future__ import annotations

import json
import sys
import textwrap

import pytest

from controllers.registry import controller_names, unregister_controller
from scenarios.cli.main import main
from scenarios.execution.sweep import DEFAULT_TASK, SweepExecution, plan, run_sweep
from scenarios.plugins import PluginError, load_plugins
from scenarios.runners.dispatch import scenario_kinds, unregister_kind
from scenarios.schema import ScenarioError, expand_sweep, load_sweep
from scenarios.store import ResultStore

#: A controller module with only reset, act and loop, as a user would write it.
INTEGRAL_PLUGIN = '''
"""My integral grip controller."""
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
    """Integral gain for the phase margin, at a crossover of at most crossover_rad_s."""
    dt = float(plant.dt)
    w = np.geomspace(0.05, crossover_rad_s, 400)
    z = np.exp(1j * w * dt)
    shape = np.array([complex(control.evalfr(plant, zi)) for zi in z]) * dt / (z - 1.0)
    keep = np.flatnonzero(np.degrees(np.unwrap(np.angle(shape))) >= phase_margin_deg - 180.0)
    return Integral(1.0 / abs(shape[keep[-1] if keep.size else 0]), dt)


register_controller("my_integral", design)
'''

#: A scenario-kind module: returns the process it ran in.
KIND_PLUGIN = '''
import os

from scenarios.runners.dispatch import register_kind


def where(scenario):
    return {"pid": os.getpid(), "mass_kg": scenario.object.mass_kg}


register_kind("my_where", where)
'''


@pytest.fixture
def plugin_dir(tmp_path, monkeypatch):
    """A directory with the plugin modules, as the current directory; cleaned up after."""
    (tmp_path / "my_integral_plugin.py").write_text(textwrap.dedent(INTEGRAL_PLUGIN))
    (tmp_path / "my_kind_plugin.py").write_text(textwrap.dedent(KIND_PLUGIN))
    (tmp_path / "my_broken_plugin.py").write_text("RATIO = 1 / 0\n")
    (tmp_path / "my_idle_plugin.py").write_text("NOTHING = 'registered'\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    unregister_controller("my_integral")
    unregister_kind("my_where")
    for name in ("my_integral_plugin", "my_kind_plugin", "my_broken_plugin", "my_idle_plugin"):
        sys.modules.pop(name, None)


def test_a_plugin_controller_holds_the_can_and_prints_its_margins(plugin_dir, capsys):
    out = plugin_dir / "episode.json"
    status = main(["--plugin", "my_integral_plugin", "episode", "--controller", "my_integral",
                   "--estimator", "oracle", "--object", "can", "--json", str(out)])
    assert status == 0, capsys.readouterr().err
    row = json.loads(out.read_text())
    assert row["metrics"]["outcome"] == "held"
    margins = plugin_dir / "margins.json"
    status = main(["--plugin=my_integral_plugin", "margins", "--controller", "my_integral",
                   "--object", "can", "--json", str(margins)])
    assert status == 0
    assert "margins of my_integral" in capsys.readouterr().out
    worst = json.loads(margins.read_text())["worst_case"]
    assert worst["all_stable"] and worst["phase_margin_deg"] >= 55.0  # the plugin's rule
    points = json.loads(margins.read_text())["operating_points"]
    assert len(points) >= 10 and all(p["controller"] is None for p in points)


def test_without_the_plugin_the_name_is_unknown(plugin_dir, capsys):
    status = main(["margins", "--controller", "my_integral", "--object", "can"])
    err = capsys.readouterr().err
    assert status == 2 and "my_integral" in err and len(err.strip().splitlines()) == 1
    assert "my_integral" not in controller_names()


@pytest.mark.parametrize("module, message", [
    ("my_missing_plugin", "plugin my_missing_plugin: cannot import: ModuleNotFoundError: "
                          "No module named 'my_missing_plugin'"),
    ("my_broken_plugin", "plugin my_broken_plugin: cannot import: ZeroDivisionError: "
                         "division by zero"),
    ("my_idle_plugin", "plugin my_idle_plugin: imported, but registered nothing"),
])
def test_a_bad_plugin_is_one_line_with_its_own_error(plugin_dir, capsys, module, message):
    status = main(["--plugin", module, "margins", "--controller", "pid", "--object", "can"])
    err = capsys.readouterr().err
    assert status == 2
    assert err.startswith(f"griploop: error: {message}"), err
    assert len(err.strip().splitlines()) == 1
    with pytest.raises(PluginError, match=message.split(":")[0]):
        load_plugins([module])


def test_a_sweep_files_plugins_register_in_the_driver_and_every_worker(plugin_dir):
    from distributed import LocalCluster

    path = plugin_dir / "sweep.yaml"
    path.write_text("name: plugged\nplugins: [my_kind_plugin]\nbase:\n  kind: my_where\n"
                    "grid:\n  object.mass_kg: [0.2, 0.3, 0.4]\n")
    spec = load_sweep(path)  # the kind is known only once the plugin is loaded
    assert spec.plugins == ["my_kind_plugin"] and "my_where" in scenario_kinds()
    items = plan(expand_sweep(spec), DEFAULT_TASK)
    with ResultStore(plugin_dir / "local.sqlite") as store:  # forked workers
        summary = run_sweep(items, store, SweepExecution(workers=2, plugins=spec.plugins),
                            progress=False)
        assert (summary.ok, summary.failed) == (3, 0)
    # dask workers are fresh interpreters: they load the plugin before their first scenario
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, \
            ResultStore(plugin_dir / "dask.sqlite") as store:
        summary = run_sweep(items, store, SweepExecution(scheduler=cluster.scheduler_address,
                                                         plugins=spec.plugins),
                            progress=False)
        rows = store.rows()
        assert (summary.ok, summary.failed) == (3, 0), [r["error"] for r in rows]
        assert sorted(r["result"]["mass_kg"] for r in rows) == [0.2, 0.3, 0.4]


def test_a_sweep_plugin_that_fails_names_its_line(plugin_dir):
    path = plugin_dir / "sweep.yaml"
    path.write_text("plugins:\n  - my_kind_plugin\n  - my_broken_plugin\nbase: {}\n")
    with pytest.raises(ScenarioError) as info:
        load_sweep(path)
    assert str(info.value) == (f"{path}:3: plugins[1]: plugin my_broken_plugin: cannot import: "
                               "ZeroDivisionError: division by zero")
