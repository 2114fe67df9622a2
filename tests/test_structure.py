"""The code's shape: modules with one job each, as issue 19 set the limits."""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path

import pytest
from import_graph import ImportGraph, module_name

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


# ------------------------------------------------------ a house a contributor can work in (34)
MAX_PARAMETERS = 8
#: Layers a package may not import, by name or by a ``"module:attribute"`` string
#: (tests/estimation/test_layers.py reads the import statements).
LOWER_LAYERS = {"sim": ("estimation", "controllers", "scenarios"),
                "estimation": ("sim.user", "sim.hand", "controllers", "scenarios")}


def _graph() -> ImportGraph:
    return ImportGraph(ROOT, PACKAGES)


def test_no_import_circle_inside_the_packages():
    assert _graph().circles() == []


def test_no_private_name_is_imported_across_modules():
    assert [f"{i.module}:{i.line} takes {i.source}.{i.name}"
            for i in _graph().private_imports()] == []


def _strings(path: Path):
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            yield node.lineno, node.value


@pytest.mark.parametrize("package", sorted(LOWER_LAYERS))
def test_no_layer_is_crossed_by_a_string_reference(package):
    """A ``"scenarios.runners.x:f"`` string in estimation would import a layer above it
    when resolved, out of sight of the import check."""
    above = "|".join(re.escape(p) for p in LOWER_LAYERS[package])
    reference = re.compile(rf"^({above})(\.\w+)*(:\w+)?$")
    found = [f"{path.relative_to(ROOT)}:{line} {text!r}"
             for path in sorted((ROOT / package).rglob("*.py"))
             for line, text in _strings(path) if reference.match(text) and "." in text]
    assert found == []


def _parameters(node: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    args = node.args
    return [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)
            if a.arg not in ("self", "cls")]


def _is_scikit_learn_estimator(module: str, class_name: str) -> bool:
    from sklearn.base import BaseEstimator

    cls = getattr(importlib.import_module(module), class_name, None)
    return isinstance(cls, type) and issubclass(cls, BaseEstimator)


def test_no_function_takes_more_than_8_parameters():
    """Except the ``__init__`` of an estimator, whose parameters are its hyperparameters
    (scikit-learn's convention: ``get_params`` reads them from the signature)."""
    found = []
    for path in _modules():
        module = module_name(ROOT, path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        classes = {id(f): c.name for c in ast.walk(tree) if isinstance(c, ast.ClassDef)
                   for f in c.body}
        for node in ast.walk(tree):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            n = len(_parameters(node))
            if n <= MAX_PARAMETERS:
                continue
            owner = classes.get(id(node))
            if node.name == "__init__" and owner and _is_scikit_learn_estimator(module, owner):
                continue
            found.append(f"{path.relative_to(ROOT)}:{node.lineno} {owner or ''}"
                         f"{'.' if owner else ''}{node.name} ({n})")
    assert found == []


def test_the_structure_checks_see_circles_private_imports_and_long_signatures(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from pkg.b import _hidden\n")
    (pkg / "b.py").write_text("def f():\n    from pkg import a\n_hidden = 1\n")
    (pkg / "c.py").write_text("import pkg.b as b\nx = b._hidden\n")
    graph = ImportGraph(tmp_path, ("pkg",))
    assert graph.circles() == [["pkg.a", "pkg.b"]]
    assert {(i.module, i.name) for i in graph.private_imports()} == {
        ("pkg.a", "_hidden"), ("pkg.c", "_hidden")}
    (node,) = ast.parse("def f(self, a, b, c, d, e, f, g, h, *, i): pass").body
    assert len(_parameters(node)) == 9
