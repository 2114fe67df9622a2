"""What a sweep varied: its factors, their levels, and grids faceted over them."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from scenarios.report.data import OutcomeGrid, outcome_grids
from scenarios.report.loops import condition_label

# ---------------------------------------------------------------- swept factors


#: Short names of the scenario config paths a sweep usually varies (others keep their path).
FACTOR_NAMES = {
    "object.name": "object", "object.mass_kg": "mass (kg)", "object.friction": "friction",
    "object.break_force_n": "break force (N)", "controller.kind": "controller",
    "estimator.name": "estimator", "estimator.mode": "mode",
    "controller.slip_reflex.enabled": "reflex", "subject.subject_id": "subject",
    "user.kind": "user", "user.feedback": "feedback", "paradigm": "paradigm",
    "hand.drive": "drive", "auto_grip": "auto-grip",
}
#: Config path -> the result field holding the value that actually ran (e.g. the object's
#: mass when the config left it to the object library).
_RESULT_FIELDS = {
    "object.name": "object_name", "object.mass_kg": "object_mass_kg",
    "object.friction": "object_friction", "object.break_force_n": "object_break_force_n",
    "controller.kind": "controller", "estimator.name": "estimator", "estimator.mode": "mode",
    "subject.subject_id": "subject_id", "user.kind": "user", "user.feedback": "feedback",
    "paradigm": "paradigm", "hand.drive": "drive", "auto_grip": "auto_grip",
}
#: Config paths that are never grouping dimensions.
NOT_FACTORS = frozenset({"seed"})
CONTROLLER_FACTOR = "controller.kind"
MASS_FACTOR, FRICTION_FACTOR = "object.mass_kg", "object.friction"


def flatten_config(config: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"object.mass_kg": 0.2, ...}``: every leaf of a nested scenario config.

    Lists are kept as tuples (hashable), so a list-valued field is one leaf.
    """
    out: dict[str, Any] = {}
    for key, value in config.items():
        path = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out.update(flatten_config(value, f"{path}."))
        else:
            out[path] = tuple(value) if isinstance(value, list) else value
    return out


def swept_factors(episodes: Sequence[Mapping[str, Any]]) -> list[str]:
    """Config paths whose value differs between the episodes (the seed excluded).

    The order: the paths of :data:`FACTOR_NAMES` in that order, then the
    others alphabetically. A path outside :data:`FACTOR_NAMES` whose value is a
    function of one of those (e.g. ``controller.horizon``, set for the MPC
    only) is a consequence of that factor, not a factor of its own, and is left
    out.
    """
    flat = [flatten_config(e.get("config") or {}) for e in episodes]
    paths = sorted(set().union(*flat)) if flat else []
    varying = [p for p in paths if p not in NOT_FACTORS
               and len({hashable_value(f.get(p)) for f in flat}) > 1]
    known = list(FACTOR_NAMES)
    ordered = sorted(varying, key=lambda p: (known.index(p) if p in known else len(known), p))

    def determined_by(path: str, other: str) -> bool:
        seen: dict[Any, Any] = {}
        for f in flat:
            value = hashable_value(f.get(path))
            if seen.setdefault(hashable_value(f.get(other)), value) != value:
                return False
        return True

    # a setting the schema fills in per controller (the MPC's horizon) varies with the
    # controller but is not swept: drop other paths that are a function of a named factor
    return [p for p in ordered if p in FACTOR_NAMES
            or not any(determined_by(p, q) for q in ordered if q in FACTOR_NAMES)]


def hashable_value(value: Any) -> Any:
    """A factor's value as a hashable key: a dict as its sorted JSON, anything else as is."""
    return json.dumps(value, sort_keys=True, default=str) if isinstance(value, dict) else value


def factor_name(path: str) -> str:
    """Short column name of a config path (``"mass (kg)"``), the path itself if unknown."""
    return FACTOR_NAMES.get(path, path)


