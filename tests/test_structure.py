"""The code's shape: modules with one job each, as issue 19 set the limits."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("sim", "estimation", "controllers", "scenarios")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 100


def _modules() -> list[Path]:
    return sorted(p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py"))


def test_the_packages_hold_modules():
    assert len(_modules()) > 100


@pytest.mark.parametrize("path", _modules(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_module_over_600_lines_and_no_function_over_100(path):
    text = path.read_text(encoding="utf-8")
    assert text.count("\n") <= MAX_MODULE_LINES, f"{path.name}: {text.count(chr(10))} lines"
    long = [(node.name, node.end_lineno - node.lineno + 1) for node in ast.walk(ast.parse(text))
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert long == []


# ----------------------------------------------------------------- one trial loop (issue 33)
def _scenario_calls():
    for path in sorted((ROOT / "scenarios").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            yield path.relative_to(ROOT), node


def test_no_trial_chooses_by_an_operators_type_or_probes_its_attributes():
    """Every operator has the protocol's members (sim.user.operators completes a plugin's):
    the trial reads them, it does not ask what the operator is."""
    found = []
    for path, node in _scenario_calls():
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.args:
            first = ast.unparse(node.args[0]).lower()
            if node.func.id in ("getattr", "hasattr") and "operator" in first:
                found.append(f"{path}:{node.lineno} {ast.unparse(node)}")
            if node.func.id == "isinstance" and "operator" in ast.unparse(node.args[-1]).lower():
                found.append(f"{path}:{node.lineno} {ast.unparse(node)}")
        if isinstance(node, ast.Compare) and "type(" in ast.unparse(node) and \
                "operator" in ast.unparse(node).lower():
            found.append(f"{path}:{node.lineno} {ast.unparse(node)}")
    assert found == []


def test_the_arm_has_one_route_and_the_referee_one_ending():
    """No trial lifts on the environment's schedule or ends on its drop flag; the one trial
    loop makes the environment, its wrist commanded."""
    loop = Path("scenarios/runners/trial_loop.py")
    found = [f"{path}:{node.lineno} {ast.unparse(node)[:80]}" for path, node in _scenario_calls()
             if path != loop and isinstance(node, ast.Call) and (
                 any(k.arg in ("lift_after_s", "terminate_on_drop", "schedule", "wrist")
                     for k in node.keywords)
                 or (isinstance(node.func, ast.Name) and node.func.id == "WristSchedule"))]
    assert found == []


@pytest.mark.parametrize("module, function", [("scenarios/runners/episode.py", "run_episode"),
                                              ("scenarios/runners/trial.py", "run_trial")])
def test_the_trial_runners_take_a_spec_and_few_options(module, function):
    tree = ast.parse((ROOT / module).read_text(encoding="utf-8"))
    (node,) = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and n.name == function]
    assert len(node.args.args) + len(node.args.kwonlyargs) <= 6
