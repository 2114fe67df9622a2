"""Gathering the report's data: reproduction scores, episodes, outcome grids, loop designs.

Everything here is plain data (no figures, no HTML), so each aggregation can be
tested against an independent re-computation. Input enters at
:func:`read_reproduction_json`, :func:`split_rows` and :func:`check_traces`,
which raise :class:`ReportInputError` with one line saying what was expected
and what was found.
"""

from __future__ import annotations

import hashlib
import json
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from scenarios.stats import t_quantile, wilson_interval
from sim.errors import GriploopError

if TYPE_CHECKING:  # python-control is imported only to re-analyse loops (recheck)
    import control

    from controllers.analysis import LoopMargins

MODES = ("one_step", "free_run")

#: Result fields every episode row must carry for the report's sections.
EPISODE_FIELDS = (
    "controller", "estimator", "mode", "object_name", "object_mass_kg", "object_friction",
    "dropped", "crushed", "slip_events", "gain_margin_db", "phase_margin_deg", "ms",
    "stable", "loop_dt_s",
)  # fmt: skip
#: Traces an episode row must carry.
EPISODE_TRACES = ("t_s", "intent_n", "reference_n", "grip_force_n")
LOOP_TRACES = ("loop_A", "loop_B", "loop_C", "loop_D")


class ReportInputError(GriploopError, ValueError):
    """A results store row or a reproduction JSON file lacks what the report needs."""


# ---------------------------------------------------------------- reproduction


@dataclass(frozen=True)
class EstimatorScores:
    """R^2 / NRMSE of one estimator in one mode, over subjects.

    Attributes
    ----------
    per_subject : dict of int to (float, float)
        Subject number -> (R^2, NRMSE) on the validation part (mean over rows
        if a subject has several); subjects whose model diverged are absent.
    r2_mean, r2_sd, nrmse_mean, nrmse_sd : float
        Mean and SD (ddof = 1, as the paper's tables; 0 for one subject).
    n : int
        Number of scores behind the mean.
    train_ms : tuple of (float, float) or None
        Training time mean and SD, ms.
    step_us_median : float or None
        Median wall time of one streaming estimator update, microseconds.
    """

    per_subject: dict[int, tuple[float, float]]
    r2_mean: float
    r2_sd: float
    nrmse_mean: float
    nrmse_sd: float
    n: int
    train_ms: tuple[float, float] | None = None
    step_us_median: float | None = None


ScoreTable = dict[str, dict[str, EstimatorScores]]
"""mode -> estimator -> scores; modes are never mixed."""


def _mean_sd(values: Sequence[float]) -> tuple[float, float]:
    arr = np.asarray(values, dtype=float)
    sd = float(np.std(arr, ddof=1)) if arr.size > 1 else 0.0
    return float(np.mean(arr)), sd


def scores_from_rows(rows: Iterable[Mapping[str, Any]]) -> ScoreTable:
    """Aggregate ``ok`` reproduction rows of a results store per mode and estimator.

    Parameters
    ----------
    rows : iterable of dict
        Rows of :meth:`scenarios.store.ResultStore.rows` of kind ``reproduction``
        and status ``ok`` (``result`` holds ``estimator``, ``mode``,
        ``subject_id``, ``r2``, ``nrmse``, ``train_ms``, ``step_us``).

    Returns
    -------
    ScoreTable
    """
    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for row in rows:
        res = row["result"]
        groups.setdefault((res["mode"], res["estimator"]), []).append(res)
    table: ScoreTable = {}
    for (mode, name), results in sorted(groups.items(), key=lambda kv: _mode_key(kv[0])):
        by_subject: dict[int, list[tuple[float, float]]] = {}
        for res in results:
            by_subject.setdefault(int(res["subject_id"]), []).append((res["r2"], res["nrmse"]))
        per_subject = {
            s: (float(np.mean([v[0] for v in vals])), float(np.mean([v[1] for v in vals])))
            for s, vals in sorted(by_subject.items())
        }
        r2_mean, r2_sd = _mean_sd([r["r2"] for r in results])
        nrmse_mean, nrmse_sd = _mean_sd([r["nrmse"] for r in results])
        train = [r["train_ms"] for r in results if r.get("train_ms") is not None]
        steps = [r["step_us"] for r in results if r.get("step_us") is not None]
        table.setdefault(mode, {})[name] = EstimatorScores(
            per_subject, r2_mean, r2_sd, nrmse_mean, nrmse_sd, len(results),
            _mean_sd(train) if train else None,
            float(np.median(steps)) if steps else None,
        )
    return table


