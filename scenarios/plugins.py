"""Plugins: modules outside griploop that register controllers, estimators, objects, kinds.

A plugin is an importable module whose import registers something through a
registry's public call (:func:`controllers.registry.register_controller`,
:func:`estimation.registry.register_estimator`,
:func:`sim.hand.objects.register_object`,
:func:`scenarios.runners.dispatch.register_kind`, ...). The command line loads
them with ``griploop --plugin MODULE COMMAND ...``; a sweep file with a
top-level ``plugins: [MODULE, ...]``, in the driver and in every worker (local
workers are forked after the driver loaded them; a Dask worker loads them
before its first scenario).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Iterable

from sim.errors import GriploopError
from sim.registry import Registry


class PluginError(GriploopError, ValueError):
    """A plugin module does not import, or registers nothing."""


def load_plugins(modules: Iterable[str]) -> tuple[str, ...]:
    """Import every plugin module once, in order.

    Parameters
    ----------
    modules : iterable of str
        Dotted module names, importable from ``sys.path`` (the current
        directory included, as ``python -m`` would).

    Returns
    -------
    tuple of str
        The modules, as loaded.

    Raises
    ------
    PluginError
        A module that fails to import (the message carries the module's own
        error), or whose first import registered nothing.
    """
    loaded = []
    if "" not in sys.path:  # a plugin beside the user's files, as `python -m` finds it
        sys.path.insert(0, "")
    for name in modules:
        if not isinstance(name, str) or not name.strip():
            raise PluginError(f"plugin: expected a module name, found {name!r}")
        name = name.strip()
        if name in sys.modules:  # loaded already (by this call or another): registered then
            loaded.append(name)
            continue
        before = Registry.registrations
        try:
            importlib.import_module(name)
        except Exception as exc:  # the module's own error, in one line
            detail = str(exc).splitlines()[0] if str(exc) else ""
            raise PluginError(f"plugin {name}: cannot import: {type(exc).__name__}: "
                              f"{detail}") from None
        if Registry.registrations == before:
            sys.modules.pop(name, None)  # so that a fixed module can be loaded again
            raise PluginError(f"plugin {name}: imported, but registered nothing (a plugin "
                              "calls register_controller, register_estimator, "
                              "register_object, register_kind, ... when imported)")
        loaded.append(name)
    return tuple(loaded)
