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
python-control versions, every source file of the packages that design, run
and analyse controllers and build their plants (walked, not listed:
:data:`controllers.plant_cache.SOURCE_PACKAGES`), and the module of a kind
registered from outside them (a plugin's). A changed specification, object or
source file misses the cache.

Files hold no pickles: an NPZ (read with ``allow_pickle=False``) of the key,
a JSON tree and one byte buffer of every array (:mod:`sim.codec`). Reading a
file builds numbers, arrays, python-control systems and instances of
griploop's own classes (or of the kind's plugin module, already imported),
and nothing else, so a cache directory shared by users on a cluster file
system cannot run code. A file whose key does not match, or that is
truncated, corrupted or foreign, is a miss: the design is rebuilt and the
file replaced. The cache lives in ``$GRIPLOOP_CACHE_DIR/designs`` (default
``~/.cache/griploop/designs``; ``GRIPLOOP_CACHE_DIR=off`` or
``GRIPLOOP_DESIGN_CACHE=off`` disables it). Writes are atomic (temporary
file, then rename), so concurrent workers never read half a file; a
directory that cannot be written is skipped with a
:class:`~sim.cache.CacheNotWritableWarning`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import io
import json
import os
import zipfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from controllers import plant_cache
from controllers.registry import design_modules
from sim import cache as sim_cache
from sim.cache import cached, write_atomic
from sim.codec import CodecError, decode, encode
from sim.hand.objects import ObjectSpec

FORMAT = 2


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
def source_digest(kind: str | None = None) -> str:
    """SHA-256 of the design sources (and of ``kind``'s own modules outside them), once."""
    outside = tuple(m for m in (design_modules(kind) if kind else ())
                    if m.split(".")[0] not in ("controllers", "sim"))
    return sim_cache.source_digest(plant_cache.SOURCE_PACKAGES, outside,
                                   distributions=("griploop", "control"))


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
        The flat design specification
        (:meth:`~controllers.design_spec.DesignSpec.from_mapping`; JSON-serializable
        values, nested mappings allowed).
    forces_n : tuple of float
        The design grid, N.
    """
    payload = json.dumps({"format": FORMAT, "object": dataclasses.asdict(obj), "kind": kind,
                          "dt": float(control_dt_s), "spec": dict(spec),
                          "forces": [float(f) for f in forces_n],
                          "source": source_digest(kind)}, sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()[:32]


def dumps(value: Any, key: str, kind: str | None = None) -> bytes:
    """``value`` as a cache file's bytes: an NPZ of the key, a JSON tree and the arrays.

    Raises
    ------
    sim.codec.CodecError
        ``value`` holds something the codec does not store.
    """
    tree, arrays = encode(value, modules=design_modules(kind) if kind else ())
    layout, chunks, offset = [], [], 0
    for a in arrays:
        raw = np.ascontiguousarray(a).tobytes()
        layout.append([a.dtype.str, list(a.shape), offset, len(raw)])
        chunks.append(raw)
        offset += len(raw)
    buffer = io.BytesIO()
    np.savez(buffer, key=np.array(f"{FORMAT} {key}"),
             tree=np.frombuffer(json.dumps({"layout": layout, "value": tree}).encode(),
                                np.uint8),
             blob=np.frombuffer(b"".join(chunks), np.uint8))
    return buffer.getvalue()


def loads(data: bytes, key: str, kind: str | None = None) -> Any:
    """The value of a cache file written by :func:`dumps` under ``key``.

    Raises
    ------
    ValueError
        Not such a file, another key, a malformed tree or a class that is not
        allowed (the file is not trusted).
    """
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as f:
            if str(f["key"]) != f"{FORMAT} {key}":
                raise ValueError(f"design cache key {str(f['key'])!r} is not {key!r}")
            document = json.loads(f["tree"].tobytes().decode())
            blob = f["blob"].tobytes()
    except (OSError, KeyError, zipfile.BadZipFile, UnicodeDecodeError) as exc:
        raise ValueError(f"not a griploop design cache file ({exc})") from None
    arrays = []
    for dtype, shape, offset, size in document["layout"]:
        if offset + size > len(blob) or np.dtype(dtype).hasobject:
            raise ValueError("design cache file: an array lies outside its buffer")
        arrays.append(np.frombuffer(blob[offset:offset + size], dtype=dtype).reshape(shape).copy())
    try:
        return decode(document["value"], arrays, modules=design_modules(kind) if kind else ())
    except CodecError as exc:
        raise ValueError(str(exc)) from None


def _read_design(path: Path, key: str, kind: str) -> Any:
    """The design stored at ``path`` for ``kind``, or None (a miss)."""
    design = _read(path, key, kind)
    return design if design is not None and getattr(design, "kind", None) == kind else None


def _read(path: Path, key: str, kind: str | None = None) -> Any:
    """The value stored at ``path``, or None when missing, corrupted or foreign."""
    try:
        return loads(path.read_bytes(), key, kind)
    except FileNotFoundError:
        return None
    except Exception:  # noqa: BLE001  (any unreadable or mismatched file is a miss)
        return None


class _WrittenThrough(dict):
    """A design's analyses by force; each new one is also written to the cache file."""

    def __init__(self, initial: Mapping[float, Any], path: Path, key: str, kind: str) -> None:
        super().__init__(initial)
        self._path, self._key, self._kind = path, key, kind
        self._deferring, self._unwritten = False, False

    def __setitem__(self, force_n: float, analysis: Any) -> None:
        super().__setitem__(force_n, analysis)
        self._unwritten = True
        if not self._deferring:
            self._write()

    @contextlib.contextmanager
    def deferred_writes(self) -> Iterator[None]:
        """Write the analyses added inside the block once, at its end."""
        self._deferring = True
        try:
            yield
        finally:
            self._deferring = False
            if self._unwritten:
                self._write()

    def _write(self) -> None:
        stored = _read(self._path, self._key, self._kind)  # another process may have added some
        merged = {**(stored if isinstance(stored, dict) else {}), **self}
        self._unwritten = False
        try:
            data = dumps(merged, self._key, self._kind)
        except CodecError:
            return  # not cached: the analysis is still returned
        try:
            write_atomic(self._path, data)
        except OSError as exc:  # not cached either: said once per directory
            sim_cache.warn_not_writable(self._path.parent, exc)

    def __reduce__(self) -> tuple[type, tuple[dict[float, Any]]]:
        return dict, (dict(self),)