def _mode_key(key: tuple[str, str]) -> tuple[int, int, str]:
    """Sort key: modes in :data:`MODES` order, estimators in the schema's order."""
    from estimation.registry import estimator_names  # the schema's order, without pydantic

    mode, name = key
    names = estimator_names()
    rank = names.index(name) if name in names else len(names)
    return (MODES.index(mode) if mode in MODES else len(MODES), rank, name)


def load_reproduction_json(path: str | Path) -> ScoreTable:
    """Read the JSON of ``griploop reproduce --json`` into a :data:`ScoreTable`.

    :func:`read_reproduction_json`, then :func:`reproduction_scores`.

    Raises
    ------
    FileNotFoundError
        No such file.
    ReportInputError
        Not JSON, or not the reproduce contract.
    """
    return reproduction_scores(read_reproduction_json(path), path)


def read_reproduction_json(path: str | Path) -> dict[str, Any]:
    """The JSON object of ``griploop reproduce --json`` (read once; the report's sections
    take its scores, ``config`` and ``transfer`` from it).

    Raises
    ------
    FileNotFoundError
        No such file.
    ReportInputError
        Not JSON, or not an object with ``estimators``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: no such reproduction file (expected the JSON of griploop reproduce --json)"
        )
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ReportInputError(f"{path}: not JSON (expected griploop reproduce --json; {exc})") \
            from None
    if not isinstance(data, dict) or not isinstance(data.get("estimators"), dict):
        kind = type(data).__name__
        found = f"keys {sorted(data)}" if isinstance(data, dict) else f"a JSON {kind}"
        raise ReportInputError(
            f"{path}: expected an object with 'estimators' (griploop reproduce --json), "
            f"found {found}"
        )
    return data


def reproduction_scores(data: Mapping[str, Any], path: str | Path = "reproduction") -> ScoreTable:
    """The :data:`ScoreTable` of a reproduction JSON object (:func:`read_reproduction_json`).

    Raises
    ------
    ReportInputError
        An estimator entry lacks ``r2_mean``, ``r2_sd``, ``nrmse_mean``, ``nrmse_sd`` or
        ``per_subject`` (``path`` names the file in the message).
    """
    subject_ids = [s.get("subject_id") for s in data.get("subjects", [])]
    timing = data.get("timing", {})
    table: ScoreTable = {}
    for name, modes in data["estimators"].items():
        for mode, entry in modes.items():
            missing = [k for k in ("r2_mean", "r2_sd", "nrmse_mean", "nrmse_sd", "per_subject")
                       if k not in entry]
            if missing:
                raise ReportInputError(
                    f"{path}: estimators.{name}.{mode} lacks {missing} "
                    "(expected the griploop reproduce --json contract)"
                )
            per_subject = {}
            for i, score in enumerate(entry["per_subject"]):
                if score.get("r2") is None or score.get("nrmse") is None:
                    continue
                sid = subject_ids[i] if i < len(subject_ids) and subject_ids[i] else i + 1
                per_subject[int(sid)] = (float(score["r2"]), float(score["nrmse"]))
            t = timing.get(name, {})
            train = None
            if t.get("train_ms_mean") is not None:
                train = (float(t["train_ms_mean"]), float(t.get("train_ms_sd") or 0.0))
            if entry["r2_mean"] is None:
                continue  # every subject diverged in this mode: nothing to tabulate
            table.setdefault(mode, {})[name] = EstimatorScores(
                per_subject, float(entry["r2_mean"]), float(entry["r2_sd"] or 0.0),
                float(entry["nrmse_mean"]), float(entry["nrmse_sd"] or 0.0),
                int(entry.get("n_ok", len(per_subject))), train,
                t.get("step_us_median"),
            )
    return {m: dict(sorted(table[m].items(), key=lambda kv: _mode_key((m, kv[0]))))
            for m in sorted(table, key=lambda m: _mode_key((m, ""))[0])}


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


def episode_outcome(result: Mapping[str, Any]) -> str:
    """``held``, ``not_lifted``, ``dropped`` or ``crushed`` (rows before the outcome column:
    from the flags, an object never lifted counting as not lifted)."""
    if result.get("outcome"):
        return str(result["outcome"])
    if result.get("crushed"):
        return "crushed"
    if not result.get("lifted", True):
        return "not_lifted"
    return "dropped" if result.get("dropped") else "held"


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
    outcome = [episode_outcome(e["result"]) for e in episodes]
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


# ---------------------------------------------------------------- loop designs


#: Margin fields of an episode row: the episode runner computed them with
#: :func:`controllers.analysis.loop_margins` of the loop it ran at the held force.
STORED_MARGINS = ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "crossover_rad_s",
                  "n_crossovers", "ms", "stable", "bandwidth_rad_s")


@dataclass(frozen=True)
class LoopDesign:
    """One distinct analysed open loop of the episodes, with its margins.

    Attributes
    ----------
    label : str
        ``"D1 pid"``: number in order of appearance and controller.
    controller : str
        Controller family.
    matrices : tuple of ndarray
        The loop's ``(A, B, C, D)`` as stored with the first episode.
    dt_s : float
        Its sampling period, s.
    stored : dict
        The first episode's stored margins (:data:`STORED_MARGINS`, ``None`` where absent).
    hashes : list of str
        Store hashes of the episodes that share this loop.
    conditions : list of str
        ``"object m=0.2 kg mu=0.8"`` of those episodes (distinct, in order).
    margins : LoopMargins or None
        :func:`controllers.analysis.loop_margins` of the rebuilt loop, when re-analysed
        (``loop_designs(..., recheck=True)``).
    row_agrees : bool or None
        Whether the stored scalars (gain and phase margin, Ms, stable) match the
        re-analysed margins (rtol 1e-3); ``None`` when not re-analysed.
    """

    label: str
    controller: str
    matrices: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    dt_s: float
    stored: dict[str, Any]
    hashes: list[str]
    conditions: list[str]
    margins: LoopMargins | None = None
    row_agrees: bool | None = None


def loop_matrices(traces: Mapping[str, np.ndarray]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of the analysed loop in an episode's traces, each 2-D."""
    a, b, c, d = (np.atleast_2d(np.asarray(traces[n], dtype=float)) for n in LOOP_TRACES)
    return a, b, c, d


