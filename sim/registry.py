"""Named registries: the one place a family of extensions (estimators, objects, ...) is listed.

A :class:`Registry` maps a name to an entry: an object (a class, a factory
function, a value) or its ``"package.module:attribute"`` reference, imported
the first time the entry is used. Registering by reference keeps listing the
names light: a registry of estimators does not import scikit-learn until one
is built. Each registration also carries metadata (keyword arguments of
:meth:`Registry.register`) that callers read with :meth:`Registry.info`: for
the main families a typed record of the capabilities the family declares
(:class:`Capabilities`: controllers' ``ControllerKind``, estimators'
``EstimatorKind``, scenario kinds' ``ScenarioKind``).

The module that owns a registry writes its own ``register_<thing>`` (whose docstring says
what the registered object must be); :meth:`Registry.functions` makes the rest of its
public functions, ``unregister_<thing>`` and ``<thing>_names``, in one line.

The registries of griploop: sEMG generators (:mod:`sim.user.generators`),
objects (:mod:`sim.hand.objects`), estimators (:mod:`estimation.registry`),
controllers (:mod:`controllers.registry`), scenario kinds
(:mod:`scenarios.runners.dispatch`) and report sections
(:mod:`scenarios.report.sections`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Any, NamedTuple

from sim.errors import GriploopError


class RegistrationError(GriploopError, ValueError):
    """A registration is malformed (bad reference) or would silently replace another."""


class UnresolvableEntryError(GriploopError, LookupError):
    """A registered ``"module:attribute"`` reference cannot be imported."""


class Capabilities(Mapping[str, Any]):
    """Base of a registry's typed capability record (a frozen dataclass of its own).

    A registry made with ``capabilities=Kind`` stores each registration's
    metadata as a ``Kind`` instance: its fields are the capabilities the family
    declares, typed and documented in one place, and a registration with a
    field the family does not have is refused. The record also reads as a
    mapping of its fields (``info["modes"]``).
    """

    def __getitem__(self, key: str) -> Any:
        if key not in self._names():
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))


@dataclass
class Entry:
    """One registration.

    Attributes
    ----------
    name : str
        Registered name.
    target : object or str
        The registered object, or its ``"package.module:attribute"`` reference.
    info : Mapping
        Metadata given at registration (read-only).
    """

    name: str
    target: Any
    info: Mapping[str, Any] = field(default_factory=dict)

    def resolve(self) -> Any:
        """The registered object, importing it first if it was registered by reference.

        Raises
        ------
        UnresolvableEntryError
            The module cannot be imported or lacks the attribute.
        """
        if not isinstance(self.target, str):
            return self.target
        try:
            obj = import_reference(self.target, callable_only=False)
        except UnresolvableEntryError as exc:
            raise UnresolvableEntryError(f"{self.name}: {exc}") from None
        self.target = obj
        return obj


def import_reference(reference: str, *, callable_only: bool = True) -> Any:
    """The object named by a ``"package.module:attribute"`` reference, imported now.

    Parameters
    ----------
    reference : str
        ``"package.module:attribute"`` (exactly one colon).
    callable_only : bool
        Refuse an attribute that is not callable (runners, tasks, factories).

    Returns
    -------
    object

    Raises
    ------
    UnresolvableEntryError
        Malformed reference, module not importable, attribute missing (or not callable).
    """
    if not isinstance(reference, str) or reference.count(":") != 1:
        raise UnresolvableEntryError(
            f"expected a 'package.module:attribute' reference, found {reference!r}")
    module_name, attr = reference.split(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnresolvableEntryError(f"{module_name} cannot be imported ({exc})") from None
    obj = getattr(module, attr, None)
    if obj is None or (callable_only and not callable(obj)):
        what = "callable" if callable_only else "attribute"
        raise UnresolvableEntryError(f"{module_name} has no {what} {attr!r}") from None
    return obj


class Registry:
    """Names of one family of extensions, in registration order.

    Parameters
    ----------
    what : str
        What is registered, for messages (e.g. ``"estimator"``).
    unknown_error : type of Exception
        Raised by :meth:`entry` / :meth:`get` for an unknown name; the message
        lists the registered names.
    capabilities : type, optional
        A :class:`Capabilities` dataclass: each registration's metadata is made
        into one (typed fields; an unknown one is refused). Default: a
        read-only mapping of whatever was given.
    """

    #: Registrations made so far in this process, over every registry (a plugin
    #: that imports without raising this registered nothing).
    registrations: int = 0

    def __init__(self, what: str, unknown_error: type[Exception] = LookupError, *,
                 capabilities: type[Capabilities] | None = None) -> None:
        self.what = what
        self.unknown_error = unknown_error
        self.capabilities = capabilities
        self._entries: dict[str, Entry] = {}

    def register(self, name: str, target: Any, *, replace: bool = False, **info: Any) -> Entry:
        """Register ``target`` as ``name``.

        Parameters
        ----------
        name : str
            New name (a non-empty string).
        target : object or str
            The object, or its ``"package.module:attribute"`` reference.
        replace : bool
            Allow replacing an existing registration of ``name``.
        **info
            Metadata stored with the entry (see the owning registry's docs).

        Returns
        -------
        Entry

        Raises
        ------
        RegistrationError
            Empty name, malformed reference, or ``name`` taken and ``replace`` false.
        """
        self._check_new(name, target, replace)
        if self.capabilities is None:
            return self._add(name, target, MappingProxyType(dict(info)))
        unknown = sorted(set(info) - set(self.capabilities._names()))
        if unknown:
            raise RegistrationError(
                f"{self.what} {name}: no capabilities {unknown} (a {self.what} declares "
                f"{', '.join(self.capabilities._names())})")
        return self._add(name, target, self.capabilities(**info))

    def register_record(self, name: str, target: Any, record: Capabilities, *,
                        replace: bool = False) -> Entry:
        """Register ``target`` as ``name`` with its capabilities given as one record.

        Parameters
        ----------
        name, target, replace
            As for :meth:`register`.
        record : Capabilities
            An instance of this registry's ``capabilities`` class.

        Raises
        ------
        RegistrationError
            As :meth:`register`, or ``record`` is not this registry's capability record.
        """
        self._check_new(name, target, replace)
        if self.capabilities is None or not isinstance(record, self.capabilities):
            expected = self.capabilities.__name__ if self.capabilities else "no record"
            raise RegistrationError(f"{self.what} {name}: expected {expected}, found "
                                    f"{type(record).__name__}")
        return self._add(name, target, record)

    def _check_new(self, name: str, target: Any, replace: bool) -> None:
        if not isinstance(name, str) or not name:
            raise RegistrationError(f"{self.what} name: expected a non-empty string, "
                                    f"found {name!r}")
        if isinstance(target, str) and (target.count(":") != 1 or not all(target.split(":"))):
            raise RegistrationError(f"{self.what} {name}: reference must be "
                                    f"'package.module:attribute' (found {target!r})")
        if name in self._entries and not replace:
            raise RegistrationError(f"{self.what} {name!r} is already registered "
                                    f"({self._entries[name].target!r}); pass replace=True")

    def _add(self, name: str, target: Any, record: Mapping[str, Any]) -> Entry:
        entry = Entry(name, target, record)
        self._entries[name] = entry
        Registry.registrations += 1
        return entry

    def unregister(self, name: str) -> None:
        """Remove ``name`` (no effect if it is not registered)."""
        self._entries.pop(name, None)

    def names(self) -> tuple[str, ...]:
        """Registered names, in registration order."""
        return tuple(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(tuple(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def unknown_message(self, name: object) -> str:
        """``unknown estimator 'x'; expected one of a, b, c``."""
        return f"unknown {self.what} {name!r}; expected one of {', '.join(self._entries)}"

    def entry(self, name: str) -> Entry:
        """The entry of ``name``.

        Raises
        ------
        unknown_error
            ``name`` is not registered; the message lists the registered names.
        """
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise self.unknown_error(self.unknown_message(name)) from None

    def get(self, name: str) -> Any:
        """The object registered as ``name``, imported on first use."""
        return self.entry(name).resolve()

    def info(self, name: str) -> Mapping[str, Any]:
        """Metadata of ``name`` (read-only mapping)."""
        return self.entry(name).info

    def where(self, **info: Any) -> tuple[str, ...]:
        """Names whose metadata has every given ``key=value``."""
        return tuple(n for n, e in self._entries.items()
                     if all(e.info.get(k) == v for k, v in info.items()))

    def functions(self, module: str, noun: str) -> RegistryFunctions:
        """``unregister_<noun>`` and ``<noun>_names``: public functions of the owning module.

        Each is a plain function of ``module`` (its name, module and docstring set), so
        the API reference lists it there and it pickles by reference::

            unregister_generator, generator_names = _REGISTRY.functions(__name__, "generator")

        Parameters
        ----------
        module : str
            The owning module's ``__name__``.
        noun : str
            What the functions are named after (``"generator"``).

        Returns
        -------
        RegistryFunctions
        """
        def unregister(name: str) -> None:
            self.unregister(name)

        def names() -> tuple[str, ...]:
            return self.names()

        unregister.__doc__ = (f"Remove the {self.what} ``name`` (no effect if it is not "
                              "registered).\n\nParameters\n----------\nname : str\n"
                              f"    A registered {self.what}.\n")
        names.__doc__ = (f"Every registered {self.what}, in registration order.\n\n"
                         "Returns\n-------\ntuple of str\n")
        for function, name in ((unregister, f"unregister_{noun}"), (names, f"{noun}_names")):
            function.__name__ = function.__qualname__ = name
            function.__module__ = module
        return RegistryFunctions(unregister, names)


class RegistryFunctions(NamedTuple):
    """The public functions :meth:`Registry.functions` makes for the module that owns it.

    Attributes
    ----------
    unregister : callable
        ``unregister_<noun>(name)``: remove a registration (no effect if absent).
    names : callable
        ``<noun>_names()``: the registered names, in registration order.
    """

    unregister: Callable[[str], None]
    names: Callable[[], tuple[str, ...]]
