"""The modules as a graph of import statements, read from the source (tests/test_structure.py).

Every ``import`` counts: at the top of a module, inside a function, under
``if TYPE_CHECKING:``. ``from a.b import c`` is an edge to the module ``a.b.c`` when
that is a module, else to ``a.b``; importing a submodule is not counted as importing its
package's ``__init__``, so a package that re-exports its modules is not a circle by itself.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ImportedName:
    """One ``from MODULE import NAME`` (or ``MODULE.NAME`` on an imported module) in a module."""

    module: str  #: the importing module
    line: int
    source: str  #: the module imported from
    name: str


def module_name(root: Path, path: Path) -> str:
    """``sim/user/subjects.py`` -> ``sim.user.subjects``; a package's ``__init__``: the package."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


class ImportGraph:
    """Modules of ``packages`` under ``root`` and the import edges between them."""

    def __init__(self, root: Path, packages: tuple[str, ...]) -> None:
        self.root = root
        self.paths = {module_name(root, p): p
                      for pkg in packages for p in sorted((root / pkg).rglob("*.py"))}
        self.edges: dict[str, set[str]] = {m: set() for m in self.paths}
        self.names: list[ImportedName] = []
        for module in self.paths:
            self._read(module)

    def _absolute(self, module: str, node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        package = module.split(".")
        if self.paths[module].name != "__init__.py":
            package = package[:-1]
        package = package[:len(package) - (node.level - 1)]
        return ".".join(package + ([node.module] if node.module else []))

    def _read(self, module: str) -> None:
        tree = ast.parse(self.paths[module].read_text(encoding="utf-8"))
        aliases: dict[str, str] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in self.paths:
                        self.edges[module].add(alias.name)
                        if alias.asname:
                            aliases[alias.asname] = alias.name
            elif isinstance(node, ast.ImportFrom):
                source = self._absolute(module, node)
                for alias in node.names:
                    full = f"{source}.{alias.name}"
                    if full in self.paths:
                        self.edges[module].add(full)
                        aliases[alias.asname or alias.name] = full
                    elif source in self.paths:
                        self.edges[module].add(source)
                        self.names.append(ImportedName(module, node.lineno, source, alias.name))
        for node in ast.walk(tree):  # module._name, on a module imported by name
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in aliases):
                self.names.append(ImportedName(module, node.lineno, aliases[node.value.id],
                                               node.attr))

    def circles(self) -> list[list[str]]:
        """Every set of two or more modules that import each other (Tarjan's components)."""
        index: dict[str, int] = {}
        low: dict[str, int] = {}
        stack: list[str] = []
        found: list[list[str]] = []

        def visit(v: str) -> None:
            index[v] = low[v] = len(index)
            stack.append(v)
            for w in sorted(self.edges[v] - {v}):
                if w not in index:
                    visit(w)
                    low[v] = min(low[v], low[w])
                elif w in stack:
                    low[v] = min(low[v], index[w])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))

        for v in sorted(self.paths):
            if v not in index:
                visit(v)
        return found

    def private_imports(self) -> Iterator[ImportedName]:
        """Names starting with one ``_`` that a module takes from another module."""
        for imported in self.names:
            if (imported.name.startswith("_") and not imported.name.startswith("__")
                    and imported.source != imported.module):
                yield imported
