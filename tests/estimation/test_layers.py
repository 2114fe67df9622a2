"""The layer rules of the design (DESIGN.md), read from the import statements of the source.

``estimation`` computes from recordings and features: it may import ``sim`` for the types
it exchanges, its errors and its registry, never the virtual users or the hand
(``sim.user``, ``sim.hand``), the controllers or the scenarios, which orchestrate it.
``sim`` is the bottom layer and imports none of the other packages. Every import
statement counts, at the top of a module or inside a function.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: package -> module prefixes its source must not import.
FORBIDDEN = {
    "estimation": ("sim.user", "sim.hand", "controllers", "scenarios"),
    "sim": ("estimation", "controllers", "scenarios"),
}


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """``(line, module)`` of every ``import`` and ``from ... import`` in a file.

    ``from package import name`` counts as ``package.name`` too, so that
    ``from sim import user`` is seen as importing ``sim.user``.
    """
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.lineno, node.module))
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


def _violations(package: str) -> list[str]:
    bad = []
    for path in sorted((ROOT / package).rglob("*.py")):
        for line, module in imported_modules(path):
            if any(module == p or module.startswith(p + ".") for p in FORBIDDEN[package]):
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    return bad


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_package_imports_only_the_layers_below(package: str) -> None:
    assert _violations(package) == []


def test_the_check_sees_imports_inside_functions(tmp_path: Path) -> None:
    path = tmp_path / "m.py"
    path.write_text("def f():\n    from sim import user\n    import scenarios.cli\n")
    modules = [m for _, m in imported_modules(path)]
    assert "sim.user" in modules and "scenarios.cli" in modules
