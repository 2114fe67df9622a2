"""On-disk cache of controller designs and their loop analyses, shared by every process.

A design (:func:`controllers.design.design_for_object`) tunes a controller at
every grid force of the object's plant family and checks each loop's margins;
the episode then analyses the loop at the forces it visited. Every sweep
worker and every ``griploop episode`` process would otherwise redo both for
each object it meets. Next to :mod:`controllers.plant_cache` (plant families),
this module keeps, per design:

- ``<object>-<kind>-<key>.design``: the design as built (before any episode ran
  it), so its controllers start from their designed state;
- ``<object>-<kind>-<key>.analyses``: the :class:`~controllers.design.OperatingAnalysis`
  of every force analysed so far by any process, written through as they are made.

The key hashes everything the design depends on: the object's full
specification, the controller kind, the control period, the specification
(fragile force limit included), the force grid, the griploop and
python-control versions and the source of the modules that design, schedule,
run and analyse controllers (and of those the plant cache hashes). A changed
specification, object or source file misses the cache.

Files are pickles (protocol 5) behind a header: a magic line, the key and the
SHA-256 of the payload. A file whose header, key or digest does not match
(truncated, corrupted, foreign, written by another version) is a miss: the
design is rebuilt and the file replaced. The cache lives in the user's own
directory (``$GRIPLOOP_CACHE_DIR/designs``, default ``~/.cache/griploop/designs``;
``GRIPLOOP_CACHE_DIR=off`` or ``GRIPLOOP_DESIGN_CACHE=off`` disables it), which
is trusted as the user's site-packages are. python-control state-space and transfer-function objects
are stored as their matrices (:func:`_rebuild_ss`, :func:`_rebuild_tf`).
Writes are atomic (temporary file, then rename), so concurrent workers never
read half a file; a directory that cannot be written is skipped.
"""

from __future__ import annotations

import copyreg
import dataclasses
import functools
import hashlib
import io
import json
import os
import pickle
from collections.abc import Callable, Mapping
from importlib import metadata, resources
from pathlib import Path
from typing import Any

import control

from controllers import plant_cache
from sim.cache import write_atomic
from sim.hand.objects import ObjectSpec

FORMAT = 1
MAGIC = b"griploop-design-cache\n"
_SOURCES = tuple(("controllers", name) for name in (
    "design.py", "analysis.py", "approach.py", "bounds.py", "lead_lag.py", "mpc.py", "pid.py",
    "plant.py", "reflex.py", "registry.py", "schedule.py", "base.py", "design_plant.py",
    "design_cache.py"))


def cache_dir() -> Path | None:
    """The design cache directory, or None when disabled.

    ``GRIPLOOP_CACHE_DIR=off`` disables every disk cache; ``GRIPLOOP_DESIGN_CACHE=off``
    this one only (the plant families stay cached: how sweeps ran before designs were).
    """
    if os.environ.get("GRIPLOOP_DESIGN_CACHE", "").lower() in ("off", "0", "none"):
        return None
    plants = plant_cache.cache_dir()
    return None if plants is None else plants.parent / "designs"


@functools.cache
def source_digest() -> str:
    """SHA-256 of the plant cache's sources, the design modules and the versions (once)."""
    h = hashlib.sha256(plant_cache.source_digest().encode())
    for package, name in _SOURCES:
        h.update(resources.files(package).joinpath(name).read_bytes())
    for dist in ("griploop", "control"):
        try:
            h.update(metadata.version(dist).encode())
        except metadata.PackageNotFoundError:  # running from a source tree
            h.update(b"source")
    return h.hexdigest()


