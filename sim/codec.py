"""Object graphs as JSON and arrays: what disk caches store instead of pickles.

A cache shared by processes (sweep workers, Dask workers on a cluster file
system) must not run code from the files it reads. :func:`encode` turns a
graph of griploop objects into a JSON tree plus a list of numpy arrays;
:func:`decode` rebuilds it, and all it ever does is:

- build JSON values, numpy arrays and scalars, containers, python-control
  systems (from their matrices or coefficients);
- create instances of *allowed* classes without calling their constructors
  (``cls.__new__(cls)``), and set their attributes.

Allowed classes live in griploop's own packages (:data:`PACKAGES`) or in the
modules the caller names (a plugin's module, already imported). A class
outside them, a function, a lambda or any other object raises
:class:`CodecError` when encoding, and a file naming one raises it when
decoding: a foreign file cannot make :func:`decode` import or call anything.

Shared references (the same object reached twice) and cycles are kept: each
object and mutable container is written once and referred to by number.
Bound methods of allowed objects (a design's feed-forward) are kept as
(object, method name). Arrays are copied: views become separate arrays, as
with pickle.

A class marks the attributes that hold python-control systems only for analysis
with :func:`stored_systems` (a design's plants and loops). Decoding leaves such an
attribute as a :class:`StoredSystem`, its matrices, and the attribute builds the
system when it is first read: a process that only runs a cached design never
imports python-control (issue 22).
"""

from __future__ import annotations

import collections
import importlib
import math
import sys
import types
from collections.abc import Iterable
from typing import Any

import numpy as np

from sim.errors import GriploopError

#: Packages whose classes may be encoded and rebuilt.
PACKAGES = ("controllers", "sim", "estimation", "scenarios")


class CodecError(GriploopError, ValueError):
    """A value cannot be encoded, or a tree names something that is not allowed."""


def _allowed_module(module: str, extra: frozenset[str]) -> bool:
    return module.split(".")[0] in PACKAGES or module in extra


class StoredSystem:
    """A python-control system as read from a file: its matrices, built on demand.

    Parameters
    ----------
    tag : {"$ss", "$tf"}
        State space (``parts`` = A, B, C, D) or transfer function (``parts`` =
        numerator and denominator coefficient arrays, by output and input).
    parts : tuple
        The matrices or coefficients, as numpy arrays.
    dt : float, bool or None
        Sampling period in seconds (python-control's ``dt``).
    labels : dict
        ``inputs``, ``outputs``, ``name`` and, for a state space, ``states``.
    """

    __slots__ = ("tag", "parts", "dt", "labels")

    def __init__(self, tag: str, parts: tuple, dt: Any, labels: dict[str, Any]) -> None:
        self.tag, self.parts, self.dt, self.labels = tag, parts, dt, labels

    def __getstate__(self) -> tuple:
        return self.tag, self.parts, self.dt, self.labels

    def __setstate__(self, state: tuple) -> None:
        self.tag, self.parts, self.dt, self.labels = state

    def build(self) -> Any:
        """The python-control system (imports python-control)."""
        import control

        labels = dict(self.labels)
        if self.tag == "$ss":
            return control.ss(*self.parts, self.dt, **labels)
        labels.pop("states", None)
        num, den = self.parts
        return control.tf([list(row) for row in num], [list(row) for row in den], self.dt,
                          **labels)


