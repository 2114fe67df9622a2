"""Gathering the report's data: reproduction scores, episodes, outcome grids, loop designs.

Everything here is plain data (no figures, no HTML), so each aggregation can be
tested against an independent re-computation. Input enters at
:func:`~scenarios.report.reproduction_data.read_reproduction_json`, :func:`split_rows` and
:func:`check_traces`,
which raise :class:`ReportInputError` with one line saying what was expected
and what was found.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from scenarios.outcomes import row_outcome
from sim.errors import GriploopError

if TYPE_CHECKING:  # python-control is imported only to re-analyse loops (recheck)

    pass


#: Result fields every episode row must carry for the report's sections.
EPISODE_FIELDS = (
    "controller", "estimator", "mode", "object_name", "object_mass_kg", "object_friction",
    "dropped", "crushed", "slip_events", "gain_margin_db", "phase_margin_deg", "ms",
    "stable", "loop_dt_s",
)  # fmt: skip
#: Traces an episode row must carry.
EPISODE_TRACES = ("t_s", "intent_n", "reference_n", "grip_force_n")
#: Traces of a row's loop matrices (A, B, C, D) for the loop figures.
LOOP_TRACES = ("loop_A", "loop_B", "loop_C", "loop_D")


class ReportInputError(GriploopError, ValueError):
    """A results store row or a reproduction JSON file lacks what the report needs."""


# ---------------------------------------------------------------- store rows


@dataclass
class StoreRows:
    """The rows of a results store, split by what the report does with them.

    Attributes
    ----------
    reproduction : list of dict
        ``ok`` rows of kind ``reproduction``.
    episodes : list of dict
        ``ok`` rows of kind ``episode``.
    failed : list of dict
        Rows with status ``failed`` (any kind).
    other : list of dict
        ``ok`` rows of other kinds (e.g. ``calibration``), counted only.
    """

    reproduction: list[dict[str, Any]] = field(default_factory=list)
    episodes: list[dict[str, Any]] = field(default_factory=list)
    failed: list[dict[str, Any]] = field(default_factory=list)
    other: list[dict[str, Any]] = field(default_factory=list)


def split_rows(rows: Iterable[dict[str, Any]]) -> StoreRows:
    """Sort store rows into reproduction, episode, failed and other rows.

    Raises
    ------
    ReportInputError
        An ``ok`` episode row lacks a field of :data:`EPISODE_FIELDS`, or a
        reproduction row lacks ``estimator``, ``mode``, ``subject_id``, ``r2``
        or ``nrmse``.
    """
    out = StoreRows()
    for row in rows:
        if row["status"] == "failed":
            out.failed.append(row)
        elif row["kind"] == "episode":
            _require(row, EPISODE_FIELDS, "the episode row of scenarios.runners.episode")
            out.episodes.append(row)
        elif row["kind"] == "reproduction":
            _require(row, ("estimator", "mode", "subject_id", "r2", "nrmse"),
                     "the row of scenarios.runners.dispatch.run_reproduction_scenario")
            out.reproduction.append(row)
        else:
            out.other.append(row)
    return out


def _require(row: Mapping[str, Any], names: Sequence[str], what: str) -> None:
    missing = [n for n in names if n not in row["result"]]
    if missing:
        raise ReportInputError(
            f"{row['kind']} row {row['hash'][:12]}: missing result field(s) "
            f"{', '.join(missing)} (expected {what})"
        )


def check_traces(row: Mapping[str, Any], traces: Mapping[str, np.ndarray],
                 names: Sequence[str]) -> None:
    """Raise :class:`ReportInputError` if ``traces`` of ``row`` lack any of ``names``."""
    missing = [n for n in names if n not in traces]
    if missing:
        raise ReportInputError(
            f"episode row {row['hash'][:12]}: missing trace(s) {', '.join(missing)} "
            f"(found {', '.join(sorted(traces)) or 'none'})"
        )


def group_key(result: Mapping[str, Any]) -> tuple[str, str, str]:
    """``(controller, estimator, mode)`` of an episode result."""
    return (str(result["controller"]), str(result["estimator"]), str(result["mode"]))


def group_label(key: tuple[str, str, str]) -> str:
    """``"pid / ss_kf (free_run)"``."""
    controller, estimator, mode = key
    return f"{controller} / {estimator} ({mode})"


def representative_episodes(episodes: Sequence[dict[str, Any]],
                            limit: int = 12) -> list[dict[str, Any]]:
    """The first row (store order) of each controller / estimator / mode, at most ``limit``."""
    chosen: dict[tuple[str, str, str], dict[str, Any]] = {}
    for row in episodes:
        chosen.setdefault(group_key(row["result"]), row)
    return list(chosen.values())[:limit]


# ---------------------------------------------------------------- outcome grids


@dataclass(frozen=True)
class OutcomeGrid:
    """Not-lifted / drop / crush / slip outcomes of one facet over two factors (a heatmap).

    Attributes
    ----------
    key : tuple
        The facet (e.g. ``(controller, estimator, mode)`` or the levels of the
        factors the heatmap does not plot).
    row_levels, col_levels : list
        Levels of the plotted factors (by default mass in kg and friction),
        ascending, shared by every grid of a report.
    not_lifted_frac, dropped_frac, crushed_frac : ndarray, shape (n_rows, n_cols)
        Fraction of episodes (over seeds) whose outcome was not lifted / dropped
        / crushed (one category each: a crushed object counts as crushed only);
        ``nan`` where the cell has no episode.
    slip_events_mean : ndarray, shape (n_rows, n_cols)
        Mean number of slip events per episode; ``nan`` where empty.
    n_episodes : ndarray of int, shape (n_rows, n_cols)
        Episodes behind each cell.
    label : str
        Panel title.
    """

    key: tuple
    row_levels: list
    col_levels: list
    not_lifted_frac: np.ndarray
    dropped_frac: np.ndarray
    crushed_frac: np.ndarray
    slip_events_mean: np.ndarray
    n_episodes: np.ndarray
    label: str = ""

    @property
    def mass_kg(self) -> np.ndarray:
        """Row levels as an array (masses, kg, for the default axes)."""
        return np.asarray(self.row_levels)

    @property
    def friction(self) -> np.ndarray:
        """Column levels as an array (friction coefficients for the default axes)."""
        return np.asarray(self.col_levels)


def _sorted_levels(values: Sequence[Any]) -> list[Any]:
    distinct = list(dict.fromkeys(values))
    if all(v is None or isinstance(v, (bool, int, float)) for v in distinct):
        return sorted(distinct, key=lambda v: (v is not None, 0.0 if v is None else float(v)))
    return distinct


def outcome_grids(episodes: Sequence[Mapping[str, Any]], *, key: Any = None, rows: Any = None,
                  cols: Any = None, label: Any = None) -> list[OutcomeGrid]:
    """Per facet, outcomes averaged over seeds in each cell of a two-factor grid.

    By default a facet is a controller / estimator / mode (:func:`group_key`)
    and the grid is mass x friction, the values the episodes report
    (``object_mass_kg``, ``object_friction``) rounded to 1e-9 so that values
    equal up to round-off share a cell. ``key``, ``rows`` and ``cols`` are
    functions of an episode row giving its facet and its two levels; ``label``
    a function of the facet giving the panel title.
    """
    if not episodes:
        return []
    key = key or (lambda e: group_key(e["result"]))
    rows = rows or (lambda e: round(float(e["result"]["object_mass_kg"]), 9))
    cols = cols or (lambda e: round(float(e["result"]["object_friction"]), 9))
    label = label or group_label
    row_of = [rows(e) for e in episodes]
    col_of = [cols(e) for e in episodes]
    row_levels, col_levels = _sorted_levels(row_of), _sorted_levels(col_of)
    i_row = np.array([row_levels.index(v) for v in row_of])
    i_col = np.array([col_levels.index(v) for v in col_of])
    keys = [key(e) for e in episodes]
    outcome = [row_outcome(e["result"]) for e in episodes]
    not_lifted = np.array([o == "not_lifted" for o in outcome], dtype=float)
    dropped = np.array([o == "dropped" for o in outcome], dtype=float)
    crushed = np.array([o == "crushed" for o in outcome], dtype=float)
    slips = np.array([float(e["result"]["slip_events"]) for e in episodes])
    shape = (len(row_levels), len(col_levels))
    grids = []
    for facet in dict.fromkeys(keys):
        sel = np.array([k == facet for k in keys])
        cells = np.ravel_multi_index((i_row[sel], i_col[sel]), shape)
        count = np.bincount(cells, minlength=shape[0] * shape[1]).reshape(shape)

        def mean(values: np.ndarray, cells: np.ndarray = cells,
                 count: np.ndarray = count) -> np.ndarray:
            total = np.bincount(cells, weights=values, minlength=count.size).reshape(shape)
            with np.errstate(invalid="ignore", divide="ignore"):
                return np.where(count > 0, total / count, np.nan)

        grids.append(OutcomeGrid(facet, row_levels, col_levels, mean(not_lifted[sel]),
                                 mean(dropped[sel]), mean(crushed[sel]), mean(slips[sel]),
                                 count, label(facet)))
    return grids


# ---------------------------------------------------------------- misc


def most_common_object(episodes: Sequence[Mapping[str, Any]], default: str = "ball") -> str:
    """Most frequent ``object_name`` of the episodes (first in store order on ties)."""
    names = [str(e["result"]["object_name"]) for e in episodes]
    return Counter(names).most_common(1)[0][0] if names else default


def scenario_summary(row: Mapping[str, Any]) -> str:
    """One line naming a stored scenario: kind, subject, object, estimator, controller, seed."""
    cfg = row["config"]
    obj = cfg.get("object", {})
    parts = [row["kind"], f"subject {cfg.get('subject', {}).get('subject_id')}"]
    if row["kind"] == "episode":
        extra = "".join(f" {k}={obj[k]:g}" for k in ("mass_kg", "friction")
                        if obj.get(k) is not None)
        parts.append(f"{obj.get('name')}{extra}")
    est = cfg.get("estimator", {})
    parts.append(f"{est.get('name')} ({est.get('mode')})")
    if row["kind"] == "episode":
        parts.append(cfg.get("controller", {}).get("kind", "?"))
    parts.append(f"seed {cfg.get('seed')}")
    return ", ".join(str(p) for p in parts)
