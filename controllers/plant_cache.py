"""On-disk cache of plant families, shared by every process of a machine (sweep workers too).

Building an object's plant family linearizes the MuJoCo hand at 20 grip forces
(about 2 s); every sweep worker and every command would otherwise do it again.
A family is stored under a key that hashes the object's full specification,
the control period, the force grid, the griploop version and every source file
of the packages that produce it (:data:`SOURCE_PACKAGES`: the hand model, its
XML, the environment, the contact reading, the linearization and the
design-plant code), so a change to any of them misses the cache instead of
reading a stale model.

Location: ``$GRIPLOOP_CACHE_DIR/plants`` (default ``~/.cache/griploop/plants``;
``GRIPLOOP_CACHE_DIR=off`` disables the disk cache). Writes are atomic (a
temporary file renamed into place), so concurrent workers never read half a
file. An unreadable, corrupted or foreign cache file is a miss: the family is
rebuilt and the file replaced; a cache directory that cannot be written is
skipped with a :class:`~sim.cache.CacheNotWritableWarning` (the family is still returned).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import io
import json
from pathlib import Path

import numpy as np

from controllers.design_plant import DesignPlant, OperatingPoint, PlantFamily
from controllers.errors import PlantError
from sim import cache as sim_cache
from sim.cache import cache_subdir, cached, write_atomic
from sim.hand.objects import ObjectSpec

FORMAT = 1
#: Packages whose every source file a plant family depends on (the hand, its XML,
#: the environment, the linearization and the design-plant code).
SOURCE_PACKAGES = ("sim.hand", "controllers")


def cache_dir() -> Path | None:
    """The plant cache directory, or None when disabled (``GRIPLOOP_CACHE_DIR=off``)."""
    return cache_subdir("plants")


@functools.cache
def source_digest() -> str:
    """SHA-256 of every source file of :data:`SOURCE_PACKAGES` and the griploop version.

    Computed once per process: the source files do not change while it runs.
    """
    return sim_cache.source_digest(SOURCE_PACKAGES)


def family_key(obj: ObjectSpec, control_dt_s: float, forces_n: tuple[float, ...]) -> str:
    """Hex digest naming a family: object, period, grid, version and source."""
    payload = json.dumps({"format": FORMAT, "object": dataclasses.asdict(obj),
                          "dt": float(control_dt_s), "forces": [float(f) for f in forces_n],
                          "source": source_digest()}, sort_keys=True, default=str)
    return hashlib.sha256(payload.encode()).hexdigest()[:32]


def save_family(family: PlantFamily, path: Path) -> None:
    """Write ``family`` to ``path`` (NPZ, no pickles) atomically."""
    arrays: dict[str, np.ndarray] = {}
    points = []
    for i, p in enumerate(family.points):
        entry = {"force_n": p.force_n, "how": p.how, "notes": list(p.notes), "reason": p.reason,
                 "plant": None}
        if p.plant is not None:
            ss = p.plant.model
            for name in ("A", "B", "C", "D"):
                arrays[f"p{i}_{name}"] = np.asarray(getattr(ss, name), dtype=float)
            entry["plant"] = {"method": p.plant.method, "u0": p.plant.u0, "y0_n": p.plant.y0_n,
                              "dt": float(ss.dt), "fit": p.plant.fit}
        points.append(entry)
    meta = {"format": FORMAT, "control_dt_s": family.control_dt_s,
            "build_s": family.build_s, "points": points}
    arrays["meta"] = np.array(json.dumps(meta, default=float))
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    write_atomic(path, buffer.getvalue())


def load_family(path: Path, obj: ObjectSpec) -> PlantFamily:
    """Read a family written by :func:`save_family` for ``obj``.

    Raises
    ------
    ValueError
        If the file is not a plant-family cache of this format.
    """
    import control
    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        if meta.get("format") != FORMAT:
            raise PlantError(f"{path}: expected plant cache format {FORMAT}, found "
                             f"{meta.get('format')!r}")
        points = []
        for i, entry in enumerate(meta["points"]):
            plant = None
            if entry["plant"] is not None:
                e = entry["plant"]
                model = control.ss(*(data[f"p{i}_{n}"] for n in ("A", "B", "C", "D")), e["dt"])
                plant = DesignPlant(model=model, method=e["method"], object=obj, u0=e["u0"],
                                    y0_n=e["y0_n"], fit=e["fit"])
            points.append(OperatingPoint(float(entry["force_n"]), plant, entry["how"],
                                         tuple(entry["notes"]), entry["reason"]))
    return PlantFamily(object=obj, control_dt_s=float(meta["control_dt_s"]),
                       points=tuple(points), build_s=float(meta["build_s"]))


def cached_family(obj: ObjectSpec, control_dt_s: float, forces_n: tuple[float, ...],
                  build) -> tuple[PlantFamily, str]:
    """The family from the disk cache, or ``build()`` and store it (:func:`sim.cache.cached`).

    Returns
    -------
    family : PlantFamily
    source : {"disk", "built", "built (cache off)", "built (cache not writable)"}
    """
    root = cache_dir()
    path = None
    if root is not None:
        path = root / f"{obj.name}-{family_key(obj, control_dt_s, forces_n)}.npz"
    return cached(path, lambda p: _load(p, obj), build,
                  lambda p, family: save_family(family, p))


def _load(path: Path, obj: ObjectSpec) -> PlantFamily | None:
    """The family stored at ``path``; None when missing, corrupted or foreign (a miss)."""
    if not path.is_file():
        return None
    try:
        return load_family(path, obj)
    except (OSError, ValueError, KeyError, json.JSONDecodeError):
        return None
