"""Register griploop's Gymnasium ids whenever ``gymnasium`` is imported, without importing griploop.

Gymnasium 1.x has no plugin discovery (the ``gymnasium.envs`` entry points of
0.26-0.29 were removed), so ``gymnasium.make("griploop/GraspLift-v0")`` would
need ``import sim`` first. The installed ``griploop-gymnasium.pth`` calls
:func:`install` at interpreter start-up: it costs one small import and puts a
finder on :data:`sys.meta_path` that, once ``gymnasium`` has been imported,
registers the ids below with string entry points (nothing of griploop is
imported until an environment is made). :mod:`sim.hand.registration` registers the
same ids when ``sim.hand`` is imported first.
"""

from __future__ import annotations

import sys
from importlib.abc import Loader, MetaPathFinder
from importlib.machinery import ModuleSpec
from types import ModuleType
from typing import Any

#: Environment id -> entry point (kept equal to :mod:`sim.hand.registration`; a test checks).
ENVIRONMENTS = {"griploop/GraspLift-v0": "sim.hand.grasp_env:GraspEnv"}


def register(gymnasium: Any) -> None:
    """Register :data:`ENVIRONMENTS` that ``gymnasium``'s registry does not have yet."""
    for env_id, entry_point in ENVIRONMENTS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point)


class _Loader(Loader):
    def __init__(self, loader: Loader) -> None:
        self._loader = loader

    def create_module(self, spec: ModuleSpec) -> ModuleType | None:
        return self._loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self._loader.exec_module(module)
        try:
            register(module)
        except Exception:  # noqa: BLE001  (never break ``import gymnasium``)
            pass

    def __getattr__(self, name: str) -> Any:  # resources, get_source, ...
        return getattr(self._loader, name)


class _Finder(MetaPathFinder):
    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> ModuleSpec | None:
        if fullname != "gymnasium":
            return None
        for finder in sys.meta_path:  # whoever would have found it without us
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None and spec.loader is not None:
                spec.loader = _Loader(spec.loader)
                return spec
        return None


def install() -> None:
    """Register now if gymnasium is loaded, else when it is first imported (idempotent)."""
    if "gymnasium" in sys.modules:
        register(sys.modules["gymnasium"])
    elif not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())
