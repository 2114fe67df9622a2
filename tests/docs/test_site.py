"""The documentation site builds with warnings as errors, and its API reference is whole.

The build runs as ``make docs`` does (``sphinx -W --keep-going -n``: a docstring that
refers to a griploop name that does not exist fails it), on a copy of ``docs/`` and
``examples/`` so the working tree is left as it was; the examples run in it.
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("sim", "estimation", "controllers", "scenarios")
GENERATED = ("_build", "api", "auto_examples", "sg_execution_times.rst")


def sphinx(source: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    """``python -m sphinx -b html -W --keep-going -n -q -N SOURCE OUT``, output captured.

    ``-N`` (no colour) and ``NO_COLOR`` keep the messages plain whatever the terminal or
    ``FORCE_COLOR`` of the machine running the suite says.
    """
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), MPLBACKEND="Agg",
               NO_COLOR="1")
    env.pop("FORCE_COLOR", None)
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-n", "-q", "-N",
         *extra, str(source), str(out)],
        capture_output=True, text=True, env=env, timeout=600)


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built from a copy of docs/, examples/ and the changelog."""
    root = tmp_path_factory.mktemp("site")
    shutil.copytree(ROOT / "docs", root / "docs", ignore=shutil.ignore_patterns(*GENERATED))
    shutil.copytree(ROOT / "examples", root / "examples")
    shutil.copy(ROOT / "CHANGELOG.md", root / "CHANGELOG.md")
    done = sphinx(root / "docs", root / "html")
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-20000:]
    return root / "html"


def public_callables() -> list[str]:
    """``module.name`` of every public function and class, and ``module.Class.method`` of
    every public method, defined in the four packages (read from the source)."""
    names = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__main__":
                continue
            module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            for node in ast.parse(path.read_text(encoding="utf-8")).body:
                if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) \
                        or node.name.startswith("_"):
                    continue
                names.append(f"{module}.{node.name}")
                if isinstance(node, ast.ClassDef):
                    names += [f"{module}.{node.name}.{item.name}" for item in node.body
                              if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef))
                              and not item.name.startswith("_")]
    return names


@pytest.mark.slow
def test_the_site_builds_without_a_warning_and_runs_the_examples(site):
    assert (site / "index.html").is_file()
    for page in ("GETTING_STARTED", "COMMANDS", "EXTENDING", "results/reproduction",
                 "results/speed", "changelog", "api"):
        assert (site / f"{page}.html").is_file(), page
    examples = sorted(p.stem for p in (ROOT / "examples").glob("plot_*.py"))
    assert len(examples) >= 4
    for name in examples:  # each ran: its page holds its output
        page = (site / "auto_examples" / f"{name}.html").read_text(encoding="utf-8")
        assert "sphx-glr-script-out" in page, name


@pytest.mark.slow
def test_every_guide_beside_the_configuration_is_a_page(site):
    guides = sorted(p.stem for p in (ROOT / "docs").glob("*.md"))
    assert {"SUBJECTS", "OPERATOR", "ESTIMATION", "HAND", "CONTROL", "FORMAT", "DEPLOY"} \
        <= set(guides)
    assert [g for g in guides if not (site / f"{g}.html").is_file()] == []


@pytest.mark.slow
def test_the_api_reference_covers_every_public_callable(site):
    from sphinx.util.inventory import InventoryFile

    with open(site / "objects.inv", "rb") as fh:
        inventory = InventoryFile.load(fh, "", lambda base, uri: uri)
    documented = {name for entries in inventory.data.values() for name in entries} \
        if hasattr(inventory, "data") else {n for e in inventory.values() for n in e}
    wanted = public_callables()
    assert len(wanted) > 1000
    assert [name for name in wanted if name not in documented] == []


BAD_MODULE = '''
"""A module whose docstrings refer to names."""


def broken():
    """Return nothing.

    Parameters
    ----------
    none

    Notes
    -----
    Calls :func:`sim.hand.grasp_env.no_such_function`, which does not exist.
    """


def fine():
    """Return :class:`numpy.ndarray` and :class:`control.StateSpace` (no inventory
    offline), and a :class:`sim.errors.GriploopError`."""
'''


def test_a_reference_to_a_griploop_name_that_does_not_exist_fails_with_file_and_line(tmp_path):
    (tmp_path / "refmod.py").write_text(BAD_MODULE)
    (tmp_path / "conf.py").write_text(textwrap.dedent(f'''
        import runpy, sys
        globals().update({{k: v for k, v in runpy.run_path({str(ROOT / "docs" / "conf.py")!r})
                           .items() if not k.startswith("__")}})
        sys.path.insert(0, {str(tmp_path)!r})
        extensions = [e for e in extensions if e != "sphinx_gallery.gen_gallery"]
        '''))
    (tmp_path / "index.rst").write_text("Refs\n====\n\n.. automodule:: refmod\n\n"
                                        ".. autoexception:: sim.errors.GriploopError\n")
    done = sphinx(tmp_path, tmp_path / "html")
    assert done.returncode != 0
    warnings = [line for line in done.stderr.splitlines() if "WARNING" in line]
    assert len(warnings) == 1, done.stderr  # numpy, control pass; GriploopError resolves
    line = BAD_MODULE.splitlines().index(
        "    Calls :func:`sim.hand.grasp_env.no_such_function`, which does not exist.") + 1
    assert warnings[0].startswith(
        f"{tmp_path / 'refmod.py'}:{line} (docstring of refmod.broken): WARNING: "
        "py:func reference target not found: sim.hand.grasp_env.no_such_function"), warnings[0]