def cached_design(obj: ObjectSpec, kind: str, control_dt_s: float, spec: Mapping[str, Any],
                  forces_n: tuple[float, ...], build: Callable[[], Any]) -> tuple[Any, str]:
    """The design from the disk cache, or ``build()`` and store it (:func:`sim.cache.cached`).

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
    source : {"disk", "built", "built (cache off)", "built (cache not writable)", \
"built (not storable)"}
    """
    root = cache_dir()
    if root is None:
        return build(), "built (cache off)"
    key = design_key(obj, kind, control_dt_s, spec, forces_n)
    stem = root / f"{obj.name}-{kind}-{key}"
    design_path, analyses_path = stem.with_suffix(".design"), stem.with_suffix(".analyses")

    def write(path: Path, design: Any) -> str | None:
        try:
            data = dumps(design, key, kind)
        except CodecError:  # e.g. a plugin's controller holding a function
            return "built (not storable)"
        write_atomic(path, data)
        return None

    design, source = cached(design_path, lambda p: _read_design(p, key, kind), build, write)
    stored = _read(analyses_path, key, kind)
    analyses = {**(stored if isinstance(stored, dict) else {}), **design._cache}
    design._cache = _WrittenThrough(analyses, analyses_path, key, kind)
    return design, source


_MEMO: dict[str, Any] = {}


def grasp_design(obj: ObjectSpec, kind: str, control_dt_s: float,
                 spec: Mapping[str, Any] | None) -> Any:
    """The controller a grasp of ``obj`` runs (``design_for_object``, memoized).

    Every command designs through this function (``episode``, ``margins``, the
    feedback tasks, ``live``), so they design the same controller for the same
    object. A fragile object's break force is the user's force limit (the
    hand's "fragile" setting, ``force_max_n``), which bounds the MPC and the
    slip reflex. Designs are kept in memory per process and on disk for every
    process under one key (:func:`design_key`; :func:`cached_design`, with the
    loop analyses made so far); a
    design is reset at the start of every episode, so episodes in one process
    share it.

    Parameters
    ----------
    obj : ObjectSpec
        The grasped object.
    kind : str
        Registered controller kind.
    control_dt_s : float
        Control period, s.
    spec : mapping or None
        The flat design specification (``DesignSpec.from_mapping``: loop targets,
        kind options, ``scheduled``, ``operating_force_n``, ``forces_n``).

    Returns
    -------
    controllers.design.ControllerDesign
    """
    from controllers.design import design_for_object
    from controllers.design_plant import DEFAULT_FORCE_GRID_N
    from controllers.design_spec import DesignSpec

    spec = dict(spec or {})
    if obj.break_force_n is not None:
        spec.setdefault("force_max_n", float(obj.break_force_n))
    forces_n = tuple(float(f) for f in spec.get("forces_n", DEFAULT_FORCE_GRID_N))
    key = design_key(obj, kind, float(control_dt_s), spec, forces_n)  # the disk cache's key
    if key not in _MEMO:
        _MEMO[key], _ = cached_design(
            obj, kind, float(control_dt_s), spec, forces_n,
            lambda: design_for_object(obj, kind, DesignSpec.from_mapping(spec),
                                      control_dt_s=control_dt_s))
    return _MEMO[key]
