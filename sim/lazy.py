"""Package attributes imported on first use (PEP 562), so that importing a package stays light."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, table: Mapping[str, str]) -> Callable[[str], Any]:
    """A module ``__getattr__`` that imports ``table[name]`` when ``package.name`` is read.

    Parameters
    ----------
    package : str
        The package's name, for the error message.
    table : mapping
        Public name -> module that defines it.

    Returns
    -------
    callable
        ``__getattr__(name)``, raising :class:`AttributeError` for names not in ``table``.
    """

    def __getattr__(name: str) -> Any:
        if name in table:
            return getattr(importlib.import_module(table[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__
