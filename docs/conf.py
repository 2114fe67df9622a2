"""Sphinx configuration of griploop's documentation site (``make docs``).

The site is built from this folder: the guides are the Markdown files beside this one
(read by MyST), the API reference is generated from the docstrings of the four packages
(autosummary, recursive; numpydoc), and the example gallery runs ``examples/*.py``
(sphinx-gallery). The build needs no network: nothing is fetched through intersphinx,
and the names of other projects that the docstrings mention are listed in
``nitpick_ignore_regex`` below, so that a reference to a griploop name that does not
exist fails a build run with ``-W``.
"""

from __future__ import annotations

import builtins
import os
import sys
from importlib.metadata import version as _version
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))
# headless: the gallery renders the hand and draws figures without a display
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")

project = "griploop"
author = "griploop developers"
copyright = "2026, griploop developers"  # noqa: A001 (Sphinx's name)
release = _version("griploop")
version = ".".join(release.split(".")[:2])

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "griploop_sphinx",  # docs/_ext: source lines in warnings, members listed, modules first
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_templates", "auto_examples/*.ipynb",
                    "auto_examples/*.py", "auto_examples/*.zip"]
templates_path = ["_templates"]
suppress_warnings: list[str] = []

# ---------------------------------------------------------------- MyST (the guides)
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 4  # "#a-heading" links between the guides resolve

# ---------------------------------------------------------------- API reference
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {
    "members": True,
    "undoc-members": True,
    "show-inheritance": True,
    "member-order": "bysource",
}
autodoc_typehints = "none"  # numpydoc sections give the types (with units)
autodoc_class_signature = "mixed"
autodoc_inherit_docstrings = True
numpydoc_show_class_members = False  # autodoc lists the members once
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()

# ---------------------------------------------------------------- cross-references
# Every reference to a griploop name must resolve (the test build runs with -W). Names
# of Python itself and of other projects have no inventory offline: they are accepted
# here by their prefix, so a misspelt griploop name still fails the build.
nitpicky = True
_THIRD_PARTY = (
    "numpy", "np", "scipy", "control", "ct", "mujoco", "gymnasium", "gym", "sklearn",
    "casadi", "daqp", "dask", "distributed", "pydantic", "yaml", "pyarrow", "pa", "tqdm",
    "jinja2", "pylsl", "matplotlib", "PIL", "osqp", "proxsuite", "numpy.typing", "npt",
    # the standard library
    "pathlib", "typing", "collections", "os", "sys", "io", "re", "json", "sqlite3",
    "subprocess", "multiprocessing", "concurrent", "threading", "signal", "argparse",
    "dataclasses", "enum", "abc", "contextlib", "functools", "itertools", "types",
    "datetime", "time", "logging", "tempfile", "shutil", "socket", "importlib", "ctypes",
    "queue", "random", "string", "textwrap", "numbers", "hashlib", "zipfile", "csv",
    "urllib", "weakref", "warnings", "inspect", "traceback", "fractions", "decimal",
    "math", "statistics", "typing_extensions", "_io", "builtins", "collections.abc",
)
_BUILTIN_NAMES = sorted(name for name in dir(builtins) if not name.startswith("_"))
nitpick_ignore_regex = [
    # private names (a module's own helpers) are not documented
    (r"py:.*", r"(.*\.)?_[A-Za-z].*"),
    (r"py:.*", rf"({'|'.join(_THIRD_PARTY)})(\..*)?"),
    (r"py:.*", rf"({'|'.join(_BUILTIN_NAMES)})"),
]

# ---------------------------------------------------------------- the gallery
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "only_warn_on_example_error": False,
    "within_subsection_order": "FileNameSortKey",
    "matplotlib_animations": False,
    "plot_gallery": True,  # -D plot_gallery=0 builds without running them
}

# ---------------------------------------------------------------- HTML
html_theme = "alabaster"
html_title = f"griploop {release}"
html_static_path: list[str] = []
html_theme_options = {
    "description": "Simulation-in-the-loop testbed for myoelectric grip control",
    "fixed_sidebar": True,
    "page_width": "1200px",
    "sidebar_width": "260px",
}