def design_key(obj: ObjectSpec, kind: str, control_dt_s: float, spec: Mapping[str, Any],
               forces_n: tuple[float, ...]) -> str:
    """Hex digest naming a design: object, kind, period, specification, grid and source.

    Parameters
    ----------
    obj : ObjectSpec
        The grasped object (every field counts).
    kind : str
        Controller family.
    control_dt_s : float
        Control period, s.
    spec : mapping
        Keyword arguments of :func:`controllers.design.design_for_object`
        (JSON-serializable values; nested mappings allowed).
    forces_n : tuple of float
        The design grid, N.
    """
    payload = json.dumps({"format": FORMAT, "object": dataclasses.asdict(obj), "kind": kind,
                          "dt": float(control_dt_s), "spec": dict(spec),
                          "forces": [float(f) for f in forces_n],
                          "source": source_digest()}, sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()[:32]


def _rebuild_ss(A: Any, B: Any, C: Any, D: Any, dt: Any, labels: dict[str, Any]
                ) -> control.StateSpace:
    """A ``control.StateSpace`` from its matrices, period and signal names."""
    return control.ss(A, B, C, D, dt, **labels)


def _rebuild_tf(num: Any, den: Any, dt: Any, labels: dict[str, Any]) -> control.TransferFunction:
    """A ``control.TransferFunction`` from its coefficients, period and signal names."""
    return control.tf(num, den, dt, **labels)


def _reduce_ss(sys: control.StateSpace) -> tuple[Callable[..., Any], tuple[Any, ...]]:
    labels = {"inputs": sys.input_labels, "outputs": sys.output_labels,
              "states": sys.state_labels, "name": sys.name}
    return _rebuild_ss, (sys.A, sys.B, sys.C, sys.D, sys.dt, labels)


def _reduce_tf(sys: control.TransferFunction) -> tuple[Callable[..., Any], tuple[Any, ...]]:
    labels = {"inputs": sys.input_labels, "outputs": sys.output_labels, "name": sys.name}
    return _rebuild_tf, (sys.num, sys.den, sys.dt, labels)


class _Pickler(pickle.Pickler):
    """Pickles python-control systems as their matrices (they hold lambdas)."""

    dispatch_table = copyreg.dispatch_table.copy()
    dispatch_table[control.StateSpace] = _reduce_ss
    dispatch_table[control.TransferFunction] = _reduce_tf


def dumps(value: Any, key: str) -> bytes:
    """``value`` as a cache file's bytes: header (magic, key, payload digest) and pickle."""
    buffer = io.BytesIO()
    _Pickler(buffer, protocol=5).dump(value)
    payload = buffer.getvalue()
    header = f"{FORMAT} {key} {hashlib.sha256(payload).hexdigest()}\n".encode()
    return MAGIC + header + payload


def loads(data: bytes, key: str) -> Any:
    """The value of a cache file written by :func:`dumps` under ``key``.

    Raises
    ------
    ValueError
        The header, key or payload digest does not match (the file is not trusted).
    """
    if not data.startswith(MAGIC):
        raise ValueError("not a griploop design cache file")
    header, _, payload = data[len(MAGIC):].partition(b"\n")
    fields = header.decode("ascii", "replace").split()
    expected = [str(FORMAT), key, hashlib.sha256(payload).hexdigest()]
    if fields != expected:
        raise ValueError(f"design cache header {fields} does not match {expected}")
    return pickle.loads(payload)


def _read(path: Path, key: str) -> Any:
    """The value stored at ``path``, or None when missing, corrupted or foreign."""
    try:
        return loads(path.read_bytes(), key)
    except FileNotFoundError:
        return None
    except Exception:  # noqa: BLE001  (any unreadable or mismatched file is a miss)
        return None


class _WrittenThrough(dict):
    """A design's analyses by force; each new one is also written to the cache file."""

    def __init__(self, initial: Mapping[float, Any], path: Path, key: str) -> None:
        super().__init__(initial)
        self._path, self._key = path, key

    def __setitem__(self, force_n: float, analysis: Any) -> None:
        super().__setitem__(force_n, analysis)
        stored = _read(self._path, self._key)  # another process may have added some
        merged = {**(stored if isinstance(stored, dict) else {}), **self}
        try:
            write_atomic(self._path, dumps(merged, self._key))
        except (OSError, pickle.PicklingError, TypeError, AttributeError):
            pass  # not cached: the analysis is still returned

    def __reduce__(self) -> tuple[type, tuple[dict[float, Any]]]:
        return dict, (dict(self),)


def cached_design(obj: ObjectSpec, kind: str, control_dt_s: float, spec: Mapping[str, Any],
                  forces_n: tuple[float, ...], build: Callable[[], Any]) -> tuple[Any, str]:
    """The design from the disk cache, or ``build()`` and store it.

    The returned design's analyses (``design._cache``) start with every one
    stored for this key and write each new one through to the cache.

    Parameters
    ----------
    obj, kind, control_dt_s, spec, forces_n
        What the design is made from (see :func:`design_key`).
    build : callable
        ``build() -> ControllerDesign``, called on a miss.

    Returns
    -------
    design : ControllerDesign
    source : {"disk", "built", "built (cache off)", "built (cache not writable)"}
    """
    root = cache_dir()
    if root is None:
        return build(), "built (cache off)"
    key = design_key(obj, kind, control_dt_s, spec, forces_n)
    stem = root / f"{obj.name}-{kind}-{key}"
    design_path, analyses_path = stem.with_suffix(".design"), stem.with_suffix(".analyses")
    design = _read(design_path, key)
    if design is not None and getattr(design, "kind", None) == kind:
        source = "disk"
    else:
        design = build()
        try:
            write_atomic(design_path, dumps(design, key))
            source = "built"
        except (OSError, pickle.PicklingError, TypeError, AttributeError):
            source = "built (cache not writable)"
    stored = _read(analyses_path, key)
    analyses = {**(stored if isinstance(stored, dict) else {}), **design._cache}
    design._cache = _WrittenThrough(analyses, analyses_path, key)
    return design, source