def rebuild_loop(traces: Mapping[str, np.ndarray], dt_s: float) -> control.StateSpace:
    """The analysed open loop ``control.ss(A, B, C, D, dt)`` from an episode's loop traces."""
    import control

    return control.ss(*loop_matrices(traces), float(dt_s))


def loop_fingerprint(traces: Mapping[str, np.ndarray], dt_s: float) -> str:
    """SHA-1 of the loop matrices (rounded to 12 significant digits) and the period."""
    digest = hashlib.sha1(repr(float(dt_s)).encode())
    for name in LOOP_TRACES:
        arr = np.atleast_2d(np.asarray(traces[name], dtype=float))
        digest.update(repr(arr.shape).encode())
        digest.update(np.char.mod("%.12g", arr).tobytes())
    return digest.hexdigest()


def _close(stored: Any, value: float) -> bool:
    if stored is None:
        return not np.isfinite(value)
    if isinstance(stored, bool):
        return stored == bool(value)
    return bool(np.isclose(float(stored), value, rtol=1e-3, atol=1e-9))


def condition_label(result: Mapping[str, Any]) -> str:
    """``"block m=0.2 kg mu=0.8"`` of an episode result."""
    return (f"{result['object_name']} m={float(result['object_mass_kg']):g} kg "
            f"mu={float(result['object_friction']):g}")