def factor_value(row: Mapping[str, Any], path: str) -> Any:
    """The value of ``path`` for an episode row: the result field that ran, else the config."""
    field_name = _RESULT_FIELDS.get(path)
    if field_name is not None and row["result"].get(field_name) is not None:
        value = row["result"][field_name]
        return round(float(value), 9) if isinstance(value, float) else value
    value = flatten_config(row.get("config") or {}).get(path)
    return round(value, 9) if isinstance(value, float) else value


def level_key(row: Mapping[str, Any], path: str) -> Any:
    """The level of ``path`` for an episode row as :func:`levels` lists it (hashable)."""
    return hashable_value(factor_value(row, path))


def level_text(value: Any) -> str:
    """A factor level as table text: ``0.2``, ``yes`` / ``no``, ``default`` for None."""
    if value is None:
        return "default"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _level_key(value: Any) -> tuple[int, Any]:
    """Sort key putting None first, then numbers ascending, then text."""
    if value is None:
        return (0, 0.0)
    if isinstance(value, (bool, int, float)):
        return (1, float(value))
    return (2, str(value))


def levels(episodes: Sequence[Mapping[str, Any]], path: str) -> list[Any]:
    """Distinct values of a factor over the episodes: numbers ascending, names in store order."""
    values = list(dict.fromkeys(hashable_value(factor_value(e, path)) for e in episodes))
    if all(v is None or isinstance(v, (bool, int, float)) for v in values):
        return sorted(values, key=_level_key)
    return values


# ---------------------------------------------------------------- faceted heatmaps


def heatmap_axes(episodes: Sequence[Mapping[str, Any]],
                 factors: Sequence[str]) -> tuple[str, str]:
    """The two factors a heatmap plots: mass x friction when both vary, else the two
    swept factors with the most levels (numeric ones first), padded with mass and friction."""
    if MASS_FACTOR in factors and FRICTION_FACTOR in factors:
        return MASS_FACTOR, FRICTION_FACTOR

    def rank(p: str) -> tuple[int, int]:
        values = levels(episodes, p)
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool)
                      for v in values if v is not None)
        return (0 if numeric else 1, -len(values))

    chosen = sorted(factors, key=rank)[:2]
    for fallback in (MASS_FACTOR, FRICTION_FACTOR):
        if len(chosen) < 2 and fallback not in chosen:
            chosen.append(fallback)
    return chosen[0], chosen[1]


def facet_label(paths: Sequence[str], values: Sequence[Any]) -> str:
    """``"can, pid, oracle"``: the levels of a facet (names of yes/no factors spelled out)."""
    parts = []
    for path, value in zip(paths, values, strict=True):
        if isinstance(value, bool) or isinstance(value, (int, float)):
            parts.append(f"{factor_name(path).split(' (')[0]} {level_text(value)}")
        else:
            parts.append(level_text(value))
    return ", ".join(parts) or "all episodes"


def faceted_grids(episodes: Sequence[Mapping[str, Any]],
                  factors: Sequence[str]) -> tuple[str, str, list[OutcomeGrid]]:
    """Outcome grids over :func:`heatmap_axes`, one per combination of the other factors.

    Returns
    -------
    (row factor, column factor, grids)
        Each grid's ``key`` is the tuple of the facet's levels and ``label`` its
        :func:`facet_label`.
    """
    rows_f, cols_f = heatmap_axes(episodes, factors)
    facets = [p for p in factors if p not in (rows_f, cols_f)]
    grids = outcome_grids(
        episodes,
        key=lambda e: tuple(hashable_value(factor_value(e, p)) for p in facets),
        rows=lambda e: factor_value(e, rows_f), cols=lambda e: factor_value(e, cols_f),
        label=lambda k: facet_label(facets, k))
    order = [{v: i for i, v in enumerate(levels(episodes, p))} for p in facets]
    grids.sort(key=lambda g: tuple(o[v] for o, v in zip(order, g.key, strict=True)))
    return rows_f, cols_f, grids


def scenario_title(row: Mapping[str, Any], factors: Sequence[str]) -> str:
    """Short title of an episode: its levels of the swept factors (``"can, m=0.2 ..."``)."""
    if not factors:
        return f"{row['result']['controller']}, {condition_label(row['result'])}"
    return facet_label(factors, [factor_value(row, p) for p in factors])
