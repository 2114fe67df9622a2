"""What griploop's documentation build adds to Sphinx (loaded by ``docs/conf.py``).

- A warning about a reference in a docstring names the line of the source file that holds
  it (``sim/foo.py:123 (docstring of sim.foo.bar)``) rather than a line of the docstring
  as numpydoc rewrote it.
- The API reference lists a class's own members, not what it inherits from another
  project (scikit-learn's ``set_fit_request``), and no type aliases (they have no
  signature to show).
- autosummary documents a griploop name that is a module as that module, even where its
  package re-exports a function of the same name (``scenarios.cli.main``).
- numpydoc's docstring template is compiled once per builder: numpydoc 1.11 makes a new
  Jinja environment and compiles the template for every docstring it renders (6,800 in
  this site, 20 s of a 60 s build). The rendering is numpydoc's own
  (``get_doc_object_orig`` with its classes), given the template it would have compiled.
"""

from __future__ import annotations

import ast
import importlib
import logging
import re
import types
from functools import cache
from pathlib import Path

import sphinx.ext.autosummary as autosummary
from sphinx.util.logging import WarningLogRecordTranslator

OURS = ("sim", "estimation", "controllers", "scenarios")

_DOCSTRING_AT = re.compile(r"^(?P<path>.+\.py):docstring of (?P<name>[\w.]+):\d+$")
_TARGET = re.compile(r"reference target not found: (?P<target>\S+)")


@cache
def _tree(path: str) -> ast.Module:
    return ast.parse(Path(path).read_text(encoding="utf-8"))


def _span(path: str, name: str) -> tuple[int, int] | None:
    """First and last line of the docstring (or ``#:`` comment block) of ``name``."""
    tree = _tree(path)
    parts = name.split(".")
    for start in range(len(parts) + 1):  # the module's own dotted name is a prefix
        node: ast.AST = tree
        for part in parts[start:]:
            found = [n for n in getattr(node, "body", [])
                     if getattr(n, "name", None) == part
                     or isinstance(n, (ast.Assign, ast.AnnAssign)) and part in
                     [t.id for t in (n.targets if isinstance(n, ast.Assign) else [n.target])
                      if isinstance(t, ast.Name)]]
            if not found:
                break
            node = found[0]
        else:
            if isinstance(node, (ast.Assign, ast.AnnAssign)):
                return max(1, node.lineno - 20), node.end_lineno
            doc = node.body[0] if getattr(node, "body", None) else None
            if isinstance(doc, ast.Expr) and isinstance(doc.value, ast.Constant):
                return doc.lineno, doc.end_lineno
    return None


def source_line(path: str, name: str, text: str) -> int | None:
    """The line of ``path`` within ``name``'s docstring that holds ``text``, if any."""
    span = _span(path, name)
    if span is None:
        return None
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    for number in range(span[0], span[1] + 1):
        if text in lines[number - 1]:
            return number
    return None


class SourceLines(logging.Filter):
    """Point a docstring's unresolved reference at its line in the source file."""

    def filter(self, record: logging.LogRecord) -> bool:
        where = _DOCSTRING_AT.match(str(getattr(record, "location", "") or ""))
        target = _TARGET.search(str(record.msg) % record.args if record.args else str(record.msg))
        if where and target:
            line = source_line(where["path"], where["name"], target["target"])
            if line is not None:
                record.location = f"{where['path']}:{line} (docstring of {where['name']})"
        return True


def skip_foreign_members(app, what, name, obj, skip, options):
    """Leave out what a class gets from another project, and type aliases."""
    module = getattr(obj, "__module__", None) or ""
    if what == "class" and callable(obj) and module and module.split(".")[0] not in OURS:
        return True
    if isinstance(obj, types.GenericAlias):
        return True
    return None


_import_by_name = autosummary._import_by_name


def _modules_first(name, grouped_exception=True):
    found = _import_by_name(name, grouped_exception)
    if isinstance(found[0], types.ModuleType) or name.split(".")[0] not in OURS:
        return found
    try:
        return importlib.import_module(name), None, name
    except ImportError:  # not a module: the object found
        return found


def _compiled_template(builder):
    """numpydoc's ``numpydoc_docstring.rst``, loaded as numpydoc loads it, once per builder."""
    import os

    from jinja2 import FileSystemLoader
    from jinja2.sandbox import SandboxedEnvironment
    from numpydoc import docscrape_sphinx
    from sphinx.jinja2glue import BuiltinTemplateLoader

    key = id(builder)
    if key not in _TEMPLATES:
        dirs = [os.path.join(os.path.dirname(docscrape_sphinx.__file__), "templates")]
        if builder is not None:
            loader = BuiltinTemplateLoader()
            loader.init(builder, dirs=dirs)
        else:
            loader = FileSystemLoader(dirs)
        _TEMPLATES[key] = (builder, SandboxedEnvironment(loader=loader).get_template(
            "numpydoc_docstring.rst"))
    return _TEMPLATES[key][1]


_TEMPLATES: dict[int, tuple[object, object]] = {}  # the builder kept alive beside its id


def numpydoc_doc_object(obj, what=None, doc=None, config=None, builder=None):
    """``numpydoc.docscrape_sphinx.get_doc_object`` with the template compiled once."""
    from numpydoc import docscrape_sphinx as ds

    config = {} if config is None else config
    config["template"] = _compiled_template(builder)
    return ds.get_doc_object_orig(obj, what=what, doc=doc, config=config,
                                  class_doc=ds.SphinxClassDoc, func_doc=ds.SphinxFunctionDoc,
                                  obj_doc=ds.SphinxObjDoc)


def setup(app):
    import numpydoc.numpydoc

    # what numpydoc's own setup(app, get_doc_object_=...) sets: the function it renders with
    numpydoc.numpydoc.get_doc_object = numpydoc_doc_object
    autosummary._import_by_name = _modules_first
    app.connect("autodoc-skip-member", skip_foreign_members)
    for handler in logging.getLogger("sphinx").handlers:
        if any(isinstance(f, WarningLogRecordTranslator) for f in handler.filters):
            handler.addFilter(SourceLines())
    return {"parallel_read_safe": True, "parallel_write_safe": True}