def loop_designs(episodes: Sequence[Mapping[str, Any]],
                 traces: Mapping[str, Mapping[str, np.ndarray]],
                 label: Any = None, *, recheck: bool = True) -> list[LoopDesign]:
    """Distinct analysed loops of the episodes, in order of first appearance.

    Parameters
    ----------
    episodes : sequence of dict
        ``ok`` episode rows.
    traces : dict of str to dict
        Store hash -> that row's traces (must hold :data:`LOOP_TRACES`).
    label : callable, optional
        Condition text of an episode row (default: :func:`condition_label` of
        its result).
    recheck : bool
        Re-analyse each loop with :func:`controllers.analysis.loop_margins` (imports
        python-control; about 0.1 s a loop) and compare with the stored margins; otherwise
        the designs carry the stored margins only.

    Episodes that never held a force in the air (``held_force_n`` is None: not
    lifted, or crushed on the way) and carry no loop traces are skipped.

    Raises
    ------
    ReportInputError
        A row that held a force lacks a loop trace, or has only some of them.
    """
    found: dict[str, dict[str, Any]] = {}
    for row in episodes:
        res, tr = row["result"], traces[row["hash"]]
        if not any(n in tr for n in LOOP_TRACES) and res.get("held_force_n") is None:
            continue  # never held a force in the air: the episode analysed no loop
        check_traces(row, tr, LOOP_TRACES)
        key = loop_fingerprint(tr, res["loop_dt_s"])
        entry = found.setdefault(key, {"row": row, "hashes": [], "conditions": []})
        entry["hashes"].append(row["hash"])
        text = label(row) if label is not None else condition_label(res)
        if text not in entry["conditions"]:
            entry["conditions"].append(text)
    designs = []
    for i, entry in enumerate(found.values(), start=1):
        row = entry["row"]
        res = row["result"]
        margins, agrees = None, None
        if recheck:
            from controllers.analysis import loop_margins

            margins = loop_margins(rebuild_loop(traces[row["hash"]], res["loop_dt_s"]))
            agrees = (_close(res["gain_margin_db"], margins.gain_margin_db)
                      and _close(res["phase_margin_deg"], margins.phase_margin_deg)
                      and _close(res["ms"], margins.ms)
                      and bool(res["stable"]) == margins.stable)
        designs.append(LoopDesign(
            f"D{i} {res['controller']}", str(res["controller"]),
            loop_matrices(traces[row["hash"]]), float(res["loop_dt_s"]),
            {k: res.get(k) for k in STORED_MARGINS}, entry["hashes"], entry["conditions"],
            margins, agrees))
    return designs


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


# ---------------------------------------------------------------- swept factors


#: Short names of the scenario config paths a sweep usually varies (others keep their path).
FACTOR_NAMES = {
    "object.name": "object", "object.mass_kg": "mass (kg)", "object.friction": "friction",
    "object.break_force_n": "break force (N)", "controller.kind": "controller",
    "estimator.name": "estimator", "estimator.mode": "mode",
    "controller.slip_reflex.enabled": "reflex", "subject.subject_id": "subject",
    "user.kind": "user", "user.feedback": "feedback",
}
#: Config path -> the result field holding the value that actually ran (e.g. the object's
#: mass when the config left it to the object library).
_RESULT_FIELDS = {
    "object.name": "object_name", "object.mass_kg": "object_mass_kg",
    "object.friction": "object_friction", "object.break_force_n": "object_break_force_n",
    "controller.kind": "controller", "estimator.name": "estimator", "estimator.mode": "mode",
    "subject.subject_id": "subject_id", "user.kind": "user", "user.feedback": "feedback",
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
               and len({_hashable(f.get(p)) for f in flat}) > 1]
    known = list(FACTOR_NAMES)
    ordered = sorted(varying, key=lambda p: (known.index(p) if p in known else len(known), p))

    def determined_by(path: str, other: str) -> bool:
        seen: dict[Any, Any] = {}
        for f in flat:
            value = _hashable(f.get(path))
            if seen.setdefault(_hashable(f.get(other)), value) != value:
                return False
        return True

    # a setting the schema fills in per controller (the MPC's horizon) varies with the
    # controller but is not swept: drop other paths that are a function of a named factor
    return [p for p in ordered if p in FACTOR_NAMES
            or not any(determined_by(p, q) for q in ordered if q in FACTOR_NAMES)]