class _SystemAttribute:
    """Data descriptor of a :func:`~sim.codec.stored_systems` attribute: builds a stored system
    once."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        try:
            value = obj.__dict__[self.name]
        except KeyError:
            raise AttributeError(self.name) from None
        if isinstance(value, StoredSystem):
            value = obj.__dict__[self.name] = value.build()
        return value

    def __set__(self, obj: Any, value: Any) -> None:
        obj.__dict__[self.name] = value


def stored_systems(*names: str) -> Any:
    """Class decorator: attributes ``names`` hold systems a file may leave as matrices.

    Place it above ``@dataclass``. The attributes behave as before (a frozen
    dataclass's constructor still sets them); a decoded instance holds a
    :class:`StoredSystem` until the attribute is read.
    """
    def mark(cls: type) -> type:
        for name in names:
            setattr(cls, name, _SystemAttribute(name))
        return cls
    return mark


def state_space_matrices(owner: Any, name: str) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D)`` of the system in ``owner.<name>``, as 2-D float arrays.

    A state space still stored as matrices (:func:`stored_systems`) is not built,
    so python-control is not imported for it.
    """
    value = owner.__dict__.get(name)
    if isinstance(value, StoredSystem) and value.tag == "$ss":
        mats = value.parts
    else:
        import control

        ss = control.ss(getattr(owner, name))
        mats = (ss.A, ss.B, ss.C, ss.D)
    return tuple(np.atleast_2d(np.asarray(m, dtype=float)) for m in mats)


def _is_stored_system_attribute(cls: type, name: str) -> bool:
    return any(isinstance(c.__dict__.get(name), _SystemAttribute) for c in cls.__mro__)


def encode(value: Any, *, modules: Iterable[str] = ()) -> tuple[Any, list[np.ndarray]]:
    """``value`` as a JSON-ready tree and the arrays it refers to.

    Parameters
    ----------
    value : object
        Built from JSON types, tuples, sets, deques, numpy arrays and scalars,
        python-control systems, and instances of allowed classes.
    modules : iterable of str
        Further modules whose classes are allowed (e.g. a plugin's).

    Returns
    -------
    tree : JSON-ready object
    arrays : list of ndarray
        Numeric arrays referred to by index from ``tree`` (no object arrays).

    Raises
    ------
    CodecError
        Something that is not allowed (the message names its type and where).
    """
    encoder = _Encoder(frozenset(modules))
    return encoder.value(value, "value"), encoder.arrays


def decode(tree: Any, arrays: list[np.ndarray], *, modules: Iterable[str] = ()) -> Any:
    """The value :func:`encode` gave ``tree`` and ``arrays`` for.

    Raises
    ------
    CodecError
        The tree is malformed or names a class that is not allowed.
    """
    return _Decoder(arrays, frozenset(modules)).value(tree)


class _Encoder:
    def __init__(self, modules: frozenset[str]) -> None:
        self.modules = modules
        self.arrays: list[np.ndarray] = []
        self.ids: dict[int, int] = {}
        self.alive: list[Any] = []  # keeps encoded objects alive: their ids stay unique

    def _ref(self, x: Any) -> tuple[int, bool]:
        """(number, seen before) of a shared object."""
        key = id(x)
        if key in self.ids:
            return self.ids[key], True
        self.ids[key] = n = len(self.ids)
        self.alive.append(x)
        return n, False

    def value(self, x: Any, where: str) -> Any:
        if x is None or isinstance(x, (bool, str)):
            return x
        if isinstance(x, int) and type(x) is int:
            return x
        if isinstance(x, float) and type(x) is float:
            return x if math.isfinite(x) else {"$float": repr(x)}
        if isinstance(x, np.ndarray):
            if x.dtype.hasobject:
                raise CodecError(f"{where}: an object array cannot be stored")
            self.arrays.append(np.array(x))
            return {"$array": len(self.arrays) - 1}
        if isinstance(x, np.generic):
            return {"$scalar": np.dtype(x.dtype).str, "value": self.value(x.item(), where)}
        if isinstance(x, tuple):
            return {"$tuple": [self.value(v, f"{where}[{i}]") for i, v in enumerate(x)]}
        if isinstance(x, frozenset):
            return {"$frozenset": [self.value(v, f"{where}{{}}") for v in x]}
        module = type(x).__module__
        if module.split(".")[0] == "control":
            return self._system(x, where)
        if isinstance(x, StoredSystem):  # decoded and never built: written as it was read
            return self._stored(x, where)
        n, seen = self._ref(x)
        if seen:
            return {"$ref": n}
        if type(x) is list:
            return {"$list": [self.value(v, f"{where}[{i}]") for i, v in enumerate(x)], "id": n}
        if type(x) is dict or (isinstance(x, dict) and _allowed_module(module, self.modules)):
            # a dict subclass of griploop's (a write-through cache) is stored as its items
            return {"$dict": [[self.value(k, f"{where} key"), self.value(v, f"{where}[{k!r}]")]
                              for k, v in x.items()], "id": n}
        if type(x) is set:
            return {"$set": [self.value(v, f"{where}{{}}") for v in x], "id": n}
        if type(x) is collections.deque:
            return {"$deque": [self.value(v, f"{where}[]") for v in x], "maxlen": x.maxlen,
                    "id": n}
        if isinstance(x, types.MethodType):
            name = x.__func__.__name__
            return {"$method": self.value(x.__self__, f"{where}.__self__"), "name": name,
                    "id": n}
        cls = type(x)
        if isinstance(x, type) or not _allowed_module(module, self.modules) or not hasattr(
                x, "__dict__"):
            raise CodecError(f"{where}: cannot store a {module}.{cls.__qualname__}")
        custom = getattr(cls, "__getstate__", None)
        state = x.__getstate__() if custom is not None and custom is not object.__getstate__ \
            else x.__dict__
        if not isinstance(state, dict):
            raise CodecError(f"{where}: {cls.__qualname__}.__getstate__ gave no dict")
        return {"$object": f"{module}:{cls.__qualname__}", "id": n,
                "state": {str(k): self.value(v, f"{where}.{k}") for k, v in state.items()}}

    def _stored(self, x: StoredSystem, where: str) -> Any:
        if x.tag == "$ss":
            parts: Any = [self.value(np.asarray(m, float), where) for m in x.parts]
        else:
            parts = [[[self.value(np.asarray(c, float), where) for c in row] for row in part]
                     for part in x.parts]
        return {x.tag: parts, "dt": self.value(x.dt, where), **x.labels}

    def _system(self, x: Any, where: str) -> Any:
        import control

        if isinstance(x, control.StateSpace):
            return {"$ss": [self.value(np.asarray(m, float), where)
                            for m in (x.A, x.B, x.C, x.D)],
                    "dt": self.value(x.dt, where), "inputs": list(x.input_labels),
                    "outputs": list(x.output_labels), "states": list(x.state_labels),
                    "name": x.name}
        if isinstance(x, control.TransferFunction):
            return {"$tf": [[[self.value(np.asarray(c, float), where) for c in row]
                             for row in part] for part in (x.num, x.den)],
                    "dt": self.value(x.dt, where), "inputs": list(x.input_labels),
                    "outputs": list(x.output_labels), "name": x.name}
        raise CodecError(f"{where}: cannot store a {type(x).__module__}.{type(x).__qualname__}")


class _Decoder:
    def __init__(self, arrays: list[np.ndarray], modules: frozenset[str]) -> None:
        self.arrays = arrays
        self.modules = modules
        self.objects: dict[int, Any] = {}

    def _keep(self, node: dict, x: Any) -> Any:
        n = node.get("id")
        if not isinstance(n, int) or n in self.objects:
            raise CodecError(f"malformed tree: object number {n!r}")
        self.objects[n] = x
        return x

    def value(self, node: Any) -> Any:
        if node is None or isinstance(node, (bool, int, float, str)):
            return node
        if isinstance(node, list):
            raise CodecError("malformed tree: a bare list")
        if not isinstance(node, dict) or len(node) < 1:
            raise CodecError(f"malformed tree: {type(node).__name__}")
        tag = next((k for k in node if k.startswith("$")), None)
        body = node.get(tag)
        if tag == "$float":
            return float(body) if body in ("inf", "-inf", "nan") else _bad(tag)
        if tag == "$array":
            if not isinstance(body, int) or not 0 <= body < len(self.arrays):
                raise CodecError(f"malformed tree: array {body!r}")
            return self.arrays[body]
        if tag == "$scalar":
            return np.dtype(str(body)).type(self.value(node["value"]))
        if tag == "$tuple":
            return tuple(self.value(v) for v in body)
        if tag == "$frozenset":
            return frozenset(self.value(v) for v in body)
        if tag == "$ref":
            if body not in self.objects:
                raise CodecError(f"malformed tree: reference {body!r} before its object")
            return self.objects[body]
        if tag == "$list":
            out: list[Any] = self._keep(node, [])
            out.extend(self.value(v) for v in body)
            return out
        if tag == "$dict":
            d: dict[Any, Any] = self._keep(node, {})
            for k, v in body:
                d[self.value(k)] = self.value(v)
            return d
        if tag == "$set":
            s: set[Any] = self._keep(node, set())
            s.update(self.value(v) for v in body)
            return s
        if tag == "$deque":
            q = self._keep(node, collections.deque(maxlen=node.get("maxlen")))
            q.extend(self.value(v) for v in body)
            return q
        if tag == "$method":
            owner = self.value(body)
            name = str(node.get("name"))
            method = getattr(type(owner), name, None)
            if not isinstance(method, types.FunctionType):
                raise CodecError(f"{type(owner).__qualname__} has no method {name!r}")
            return self._keep(node, types.MethodType(method, owner))
        if tag == "$object":
            cls = self._class(str(body))
            x = self._keep(node, cls.__new__(cls))
            state = {str(k): self._stored(v) if _is_stored_system_attribute(cls, str(k))
                     and isinstance(v, dict) and ("$ss" in v or "$tf" in v) else self.value(v)
                     for k, v in node.get("state", {}).items()}
            x.__dict__.update(state)
            return x
        if tag in ("$ss", "$tf"):
            return self._system(tag, node)
        return _bad(tag)

    def _class(self, reference: str) -> type:
        module_name, _, qualname = reference.partition(":")
        if not _allowed_module(module_name, self.modules):
            raise CodecError(f"class {reference} is not allowed")
        module = sys.modules.get(module_name)
        if module is None:
            if module_name.split(".")[0] not in PACKAGES:  # a plugin's: only if imported
                raise CodecError(f"module {module_name} is not imported")
            module = importlib.import_module(module_name)  # griploop's own
        obj: Any = module
        for part in qualname.split("."):
            obj = getattr(obj, part, None)
        if not isinstance(obj, type) or obj.__module__ != module_name:
            raise CodecError(f"{reference} is not a class of {module_name}")
        return obj

    def _stored(self, node: dict) -> StoredSystem:
        """A ``$ss`` or ``$tf`` node as a :class:`StoredSystem`, its shapes checked."""
        tag = "$ss" if "$ss" in node else "$tf"
        labels = {k: node.get(k) for k in ("inputs", "outputs", "name")}
        if tag == "$ss":
            parts: tuple = tuple(np.atleast_2d(np.asarray(self.value(m), float))
                                 for m in node["$ss"])
            if len(parts) != 4:
                raise CodecError("malformed tree: a state space needs A, B, C and D")
            a, b, c, d = (m.shape for m in parts)
            if a[0] != a[1] or b[0] != a[0] or c[1] != a[0] or d != (c[0], b[1]):
                raise CodecError(f"malformed tree: state-space shapes {a}, {b}, {c}, {d}")
            labels["states"] = node.get("states")
        else:
            parts = tuple([[np.asarray(self.value(c), float) for c in row] for row in part]
                          for part in node["$tf"])
            if len(parts) != 2:
                raise CodecError("malformed tree: a transfer function needs num and den")
        return StoredSystem(tag, parts, self.value(node.get("dt")), labels)

    def _system(self, tag: str, node: dict) -> Any:
        return self._stored(node).build()


def _bad(tag: Any) -> Any:
    raise CodecError(f"malformed tree: unknown tag {tag!r}")
