"""Pretraining corpora by name: what :mod:`estimation.transfer` pretrains its networks on.

A corpus is a function ``builder(*, n_inputs, n_subjects, seed, population)`` returning,
per subject, normalized features ``U`` (n_windows, n_inputs), normalized force ``y``
(n_windows,) and the number of identification windows ``n_id``. Recording subjects is the
work of the layers above estimation, so estimation defines no corpus: each layer that
makes one registers it here (:func:`register_corpus`), by reference when listing the
names should import nothing. The scenarios package registers ``"virtual"``, the paper's
protocol recorded from virtual subjects, when it is imported; a program that uses
:mod:`estimation` alone registers its own corpus, or imports that package first.

A pretrained network is keyed by the source of the module that defines its corpus's
builder (:func:`corpus_source`), read without importing it, and of the packages the
corpus declares it depends on (:func:`corpus_packages`: the virtual subjects' for
``"virtual"``), so an edit to any of them makes the stored networks stale.

Importing this module imports neither scikit-learn nor any corpus.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from sim.errors import GriploopError
from sim.registry import Registry

if TYPE_CHECKING:  # numpy is not imported with the registry: the command line's help lists it
    import numpy as np

Corpus = list[tuple["np.ndarray", "np.ndarray", int]]
"""Per subject: normalized features ``U`` (n_windows, n_inputs), force ``y`` and ``n_id``."""


class UnknownCorpusError(GriploopError, LookupError):
    """A pretraining corpus name is not registered (a lookup error, as an unknown estimator)."""


_CORPORA = Registry("pretraining corpus", UnknownCorpusError)


def register_corpus(name: str, builder: Callable[..., Corpus] | str, *,
                    packages: Sequence[str] = (), replace: bool = False) -> None:
    """Register a pretraining corpus.

    Parameters
    ----------
    name : str
        Name used by ``TransferMLP(corpus=name)``.
    builder : callable or str
        ``builder(*, n_inputs, n_subjects, seed, population) -> [(U, y, n_id), ...]``: per
        subject, normalized features ``U`` (n_windows, n_inputs), normalized force ``y`` and
        the number of identification windows; ``population`` names the population variant
        the subjects come from (``sim.user.populations``; a builder that has no variants
        accepts ``"default"``). Or its ``"module:attribute"`` reference.
    packages : sequence of str
        Packages whose every source file the corpus depends on besides its builder's
        module (e.g. the one that makes its subjects); they key the networks pretrained
        on it.
    replace : bool
        Allow replacing an existing registration.

    Raises
    ------
    sim.registry.RegistrationError
        Malformed reference, or ``name`` already registered.
    """
    _CORPORA.register(name, builder, replace=replace, packages=tuple(packages))


unregister_corpus, corpus_names = _CORPORA.functions(__name__, "corpus")


def corpus_builder(name: str) -> Callable[..., Corpus]:
    """The builder registered as ``name`` (imported on first use).

    Raises
    ------
    UnknownCorpusError
        ``name`` is not registered; the message lists the registered corpora.
    """
    return _CORPORA.get(name)


def corpus_packages(name: str) -> tuple[str, ...]:
    """The packages ``name`` was registered as depending on (:func:`register_corpus`).

    Raises
    ------
    UnknownCorpusError
        ``name`` is not registered.
    """
    return tuple(_CORPORA.info(name)["packages"])


def corpus_source(name: str) -> bytes:
    """The source file of the module that defines ``name``'s builder, read, not imported.

    A module without a file (an interactive session) gives its name.

    Raises
    ------
    UnknownCorpusError
        ``name`` is not registered.
    """
    target = _CORPORA.entry(name).target
    module = (target.partition(":")[0] if isinstance(target, str)
              else str(getattr(target, "__module__", "")))
    file = getattr(sys.modules.get(module), "__file__", None)
    if file is None:
        try:
            spec = importlib.util.find_spec(module)
        except (ImportError, ValueError):
            spec = None
        file = spec.origin if spec is not None else None
    if file and Path(file).is_file():
        return Path(file).read_bytes()
    return f"module {module}".encode()