def _hashable(value: Any) -> Any:
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
    return _hashable(factor_value(row, path))


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
    values = list(dict.fromkeys(_hashable(factor_value(e, path)) for e in episodes))
    if all(v is None or isinstance(v, (bool, int, float)) for v in values):
        return sorted(values, key=_level_key)
    return values


OUTCOMES = ("held", "not_lifted", "dropped", "crushed")


@dataclass(frozen=True)
class SummaryRow:
    """Outcomes and metrics of the episodes of one combination of the swept factors.

    Attributes
    ----------
    levels : tuple
        The combination, one value per factor (in :func:`outcome_summary`'s order).
    n : int
        Episodes.
    counts : dict of str to int
        Episodes per outcome of :data:`OUTCOMES`.
    intervals : dict of str to (float, float)
        95 % Wilson interval of each outcome's rate.
    tracking_rmse_n, contact_peak_ratio, slip_distance_m : float
        Means over the episodes that report the metric (``nan`` if none does).
    phase_margin_deg : float
        Mean phase margin at the held force (``nan`` if no episode held a force).
    worst_phase_margin_deg : float
        Minimum over episodes of the worst phase margin over visited forces.
    """

    levels: tuple
    n: int
    counts: dict[str, int]
    intervals: dict[str, tuple[float, float]]
    tracking_rmse_n: float
    contact_peak_ratio: float
    slip_distance_m: float
    phase_margin_deg: float
    worst_phase_margin_deg: float

    def rate(self, outcome: str) -> float:
        """Fraction of the episodes with ``outcome``."""
        return self.counts[outcome] / self.n


def _values(results: Sequence[Mapping[str, Any]], name: str) -> np.ndarray:
    out = [float(r[name]) for r in results if r.get(name) is not None]
    return np.array([v for v in out if np.isfinite(v)], dtype=float)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if values.size else float("nan")


def outcome_summary(episodes: Sequence[Mapping[str, Any]],
                    factors: Sequence[str]) -> list[SummaryRow]:
    """One :class:`SummaryRow` per combination of ``factors`` present in the episodes.

    Rows are sorted by the factors' levels (numbers ascending, names in store order).
    """
    groups: dict[tuple, list[Mapping[str, Any]]] = {}
    for e in episodes:
        key = tuple(_hashable(factor_value(e, p)) for p in factors)
        groups.setdefault(key, []).append(e["result"])
    order = [{v: i for i, v in enumerate(levels(episodes, p))} for p in factors]
    out = []
    for key in sorted(groups, key=lambda k: tuple(o[v] for o, v in zip(order, k, strict=True))):
        results = groups[key]
        outcomes = [episode_outcome(r) for r in results]
        counts = {o: outcomes.count(o) for o in OUTCOMES}
        worst = _values(results, "worst_phase_margin_deg")
        out.append(SummaryRow(
            key, len(results), counts,
            {o: wilson_interval(c, len(results)) for o, c in counts.items()},
            _mean(_values(results, "tracking_rmse_n")),
            _mean(_values(results, "contact_peak_ratio")),
            _mean(_values(results, "slip_distance_m")),
            _mean(_values(results, "phase_margin_deg")),
            float(worst.min()) if worst.size else float("nan"),
        ))
    return out


