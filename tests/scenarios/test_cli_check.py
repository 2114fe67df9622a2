"""``griploop --plugin MODULE check``: the checkers for plugin authors, from Python and the CLI.

A toy plugin, written to a temporary directory as a user's own module would be, registers
three faulty pieces: a controller whose ``reset()`` forgets to clear its integrator, a
controller that returns NaN, and an estimator whose stream drifts away from its
``predict``. Each is one failure line naming its check, from the Python checkers and from
the command line. The plugin of ``examples/plot_02_your_controller.py`` passes.
"""

from __future__ import annotations

import ast
import sys
import textwrap
from pathlib import Path

import pytest

from controllers.checks import check_controller
from controllers.registry import controller_names, unregister_controller
from estimation.checks import check_estimator
from estimation.registry import estimator_names, unregister_estimator
from scenarios.checks import load_recorded, plugin_registrations
from scenarios.cli.main import main

ROOT = Path(__file__).resolve().parents[2]

#: The toy plugin: (a) a forgetful reset, (b) a NaN command, (c) a drifting stream.
FAULTY_PLUGIN = '''
"""Three faulty pieces, as a plugin author might write them by mistake."""
import control
import numpy as np

from controllers.registry import register_controller
from estimation.base import ForceEstimator
from estimation.registry import register_estimator


class Forgetful:
    """An integral controller whose reset() does not clear its integrator."""

    def __init__(self, period_s):
        self.period_s, self.u = period_s, 0.0

    def reset(self, u0=0.0):
        pass

    def act(self, observation):
        error = observation.reference_n - observation.grip_force_n
        self.u = float(np.clip(self.u + 0.01 * error, -1.0, 1.0))
        return self.u

    def loop(self, plant):
        return control.tf([0.01], [1.0, -1.0], self.period_s) * plant


class Broken(Forgetful):
    """Resets, but every command is NaN."""

    def reset(self, u0=0.0):
        self.u = float(u0)

    def act(self, observation):
        return float("nan")


class Drifting(ForceEstimator):
    """Predicts the mean force; its stream adds 0.01 N per step."""

    def fit(self, U, y):
        self.mean_ = float(np.mean(y))
        return self

    def predict(self, U, y=None, *, mode=None):
        self._mode(mode, y)
        return np.full(np.asarray(U).shape[0], self.mean_)

    def streaming(self, mode="free_run", *, scaling=None, **options):
        value = self.mean_ if scaling is None else float(
            scaling.inverse_y(np.array([self.mean_]))[0])
        return DriftingStream(value)


class DriftingStream:
    def __init__(self, value):
        self.value, self.k = value, 0

    def reset(self):
        self.k = 0

    def step(self, u, y_prev=None):
        self.k += 1
        return self.value + 0.01 * self.k


register_controller("toy_forgetful", lambda plant, **spec: Forgetful(float(plant.dt)))
register_controller("toy_nan", lambda plant, **spec: Broken(float(plant.dt)))
register_estimator("toy_drifting", Drifting)
'''

#: What each faulty piece must be reported for: ``(family subject, check)``, the estimator
#: once for each of its modes (the stream drifts in both).
EXPECTED = [("controller toy_forgetful", "reset_reproduces"),
            ("controller toy_nan", "finite_output"),
            ("estimator toy_drifting", "stream_matches_predict"),
            ("estimator toy_drifting", "stream_matches_predict")]


def example_plugins() -> dict[str, str]:
    """``module name -> source`` of every plugin an example writes (a module-level string
    constant that calls a ``register_`` function), read from the examples' source."""
    found = {}
    for path in sorted((ROOT / "examples").glob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) \
                    and isinstance(node.value.value, str) and "register_" in node.value.value:
                found[f"example_{path.stem}_{node.targets[0].id.lower()}"] = node.value.value
    return found


@pytest.fixture
def plugin_dir(tmp_path, monkeypatch):
    """The toy plugin and the examples' plugins on ``sys.path``; everything removed after."""
    (tmp_path / "toy_faulty_plugin.py").write_text(textwrap.dedent(FAULTY_PLUGIN))
    examples = example_plugins()
    for module, source in examples.items():
        (tmp_path / f"{module}.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    controllers_before, estimators_before = controller_names(), estimator_names()
    yield tmp_path
    for name in set(controller_names()) - set(controllers_before):
        unregister_controller(name)
    for name in set(estimator_names()) - set(estimators_before):
        unregister_estimator(name)
    for module in ("toy_faulty_plugin", *examples):
        sys.modules.pop(module, None)


def _lines(failures) -> list[str]:
    return [f.line() for f in failures]


def test_the_python_checkers_report_each_fault_in_one_line_naming_its_check(plugin_dir):
    assert load_recorded(["toy_faulty_plugin"]) == ("toy_faulty_plugin",)
    assert plugin_registrations(["toy_faulty_plugin"]) == {
        "controller": ("toy_forgetful", "toy_nan"), "estimator": ("toy_drifting",),
        "object": (), "scenario kind": ()}
    found = {"controller toy_forgetful": check_controller("toy_forgetful"),
             "controller toy_nan": check_controller("toy_nan"),
             "estimator toy_drifting": check_estimator("toy_drifting")}
    reported = [(subject, f.check) for subject, failures in found.items() for f in failures]
    assert reported == EXPECTED, {k: _lines(v) for k, v in found.items()}
    for subject, failures in found.items():
        for failure in failures:
            line = failure.line()
            assert line.startswith(f"{subject}: {failure.check}: expected ") and ", found " in line
            assert "\n" not in line
    drift = [f.expected for f in found["estimator toy_drifting"]]
    assert [e.split(":")[0] for e in drift] == ["one_step", "free_run"]  # one line per mode


def test_the_cli_prints_one_line_per_failed_check_and_exits_2(plugin_dir, capsys):
    status = main(["--plugin", "toy_faulty_plugin", "check"])
    out, err = capsys.readouterr()
    assert status == 2, err
    lines = out.strip().splitlines()
    assert [tuple(line.split(": ")[:2]) for line in lines] == EXPECTED, out
    assert all(", found " in line for line in lines)
    assert err.startswith("griploop check: error: 4 checks failed on controller toy_forgetful, "
                          "controller toy_nan, estimator toy_drifting ")
    assert len(err.strip().splitlines()) == 1
    assert "toy_faulty_plugin registered 2 controllers, 1 estimator" in err


def test_the_examples_plugins_pass(plugin_dir, capsys):
    modules = sorted(example_plugins())
    assert modules, "no example registers a plugin"
    for module in modules:
        status = main(["--plugin", module, "check"])
        out, err = capsys.readouterr()
        assert status == 0, out + err
        assert out.startswith(f"griploop check: OK: {module} registered 1 ") and not err


def test_a_plugin_that_registers_nothing_checkable_is_ok(plugin_dir, capsys):
    (plugin_dir / "toy_section_plugin.py").write_text(
        "from scenarios.report.sections import register_section\n"
        "register_section('toy_check_section', lambda context: None, order=95)\n")
    try:
        status = main(["--plugin", "toy_section_plugin", "check"])
    finally:
        from scenarios.report.sections import unregister_section

        unregister_section("toy_check_section")
        sys.modules.pop("toy_section_plugin", None)
    out = capsys.readouterr().out
    assert status == 0 and out.startswith("griploop check: OK: nothing to check"), out
