"""Deferred imports: a module that is imported only when one of its attributes is used.

python-control imports ``matplotlib`` and ``matplotlib.pyplot`` when it is
imported (its plotting modules do ``import matplotlib.pyplot as plt`` at the
top), which costs a quarter of a second and tens of MB in every process that
designs or analyses a controller, although only reports and ``plot`` commands
draw figures.
:func:`defer_module` puts a stand-in in ``sys.modules``: ``import
matplotlib.pyplot as plt`` then binds the stand-in, and the real module is
imported on the first attribute looked up through it (``plt.figure``), after
which every lookup goes to the real module.

(:class:`importlib.util.LazyLoader` does not serve here: the import system
reads ``__spec__`` of a module found in ``sys.modules``, which loads it.)
Only the ``griploop`` process itself defers (:func:`scenarios.cli.main.entry`,
before any command is imported; sweep workers are forked from it): importing
griploop's packages as a library changes nothing in the importing process.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
from typing import Any


class DeferredModule(types.ModuleType):
    """Stand-in for a module not imported yet; imports it on first attribute use.

    A stand-in for a package has the package's ``__path__``, so that ``import
    package.sub`` finds the submodule (itself deferred, or imported for real).
    """

    def __init__(self, name: str, spec: Any, functions: frozenset[str] = frozenset()) -> None:
        super().__init__(name)
        self.__spec__ = spec
        self.__deferred_real__: types.ModuleType | None = None
        self.__deferred_functions__ = functions
        if spec.submodule_search_locations is not None:
            self.__path__ = list(spec.submodule_search_locations)

    def _real(self) -> types.ModuleType:
        real = self.__dict__.get("__deferred_real__")
        if real is None:
            name = self.__name__
            parent_name, _, child = name.rpartition(".")
            parent = sys.modules.get(parent_name) if parent_name else None
            if isinstance(parent, DeferredModule):
                parent = parent._real()  # the real package first: it runs its __init__
            if sys.modules.get(name) is self:
                del sys.modules[name]
            real = importlib.import_module(name)
            self.__dict__["__deferred_real__"] = real
            if parent is not None and getattr(parent, child, None) is not real:
                setattr(parent, child, real)
            for attr, value in list(vars(self).items()):  # submodules bound on the stand-in
                if isinstance(value, DeferredModule) and not hasattr(real, attr):
                    setattr(real, attr, value)
        return real

    def __getattr__(self, attr: str) -> Any:
        if attr.startswith("__") and attr.endswith("__"):
            # the import system probes __file__, __path__, __cached__...: not a use
            raise AttributeError(attr)
        if attr in self.__deferred_functions__ and self.__dict__["__deferred_real__"] is None:
            return self._deferred_function(attr)  # ``from module import f``: not a use yet
        return getattr(self._real(), attr)

    def _deferred_function(self, attr: str) -> Any:
        def call(*args: Any, **kwargs: Any) -> Any:
            return getattr(self._real(), attr)(*args, **kwargs)

        call.__name__ = call.__qualname__ = attr
        call.__doc__ = f"{self.__name__}.{attr}, imported on the first call."
        return call

    def __dir__(self) -> list[str]:
        return dir(self._real())


class _StandInLoader(importlib.abc.Loader):
    """Creates a :class:`DeferredModule` instead of executing the module."""

    def __init__(self, functions: frozenset[str]) -> None:
        self.functions = functions

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        return DeferredModule(spec.name, spec, self.functions)

    def exec_module(self, module: types.ModuleType) -> None:
        """Nothing to run: the real module runs on first use."""


class _Loaded(importlib.abc.Loader):
    """Hands out a module that is already in ``sys.modules`` (and keeps its own spec)."""

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        module = sys.modules[spec.name]
        self._spec = module.__spec__
        return module

    def exec_module(self, module: types.ModuleType) -> None:
        module.__spec__ = self._spec  # the import system set it to the spec made here


class _DeferringFinder(importlib.abc.MetaPathFinder):
    """Answers the first import of each deferred name with a stand-in."""

    def __init__(self) -> None:
        self.names: dict[str, frozenset[str]] = {}

    def find_spec(self, fullname: str, path: Any, target: Any = None
                  ) -> importlib.machinery.ModuleSpec | None:
        parent = sys.modules.get(fullname.rpartition(".")[0])
        if isinstance(parent, DeferredModule) and fullname not in self.names:
            # a submodule that is not deferred (matplotlib.figure): its package runs first,
            # as in a normal import, and may import the submodule itself on the way
            parent._real()
            if fullname in sys.modules:
                return importlib.machinery.ModuleSpec(fullname, _Loaded())
            return None
        if fullname not in self.names:
            return None
        functions = self.names.pop(fullname)  # the real import, later, goes to the normal finders
        # where the real module lives (found, not run): a package's stand-in needs its path
        real = importlib.machinery.PathFinder.find_spec(fullname, path)
        spec = importlib.machinery.ModuleSpec(fullname, _StandInLoader(functions),
                                              is_package=real is not None
                                              and real.submodule_search_locations is not None)
        if spec.submodule_search_locations is not None:
            spec.submodule_search_locations[:] = real.submodule_search_locations
        return spec


_FINDER = _DeferringFinder()


#: What griploop defers (:func:`defer_plotting`), with the functions other modules take
#: from them at import time: python-control imports matplotlib, pyplot and matplotlib's
#: transforms and its pole-zero grids (which pull matplotlib's axes and axisartist) for its
#: plots; scipy.signal (which python-control imports) takes one function of scipy.stats for
#: its peak finder, scikit-learn two. matplotlib itself (its rc parameters, colors and fonts)
#: costs a tenth of a second: a process that draws nothing does not load it.
PLOTTING = (("matplotlib", ()), ("matplotlib.pyplot", ()), ("matplotlib.transforms", ()),
            ("control.grid", ("nogrid", "sgrid", "zgrid")),
            ("scipy.stats", ("scoreatpercentile", "rankdata", "spearmanr")))


def defer_plotting() -> None:
    """Defer the modules of :data:`PLOTTING` until they are used (a figure is drawn)."""
    for name, functions in PLOTTING:
        defer_module(name, functions)


def defer_module(name: str, functions: tuple[str, ...] = ()) -> bool:
    """Defer ``name`` (e.g. ``"matplotlib.pyplot"``): its first import binds a stand-in.

    Costs nothing now (nothing is imported); the first ``import name`` anywhere
    gets a :class:`DeferredModule`, which imports the real module on its first
    attribute use. ``functions`` are names that ``from name import f`` may take
    without using them: they are handed out as wrappers that import the module
    when called. No effect if ``name`` is already imported.

    Returns
    -------
    bool
        Whether ``name`` is now deferred.
    """
    if name in sys.modules:
        return False
    _FINDER.names[name] = frozenset(functions)
    if _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)
    return True