# ---------------------------------------------------------------- paired comparison


#: Paired metrics: name -> (label, function of an episode result giving a float or None).
PAIRED_METRICS: dict[str, tuple[str, Any]] = {
    "held": ("held rate", lambda r: float(episode_outcome(r) == "held")),
    "tracking_rmse_n": ("tracking RMSE (N)", lambda r: r.get("tracking_rmse_n")),
    "slip_distance_m": ("slip distance (m)", lambda r: r.get("slip_distance_m")),
    "contact_peak_ratio": ("contact peak ratio", lambda r: r.get("contact_peak_ratio")),
}


@dataclass(frozen=True)
class PairedDifference:
    """Mean difference ``other - baseline`` of one metric over paired scenarios.

    Two episodes are paired when every swept factor but the controller, and the
    seed, are equal. The interval is the 95 % t interval of the mean of the
    paired differences (``nan`` for fewer than two pairs).

    Attributes
    ----------
    baseline, other : str
        Controllers.
    metric : str
        Key of :data:`PAIRED_METRICS`.
    n_pairs : int
        Pairs where both episodes report the metric.
    baseline_mean, other_mean : float
        Means of the metric over those pairs.
    mean_diff, ci_low, ci_high : float
        Mean paired difference and its 95 % interval.
    """

    baseline: str
    other: str
    metric: str
    n_pairs: int
    baseline_mean: float
    other_mean: float
    mean_diff: float
    ci_low: float
    ci_high: float


def paired_differences(episodes: Sequence[Mapping[str, Any]], factors: Sequence[str],
                       controller: str = CONTROLLER_FACTOR,
                       metrics: Sequence[str] = tuple(PAIRED_METRICS)) -> list[PairedDifference]:
    """Paired differences between each pair of controllers on the same scenarios.

    Parameters
    ----------
    episodes : sequence of dict
        Episode rows (``result`` and ``config``).
    factors : sequence of str
        The swept factors (:func:`swept_factors`); must include ``controller``.
    controller : str
        The factor compared.
    metrics : sequence of str
        Keys of :data:`PAIRED_METRICS`.

    Returns
    -------
    list of PairedDifference
        For each controller pair ``(a, b)`` with ``a`` before ``b`` in store
        order, each metric: ``b - a``. Empty if the controller does not vary.
        When a scenario appears more than once per controller (repeated rows),
        the first row is used.
    """
    if controller not in factors:
        return []
    others = [p for p in factors if p != controller]
    by_controller: dict[Any, dict[tuple, Mapping[str, Any]]] = {}
    for e in episodes:
        key = (*(_hashable(factor_value(e, p)) for p in others),
               e["result"].get("seed", (e.get("config") or {}).get("seed")))
        by_controller.setdefault(factor_value(e, controller), {}).setdefault(key, e["result"])
    names = list(by_controller)
    out = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            shared = [k for k in by_controller[a] if k in by_controller[b]]
            for metric in metrics:
                get = PAIRED_METRICS[metric][1]
                pairs = [(get(by_controller[a][k]), get(by_controller[b][k])) for k in shared]
                pairs = [(float(x), float(y)) for x, y in pairs
                         if x is not None and y is not None
                         and np.isfinite(float(x)) and np.isfinite(float(y))]
                n = len(pairs)
                xa = np.array([p[0] for p in pairs])
                xb = np.array([p[1] for p in pairs])
                diff = xb - xa
                mean = _mean(diff)
                if n >= 2:
                    half = float(t_quantile(0.975, n - 1) * diff.std(ddof=1) / np.sqrt(n))
                    low, high = mean - half, mean + half
                else:
                    low = high = float("nan")
                out.append(PairedDifference(str(a), str(b), metric, n, _mean(xa), _mean(xb),
                                            mean, low, high))
    return out


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
        key=lambda e: tuple(_hashable(factor_value(e, p)) for p in facets),
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
